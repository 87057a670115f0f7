!> Named real parameters of a node or element, as used (derived values
!> included): printed before a run and written to the output file.
module trainsim_param_list
   use trainsim_kinds, only: wp
   use trainsim_strings, only: string_t
   implicit none
   private

   public :: param_list_t, guarded_product, guarded_ratio, make_param_list, append_params

   !> Named real parameters of one element or node (derived values included).
   type :: param_list_t
      type(string_t), allocatable :: names(:)
      real(wp), allocatable :: values(:)
   end type param_list_t
contains

   !> The list of `names` (blank-padded) and `values`. (Not an array constructor of
   !> string_t structure constructors: gfortran 12 leaks their strings, and params() is
   !> called several times per model build, so a 10^5-run sweep grew without bound.)
   pure function make_param_list(names, values) result(p)
      character(len=*), intent(in) :: names(:)
      real(wp), intent(in) :: values(:)
      type(param_list_t) :: p
      integer :: i
      allocate (p%names(size(names)))
      do i = 1, size(names)
         p%names(i)%s = trim(names(i))
      end do
      p%values = values
   end function make_param_list

   !> Append `names` and `values` to p (as make_param_list).
   pure subroutine append_params(p, names, values)
      type(param_list_t), intent(inout) :: p
      character(len=*), intent(in) :: names(:)
      real(wp), intent(in) :: values(:)
      type(string_t), allocatable :: all(:)
      integer :: i, m
      m = size(p%names)
      allocate (all(m + size(names)))
      do i = 1, m
         call move_alloc(p%names(i)%s, all(i)%s)
      end do
      do i = 1, size(names)
         all(m + i)%s = trim(names(i))
      end do
      call move_alloc(all, p%names)
      p%values = [p%values, values]
   end subroutine append_params

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
