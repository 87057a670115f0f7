!> `trainsim gear` and `trainsim key` (src/analysis/trainsim_gear_calc.f90): the
!> thesis's printed gear constants to their printed precision (App. E, Tables 5.3
!> and 5.5), the keyed-joint curve against the FEM datum of Fig. 4.41, the SI form
!> against the inch form, and the unit slips each plausibility check must name.
program test_gear_calc
   use trainsim_kinds, only: wp, pi
   use trainsim_error, only: error_t
   use trainsim_units, only: make_units
   use trainsim_contact, only: contact_law_t, fit_loose
   use trainsim_gear_calc, only: gear_input_t, gear_result_t, gear_calc, key_input_t, key_result_t, key_calc
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   implicit none

   call suite_begin('gear and key calculators')
   call test_app_e_gears_reproduce_appendix_e()
   call test_app_e_gears_give_table_5_3_contact_ratio_and_alpha()
   call test_app_e_driven_inertia_for_350_hz()
   call test_table_5_5_gears_reproduce_table_5_5()
   call test_yang_sun_d_equals_the_contact_law()
   call test_stiffness_scales_with_youngs_modulus()
   call test_si_input_gives_the_inch_results_converted()
   call test_unit_slips_are_errors_that_name_the_slip()
   call test_key_curve_matches_fig_4_41()
   call suite_end()

contains

   !> App. E's gears: 28 teeth, P = 8, 20 deg, F = 0.700 in.
   function app_e() result(g)
      type(gear_input_t) :: g
      type(error_t), allocatable :: err
      call make_units('in-lbf-s', g%units, err)
      g%teeth1 = 28.0_wp; g%teeth2 = 28.0_wp
      g%diametral_pitch = 8.0_wp; g%pressure_angle_deg = 20.0_wp; g%face_width = 0.7_wp
      g%backlash = 0.002_wp
   end function app_e

   subroutine test_app_e_gears_reproduce_appendix_e()
      type(gear_input_t) :: g
      type(gear_result_t) :: r
      type(error_t), allocatable :: err
      call test_begin('app_e_gears_reproduce_appendix_e')
      g = app_e()
      g%stiffness_per_width = 25.76e6_wp   ! App. F listing's per-inch stiffness
      call gear_calc(g, r, err)
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      ! App. E.3, to the digits printed there
      call check('r_p = 1.750 in', r%rp1, 1.750_wp, abs_tol=5.0e-4_wp)
      call check('a = 0.125 in', r%addendum, 0.125_wp, abs_tol=5.0e-4_wp)
      call check('R_o = 1.8750 in', r%ro1, 1.8750_wp, abs_tol=5.0e-5_wp)
      call check('R_b1 = 1.6445 in', r%rb1, 1.6445_wp, abs_tol=5.0e-5_wp)
      call check('R_b2 = 1.6445 in', r%rb2, 1.6445_wp, abs_tol=5.0e-5_wp)
      call check('p_b = 0.36902 in', r%base_pitch, 0.36902_wp, abs_tol=5.0e-6_wp)
      ! App. E.1: J = 1.148e-3 r_p^4 F for steel
      call check('J1 = 7.537e-3 lbf in s^2', r%j1, 7.537e-3_wp, abs_tol=5.0e-7_wp)
      call check('k = 18.03e6 lbf/in (25.76e6 x 0.700)', r%stiffness, 18.03e6_wp, abs_tol=5.0e3_wp)
      ! App. E prints z = 0.6043 from R_b rounded to 1.6445 before squaring
      ! (dz/dR_b = -3.65: 3.8e-5 in of rounding moves z by -1.4e-4); the unrounded
      ! R_b = 1.644462 gives z = 0.60445 (docs/elements.md, "trainsim gear")
      call check('z = 0.60445 in (R_b unrounded)', r%length_of_action, 0.60445_wp, abs_tol=1.0e-5_wp)
      call check('App. E z = 0.6043 differs by its R_b rounding (1.4e-4)', &
                 abs(r%length_of_action - 0.6043_wp - 1.4e-4_wp) < 2.0e-5_wp)
      call check('gear ratio 1', r%gear_ratio, 1.0_wp, abs_tol=1.0e-15_wp)
      call check('b = backlash / 2', r%half_backlash, 0.001_wp, rel_tol=1.0e-15_wp)
   end subroutine test_app_e_gears_reproduce_appendix_e

   subroutine test_app_e_gears_give_table_5_3_contact_ratio_and_alpha()
      type(gear_result_t) :: r
      type(error_t), allocatable :: err
      call test_begin('app_e_gears_give_table_5_3_contact_ratio_and_alpha')
      call gear_calc(app_e(), r, err)
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      ! Table 5.3 RE15, RE16 (App. E's hand values 1.6376 / 0.18374 carry its z slip)
      call check('m_p = 1.6380 (Table 5.3 RE15)', r%contact_ratio, 1.6380_wp, abs_tol=5.0e-5_wp)
      call check('alpha = 0.1838 rad (Table 5.3 RE16)', r%approach_angle, 0.1838_wp, abs_tol=5.0e-5_wp)
      call check('App. E 1.6376 is outside the printed precision', abs(r%contact_ratio - 1.6376_wp) > 5.0e-5_wp)
   end subroutine test_app_e_gears_give_table_5_3_contact_ratio_and_alpha

   subroutine test_app_e_driven_inertia_for_350_hz()
      type(gear_input_t) :: g
      type(gear_result_t) :: r
      type(error_t), allocatable :: err
      call test_begin('app_e_driven_inertia_for_350_hz')
      g = app_e()
      g%stiffness = 18.03e6_wp           ! App. E.3 computes J2 from k as printed, 18.03e6
      g%target_frequency = 350.0_wp
      call gear_calc(g, r, err)
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      call check('J2 = 10.082 for 350 Hz (App. E.3, Table 5.3 RN21)', r%j2_target, 10.082_wp, abs_tol=5.0e-4_wp)
      ! and the inertia does put the driven gear at 350 Hz on the mesh spring
      call check('sqrt(k R_b2^2 / J2) / 2 pi = 350 Hz', sqrt(r%stiffness*r%rb2**2/r%j2_target)/(2.0_wp*pi), &
                 350.0_wp, rel_tol=1.0e-12_wp)
   end subroutine test_app_e_driven_inertia_for_350_hz

   subroutine test_table_5_5_gears_reproduce_table_5_5()
      type(gear_input_t) :: g
      type(gear_result_t) :: r
      type(error_t), allocatable :: err
      call test_begin('table_5_5_gears_reproduce_table_5_5')
      g = app_e()
      g%teeth1 = 32.0_wp; g%teeth2 = 32.0_wp; g%diametral_pitch = 4.0_wp; g%face_width = 0.5_wp
      g%backlash = 0.01_wp
      call gear_calc(g, r, err)
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      call check('R_b = 3.7588 in (RE22, RE23)', r%rb1, 3.7588_wp, abs_tol=5.0e-5_wp)
      call check('m_p = 1.6676 (RE25)', r%contact_ratio, 1.6676_wp, abs_tol=5.0e-5_wp)
      call check('alpha = 0.1637 rad (RE26)', r%approach_angle, 0.1637_wp, abs_tol=5.0e-5_wp)
      call check('half backlash 0.005 in (RE27)', r%half_backlash, 0.005_wp, rel_tol=1.0e-15_wp)
   end subroutine test_table_5_5_gears_reproduce_table_5_5

   !> D of eq. (3.12) at V_i is the D the gear element's contact law uses.
   subroutine test_yang_sun_d_equals_the_contact_law()
      type(gear_input_t) :: g
      type(gear_result_t) :: r
      type(error_t), allocatable :: err
      type(contact_law_t) :: law
      call test_begin('yang_sun_d_equals_the_contact_law')
      g = app_e()
      g%approach_velocity = 12.0_wp
      call gear_calc(g, r, err)
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      law%k = r%stiffness
      call law%begin_contact(12.0_wp, .false.)
      call check('e (Goldsmith, App. E.2)', r%restitution, law%e, rel_tol=1.0e-14_wp)
      call check('D (eq. 3.12)', r%damping_d, law%d, rel_tol=1.0e-14_wp)
   end subroutine test_yang_sun_d_equals_the_contact_law

   !> Eq. (3.8) is proportional to 1/E: aluminium (10e6 psi) has a third of steel's stiffness.
   subroutine test_stiffness_scales_with_youngs_modulus()
      type(gear_input_t) :: g
      type(gear_result_t) :: steel, alu
      type(error_t), allocatable :: err
      call test_begin('stiffness_scales_with_youngs_modulus')
      g = app_e()
      call gear_calc(g, steel, err)
      g%youngs_modulus = 10.0e6_wp
      g%density = 2.0_wp*1.148e-3_wp/pi/2.9_wp
      call gear_calc(g, alu, err)
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      call check('eq. 3.9 at 20 deg: 1e7/(0.39 + 1.49 cos 20) per in', steel%stiffness_per_width, &
                 1.0e7_wp/(0.39_wp + 1.49_wp*cos(20.0_wp*pi/180.0_wp)), rel_tol=1.0e-14_wp)
      call check('k(E = 10e6) = k(steel) / 3', alu%stiffness, steel%stiffness/3.0_wp, rel_tol=1.0e-14_wp)
      call check('J scales with density', alu%j1, steel%j1/2.9_wp, rel_tol=1.0e-14_wp)
   end subroutine test_stiffness_scales_with_youngs_modulus

   !> The same pair in SI (module 3.175 mm, face 17.78 mm): every result is the inch one converted.
   subroutine test_si_input_gives_the_inch_results_converted()
      type(gear_input_t) :: g
      type(gear_result_t) :: ri, rs
      type(error_t), allocatable :: err
      real(wp), parameter :: m_per_in = 0.0254_wp, n_per_lbf = 4.4482216152605_wp
      call test_begin('si_input_gives_the_inch_results_converted')
      g = app_e()
      g%approach_velocity = 10.0_wp
      g%target_frequency = 350.0_wp
      call gear_calc(g, ri, err)
      call make_units('si', g%units, err)
      g%diametral_pitch = -huge(1.0_wp); g%module_mm = 3.175_wp
      g%face_width = 0.7_wp*m_per_in; g%backlash = 0.002_wp*m_per_in
      g%approach_velocity = 10.0_wp*m_per_in
      call gear_calc(g, rs, err)
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      call check('R_b', rs%rb1, ri%rb1*m_per_in, rel_tol=1.0e-13_wp)
      call check('m_p', rs%contact_ratio, ri%contact_ratio, rel_tol=1.0e-13_wp)
      call check('k', rs%stiffness, ri%stiffness*n_per_lbf/m_per_in, rel_tol=1.0e-13_wp)
      call check('J1', rs%j1, ri%j1*n_per_lbf*m_per_in, rel_tol=1.0e-13_wp)
      call check('J2 at 350 Hz', rs%j2_target, ri%j2_target*n_per_lbf*m_per_in, rel_tol=1.0e-13_wp)
      call check('D', rs%damping_d, ri%damping_d*n_per_lbf/m_per_in**2, rel_tol=1.0e-12_wp)
      call check('steel density 7811 kg/m^3 (App. E.1 constant)', rs%density, 7810.6_wp, abs_tol=0.5_wp)
   end subroutine test_si_input_gives_the_inch_results_converted

   subroutine test_unit_slips_are_errors_that_name_the_slip()
      type(gear_input_t) :: g
      call test_begin('unit_slips_are_errors_that_name_the_slip')
      g = app_e(); g%pressure_angle_deg = 0.3491_wp
      call expect_error(g, 'pressure angle in radians', 'looks like radians')
      g = app_e(); g%density = 0.282_wp
      call expect_error(g, 'weight density for mass density', 'weight density')
      g = app_e(); g%diametral_pitch = -huge(1.0_wp); g%module_mm = 0.003_wp
      call expect_error(g, 'module in metres', 'metres')
      g = app_e(); g%diametral_pitch = -huge(1.0_wp); g%module_mm = 0.06_wp; g%teeth1 = 10.0_wp
      call expect_error(g, 'base radius of 0.28 mm', 'base radius')
      g = app_e(); g%face_width = 700.0_wp
      call expect_error(g, 'face width in thousandths', 'face width')
      g = app_e(); g%backlash = 0.5_wp
      call expect_error(g, 'backlash beyond the base pitch', 'base pitch')
      g = app_e(); g%teeth2 = 28.5_wp
      call expect_error(g, 'fractional teeth', 'whole number')
      g = app_e(); g%module_mm = 3.0_wp
      call expect_error(g, 'both pitch and module', 'exactly one')
   end subroutine test_unit_slips_are_errors_that_name_the_slip

   subroutine expect_error(g, what, phrase)
      type(gear_input_t), intent(in) :: g
      character(len=*), intent(in) :: what, phrase
      type(gear_result_t) :: r
      type(error_t), allocatable :: err
      call gear_calc(g, r, err)
      call check(what//': an error', allocated(err))
      if (allocated(err)) call check(what//": the message says '"//phrase//"'", index(err%message, phrase) > 0)
   end subroutine expect_error

   !> Fig. 4.41: D = 1.000 in, loose fit, T = 30000 lb-in: lineal 300444 lb/in/in,
   !> angular 75111 lb-in/rad/in (FEM; eq. 4.36 passes within 0.2 % of it).
   subroutine test_key_curve_matches_fig_4_41()
      type(key_input_t) :: q
      type(key_result_t) :: r
      type(error_t), allocatable :: err
      integer :: n
      call test_begin('key_curve_matches_fig_4_41')
      call make_units('in-lbf-s', q%units, err)
      q%diameter = 1.0_wp; q%key_length = 1.0_wp; q%fit = fit_loose; q%torque_max = 30000.0_wp
      call key_calc(q, r, err)
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      n = size(r%torque)
      call check('last torque 30000 lb-in', r%torque(n), 30000.0_wp, rel_tol=1.0e-12_wp)
      call check('key force 2T/d = 60000 lb', r%key_force(n), 60000.0_wp, rel_tol=1.0e-12_wp)
      call check('lineal stiffness 300444 lb/in/in (0.2 %)', r%lineal(n, 1), 300444.0_wp, rel_tol=2.0e-3_wp)
      call check('angular stiffness 75111 lb-in/rad/in (0.2 %)', r%angular(n, 1), 75111.0_wp, rel_tol=2.0e-3_wp)
      call check('first key force 100 lbf (bottom of the fits)', r%key_force(1), 100.0_wp, rel_tol=1.0e-12_wp)
      call make_units('si', q%units, err)   ! a 25 m shaft is a slip (mm given for m)
      q%diameter = 25.0_wp; q%key_length = 30.0_wp
      call key_calc(q, r, err)
      call check('a 25 m shaft is an error', allocated(err))
   end subroutine test_key_curve_matches_fig_4_41
end program test_gear_calc
