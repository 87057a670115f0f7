!> Issue 3 must-shows: App. C/D first impact, the Chapter III cases, Table 5.4,
!> event-location convergence, energy over many impacts, restitution, free
!> flight through a coupling, a DC motor starting a geared load.
program test_clearance_verification
   use trainsim_kinds, only: wp, pi
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: ev_contact_front, ev_contact_rear, ev_separation, ev_zone
   use trainsim_strings, only: str
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, load_model_text, run_model, nl
   implicit none

   call suite_begin('clearance verification (thesis ch. III-V, issue 3)')
   call test_table5_3_first_impact_matches_appendix_c_and_d()
   call test_case1_impacts_alternate_faces_and_lose_energy()
   call test_case2_front_faces_only_then_persistent_contact()
   call test_case3_keeps_accelerating_with_momentum_balance()
   call test_table5_4_keyed_joint_one_impact_with_law_restitution()
   call test_event_location_converges_with_dt()
   call test_undamped_impacts_conserve_energy_over_200_impacts()
   call test_coupling_free_flight_is_straight_line()
   call test_thesis_mode_first_impact_close_to_located()
   call suite_end()

contains

   !> Restitution of F = k p + D p pdot for a free impact (Hunt-Crossley,
   !> exact): G(-v_out) = G(v_in) with G(v) = v/l - ln(1 + l v)/l^2, l = D/k.
   real(wp) function hunt_crossley_restitution(d, k, v) result(e)
      real(wp), intent(in) :: d, k, v
      real(wp) :: l, a, b, m, ga
      integer :: it
      l = d/k
      ga = hc_g(v, l)
      a = 0.0_wp; b = min(v, 0.999999999_wp/l)
      do it = 1, 200
         m = 0.5_wp*(a + b)
         if (hc_g(-m, l) < ga) then
            a = m
         else
            b = m
         end if
      end do
      e = 0.5_wp*(a + b)/v
   end function hunt_crossley_restitution

   !> G(v) = v/l - ln(1 + l v)/l^2, an energy-like invariant of the impact.
   pure real(wp) function hc_g(x, l) result(g)
      real(wp), intent(in) :: x, l
      g = x/l - log(1.0_wp + l*x)/l**2
   end function hc_g

   subroutine test_table5_3_first_impact_matches_appendix_c_and_d()
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: peak_c, dur_c, x, peak_sim, a, b
      integer :: i
      call test_begin('table5_3_first_impact_matches_appendix_c_and_d')
      call load_model('verification/table5_3/table5_3.nml', m)
      call run_model(m, r)
      ! App. C: delta(t) = 0.0001968 sin(80322 t) + 4.0009e-6 sin(160644 t)
      a = 0.0001968_wp; b = 4.0009e-6_wp
      x = pi/2.0_wp
      do i = 1, 50   ! Newton on a cos x + 2 b cos 2x = 0
         x = x - (a*cos(x) + 2.0_wp*b*cos(2.0_wp*x))/(-a*sin(x) - 4.0_wp*b*sin(2.0_wp*x))
      end do
      peak_c = a*sin(x) + b*sin(2.0_wp*x)
      dur_c = pi/80322.0_wp
      peak_sim = maxval(r%series_disp(1, :)) - 0.001_wp
      call check('first contact at the free-flight time b/(rb w) (s)', r%events(1)%t, 0.001_wp/(1.6445_wp*10.0_wp), &
                 rel_tol=1.0e-9_wp)
      call check('D vs App. D 1.285e5, 0.5 %', r%events(1)%damping, 1.285e5_wp, rel_tol=5.0e-3_wp)
      call check('peak penetration vs App. C, 0.5 %', peak_sim, peak_c, rel_tol=5.0e-3_wp)
      call check('contact duration vs App. C, 0.5 %', r%events(1)%duration, dur_c, rel_tol=5.0e-3_wp)
      call check('one impact, then separation', r%events(2)%kind == ev_separation .and. r%el(1)%impacts == 1)
   end subroutine test_table5_3_first_impact_matches_appendix_c_and_d

   subroutine test_case1_impacts_alternate_faces_and_lose_energy()
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: i, k, last
      real(wp) :: vprev
      logical :: alternate, decreasing
      call test_begin('case1_impacts_alternate_faces_and_lose_energy')
      call load_model('verification/chapter3/case1.nml', m)
      call run_model(m, r)
      alternate = .true.; decreasing = .true.
      last = 0; vprev = huge(1.0_wp); k = 0
      do i = 1, size(r%events)
         associate (ev => r%events(i))
            if (ev%kind /= ev_contact_front .and. ev%kind /= ev_contact_rear) cycle
            k = k + 1
            if (ev%kind == last) alternate = .false.
            last = ev%kind
            if (.not. ev%approach_velocity < vprev) decreasing = .false.
            vprev = ev%approach_velocity
         end associate
      end do
      write (*, '(a,i0,a,es12.5,a)') '    case I: ', k, ' impacts, last approach velocity ', vprev, ' in/s'
      call check('more than 50 impacts in 0.05 s', k > 50)
      call check('impacts alternate front / rear faces', alternate)
      call check('every impact slower than the one before (energy lost)', decreasing)
      call check('relative speed decays (last V_i < 80 % of the first)', vprev < 0.8_wp*r%events(1)%approach_velocity)
   end subroutine test_case1_impacts_alternate_faces_and_lose_energy

   subroutine test_case2_front_faces_only_then_persistent_contact()
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: i, n_front, n_rear, last_sep, last_imp
      real(wp) :: p_static
      call test_begin('case2_front_faces_only_then_persistent_contact')
      call load_model('verification/chapter3/case2.nml', m)
      call run_model(m, r)
      n_front = 0; n_rear = 0; last_sep = 0; last_imp = 0
      do i = 1, size(r%events)
         if (r%events(i)%kind == ev_contact_front) then
            n_front = n_front + 1; last_imp = i
         end if
         if (r%events(i)%kind == ev_contact_rear) n_rear = n_rear + 1
         if (r%events(i)%kind == ev_separation) last_sep = i
      end do
      write (*, '(a,i0,a,es12.5,a)') '    case II: ', n_front, ' front impacts; contact closed for good at ', &
         r%events(last_imp)%t, ' s'
      call check('no rear-face impact', n_rear == 0)
      call check('several front impacts', n_front >= 2)
      call check('the last event is an impact: contact persists', last_imp > last_sep)
      call check('in contact at the end', r%series_disp(1, size(r%series_t)) > 0.001_wp)
      ! settles at the static penetration of 1000 lb-in through rb = 1.6445 in (c = 1)
      p_static = 1000.0_wp/1.6445_wp/18.03e6_wp
      call check('final penetration = static deflection (5 %)', r%series_disp(1, size(r%series_t)) - 0.001_wp, &
                 p_static, rel_tol=5.0e-2_wp)
   end subroutine test_case2_front_faces_only_then_persistent_contact

   subroutine test_case3_keeps_accelerating_with_momentum_balance()
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: i
      logical :: front_only
      call test_begin('case3_keeps_accelerating_with_momentum_balance')
      call load_model('verification/chapter3/case3.nml', m)
      call run_model(m, r)
      front_only = .true.
      do i = 1, size(r%events)
         if (r%events(i)%kind == ev_contact_rear) front_only = .false.
      end do
      call check('front-face impacts only', front_only)
      ! equal base radii: the mesh force is internal, J1 w1 + J2 w2 = T t exactly
      call check('angular momentum = applied impulse (lb-in-s)', 7.537e-3_wp*r%y_final(2) + 10.082_wp*r%y_final(4), &
                 1000.0_wp*0.02_wp, rel_tol=1.0e-9_wp)
      call check('gear 2 speed = T t / (J1 + J2) in contact (1 %)', r%y_final(4), 1000.0_wp*0.02_wp/(7.537e-3_wp + 10.082_wp), &
                 rel_tol=1.0e-2_wp)
      call check('still accelerating at the end', r%series_omega(2, size(r%series_t)) > &
                 r%series_omega(2, size(r%series_t) - 100))
   end subroutine test_case3_keeps_accelerating_with_momentum_balance

   subroutine test_table5_4_keyed_joint_one_impact_with_law_restitution()
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: e_meas, e_hc, e_law, v
      call test_begin('table5_4_keyed_joint_one_impact_with_law_restitution')
      call load_model('verification/table5_4/table5_4.nml', m)
      call run_model(m, r)
      call check('exactly one impact in the run', r%el(1)%impacts == 1 .and. size(r%events) == 2)
      v = 10.0_wp*2.6312_wp/2.0_wp
      call check('approach velocity = (d/2) w (in/s)', r%events(1)%approach_velocity, v, rel_tol=1.0e-12_wp)
      e_law = 1.0_wp - 0.019_wp*v**0.48_wp
      call check('restitution used is Goldsmith at V_i', r%events(1)%restitution, e_law, rel_tol=1.0e-12_wp)
      e_meas = r%events(2)%approach_velocity/r%events(1)%approach_velocity
      e_hc = hunt_crossley_restitution(r%events(1)%damping, 2.03e6_wp, v)
      call check('rebound ratio = exact Hunt-Crossley restitution of the D used', e_meas, e_hc, rel_tol=1.0e-6_wp)
      ! eq. (3.12) is Yang and Sun's first-order fit: error O((1 - e)^2)
      call check('rebound ratio = law restitution within (1-e)^2', e_meas, e_law, abs_tol=(1.0_wp - e_law)**2)
   end subroutine test_table5_4_keyed_joint_one_impact_with_law_restitution

   subroutine test_event_location_converges_with_dt()
      type(model_t) :: m1, m4
      type(run_result_t) :: r1, r4
      integer :: i, n
      real(wp) :: dt_max, dv_max
      call test_begin('event_location_converges_with_dt')
      call load_model('verification/chapter3/case1.nml', m1)
      m1%run%t_end = 0.005_wp
      m4 = m1
      m4%run%dt = m1%run%dt/4.0_wp
      call run_model(m1, r1)
      call run_model(m4, r4)
      n = min(size(r1%events), size(r4%events))
      call check('same number of events at dt and dt/4', size(r1%events) == size(r4%events) .and. n >= 10)
      dt_max = 0.0_wp; dv_max = 0.0_wp
      do i = 1, n
         dt_max = max(dt_max, abs(r1%events(i)%t - r4%events(i)%t)/r4%events(i)%t)
         if (r4%events(i)%approach_velocity /= 0.0_wp) dv_max = max(dv_max, &
            abs(r1%events(i)%approach_velocity - r4%events(i)%approach_velocity)/abs(r4%events(i)%approach_velocity))
      end do
      call check('event times at dt and dt/4 agree to 1e-6 relative', dt_max, 0.0_wp, abs_tol=1.0e-6_wp)
      call check('approach velocities at dt and dt/4 agree to 1e-6 relative', dv_max, 0.0_wp, abs_tol=1.0e-6_wp)
   end subroutine test_event_location_converges_with_dt

   subroutine test_undamped_impacts_conserve_energy_over_200_impacts()
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: wh, bound
      call test_begin('undamped_impacts_conserve_energy_over_200_impacts')
      call load_model_text('&run t_end = 0.04, dt = 5e-7 /'//nl// &
                           "&node type='inertia', inertia=7.537e-3 /"//nl//"&node type='inertia', inertia=10.082 /"//nl// &
                           "&element type='spur_gear', stiffness=18.03e6, rb_driver=1.6445, rb_driven=1.6445, teeth=28,"// &
                           " contact_ratio=1.638, approach_angle=0.1838, half_backlash=0.001,"// &
                           " restitution_law='constant', restitution=1.0 /"//nl// &
                           "&initial node='n1', speed=10.0 /", m)
      call run_model(m, r)
      write (*, '(a,i0,a)') '    ', r%el(1)%impacts, ' impacts'
      call check('at least 200 impacts', r%el(1)%impacts >= 200)
      call check('no energy dissipated (D = 0)', r%y_final(m%n_states + 1), 0.0_wp, abs_tol=1.0e-14_wp)
      ! RK4 loses (w h)^6/72 of the contact-mode energy per step, over pi/(w h)
      ! steps per contact; w = sqrt(k rb^2 (1/J1 + 1/J2)). Bound with a factor 1.5.
      wh = sqrt(18.03e6_wp*1.6445_wp**2*(1.0_wp/7.537e-3_wp + 1.0_wp/10.082_wp))*5.0e-7_wp
      bound = 1.5_wp*r%el(1)%impacts*(pi/wh)*wh**6/72.0_wp
      call check('energy conserved to the RK4 drift bound '//str(bound), r%energy_residual_max/r%energy_scale, &
                 0.0_wp, abs_tol=bound)
      call check('last rebound speed = first approach speed (1e-6)', r%events(size(r%events))%approach_velocity, &
                 16.445_wp, rel_tol=1.0e-6_wp)
   end subroutine test_undamped_impacts_conserve_energy_over_200_impacts

   subroutine test_coupling_free_flight_is_straight_line()
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: i, j, k, nseg
      real(wp) :: t0, th0, w0, dev
      call test_begin('coupling_free_flight_is_straight_line')
      ! a disk rattling in a 0.02 rad dead zone against ground, linear law with damping
      call load_model_text('&run t_end = 0.2, dt = 1e-5, output_interval = 1e-5 /'//nl// &
                           "&node id='g', type='fixed' /"//nl//"&node id='d', type='inertia', inertia=0.01 /"//nl// &
                           "&element type='clearance_coupling', left='d', right='g', clearance=0.02, stiffness=1e4,"// &
                           " contact_damping=0.5 /"//nl//"&initial node='d', speed=2.0 /", m)
      call run_model(m, r)
      nseg = 0; dev = 0.0_wp
      do i = 1, size(r%events)
         if (r%events(i)%kind /= ev_separation) cycle
         if (i == size(r%events)) exit
         ! from this separation to the next contact: theta = th0 + w0 (t - t0)
         t0 = r%events(i)%t
         do j = 1, size(r%series_t)
            if (r%series_t(j) >= t0) exit
         end do
         th0 = r%series_theta(2, j); w0 = r%series_omega(2, j)
         nseg = nseg + 1
         do k = j, size(r%series_t)
            if (r%series_t(k) > r%events(i + 1)%t) exit
            dev = max(dev, abs(r%series_theta(2, k) - (th0 + w0*(r%series_t(k) - r%series_t(j)))), &
                      abs(r%series_omega(2, k) - w0))
         end do
      end do
      write (*, '(a,i0,a)') '    ', nseg, ' free-flight segments'
      call check('several free-flight segments', nseg >= 3)
      call check('free flight: constant speed, straight line in angle (1e-12)', dev, 0.0_wp, abs_tol=1.0e-12_wp)
      call check('speed after each contact lower (damped)', abs(r%y_final(2)) < 2.0_wp)
   end subroutine test_coupling_free_flight_is_straight_line

   subroutine test_thesis_mode_first_impact_close_to_located()
      type(model_t) :: m
      type(run_result_t) :: r
      call test_begin('thesis_mode_first_impact_close_to_located')
      call load_model('verification/table5_3/table5_3.nml', m)
      m%run%integrator = 'rk4-thesis'
      call run_model(m, r)
      ! App. F detects contact at the first step start past b: within one dt late
      call check('thesis-mode contact detected within one dt after the true time', &
                 r%events(1)%t - 0.001_wp/16.445_wp >= 0.0_wp .and. r%events(1)%t - 0.001_wp/16.445_wp <= 5.0e-7_wp)
      call check('thesis-mode D within 1 % of App. D', r%events(1)%damping, 1.285e5_wp, rel_tol=1.0e-2_wp)
      call check('thesis-mode contact duration within 2 % of App. C', r%events(1)%duration, pi/80322.0_wp, &
                 rel_tol=2.0e-2_wp)
      if (.false.) print *, str(1), ev_zone
   end subroutine test_thesis_mode_first_impact_close_to_located
end program test_clearance_verification
