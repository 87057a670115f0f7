!> Loads that depend on speed and prescribed angles and accelerations (issue 23
!> item 3, D-78, D-79) against closed forms: an inertia spun down by each speed
!> law (linear: exponential; quadratic: 1/(1 + a t); sign: linear to the
!> regularisation speed, then exponential; a table), the energy ledger closing
!> on each; the analytic Jacobian of the laws against central differences; a
!> sine angle driving an inertia through a shaft; a sine and a table
!> acceleration against their exact integrals.
program test_speed_loads
   use trainsim_kinds, only: wp, two_pi
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, run_model, nl, jacobian_fd_error
   implicit none

   ! J = 2, w(0) = 10 rad/s; RK4 at dt = 1e-3 (|lambda dt| <= 2e-4 for the smooth laws)
   character(len=*), parameter :: disk = "&run t_end = 4.0, dt = 1e-3, integrator = 'rk4', track_energy = .true.,"// &
                                         " output_interval = 0.01 /"//nl// &
                                         "&node id = 'n1', type = 'inertia', inertia = 2.0 /"//nl// &
                                         "&initial node = 'n1', speed = 10.0 /"//nl

   call suite_begin('speed-dependent loads, prescribed angle and acceleration (issue 23 item 3)')
   call spin_down('linear: w = w0 exp(-c t / (J w_n))', &
                  "&load node = 'n1', speed_law = 'linear', w_nominal = 10.0, value = -4.0 /", 1, 1.0e-10_wp)
   call spin_down('quadratic: w = w0 / (1 + a w0 t)', &
                  "&load node = 'n1', speed_law = 'quadratic', w_nominal = 10.0, value = -5.0 /", 2, 1.0e-10_wp)
   ! one step straddles the kink of the regularised sign law at w = w_reg: its local
   ! error is O(dt^3 |jump of w''|) = 1e-9 * 4.5 (w'' jumps from 0 to 3 * 1.5)
   call spin_down('sign: linear to w_reg, then exponential', &
                  "&load node = 'n1', speed_law = 'sign', w_reg = 0.5, value = -3.0 /", 3, 5.0e-8_wp)
   call spin_down('table of torque against speed (T = -w on [0, 20])', &
                  "&load node = 'n1', speed_law = 'table', speeds = 0.0, 20.0, torques = 0.0, -20.0 /", 4, &
                  1.0e-10_wp)
   call spin_down('quadratic_abs scaled by a step at t = 1: w0, then w0 / (1 - a w0 (t - 1))', &
                  "&load node = 'n1', speed_law = 'quadratic_abs', w_nominal = 10.0, kind = 'step',"// &
                  " value0 = 0.0, value1 = 4.0, t_step = 1.0 /", 5, 1.0e-9_wp)
   call jacobian_of_the_laws()
   call prescribed_angle_sine_through_a_shaft()
   call prescribed_acceleration(" kind = 'sine', offset = 0.5, amplitude = 2.0, frequency = 1.0 /", 1)
   call prescribed_acceleration(" kind = 'table', times = 0.0, 1.0, 2.0, values = 0.0, 2.0, 2.0 /", 2)
   call load_on_a_held_node("kind = 'constant', quantity = 'speed', value = -2.0 /", 'at a constant speed (families)')
   call load_on_a_held_node("kind = 'sine', quantity = 'angle', amplitude = 0.1, frequency = 0.5 /", &
                            'at a sine angle (general path)')
   call suite_end()

contains

   !> The closed-form speed of the spin-down `law` (J = 2, w0 = 10).
   pure real(wp) function w_exact(law, t) result(w)
      integer, intent(in) :: law
      real(wp), intent(in) :: t
      real(wp) :: t1
      select case (law)
      case (1); w = 10.0_wp*exp(-4.0_wp/(2.0_wp*10.0_wp)*t)              ! J w' = -4 w/10
      case (2); w = 10.0_wp/(1.0_wp + 5.0_wp/(2.0_wp*100.0_wp)*10.0_wp*t)  ! J w' = -5 (w/10)^2
      case (3)                                                            ! J w' = -3 min(1, w/0.5)
         t1 = (10.0_wp - 0.5_wp)/1.5_wp
         if (t <= t1) then
            w = 10.0_wp - 1.5_wp*t
         else
            w = 0.5_wp*exp(-3.0_wp*(t - t1))
         end if
      case (4); w = 10.0_wp*exp(-t/2.0_wp)                                 ! J w' = -w
      case default                                                        ! J w' = 4 (w/10)^2 from t = 1
         w = 10.0_wp
         if (t > 1.0_wp) w = 10.0_wp/(1.0_wp - 4.0_wp/(2.0_wp*100.0_wp)*10.0_wp*(t - 1.0_wp))
      end select
   end function w_exact

   subroutine spin_down(name, load, law, tol)
      character(len=*), intent(in) :: name, load
      integer, intent(in) :: law
      real(wp), intent(in) :: tol
      type(model_t) :: m
      type(run_result_t) :: res
      real(wp) :: worst
      integer :: k
      call test_begin('spin-down, '//name)
      call load_model_text(disk//load, m)
      if (law == 3) m%run%t_end = 7.0_wp
      call run_model(m, res)
      worst = 0.0_wp
      do k = 1, size(res%series_t)
         worst = max(worst, abs(res%series_omega(1, k) - w_exact(law, res%series_t(k))))
      end do
      call check('max |w - w_exact| over the run (rad/s)', worst, 0.0_wp, abs_tol=tol)
      call check('the run ends at t_end', res%t_final, m%run%t_end, abs_tol=1.0e-12_wp)
      ! the ledger: kinetic energy lost = work of the load, to RK4's error (1e-9 of J w0^2 / 2)
      call check('energy ledger closes: max |residual| / scale', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-9_wp)
      if (law == 5) call check('pushed to 25 rad/s at t = 4', res%series_omega(1, size(res%series_t)), 25.0_wp, &
                               abs_tol=1.0e-9_wp)
   end subroutine spin_down

   !> Two inertias on a shaft, every law on them inside and outside its kinks.
   subroutine jacobian_of_the_laws()
      type(model_t) :: m
      real(wp) :: worst, scale
      real(wp), allocatable :: y(:), ja(:, :)
      call test_begin('analytic Jacobian of the speed laws = central differences')
      call load_model_text("&run t_end = 1.0, dt = 1e-3 /"//nl// &
                           "&node id = 'a', type = 'inertia', inertia = 0.5, damping = 0.1 /"//nl// &
                           "&node id = 'b', type = 'inertia', inertia = 2.0 /"//nl// &
                           "&element type = 'shaft', stiffness = 100.0 /"//nl// &
                           "&load node = 'a', speed_law = 'quadratic', w_nominal = 3.0, kind = 'ramp', value1 = -2.0,"// &
                           " t1 = 2.0 /"//nl// &
                           "&load node = 'a', speed_law = 'sign', w_reg = 2.0, value = -1.5 /"//nl// &
                           "&load node = 'b', speed_law = 'linear_abs', w_nominal = 5.0, value = -0.7 /"//nl// &
                           "&load node = 'b', speed_law = 'table', speeds = -10.0, 0.0, 10.0,"// &
                           " torques = 3.0, 0.0, -8.0, value = 0.5 /"//nl// &
                           "&load node = 'b', speed_law = 'quadratic_abs', w_nominal = 4.0, value = 0.25 /"//nl// &
                           "&initial node = 'a', speed = 1.3 /"//nl//"&initial node = 'b', angle = 0.01, speed = -2.1 /", &
                           m)
      call jacobian_fd_error(m, 0.7_wp, worst, scale)
      ! central differences of smooth pieces: truncation ~ h^2 w''' ~ 1e-12, rounding ~ 1e-16/h ~ 1e-10
      call check('max |J_analytic - J_fd| / max |J|', worst, 0.0_wp, abs_tol=1.0e-7_wp)
      call m%initial_state(y)
      allocate (ja(size(y), size(y)))
      call m%jacobian(0.7_wp, y, ja)
      ! d(w_a')/d(w_a) = (-d + slopes)/J: the laws' part alone
      call check('the loads add to d w_a'' / d w_a', ja(2, 2), &
                 (-0.1_wp - 2.0_wp*0.7_wp/2.0_wp*2.0_wp*1.3_wp/9.0_wp - 1.5_wp/2.0_wp)/0.5_wp, rel_tol=1.0e-12_wp)
   end subroutine jacobian_of_the_laws

   !> Node 1 held at A sin(W t), node 2 (J) on a shaft k: the closed-form forced
   !> response from rest, theta2 = A wn^2/(wn^2 - W^2) (sin W t - (W/wn) sin wn t).
   subroutine prescribed_angle_sine_through_a_shaft()
      type(model_t) :: m
      type(run_result_t) :: res
      real(wp), parameter :: a = 0.1_wp, wn = 10.0_wp, ww = two_pi*0.5_wp
      real(wp) :: worst, worst1, t, th2
      integer :: k
      call test_begin('prescribed angle (sine) drives an inertia through a shaft: closed form')
      call load_model_text("&run t_end = 2.0, dt = 1e-4, integrator = 'rk4', track_energy = .true.,"// &
                           " output_interval = 0.01 /"//nl// &
                           "&node id = 'drive', type = 'inertia', inertia = 3.0 /"//nl// &
                           "&node id = 'disk', type = 'inertia', inertia = 1.0 /"//nl// &
                           "&element type = 'shaft', stiffness = 100.0 /"//nl// &
                           "&load node = 'drive', quantity = 'angle', kind = 'sine', amplitude = 0.1, frequency = 0.5 /", m)
      call run_model(m, res)
      worst = 0.0_wp
      worst1 = 0.0_wp
      do k = 1, size(res%series_t)
         t = res%series_t(k)
         th2 = a*wn**2/(wn**2 - ww**2)*(sin(ww*t) - ww/wn*sin(wn*t))
         worst = max(worst, abs(res%series_theta(2, k) - th2))
         worst1 = max(worst1, abs(res%series_theta(1, k) - a*sin(ww*t)) + abs(res%series_omega(1, k) - a*ww*cos(ww*t)))
      end do
      ! RK4 at wn dt = 1e-3: global error ~ (wn dt)^4 A wn t = 2e-12
      call check('max |theta_disk - closed form| (rad)', worst, 0.0_wp, abs_tol=1.0e-10_wp)
      call check('the held node follows A sin(W t) and its derivative', worst1, 0.0_wp, abs_tol=1.0e-14_wp)
      ! the drive's power (J_drive alpha - torque) omega is in the ledger
      call check('energy ledger closes: max |residual| / scale', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-9_wp)
   end subroutine prescribed_angle_sine_through_a_shaft

   !> A torque load on a node whose motion is prescribed does no work on the
   !> train: the drive takes it (its torque is minus the element torques and the
   !> load), so the energy put in is minus the element torques times the speed.
   !> The ledger closes with a 0.5 load on the held node beside a load on the
   !> free one; before, it lost T w t (0.05 of a 82 scale on held_nodes_two.nml).
   subroutine load_on_a_held_node(motion, what)
      character(len=*), intent(in) :: motion, what
      type(model_t) :: m
      type(run_result_t) :: res
      call test_begin('a constant load on a held node '//what//': the energy ledger closes')
      call load_model_text("&run t_end = 2.0, dt = 1e-4, integrator = 'rk4', track_energy = .true.,"// &
                           " output_interval = 0.01 /"//nl// &
                           "&node id = 'drive', type = 'inertia', inertia = 3.0 /"//nl// &
                           "&node id = 'disk', type = 'inertia', inertia = 1.0 /"//nl// &
                           "&element type = 'shaft', stiffness = 100.0, damping = 0.5 /"//nl// &
                           "&load node = 'drive', value = 0.5 /"//nl// &
                           "&load node = 'disk', value = -0.3 /"//nl// &
                           "&load node = 'drive', "//motion, m)
      call run_model(m, res)
      ! RK4 at wn dt = 1e-3 on a damped shaft: the ledger's own error is ~1e-12 of the scale
      call check('energy ledger closes: max |residual| / scale', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-9_wp)
   end subroutine load_on_a_held_node

   !> A held node's acceleration a(t) from t = 0 with w(0) = 3, theta(0) = 0.2: its
   !> speed and angle against the exact first and second integrals.
   subroutine prescribed_acceleration(fn, which)
      character(len=*), intent(in) :: fn
      integer, intent(in) :: which
      type(model_t) :: m
      type(run_result_t) :: res
      real(wp), parameter :: w0 = 3.0_wp, th0 = 0.2_wp
      real(wp) :: worst_w, worst_th, t, w, th
      integer :: k
      call test_begin('prescribed acceleration ('//merge('sine ', 'table', which == 1)//') against its integrals')
      call load_model_text("&run t_end = 3.0, dt = 1e-3, integrator = 'rk4', track_energy = .true.,"// &
                           " output_interval = 0.01 /"//nl// &
                           "&node id = 'drive', type = 'inertia', inertia = 3.0 /"//nl// &
                           "&node id = 'disk', type = 'inertia', inertia = 1.0 /"//nl// &
                           "&element type = 'shaft', stiffness = 100.0 /"//nl// &
                           "&initial node = 'drive', angle = 0.2, speed = 3.0 /"//nl// &
                           "&load node = 'drive', quantity = 'acceleration',"//fn, m)
      call run_model(m, res)
      worst_w = 0.0_wp
      worst_th = 0.0_wp
      do k = 1, size(res%series_t)
         t = res%series_t(k)
         if (which == 1) then   ! a = 0.5 + 2 sin(2 pi t)
            w = w0 + 0.5_wp*t + 2.0_wp/two_pi*(1.0_wp - cos(two_pi*t))
            th = th0 + w0*t + 0.25_wp*t**2 + 2.0_wp/two_pi*(t - sin(two_pi*t)/two_pi)
         else if (t <= 1.0_wp) then   ! a = 2 t, then 2
            w = w0 + t**2
            th = th0 + w0*t + t**3/3.0_wp
         else
            w = w0 + 1.0_wp + 2.0_wp*(t - 1.0_wp)
            th = th0 + w0*t + 1.0_wp/3.0_wp + (t - 1.0_wp) + (t - 1.0_wp)**2
         end if
         worst_w = max(worst_w, abs(res%series_omega(1, k) - w))
         worst_th = max(worst_th, abs(res%series_theta(1, k) - th))
      end do
      ! exact formulas evaluated in double precision: rounding of values ~ 10
      call check('max |w - exact| (rad/s)', worst_w, 0.0_wp, abs_tol=1.0e-13_wp)
      call check('max |theta - exact| (rad)', worst_th, 0.0_wp, abs_tol=1.0e-13_wp)
      call check('energy ledger closes: max |residual| / scale', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-9_wp)
   end subroutine prescribed_acceleration
end program test_speed_loads
