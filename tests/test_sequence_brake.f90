!> A holding brake commanded by a positioning sequence (&controller brake = 'ID',
!> D-76) on a DC motor rigidly joined to a disk under a constant load torque T_L:
!> the sequence moves to its target, the brake engages at the arrival (the motor
!> at 0 V, armature shorted), holds through the dwell and opens at the next
!> target's time. From the arrival on the motion has a closed form: J w' = k_t i - F,
!> L i' = -R i - k_e w (F constant in each phase), solved exactly (Sylvester's
!> formula for the 2 x 2 exponential) from the current at the arrival.
!>  - held (T_L below the static limit Ts): the brake slips forward to a stop (stick
!>    at the closed-form instant), then the angle is constant to 1e-12 through the
!>    dwell and the brake carries T_L; it opens exactly at the next target's time;
!>  - slipping (T_L above Ts): stops, then slips backward at the closed-form
!>    motion under T_L - Tc;
!>  - both: the energy ledger closes.
program test_sequence_brake
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_event, only: ev_stick, ev_slip_backward, ev_target_reached
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check, check_true
   use trainsim_test_support, only: load_model_text, run_model, nl
   implicit none

   ! the train: motor J_m = 0.002 rigidly joined to a disk J_d = 0.003 (J = 0.005)
   real(wp), parameter :: jt = 0.005_wp, kt = 0.05_wp, ke = 0.05_wp, ll = 1.0e-3_wp, rr = 10.0_wp
   real(wp), parameter :: t_release = 1.0_wp, t_load = 0.05_wp
   integer, parameter :: i_brake = 2      ! the deck's second element

   call suite_begin('holding brake commanded by a positioning sequence (issue 23, D-76)')
   call test_held_brake_holds_the_load_through_the_dwell()
   call test_weak_brake_slips_under_the_load()
   call suite_end()

contains

   !> The deck: Ts and Tc of the brake, the run's t_end.
   function deck(ts, tc, t_end) result(s)
      real(wp), intent(in) :: ts, tc, t_end
      character(len=:), allocatable :: s
      character(len=24) :: a, b, c
      write (a, '(es22.15)') ts
      write (b, '(es22.15)') tc
      write (c, '(es22.15)') t_end
      s = "&run units = 'si', t_end = "//trim(c)//", dt = 1.0e-5, output_interval = 1.0e-3, integrator = 'rk4' /"//nl// &
          "&node id = 'm', type = 'dc_motor', inertia = 0.002, torque_constant = 0.05, back_emf_constant = 0.05, "// &
          "inductance = 1.0e-3, resistance = 10.0 /"//nl// &
          "&node id = 'disk', type = 'inertia', inertia = 0.003 /"//nl// &
          "&node id = 'ground', type = 'fixed' /"//nl// &
          "&element id = 'join', type = 'rigid_join', left = 'm', right = 'disk' /"//nl// &
          "&element id = 'brake', type = 'brake', left = 'm', right = 'ground', torque_sliding = "//trim(b)// &
          ", torque_static = "//trim(a)//" /"//nl// &
          "&controller id = 'pos', motor = 'm', sensor = 'disk', measure = 'angle', kp = 400.0, kd = 40.0, "// &
          "filter_time = 1.0e-3, v_min = -24.0, v_max = 24.0, sequence = .true., hold = 'off', brake = 'brake', "// &
          "kind = 'table', times = 0.0, 1.0, values = 1.0, 1.5, tolerance = 0.05, speed_tolerance = 0.01 /"//nl// &
          "&load node = 'disk', kind = 'constant', value = -0.05 /"
   end function deck

   !> (w, i) at time s after (w0, i0) under J w' = k_t i - f, L i' = -R i - k_e w:
   !> x_p + exp(A s) (x0 - x_p), exp(A s) by Sylvester's formula (A's eigenvalues
   !> are real and distinct: (R/L)^2 > 4 k_t k_e/(J L)).
   function motion(w0, i0, f, s) result(x)
      real(wp), intent(in) :: w0, i0, f, s
      real(wp) :: x(2), a(2, 2), xp(2), d(2), l1, l2
      call system(f, a, l1, l2, xp)
      d = [w0, i0] - xp
      x = xp + (exp(l1*s)*(matmul(a, d) - l2*d) - exp(l2*s)*(matmul(a, d) - l1*d))/(l1 - l2)
   end function motion

   !> The instant the forward slip under f stops (w = 0), by bisection on `motion`.
   real(wp) function stop_time(w0, i0, f) result(s)
      real(wp), intent(in) :: w0, i0, f
      real(wp) :: lo, hi, x(2)
      integer :: k
      lo = 0.0_wp
      hi = 1.0e-2_wp
      do k = 1, 200
         s = 0.5_wp*(lo + hi)
         x = motion(w0, i0, f, s)
         if (x(1) > 0.0_wp) then
            lo = s
         else
            hi = s
         end if
      end do
      s = 0.5_wp*(lo + hi)
   end function stop_time

   !> The current at the arrival: the same run stopped there (RK4's grid up to it
   !> is the same, so its state is the arrival's to the event location).
   real(wp) function current_at(ts, tc, t) result(i)
      real(wp), intent(in) :: ts, tc, t
      type(model_t) :: m
      type(run_result_t) :: r
      call load_model_text(deck(ts, tc, t), m)
      call run_model(m, r)
      i = r%y_final(3)
   end function current_at

   !> The whole run (to 1.2 s) and its arrival: time (-1 if none), speed, current.
   subroutine run_to_arrival(ts, tc, r, t_r, w_r, i_r)
      real(wp), intent(in) :: ts, tc
      type(run_result_t), intent(out) :: r
      real(wp), intent(out) :: t_r, w_r, i_r
      type(model_t) :: m
      integer :: kr
      call load_model_text(deck(ts, tc, 1.2_wp), m)
      call run_model(m, r)
      kr = first_event(r, ev_target_reached, 0.0_wp)
      call check_true('the sequence reaches its target', kr > 0)
      t_r = -1.0_wp; w_r = 0.0_wp; i_r = 0.0_wp
      if (kr == 0) return
      t_r = r%events(kr)%t
      w_r = r%events(kr)%omega_left
      i_r = current_at(ts, tc, t_r)
   end subroutine run_to_arrival

   !> A = [0, k_t/J; -k_e/L, -R/L] of the motion (w, i), its eigenvalues and the
   !> steady state under f.
   pure subroutine system(f, a, l1, l2, xp)
      real(wp), intent(in) :: f
      real(wp), intent(out) :: a(2, 2), l1, l2, xp(2)
      real(wp) :: disc
      a = reshape([0.0_wp, -ke/ll, kt/jt, -rr/ll], [2, 2])
      disc = sqrt((rr/ll)**2 - 4.0_wp*kt*ke/(jt*ll))
      l1 = 0.5_wp*(-rr/ll + disc)
      l2 = 0.5_wp*(-rr/ll - disc)
      xp = [-rr*f/(kt*ke), f/kt]                   ! steady state: k_t i = f, R i = -k_e w
   end subroutine system

   integer function first_event(r, kind, after) result(k)
      type(run_result_t), intent(in) :: r
      integer, intent(in) :: kind
      real(wp), intent(in) :: after
      do k = 1, size(r%events)
         if (r%events(k)%kind == kind .and. r%events(k)%t >= after) return
      end do
      k = 0
   end function first_event

   !> Ts = 0.2 > T_L = 0.05 (Tc = 0.15).
   subroutine test_held_brake_holds_the_load_through_the_dwell()
      real(wp), parameter :: ts = 0.2_wp, tc = 0.15_wp
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: t_r, w_r, i_r, t_s, th_s, disp, force
      integer :: ks, kl, n, contact, pairs
      logical, allocatable :: dwell(:)
      call test_begin('held_brake_holds_the_load_through_the_dwell')
      call run_to_arrival(ts, tc, r, t_r, w_r, i_r)
      if (t_r < 0.0_wp) return
      ks = first_event(r, ev_stick, t_r)
      call check_true('the brake sticks after the arrival', ks > 0)
      if (ks == 0) return
      t_s = r%events(ks)%t
      th_s = r%events(ks)%theta_left
      ! engaged at the arrival, the brake slips forward under Tc + T_L (and the
      ! decaying current) to a stop: the closed form's instant, to RK4's error and
      ! the event location (1e-9 dt) on a 2.7e-4 s phase
      call check('stick instant - arrival = the closed-form stopping time', t_s - t_r, &
                 stop_time(w_r, i_r, tc + t_load), rel_tol=1.0e-6_wp)
      ! the dwell: stuck from t_s to the release, its angle the stick's to 1e-12
      dwell = r%series_t > t_s .and. r%series_t < t_release
      n = count(dwell)
      call check_true('samples in the dwell (> 200)', n > 200)
      call check('angle range over the dwell (rad)', maxval(r%series_theta(1, :), mask=dwell) - &
                 minval(r%series_theta(1, :), mask=dwell), 0.0_wp, abs_tol=1.0e-12_wp)
      call check('dwell angle = the angle at the stick', maxval(abs(r%series_theta(1, :) - th_s), mask=dwell), &
                 0.0_wp, abs_tol=1.0e-12_wp)
      call check('speed over the dwell', maxval(abs(r%series_omega(1, :)), mask=dwell), 0.0_wp, abs_tol=0.0_wp)
      ! the release: the next target's time, exactly (a breakpoint of the sequence)
      kl = first_event(r, ev_slip_backward, t_s)
      call check_true('the brake opens (slips) after the dwell', kl > 0)
      if (kl > 0) call check('release instant = the next target''s time', r%events(kl)%t, t_release, abs_tol=0.0_wp)
      call check_true('no brake event inside the dwell', &
                      .not. any(r%events(:)%t > t_s .and. r%events(:)%t < t_release))
      call check('energy ledger closes (residual / scale; RK4 on L/R = 10 dt)', &
                 r%energy_residual_max/r%energy_scale, 0.0_wp, abs_tol=1.0e-9_wp)
      ! the torque the brake carries in the dwell: the load (the current has
      ! decayed as exp(-R t/L) to nothing): the constraint torque, to roundoff
      call load_model_text(deck(ts, tc, 0.9_wp), m)
      call run_model(m, r)
      call m%elements(i_brake)%e%status(0.0_wp, 0.0_wp, 0.0_wp, 0.0_wp, disp, force, contact, pairs)
      call check_true('the brake is stuck in the dwell (contact = 0)', contact == 0)
      call check('brake torque on ground in the dwell = -T_L', force, -t_load, rel_tol=1.0e-12_wp)
   end subroutine test_held_brake_holds_the_load_through_the_dwell

   !> Ts = 0.04 < T_L = 0.05 (Tc = 0.03): the brake stops the train, cannot hold
   !> it, and the load drives it backward against Tc: J w' = k_t i - (T_L - Tc).
   subroutine test_weak_brake_slips_under_the_load()
      real(wp), parameter :: ts = 0.04_wp, tc = 0.03_wp
      type(run_result_t) :: r
      real(wp) :: t_r, w_r, i_r, t_s, x_s(2), x(2), th, worst_w, worst_th, s
      integer :: ks, kb, k, n
      call test_begin('weak_brake_slips_under_the_load')
      call run_to_arrival(ts, tc, r, t_r, w_r, i_r)
      if (t_r < 0.0_wp) return
      s = stop_time(w_r, i_r, tc + t_load)
      ks = first_event(r, ev_stick, t_r)
      kb = first_event(r, ev_slip_backward, t_r)
      call check_true('stick, then slip backward at the same instant', ks > 0 .and. kb > 0)
      if (ks == 0 .or. kb == 0) return
      t_s = r%events(ks)%t
      call check('stick instant - arrival = the closed-form stopping time', t_s - t_r, s, rel_tol=1.0e-6_wp)
      call check('slip instant = stick instant (the limit cannot hold T_L)', r%events(kb)%t, t_s, abs_tol=0.0_wp)
      ! backward slip from (0, i at the stop) under f = T_L - Tc (the brake's +Tc
      ! against the motion), compared at the samples up to the release
      x_s = motion(w_r, i_r, tc + t_load, s)
      worst_w = 0.0_wp
      worst_th = 0.0_wp
      n = 0
      do k = 1, size(r%series_t)
         if (r%series_t(k) <= t_s .or. r%series_t(k) >= t_release) cycle
         n = n + 1
         x = motion(0.0_wp, x_s(2), t_load - tc, r%series_t(k) - t_s)
         worst_w = max(worst_w, abs(r%series_omega(1, k) - x(1)))
         th = slip_angle(x_s(2), t_load - tc, r%series_t(k) - t_s)
         worst_th = max(worst_th, abs(r%series_theta(1, k) - r%events(ks)%theta_left - th))
      end do
      call check_true('samples in the slip (> 200)', n > 200)
      ! scale: (T_L - Tc)/J over the 0.28 s phase (1.1 rad/s, 0.16 rad); RK4 at
      ! dt = 0.01 L/R is exact to ~1e-12 here, the stick instant to 1e-9 dt
      call check('max |w - closed form| / 1 rad/s', worst_w, 0.0_wp, abs_tol=1.0e-8_wp)
      call check('max |angle - closed form| / 1 rad', worst_th, 0.0_wp, abs_tol=1.0e-8_wp)
      call check_true('slipping backward through the dwell (no stick before the release)', &
                      .not. any(r%events(:)%t > t_s .and. r%events(:)%t < t_release .and. &
                                r%events(:)%kind == ev_stick))
      call check('energy ledger closes (residual / scale)', r%energy_residual_max/r%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-9_wp)
   end subroutine test_weak_brake_slips_under_the_load

   !> The angle travelled in time s from w = 0, current i0, under f: the integral
   !> of `motion`'s speed, w = w_p + c1 exp(l1 s) + c2 exp(l2 s) integrated exactly.
   real(wp) function slip_angle(i0, f, s) result(th)
      real(wp), intent(in) :: i0, f, s
      real(wp) :: a(2, 2), xp(2), d(2), ad(2), l1, l2, c1, c2
      call system(f, a, l1, l2, xp)
      d = [0.0_wp, i0] - xp
      ad = matmul(a, d)
      c1 = (ad(1) - l2*d(1))/(l1 - l2)
      c2 = -(ad(1) - l1*d(1))/(l1 - l2)
      th = xp(1)*s + c1*(exp(l1*s) - 1.0_wp)/l1 + c2*(exp(l2*s) - 1.0_wp)/l2
   end function slip_angle
end program test_sequence_brake
