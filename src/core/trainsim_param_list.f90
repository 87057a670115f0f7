!> Named real parameters of a node or element, as used (derived values
!> included): printed before a run and written to the output file.
module trainsim_param_list
   use trainsim_kinds, only: wp
   use trainsim_strings, only: string_t
   implicit none
   private

   public :: param_list_t

   !> Named real parameters of one element or node (derived values included).
   type :: param_list_t
      type(string_t), allocatable :: names(:)
      real(wp), allocatable :: values(:)
   end type param_list_t
end module trainsim_param_list
