!> The spur gear's mesh excitation (issue 26): stiffness along the path of
!> contact (fourier, table, iso6336), the static transmission error (TE
!> harmonics, tip relief, per-tooth errors, run-out) and tooth faults, with
!> known answers: a DFT of the Fourier stiffness, ISO 6336-1's c' and
!> c_gamma_alpha by hand, the unloaded TE of tip relief from the hand geometry,
!> a fault once per driver turn, the energy ledger with a parametric stiffness
!> and a moving TE, the Jacobian against finite differences, bad input.
program test_mesh_excitation
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_el_spur_gear, only: spur_gear_t
   use trainsim_mesh_excitation, only: iso_single_pair_stiffness
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, run_model, nl, jacobian_fd_error, expect_build_error
   implicit none

   character(len=*), parameter :: head = "&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                                         "&node id='a', type = 'inertia', inertia = 1.0 /"//nl// &
                                         "&node id='b', type = 'inertia', inertia = 1.0 /"//nl
   !> 20 teeth on base radius 1: base pitch 2 pi/20; m_p = 1.6; alpha = 0, phase 0: u = 20 theta/(2 pi)
   character(len=*), parameter :: spur = "&element type='spur_gear', stiffness=1e6, rb_driver=1.0, rb_driven=2.0, "// &
                                         "teeth=20, contact_ratio=1.6, approach_angle=0.0, half_backlash=0.01, "
   !> the Table 5.5 rig (Gregory, Harris and Munro) at 485 teeth/s under its load:
   !> rig_a, the mesh's excitation keys, rig_b
   character(len=*), parameter :: rig_a = "&run t_end = 0.02, dt = 8.0e-6, integrator = 'rk4' /"//nl// &
      "&node id = 'n1', type = 'inertia', inertia = 100.0 /"//nl// &
      "&node id = 'n2', type = 'inertia', inertia = 0.987 /"//nl// &
      "&node id = 'n3', type = 'inertia', inertia = 0.987 /"//nl// &
      "&node id = 'n4', type = 'inertia', inertia = 100.0 /"//nl// &
      "&element type = 'shaft', stiffness = 32000.0, damping = 0.0 /"//nl// &
      "&element type = 'spur_gear', stiffness = 234500.0, rb_driver = 3.7588, "// &
      "rb_driven = 3.7588, teeth = 32, contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = 0.005, "
   character(len=*), parameter :: rig_b = nl//"&element type = 'shaft', stiffness = 32000.0, damping = 0.0 /"//nl// &
      "&load node = 'n1', quantity = 'speed', kind = 'constant', value = 95.2286 /"//nl// &
      "&load node = 'n4', kind = 'constant', value = -798.8 /"//nl// &
      "&initial node = 'all', speed = 95.2286 /"//nl// &
      "&initial node = 'n1', angle = -0.187847 /"//nl// &
      "&initial node = 'n2', angle = -0.212810 /"//nl// &
      "&initial node = 'n3', angle = -0.214283 /"//nl// &
      "&initial node = 'n4', angle = -0.239246 /"//nl

   call suite_begin('mesh excitation: stiffness along the path of contact, static TE, faults')
   call test_fourier_stiffness_reproduces_its_harmonics()
   call test_zones_model_is_trains_two_levels()
   call test_iso6336_stiffness_matches_the_hand_calculation()
   call test_stiffness_table_interpolates_periodically()
   call test_unloaded_te_of_tip_relief_matches_hand_geometry()
   call test_pitch_errors_repeat_with_the_hunting_period()
   call test_fault_appears_once_per_driver_revolution()
   call test_energy_ledger_closes_with_excited_mesh()
   call test_excited_jacobian_matches_finite_differences()
   call test_bad_excitation_input_is_named()
   call suite_end()

contains

   !> The spur gear of a model built from `text` (its element `i`).
   subroutine spur_of(m, i, g)
      type(model_t), intent(in), target :: m
      integer, intent(in) :: i
      type(spur_gear_t), intent(out) :: g
      select type (e => m%elements(i)%e)
      type is (spur_gear_t)
         g = e
      class default
         error stop 'not a spur gear'
      end select
   end subroutine spur_of

   !> Stiffness factor at driver angle th, the zone set there first.
   real(wp) function factor_at(g, th) result(c)
      type(spur_gear_t), intent(inout) :: g
      real(wp), intent(in) :: th
      call g%init_mode(th, 0.0_wp, 0.0_wp, 0.0_wp)
      c = g%factor(th)
   end function factor_at

   !> c(u) = 1 + 0.2 cos(2 pi u) + 0.1 cos(4 pi u + 1) + 0.05 cos(6 pi u - 2):
   !> the DFT of 64 samples over one tooth period (driver angle 2 pi/20) gives
   !> back a_k/2 e^{i p_k} for k = 1..3, the mean 1, and nothing else (1e-12).
   subroutine test_fourier_stiffness_reproduces_its_harmonics()
      type(model_t) :: m
      type(spur_gear_t) :: g
      integer, parameter :: n = 64
      real(wp) :: c(0:n - 1), a(3), p(3), re, im, th
      integer :: j, k
      call test_begin('fourier_stiffness_reproduces_its_harmonics')
      a = [0.2_wp, 0.1_wp, 0.05_wp]; p = [0.0_wp, 1.0_wp, -2.0_wp]
      call load_model_text(head//spur//"stiffness_model='fourier', stiffness_harmonics=0.2, 0.1, 0.05, "// &
                           "stiffness_phases=0.0, 1.0, -2.0 /", m)
      call spur_of(m, 1, g)
      do j = 0, n - 1
         th = 7.0_wp*two_pi/20.0_wp + real(j, wp)/n*two_pi/20.0_wp   ! (an arbitrary period: the 8th tooth)
         c(j) = factor_at(g, th)
      end do
      call check('mean = 1', sum(c)/n, 1.0_wp, abs_tol=1.0e-12_wp)
      do k = 1, 8
         re = 0.0_wp; im = 0.0_wp
         do j = 0, n - 1
            re = re + c(j)*cos(two_pi*k*j/n)*2.0_wp/n
            im = im + c(j)*sin(two_pi*k*j/n)*2.0_wp/n
         end do
         if (k <= 3) then
            ! a cos(2 pi k u + p) = a cos p cos(2 pi k u) - a sin p sin(2 pi k u)
            call check('harmonic '//achar(48 + k)//' cosine part', re, a(k)*cos(p(k)), abs_tol=1.0e-12_wp)
            call check('harmonic '//achar(48 + k)//' sine part', im, -a(k)*sin(p(k)), abs_tol=1.0e-12_wp)
         else
            call check('no harmonic '//achar(48 + k), abs(re) + abs(im), 0.0_wp, abs_tol=1.0e-12_wp)
         end if
      end do
      call check('mean factor for modes', g%linear_factor(), 1.0_wp, abs_tol=1.0e-12_wp)
   end subroutine test_fourier_stiffness_reproduces_its_harmonics

   !> stiffness_model = 'zones' given or not: 1 in the single-pair zone (u in
   !> (0.6, 1)), two_pair_factor in the two-pair zone, and the mesh unexcited.
   subroutine test_zones_model_is_trains_two_levels()
      type(model_t) :: m
      type(spur_gear_t) :: g
      call test_begin('zones_model_is_trains_two_levels')
      call load_model_text(head//spur//"stiffness_model='zones', two_pair_factor=1.7 /", m)
      call spur_of(m, 1, g)
      call check('not excited', .not. g%ex%active .and. .not. g%supplies_power)
      call check('u = 0.3: two pairs, 1.7', factor_at(g, 0.3_wp*two_pi/20.0_wp) == 1.7_wp)
      call check('u = 0.8: one pair, 1', factor_at(g, 0.8_wp*two_pi/20.0_wp) == 1.0_wp)
   end subroutine test_zones_model_is_trains_two_levels

   !> ISO 6336-1 method B for z = 20/40, 20 deg, x = 0: q' = 0.04723 +
   !> 0.15551/20 + 0.25791/40 = 0.06145325, c'_th = 16.2726, C_B = 0.975,
   !> c' = 0.8 C_B c'_th = 12.6926 N/(mm um); c_gamma_alpha = c' (0.75 x 1.6 +
   !> 0.25). The element's mean stiffness is c_gamma_alpha b (b = 20 mm), and
   !> its single pair at mid path carries c' b.
   subroutine test_iso6336_stiffness_matches_the_hand_calculation()
      type(model_t) :: m
      type(spur_gear_t) :: g
      real(wp) :: cp, cg, cp_hand, k
      call test_begin('iso6336_stiffness_matches_the_hand_calculation')
      cp_hand = 0.8_wp*0.975_wp/(0.04723_wp + 0.15551_wp/20.0_wp + 0.25791_wp/40.0_wp)
      call iso_single_pair_stiffness(20.0_wp, 40.0_wp, 20.0_wp, 1.6_wp, .false., cp, cg)
      call check("c' (N/(mm um))", cp, cp_hand, rel_tol=1.0e-14_wp)
      call check("  = 12.6926", cp, 12.6926_wp, abs_tol=1.0e-4_wp)
      call check('c_gamma_alpha', cg, cp_hand*1.45_wp, rel_tol=1.0e-14_wp)
      call load_model_text("&run t_end = 1e-3, dt = 1e-6, units = 'si' /"//nl// &
                           "&node type = 'inertia', inertia = 1.0 /"//nl//"&node type = 'inertia', inertia = 1.0 /"//nl// &
                           "&element type='spur_gear', teeth_driver=20, teeth_driven=40, module=3.0, face_width=0.02, "// &
                           "backlash=1e-4, stiffness_model='iso6336' /", m)
      call spur_of(m, 1, g)
      call iso_single_pair_stiffness(20.0_wp, 40.0_wp, 20.0_wp, g%mp, .false., cp, cg)
      k = cg*1.0e9_wp*0.02_wp          ! N/(mm um) = 1e9 N/m^2, times b in m
      call check('mean mesh stiffness c_gamma_alpha b (N/m)', g%cl%law%k, k, rel_tol=1.0e-9_wp)
      ! (cmean: 4096 midpoints over a period with a jump of ~0.3 at the zone change: error < 0.3/4096)
      call check('mean of the factor over a period = 1', g%ex%cmean, 1.0_wp, abs_tol=1.0e-4_wp)
      ! the single-pair zone's middle, u = m_p/2 (the pair entered at 0 is at mid path)
      call check("single pair at mid path: c' b", factor_at(g, (g%mp/2.0_wp)*two_pi/20.0_wp - g%alpha)*k, &
                 cp*1.0e9_wp*0.02_wp, rel_tol=1.0e-9_wp)
      call check('stiffest above single', g%ex%cmax > g%ex%cmin)
   end subroutine test_iso6336_stiffness_matches_the_hand_calculation

   !> A table (0, 1.4), (0.6, 1.4), (0.6 + eps, 1), (1, 1.4)... interpolates
   !> linearly: at u = 0.3 it is 1.4; at 0.8, halfway from 1 to 1.4 over
   !> [0.7, 1]: 1 + 0.4/3.
   subroutine test_stiffness_table_interpolates_periodically()
      type(model_t) :: m
      type(spur_gear_t) :: g
      call test_begin('stiffness_table_interpolates_periodically')
      call load_model_text(head//spur//"stiffness_model='table', stiffness_roll = 0, 0.6, 0.7, 1.0, "// &
                           "stiffness_factors = 1.4, 1.4, 1.0, 1.4 /", m)
      call spur_of(m, 1, g)
      call check('u = 0.3', factor_at(g, 0.3_wp*two_pi/20.0_wp), 1.4_wp, rel_tol=1.0e-14_wp)
      call check('u = 5.8 (a later tooth)', factor_at(g, 5.8_wp*two_pi/20.0_wp), 1.0_wp + 0.4_wp/3.0_wp, rel_tol=1.0e-12_wp)
      call check('u = 0.65', factor_at(g, 0.65_wp*two_pi/20.0_wp), 1.2_wp, rel_tol=1.0e-12_wp)
   end subroutine test_stiffness_table_interpolates_periodically

   !> Linear and parabolic tip relief C_a = 1e-3 over l_a = 0.7 base pitches
   !> (m_p = 1.6, base pitch 2 pi/20 on r_b = 1). A pair entered at u = 0 is at
   !> x = u along its path; the relief of the driven tip covers x < 0.7, the
   !> driver's x > 0.9. Unloaded, the pair with the least relief touches:
   !>   u = 0.1: pairs at x = 0.1 (relief 0.6/0.7) and 1.1 (0.2/0.7): 0.2/0.7 C_a
   !>   u = 0.3: both 0.4/0.7 (the peak of the two-pair zone, C_a (1 - (m_p - 1)/(2 l_a)))
   !>   u = 0.65: one pair at 0.65: 0.05/0.7;  u = 0.8: none;  u = 0.95: 0.05/0.7
   !> (parabolic: the squares). The loaded TE, equal shares in TRAIN's zones,
   !> is the mean of the two pairs: at u = 0.1, (0.6 + 0.2)/0.7/2 C_a.
   subroutine test_unloaded_te_of_tip_relief_matches_hand_geometry()
      type(model_t) :: m
      type(spur_gear_t) :: g
      real(wp) :: u(5), r(5), c, e, pb, ca
      integer :: j, shape
      character(len=9), parameter :: shapes(2) = ['linear   ', 'parabolic']
      call test_begin('unloaded_te_of_tip_relief_matches_hand_geometry')
      pb = two_pi/20.0_wp
      ca = 1.0e-3_wp
      u = [0.1_wp, 0.3_wp, 0.65_wp, 0.8_wp, 0.95_wp]
      r = [0.2_wp, 0.4_wp, 0.05_wp, 0.0_wp, 0.05_wp]/0.7_wp
      do shape = 1, 2
         call load_model_text(head//spur//"tip_relief = 1e-3, tip_relief_length = "//num(0.7_wp*pb)// &
                              ", tip_relief_shape = '"//trim(shapes(shape))//"' /", m)
         call spur_of(m, 1, g)
         do j = 1, size(u)
            call check(trim(shapes(shape))//' unloaded TE at u = '//num(u(j)), g%ex%unloaded_te(u(j)), &
                       ca*r(j)**shape, abs_tol=1.0e-15_wp)
         end do
         call g%ex%at_roll(0.1_wp, c, e)
         call check(trim(shapes(shape))//' loaded TE at u = 0.1 (mean of the pairs)', e, &
                    ca*0.5_wp*((0.6_wp/0.7_wp)**shape + (0.2_wp/0.7_wp)**shape), abs_tol=1.0e-15_wp)
      end do
   end subroutine test_unloaded_te_of_tip_relief_matches_hand_geometry

   !> Pitch errors on 3-tooth driver and 4-tooth driven lists (a 3:4 pair in
   !> the constants form: rb 1 and 4/3): the TE in the single-pair zone is
   !> p1(i1) + p2(i2) of the pair's teeth, i1 = m mod 3 + 1, i2 = m mod 4 + 1,
   !> and repeats after lcm(3, 4) = 12 mesh cycles, not before.
   subroutine test_pitch_errors_repeat_with_the_hunting_period()
      type(model_t) :: m
      type(spur_gear_t) :: g
      real(wp) :: p1(3), p2(4), e, c
      integer :: mm
      logical :: ok, repeats
      call test_begin('pitch_errors_repeat_with_the_hunting_period')
      p1 = [1.0e-4_wp, -2.0e-4_wp, 0.5e-4_wp]
      p2 = [3.0e-4_wp, 0.0_wp, -1.0e-4_wp, 2.0e-4_wp]
      call load_model_text(head//"&element type='spur_gear', stiffness=1e6, rb_driver=1.0, rb_driven="// &
                           num(4.0_wp/3.0_wp)//", teeth=3, contact_ratio=1.6, approach_angle=0.0, "// &
                           "half_backlash=0.01, pitch_errors_driver = 1e-4, -2e-4, 0.5e-4, "// &
                           "pitch_errors_driven = 3e-4, 0, -1e-4, 2e-4 /", m)
      call spur_of(m, 1, g)
      call check('hunting period 12 mesh cycles', g%ex%hunting_period(), 12.0_wp, abs_tol=0.0_wp)
      ok = .true.
      do mm = 0, 23
         call g%ex%at_roll(mm + 0.8_wp, c, e)
         ok = ok .and. abs(e - (p1(mod(mm, 3) + 1) + p2(mod(mm, 4) + 1))) < 1.0e-18_wp
      end do
      call check('single-pair TE = p1(i1) + p2(i2) over two hunting periods', ok)
      repeats = .true.
      do mm = 1, 11
         call g%ex%at_roll(mm + 0.8_wp, c, e)
         repeats = repeats .and. abs(e - (p1(1) + p2(1))) < 1.0e-18_wp
      end do
      call check('no shorter period than 12 for this pattern', .not. repeats)
   end subroutine test_pitch_errors_repeat_with_the_hunting_period

   !> Tooth 5 of the 20-tooth driver at stiffness factor 0.4: sampled over
   !> three driver turns, the stiffness drops in exactly three windows, one
   !> turn (2 pi) apart, each as long as the tooth's mesh (m_p teeth); in its
   !> single-pair zone the factor is 0.4.
   subroutine test_fault_appears_once_per_driver_revolution()
      type(model_t) :: m
      type(spur_gear_t) :: g
      integer, parameter :: n = 6000
      real(wp) :: th, c, start(10), width
      integer :: j, k
      logical :: low, was_low
      call test_begin('fault_appears_once_per_driver_revolution')
      call load_model_text(head//spur//"two_pair_factor = 1.8, fault_tooth = 5, fault_stiffness_factor = 0.4 /", m)
      call spur_of(m, 1, g)
      k = 0; was_low = .false.; width = 0.0_wp
      do j = 0, n - 1
         th = 3.0_wp*two_pi*(j + 0.5_wp)/n
         c = factor_at(g, th)
         low = c < 0.99_wp*merge(1.8_wp, 1.0_wp, g%pairs == 2)
         if (low .and. .not. was_low .and. k < 10) then
            k = k + 1
            start(k) = th
         end if
         if (low) width = width + 3.0_wp*two_pi/n
         if (low .and. g%pairs == 1) call check_quiet(c == 0.4_wp)
         was_low = low
      end do
      call check('three drops in three turns', k == 3)
      if (k == 3) then
         call check('  one turn apart', start(2) - start(1), two_pi, abs_tol=2.0_wp*3.0_wp*two_pi/n)
         call check('  and again', start(3) - start(2), two_pi, abs_tol=2.0_wp*3.0_wp*two_pi/n)
         ! tooth 5 enters at m = 4: u = 4, theta = 4 (2 pi/20)
         call check('  the first as tooth 5 enters', start(1), 4.0_wp*two_pi/20.0_wp, abs_tol=2.0_wp*3.0_wp*two_pi/n)
      end if
      call check('each m_p = 1.6 teeth long', width/3.0_wp, 1.6_wp*two_pi/20.0_wp, abs_tol=4.0_wp*two_pi/n)
   end subroutine test_fault_appears_once_per_driver_revolution

   subroutine check_quiet(ok)
      logical, intent(in) :: ok
      if (.not. ok) call check('faulted single pair at 0.4', ok)
   end subroutine check_quiet

   !> The Table 5.5 rig, loaded, with (a) a three-harmonic Fourier stiffness
   !> and a three-harmonic TE, (b) ISO-like geometry: tip relief, pitch errors,
   !> run-out and a fault (jumps at the zone events), under RK4 and CVODE: the
   !> ledger (stored + dissipated - input - E0) closes to 1e-10 of its scale
   !> (measured 3e-15, 5e-13, with tooth friction 2e-15; CVODE 4e-12 under 1e-8). Dropping either term of
   !> the excitation's work, 1/2 p^2 dk/dt or -F de/dt, leaves 4e-7.
   subroutine test_energy_ledger_closes_with_excited_mesh()
      type(model_t) :: m
      type(run_result_t) :: res
      character(len=*), parameter :: fourier = "stiffness_model = 'fourier', stiffness_harmonics = 0.2, 0.1, 0.05, "// &
         "stiffness_phases = 0.0, 1.0, 2.0, te_harmonics = 2.0e-4, 1.0e-4, 5.0e-5, te_phases = 0.5, 0.0, -1.0 /"
      character(len=*), parameter :: errors = "tip_relief = 3e-4, tip_relief_length = 0.3, tip_relief_shape = "// &
         "'parabolic', runout_driver = 1e-4, runout_driven_phase = 1.0, runout_driven = 5e-5, fault_tooth = 3, "// &
         "fault_stiffness_factor = 0.7, pitch_errors_driver = 1e-4, 2e-4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, "// &
         "0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, -1e-4 /"
      call test_begin('energy_ledger_closes_with_excited_mesh')
      call load_model_text(rig_a//fourier//rig_b, m)
      call run_model(m, res)
      call check('fourier + TE, rk4: residual / scale', res%energy_residual_max/res%energy_scale, 0.0_wp, abs_tol=1.0e-10_wp)
      call load_model_text(rig_a//errors//rig_b, m)
      call run_model(m, res)
      call check('relief, pitch, run-out, fault, rk4: residual / scale', res%energy_residual_max/res%energy_scale, &
                 0.0_wp, abs_tol=1.0e-10_wp)
      ! with tooth friction (issue 26 item 3) on the excited mesh's force: its loss in the ledger too
      call load_model_text(rig_a//fourier(:len(fourier) - 1)//", tooth_friction = 0.06 /"//rig_b, m)
      call run_model(m, res)
      call check('fourier + TE + tooth friction, rk4: residual / scale', res%energy_residual_max/res%energy_scale, &
                 0.0_wp, abs_tol=1.0e-10_wp)
      call load_model_text(replace_rk4(rig_a)//fourier//rig_b, m)
      call run_model(m, res)
      call check('fourier + TE, cvode-bdf: residual / scale', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-8_wp)
   end subroutine test_energy_ledger_closes_with_excited_mesh

   !> The excited mesh's analytic Jacobian (the TE's e' and e'' terms) against
   !> central differences of the right-hand side.
   subroutine test_excited_jacobian_matches_finite_differences()
      type(model_t) :: m
      real(wp) :: err, scale
      call test_begin('excited_jacobian_matches_finite_differences')
      call load_model_text(rig_a//"stiffness_model = 'fourier', stiffness_harmonics = 0.2, 0.1, "// &
                           "te_harmonics = 2.0e-4, 1.0e-4, runout_driver = 1e-4 /"//rig_b, m)
      call jacobian_fd_error(m, 0.0_wp, err, scale)
      call check('|J - J_fd| / |J| < 1e-6', err/scale < 1.0e-6_wp)
      call load_model_text(rig_a//"stiffness_model = 'fourier', stiffness_harmonics = 0.2, 0.1, te_harmonics = 2.0e-4, "// &
                           "tooth_friction = 0.06, tooth_friction_model = 'speed' /"//rig_b, m)
      call jacobian_fd_error(m, 0.0_wp, err, scale)
      call check('with tooth friction: |J - J_fd| / |J| < 1e-6', err/scale < 1.0e-6_wp)
   end subroutine test_excited_jacobian_matches_finite_differences

   subroutine test_bad_excitation_input_is_named()
      call test_begin('bad_excitation_input_is_named')
      call expect_error(head//spur//"tip_relief = 1e-3, tip_relief_length = 0.3 /", "key 'tip_relief_length'")
      call expect_error(head//spur//"stiffness_model = 'table', stiffness_roll = 0, 0.5, 1, "// &
                        "stiffness_factors = 1.4, 1.0, 1.3 /", "not periodic")
      call expect_error(head//spur//"stiffness_model = 'fourier', stiffness_harmonics = 0.2, -0.1 /", &
                        "key 'stiffness_harmonics'")
      call expect_error(head//spur//"te_harmonics = 1e-4, 2e-4, te_phases = 0.0 /", "key 'te_phases'")
      call expect_error(head//spur//"stiffness_model = 'fourier', stiffness_harmonics = 0.6, 0.5 /", &
                        "key 'stiffness_harmonics'")
      call expect_error(head//spur//"stiffness_model = 'fourier' /", "stiffness_harmonics")
      call expect_error(head//spur//"stiffness_model = 'splines' /", "key 'stiffness_model'")
      call expect_error(head//spur//"stiffness_model = 'iso6336' /", "key 'stiffness_model'")
      call expect_error(head//spur//"pitch_errors_driver = 1e-4, 2e-4 /", "key 'pitch_errors_driver'")
      call expect_error(head//spur//"fault_tooth = 21, fault_stiffness_factor = 0.5 /", "key 'fault_tooth'")
      call expect_error(head//spur//"fault_tooth = 2, fault_stiffness_factor = 1.5 /", "key 'fault_stiffness_factor'")
      call expect_error(head//spur//"runout_driver = -1e-4 /", "key 'runout_driver'")
   end subroutine test_bad_excitation_input_is_named

   !> Building the deck fails with an input error whose message names `key`, the file and the group.
   subroutine expect_error(text, key)
      character(len=*), intent(in) :: text, key
      call expect_build_error(text, key, where=.true.)
   end subroutine expect_error

   function replace_rk4(s) result(r)
      character(len=*), intent(in) :: s
      character(len=:), allocatable :: r
      integer :: i
      i = index(s, "'rk4'")
      r = s(:i - 1)//"'cvode-bdf'"//s(i + 5:)
   end function replace_rk4

   function num(x) result(s)
      real(wp), intent(in) :: x
      character(len=:), allocatable :: s
      character(len=32) :: b
      write (b, '(es24.16)') x
      s = trim(adjustl(b))
   end function num
end program test_mesh_excitation
