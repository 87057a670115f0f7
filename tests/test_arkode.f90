!> The ARKODE ERKStep integrators ('arkode-dp': Dormand-Prince 5(4),
!> 'arkode-verner': Verner 6(5)), which run in the same SUNDIALS driver as
!> CVODE: against the event-located RK4 at dt/4 of the deck, tolerance
!> convergence, counters, and failures reported as errors with advice.
program test_arkode
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, err_numeric, err_input
   use trainsim_deck, only: deck_t, parse_deck
   use trainsim_builder, only: build_model, integrator_names
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_simulate, only: simulate
   use trainsim_sink, only: null_sink_t
   use trainsim_strings, only: str
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: zero_crossings, load_model, load_model_text, run_model, nl
   implicit none

   !> Tight tolerances of the comparisons with RK4: the absolute tolerances
   !> sit far below rtol times the smallest state that matters (the driven
   !> gear of Table 5.3 turns by microradians during the impact).
   real(wp), parameter :: tight_rtol = 1.0e-11_wp
   real(wp), parameter :: tight_atol_angle = 1.0e-4_wp*tight_rtol, tight_atol_speed = 1.0e-2_wp*tight_rtol
   character(len=*), parameter :: methods(2) = ['arkode-dp    ', 'arkode-verner']
   integer :: im
   !> The RK4 (dt/4) reference runs, made once and shared by both methods.
   type(run_result_t) :: rk_51, rk_53, rk_c1
   logical :: have_rk(3) = .false.

   call suite_begin('ARKODE ERKStep integrators')
   call test_names_are_valid_integrators()
   do im = 1, 2
      call test_table5_1_frequency_matches_rk4(trim(methods(im)))
      call test_table5_3_impact_matches_rk4(trim(methods(im)))
      call test_case1_events_match_rk4(trim(methods(im)))
      call test_table5_3_contact_duration_converges_with_rtol(trim(methods(im)))
      call test_stiff_train_runs_out_of_steps_with_advice(trim(methods(im)))
      call test_step_load_breakpoint_keeps_momentum_exact(trim(methods(im)))
   end do
   call test_counters_against_cvode_adams()
   call test_impossible_tolerance_is_a_numeric_error_with_advice()
   call suite_end()

contains

   !> Load `path` with the given integrator and the tight tolerances.
   subroutine load_tight(path, integrator, m)
      character(len=*), intent(in) :: path, integrator
      type(model_t), intent(out) :: m
      call load_model(path, m)
      m%run%integrator = integrator
      m%run%rtol = tight_rtol
      m%run%atol_angle = tight_atol_angle
      m%run%atol_speed = tight_atol_speed
   end subroutine load_tight

   !> "steps 123, RHS 456, ..." of a run.
   function counters(r) result(s)
      type(run_result_t), intent(in) :: r
      character(len=:), allocatable :: s
      s = 'steps '//str(real(r%stats%steps, wp))//', RHS '//str(real(r%stats%rhs_evals, wp))//', roots '// &
          str(real(r%stats%root_returns, wp))//', error-test fails '//str(real(r%stats%error_test_fails, wp))
   end function counters

   subroutine test_names_are_valid_integrators()
      type(deck_t) :: deck
      type(model_t) :: m
      type(error_t), allocatable :: err
      integer :: i, found
      call test_begin('names_are_valid_integrators')
      found = 0
      associate (names => integrator_names())
         do i = 1, size(names)
            if (names(i)%s == 'arkode-dp' .or. names(i)%s == 'arkode-verner') found = found + 1
         end do
      end associate
      call check('arkode-dp and arkode-verner are in integrator_names()', found == 2)
      call parse_deck("&run t_end = 0.01, dt = 1.0e-4, integrator = 'ARKODE-Verner' /"//nl// &
                      "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl// &
                      "&node id = 'b', type = 'inertia', inertia = 1.0 /"//nl// &
                      "&element id = 's', type = 'shaft', stiffness = 1.0e3 /"//nl, 'inline.nml', deck, err)
      if (.not. allocated(err)) call build_model(deck, m, err)
      call check('a deck with arkode-verner (any case) builds', .not. allocated(err))
      if (.not. allocated(err)) call check('integrator stored in lower case', m%run%integrator == 'arkode-verner')
      call parse_deck("&run t_end = 0.01, dt = 1.0e-4, integrator = 'arkode-rk4' /"//nl// &
                      "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl, 'inline.nml', deck, err)
      if (.not. allocated(err)) call build_model(deck, m, err)
      call check('an unknown integrator is an input error', allocated(err))
      if (allocated(err)) then
         call check('code is err_input', err%code == err_input)
         call check('the message lists arkode-dp', index(err%message, 'arkode-dp') > 0)
      end if
   end subroutine test_names_are_valid_integrators

   !> Frequency of disk 1 from its first two zero crossings.
   real(wp) function disk1_frequency(r) result(f)
      type(run_result_t), intent(in) :: r
      real(wp) :: tz(8)
      integer :: n
      call zero_crossings(r%series_t, r%series_theta(1, :), tz, n)
      f = 0.0_wp
      if (n >= 2) f = 1.0_wp/(2.0_wp*(tz(2) - tz(1)))
   end function disk1_frequency

   subroutine test_table5_1_frequency_matches_rk4(method)
      character(len=*), intent(in) :: method
      type(model_t) :: m
      type(run_result_t) :: rk, ark
      real(wp) :: f_rk, f_ark, dt
      call test_begin('table5_1_frequency_matches_rk4 ['//method//']')
      ! RK4 at dt/4 of the deck; the ERK run samples the same grid
      call load_model('verification/table5_1/table5_1.nml', m)
      dt = m%run%dt/4.0_wp
      if (.not. have_rk(1)) then
         m%run%dt = dt
         m%run%output_interval = 0.0_wp
         call run_model(m, rk_51)
         have_rk(1) = .true.
      end if
      rk = rk_51
      call load_tight('verification/table5_1/table5_1.nml', method, m)
      m%run%output_interval = dt
      call run_model(m, ark)
      f_rk = disk1_frequency(rk)
      f_ark = disk1_frequency(ark)
      call check('frequency of disk 1 (Hz) vs RK4 at dt/4, 0.05 %', f_ark, f_rk, rel_tol=5.0e-4_wp)
      write (*, '(a)') '    relative frequency difference to RK4: '//str(abs(f_ark/f_rk - 1.0_wp))
      call check('frequency of disk 1 (Hz) vs 19.68, 0.05 %', f_ark, 19.68_wp, rel_tol=5.0e-4_wp)
      call check('same output grid as RK4 (samples)', real(size(ark%series_t), wp), real(size(rk%series_t), wp), &
                 abs_tol=0.0_wp)
      if (size(ark%series_t) == size(rk%series_t)) &
         call check('max |theta - theta_rk4| over the run (rad), amplitude 0.1', &
                    maxval(abs(ark%series_theta - rk%series_theta)), 0.0_wp, abs_tol=1.0e-8_wp)
      call check('run ends exactly at t_end', ark%t_final, m%run%t_end, abs_tol=0.0_wp)
      call check('no Jacobian, no nonlinear solver', ark%stats%jac_evals == 0 .and. ark%stats%conv_fails == 0)
      write (*, '(a)') '    counters '//method//': '//counters(ark)
   end subroutine test_table5_1_frequency_matches_rk4

   !> Same events as RK4, with times and approach velocities to rel_tol.
   subroutine compare_events(rk, ark, rel_tol)
      type(run_result_t), intent(in) :: rk, ark
      real(wp), intent(in) :: rel_tol
      integer :: i
      real(wp) :: et, ev
      character(len=:), allocatable :: lab
      call check('same number of events as RK4', real(size(ark%events), wp), real(size(rk%events), wp), &
                 abs_tol=0.0_wp)
      et = 0.0_wp; ev = 0.0_wp
      do i = 1, min(size(rk%events), size(ark%events))
         lab = 'event '//str(i)
         call check(lab//': kind and element', ark%events(i)%kind == rk%events(i)%kind .and. &
                    ark%events(i)%element == rk%events(i)%element)
         call check(lab//' time (s)', ark%events(i)%t, rk%events(i)%t, rel_tol=rel_tol)
         call check(lab//' approach velocity', ark%events(i)%approach_velocity, rk%events(i)%approach_velocity, &
                    rel_tol=rel_tol)
         et = max(et, abs(ark%events(i)%t - rk%events(i)%t)/abs(rk%events(i)%t))
         if (rk%events(i)%approach_velocity /= 0.0_wp) &
            ev = max(ev, abs(ark%events(i)%approach_velocity/rk%events(i)%approach_velocity - 1.0_wp))
      end do
      write (*, '(a)') '    largest relative difference to RK4: event times '//str(et)//', approach velocities '// &
         str(ev)
      call check('one root return per event', real(ark%stats%root_returns, wp), real(size(ark%events), wp), &
                 abs_tol=0.0_wp)
   end subroutine compare_events

   subroutine test_table5_3_impact_matches_rk4(method)
      character(len=*), intent(in) :: method
      type(model_t) :: m
      type(run_result_t) :: rk, ark
      call test_begin('table5_3_impact_matches_rk4 ['//method//']')
      if (.not. have_rk(2)) then
         call load_model('verification/table5_3/table5_3.nml', m)
         m%run%dt = m%run%dt/4.0_wp
         call run_model(m, rk_53)
         have_rk(2) = .true.
      end if
      rk = rk_53
      call load_tight('verification/table5_3/table5_3.nml', method, m)
      call run_model(m, ark)
      call check('at least two events (impact, separation)', size(ark%events) >= 2)
      call compare_events(rk, ark, 1.0e-6_wp)
      if (size(ark%events) >= 1 .and. size(rk%events) >= 1) &
         call check('first contact duration (s)', ark%events(1)%duration, rk%events(1)%duration, rel_tol=1.0e-6_wp)
      call check('no Jacobian, no nonlinear solver', ark%stats%jac_evals == 0 .and. ark%stats%conv_fails == 0)
      call check('RHS evaluations > 5 per step (explicit RK stages)', ark%stats%rhs_evals > 5*ark%stats%steps)
      write (*, '(a)') '    counters '//method//': '//counters(ark)//'; RK4 dt/4: steps '// &
         str(real(rk%stats%steps, wp))//', RHS '//str(real(rk%stats%rhs_evals, wp))
   end subroutine test_table5_3_impact_matches_rk4

   subroutine test_case1_events_match_rk4(method)
      character(len=*), intent(in) :: method
      type(model_t) :: m
      type(run_result_t) :: rk, ark
      real(wp), parameter :: t_end = 0.01_wp
      call test_begin('case1_events_match_rk4 ['//method//']')
      if (.not. have_rk(3)) then
         call load_model('verification/chapter3/case1.nml', m)
         m%run%dt = m%run%dt/4.0_wp
         m%run%t_end = t_end
         call run_model(m, rk_c1)
         have_rk(3) = .true.
      end if
      rk = rk_c1
      call load_tight('verification/chapter3/case1.nml', method, m)
      m%run%t_end = t_end
      call run_model(m, ark)
      call check('more than 20 events in 10 ms', size(ark%events) > 20)
      call compare_events(rk, ark, 1.0e-6_wp)
      write (*, '(a)') '    counters '//method//' (10 ms): '//counters(ark)//'; RK4 dt/4: steps '// &
         str(real(rk%stats%steps, wp))//', RHS '//str(real(rk%stats%rhs_evals, wp))
   end subroutine test_case1_events_match_rk4

   !> First-contact duration of Table 5.3 at rtol (absolute tolerances that
   !> leave the control relative, as in the comparisons).
   real(wp) function duration_at(method, rtol) result(d)
      character(len=*), intent(in) :: method
      real(wp), intent(in) :: rtol
      type(model_t) :: m
      type(run_result_t) :: r
      call load_model('verification/table5_3/table5_3.nml', m)
      m%run%integrator = method
      m%run%rtol = rtol
      m%run%atol_angle = 1.0e-4_wp*rtol
      m%run%atol_speed = 1.0e-2_wp*rtol
      call run_model(m, r)
      d = -1.0_wp
      if (size(r%events) >= 1) d = r%events(1)%duration
   end function duration_at

   subroutine test_table5_3_contact_duration_converges_with_rtol(method)
      character(len=*), intent(in) :: method
      real(wp), parameter :: rtols(4) = [1.0e-5_wp, 1.0e-6_wp, 1.0e-7_wp, 1.0e-8_wp]
      real(wp) :: d(4), e(4), dref
      integer :: i
      call test_begin('table5_3_contact_duration_converges_with_rtol ['//method//']')
      dref = duration_at(method, 1.0e-12_wp)
      do i = 1, 4
         d(i) = duration_at(method, rtols(i))
         e(i) = abs(d(i) - dref)/dref
         call check('duration error at rtol = '//str(rtols(i))//' within 100 rtol (relative)', d(i), dref, &
                    rel_tol=100.0_wp*rtols(i))
      end do
      write (*, '(a)') '    relative duration errors at rtol 1e-5 .. 1e-8: '//str(e(1))//', '//str(e(2))//', '// &
         str(e(3))//', '//str(e(4))
      ! the error falls with rtol until it is below rtol itself: an error far
      ! below its bound (arkode-verner: 1.5e-8 at rtol 1e-6) may be a lucky
      ! cancellation that the next rtol does not repeat (1.9e-8 at 1e-7)
      do i = 1, 3
         call check('error at rtol '//str(rtols(i + 1))//' ('//str(e(i + 1))//') below the error at rtol '// &
                    str(rtols(i))//' ('//str(e(i))//') or below rtol', e(i + 1) < e(i) .or. e(i + 1) < rtols(i + 1))
      end do
   end subroutine test_table5_3_contact_duration_converges_with_rtol

   !> A shaft with huge damping on a light disk (eigenvalue -c/J = -2e7 1/s):
   !> an explicit RK method must keep h below about 3/2e7 s for stability, and
   !> the 0.5 s output interval needs far more than the allowed internal steps.
   subroutine test_stiff_train_runs_out_of_steps_with_advice(method)
      character(len=*), intent(in) :: method
      type(model_t) :: m
      type(run_result_t) :: r
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      call test_begin('stiff_train_runs_out_of_steps_with_advice ['//method//']')
      call load_model_text("&run t_end = 1.0, dt = 1.0e-3, output_interval = 0.5, integrator = '"//method//"' /"//nl// &
                           "&node id = 'ground', type = 'fixed' /"//nl// &
                           "&node id = 'disk', type = 'inertia', inertia = 1.0e-3 /"//nl// &
                           "&element id = 's', type = 'shaft', stiffness = 1.0, damping = 2.0e4 /"//nl// &
                           "&initial node = 'disk', speed = 1.0 /"//nl, m)
      call simulate(m, none, r, err)
      call check('an error is returned', allocated(err))
      if (.not. allocated(err)) return
      write (*, '(a)') '    message: '//err%message
      call check('code is err_numeric', err%code == err_numeric)
      call check('message names the integrator', index(err%message, "'"//method//"'") > 0)
      call check('message names the time reached', index(err%message, 'failed at t = ') > 0)
      call check('message says why (internal steps)', index(err%message, 'internal steps') > 0)
      call check('message names a state by node id', index(err%message, "of node 'disk'") > 0)
      call check('message says the train may be stiff', index(err%message, 'stiff for an explicit') > 0)
      call check('message advises cvode-bdf', index(err%message, "use integrator = 'cvode-bdf'") > 0)
      call check('message gives the step budget per output interval', index(err%message, 'more than 1000000 internal steps') > 0)
      call check('no bare return code', index(err%message, 'flag') == 0)
   end subroutine test_stiff_train_runs_out_of_steps_with_advice

   !> A step torque at t = 0.0123 s (off every grid) on a free two-inertia
   !> train: the angular momentum J1 w1 + J2 w2 must be T (t - t_step). Every
   !> Runge-Kutta method keeps linear invariants, so with the step time a stop
   !> time followed by a re-initialisation (no step straddles the jump) the
   !> momentum is exact to rounding.
   subroutine test_step_load_breakpoint_keeps_momentum_exact(method)
      character(len=*), intent(in) :: method
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: l_end, l_exact
      call test_begin('step_load_breakpoint_keeps_momentum_exact ['//method//']')
      call load_model_text("&run t_end = 0.05, dt = 1.0e-3, integrator = '"//method//"', rtol = 1e-6 /"//nl// &
                           "&node id = 'a', type = 'inertia', inertia = 2.0 /"//nl// &
                           "&node id = 'b', type = 'inertia', inertia = 3.0 /"//nl// &
                           "&element id = 's', type = 'shaft', stiffness = 1.0e4 /"//nl// &
                           "&load node = 'a', kind = 'step', value1 = 5.0, t_step = 0.0123 /"//nl, m)
      call run_model(m, r)
      l_end = 2.0_wp*r%y_final(2) + 3.0_wp*r%y_final(4)
      l_exact = 5.0_wp*(0.05_wp - 0.0123_wp)
      call check('angular momentum at t_end vs 5 (0.05 - 0.0123), to rounding', l_end, l_exact, rel_tol=1.0e-13_wp)
      call check('at most 3 error-test failures (the jump is not stepped over)', r%stats%error_test_fails <= 3)
      call check('energy balance closes (residual / scale < 1e-5)', r%energy_residual_max < 1.0e-5_wp*r%energy_scale)
   end subroutine test_step_load_breakpoint_keeps_momentum_exact

   !> Table 5.3 and the first 10 ms of case 1 at the tight tolerances with
   !> both ERK integrators and cvode-adams: the same events, and the counters
   !> side by side.
   subroutine test_counters_against_cvode_adams()
      character(len=*), parameter :: all(3) = ['arkode-dp    ', 'arkode-verner', 'cvode-adams  ']
      character(len=*), parameter :: decks(2) = ['verification/table5_3/table5_3.nml', &
                                                 'verification/chapter3/case1.nml   ']
      type(model_t) :: m
      type(run_result_t) :: r(3)
      integer :: i, j
      call test_begin('counters_against_cvode_adams')
      do j = 1, 2
         do i = 1, 3
            call load_tight(trim(decks(j)), trim(all(i)), m)
            if (j == 2) m%run%t_end = 0.01_wp
            call run_model(m, r(i))
            write (*, '(a)') '    '//trim(decks(j))//' '//trim(all(i))//': '//counters(r(i))
         end do
         do i = 1, 2
            call check(trim(all(i))//': as many events as cvode-adams', size(r(i)%events) == size(r(3)%events))
            call check(trim(all(i))//': as many root returns as cvode-adams', &
                       r(i)%stats%root_returns == r(3)%stats%root_returns)
            call check(trim(all(i))//': no Jacobian, no nonlinear convergence failure', &
                       r(i)%stats%jac_evals == 0 .and. r(i)%stats%conv_fails == 0)
            call check(trim(all(i))//': rejected steps = error-test failures', &
                       r(i)%stats%rejected == r(i)%stats%error_test_fails)
         end do
      end do
   end subroutine test_counters_against_cvode_adams

   subroutine test_impossible_tolerance_is_a_numeric_error_with_advice()
      type(model_t) :: m
      type(run_result_t) :: r
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      call test_begin('impossible_tolerance_is_a_numeric_error_with_advice')
      call load_model('verification/table5_3/table5_3.nml', m)
      m%run%integrator = 'arkode-dp'
      m%run%rtol = 1.0e-20_wp
      m%run%atol_angle = 1.0e-30_wp; m%run%atol_speed = 1.0e-30_wp
      call simulate(m, none, r, err)
      call check('an error is returned', allocated(err))
      if (.not. allocated(err)) return
      write (*, '(a)') '    message: '//err%message
      call check('code is err_numeric', err%code == err_numeric)
      call check('message names the integrator', index(err%message, "'arkode-dp'") > 0)
      call check('message names the time', index(err%message, 'failed at t = ') > 0)
      call check('message names a state by node id', index(err%message, "of node '") > 0)
      call check('message gives advice on the tolerances', index(err%message, 'Advice: loosen the tolerances') > 0)
      call check('no bare return code', index(err%message, 'flag') == 0)
   end subroutine test_impossible_tolerance_is_a_numeric_error_with_advice
end program test_arkode
