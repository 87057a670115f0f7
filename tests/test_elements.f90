!> Types for the hot-path tests: a shaft and an inertia extended to change
!> their physics but not their hot-path claims (`linear_spring`,
!> `plain_inertia`), as a careless plug-in might.
module test_elements_doubles
   use trainsim_kinds, only: wp
   use trainsim_el_shaft, only: shaft_t
   use trainsim_node_inertia, only: inertia_node_t
   use trainsim_el_keyed_joint, only: keyed_joint_t
   use trainsim_element, only: hot_form_t
   implicit none
   private
   public :: stiffening_shaft_t, pushed_inertia_t, recording_shaft_t, powered_shaft_t, rear_lying_joint_t

   !> A shaft whose torque grows with the cube of the twist.
   type, extends(shaft_t) :: stiffening_shaft_t
   contains
      procedure :: torques => stiffening_torques
   end type stiffening_shaft_t

   !> A shaft that records its force in other units (its status is not the
   !> linear spring's (delta, F), though its torques are).
   type, extends(shaft_t) :: recording_shaft_t
   contains
      procedure :: status => recording_status
   end type recording_shaft_t

   !> A shaft that claims to feed power in (supplies_power set by the test):
   !> an input power that is not zero (its torques are the shaft's).
   type, extends(shaft_t) :: powered_shaft_t
   contains
      procedure :: input_power => powered_input_power
   end type powered_shaft_t

   !> A disk with a constant extra torque of 1 on it.
   type, extends(inertia_node_t) :: pushed_inertia_t
   contains
      procedure :: derivatives => pushed_derivatives
   end type pushed_inertia_t

   !> A keyed joint whose torques on the rear face are twice its hot form's (a
   !> careless plug-in's record, true in some modes only), that vouches for
   !> its record (hot_form_t%exact, D-167) when `vouch` is set.
   type, extends(keyed_joint_t) :: rear_lying_joint_t
      logical :: vouch = .false.
   contains
      procedure :: torques => rear_lying_torques
      procedure :: hot_form => rear_lying_hot_form
   end type rear_lying_joint_t

contains

   pure subroutine rear_lying_torques(self, thl, wl, thr, wr, tl, tr)
      class(rear_lying_joint_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      call self%keyed_joint_t%torques(thl, wl, thr, wr, tl, tr)
      if (self%cl%mode == -1) then
         tl = 2.0_wp*tl
         tr = 2.0_wp*tr
      end if
   end subroutine rear_lying_torques

   pure subroutine rear_lying_hot_form(self, form)
      class(rear_lying_joint_t), intent(in) :: self
      type(hot_form_t), intent(out) :: form
      call self%keyed_joint_t%hot_form(form)
      form%exact = self%vouch
   end subroutine rear_lying_hot_form

   pure subroutine stiffening_torques(self, thl, wl, thr, wr, tl, tr)
      class(stiffening_shaft_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      tr = self%k*(thl - thr)*(1.0_wp + (thl - thr)**2) + self%c*(wl - wr)
      tl = -tr
   end subroutine stiffening_torques

   pure subroutine recording_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(recording_shaft_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      call self%shaft_t%status(thl, wl, thr, wr, disp, force, contact, pairs)
      force = 4.448_wp*force
   end subroutine recording_status

   pure real(wp) function powered_input_power(self, thl, wl, thr, wr) result(p)
      class(powered_shaft_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      p = 0.37_wp*self%k*(thl - thr)*(wl + 0.1_wp*wr)
   end function powered_input_power

   pure subroutine pushed_derivatives(self, t, y, torque, dydt)
      class(pushed_inertia_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:), torque
      real(wp), intent(inout) :: dydt(:)
      call self%inertia_node_t%derivatives(t, y, torque + 1.0_wp, dydt)
   end subroutine pushed_derivatives
end module test_elements_doubles

!> Unit tests of the element and node plug-ins: torques inside the clearance,
!> at contact onset, action and reaction, each contact law's promises, unit
!> conversion of the empirical fits, a DC motor starting a geared load, and
!> the model's hot path against the plug-ins' own procedures.
program test_elements
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_kinds, only: two_pi
   use trainsim_error, only: error_t
   use trainsim_modes, only: modes_t, compute_modes
   use trainsim_el_helical_gear, only: helical_contact_length
   use trainsim_contact, only: key_lineal_stiffness, fit_tight, fit_loose, fit_average
   use trainsim_key_fit, only: key_fit_force, key_k100
   use trainsim_el_keyed_joint, only: keyed_joint_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_event, only: event_t
   use trainsim_element, only: hf_none, hf_open, hf_yang_sun, hf_linear, hg_none, hg_faces, hg_faces_zone
   use trainsim_test_support, only: load_model, load_model_text, run_model, nl
   use trainsim_el_shaft, only: shaft_t
   use trainsim_node_inertia, only: inertia_node_t
   use test_elements_doubles, only: stiffening_shaft_t, pushed_inertia_t, recording_shaft_t, powered_shaft_t, &
                                    rear_lying_joint_t
   implicit none

   !> Two disks on a keyed joint with the state, rates, guards and events of
   !> the hot-form mode tests (`open_keyed_joint`).
   type :: joint_case_t
      type(model_t) :: m
      real(wp), allocatable :: y(:), dydt(:), g(:)
      type(event_t), allocatable :: events(:)
      logical, allocatable :: fired(:)
   end type joint_case_t

   character(len=*), parameter :: two_disks = "&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                                              "&node type='inertia', inertia=1.0 /"//nl// &
                                              "&node type='inertia', inertia=2.0 /"//nl

   call suite_begin('element and node plug-ins')
   call test_clearance_elements_exert_no_torque_inside_clearance()
   call test_yang_sun_force_is_continuous_at_contact_onset()
   call test_linear_law_jumps_by_damping_force_at_onset()
   call test_elasto_backlash_never_pulls()
   call test_no_tension_clamp_keeps_force_compressive()
   call test_gear_torques_are_action_and_reaction_along_line_of_action()
   call test_restitution_fit_is_unit_independent()
   call test_dc_motor_reaches_closed_form_steady_state()
   call test_helical_contact_length_eq_6_1()
   call test_helical_gear_mesh_mode_from_mean_contact_length()
   call test_key_stiffness_fits_match_fem_points()
   call test_key_fit_force_solves_implicit_stiffness()
   call test_key_fit_force_is_six_newton_steps()
   call test_key_torques_dissipation_one_fit()
   call test_varying_stiffness_work_keeps_energy_balance()
   call test_key_bore_friction_capacity_from_hub_load()
   call test_model_rhs_is_the_plug_ins_own_torques_and_derivatives()
   call test_hot_path_asks_an_extension_that_changes_the_physics()
   call test_rhs_on_a_part_of_the_train_is_bit_for_bit_the_whole_rhs()
   call test_rhs_kernel_is_the_generic_rhs_and_fills_workspace(.false.)
   call test_rhs_kernel_is_the_generic_rhs_and_fills_workspace(.true.)
   call test_chain_kernel_is_the_generic_rhs(.false., .true.)
   call test_chain_kernel_is_the_generic_rhs(.true., .true.)
   call test_chain_kernel_is_the_generic_rhs(.true., .false.)
   call test_chain_kernel_is_the_generic_rhs(.true., .false., shuffled=.true.)
   call test_stage_energy_rates_are_the_full_rhs_own()
   call test_hot_forms_are_the_elements_own_arithmetic()
   call test_hot_form_follows_mode_changes()
   call test_hot_form_probed_again_unless_it_vouches(.false.)
   call test_hot_form_probed_again_unless_it_vouches(.true.)
   call test_guards_next_to_a_held_node_are_the_elements_own()
   call suite_end()

contains

   !> Torques of element 1 of `deck` with its mode set from the given state.
   subroutine torques_at(m, thl, wl, thr, wr, tl, tr)
      type(model_t), intent(inout) :: m
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      call m%elements(1)%e%init_mode(thl, wl, thr, wr)
      call m%elements(1)%e%torques(thl, wl, thr, wr, tl, tr)
   end subroutine torques_at

   subroutine test_clearance_elements_exert_no_torque_inside_clearance()
      type(model_t) :: m
      real(wp) :: tl, tr
      character(len=200) :: el(4)
      integer :: i
      call test_begin('clearance_elements_exert_no_torque_inside_clearance')
      el(1) = "type='spur_gear', stiffness=1e6, rb_driver=1.0, rb_driven=2.0, teeth=20, contact_ratio=1.5,"// &
              " approach_angle=0.1, half_backlash=0.01"
      el(2) = "type='keyed_joint', diameter=2.0, half_clearance=0.01, stiffness=1e6"
      el(3) = "type='clearance_coupling', clearance=0.02, stiffness=1e4, contact_damping=1.0"
      el(4) = "type='clearance_coupling', clearance=0.02, stiffness=1e4, contact_law='elasto_backlash', "// &
              "contact_damping=1.0"
      do i = 1, size(el)
         call load_model_text(two_disks//'&element '//trim(el(i))//' /', m)
         ! relative displacement 0.005 (inside b = 0.01), moving fast
         call torques_at(m, 0.005_wp, 3.0_wp, 0.0_wp, -1.0_wp, tl, tr)
         call check('zero torque inside the clearance: '//trim(el(i)(1:40)), abs(tl) + abs(tr) == 0.0_wp)
         call check('not in contact', .not. m%elements(1)%e%in_contact())
      end do
   end subroutine test_clearance_elements_exert_no_torque_inside_clearance

   subroutine test_yang_sun_force_is_continuous_at_contact_onset()
      type(model_t) :: m
      real(wp) :: tl, tr, eps
      call test_begin('yang_sun_force_is_continuous_at_contact_onset')
      call load_model_text(two_disks//"&element type='keyed_joint', diameter=2.0, half_clearance=0.01,"// &
                           " stiffness=1e6, initial_contact_velocity=5.0 /", m)
      eps = 1.0e-9_wp
      ! delta = r (thl - thr) = 0.01 + eps with r = 1: just inside the front contact, approaching at 5
      call torques_at(m, 0.01_wp + eps, 5.0_wp, 0.0_wp, 0.0_wp, tl, tr)
      call check('in contact just past b', m%elements(1)%e%in_contact())
      ! F = k p + D p pdot -> 0 as p -> 0: |T| <= (k + D pdot) eps r
      call check('torque at p = 1e-9 is O(p)', abs(tr), 0.0_wp, abs_tol=2.0e6_wp*eps)
      call check('right node pushed forward, left held back', tr > 0.0_wp .and. tl < 0.0_wp)
   end subroutine test_yang_sun_force_is_continuous_at_contact_onset

   subroutine test_linear_law_jumps_by_damping_force_at_onset()
      type(model_t) :: m
      real(wp) :: tl, tr
      call test_begin('linear_law_jumps_by_damping_force_at_onset')
      call load_model_text(two_disks//"&element type='clearance_coupling', clearance=0.02, stiffness=1e4,"// &
                           " contact_damping=3.0 /", m)
      call torques_at(m, 0.01_wp, 2.0_wp, 0.0_wp, 0.0_wp, tl, tr)
      ! a spring-damper engages with its full damping torque d * rate (the law says so)
      call check('onset torque = d x relative speed', tr, 3.0_wp*2.0_wp, rel_tol=1.0e-14_wp)
      call check('equal and opposite', tl, -tr, rel_tol=1.0e-14_wp)
   end subroutine test_linear_law_jumps_by_damping_force_at_onset

   subroutine test_elasto_backlash_never_pulls()
      type(model_t) :: m
      real(wp) :: tl, tr
      call test_begin('elasto_backlash_never_pulls')
      call load_model_text(two_disks//"&element type='clearance_coupling', clearance=0.02, stiffness=1e4,"// &
                           " contact_law='elasto_backlash', contact_damping=50.0 /", m)
      ! penetration 1e-3 rad, separating fast: spring 10, damping -500 -> no pull
      call torques_at(m, 0.011_wp, -10.0_wp, 0.0_wp, 0.0_wp, tl, tr)
      call check('separating fast: torque is zero, not tensile', tr == 0.0_wp .and. tl == 0.0_wp)
      ! approaching fast: tau_c + min(tau_c, tau_d) = 2 tau_c
      call torques_at(m, 0.011_wp, 10.0_wp, 0.0_wp, 0.0_wp, tl, tr)
      call check('approaching fast: damping limited to the spring torque', tr, 2.0_wp*1.0e4_wp*1.0e-3_wp, &
                 rel_tol=1.0e-12_wp)
   end subroutine test_elasto_backlash_never_pulls

   subroutine test_no_tension_clamp_keeps_force_compressive()
      type(model_t) :: m1, m2
      real(wp) :: tl, tr1, tr2
      call test_begin('no_tension_clamp_keeps_force_compressive')
      call load_model_text(two_disks//"&element type='keyed_joint', diameter=2.0, half_clearance=0.01,"// &
                           " stiffness=1e6, initial_contact_velocity=1.0 /", m1)
      call load_model_text(two_disks//"&element type='keyed_joint', diameter=2.0, half_clearance=0.01,"// &
                           " stiffness=1e6, initial_contact_velocity=1.0, no_tension=.true. /", m2)
      ! small penetration, fast separation: k p + D p pdot < 0
      call torques_at(m1, 0.0101_wp, -50.0_wp, 0.0_wp, 0.0_wp, tl, tr1)
      call torques_at(m2, 0.0101_wp, -50.0_wp, 0.0_wp, 0.0_wp, tl, tr2)
      call check('thesis default: the Yang-Sun force turns tensile here', tr1 < 0.0_wp)
      call check('no_tension: clamped to zero', tr2 == 0.0_wp)
   end subroutine test_no_tension_clamp_keeps_force_compressive

   subroutine test_gear_torques_are_action_and_reaction_along_line_of_action()
      type(model_t) :: m
      real(wp) :: tl, tr
      call test_begin('gear_torques_are_action_and_reaction_along_line_of_action')
      call load_model_text(two_disks//"&element type='spur_gear', stiffness=1e6, rb_driver=1.0, rb_driven=2.5,"// &
                           " teeth=20, contact_ratio=1.5, approach_angle=0.1, half_backlash=0.01 /", m)
      ! rear face: delta = 1.0*0.0 - 2.5*0.006 = -0.015 <= -b
      call torques_at(m, 0.0_wp, 0.0_wp, 0.006_wp, 0.0_wp, tl, tr)
      call check('rear face: same force on both base circles (tl/r1 = -tr/r2)', tl/1.0_wp, -tr/2.5_wp, rel_tol=1.0e-14_wp)
      call check('rear face pushes the driver forward', tl > 0.0_wp)
      ! p = 0.015 - 0.01 = 0.005; zone of the driver at 0: u = 20 (0 + 0.1)/(2 pi) = 0.318 <= m_p - 1 -> two pairs
      call check('rear-face force = c k p with c = 1.8 (two-pair zone, no approach so D = 0)', tl/1.0_wp, &
                 1.8_wp*1.0e6_wp*0.005_wp, rel_tol=1.0e-12_wp)
   end subroutine test_gear_torques_are_action_and_reaction_along_line_of_action

   subroutine test_restitution_fit_is_unit_independent()
      type(model_t) :: mi, ms
      type(run_result_t) :: ri, rs
      call test_begin('restitution_fit_is_unit_independent')
      ! the same keyed-joint impact in inch-lbf-s and in SI (Table 5.4 numbers)
      call load_model_text("&run t_end = 2e-4, dt = 5e-7 /"//nl// &
                           "&node type='inertia', inertia=7.537e-3 /"//nl//"&node type='inertia', inertia=10.082 /"//nl// &
                           "&element type='keyed_joint', diameter=2.6312, half_clearance=0.001, stiffness=2.03e6 /"//nl// &
                           "&initial node='n1', speed=10.0 /", mi)
      call load_model_text("&run units='si', t_end = 2e-4, dt = 5e-7 /"//nl// &
                           "&node type='inertia', inertia=8.5157e-4 /"//nl//"&node type='inertia', inertia=1.13911 /"//nl// &
                           "&element type='keyed_joint', diameter=0.06683248, half_clearance=2.54e-5,"// &
                           " stiffness=3.5550585e8 /"//nl//"&initial node='n1', speed=10.0 /", ms)
      call run_model(mi, ri)
      call run_model(ms, rs)
      call check('same restitution from the Goldsmith fit in both unit systems', rs%events(1)%restitution, &
                 ri%events(1)%restitution, rel_tol=1.0e-6_wp)
      call check('approach velocity in m/s = in/s x 0.0254', rs%events(1)%approach_velocity, &
                 ri%events(1)%approach_velocity*0.0254_wp, rel_tol=1.0e-6_wp)
   end subroutine test_restitution_fit_is_unit_independent

   subroutine test_dc_motor_reaches_closed_form_steady_state()
      type(model_t) :: m, m0, m2
      real(wp) :: e1
      type(run_result_t) :: r
      real(wp), parameter :: v = 12.0_wp, res = 1.0_wp, a = 0.05_wp, dm = 1.0e-5_wp, dl = 1.0e-3_wp, ratio = 1.0_wp/3.0_wp
      real(wp) :: deq, w_m, i_a, wm_avg, wl_avg, i_avg
      integer :: n, k0
      call test_begin('dc_motor_reaches_closed_form_steady_state')
      ! SI: torque constant = back-emf constant (N m/A = V s). Motor -> 1:3 ideal gear -> damped load.
      call load_model_text("&run units='si', t_end = 1.5, dt = 1e-4, output_interval = 1e-3 /"//nl// &
                           "&node id='m', type='dc_motor', inertia=1e-4, damping=1e-5, torque_constant=0.05,"// &
                           " back_emf_constant=0.05, inductance=1e-3, resistance=1.0 /"//nl// &
                           "&node id='load', type='inertia', inertia=1e-3, damping=1e-3 /"//nl// &
                           "&element type='ideal_gear', stiffness=1e7, rb_driver=0.01, rb_driven=0.03 /"//nl// &
                           "&load node='m', quantity='voltage', kind='constant', value=12.0 /", m)
      m0 = m
      call run_model(m, r)
      deq = dm + dl*ratio**2
      w_m = v/(res*deq/a + a)          ! V = R i + a w,  a i = d_eq w
      i_a = w_m*deq/a
      n = size(r%series_t)
      k0 = n - 100                     ! average the last 0.1 s (the undamped mesh mode rings)
      wm_avg = sum(r%series_omega(1, k0:n))/real(n - k0 + 1, wp)
      wl_avg = sum(r%series_omega(2, k0:n))/real(n - k0 + 1, wp)
      i_avg = r%y_final(3)
      call check('motor speed = V / (R d_eq / a + a) (1e-4)', wm_avg, w_m, rel_tol=1.0e-4_wp)
      call check('load speed = motor speed x r1/r2 (1e-4)', wl_avg, w_m*ratio, rel_tol=1.0e-4_wp)
      call check('armature current = d_eq w / a (1e-3)', i_avg, i_a, rel_tol=1.0e-3_wp)
      ! the residual is RK4 error (electrical mode: dt R/L = 0.1): small and O(dt^4)
      e1 = r%energy_residual_max/r%energy_scale
      m2 = m0
      m2%run%dt = 0.5_wp*m0%run%dt
      call run_model(m2, r)
      call check('energy balance closes (electrical W converted): residual < 1e-6', e1, 0.0_wp, abs_tol=1.0e-6_wp)
      call check('and shrinks >= 8x when dt halves', e1/(r%energy_residual_max/r%energy_scale) >= 8.0_wp)
   end subroutine test_dc_motor_reaches_closed_form_steady_state
   subroutine test_helical_contact_length_eq_6_1()
      real(wp) :: lc(0:1000), e, zeta
      integer :: i
      logical :: continuous
      call test_begin('helical_contact_length_eq_6_1')
      zeta = 0.3_wp
      ! integer face contact ratio: constant length m_p F / cos(zeta) = m_p p_tb / sin(zeta)
      do i = 0, 100
         e = real(i, wp)/100.0_wp
         lc(i) = helical_contact_length(e, 1.6_wp, 1.0_wp, 0.5_wp, zeta)
      end do
      call check('m_F = 1: constant length (max - min)', maxval(lc(0:99)) - minval(lc(0:99)), 0.0_wp, abs_tol=1.0e-12_wp)
      call check('m_F = 1: length = m_p p_tb / sin(zeta)', lc(0), 1.6_wp*0.5_wp/sin(zeta), rel_tol=1.0e-12_wp)
      ! non-integer m_F: minimum at e = 0, maximum at e = frac(m_F) (sec. 6.2), continuous, periodic
      do i = 0, 1000
         e = real(i, wp)/1000.0_wp
         lc(i) = helical_contact_length(e, 1.6_wp, 1.3_wp, 0.5_wp, zeta)
      end do
      continuous = maxval(abs(lc(1:1000) - lc(0:999))) < 2.0e-3_wp
      call check('continuous in e', continuous)
      call check('periodic: L(0) = L(1)', lc(1000), lc(0), rel_tol=1.0e-12_wp)
      call check('minimum at e = 0', minval(lc) >= lc(0) - 1.0e-12_wp)
      call check('maximum first reached at e = frac(m_F) = 0.3', lc(300) >= maxval(lc) - 1.0e-12_wp .and. &
                 lc(290) < maxval(lc) - 1.0e-6_wp)
   end subroutine test_helical_contact_length_eq_6_1

   subroutine test_helical_gear_mesh_mode_from_mean_contact_length()
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      real(wp) :: k, zeta
      call test_begin('helical_gear_mesh_mode_from_mean_contact_length')
      call load_model_text(two_disks//"&element type='helical_gear', rb_driver=1.5, rb_driven=1.5, teeth=30,"// &
                           " profile_contact_ratio=1.5, base_helix_angle=20.0, face_width=1.0, half_backlash=0.001 /"// &
                           nl//"&initial node='n1', angle=0.01 /", m)
      call compute_modes(m, md, err)
      call check('modes computed', .not. allocated(err))
      zeta = 20.0_wp*two_pi/360.0_wp
      k = 30.0e6_wp/17.6_wp*1.5_wp*1.0_wp/cos(zeta)
      call check('mesh mode: k = E/17.6 m_p F / cos(zeta_b)', md%freq_hz(2), &
                 sqrt(k*1.5_wp**2*(1.0_wp/1.0_wp + 1.0_wp/2.0_wp))/two_pi, rel_tol=1.0e-10_wp)
   end subroutine test_helical_gear_mesh_mode_from_mean_contact_length
   subroutine test_key_stiffness_fits_match_fem_points()
      real(wp) :: k, dk
      call test_begin('key_stiffness_fits_match_fem_points')
      ! Figs. 4.19-4.41, 1.000 in shaft: key force P = 2 T / d
      call key_lineal_stiffness(fit_tight, 2.0_wp*450.0_wp, k, dk)
      call check('tight, T = 450 lb-in vs FEM 218035 (1 %)', k, 218035.0_wp, rel_tol=1.0e-2_wp)
      call key_lineal_stiffness(fit_tight, 2.0_wp*750.0_wp, k, dk)
      call check('tight, T = 750 lb-in vs FEM 233650 (1 %)', k, 233650.0_wp, rel_tol=1.0e-2_wp)
      call key_lineal_stiffness(fit_tight, 2.0_wp*7500.0_wp, k, dk)
      call check('tight, T = 7500 lb-in vs FEM 280903 (1 %)', k, 280903.0_wp, rel_tol=1.0e-2_wp)
      call key_lineal_stiffness(fit_loose, 2.0_wp*3000.0_wp, k, dk)
      call check('loose, T = 3000 lb-in vs FEM 234797 (1 %)', k, 234797.0_wp, rel_tol=1.0e-2_wp)
      call key_lineal_stiffness(fit_loose, 2.0_wp*7500.0_wp, k, dk)
      call check('loose, T = 7500 lb-in vs FEM 268556 (1 %)', k, 268556.0_wp, rel_tol=1.0e-2_wp)
   end subroutine test_key_stiffness_fits_match_fem_points

   subroutine test_key_fit_force_solves_implicit_stiffness()
      type(model_t) :: m
      real(wp) :: f, k, dk, p
      integer :: i
      call test_begin('key_fit_force_solves_implicit_stiffness')
      call load_model_text(two_disks//"&element type='keyed_joint', diameter=1.0, half_clearance=0.001,"// &
                           " stiffness_fit='tight', key_length=1.5 /", m)
      select type (e => m%elements(1)%e)
      type is (keyed_joint_t)
         do i = 1, 4
            p = 10.0_wp**(-6 + i)*1.0e-1_wp      ! 1e-6 .. 1e-3 in
            f = e%cl%law%fit_elastic_force(p)
            call key_lineal_stiffness(fit_tight, f, k, dk)
            call check('F = k(F) L p at p = '//trim(adjustl(rstr(p))), f, k*1.5_wp*p, rel_tol=1.0e-10_wp)
         end do
      class default
         call check('element is a keyed joint', .false.)
      end select
   end subroutine test_key_fit_force_solves_implicit_stiffness

   !> key_fit_force ends Newton when a step leaves F unchanged: it must give the
   !> six steps of D-5 bit for bit (both signs, zero, all three fits, 1e-14..1 in^2,
   !> across the fits' 100 lbf floor, their linear parts and the 60000 lbf cap).
   subroutine test_key_fit_force_is_six_newton_steps()
      integer, parameter :: fits(3) = [fit_tight, fit_loose, fit_average]
      real(wp) :: lp, fl, k, dk, f
      integer :: i, j, it, n_diff
      call test_begin('key_fit_force_is_six_newton_steps')
      n_diff = 0
      do j = 1, 3
         do i = -1400, 1400
            lp = sign(10.0_wp**(-abs(i)/100.0_wp), real(i, wp))
            if (i == 0) lp = 0.0_wp
            call key_lineal_stiffness(fits(j), 100.0_wp, k, dk)
            fl = k*lp
            do it = 1, 6
               call key_lineal_stiffness(fits(j), abs(fl), k, dk)
               fl = fl - (fl - k*lp)/(1.0_wp - dk*lp*sign(1.0_wp, fl))
            end do
            call key_lineal_stiffness(fits(j), abs(fl), k, dk)
            f = key_fit_force(fits(j), lp)
            if (.not. (f == k*lp .and. sign(1.0_wp, f) == sign(1.0_wp, k*lp))) n_diff = n_diff + 1
         end do
      end do
      call check('key forces that differ from six Newton steps (of 8403)', real(n_diff, wp), 0.0_wp, abs_tol=0.0_wp)
   end subroutine test_key_fit_force_is_six_newton_steps

   !> The keyed joint's torques and dissipated power from one key fit (the
   !> general path's one call, D-178): bit for bit `torques` and
   !> `dissipation_power`, each fit, bore friction from the hub load or the key
   !> force, open and on both faces; key_fit_force's start (key_k100, folded by
   !> the compiler) equal to the fit's stiffness at 100 lbf evaluated at run time.
   subroutine test_key_torques_dissipation_one_fit()
      character(len=*), parameter :: fits(3) = [character(len=7) :: 'tight', 'loose', 'average']
      character(len=*), parameter :: bores(2) = [character(len=9) :: 'hub_load', 'key_force']
      type(model_t) :: m
      real(wp), allocatable :: y(:)
      real(wp) :: tl, tr, p, tl2, tr2, k, dk
      integer :: j, kf, i, n_diff, n_face(-1:1)
      call test_begin('key_torques_dissipation_one_fit')
      n_diff = 0
      n_face = 0
      do j = 1, 3
         call key_lineal_stiffness(j, 100.0_wp, k, dk)
         call check('key_k100 of fit '//trim(fits(j))//' = its stiffness at 100 lbf at run time', key_k100(j) == k)
         do kf = 1, 2
            call load_model_text(two_disks//"&element type='keyed_joint', diameter=1.0, half_clearance=0.001,"// &
                                 " stiffness_fit='"//trim(fits(j))//"', key_length=1.5, friction=0.15, load_radius=2.0,"// &
                                 " bore_friction='"//trim(bores(kf))//"' /", m)
            allocate (y(m%n_y))
            do i = -20, 20
               y = 0.0_wp
               y(1:4) = [real(i, wp)*2.0e-4_wp, 3.0_wp*sin(real(i, wp)), 0.0_wp, 1.5_wp*cos(real(i, wp))]
               call m%init_modes(0.0_wp, y)
               associate (e => m%elements(1)%e)
                  call e%torques_dissipation(y(1), y(2), y(3), y(4), tl, tr, p)
                  call e%torques(y(1), y(2), y(3), y(4), tl2, tr2)
                  if (.not. (tl == tl2 .and. tr == tr2 .and. p == e%dissipation_power(y(1), y(2), y(3), y(4)))) &
                     n_diff = n_diff + 1
                  select type (e)
                  type is (keyed_joint_t)
                     n_face(e%cl%mode) = n_face(e%cl%mode) + 1
                  end select
               end associate
            end do
            deallocate (y)
         end do
      end do
      call check('states on the rear face, open, on the front face', all(n_face > 0))
      call check('states where the one call differs from the two (of 246)', real(n_diff, wp), 0.0_wp, abs_tol=0.0_wp)
   end subroutine test_key_torques_dissipation_one_fit

   subroutine test_varying_stiffness_work_keeps_energy_balance()
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: res1
      call test_begin('varying_stiffness_work_keeps_energy_balance')
      ! helical: the position-dependent stiffness does work on loaded teeth (booked as input)
      call load_model('inputs/helical_pair.nml', m)
      call run_model(m, r)
      call check('helical pair: energy balance closes to 1e-9 of the energy scale', &
                 r%energy_residual_max/r%energy_scale, 0.0_wp, abs_tol=1.0e-9_wp)
      ! keyed joint with the nonlinear stiffness fit, undamped: nothing may look dissipated
      call load_model_text("&run t_end = 3e-4, dt = 5e-7 /"//nl//"&node type='inertia', inertia=7.537e-3 /"//nl// &
                           "&node type='inertia', inertia=10.082 /"//nl//"&element type='keyed_joint', diameter=2.6312,"// &
                           " half_clearance=0.001, stiffness_fit='average', key_length=2.0, restitution_law='constant',"// &
                           " restitution=1.0 /"//nl//"&initial node='n1', speed=10.0 /", m)
      call run_model(m, r)
      call check('key fit, e = 1: one impact', r%el(1)%impacts == 1)
      call check('key fit, e = 1: no energy dissipated', abs(r%y_final(m%n_states + 1)), 0.0_wp, abs_tol=1.0e-9_wp)
      res1 = r%energy_residual_max/r%energy_scale
      ! the stored energy of the nonlinear key force is a 5-point Gauss integral:
      ! it plateaus near 3e-8 of the energy (it does not shrink with dt); a wrong
      ! force/energy pairing would show at the 1e-3 level
      call check('key fit: energy residual < 1e-6 (quadrature of the stored energy)', res1, 0.0_wp, abs_tol=1.0e-6_wp)
   end subroutine test_varying_stiffness_work_keeps_energy_balance

   subroutine test_key_bore_friction_capacity_from_hub_load()
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: tmax, a
      call test_begin('key_bore_friction_capacity_from_hub_load')
      ! shaft held (fixed), hub (J = 1) loaded by 100 lbf*in; wide clearance so the key never bears
      call load_model_text("&run t_end = 0.05, dt = 1e-5 /"//nl//"&node id='shaft', type='fixed' /"//nl// &
                           "&node id='hub', type='inertia', inertia=1.0 /"//nl// &
                           "&element type='keyed_joint', diameter=2.6312, half_clearance=0.5, stiffness=2.03e6,"// &
                           " friction=0.5, load_radius=4.0, friction_angle=-1.4562 /"//nl// &
                           "&load node='hub', kind='constant', value=100.0 /", m)
      call run_model(m, r)
      ! eqs. (4.38)-(4.40): T_max = mu (d/2) T_h / (R |sin a + mu cos a|)
      a = -1.4562_wp
      tmax = 0.5_wp*1.3156_wp*100.0_wp/(4.0_wp*abs(sin(a) + 0.5_wp*cos(a)))
      call check('key stays out of contact', r%el(1)%impacts == 0)
      call check('hub speed = (T_h - T_max) t / J once slipping (0.1 %)', r%y_final(2), (100.0_wp - tmax)*0.05_wp, &
                 rel_tol=1.0e-3_wp)
      call check('friction torque on the hub = -T_max (0.1 %)', r%el(1)%torque_min, -tmax, rel_tol=1.0e-3_wp)
      call check('friction work dissipated = T_max x slip angle (0.1 %)', r%y_final(m%n_states + 1), &
                 tmax*0.5_wp*(100.0_wp - tmax)*0.05_wp**2, rel_tol=1.0e-3_wp)
   end subroutine test_key_bore_friction_capacity_from_hub_load

   function rstr(x) result(s)
      real(wp), intent(in) :: x
      character(len=16) :: s
      write (s, '(es9.2)') x
   end function rstr

   !> The seven-node serial train of the RHS-kernel tests (a to g: shafts, a damped shaft,
   !> a spur gear with backlash, an ideal gear, a keyed joint), without loads; `b_keys`
   !> is added to node b's group.
   function kernel_train(b_keys) result(train)
      character(len=*), intent(in) :: b_keys
      character(len=:), allocatable :: train
      train = "&node id='a', type='inertia', inertia=1.0 /"//nl// &
              "&node id='b', type='inertia', inertia=0.3"//b_keys//" /"//nl// &
              "&node id='c', type='inertia', inertia=0.7 /"//nl// &
              "&node id='d', type='inertia', inertia=0.4 /"//nl// &
              "&node id='e', type='inertia', inertia=1.5 /"//nl// &
              "&node id='f', type='inertia', inertia=2.0 /"//nl// &
              "&node id='g', type='inertia', inertia=0.9 /"//nl// &
              "&element type='shaft', stiffness=1e3, left='a', right='b' /"//nl// &
              "&element type='shaft', stiffness=2e3, damping=0.1, left='b', right='c' /"//nl// &
              "&element type='spur_gear', stiffness=1e5, rb_driver=1.0, rb_driven=1.5, teeth=20, "// &
              "contact_ratio=1.5, approach_angle=0.1, half_backlash=0.001, left='c', right='d' /"//nl// &
              "&element type='ideal_gear', stiffness=2e4, rb_driver=0.7, rb_driven=1.1, left='d', right='e' /"//nl// &
              "&element type='keyed_joint', diameter=2.0, half_clearance=0.001, stiffness=1e6, left='e', right='f' /"//nl// &
              "&element type='shaft', stiffness=3e3, left='f', right='g' /"//nl
   end function kernel_train
   !> The model's right-hand side (hot path for shafts, ideal gears and
   !> inertias; calls through the objects for the rest) equals what the
   !> element's `torques`, `dissipation_power` and the nodes' `derivatives` give,
   !> to rounding: the hot path is the same physics, only faster. Two disks
   !> (J = 1 with damping 0.3, J = 2) joined by each element type, energy on.
   subroutine test_model_rhs_is_the_plug_ins_own_torques_and_derivatives()
      type(model_t) :: m
      character(len=200) :: el(5)
      real(wp), allocatable :: y(:), dydt(:), ref(:)
      real(wp) :: x(4), tl, tr, pd
      integer :: i
      call test_begin('model_rhs_is_the_plug_ins_own_torques_and_derivatives')
      el(1) = "type='shaft', stiffness=3e3, damping=0.7"
      el(2) = "type='ideal_gear', stiffness=1e5, rb_driver=0.4, rb_driven=0.9"
      el(3) = "type='damper', damping=2.5"
      el(4) = "type='spur_gear', stiffness=1e6, rb_driver=1.0, rb_driven=2.0, teeth=20, contact_ratio=1.5,"// &
              " approach_angle=0.1, half_backlash=0.001"
      el(5) = "type='clearance_coupling', clearance=0.002, stiffness=1e4, contact_damping=1.0"
      x = [0.013_wp, 3.0_wp, -0.002_wp, -1.0_wp]   ! thl, wl, thr, wr: in contact for the clearances
      do i = 1, size(el)
         call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                              "&node type='inertia', inertia=1.0, damping=0.3 /"//nl// &
                              "&node type='inertia', inertia=2.0 /"//nl//'&element '//trim(el(i))//' /', m)
         call m%initial_state(y)
         y(1:4) = [x(1), x(2), x(3), x(4)]
         call m%init_modes(0.0_wp, y)
         allocate (dydt(size(y)), ref(size(y)))
         call m%rhs(0.0_wp, y, dydt)
         call m%elements(1)%e%torques(x(1), x(2), x(3), x(4), tl, tr)
         pd = m%elements(1)%e%dissipation_power(x(1), x(2), x(3), x(4)) + 0.3_wp*x(2)**2
         ref(1:4) = [x(2), (tl - 0.3_wp*x(2))/1.0_wp, x(4), tr/2.0_wp]
         call check(trim(el(i)(1:30))//': torque on each node nonzero', abs(tl) > 0.0_wp .and. abs(tr) > 0.0_wp)
         call check(trim(el(i)(1:30))//': speeds and accelerations', maxval(abs(dydt(1:4) - ref(1:4))) <= &
                    1.0e-13_wp*maxval(abs(ref(1:4))))
         call check(trim(el(i)(1:30))//': dissipated power', dydt(5), pd, rel_tol=1.0e-13_wp)
         deallocate (dydt, ref)
      end do
   end subroutine test_model_rhs_is_the_plug_ins_own_torques_and_derivatives

   !> D-106: a serial chain (each element joins the node after the last one;
   !> undamped inertias, the head held or free; springs, a damped shaft and
   !> clearances in their hot forms) runs the chain kernel; the same train with
   !> one load given as a sine of zero amplitude runs the generic RHS. Both must
   !> give the same derivatives, energy rates, node torques and workspace to the
   !> bit, at the step end, an inner stage and RK4's inner stages at y + c k.
   !> `shuffled`: the head's node declared last, so the chain does not pass the
   !> nodes in node order (the step end's kinetic energy summed by the node
   !> loop, not in the links: D-160).
   subroutine test_chain_kernel_is_the_generic_rhs(track, held, shuffled)
      logical, intent(in) :: track, held
      logical, intent(in), optional :: shuffled
      type(model_t) :: ms, mg
      real(wp), allocatable :: y(:), ds(:), dg(:), yk(:), ya(:), k2(:), k3(:), k4(:), y2(:)
      real(wp) :: stored, elastic, sg, eg, disp, force
      integer :: i, k, kind, gk, ns, ng, contact, pairs, changes, oc
      logical :: status_ok, same, was(2), now(2), mixed
      character(len=:), allocatable :: train, run
      mixed = .false.
      if (present(shuffled)) mixed = shuffled
      call test_begin('chain_kernel_is_bit_for_bit_the_generic_rhs, track_energy = '//merge('on ', 'off', track)// &
                      ', head '//merge('held', 'free', held)//merge(', head node last', '                ', mixed))
      run = "&run t_end = 1e-3, dt = 1e-6, track_energy = "//merge('.true. ', '.false.', track)//' /'//nl
      train = kernel_train('')
      if (mixed) train = train(index(train, nl) + 1:index(train, "&element") - 1)//train(1:index(train, nl))// &
                         train(index(train, "&element"):)
      train = train// &
              "&load node='c', value=0.5 /"//nl// &
              "&load node='a', value=1.25 /"//nl
      if (held) train = train//"&load node='a', quantity='speed', kind='constant', value=5.0 /"//nl
      call load_model_text(run//train//"&load node='g', value=-3.0 /"//nl, ms)
      call load_model_text(run//train//"&load node='g', kind='sine', offset=-3.0, amplitude=0.0, frequency=7.0 /"// &
                           nl, mg)
      call ms%initial_state(y)
      do i = 1, size(y) - merge(2, 0, track)
         y(i) = 0.01_wp*sin(1.7_wp*i) + merge(0.05_wp, 0.0_wp, i == 3) + merge(0.0004_wp, 0.0_wp, i == 9)
      end do
      call ms%init_modes(0.1_wp, y)
      call mg%init_modes(0.1_wp, y)
      call ms%hot_kinds(1, kind, gk, ns)
      call mg%hot_kinds(1, kind, gk, ng)
      call check('the simple model runs the chain kernel over its six elements, the other the generic RHS', &
                 ns == 6 .and. ng == 0)
      call check('the gear and the keyed joint are in contact (their torques take part)', &
                 ms%elements(3)%e%in_contact() .and. ms%elements(5)%e%in_contact())
      allocate (ds(size(y)), dg(size(y)))
      ds = huge(1.0_wp); dg = -huge(1.0_wp)
      call ms%rhs_step_end(0.1_wp, y, ds)
      call mg%rhs_step_end(0.1_wp, y, dg)
      call check('step end: derivatives (energy rates too) identical to the bit', all(ds == dg))
      call check('step end: node angles, speeds, torques and element torques identical to the bit', &
                 all(ms%theta == mg%theta) .and. all(ms%omega == mg%omega) .and. all(ms%torque == mg%torque) &
                 .and. all(ms%el_torque == mg%el_torque))
      status_ok = all(ms%ws_status)
      do i = 1, size(ms%elements)
         associate (e => ms%elements(i)%e)
            call e%status(ms%theta(e%left), ms%omega(e%left), ms%theta(e%right), ms%omega(e%right), disp, force, &
                          contact, pairs)
         end associate
         status_ok = status_ok .and. disp == ms%el_disp(i) .and. force == ms%el_force(i) .and. &
                     contact == ms%el_contact(i)
      end do
      call check('step end: every element''s displacement, force and contact in the workspace, its own', status_ok)
      if (track) then
         call ms%workspace_energy(y, stored, elastic)
         call mg%workspace_energy(y, sg, eg)
         call check('step end: stored and elastic energy in the workspace, identical to the bit', ms%ws_energy .and. &
                    ms%ws_stored == stored .and. ms%ws_elastic == elastic .and. stored == sg .and. elastic == eg)
      end if
      if (mixed .and. track) then
         ! every angle zero, the clearances open: the stored energy is the kinetic
         ! sum alone, which the node loop adds in node order (D-160; the chain's
         ! order, head first, gives another last bit here)
         y2 = y
         y2(1:size(y) - 2:2) = 0.0_wp
         call ms%init_modes(0.1_wp, y2, tables=.false.)
         call ms%rhs_step_end(0.1_wp, y2, ds)
         call ms%workspace_energy(y2, stored, elastic)
         call check('head node last: the stored energy is the kinetic energies'' sum in node order, to the bit', &
                    ms%ws_energy .and. elastic == 0.0_wp .and. ms%ws_stored == stored .and. stored > 0.0_wp)
         call ms%init_modes(0.1_wp, y, tables=.false.)
      end if
      ds = huge(1.0_wp); dg = -huge(1.0_wp)
      call ms%rhs_stage(0.1_wp, y, ds)
      call mg%rhs(0.1_wp, y, dg)
      call check('inner stage: the same derivatives to the bit', all(ds == dg))
      yk = [(0.5_wp*cos(0.7_wp*i), i=1, size(y))]
      allocate (k2(size(y)), k3(size(y)), k4(size(y)), ya(size(y)))
      call rk4_by_stages(mg, 0.1_wp, 0.37_wp, y, yk, dg)
      ds = huge(1.0_wp)
      call ms%rk4_stages(0.1_wp, 0.37_wp, 0.1_wp + 0.37_wp, y, yk, k2, k3, k4, ya, ds)
      call check('RK4 inner stages at y + c k: the step of the generic stages to the bit', all(ds == dg))
      ! the clearances change mode at other states (their rows move between the
      ! law's tables, the chain's links follow them: chain_laws), without the
      ! tables rebuilt: again the generic RHS's derivatives to the bit
      changes = 0
      same = .true.
      was = [ms%elements(3)%e%in_contact(), ms%elements(5)%e%in_contact()]
      oc = merge(3, 5, held .or. mixed)   ! node c's angle (then d, e, f every second state)
      do k = 1, 8
         y2 = y
         select case (mod(k, 4))
         case (1); y2(oc:oc + 6:2) = 0.0_wp            ! both open
         case (2); y2(oc:oc + 2:2) = 0.0_wp            ! the gear open
         case (3); y2(oc + 4:oc + 6:2) = 0.0_wp        ! the keyed joint open
         end select
         call ms%init_modes(0.1_wp, y2, tables=.false.)
         call mg%init_modes(0.1_wp, y2)
         now = [ms%elements(3)%e%in_contact(), ms%elements(5)%e%in_contact()]
         changes = changes + count(now .neqv. was)
         was = now
         ds = huge(1.0_wp); dg = -huge(1.0_wp)
         call ms%rhs_stage(0.1_wp, y2, ds)
         call mg%rhs(0.1_wp, y2, dg)
         same = same .and. all(ds == dg)
      end do
      call check('mode changes: the clearances changed mode twelve times', changes == 12)
      call check('mode changes: the chain kernel''s derivatives are the generic RHS''s to the bit', same)
   end subroutine test_chain_kernel_is_the_generic_rhs

   !> A type extended from a shaft or an inertia that overrides the physics but
   !> keeps the parent's hot-path claim must still be asked through its own
   !> procedures (the model checks each claim at the start of a run).
   subroutine test_hot_path_asks_an_extension_that_changes_the_physics()
      type(model_t) :: m
      type(stiffening_shaft_t) :: s2
      type(pushed_inertia_t) :: n2
      real(wp), allocatable :: y(:), dydt(:)
      real(wp) :: tl, tr
      call test_begin('hot_path_asks_an_extension_that_changes_the_physics')
      call load_model_text(two_disks//"&element type='shaft', stiffness=100.0 /", m)
      select type (e => m%elements(1)%e)
      type is (shaft_t)
         s2%shaft_t = e
      end select
      select type (nd => m%nodes(2)%n)
      type is (inertia_node_t)
         n2%inertia_node_t = nd
      end select
      deallocate (m%elements(1)%e, m%nodes(2)%n)
      allocate (m%elements(1)%e, source=s2)
      allocate (m%nodes(2)%n, source=n2)
      call m%initial_state(y)
      y(1:4) = [0.5_wp, 0.0_wp, -0.5_wp, 0.0_wp]
      call m%init_modes(0.0_wp, y)
      allocate (dydt(size(y)))
      call m%rhs(0.0_wp, y, dydt)
      call s2%torques(0.5_wp, 0.0_wp, -0.5_wp, 0.0_wp, tl, tr)
      call check('the extended shaft''s own torque (twice the linear one)', tl, -200.0_wp, rel_tol=1.0e-14_wp)
      call check('node 1 feels it', dydt(2), tl/1.0_wp, rel_tol=1.0e-14_wp)
      call check('node 2 feels it and the extended node''s own extra torque', dydt(4), (tr + 1.0_wp)/2.0_wp, &
                 rel_tol=1.0e-14_wp)
   end subroutine test_hot_path_asks_an_extension_that_changes_the_physics
   !> Event location on a long train steps only the part a guard sees
   !> (`model%rhs_part`); for the nodes it covers it must give exactly what
   !> `model%rhs` gives (the same torque sums, in the same order), or located
   !> times would differ from those of the whole train. Six disks: shafts, a
   !> spur gear in contact (element 3), a damped shaft, a keyed joint; the part:
   !> nodes 3 and 4 (the gear's) with their elements 2, 3, 4.
   subroutine test_rhs_on_a_part_of_the_train_is_bit_for_bit_the_whole_rhs()
      type(model_t) :: m
      real(wp), allocatable :: y(:), full(:), part(:)
      integer :: i
      call test_begin('rhs_on_a_part_of_the_train_is_bit_for_bit_the_whole_rhs')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                           "&node id='a', type='inertia', inertia=1.0 /"//nl// &
                           "&node id='b', type='inertia', inertia=0.3, damping=0.2 /"//nl// &
                           "&node id='c', type='inertia', inertia=0.7 /"//nl// &
                           "&node id='d', type='inertia', inertia=0.4 /"//nl// &
                           "&node id='e', type='inertia', inertia=1.5 /"//nl// &
                           "&node id='f', type='inertia', inertia=2.0 /"//nl// &
                           "&element type='shaft', stiffness=1e3, left='a', right='b' /"//nl// &
                           "&element type='shaft', stiffness=2e3, damping=0.1, left='b', right='c' /"//nl// &
                           "&element type='spur_gear', stiffness=1e5, rb_driver=1.0, rb_driven=1.5, teeth=20, "// &
                           "contact_ratio=1.5, approach_angle=0.1, half_backlash=0.001, left='c', right='d' /"//nl// &
                           "&element type='shaft', stiffness=3e3, left='d', right='e' /"//nl// &
                           "&element type='keyed_joint', diameter=2.0, half_clearance=0.001, stiffness=1e6, "// &
                           "left='e', right='f' /"//nl// &
                           "&load node='f', value=-3.0 /"//nl, m)
      call m%initial_state(y)
      do i = 1, 12
         y(i) = 0.01_wp*sin(1.7_wp*i) + merge(0.05_wp, 0.0_wp, i == 5)
      end do
      call m%init_modes(0.0_wp, y)
      allocate (full(size(y)), part(size(y)))
      call m%rhs(0.1_wp, y, full)
      part = huge(1.0_wp)
      call m%rhs_part(0.1_wp, y, part, [2, 3, 4, 5], [2, 3, 4], [3, 4])
      call check('the gear is in contact (its torques take part)', m%elements(3)%e%in_contact())
      call check('derivatives of nodes c and d: identical to the bit', all(part(5:8) == full(5:8)))
      call check('no other entry written', all(part(1:4) == huge(1.0_wp)) .and. all(part(9:) == huge(1.0_wp)))
   end subroutine test_rhs_on_a_part_of_the_train_is_bit_for_bit_the_whole_rhs
   !> A model of plain inertias, nodes held at constant speeds and constant
   !> loads runs the RHS kernel `rhs_simple`; the same train with one load
   !> given as a sine of zero amplitude (the same value) runs the generic RHS.
   !> Both must give the same derivatives to the bit (energy rates included),
   !> and the kernel must leave in the workspace each element's torques as
   !> `element_torques` gives them, and for the elements whose `status` it
   !> takes over (status_in_ws: the shafts, damped or not, and the ideal gear)
   !> that status: the observer reads these instead of recomputing them.
   subroutine test_rhs_kernel_is_the_generic_rhs_and_fills_workspace(track)
      logical, intent(in) :: track
      type(model_t) :: ms, mg
      real(wp), allocatable :: y(:), ds(:), dg(:), yk(:), yt(:), ya(:), k2(:), k3(:), k4(:)
      real(wp) :: tl, tr, disp, force, stored, elastic
      integer :: i, contact, pairs
      logical :: torques_ok, status_ok
      character(len=:), allocatable :: train
      call test_begin('simple_rhs_kernel_is_bit_for_bit_the_generic_rhs_and_fills_the_workspace, track_energy = '// &
                      merge('on ', 'off', track))
      train = kernel_train(', damping=0.2')// &
              "&load node='a', quantity='speed', kind='constant', value=5.0 /"//nl// &
              "&load node='c', value=0.5 /"//nl
      call load_model_text("&run t_end = 1e-3, dt = 1e-6, track_energy = "//merge('.true. ', '.false.', track)//' /'// &
                           nl//train//"&load node='g', value=-3.0 /"//nl, ms)
      call load_model_text("&run t_end = 1e-3, dt = 1e-6, track_energy = "//merge('.true. ', '.false.', track)//' /'// &
                           nl//train//"&load node='g', kind='sine', offset=-3.0, amplitude=0.0, frequency=7.0 /"//nl, mg)
      ! the last shaft records its force in other units: its status stays its own
      call swap_in_recording_shaft(ms)
      call swap_in_recording_shaft(mg)
      call ms%initial_state(y)
      do i = 1, 12
         y(i) = 0.01_wp*sin(1.7_wp*i) + merge(0.05_wp, 0.0_wp, i == 3)
      end do
      call ms%init_modes(0.1_wp, y)
      call mg%init_modes(0.1_wp, y)
      allocate (ds(size(y)), dg(size(y)))
      ds = huge(1.0_wp); dg = -huge(1.0_wp)
      call ms%rhs_step_end(0.1_wp, y, ds)
      call mg%rhs_step_end(0.1_wp, y, dg)
      call check('the gear is in contact (its torques take part)', ms%elements(3)%e%in_contact())
      call check('derivatives (energy rates too): identical to the bit', all(ds == dg))
      torques_ok = .true.
      status_ok = .true.
      do i = 1, size(ms%elements)
         call ms%element_torques(i, tl, tr)
         torques_ok = torques_ok .and. tl == ms%el_torque(1, i) .and. tr == ms%el_torque(2, i)
         if (.not. ms%ws_status(i)) cycle
         associate (e => ms%elements(i)%e)
            call e%status(ms%theta(e%left), ms%omega(e%left), ms%theta(e%right), ms%omega(e%right), disp, force, &
                          contact, pairs)
         end associate
         status_ok = status_ok .and. disp == ms%el_disp(i) .and. force == ms%el_force(i) .and. &
                     contact == ms%el_contact(i)
         if (ms%status_in_ws(i)) status_ok = status_ok .and. contact == 1 .and. pairs == 0
      end do
      call check('workspace: every element''s torques, identical to the bit', torques_ok)
      call check('status taken over for the shafts and the ideal gear, not the clearance elements nor a shaft '// &
                 'with a status of its own', all(ms%status_in_ws .eqv. [.true., .true., .false., .true., .false., .false.]))
      call check('the other model runs the generic RHS (no status taken over)', .not. any(mg%status_in_ws))
      ! D-36: the clearance elements in a hot form (the spur gear, the keyed joint) too
      call check('status from the workspace (D-36): also the clearance elements in a hot form', &
                 all(ms%ws_status .eqv. [.true., .true., .true., .true., .true., .false.]) .and. .not. any(mg%ws_status))
      call check('workspace: their displacement, force and contact, identical to the bit', status_ok)
      ! D-36: with energy tracking the kernel leaves the stored energy (every
      ! element a linear spring or a hot form), `workspace_energy`'s to the bit
      call ms%workspace_energy(y, stored, elastic)
      call check('energy in the workspace exactly when tracked (D-36)', (ms%ws_energy .eqv. track) .and. &
                 .not. mg%ws_energy)
      if (track) call check('workspace: stored and elastic energy, identical to the bit (and not zero)', &
                            ms%ws_stored == stored .and. ms%ws_elastic == elastic .and. elastic > 0.0_wp)
      ! an inner stage's RHS (rk4's k2 .. k4): the kernel that stores only dy/dt
      ! and the element torques gives the same derivatives, on both models
      ds = huge(1.0_wp); dg = -huge(1.0_wp)
      call ms%rhs_stage(0.1_wp, y, ds)
      call mg%rhs_stage(0.1_wp, y, dg)
      call check('inner-stage RHS: the same derivatives to the bit, kernel and generic', all(ds == dg))
      call mg%rhs(0.1_wp, y, dg)
      call check('inner-stage RHS: the same derivatives to the bit as the full RHS', all(ds == dg))
      call check('inner-stage RHS: the workspace is not marked as a step end', .not. ms%ws_step_end)
      ! RK4's inner stages at y + c k and the combination in one call (D-75,
      ! D-77): the kernel reads the stages' states without forming them, the
      ! generic model forms them; both give the step of `rhs_stage` at the formed
      ! states to the bit
      yk = [(0.5_wp*cos(0.7_wp*i), i=1, size(y))]
      call rk4_by_stages(ms, 0.1_wp, 0.37_wp, y, yk, ds)
      allocate (k2(size(y)), k3(size(y)), k4(size(y)))
      dg = -huge(1.0_wp)
      ya = y + huge(1.0_wp)
      yt = ya
      call ms%rk4_stages(0.1_wp, 0.37_wp, 0.1_wp + 0.37_wp, y, yk, k2, k3, k4, ya, dg)
      call check('RK4 step from inner stages at y + c k, kernel: to the bit the stages at the states', &
                 all(ds == dg) .and. all(ya == yt))
      dg = -huge(1.0_wp)
      call rk4_by_stages(mg, 0.1_wp, 0.37_wp, y, yk, ds)
      call mg%rk4_stages(0.1_wp, 0.37_wp, 0.1_wp + 0.37_wp, y, yk, k2, k3, k4, ya, dg)
      call check('RK4 step from inner stages at y + c k, generic (forms them in ytmp): to the bit', &
                 all(ds == dg) .and. all(ya == y + 0.37_wp*k3))
   end subroutine test_rhs_kernel_is_the_generic_rhs_and_fills_workspace

   !> Every clearance element type of the registry, with every contact law it
   !> takes: in every face (and, for the spur gear, both zones), at random
   !> states, the model's kernels (inner stage, full RHS with energy rates) and
   !> guards give the element's own torques, dissipated power and guards to the
   !> bit, and the hot form (D-35) is taken where it should be.
   subroutine test_hot_forms_are_the_elements_own_arithmetic()
      integer, parameter :: n_el = 9
      character(len=240) :: el(n_el)
      ! expected torque form when closed / when open, guard form (no_tension, 2 and 9, and
      ! elasto_backlash, 8: none, the clip's guard reads the speeds, D-136, D-141)
      integer, parameter :: want_closed(n_el) = [hf_yang_sun, hf_yang_sun, hf_none, hf_yang_sun, hf_none, &
                                                 hf_linear, hf_yang_sun, hf_none, hf_linear]
      integer, parameter :: want_open(n_el) = [hf_open, hf_open, hf_none, hf_open, hf_none, hf_open, hf_open, &
                                               hf_open, hf_open]
      integer, parameter :: want_g(n_el) = [hg_faces_zone, hg_none, hg_faces, hg_faces, hg_faces, hg_faces, &
                                            hg_faces, hg_none, hg_none]
      type(model_t) :: m
      real(wp), allocatable :: y(:), dydt(:), g(:)
      real(wp) :: ge(4), x(4), tl, tr, pw, sgn, b, disp, force, stored, elastic, gone
      integer :: ie, face, p, kind, gk, ng, zones(2), nz, contact, pairs, il, ir, k
      logical :: torques_ok, power_ok, guards_ok, kinds_ok, track, status_ok, energy_ok, angles_ok
      call test_begin('hot_forms_are_the_elements_own_arithmetic')
      angles_ok = .true.
      el(1) = "type='spur_gear', stiffness=1e5, rb_driver=1.0, rb_driven=1.5, teeth=20, contact_ratio=1.5, "// &
              "approach_angle=0.1, half_backlash=0.001, initial_contact_velocity=0.3"
      el(2) = "type='spur_gear', stiffness=1e5, rb_driver=1.0, rb_driven=1.5, teeth=20, contact_ratio=1.5, "// &
              "approach_angle=0.1, half_backlash=0.001, no_tension=.true., two_pair_factor=2.0, zone_function='truncate'"
      el(3) = "type='helical_gear', rb_driver=1.5, rb_driven=1.5, teeth=30, profile_contact_ratio=1.5, "// &
              "base_helix_angle=20.0, face_width=1.0, half_backlash=0.001"
      el(4) = "type='keyed_joint', diameter=2.0, half_clearance=0.001, stiffness=1e6, initial_contact_velocity=0.2"
      el(5) = "type='keyed_joint', diameter=2.0, half_clearance=0.001, stiffness_fit='tight', key_length=1.0"
      el(6) = "type='clearance_coupling', clearance=0.02, stiffness=1e4, contact_damping=1.0"
      el(7) = "type='clearance_coupling', clearance=0.02, stiffness=1e4, contact_law='yang_sun', radius=0.1, "// &
              "initial_contact_velocity=0.2, restitution_law='smith'"
      el(8) = "type='clearance_coupling', clearance=0.02, stiffness=1e4, contact_law='elasto_backlash', contact_damping=2.0"
      el(9) = "type='clearance_coupling', clearance=0.02, stiffness=1e4, contact_damping=1.5, no_tension=.true."
      torques_ok = .true.; power_ok = .true.; guards_ok = .true.; kinds_ok = .true.
      status_ok = .true.; energy_ok = .true.
      do ie = 1, 2*n_el
         track = ie > n_el
         call load_model_text("&run t_end = 1e-3, dt = 1e-6, track_energy = "//merge('.true. ', '.false.', track)// &
                              " /"//nl//"&node type='inertia', inertia=1.3 /"//nl// &
                              "&node type='inertia', inertia=0.7 /"//nl//"&element "//trim(el(1 + mod(ie - 1, n_el)))// &
                              " /"//nl, m)
         call m%initial_state(y)
         allocate (dydt(size(y)), g(m%n_guards))
         ng = m%n_guards
         nz = 1
         zones = [0, 0]
         do face = -1, 1
            do p = 1, 40
               associate (e => m%elements(1)%e)
                  ! a random state near the face: delta = s b (1 + 2u), u in [-1, 1]
                  ! (penetrations of either sign), the driven angle over a few teeth
                  sgn = merge(1.0_wp, -1.0_wp, face >= 0)
                  b = merge(0.01_wp, 0.001_wp, e%displacement_unit() == 'rad')
                  x(2) = 3.0_wp*sin(78.233_wp*p + face)
                  x(3) = sin(39.425_wp*p + 2*face)
                  x(4) = 3.0_wp*sin(4.1_wp*p)
                  x(1) = (sgn*b*(1.0_wp + 2.0_wp*sin(12.9898_wp*p)) - e%displacement(0.0_wp, x(3)))/ &
                         e%displacement(1.0_wp, 0.0_wp)
                  y(1:4) = x
                  call m%preload_mode(1, face, x(1), x(2), x(3), x(4))
                  call m%hot_kinds(1, kind, gk)
                  if (face == 0) then
                     kinds_ok = kinds_ok .and. kind == want_open(1 + mod(ie - 1, n_el))
                  else
                     kinds_ok = kinds_ok .and. kind == want_closed(1 + mod(ie - 1, n_el))
                  end if
                  kinds_ok = kinds_ok .and. gk == want_g(1 + mod(ie - 1, n_el))
                  ! the inner-stage kernel, then the full RHS (energy rates when tracked)
                  call m%rhs_stage(0.0_wp, y, dydt)
                  call e%torques(x(1), x(2), x(3), x(4), tl, tr)
                  torques_ok = torques_ok .and. tl == m%el_torque(1, 1) .and. tr == m%el_torque(2, 1)
                  call m%rhs_step_end(0.0_wp, y, dydt)
                  torques_ok = torques_ok .and. tl == m%el_torque(1, 1) .and. tr == m%el_torque(2, 1)
                  if (track) then
                     call e%torques_dissipation(x(1), x(2), x(3), x(4), tl, tr, pw)
                     power_ok = power_ok .and. dydt(m%n_states + 1) == pw
                  end if
                  ! D-36: a hot form's status (displacement, signed force, face)
                  ! and, tracked, the stored energy are left in the workspace
                  call e%status(x(1), x(2), x(3), x(4), disp, force, contact, pairs)
                  status_ok = status_ok .and. (m%ws_status(1) .eqv. kind /= hf_none)
                  if (m%ws_status(1)) status_ok = status_ok .and. disp == m%el_disp(1) .and. &
                                                  force == m%el_force(1) .and. contact == m%el_contact(1)
                  energy_ok = energy_ok .and. (m%ws_energy .eqv. (track .and. kind /= hf_none))
                  if (m%ws_energy) then
                     call m%workspace_energy(y, stored, elastic)
                     energy_ok = energy_ok .and. m%ws_stored == stored .and. m%ws_elastic == elastic .and. &
                                 elastic == e%potential_energy(x(1), x(3))
                  end if
                  call m%guards(0.0_wp, y, g)
                  call e%guards(x(1), x(2), x(3), x(4), ge(1:ng))
                  guards_ok = guards_ok .and. all(g == ge(1:ng))
                  call m%element_guards(1, 0.0_wp, y, g)
                  guards_ok = guards_ok .and. all(g == ge(1:ng))
                  ! one guard at a time (event location), and from the two angles
                  ! where the model says the guards read only those (two plain
                  ! inertias: states 1 and 3, whenever the guard form is hot)
                  call m%guard_angles(1, il, ir)
                  angles_ok = angles_ok .and. ((il == 1 .and. ir == 3) .eqv. gk /= hg_none) .and. &
                              (il == 0 .eqv. ir == 0)
                  do k = 1, ng
                     gone = m%element_guard(1, k, 0.0_wp, y)
                     guards_ok = guards_ok .and. gone == ge(k)
                     if (il > 0) angles_ok = angles_ok .and. m%angle_guard(1, k, y(il), y(ir)) == ge(k)
                  end do
                  if (ng == 4 .and. face /= 0) then
                     call e%status(x(1), x(2), x(3), x(4), tl, tr, kind, gk)
                     zones(gk) = 1
                  end if
               end associate
            end do
         end do
         if (ng == 4) nz = sum(zones)
         call check(trim(el(1 + mod(ie - 1, n_el)))//merge(' (energy on)', '            ', track)// &
                    ': both mesh zones visited', nz == merge(2, 1, ng == 4))
         deallocate (dydt, g)
      end do
      call check('hot forms taken (or declined) as expected', kinds_ok)
      call check('kernel torques are the element''s own, to the bit', torques_ok)
      call check('kernel dissipated power is the element''s own, to the bit', power_ok)
      call check('guards (all, one element''s, one guard) are the element''s own, to the bit', guards_ok)
      call check('a hot guard form on two plain inertias: guard_angles names their angles, angle_guard '// &
                 'is the element''s guard from them, to the bit', angles_ok)
      call check('D-36: a hot form''s status in the workspace is the element''s own, to the bit', status_ok)
      call check('D-36: the stored energy in the workspace is workspace_energy''s, to the bit', energy_ok)
   end subroutine test_hot_forms_are_the_elements_own_arithmetic

   !> The hot form follows every mode change the model makes (an event through
   !> `apply_events`, `init_modes`, `preload_mode`); a change made on the
   !> element behind the model's back is not seen (the contract the test
   !> relies on: without the refresh the kernel's torques would be stale).
   subroutine test_hot_form_follows_mode_changes()
      type(joint_case_t), target :: jc
      real(wp) :: tl, tr
      integer :: nev, kind, gk
      call test_begin('hot_form_follows_mode_changes')
      call open_keyed_joint(jc)
      associate (m => jc%m, y => jc%y, dydt => jc%dydt, g => jc%g, fired => jc%fired)
      call m%hot_kinds(1, kind, gk)
      call check('init_modes: open', kind == hf_open .and. gk == hg_faces)
      call close_on_face(jc, 1, nev, kind, gk)
      call check('apply_events: an impact, the form now closed (yang_sun)', nev == 1 .and. kind == hf_yang_sun)
      call m%rhs_stage(0.0_wp, y, dydt)
      call m%elements(1)%e%torques(y(1), y(2), y(3), y(4), tl, tr)
      call check('after the event: the kernel''s torques are the element''s, to the bit, and not zero', &
                 tl == m%el_torque(1, 1) .and. tr == m%el_torque(2, 1) .and. tl /= 0.0_wp)
      call m%preload_mode(1, -1, y(1), y(2), y(3), y(4))
      call m%rhs_stage(0.0_wp, y, dydt)
      call m%elements(1)%e%torques(y(1), y(2), y(3), y(4), tl, tr)
      call check('preload_mode (rear face): the kernel''s torques are the element''s, to the bit', &
                 tl == m%el_torque(1, 1) .and. tr == m%el_torque(2, 1))
      ! behind the model's back: the element opens, the model's record does not know
      call m%elements(1)%e%preload_mode(0, y(1), y(2), y(3), y(4))
      call m%rhs_stage(0.0_wp, y, dydt)
      call m%elements(1)%e%torques(y(1), y(2), y(3), y(4), tl, tr)
      call check('a mode set on the element directly is not seen by the kernel (the refresh is what keeps it '// &
                 'current)', tl == 0.0_wp .and. m%el_torque(1, 1) /= 0.0_wp)
      call m%init_modes(0.0_wp, y)
      call m%rhs_stage(0.0_wp, y, dydt)
      call m%elements(1)%e%torques(y(1), y(2), y(3), y(4), tl, tr)
      call check('init_modes refreshes it again', tl == m%el_torque(1, 1) .and. tr == m%el_torque(2, 1))
      end associate
   end subroutine test_hot_form_follows_mode_changes

   !> Two disks on a keyed joint, inside its clearance (open), modes set; with
   !> `lying` present the joint is a rear_lying_joint_t that vouches if lying.
   subroutine open_keyed_joint(jc, lying)
      type(joint_case_t), intent(inout) :: jc
      logical, intent(in), optional :: lying
      type(rear_lying_joint_t) :: lj
      call load_model_text("&run t_end = 1e-3, dt = 1e-6, track_energy = .false. /"//nl// &
                           "&node type='inertia', inertia=1.3 /"//nl//"&node type='inertia', inertia=0.7 /"//nl// &
                           "&element type='keyed_joint', diameter=2.0, half_clearance=0.001, stiffness=1e6 /"//nl, jc%m)
      if (present(lying)) then
         select type (e => jc%m%elements(1)%e)
         type is (keyed_joint_t)
            lj%keyed_joint_t = e
         end select
         lj%vouch = lying
         deallocate (jc%m%elements(1)%e)
         allocate (jc%m%elements(1)%e, source=lj)
      end if
      call jc%m%initial_state(jc%y)
      allocate (jc%dydt(size(jc%y)), jc%g(jc%m%n_guards), jc%fired(jc%m%n_guards), jc%events(4))
      jc%y(1:4) = [0.0_wp, 1.0_wp, 0.0_wp, -1.0_wp]       ! inside the clearance: open
      call jc%m%init_modes(0.0_wp, jc%y)
   end subroutine open_keyed_joint

   !> The key of `open_keyed_joint` closed on a face (1 front, -1 rear: delta =
   !> r (thl - thr) = +-0.0015, beyond b), that face's guard checked below zero
   !> and its event applied: nev events, the hot kinds after.
   subroutine close_on_face(jc, face, nev, kind, gk)
      type(joint_case_t), intent(inout) :: jc
      integer, intent(in) :: face
      integer, intent(out) :: nev, kind, gk
      integer :: k
      k = merge(1, 2, face == 1)
      jc%y(1:4) = face*[0.0015_wp, 1.0_wp, 0.0_wp, -1.0_wp]
      call jc%m%guards(0.0_wp, jc%y, jc%g)
      call check('the '//merge('front', 'rear ', face == 1)//'-face guard has crossed', jc%g(k) < 0.0_wp)
      jc%fired = .false.
      jc%fired(k) = .true.
      nev = 0
      call jc%m%apply_events(0.0_wp, jc%y, jc%fired, jc%events, nev)
      call jc%m%hot_kinds(1, kind, gk)
   end subroutine close_on_face

   !> D-167: a mode change probes the element's record (its hot form) against
   !> its own procedures again, unless the record vouches for itself in every
   !> mode (hot_form_t%exact, the house's spur gear) and passed the probes
   !> since the last `init_modes`. A keyed joint that lies about its rear face
   !> (its torques there twice its record's), open at the start: without a
   !> vouch the event to the rear face demotes its record (the kernel then asks
   !> its torques); with one the record is kept (the probes are skipped), until
   !> `init_modes` probes it again.
   subroutine test_hot_form_probed_again_unless_it_vouches(vouch)
      logical, intent(in) :: vouch
      type(joint_case_t), target :: jc
      real(wp) :: tl, tr
      integer :: nev, kind, gk
      call test_begin('hot_form_probed_again_unless_it_vouches ('//merge('vouching    ', 'not vouching', vouch)//')')
      call open_keyed_joint(jc, lying=vouch)
      associate (m => jc%m, y => jc%y, dydt => jc%dydt, g => jc%g, fired => jc%fired)
      call m%hot_kinds(1, kind, gk)
      call check('init_modes: open, in its hot form (the probes pass: open, no torque)', kind == hf_open)
      call close_on_face(jc, -1, nev, kind, gk)
      call m%rhs_stage(0.0_wp, y, dydt)
      call m%elements(1)%e%torques(y(1), y(2), y(3), y(4), tl, tr)
      if (vouch) then
         call check('vouching: the record kept at the event (not probed again), its torques half the element''s', &
                    nev == 1 .and. kind == hf_yang_sun .and. m%el_torque(1, 1) == 0.5_wp*tl .and. tl /= 0.0_wp)
      else
         call check('not vouching: probed at the event, the record demoted, the kernel asks the element''s torques', &
                    nev == 1 .and. kind == hf_none .and. m%el_torque(1, 1) == tl .and. tl /= 0.0_wp)
      end if
      call m%init_modes(0.0_wp, y)
      call m%hot_kinds(1, kind, gk)
      call m%rhs_stage(0.0_wp, y, dydt)
      call m%elements(1)%e%torques(y(1), y(2), y(3), y(4), tl, tr)
      call check('init_modes probes it again: demoted, the element''s torques', &
                 kind == hf_none .and. m%el_torque(1, 1) == tl .and. tl /= 0.0_wp)
      end associate
   end subroutine test_hot_form_probed_again_unless_it_vouches

   !> The inner-stage kernel with energy tracking (`rhs_stage_energy`) sums the
   !> nodes' power terms on a serial chain apart from the elements' and joins
   !> them at the end only where that gives the same sums; else it adds them
   !> again after the elements'. On chains that take each of its ways (no term
   !> from an element or a node; only a node's; only an element's; both; an
   !> element that feeds power in; a held node in the middle and at the end)
   !> and on a branched train (with a held node of three element torques too), at random states, its dy/dt (the dissipated and
   !> the input power included) must be the full RHS's (which sums the
   !> elements' terms, then the nodes', in one pass) to the bit.
   subroutine test_stage_energy_rates_are_the_full_rhs_own()
      integer, parameter :: n_case = 8
      character(len=:), allocatable :: deck
      character(len=60) :: what(n_case)
      type(model_t) :: m
      real(wp), allocatable :: y(:), ds(:), df(:), yk(:), dk(:), ya(:), k2(:), k3(:), k4(:)
      type(powered_shaft_t) :: ps
      integer :: ic, p, i
      logical :: same, nonzero, same_at
      call test_begin('stage_energy_rates_are_the_full_rhs_own')
      what = [character(len=60) :: 'chain, no dissipation (the rig''s way)', 'chain, a damped node only', &
              'chain, a damped shaft only', 'chain, damped nodes and shaft, a clearance', &
              'chain, an element feeding power in, damped nodes', 'chain, held nodes in the middle and at the end', &
              'branched train (no chain)', 'branched, a held node with three element torques']
      do ic = 1, n_case
         deck = "&run t_end = 1e-3, dt = 1e-6, track_energy = .true. /"//nl// &
                "&node id='a', type='inertia', inertia=1.0 /"//nl// &
                "&node id='b', type='inertia', inertia=0.3"//merge(", damping=0.2", "             ", &
                                                                   any(ic == [2, 4, 5]))//" /"//nl// &
                "&node id='c', type='inertia', inertia=0.7"//merge(", damping=1.3e-3", "                ", &
                                                                   any(ic == [4, 5]))//" /"//nl// &
                "&node id='d', type='inertia', inertia=0.4"//merge(", damping=0.05", "              ", &
                                                                   any(ic == [4, 5, 6]))//" /"//nl// &
                "&node id='e', type='inertia', inertia=1.5 /"//nl// &
                "&element type='shaft', stiffness=1e3, left='a', right='b' /"//nl// &
                "&element type='shaft', stiffness=2e3"//merge(", damping=0.1", "             ", any(ic == [3, 4, 7, 8]))// &
                ", left='b', right='c' /"//nl
         if (ic == 4) then
            deck = deck//"&element type='keyed_joint', diameter=2.0, half_clearance=0.001, stiffness=1e6, "// &
                   "left='c', right='d' /"//nl
         else
            deck = deck//"&element type='ideal_gear', stiffness=2e4, rb_driver=0.7, rb_driven=1.1, left='c', "// &
                   "right='d' /"//nl
         end if
         if (ic >= 7) then
            deck = deck//"&element type='shaft', stiffness=3e3, left='c', right='e' /"//nl
         else
            deck = deck//"&element type='shaft', stiffness=3e3, left='d', right='e' /"//nl
         end if
         deck = deck//"&load node='a', quantity='speed', kind='constant', value=5.0 /"//nl// &
                "&load node='b', value=0.5 /"//nl//"&load node='e', value=-3.0 /"//nl
         if (ic == 6 .or. ic == 8) deck = deck//"&load node='c', quantity='speed', kind='constant', value=-2.0 /"//nl
         if (ic == 6) deck = deck//"&load node='e', quantity='speed', kind='constant', value=1.5 /"//nl
         call load_model_text(deck, m)
         if (ic == 5) then
            ! the shaft b-c feeds power in (an element asked through its procedures)
            select type (sh => m%elements(2)%e)
            type is (shaft_t)
               ps%shaft_t = sh
            end select
            ps%supplies_power = .true.
            deallocate (m%elements(2)%e)
            allocate (m%elements(2)%e, source=ps)
         end if
         call m%initial_state(y)
         allocate (ds(size(y)), df(size(y)), dk(size(y)), ya(size(y)), k2(size(y)), k3(size(y)), k4(size(y)))
         same = .true.
         same_at = .true.
         nonzero = .true.
         do p = 1, 25
            do i = 1, m%n_states
               y(i) = 0.01_wp*sin(1.7_wp*i + 0.61_wp*p) + merge(3.0_wp*cos(0.3_wp*p + i), 0.0_wp, mod(i, 2) == 0)
            end do
            call m%init_modes(0.1_wp*p, y)
            ds = huge(1.0_wp)
            df = -huge(1.0_wp)
            call m%rhs_stage(0.1_wp*p, y, ds)
            call m%rhs(0.1_wp*p, y, df)
            same = same .and. all(ds == df)
            ! RK4's inner stages at y + c k and its combination (D-75, D-77),
            ! energy rates included: to the bit the stages at the formed states
            yk = [(0.3_wp*sin(0.9_wp*i + p), i=1, size(y))]
            call rk4_by_stages(m, 0.1_wp*p, 0.25_wp, y, yk, df)
            dk = -huge(1.0_wp)
            call m%rk4_stages(0.1_wp*p, 0.25_wp, 0.1_wp*p + 0.25_wp, y, yk, k2, k3, k4, ya, dk)
            same_at = same_at .and. all(dk == df)
            ! the rates are not trivially zero (an input from the loads or a held node)
            nonzero = nonzero .and. ds(m%n_states + 2) /= 0.0_wp
         end do
         call check(trim(what(ic))//': dy/dt and the energy rates to the bit the full RHS''s', same)
         call check(trim(what(ic))//': the RK4 step from stages at y + c k to the bit the formed stages', same_at)
         call check(trim(what(ic))//': the input power is not zero', nonzero)
         if (ic == 1) call check(trim(what(ic))//': nothing dissipates', ds(m%n_states + 1) == 0.0_wp)
         if (ic /= 1) call check(trim(what(ic))//': something dissipates', ds(m%n_states + 1) > 0.0_wp)
         deallocate (ds, df, dk, ya, k2, k3, k4)
      end do
   end subroutine test_stage_energy_rates_are_the_full_rhs_own

   !> Element 6 (a shaft) replaced by a recording_shaft_t with its parameters.
   subroutine swap_in_recording_shaft(m)
      type(model_t), intent(inout) :: m
      type(recording_shaft_t) :: rs
      select type (sh => m%elements(6)%e)
      type is (shaft_t)
         rs%shaft_t = sh
      end select
      deallocate (m%elements(6)%e)
      allocate (m%elements(6)%e, source=rs)
   end subroutine swap_in_recording_shaft
   !> A clearance element whose left node is held at a prescribed speed: its guards
   !> read an angle that is not a state, so the model has no angle row for them
   !> (guard_angles: 0) and asks through node kinematics; a second clearance
   !> between two plain inertias has its row, and the model then takes the
   !> general loop for both. The guards, one at a time too, are still the
   !> elements' own (at the held node's angle at t), to the bit, in every mode.
   subroutine test_guards_next_to_a_held_node_are_the_elements_own()
      type(model_t) :: m
      real(wp), allocatable :: y(:), g(:)
      real(wp) :: ge(6), t, thl, wl, gone
      integer :: face, p, k, il, ir, ng, n1
      logical :: ok, rows_ok
      call test_begin('guards_next_to_a_held_node_are_the_elements_own')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                           "&node id = 'a', type='inertia', inertia=1.3 /"//nl// &
                           "&node id = 'b', type='inertia', inertia=0.7 /"//nl// &
                           "&node id = 'c', type='inertia', inertia=0.9 /"//nl// &
                           "&element type='spur_gear', stiffness=1e5, rb_driver=1.0, rb_driven=1.5, teeth=20, "// &
                           "contact_ratio=1.5, approach_angle=0.1, half_backlash=0.001 /"//nl// &
                           "&element type='clearance_coupling', clearance=0.02, stiffness=1e4, contact_damping=1.0 /"//nl// &
                           "&load node = 'a', quantity = 'speed', kind = 'constant', value = 2.5 /"//nl, m)
      call m%initial_state(y)
      ng = m%n_guards
      n1 = m%elements(1)%e%n_guards()
      allocate (g(ng))
      call check('the spur gear has four guards, the coupling two', ng == 6 .and. n1 == 4)
      ok = .true.
      rows_ok = .true.
      do face = -1, 1
         do p = 1, 10
            t = 1.0e-4_wp*p
            y(1) = 0.3_wp*sin(3.7_wp*p + face)            ! node b's angle and speed, then c's
            y(2) = 2.0_wp*sin(1.3_wp*p)
            y(3) = y(1) - 0.01_wp*(1.0_wp + face*(1.0_wp + 0.1_wp*sin(5.1_wp*p)))
            y(4) = 1.5_wp*sin(2.9_wp*p)
            thl = m%nodes(1)%n%theta0 + 2.5_wp*t            ! the held node at t
            wl = 2.5_wp
            call m%preload_mode(1, face, thl, wl, y(1), y(2))
            call m%preload_mode(2, face, y(1), y(2), y(3), y(4))
            call m%guard_angles(1, il, ir)
            rows_ok = rows_ok .and. il == 0 .and. ir == 0
            call m%guard_angles(2, il, ir)
            rows_ok = rows_ok .and. il == 1 .and. ir == 3
            call m%elements(1)%e%guards(thl, wl, y(1), y(2), ge(1:n1))
            call m%elements(2)%e%guards(y(1), y(2), y(3), y(4), ge(n1 + 1:ng))
            call m%guards(t, y, g)
            ok = ok .and. all(g == ge(1:ng))
            do k = 1, n1
               gone = m%element_guard(1, k, t, y)
               ok = ok .and. gone == ge(k)
            end do
            do k = 1, ng - n1
               gone = m%element_guard(2, k, t, y)
               ok = ok .and. gone == ge(n1 + k)
            end do
         end do
      end do
      call check('no angle row for guards that read a held node, one for the coupling', rows_ok)
      call check('guards (all, one at a time) are the elements'' own, to the bit', ok)
   end subroutine test_guards_next_to_a_held_node_are_the_elements_own

   !> RK4's step from (t, y) with k1 given, through `rhs_stage` at the formed
   !> stages' states and the combination in its order: what `rk4_stages` must
   !> give to the bit (D-77).
   subroutine rk4_by_stages(m, t, h, y, k1, ynew)
      type(model_t), intent(inout) :: m
      real(wp), intent(in) :: t, h, y(:), k1(:)
      real(wp), intent(out) :: ynew(:)
      real(wp), allocatable :: k2(:), k3(:), k4(:)
      allocate (k2(size(y)), k3(size(y)), k4(size(y)))
      call m%rhs_stage(t + 0.5_wp*h, y + 0.5_wp*h*k1, k2)
      call m%rhs_stage(t + 0.5_wp*h, y + 0.5_wp*h*k2, k3)
      call m%rhs_stage(t + h, y + h*k3, k4)
      ynew = y + h/6.0_wp*(k1 + 2.0_wp*(k2 + k3) + k4)
   end subroutine rk4_by_stages

end program test_elements
