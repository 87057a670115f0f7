!> Issue 4: the CVODE integrators ('cvode-bdf', 'cvode-adams') against the
!> event-located RK4 at a fine step, tolerance convergence, settings derived
!> from the model, counters, and failures reported as errors.
program test_cvode
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t, err_numeric
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_simulate, only: simulate
   use trainsim_sink, only: null_sink_t, ev_contact_front, ev_contact_rear
   use trainsim_sundials, only: cvode_max_step, cvode_abstol
   use trainsim_strings, only: str
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: zero_crossings, load_model, load_model_text, run_model, nl
   implicit none

   !> The tight tolerances of the comparisons with RK4.
   real(wp), parameter :: tight_rtol = 1.0e-10_wp, tight_atol_angle = 1.0e-14_wp, tight_atol_speed = 1.0e-12_wp
   character(len=*), parameter :: methods(2) = ['cvode-bdf  ', 'cvode-adams']
   integer :: im

   call suite_begin('CVODE integrators (issue 4)')
   do im = 1, 2
      call test_table5_1_frequency_matches_19_68_hz_and_rk4(trim(methods(im)))
      call test_table5_3_impact_matches_rk4(trim(methods(im)))
      call test_case1_first_ten_events_match_rk4(trim(methods(im)))
      call test_table5_3_contact_duration_converges_with_rtol(trim(methods(im)))
      call test_step_load_breakpoint_keeps_momentum_exact(trim(methods(im)))
   end do
   call test_default_max_step_is_a_tenth_of_the_contact_period()
   call test_abstol_follows_the_state_kind()
   call test_counters_accumulate_over_reinits()
   call test_impossible_tolerance_is_a_numeric_error_with_advice()
   call test_stiff_train_with_adams_runs_out_of_steps_with_advice()
   call suite_end()

contains

   !> Load `path` with the given integrator and tight tolerances.
   subroutine load_tight(path, integrator, m)
      character(len=*), intent(in) :: path, integrator
      type(model_t), intent(out) :: m
      call load_model(path, m)
      m%run%integrator = integrator
      m%run%rtol = tight_rtol
      m%run%atol_angle = tight_atol_angle
      m%run%atol_speed = tight_atol_speed
   end subroutine load_tight

   !> Frequency of disk 1 from its two zero crossings in one period.
   real(wp) function disk1_frequency(r) result(f)
      type(run_result_t), intent(in) :: r
      real(wp) :: tz(8)
      integer :: n
      call zero_crossings(r%series_t, r%series_theta(1, :), tz, n)
      f = 0.0_wp
      if (n >= 2) f = 1.0_wp/(2.0_wp*(tz(2) - tz(1)))
   end function disk1_frequency

   subroutine test_table5_1_frequency_matches_19_68_hz_and_rk4(method)
      character(len=*), intent(in) :: method
      type(model_t) :: m
      type(run_result_t) :: rk, cv
      real(wp) :: f_rk, f_cv, dmax
      integer :: n
      call test_begin('table5_1_frequency_matches_19_68_hz_and_rk4 ['//method//']')
      ! RK4 at dt = 1e-5 (dt/20 of the deck) on the same 1e-5 output grid
      call load_model('verification/table5_1/table5_1.nml', m)
      m%run%dt = 1.0e-5_wp
      m%run%output_interval = 1.0e-5_wp
      call run_model(m, rk)
      call load_tight('verification/table5_1/table5_1.nml', method, m)
      m%run%output_interval = 1.0e-5_wp
      call run_model(m, cv)
      f_rk = disk1_frequency(rk)
      f_cv = disk1_frequency(cv)
      call check('frequency of disk 1 (Hz) vs 19.68, 0.05 %', f_cv, 19.68_wp, rel_tol=5.0e-4_wp)
      call check('frequency of disk 1 (Hz) vs RK4, 0.05 %', f_cv, f_rk, rel_tol=5.0e-4_wp)
      n = size(cv%series_t)
      call check('same output grid as RK4 (samples)', real(n, wp), real(size(rk%series_t), wp), abs_tol=0.0_wp)
      if (n == size(rk%series_t)) then
         call check('output times on the t_start + k output_interval grid', maxval(abs(cv%series_t - rk%series_t)), &
                    0.0_wp, abs_tol=1.0e-15_wp)
         dmax = maxval(abs(cv%series_theta - rk%series_theta))
         call check('max |theta_cvode - theta_rk4| over the run (rad), amplitude 0.1', dmax, 0.0_wp, abs_tol=1.0e-8_wp)
      end if
      call check('run ends exactly at t_end', cv%t_final, m%run%t_end, abs_tol=0.0_wp)
   end subroutine test_table5_1_frequency_matches_19_68_hz_and_rk4

   !> Compare the first n events of two runs: kind, time and approach velocity
   !> to rel_tol, peak force (contact onsets) to 0.1 %.
   subroutine compare_events(rk, cv, n, rel_tol)
      type(run_result_t), intent(in) :: rk, cv
      integer, intent(in) :: n
      real(wp), intent(in) :: rel_tol
      integer :: i
      character(len=:), allocatable :: lab
      call check('at least '//str(n)//' events (RK4)', size(rk%events) >= n)
      call check('at least '//str(n)//' events (CVODE)', size(cv%events) >= n)
      if (size(rk%events) < n .or. size(cv%events) < n) return
      do i = 1, n
         lab = 'event '//str(i)
         call check(lab//' kind', cv%events(i)%kind == rk%events(i)%kind)
         call check(lab//' time (s)', cv%events(i)%t, rk%events(i)%t, rel_tol=rel_tol)
         call check(lab//' approach velocity', cv%events(i)%approach_velocity, rk%events(i)%approach_velocity, &
                    rel_tol=rel_tol)
         if (rk%events(i)%kind == ev_contact_front .or. rk%events(i)%kind == ev_contact_rear) then
            call check(lab//' contact duration (s)', cv%events(i)%duration, rk%events(i)%duration, rel_tol=rel_tol)
            call check(lab//' peak force, 0.1 %', cv%events(i)%peak_force, rk%events(i)%peak_force, rel_tol=1.0e-3_wp)
         end if
      end do
   end subroutine compare_events

   subroutine test_table5_3_impact_matches_rk4(method)
      character(len=*), intent(in) :: method
      type(model_t) :: m
      type(run_result_t) :: rk, cv
      call test_begin('table5_3_impact_matches_rk4 ['//method//']')
      call load_model('verification/table5_3/table5_3.nml', m)
      m%run%dt = m%run%dt/4.0_wp
      call run_model(m, rk)
      call load_tight('verification/table5_3/table5_3.nml', method, m)
      m%run%output_interval = 1.0e-7_wp   ! the observer samples the peak force at outputs
      call run_model(m, cv)
      call check('same number of events as RK4', real(size(cv%events), wp), real(size(rk%events), wp), abs_tol=0.0_wp)
      call compare_events(rk, cv, 2, 1.0e-6_wp)
      call check('one CVODE root return per event', real(cv%stats%root_returns, wp), real(size(cv%events), wp), &
                 abs_tol=0.0_wp)
      write (*, '(a)') '    counters '//method//': steps '//str(real(cv%stats%steps, wp))//', RHS '// &
         str(real(cv%stats%rhs_evals, wp))//', Jacobians '//str(real(cv%stats%jac_evals, wp))//', roots '// &
         str(real(cv%stats%root_returns, wp))//'; RK4 dt/4: steps '//str(real(rk%stats%steps, wp))//', RHS '// &
         str(real(rk%stats%rhs_evals, wp))//', located events '//str(real(rk%stats%root_returns, wp))
   end subroutine test_table5_3_impact_matches_rk4

   subroutine test_case1_first_ten_events_match_rk4(method)
      character(len=*), intent(in) :: method
      type(model_t) :: m
      type(run_result_t) :: rk, cv
      real(wp), parameter :: t_end = 4.0e-3_wp   ! holds 10 events (5 impacts)
      call test_begin('case1_first_ten_events_match_rk4 ['//method//']')
      call load_model('verification/chapter3/case1.nml', m)
      m%run%dt = m%run%dt/4.0_wp
      m%run%t_end = t_end
      m%run%output_interval = 0.0_wp
      call run_model(m, rk)
      call load_tight('verification/chapter3/case1.nml', method, m)
      m%run%t_end = t_end
      m%run%output_interval = 1.0e-7_wp
      call run_model(m, cv)
      call check('same number of events as RK4 over 4 ms', real(size(cv%events), wp), real(size(rk%events), wp), &
                 abs_tol=0.0_wp)
      call compare_events(rk, cv, 10, 1.0e-6_wp)
      write (*, '(a)') '    counters '//method//' (4 ms): steps '//str(real(cv%stats%steps, wp))//', RHS '// &
         str(real(cv%stats%rhs_evals, wp))//', Jacobians '//str(real(cv%stats%jac_evals, wp))//', roots '// &
         str(real(cv%stats%root_returns, wp))//'; RK4 dt/4: steps '//str(real(rk%stats%steps, wp))//', RHS '// &
         str(real(rk%stats%rhs_evals, wp))//', located events '//str(real(rk%stats%root_returns, wp))
   end subroutine test_case1_first_ten_events_match_rk4

   !> First-contact duration of Table 5.3 at rtol, with absolute tolerances
   !> that leave the control relative (atol well below rtol times the smallest
   !> state magnitude: driven gear angle ~1e-6 rad, speed ~1e-2 rad/s).
   real(wp) function duration_at(method, rtol) result(d)
      character(len=*), intent(in) :: method
      real(wp), intent(in) :: rtol
      type(model_t) :: m
      type(run_result_t) :: r
      call load_model('verification/table5_3/table5_3.nml', m)
      m%run%integrator = method
      m%run%rtol = rtol
      m%run%atol_angle = 1.0e-7_wp*rtol
      m%run%atol_speed = 1.0e-4_wp*rtol
      call run_model(m, r)
      d = -1.0_wp
      if (size(r%events) >= 1) d = r%events(1)%duration
   end function duration_at

   subroutine test_table5_3_contact_duration_converges_with_rtol(method)
      character(len=*), intent(in) :: method
      real(wp), parameter :: rtols(5) = [1.0e-4_wp, 1.0e-5_wp, 1.0e-6_wp, 1.0e-7_wp, 1.0e-8_wp]
      real(wp) :: d(5), dref, chg(4)
      integer :: i
      call test_begin('table5_3_contact_duration_converges_with_rtol ['//method//']')
      dref = duration_at(method, 1.0e-11_wp)
      do i = 1, 5
         d(i) = duration_at(method, rtols(i))
         call check('duration error at rtol = '//str(rtols(i))//' within 100 rtol (relative)', d(i), dref, &
                    rel_tol=100.0_wp*rtols(i))
      end do
      chg = abs(d(2:5) - d(1:4))
      do i = 1, 3
         call check('change '//str(rtols(i + 1))//' -> '//str(rtols(i + 2))//' ('//str(chg(i + 1))// &
                    ' s) smaller than the previous ('//str(chg(i))//' s)', chg(i + 1) < chg(i))
      end do
   end subroutine test_table5_3_contact_duration_converges_with_rtol

   !> A step torque at t = 0.0123 s (not on any grid) on a free two-inertia
   !> train: the angular momentum J1 w1 + J2 w2 must be T (t - t_step). The step
   !> is a CVODE stop time followed by a re-initialisation, so no step straddles
   !> it: no error-test failures there (10-26 without the stop), and Adams, which
   !> keeps linear invariants, gets the momentum to rounding (5e-6 relative at
   !> rtol 1e-6 when it steps over the jump). BDF/Newton keeps it to the
   !> nonlinear-solver tolerance only.
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
      if (method == 'cvode-adams') then
         call check('angular momentum at t_end vs 5 (0.05 - 0.0123), to rounding', l_end, l_exact, rel_tol=1.0e-13_wp)
      else
         call check('angular momentum at t_end vs 5 (0.05 - 0.0123), 100 rtol', l_end, l_exact, rel_tol=1.0e-4_wp)
      end if
      call check('at most 3 error-test failures (the jump is not stepped over)', r%stats%error_test_fails <= 3)
      call check('energy balance closes (residual / scale < 1e-5)', r%energy_residual_max < 1.0e-5_wp*r%energy_scale)
   end subroutine test_step_load_breakpoint_keeps_momentum_exact

   subroutine test_default_max_step_is_a_tenth_of_the_contact_period()
      type(model_t) :: m
      real(wp) :: hmax, omega_max, omega
      call test_begin('default_max_step_is_a_tenth_of_the_contact_period')
      call load_model('verification/table5_3/table5_3.nml', m)
      ! the clearance is open at t_start: the gear mesh mode with the teeth in contact
      omega = sqrt(18.03e6_wp*(1.6445_wp**2/7.537e-3_wp + 1.6445_wp**2/10.082_wp))
      call cvode_max_step(m, hmax, omega_max)
      call check('omega_max with the clearance closed (rad/s)', omega_max, omega, rel_tol=1.0e-10_wp)
      call check('default max step = 0.1 x 2 pi / omega_max (s)', hmax, 0.1_wp*two_pi/omega, rel_tol=1.0e-10_wp)
      call check('the model''s clearance is left open', .not. m%elements(1)%e%in_contact())
      m%run%max_step = 3.0e-6_wp
      call cvode_max_step(m, hmax, omega_max)
      call check('max_step of the deck wins (s)', hmax, 3.0e-6_wp, rel_tol=0.0_wp)
   end subroutine test_default_max_step_is_a_tenth_of_the_contact_period

   subroutine test_abstol_follows_the_state_kind()
      type(model_t) :: m
      real(wp), allocatable :: atol(:), y0(:)
      integer :: i
      call test_begin('abstol_follows_the_state_kind')
      call load_model_text("&run t_end = 0.1, dt = 1.0e-4, integrator = 'cvode-bdf', atol_angle = 1e-11, "// &
                           "atol_speed = 2e-9, atol_current = 3e-7 /"//nl// &
                           "&node id = 'motor', type = 'dc_motor', inertia = 2.0e-3, torque_constant = 0.5, "// &
                           "back_emf_constant = 0.0565, inductance = 2.0e-3, resistance = 0.5 /"//nl// &
                           "&node id = 'gear', type = 'inertia', inertia = 0.05 /"//nl// &
                           "&node id = 'ground', type = 'fixed' /"//nl// &
                           "&node id = 'load', type = 'inertia', inertia = 2.0 /"//nl// &
                           "&element id = 's1', type = 'shaft', left = 'motor', right = 'gear', stiffness = 2.0e4 /"//nl// &
                           "&element id = 's2', type = 'shaft', left = 'gear', right = 'load', stiffness = 2.0e4 /"//nl// &
                           "&element id = 's3', type = 'shaft', left = 'load', right = 'ground', stiffness = 1.0e3 /"//nl// &
                           "&initial node = 'load', speed = 3.0 /"//nl, m)
      call m%initial_state(y0)
      call m%init_modes(m%run%t_start, y0)   ! sets E0 = 0.5 * 2 * 3**2 = 9
      allocate (atol(m%n_y))
      call cvode_abstol(m, atol)
      ! motor (angle, speed, current), gear (angle, speed), ground (none), load (angle, speed), 2 energy states
      call check('state count', real(m%n_y, wp), 9.0_wp, abs_tol=0.0_wp)
      do i = 1, 4
         if (i == 3) cycle
         call check('node '//str(i)//' angle atol', atol(m%nodes(i)%n%offset + 1), 1.0e-11_wp, rel_tol=0.0_wp)
         call check('node '//str(i)//' speed atol', atol(m%nodes(i)%n%offset + 2), 2.0e-9_wp, rel_tol=0.0_wp)
      end do
      call check('motor current atol', atol(3), 3.0e-7_wp, rel_tol=0.0_wp)
      call check('initial stored energy E0', m%energy0, 9.0_wp, rel_tol=1.0e-15_wp)
      call check('energy states: max(rtol, 1e-6) (1 + E0)', atol(8), 1.0e-5_wp, rel_tol=1.0e-14_wp)
      call check('both energy states alike', atol(9), atol(8), rel_tol=0.0_wp)
   end subroutine test_abstol_follows_the_state_kind

   subroutine test_counters_accumulate_over_reinits()
      type(model_t) :: m
      type(run_result_t) :: bdf, adams
      call test_begin('counters_accumulate_over_reinits')
      call load_model('verification/chapter3/case1.nml', m)
      m%run%integrator = 'cvode-bdf'
      call run_model(m, bdf)
      call load_model('verification/chapter3/case1.nml', m)
      m%run%integrator = 'cvode-adams'
      call run_model(m, adams)
      ! 134 events in 50 ms: each ReInit zeroes CVODE's counters, ours keep adding up
      call check('bdf: root returns = events', real(bdf%stats%root_returns, wp), real(size(bdf%events), wp), &
                 abs_tol=0.0_wp)
      call check('bdf: more than 100 events', size(bdf%events) > 100)
      call check('bdf: steps > 20 per event', bdf%stats%steps > 20*size(bdf%events))
      call check('bdf: RHS evaluations > steps', bdf%stats%rhs_evals > bdf%stats%steps)
      call check('bdf: Jacobian evaluations >= one per event', bdf%stats%jac_evals >= size(bdf%events))
      call check('adams: root returns = events', real(adams%stats%root_returns, wp), real(size(adams%events), wp), &
                 abs_tol=0.0_wp)
      call check('adams: no Jacobian (fixed point)', adams%stats%jac_evals == 0)
      call check('adams: RHS evaluations > steps', adams%stats%rhs_evals > adams%stats%steps)
      call check('rejected = error-test + solve failures (>= error-test failures)', &
                 bdf%stats%rejected >= bdf%stats%error_test_fails)
      write (*, '(a)') '    case1 50 ms: bdf steps '//str(real(bdf%stats%steps, wp))//', RHS '// &
         str(real(bdf%stats%rhs_evals, wp))//', Jacobians '//str(real(bdf%stats%jac_evals, wp))//', roots '// &
         str(real(bdf%stats%root_returns, wp))//', error-test fails '//str(real(bdf%stats%error_test_fails, wp))// &
         ', conv fails '//str(real(bdf%stats%conv_fails, wp))
      write (*, '(a)') '    case1 50 ms: adams steps '//str(real(adams%stats%steps, wp))//', RHS '// &
         str(real(adams%stats%rhs_evals, wp))//', roots '//str(real(adams%stats%root_returns, wp))// &
         ', error-test fails '//str(real(adams%stats%error_test_fails, wp))//', conv fails '// &
         str(real(adams%stats%conv_fails, wp))
   end subroutine test_counters_accumulate_over_reinits

   subroutine test_impossible_tolerance_is_a_numeric_error_with_advice()
      type(model_t) :: m
      type(run_result_t) :: r
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      call test_begin('impossible_tolerance_is_a_numeric_error_with_advice')
      call load_model('verification/table5_3/table5_3.nml', m)
      m%run%integrator = 'cvode-bdf'
      m%run%rtol = 1.0e-20_wp
      m%run%atol_angle = 1.0e-30_wp; m%run%atol_speed = 1.0e-30_wp
      call simulate(m, none, r, err)
      call check('an error is returned', allocated(err))
      if (.not. allocated(err)) return
      write (*, '(a)') '    message: '//err%message
      call check('code is err_numeric', err%code == err_numeric)
      call check('message names the integrator', index(err%message, "'cvode-bdf'") > 0)
      call check('message names the time', index(err%message, 'failed at t = 0 s') > 0)
      call check('message names a state by node id', index(err%message, "of node '") > 0)
      call check('message gives advice on the tolerances', index(err%message, 'Advice: loosen the tolerances') > 0)
      call check('no bare return code', index(err%message, 'flag') == 0)
   end subroutine test_impossible_tolerance_is_a_numeric_error_with_advice

   !> A shaft with huge damping on a light disk (eigenvalue -c/J = -2e7 1/s):
   !> the fixed-point iteration of Adams forces steps of ~1e-8 s, and the 0.5 s
   !> output interval needs far more than the allowed internal steps.
   subroutine test_stiff_train_with_adams_runs_out_of_steps_with_advice()
      type(model_t) :: m
      type(run_result_t) :: r
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      call test_begin('stiff_train_with_adams_runs_out_of_steps_with_advice')
      call load_model_text("&run t_end = 1.0, dt = 1.0e-3, output_interval = 0.5, integrator = 'cvode-adams' /"//nl// &
                           "&node id = 'ground', type = 'fixed' /"//nl// &
                           "&node id = 'disk', type = 'inertia', inertia = 1.0e-3 /"//nl// &
                           "&element id = 's', type = 'shaft', stiffness = 1.0, damping = 2.0e4 /"//nl// &
                           "&initial node = 'disk', speed = 1.0 /"//nl, m)
      call simulate(m, none, r, err)
      call check('an error is returned', allocated(err))
      if (.not. allocated(err)) return
      write (*, '(a)') '    message: '//err%message
      call check('code is err_numeric', err%code == err_numeric)
      call check('message names the time reached', index(err%message, 'failed at t = ') > 0)
      call check('message says why (internal steps)', index(err%message, 'internal steps') > 0)
      call check('message names a state by node id', index(err%message, "of node 'disk'") > 0)
      call check('message advises cvode-bdf', index(err%message, "'cvode-bdf'") > 0)
      ! the same train with BDF/Newton is no trouble
      m%run%integrator = 'cvode-bdf'
      call simulate(m, none, r, err)
      call check('cvode-bdf runs it', .not. allocated(err))
      if (allocated(err)) write (*, '(a)') '    message: '//err%message
      call check('cvode-bdf: disk speed decayed (|w| < 1e-6 rad/s)', abs(r%y_final(2)) < 1.0e-6_wp)
   end subroutine test_stiff_train_with_adams_runs_out_of_steps_with_advice
end program test_cvode
