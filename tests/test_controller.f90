!> The DC motor's controller (&controller, issue 23 item 4) against closed forms:
!> a P speed loop on a motor (the exact solution of the linear second-order loop:
!> steady-state error r k_e/(kp + k_e), time constant J R/(k_t (kp + k_e)));
!> a PI loop under a step load (no steady-state error; the integral settles at
!> (k_e r + R T_L/k_t)/ki); anti-windup on a saturated start (the overshoot stays
!> below the unsaturated loop's closed form; without anti-windup it exceeds it); the current limit during a start (|i| <= i_max:
!> at the bound L i' = R (i_max - i)); a positioning sequence (arrivals within the
!> tolerances, in order, in their slots; the same under CVODE); the energy ledger;
!> the analytic Jacobian against central differences.
program test_controller
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_event, only: ev_target_reached
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check, check_true
   use trainsim_test_support, only: load_model_text, run_model, nl
   implicit none

   ! motor: J = 0.02, k_t = k_e = 0.05, R = 1, L = 1e-4 (electrical time 1e-4 s)
   character(len=*), parameter :: motor = "&node id = 'm', type = 'dc_motor', inertia = 0.02, "// &
                                          "torque_constant = 0.05, back_emf_constant = 0.05, inductance = 1.0e-4, "// &
                                          "resistance = 1.0 /"//nl
   real(wp), parameter :: jm = 0.02_wp, kt = 0.05_wp, ke = 0.05_wp, rr = 1.0_wp, ll = 1.0e-4_wp

   call suite_begin('DC motor controller (issue 23 item 4)')
   call test_p_speed_closed_form()
   call test_pi_step_load()
   call test_anti_windup()
   call test_current_limit()
   call test_sequence()
   call test_jacobian_controller()
   call suite_end()

contains

   function run_head(t_end, dt, extra) result(s)
      real(wp), intent(in) :: t_end, dt
      character(len=*), intent(in) :: extra
      character(len=:), allocatable :: s
      character(len=32) :: a, b
      write (a, '(es12.5)') t_end
      write (b, '(es12.5)') dt
      s = "&run units = 'si', t_end = "//trim(a)//", dt = "//trim(b)//", output_interval = 1.0e-3 "//extra//" /"//nl
   end function run_head

   !> P on the motor's speed: J w' = k_t i, L i' = -R i - k_e w + kp (r - w); the
   !> exact solution from the two eigenvalues, w(0) = w'(0) = 0.
   subroutine test_p_speed_closed_form()
      type(model_t) :: m
      type(run_result_t) :: res
      real(wp), parameter :: kp = 2.0_wp, r = 100.0_wp
      real(wp) :: w_ss, tau, a11, a21, a22, disc, l1, l2, c1, c2, worst, w_ex
      integer :: k
      call test_begin('P speed loop: exact second-order response, steady-state error, time constant')
      call load_model_text(run_head(3.0_wp, 1.0e-5_wp, '')//motor// &
                           "&controller motor = 'm', measure = 'speed', kp = 2.0, value = 100.0 /", m)
      call run_model(m, res)
      w_ss = kp*r/(kp + ke)
      ! x = (w, i): w' = (k_t/J) i, i' = -((kp + k_e)/L) w - (R/L) i + kp r/L
      a11 = kt/jm; a21 = -(kp + ke)/ll; a22 = -rr/ll
      disc = sqrt(a22**2 + 4.0_wp*a11*a21)
      l1 = 0.5_wp*(a22 + disc); l2 = 0.5_wp*(a22 - disc)
      c1 = w_ss*l2/(l1 - l2); c2 = -w_ss - c1          ! c1 + c2 = -w_ss, l1 c1 + l2 c2 = 0
      worst = 0.0_wp
      do k = 1, size(res%series_t)
         w_ex = w_ss + c1*exp(l1*res%series_t(k)) + c2*exp(l2*res%series_t(k))
         worst = max(worst, abs(res%series_omega(1, k) - w_ex))
      end do
      call check('max |w - w_exact| / w_ss (RK4 at dt R/L = 0.1: ~1e-9)', worst/w_ss, 0.0_wp, abs_tol=1.0e-7_wp)
      call check('steady-state error r k_e/(kp + k_e) at 15 time constants', r - res%y_final(2), r*ke/(kp + ke), &
                 rel_tol=1.0e-5_wp)
      tau = jm*rr/(kt*(kp + ke))
      call check('slow eigenvalue = -1/tau (tau = J R/(k_t (kp + k_e)), to L k_t(kp+k_e)/(J R^2) ~ 1e-3)', &
                 -1.0_wp/l1, tau, rel_tol=2.0e-3_wp)
   end subroutine test_p_speed_closed_form

   !> PI on the speed, a load torque T_L from t = 1 s: the error vanishes and the
   !> integral holds the voltage k_e r + R T_L/k_t.
   subroutine test_pi_step_load()
      type(model_t) :: m
      type(run_result_t) :: res
      real(wp), parameter :: r = 50.0_wp, tl = 0.2_wp, ki = 20.0_wp
      call test_begin('PI speed loop with a step load: zero steady-state error')
      ! s^2 + (a + b kp) s + b ki with a = k_t k_e/(J R), b = k_t/(J R): decay 2.56 1/s, 8 s: e^-18
      call load_model_text(run_head(9.0_wp, 1.0e-5_wp, '')//motor// &
                           "&controller motor = 'm', measure = 'speed', kp = 2.0, ki = 20.0, value = 50.0 /"//nl// &
                           "&load node = 'm', kind = 'step', value0 = 0.0, value1 = -0.2, t_step = 1.0 /", m)
      call run_model(m, res)
      call check('speed error at the end / r', abs(res%y_final(2) - r)/r, 0.0_wp, abs_tol=1.0e-6_wp)
      call check('current carries the load: i = T_L/k_t', res%y_final(3), tl/kt, rel_tol=1.0e-6_wp)
      call check('integral = (k_e r + R T_L/k_t)/ki', res%y_final(4), (ke*r + rr*tl/kt)/ki, rel_tol=1.0e-6_wp)
      call check('energy ledger closes (residual / scale)', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-6_wp)
   end subroutine test_pi_step_load

   !> A saturated start (v_max = 12 V; r = 100 rad/s needs 5 V) of a PI speed loop
   !> (kp = 2, ki = 20). Unsaturated, the loop is w/r = b (kp s + ki)/(s^2 + (a + b kp) s
   !> + b ki) (a = k_t k_e/(J R), b = k_t/(J R), L neglected: 1e-4 s), whose step
   !> overshoot (closed form below, 39 %) bounds the anti-windup runs: with z frozen
   !> (conditional) or tracked (back-calculation) the loop leaves the bound with less
   !> stored in z than the linear loop has; without anti-windup z winds up over the
   !> saturated seconds and the overshoot exceeds the linear one.
   subroutine test_anti_windup()
      real(wp) :: over_cond, over_none, over_back, over_lin, w_end, a, b, sg, wd, bb, t
      integer :: k
      call test_begin('anti-windup on a saturated start: conditional, back-calculation, none')
      a = kt*ke/(jm*rr); b = kt/(jm*rr)
      sg = 0.5_wp*(a + b*2.0_wp); wd = sqrt(b*20.0_wp - sg**2)
      bb = (b*2.0_wp - sg)/wd                 ! y = 1 + exp(-sg t)(-cos wd t + bb sin wd t): y(0) = 0, y'(0) = b kp
      over_lin = 0.0_wp
      do k = 1, 100000
         t = 1.0e-4_wp*k
         over_lin = max(over_lin, exp(-sg*t)*(-cos(wd*t) + bb*sin(wd*t)))
      end do
      over_cond = overshoot("anti_windup = 'conditional'", w_end)
      call check('conditional: the speed settles at r', w_end, 100.0_wp, rel_tol=1.0e-6_wp)
      over_back = overshoot("anti_windup = 'back_calculation', tracking_time = 0.05", w_end)
      over_none = overshoot("anti_windup = 'none'", w_end)
      print '(a,4es11.3)', '    overshoot / r (linear closed form; conditional, back-calculation, none):', &
         over_lin, over_cond, over_back, over_none
      call check_true('conditional: overshoot below the unsaturated loop''s', over_cond < over_lin)
      call check_true('back-calculation: overshoot below the unsaturated loop''s', over_back < over_lin)
      call check_true('none: overshoot above the unsaturated loop''s (wind-up)', over_none > over_lin)
   end subroutine test_anti_windup

   real(wp) function overshoot(aw, w_end) result(o)
      character(len=*), intent(in) :: aw
      real(wp), intent(out) :: w_end
      type(model_t) :: m
      type(run_result_t) :: res
      call load_model_text(run_head(10.0_wp, 1.0e-5_wp, '')//motor// &
                           "&controller motor = 'm', measure = 'speed', kp = 2.0, ki = 20.0, v_min = -12.0, "// &
                           "v_max = 12.0, value = 100.0, "//aw//" /", m)
      call run_model(m, res)
      w_end = res%y_final(2)
      o = max(0.0_wp, maxval(res%series_omega(1, :)) - 100.0_wp)/100.0_wp
   end function overshoot

   !> A hard start (kp = 50 on 100 rad/s, v_max = 24 V: 24 A at stall) with
   !> current_limit = 5 A: the mean current over each sample interval,
   !> J dw/(k_t dt), stays within 5 A and reaches it; without the limit it is 4x.
   subroutine test_current_limit()
      real(wp) :: peak_lim, peak_free
      call test_begin('current limit holds during a start')
      peak_lim = peak_current(', current_limit = 5.0')
      peak_free = peak_current('')
      call check('peak mean current with i_max = 5 A (<= i_max; bound exact: L i'' = R (i_max - i))', &
                 min(peak_lim, 5.0_wp), 5.0_wp, rel_tol=1.0e-2_wp)
      call check_true('peak current <= i_max (1 + 1e-9)', peak_lim <= 5.0_wp*(1.0_wp + 1.0e-9_wp))
      call check_true('without the limit the start draws > 15 A', peak_free > 15.0_wp)
   end subroutine test_current_limit

   real(wp) function peak_current(extra) result(p)
      character(len=*), intent(in) :: extra
      type(model_t) :: m
      type(run_result_t) :: res
      integer :: k
      call load_model_text(run_head(1.0_wp, 1.0e-5_wp, '')//motor// &
                           "&controller motor = 'm', measure = 'speed', kp = 50.0, v_min = -24.0, v_max = 24.0, "// &
                           "value = 100.0"//extra//" /", m)
      call run_model(m, res)
      p = 0.0_wp
      do k = 2, size(res%series_t)
         p = max(p, jm*(res%series_omega(1, k) - res%series_omega(1, k - 1))/(kt*(res%series_t(k) - &
                                                                                  res%series_t(k - 1))))
      end do
   end function peak_current

   !> A PD positioning sequence on a disk behind a shaft: targets 5, 10, 2 rad from
   !> 0.2, 2.0, 4.0 s; each arrival is a target_reached event with the sensor within
   !> the tolerances, in order, inside its slot; CVODE finds the same events.
   subroutine test_sequence()
      real(wp), parameter :: tt(3) = [0.2_wp, 2.0_wp, 4.0_wp], target(3) = [5.0_wp, 10.0_wp, 2.0_wp]
      real(wp) :: t_rk4(3)
      integer :: k, n
      type(run_result_t) :: res
      call test_begin('positioning sequence: arrivals in order, within tolerance, located as events')
      call run_seq('rk4', res)
      n = count(res%events(:)%kind == ev_target_reached)
      call check('target_reached events', real(n, wp), 3.0_wp, abs_tol=0.0_wp)
      if (n /= 3) return
      do k = 1, 3
         associate (ev => res%events(k))
            call check_true('event in its slot', ev%t >= tt(k) .and. (k == 3 .or. ev%t < tt(min(k + 1, 3))))
            call check('|angle - target| <= tolerance 1e-3 (event location to 1e-6)', &
                       abs(ev%theta_left - target(k)), 0.0_wp, abs_tol=1.0e-3_wp*(1.0_wp + 1.0e-6_wp))
            call check_true('|speed| <= speed_tolerance', abs(ev%omega_left) <= 1.0e-2_wp*(1.0_wp + 1.0e-6_wp))
            t_rk4(k) = ev%t
         end associate
      end do
      call check('energy ledger closes (residual / scale)', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-6_wp)
      call run_seq('cvode-bdf', res)
      n = count(res%events(:)%kind == ev_target_reached)
      call check('target_reached events under CVODE', real(n, wp), 3.0_wp, abs_tol=0.0_wp)
      if (n /= 3) return
      do k = 1, 3
         call check('arrival time CVODE vs RK4 (rtol 1e-8)', res%events(k)%t, t_rk4(k), rel_tol=1.0e-4_wp)
      end do
   end subroutine test_sequence

   subroutine run_seq(integrator, res)
      character(len=*), intent(in) :: integrator
      type(run_result_t), intent(out) :: res
      type(model_t) :: m
      call load_model_text(run_head(6.0_wp, 1.0e-5_wp, ", integrator = '"//integrator//"', rtol = 1.0e-8")// &
                           "&node id = 'm', type = 'dc_motor', inertia = 0.01, torque_constant = 0.05, "// &
                           "back_emf_constant = 0.05, inductance = 1.0e-3, resistance = 1.0 /"//nl// &
                           "&node id = 'load', type = 'inertia', inertia = 0.01 /"//nl// &
                           "&element id = 's', type = 'shaft', left = 'm', right = 'load', stiffness = 1.0e3, "// &
                           "damping = 0.5 /"//nl// &
                           "&controller id = 'pos', motor = 'm', sensor = 'load', measure = 'angle', kp = 40.0, "// &
                           "kd = 8.0, filter_time = 1.0e-3, v_min = -24.0, v_max = 24.0, current_limit = 30.0, "// &
                           "sequence = .true., kind = 'table', times = 0.2, 2.0, 4.0, values = 5.0, 10.0, 2.0, "// &
                           "tolerance = 1.0e-3, speed_tolerance = 1.0e-2 /", m)
      call run_model(m, res)
   end subroutine run_seq

   !> The analytic Jacobian (controller rows and the current's row) against central
   !> differences of the RHS: PID with a filter off its bounds, and on the current limit.
   subroutine test_jacobian_controller()
      call test_begin('controller Jacobian = central differences')
      call jac_case('PID off its bounds', "kp = 2.0, ki = 3.0, kd = 0.1, filter_time = 0.01, value = 10.0", 1.0_wp)
      call jac_case('P on the current limit', "kp = 50.0, current_limit = 2.0, value = 100.0", 0.0_wp)
   end subroutine test_jacobian_controller

   subroutine jac_case(name, keys, w0)
      character(len=*), intent(in) :: name, keys
      real(wp), intent(in) :: w0
      type(model_t) :: m
      real(wp), allocatable :: y(:), ja(:, :), jf(:, :), fp(:), fm(:), yp(:)
      real(wp) :: h, t, scale
      integer :: n, j
      character(len=24) :: a
      write (a, '(f8.3)') w0
      call load_model_text(run_head(1.0_wp, 1.0e-5_wp, ', track_energy = .false.')//motor// &
                           "&node id = 'd', type = 'inertia', inertia = 0.05 /"//nl// &
                           "&element type = 'shaft', stiffness = 100.0, damping = 0.1 /"//nl// &
                           "&controller motor = 'm', sensor = 'd', measure = 'speed', "//keys//" /"//nl// &
                           "&initial node = 'd', speed = "//trim(a)//", angle = 0.01 /", m)
      call m%initial_state(y)
      y(3) = 0.5_wp; y(4) = 0.2_wp           ! a current and an integral off zero
      t = m%run%t_start
      call m%init_modes(t, y)
      n = size(y)
      allocate (ja(n, n), jf(n, n), fp(n), fm(n), yp(n))
      call m%jacobian(t, y, ja)
      do j = 1, n
         h = 1.0e-6_wp*max(1.0e-3_wp, abs(y(j)))
         yp = y; yp(j) = y(j) + h
         call m%rhs(t, yp, fp)
         yp(j) = y(j) - h
         call m%rhs(t, yp, fm)
         jf(:, j) = (fp - fm)/(2.0_wp*h)
      end do
      scale = maxval(abs(jf))
      call check('max |J_analytic - J_fd| / max |J|: '//name, maxval(abs(ja - jf))/scale, 0.0_wp, abs_tol=1.0e-6_wp)
   end subroutine jac_case
end program test_controller
