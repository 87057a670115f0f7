!> Named real parameters of a node or element, as used (derived values
!> included): printed before a run and written to the output file.
module trainsim_param_list
   use trainsim_kinds, only: wp
   use trainsim_strings, only: string_t
   implicit none
   private

   public :: param_list_t, guarded_product, guarded_ratio

   !> Named real parameters of one element or node (derived values included).
   type :: param_list_t
      type(string_t), allocatable :: names(:)
      real(wp), allocatable :: values(:)
   end type param_list_t
contains

   !> a*b for a derived parameter, or huge when that would overflow: a deck value
   !> beyond the accepted range (D-28) must reach the range check that names its
   !> key, not trap in the arithmetic of params() first.
   pure real(wp) function guarded_product(a, b) result(c)
      real(wp), intent(in) :: a, b
      c = huge(1.0_wp)
      if (abs(a) <= 1.0e150_wp .and. abs(b) <= 1.0e150_wp) c = a*b
   end function guarded_product

   !> a/b for a derived parameter, or huge when that would overflow (see guarded_product).
   pure real(wp) function guarded_ratio(a, b) result(c)
      real(wp), intent(in) :: a, b
      c = huge(1.0_wp)
      if (abs(a) <= 1.0e150_wp .and. abs(b) >= 1.0e-150_wp) c = a/b
   end function guarded_ratio
end module trainsim_param_list
