!> RK4 step advice and element linearisation (D-25): RK4's stability region
!> along a ray, the limit of trains with closed-form eigenvalues, each element's
!> `linearise` in the three states, and the stiffest state of the
!> runaway_at_safe_dt reproducer (modes 149.6, 1681.5, 5690.8 Hz from an
!> engineer's independent numpy; its run at dt = 1e-4 s, which the old advice
!> called safe, runs away). tests/check_dt_advice.py checks the reproducer's
!> limit against numpy to 1e-6 and runs every bundled deck at 0.95 x the advice.
program test_stability
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_element, only: lin_state_t, lin_start, lin_closed, lin_stiffest, lin_contact_closed, &
                               lin_zone_single, lin_zone_stiffest
   use trainsim_modes, only: modes_t, compute_modes, rk4_dt_limit, rk4_ray_radius
   use trainsim_el_helical_gear, only: helical_contact_length
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, load_model_text, nl
   implicit none

   call suite_begin('RK4 step advice and element linearisation')
   call test_rk4_region_radius_on_the_axes()
   call test_undamped_oscillator_limit_is_two_root_two_over_omega()
   call test_damped_oscillator_limit_follows_its_ray()
   call test_spur_gear_linearises_per_state()
   call test_helical_gear_stiffest_is_longest_contact_line()
   call test_yang_sun_damping_is_restitution_bound()
   call test_runaway_reproducer_stiffest_state()
   call suite_end()

contains

   !> |R(z)| = 1 at z = 2 sqrt(2) i (|R(iy)|^2 = 1 - y^6/72 + y^8/576) and at the
   !> real root -2.785293563405282 of 1 + x + x^2/2 + x^3/6 + x^4/24 = 1.
   subroutine test_rk4_region_radius_on_the_axes()
      integer :: k
      call test_begin('rk4_region_radius_on_the_axes')
      call check('imaginary axis: 2 sqrt 2', rk4_ray_radius((0.0_wp, 1.0_wp)), sqrt(8.0_wp), rel_tol=1.0e-13_wp)
      call check('negative real axis: 2.7853', rk4_ray_radius((-1.0_wp, 0.0_wp)), 2.785293563405282_wp, rel_tol=1.0e-12_wp)
      ! the tabulated rays (dt_bound's rk4_radii) start stepping at 2.5, below the region's
      ! least radius over the left half-plane (2.6156): the same bracket, the same radius
      call check('rays from 2.5 give the same radii', real(count([(rk4_ray_radius(ray(k)) /= &
                 rk4_ray_radius(ray(k), from=250), k=0, 180)]), wp), 0.0_wp, abs_tol=0.0_wp)
   end subroutine test_rk4_region_radius_on_the_axes

   !> The k-th of dt_bound's 181 tabulated rays, k/2 deg from the imaginary axis.
   complex(wp) function ray(k)
      integer, intent(in) :: k
      real(wp) :: psi
      psi = 0.25_wp*two_pi*real(k, wp)/180   ! as rk4_radii
      ray = cmplx(-sin(psi), cos(psi), wp)
   end function ray

   !> One disk on a shaft to ground: lambda = +-i sqrt(k/J), limit 2 sqrt 2 / omega.
   subroutine test_undamped_oscillator_limit_is_two_root_two_over_omega()
      type(model_t) :: m
      type(error_t), allocatable :: err
      real(wp) :: h, om
      call test_begin('undamped_oscillator_limit_is_two_root_two_over_omega')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                           "&node type = 'fixed' /"//nl// &
                           "&node type = 'inertia', inertia = 2.0 /"//nl// &
                           "&element type = 'shaft', stiffness = 8.0e4 /", m)
      call rk4_dt_limit(m, lin_start, h, om, err)
      call check('no error', .not. allocated(err))
      call check('omega = sqrt(k/J) = 200 rad/s', om, 200.0_wp, rel_tol=1.0e-12_wp)
      call check('dt limit = 2 sqrt 2 / 200', h, sqrt(8.0_wp)/200.0_wp, rel_tol=1.0e-12_wp)
   end subroutine test_undamped_oscillator_limit_is_two_root_two_over_omega

   !> J = 1 on a shaft k = 1e4, c = 100 to ground: omega_n = 100, zeta = 0.5,
   !> lambda = 100 (-1/2 +- i sqrt 3/2), 30 degrees into the left half-plane;
   !> the limit is r/100 with |R(r e^{i 2 pi/3})| = 1, r = 2.622542 (a root of
   !> the polynomial |R|^2 - 1 on that ray, found independently by numpy).
   subroutine test_damped_oscillator_limit_follows_its_ray()
      type(model_t) :: m
      type(error_t), allocatable :: err
      real(wp) :: h, om, f, z
      call test_begin('damped_oscillator_limit_follows_its_ray')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                           "&node type = 'fixed' /"//nl// &
                           "&node type = 'inertia', inertia = 1.0 /"//nl// &
                           "&element type = 'shaft', stiffness = 1.0e4, damping = 100.0 /", m)
      call rk4_dt_limit(m, lin_start, h, om, err, freq_hz=f, damping_ratio=z)
      call check('no error', .not. allocated(err))
      call check('damping ratio 0.5', z, 0.5_wp, rel_tol=1.0e-12_wp)
      call check('damped frequency 100 sqrt(3)/2 / 2 pi Hz', f, 50.0_wp*sqrt(3.0_wp)/two_pi, rel_tol=1.0e-12_wp)
      call check('dt limit 2.622542/100 (RK4 region at 120 degrees)', h, 2.622542491830483e-2_wp, rel_tol=1.0e-9_wp)
   end subroutine test_damped_oscillator_limit_follows_its_ray

   !> Spur gear k = 1e6, r1 = 1, r2 = 2, c2 = 1.7, open at the start, in its
   !> single-pair zone (u = 20 (0 + 0.1)/(2 pi) = 0.318 > m_p - 1 = 0.3):
   !> as it starts it is open (K = 0); closed, K = k g g^T with g = (1, -2);
   !> stiffest, 1.7 k g g^T.
   subroutine test_spur_gear_linearises_per_state()
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      real(wp) :: k(2, 2), c(2, 2)
      type(lin_state_t) :: two_pair_open
      call test_begin('spur_gear_linearises_per_state')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                           "&node type = 'inertia', inertia = 1.0 /"//nl// &
                           "&node type = 'inertia', inertia = 4.0 /"//nl// &
                           "&element type='spur_gear', stiffness=1e6, rb_driver=1.0, rb_driven=2.0, teeth=20, "// &
                           "contact_ratio=1.3, approach_angle=0.1, half_backlash=0.01, two_pair_factor=1.7 /", m)
      call compute_modes(m, md, err)   ! sets the modes as at t_start
      call check('modes as it starts: no error', .not. allocated(err))
      call m%elements(1)%e%linearise(lin_start, 1.0_wp, 0.25_wp, k, c)
      call check('open at the start: no stiffness', all(k == 0.0_wp))
      call m%elements(1)%e%linearise(lin_closed, 1.0_wp, 0.25_wp, k, c)
      call check('closed, single-pair zone: k r1^2', k(1, 1), 1.0e6_wp, rel_tol=1.0e-14_wp)
      call check('closed, single-pair zone: -k r1 r2', k(1, 2), -2.0e6_wp, rel_tol=1.0e-14_wp)
      call m%elements(1)%e%linearise(lin_stiffest, 1.0_wp, 0.25_wp, k, c)
      call check('stiffest: two_pair_factor k r2^2', k(2, 2), 1.7_wp*4.0e6_wp, rel_tol=1.0e-14_wp)
      two_pair_open%zone = lin_zone_stiffest
      call m%elements(1)%e%linearise(two_pair_open, 1.0_wp, 0.25_wp, k, c)
      call check('two-pair zone but contacts as at the start: still open', all(k == 0.0_wp))
      ! modes --stiffest: the relative mode, omega^2 = c2 k (r1^2/J1 + r2^2/J2) = 1.7e6 (1 + 1)
      call compute_modes(m, md, err, state=lin_stiffest)
      call check('stiffest mode: sqrt(3.4e6)/2 pi Hz', md%freq_hz(md%n), sqrt(3.4e6_wp)/two_pi, rel_tol=1.0e-10_wp)
   end subroutine test_spur_gear_linearises_per_state

   !> The helical gear's stiffest factor is the longest contact line over a mesh
   !> period (eq. 6.1 sampled at 20001 points), its single-pair one the shortest.
   subroutine test_helical_gear_stiffest_is_longest_contact_line()
      type(model_t) :: m
      real(wp) :: k(2, 2), c(2, 2), lc, lmax, lmin, mf, ptb, zeta, kl
      type(lin_state_t) :: single
      integer :: i
      call test_begin('helical_gear_stiffest_is_longest_contact_line')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                           "&node type = 'inertia', inertia = 1.0 /"//nl// &
                           "&node type = 'inertia', inertia = 1.0 /"//nl// &
                           "&element type='helical_gear', rb_driver=2.0, rb_driven=2.0, teeth=30, "// &
                           "profile_contact_ratio=1.55, base_helix_angle=20.0, face_width=1.1, half_backlash=0.002 /", m)
      zeta = 20.0_wp*two_pi/360.0_wp
      ptb = two_pi*2.0_wp/30.0_wp
      mf = 1.1_wp*tan(zeta)/ptb
      kl = 30.0e6_wp/17.6_wp
      lmax = 0.0_wp; lmin = huge(1.0_wp)
      do i = 0, 20000
         lc = helical_contact_length(real(i, wp)/20000.0_wp, 1.55_wp, mf, ptb, zeta)
         lmax = max(lmax, lc); lmin = min(lmin, lc)
      end do
      call m%elements(1)%e%linearise(lin_stiffest, 1.0_wp, 1.0_wp, k, c)
      call check('stiffest: E/17.6 max L_c r1^2', k(1, 1), kl*lmax*4.0_wp, rel_tol=1.0e-6_wp)
      single%contact = lin_contact_closed
      single%zone = lin_zone_single
      call m%elements(1)%e%linearise(single, 1.0_wp, 1.0_wp, k, c)
      call check('single: E/17.6 min L_c r1^2', k(1, 1), kl*lmin*4.0_wp, rel_tol=1.0e-6_wp)
   end subroutine test_helical_gear_stiffest_is_longest_contact_line

   !> yang_sun with a constant e = 0.5: D V_i = 6 (1 - e) k / ((2e-1)^2 + 3) = k,
   !> so the damping at the largest compression of an impact is
   !> c D p_max = sqrt(c k m_eff) (D-25); keyed joint r = 1, J = 2 and 2:
   !> m_eff = 1/(1/2 + 1/2) = 1, k = 1e6 -> C = 1e3 along the key face.
   subroutine test_yang_sun_damping_is_restitution_bound()
      type(model_t) :: m
      real(wp) :: k(2, 2), c(2, 2)
      type(lin_state_t) :: half
      call test_begin('yang_sun_damping_is_restitution_bound')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                           "&node type = 'inertia', inertia = 2.0 /"//nl// &
                           "&node type = 'inertia', inertia = 2.0 /"//nl// &
                           "&element type='keyed_joint', diameter=2.0, half_clearance=0.01, stiffness=1e6, "// &
                           "restitution_law='constant', restitution=0.5 /", m)
      call m%elements(1)%e%linearise(lin_closed, 0.5_wp, 0.5_wp, k, c)
      call check('C = sqrt(k m_eff) r^2', c(1, 1), 1.0e3_wp, rel_tol=1.0e-12_wp)
      call check('C couples the faces: -C r1 r2', c(1, 2), -1.0e3_wp, rel_tol=1.0e-12_wp)
      half = lin_closed
      half%impact_scale = 0.5_wp
      call m%elements(1)%e%linearise(half, 0.5_wp, 0.5_wp, k, c)
      call check('impact_scale halves it', c(1, 1), 500.0_wp, rel_tol=1.0e-12_wp)
      call m%elements(1)%e%linearise(lin_start, 0.5_wp, 0.5_wp, k, c)
      call check('open at the start: no damping', all(c == 0.0_wp))
   end subroutine test_yang_sun_damping_is_restitution_bound

   !> The reproducer: modes of the stiffest state 149.56, 1681.46, 5690.79 Hz
   !> (independent numpy: k from eq. 3.9 for 20:80, m = 2 mm, 20 deg, F = 20 mm,
   !> times 1.8). Its RK4 limit is set by the 5690.8 Hz mode, nearly undamped
   !> (Goldsmith impact damping below 100 in/s only raises RK4's radius there):
   !> 2 sqrt 2 / (2 pi 5690.79) = 7.9103e-5 s, not the 1.059e-4 s the old advice
   !> (single-pair zone, no damping) gave; at 1e-4 s the run runs away.
   subroutine test_runaway_reproducer_stiffest_state()
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      real(wp) :: h, om, f, z
      call test_begin('runaway_reproducer_stiffest_state')
      call load_model('tests/decks/runaway_at_safe_dt.nml', m)
      call compute_modes(m, md, err, state=lin_stiffest)
      call check('modes: no error', .not. allocated(err))
      call check('mode 2: 149.56 Hz', md%freq_hz(2), 149.558079_wp, rel_tol=1.0e-6_wp)
      call check('mode 3: 1681.46 Hz', md%freq_hz(3), 1681.46399_wp, rel_tol=1.0e-6_wp)
      call check('mode 4: 5690.79 Hz', md%freq_hz(4), 5690.78505_wp, rel_tol=1.0e-6_wp)
      call rk4_dt_limit(m, lin_stiffest, h, om, err, freq_hz=f, damping_ratio=z)
      call check('limit: no error', .not. allocated(err))
      call check('set by the 5690.8 Hz mode', f, 5690.78505_wp, rel_tol=1.0e-4_wp)
      call check('dt limit 2 sqrt 2 / (2 pi 5690.79 Hz) = 7.910e-5 s', h, sqrt(8.0_wp)/(two_pi*5690.78505_wp), &
                 rel_tol=1.0e-4_wp)
      call check('below the dt = 1e-4 s that runs away', h < 1.0e-4_wp)
   end subroutine test_runaway_reproducer_stiffest_state
end program test_stability
