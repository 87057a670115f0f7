!> The magnitude range of deck quantities that enter the equations of motion (D-28).
!>
!> Every real parameter of a node or element (as used, derived ones included), every
!> value and time of a load, and every initial condition is 0 or has a magnitude in
!> [param_min, param_max]. With states held below the blow-up limit (1e50), the
!> torques, derivatives, energies and powers of such a train stay far below the
!> overflow threshold (products of a few parameters and two states: < 1e260), so a
!> runaway is reported as one instead of trapping or overflowing on the way.
!> No physical drive train comes near the bounds, in any unit system.
module trainsim_limits
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t
   implicit none
   private

   public :: param_min, param_max, in_range, check_magnitude, check_params

   !> Smallest nonzero and largest magnitude of a parameter.
   real(wp), parameter :: param_min = 1.0e-20_wp, param_max = 1.0e20_wp

contains

   !> True when x is 0 or param_min <= |x| <= param_max (false for NaN and Inf).
   elemental logical function in_range(x) result(ok)
      real(wp), intent(in) :: x
      ok = x == 0.0_wp .or. (abs(x) >= param_min .and. abs(x) <= param_max)
   end function in_range

   !> Error naming the group, key and value unless value is in range.
   subroutine check_magnitude(grp, key, value, err)
      type(deck_group_t), intent(in) :: grp
      character(len=*), intent(in) :: key
      real(wp), intent(in) :: value
      type(error_t), allocatable, intent(inout) :: err
      if (allocated(err)) return
      if (in_range(value)) return
      call fatal_error(err, grp%where(key)//': error: '//key//' = '//str(value)//' is out of range: '// &
                       'trainsim accepts 0 or a magnitude in ['//str(param_min)//', '//str(param_max)//']', err_input)
   end subroutine check_magnitude

   !> check_magnitude on every parameter of a node or element as used.
   subroutine check_params(grp, p, err)
      type(deck_group_t), intent(in) :: grp
      type(param_list_t), intent(in) :: p
      type(error_t), allocatable, intent(inout) :: err
      integer :: i
      if (.not. allocated(p%values)) return
      do i = 1, size(p%values)
         call check_magnitude(grp, p%names(i)%s, p%values(i), err)
         if (allocated(err)) return
      end do
   end subroutine check_params
end module trainsim_limits
