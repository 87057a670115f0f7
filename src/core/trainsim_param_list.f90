!> Named real parameters of a node or element, as used (derived values
!> included): printed before a run and written to the output file.
module trainsim_param_list
   use trainsim_kinds, only: wp
   use trainsim_strings, only: string_t
   implicit none
   private

   public :: param_list_t, guarded_product, guarded_ratio, add_choice

   !> Named real parameters of one element or node (derived values included).
   !> A choice key (a word in the deck) is stored by its code in `values` (the file's
   !> real attribute) and, for the print-out, by its word in `words` (same index; an
   !> empty word or unallocated `words`: print the number).
   type :: param_list_t
      type(string_t), allocatable :: names(:)
      real(wp), allocatable :: values(:)
      type(string_t), allocatable :: words(:)
   end type param_list_t
contains

   !> Append the choice key `name`, stored as `code`, printed as `word`.
   pure subroutine add_choice(p, name, code, word)
      type(param_list_t), intent(inout) :: p
      character(len=*), intent(in) :: name, word
      real(wp), intent(in) :: code
      integer :: j
      if (.not. allocated(p%words)) then
         allocate (p%words(size(p%names)))
         do j = 1, size(p%words)
            p%words(j)%s = ''
         end do
      end if
      p%names = [p%names, string_t(name)]
      p%values = [p%values, code]
      p%words = [p%words, string_t(word)]
   end subroutine add_choice

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
