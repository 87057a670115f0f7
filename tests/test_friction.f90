!> Friction with sticking (D-81): the analytic cases of issue 23 on the
!> friction elements and the constraint machinery, under RK4 and SUNDIALS.
!> Each tolerance says where it comes from.
program test_friction
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_event, only: ev_stick, ev_slip_forward, ev_slip_backward
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, run_model, nl
   implicit none

   character(len=*), parameter :: integrators(3) = [character(len=10) :: 'rk4', 'cvode-bdf', 'arkode-dp']

   call suite_begin('friction that sticks: bearing friction, brake, clutch, one-way clutch')
   call test_ramp_breaks_away_at_the_static_limit()
   call test_clutch_engagement_conserves_momentum()
   call test_held_brake_does_not_drift()
   call test_stick_slip_oscillator_phases()
   call test_one_way_clutch_drives_one_way_only()
   call test_redundant_stuck_loop_holds_without_crash()
   call suite_end()

contains

   !> The ledger (stored + dissipated - input - E0) closes: RK4 to roundoff
   !> (1e-9 of the energy scale), SUNDIALS to ten times the ledger states' own
   !> absolute tolerance, 1e-6 (1 + E) (energy_atol_factor, trainsim_sundials_callbacks).
   logical function ledger_closes(r, k) result(ok)
      type(run_result_t), intent(in) :: r
      integer, intent(in) :: k
      if (k == 1) then
         ok = r%energy_residual_max < 1.0e-9_wp*r%energy_scale
      else
         ok = r%energy_residual_max < 1.0e-5_wp*(1.0_wp + r%energy_scale)
      end if
   end function ledger_closes

   !> An inertia J on bearing friction (static Ts, sliding Tc) under T = a t:
   !> stuck until a t = Ts, then J w' = a t - Tc.
   subroutine test_ramp_breaks_away_at_the_static_limit()
      real(wp), parameter :: j = 2.0_wp, a = 10.0_wp, ts = 5.0_wp, tc = 3.0_wp, t_end = 1.5_wp
      real(wp) :: t0, w_exact, th_exact
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: k, n_slip
      call test_begin('ramp_breaks_away_at_the_static_limit')
      do k = 1, size(integrators)
         call load_model_text("&run t_end = 1.5, dt = 1.0e-3, output_interval = 1.0e-2, integrator = '"// &
                              trim(integrators(k))//"' /"//nl// &
                              "&node id = 'disk', type = 'inertia', inertia = 2.0 /"//nl// &
                              "&node id = 'ground', type = 'fixed' /"//nl// &
                              "&element id = 'bearing', type = 'bearing_friction', left = 'disk', right = 'ground', "// &
                              "torque_sliding = 3.0, torque_static = 5.0 /"//nl// &
                              "&load node = 'disk', kind = 'ramp', value0 = 0.0, value1 = 20.0, t0 = 0.0, t1 = 2.0 /", m)
         call run_model(m, r)
         t0 = ts/a
         w_exact = (0.5_wp*a*(t_end**2 - t0**2) - tc*(t_end - t0))/j
         th_exact = (a/6.0_wp*(t_end**3 - t0**3) - 0.5_wp*a*t0**2*(t_end - t0) - 0.5_wp*tc*(t_end - t0)**2)/j
         n_slip = count(r%events(:)%kind == ev_slip_forward)
         call check(trim(integrators(k))//': one break-away, forward (the load drives it forward)', n_slip == 1 .and. &
                    size(r%events) == 1)
         if (n_slip /= 1) cycle
         ! event location to the run's event tolerance (1e-9 dt by default; 1e-8 s leaves room for CVODE's root finder)
         call check(trim(integrators(k))//': break-away at a t = Ts (t = 0.5 s) to 1e-8 s', &
                    abs(r%events(1)%t - t0) < 1.0e-8_wp)
         ! the row's force: the torque on the right node (ground) just after, the sliding friction +Tc
         call check(trim(integrators(k))//': torque on ground right after the break-away = +Tc', &
                    abs(r%events(1)%force - tc) < 1.0e-9_wp)
         ! closed form w(t_end); RK4 at dt = 1e-3 on a cubic angle is exact to roundoff between events,
         ! the integrators' tolerance (rtol 1e-8) for the others
         call check(trim(integrators(k))//': speed at t_end the closed form to 1e-6 relative', &
                    abs(r%y_final(2) - w_exact) < 1.0e-6_wp*abs(w_exact))
         call check(trim(integrators(k))//': angle at t_end the closed form to 1e-6 relative', &
                    abs(r%y_final(1) - th_exact) < 1.0e-6_wp*abs(th_exact))
         call check(trim(integrators(k))//': energy ledger closes to the integrator''s tolerance', ledger_closes(r, k))
      end do
   end subroutine test_ramp_breaks_away_at_the_static_limit

   !> Two inertias at different speeds, a clutch engaging at t_e: they end at
   !> the common speed (J1 w1 + J2 w2)/(J1 + J2) whatever the friction law, and
   !> the clutch dissipates J1 J2 / (2 (J1 + J2)) (w1 - w2)^2.
   subroutine test_clutch_engagement_conserves_momentum()
      real(wp), parameter :: j1 = 0.5_wp, j2 = 1.5_wp, w1 = 20.0_wp, w2 = -4.0_wp
      real(wp) :: wc, loss
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: k
      call test_begin('clutch_engagement_conserves_momentum')
      wc = (j1*w1 + j2*w2)/(j1 + j2)
      loss = 0.5_wp*j1*j2/(j1 + j2)*(w1 - w2)**2
      do k = 1, size(integrators)
         call load_model_text("&run t_end = 2.0, dt = 1.0e-3, output_interval = 1.0e-2, integrator = '"// &
                              trim(integrators(k))//"' /"//nl// &
                              "&node id = 'a', type = 'inertia', inertia = 0.5 /"//nl// &
                              "&node id = 'b', type = 'inertia', inertia = 1.5 /"//nl// &
                              "&element id = 'clutch', type = 'clutch', left = 'a', right = 'b', "// &
                              "torque_sliding = 8.0, torque_static = 10.0, stribeck_speed = 2.0, viscous = 0.05, "// &
                              "engagement_times = 0.0, 0.2, 0.4, engagement_values = 0.0, 0.0, 1.0 /"//nl// &
                              "&initial node = 'a', speed = 20.0 /"//nl// &
                              "&initial node = 'b', speed = -4.0 /", m)
         call run_model(m, r)
         call check(trim(integrators(k))//': one stick event, nothing after it', &
                    size(r%events) == 1 .and. count(r%events(:)%kind == ev_stick) == 1)
         ! momentum is conserved by the element's own torques (tl = -tr) exactly, by the integrator to roundoff
         call check(trim(integrators(k))//': common speed from momentum to 1e-9 relative', &
                    abs(r%y_final(2) - wc) < 1.0e-9_wp*abs(w1) .and. abs(r%y_final(4) - wc) < 1.0e-9_wp*abs(w1))
         call check(trim(integrators(k))//': stuck: both speeds bit for bit equal', r%y_final(2) == r%y_final(4))
         ! the dissipated energy (state n_states + 1) against the closed form, to the integrator's tolerance
         call check(trim(integrators(k))//': clutch dissipated J1 J2/(2(J1+J2)) dw^2 to 1e-6', &
                    abs(r%y_final(m%n_states + 1) - loss) < 1.0e-6_wp*loss)
         call check(trim(integrators(k))//': energy ledger closes to the integrator''s tolerance', ledger_closes(r, k))
      end do
   end subroutine test_clutch_engagement_conserves_momentum

   !> A brake engaged at standstill holds a node against a constant load for a
   !> 1 000 s dwell: the relative angle stays constant to 1e-12 (issue 23).
   subroutine test_held_brake_does_not_drift()
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: k
      call test_begin('held_brake_does_not_drift')
      do k = 1, 2
         call load_model_text("&run t_end = 1000.0, dt = 1.0e-2, output_interval = 1.0, integrator = '"// &
                              trim(integrators(k))//"' /"//nl// &
                              "&node id = 'table', type = 'inertia', inertia = 800.0 /"//nl// &
                              "&node id = 'ground', type = 'fixed' /"//nl// &
                              "&element id = 'brake', type = 'brake', left = 'table', right = 'ground', "// &
                              "torque_sliding = 400.0, torque_static = 500.0 /"//nl// &
                              "&initial node = 'table', angle = 1.2345 /"//nl// &
                              "&load node = 'table', kind = 'constant', value = 450.0 /", m)
         call run_model(m, r)
         call check(trim(integrators(k))//': no event (450 < 500 N m held)', size(r%events) == 0)
         call check(trim(integrators(k))//': angle constant to 1e-12 over 1000 s', &
                    abs(r%y_final(1) - 1.2345_wp) < 1.0e-12_wp)
         call check(trim(integrators(k))//': speed exactly 0', r%y_final(2) == 0.0_wp)
      end do
   end subroutine test_held_brake_does_not_drift

   !> Mass-on-belt stick-slip: an inertia J tied to ground by a spring k, on a
   !> belt turning at v through Coulomb friction (Ts, Tc). Stuck (w = v) until
   !> k x = Ts; then slipping, J x'' = -k x + Tc about x_c = Tc/k: a harmonic
   !> motion of amplitude A = sqrt((x_s - x_c)^2 + (v/wn)^2) that sticks again
   !> when w returns to v. Slip lasts (2 pi - 2 atan(d wn / v))/wn, d = x_s - x_c;
   !> stuck, it rides the belt from there back to x_s.
   subroutine test_stick_slip_oscillator_phases()
      real(wp), parameter :: j = 1.0_wp, kk = 100.0_wp, v = 0.5_wp, ts = 10.0_wp, tc = 6.0_wp
      real(wp) :: wn, xs, xc, d, t_stick, t_slip, x_re
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: k, i, n
      real(wp), allocatable :: ev_t(:)
      integer, allocatable :: ev_k(:)
      call test_begin('stick_slip_oscillator_phases')
      wn = sqrt(kk/j)
      xs = ts/kk
      xc = tc/kk
      d = xs - xc
      ! slipping: x - xc = d cos(wn s) + (v/wn) sin(wn s) (s from break-away), w = v again
      ! when -d wn sin + v cos = v: wn s = 2 pi - 2 atan(d wn/v)  (the non-trivial root)
      t_slip = (2.0_wp*acos(-1.0_wp) - 2.0_wp*atan(d*wn/v))/wn
      x_re = xc + d*cos(wn*t_slip) + v/wn*sin(wn*t_slip)       ! = xc - d
      t_stick = (xs - x_re)/v                                   ! stuck, moving with the belt
      do k = 1, size(integrators)
         call load_model_text("&run t_end = 3.0, dt = 1.0e-4, output_interval = 1.0e-2, integrator = '"// &
                              trim(integrators(k))//"' /"//nl// &
                              "&node id = 'block', type = 'inertia', inertia = 1.0 /"//nl// &
                              "&node id = 'belt', type = 'inertia', inertia = 1.0 /"//nl// &
                              "&node id = 'ground', type = 'fixed' /"//nl// &
                              "&element id = 'spring', type = 'shaft', left = 'block', right = 'ground', "// &
                              "stiffness = 100.0 /"//nl// &
                              "&element id = 'contact', type = 'bearing_friction', left = 'block', right = 'belt', "// &
                              "torque_sliding = 6.0, torque_static = 10.0 /"//nl// &
                              "&initial node = 'block', speed = 0.5 /"//nl// &
                              "&load node = 'belt', quantity = 'speed', kind = 'constant', value = 0.5 /", m)
         call run_model(m, r)
         n = size(r%events)
         ev_t = r%events(:)%t
         ev_k = r%events(:)%kind
         call check(trim(integrators(k))//': alternating slip and stick events (>= 4)', n >= 4)
         if (n < 4) cycle
         call check(trim(integrators(k))//': first event a break-away backward at t = x_s/v', &
                    ev_k(1) == ev_slip_backward .and. abs(ev_t(1) - xs/v) < 1.0e-7_wp)
         do i = 2, n
            if (mod(i, 2) == 0) then
               call check(trim(integrators(k))//': slip phase lasts the closed form to 1e-6 s', &
                          ev_k(i) == ev_stick .and. abs(ev_t(i) - ev_t(i - 1) - t_slip) < 1.0e-6_wp)
            else
               call check(trim(integrators(k))//': stick phase lasts the closed form to 1e-6 s', &
                          ev_k(i) == ev_slip_backward .and. abs(ev_t(i) - ev_t(i - 1) - t_stick) < 1.0e-6_wp)
            end if
         end do
         call check(trim(integrators(k))//': energy ledger closes to the integrator''s tolerance', ledger_closes(r, k))
      end do
   end subroutine test_stick_slip_oscillator_phases

   !> A freewheel between a driven hub (left) and a wheel: while the hub drives,
   !> both accelerate together (J w' = T - d w, J = J1 + J2); when the drive
   !> stops and the hub's damping brakes it, the wheel overruns (the clutch frees).
   subroutine test_one_way_clutch_drives_one_way_only()
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: k
      call test_begin('one_way_clutch_drives_one_way_only')
      do k = 1, 2
         call load_model_text("&run t_end = 2.0, dt = 1.0e-3, output_interval = 1.0e-2, integrator = '"// &
                              trim(integrators(k))//"' /"//nl// &
                              "&node id = 'hub', type = 'inertia', inertia = 1.0, damping = 2.0 /"//nl// &
                              "&node id = 'wheel', type = 'inertia', inertia = 3.0 /"//nl// &
                              "&element id = 'freewheel', type = 'one_way_clutch', left = 'hub', right = 'wheel' /"//nl// &
                              "&load node = 'hub', kind = 'step', value0 = 8.0, value1 = 0.0, t_step = 1.0 /", m)
         call run_model(m, r)
         ! locked from the start (both at rest); freed when the drive ends (the hub's damping then pulls it back)
         call check(trim(integrators(k))//': one event, the freewheel frees at t = 1 s', &
                    size(r%events) == 1 .and. count(r%events(:)%kind == ev_slip_backward) == 1)
         if (size(r%events) /= 1) cycle
         call check(trim(integrators(k))//': ... at t = 1 s to 1e-8', abs(r%events(1)%t - 1.0_wp) < 1.0e-8_wp)
         ! after t = 1 the wheel coasts at the speed both had: w(1) of J w' = 8 - 2 w, J = 4
         ! RK4 at dt = 1e-3 on an exponential: 1e-12; CVODE at rtol 1e-8: 100 rtol of global error
         call check(trim(integrators(k))//': the wheel coasts at 4 (1 - exp(-0.5)) to 1e-6 relative', &
                    abs(r%y_final(4) - 4.0_wp*(1.0_wp - exp(-0.5_wp))) < 1.0e-6_wp*1.57_wp)
         call check(trim(integrators(k))//': energy ledger closes to the integrator''s tolerance', ledger_closes(r, k))
      end do
   end subroutine test_one_way_clutch_drives_one_way_only
   !> Three disks, each braked to ground, and clutches joining them in a loop
   !> (a, b), (b, c), (c, a): every element stuck is five redundant rows on
   !> three nodes. The solve drops the redundant rows (no crash, no NaN), every
   !> disk stays exactly where it is under loads within the limits; then the
   !> brakes open (engagement to 0 at t = 1 s) and the clutches carry the three
   !> disks as one body: J_tot w' = sum of the loads.
   subroutine test_redundant_stuck_loop_holds_without_crash()
      type(model_t) :: m
      type(run_result_t) :: r
      character(len=:), allocatable :: brk, clu
      integer :: k
      real(wp) :: w_exact
      call test_begin('redundant_stuck_loop_holds_without_crash')
      brk = "type = 'brake', right = 'g', torque_sliding = 40.0, torque_static = 50.0, "// &
            "engagement_times = 0.0, 1.0, 1.001, engagement_values = 1.0, 1.0, 0.0 /"//nl
      clu = "type = 'clutch', torque_sliding = 80.0, torque_static = 100.0 /"//nl
      do k = 1, 2
         call load_model_text("&run t_end = 2.0, dt = 1.0e-3, output_interval = 1.0e-2, integrator = '"// &
                              trim(integrators(k))//"' /"//nl// &
                              "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl// &
                              "&node id = 'b', type = 'inertia', inertia = 2.0 /"//nl// &
                              "&node id = 'c', type = 'inertia', inertia = 3.0 /"//nl// &
                              "&node id = 'g', type = 'fixed' /"//nl// &
                              "&element id = 'ba', left = 'a', "//brk//"&element id = 'bb', left = 'b', "//brk// &
                              "&element id = 'bc', left = 'c', "//brk// &
                              "&element id = 'cab', left = 'a', right = 'b', "//clu// &
                              "&element id = 'cbc', left = 'b', right = 'c', "//clu// &
                              "&element id = 'cca', left = 'c', right = 'a', "//clu// &
                              "&load node = 'a', kind = 'constant', value = 30.0 /"//nl// &
                              "&load node = 'c', kind = 'constant', value = -12.0 /", m)
         call run_model(m, r)
         ! the brakes slip when their limit falls below what they hold: the clutches stay stuck
         call check(trim(integrators(k))//': only the three brakes switch (slip), the loop of clutches holds', &
                    size(r%events) == 3 .and. all(r%events(:)%element <= 3))
         ! after the brakes open the body of J = 6 accelerates at 18/6 = 3 rad/s^2 (the brakes' sliding
         ! torque e(t) Tc acts during the 1 ms ramp: bounded by 40 N m * 1 ms / 6 = 6.7e-3 rad/s)
         w_exact = 3.0_wp*(2.0_wp - 1.0_wp)
         call check(trim(integrators(k))//': the joined disks turn together, bit for bit', &
                    r%y_final(2) == r%y_final(4) .and. r%y_final(4) == r%y_final(6))
         call check(trim(integrators(k))//': at 3 rad/s^2 after the brakes open (to 7e-3 rad/s)', &
                    abs(r%y_final(2) - w_exact) < 7.0e-3_wp)
         call check(trim(integrators(k))//': energy ledger closes to the integrator''s tolerance', ledger_closes(r, k))
      end do
   end subroutine test_redundant_stuck_loop_holds_without_crash
end program test_friction
