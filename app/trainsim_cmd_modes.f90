!> trainsim modes: natural frequencies and mode shapes of the linearised train, and its
!> RK4 step limit; `mode_name` also words the step advice of trainsim run.
module trainsim_cmd_modes
   use, intrinsic :: iso_fortran_env, only: output_unit
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_modes, only: modes_t, compute_modes, rk4_dt_limit
   use trainsim_element, only: lin_state_t, lin_contact_closed, lin_zone_single, lin_zone_stiffest
   use trainsim_report, only: print_modes
   use trainsim_preload, only: preload_info_t
   use trainsim_cli, only: fail, load
   implicit none
   private

   public :: do_modes, mode_name

contains

   subroutine do_modes(path, state)
      character(len=*), intent(in) :: path
      type(lin_state_t), intent(in) :: state
      type(model_t) :: model
      type(modes_t) :: modes
      type(error_t), allocatable :: err
      real(wp) :: dt_max, om, f, z
      character(len=:), allocatable :: what
      type(preload_info_t) :: preload
      call load(path, model, preload)
      call compute_modes(model, modes, err, state=state)
      if (allocated(err)) call fail(err)
      what = 'contacts as at the start'
      if (state%contact == lin_contact_closed) what = 'every clearance closed'
      select case (state%zone)
      case (lin_zone_single); what = what//', single-pair zones (helical: shortest contact lines)'
      case (lin_zone_stiffest); what = what//', two-pair zones (helical: longest contact lines)'
      case default; what = what//', mesh zones as at the start'
      end select
      if (model%run%preload) what = what//', about the static preload (trainsim_preload)'
      write (output_unit, '(a)') 'linearised with '//what
      if (model%run%preload) call print_preload(model, preload, output_unit)
      call print_modes(model, modes, output_unit)
      call rk4_dt_limit(model, state, dt_max, om, err, freq_hz=f, damping_ratio=z, dense=.true.)   ! the full analysis (D-64)
      if (allocated(err)) call fail(err)
      if (dt_max < huge(1.0_wp)) then
         write (output_unit, '(a)') 'RK4 stability limit (damped linear system'// &
            trim(merge(', impact damping up to the law''s largest', '                                        ', &
                       state%contact == lin_contact_closed))//'): dt < '//str(dt_max)//' s, set by '//mode_name(f, om, z)
      end if
   end subroutine do_modes

   !> The preloaded initial angles against the deck's, and the equilibrium residuals
   !> (trainsim modes --preload).
   subroutine print_preload(model, p, unit)
      type(model_t), intent(in) :: model
      type(preload_info_t), intent(in) :: p
      integer, intent(in) :: unit
      integer :: i
      if (p%free_train) then
         write (unit, '(a)') 'static preload (reference node '''//model%nodes(p%reference)%n%id// &
            ''', free train, acceleration '//str(p%acceleration, 6)//' rad/s^2):'
      else
         write (unit, '(a)') 'static preload (reference node '''//model%nodes(p%reference)%n%id//''', held or fixed):'
      end if
      write (unit, '(8x,a12,3a18)') 'node', 'deck angle', 'preload angle', 'difference'
      do i = 1, size(model%nodes)
         write (unit, '(8x,a12,3f18.9)') model%nodes(i)%n%id, p%theta_deck(i), model%nodes(i)%n%theta0, &
            p%theta_deck(i) - model%nodes(i)%n%theta0
      end do
      write (unit, '(a)') 'largest net-torque residual: '//str(p%residual, 3)//' at the preload, '// &
         str(p%deck_residual, 5)//' at the deck''s angles (torque scale '//str(p%torque_scale, 5)//'; '// &
         str(p%iterations)//' Newton iterations, '//str(p%passes)//' mode passes)'
   end subroutine print_preload

   !> "the mode at 5690.8 Hz (damping ratio 0.00)" for the eigenvalue that limits the RK4 step.
   function mode_name(f, om, z) result(s)
      real(wp), intent(in) :: f, om, z
      character(len=:), allocatable :: s
      character(len=40) :: a, b
      if (f > 0.0_wp) then
         a = str(f, 5)                             ! f0.1 would not fit above 1e38 Hz
         if (f < 1.0e9_wp) write (a, '(f0.1)') f
         write (b, '(f4.2)') z
         s = 'the mode at '//trim(a)//' Hz, damping ratio '//trim(b)
      else
         s = 'an overdamped mode, |lambda| = '//str(om, 5)//' 1/s'
      end if
   end function mode_name
end module trainsim_cmd_modes
