!> The helical gear's issue-26 leftovers (D-116) against hand geometry on the
!> plane of action, written here independently of the element:
!> a 24/48-tooth pair on r_b1 = 1.4095 in, m_p = 1.55, beta_b = 18 deg,
!> face 1.2 in (m_F = F tan(beta_b) / p_b = 1.06).
!> 1. The lines of contact: their roll extents summed, over sin(beta_b), equal
!>    L_c of eq. (6.1) (Colbourne) at every mesh position.
!> 2. Tooth friction over the lines: the torques with mu minus without at a
!>    steady deflection, against a midpoint quadrature along each line of
!>    contact in the face coordinate z (load per unit length W_n / L_c, W_n =
!>    W / cos beta_b, friction mu W_n against the slide, arm rho1 = T1P + s - AP).
!>    A narrow face (m_F = 0.02): the driver's friction torque changes sign as
!>    the single line passes the pitch point (within the line's roll extent).
!>    tooth_friction_model = 'speed' (D-129): the same quadrature with tanh(v_s/v_reg)
!>    for sign(v_s), at speed and near rest (both branches of trainsim_slide_integrals).
!> 3. Analytic Jacobian with friction against central differences ('constant', 'speed').
!> 4. A loaded run with friction closes its energy ledger; friction dissipates.
!> 5. Crowning: the loaded TE (the mean gap over the lines) and the unloaded TE
!>    (the least gap) against Simpson's rule along each line (exact for a
!>    parabola), over a mesh cycle; a run with crowning closes its ledger.
!> 6. stiffness_model = 'iso6336': ISO 6336-1 method B by hand for the virtual
!>    spur pair; the mean of k L_c over a mesh cycle is c_gamma_alpha b.
!> 7. `modes` ignore tooth friction (its linearisation is not symmetric and
!>    changes sign at the pitch point): the frequencies with mu = 0.08 are those
!>    with mu = 0, spur and helical.
program test_helical_mesh
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_error, only: error_t
   use trainsim_modes, only: modes_t, compute_modes
   use trainsim_el_helical_gear, only: helical_contact_length, contact_lines, max_lines
   use trainsim_param_list, only: param_list_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, run_model, nl, jacobian_fd_error, real_text
   implicit none

   real(wp), parameter :: rb1 = 1.4095_wp, rb2 = 2.819_wp, n1 = 24.0_wp, mp = 1.55_wp, face = 1.2_wp
   real(wp), parameter :: hb = 0.002_wp, pen = 2.0e-4_wp, mu = 0.08_wp, w1 = 60.0_wp
   real(wp) :: zeta, pb, mf, alpha_n, beta, alpha_t, t1p, t2p, ap, alpha
   character(len=*), parameter :: head = "&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                                          "&node id = 'a', type = 'inertia', inertia = 0.02 /"//nl// &
                                          "&node id = 'b', type = 'inertia', inertia = 0.08 /"//nl
   character(len=:), allocatable :: mesh

   call suite_begin('helical gear: friction over the lines of contact, crowning, ISO 6336 stiffness (D-116)')
   call hand_geometry()
   call lines_are_eq_6_1()
   call friction_against_quadrature('', w1, 0.0_wp)
   call friction_against_quadrature("tooth_friction_model = 'speed', tooth_friction_velocity = 1.0", w1, 1.0_wp)
   call friction_against_quadrature("tooth_friction_model = 'speed', tooth_friction_velocity = 1.0", 1.0e-3_wp, 1.0_wp)
   call friction_reverses_at_the_pitch_point()
   call jacobian_with_friction('', 0.0_wp, 60.0_wp)
   call jacobian_with_friction('', 0.071_wp, 60.0_wp)
   call jacobian_with_friction("tooth_friction_model = 'speed', tooth_friction_velocity = 20.0", 0.0_wp, 60.0_wp)
   call jacobian_with_friction("tooth_friction_model = 'speed', tooth_friction_velocity = 20.0", 0.071_wp, 60.0_wp)
   call jacobian_with_friction("tooth_friction_model = 'speed', tooth_friction_velocity = 1.0", 0.071_wp, 1.0e-3_wp)
   call ledger("tooth_friction = 0.08", .true.)
   call ledger("tooth_friction = 0.08, tooth_friction_model = 'speed', tooth_friction_velocity = 0.5", .true.)
   call ledger("crowning = 4e-4", .false.)
   call crowning_against_simpson()
   call iso_stiffness_by_hand()
   call modes_ignore_friction()
   call suite_end()

contains

   subroutine hand_geometry()
      zeta = 18.0_wp*pi/180.0_wp
      pb = two_pi*rb1/n1
      mf = face*tan(zeta)/pb
      alpha_n = 20.0_wp*pi/180.0_wp
      beta = asin(sin(zeta)/cos(alpha_n))
      alpha_t = atan(tan(alpha_n)/cos(beta))
      t1p = rb1*tan(alpha_t); t2p = rb2*tan(alpha_t)
      alpha = pi*mp/n1                                ! the pitch point mid-path
      ap = alpha*rb1
      mesh = "&element id = 'mesh', type = 'helical_gear', left = 'a', right = 'b', rb_driver = 1.4095, "// &
             "rb_driven = 2.819, teeth = 24, profile_contact_ratio = 1.55, base_helix_angle = 18.0, "// &
             "half_backlash = 0.002, approach_angle = "//real_text(alpha)
   end subroutine hand_geometry

   pure real(wp) function driven_angle(th) result(thr)
      real(wp), intent(in) :: th
      thr = (rb1*th - (hb + pen))/rb2
   end function driven_angle

   subroutine lines_are_eq_6_1()
      real(wp) :: c(max_lines), lo(max_lines), hi(max_lines), dlo(max_lines), dhi(max_lines), e, worst, lc
      real(wp) :: cases(2, 3)
      integer :: i, k, n
      call test_begin('lines of contact: sum of roll extents / sin(beta_b) = L_c of eq. (6.1)')
      cases = reshape([mp, mf, 1.6_wp, 1.0_wp, 1.3_wp, 2.45_wp], [2, 3])
      worst = 0.0_wp
      do k = 1, 3
         do i = 0, 999
            e = (i + 0.5_wp)/1000.0_wp
            call contact_lines(e, cases(1, k), cases(2, k), c, lo, hi, dlo, dhi, n)
            lc = helical_contact_length(e, cases(1, k), cases(2, k), pb, zeta)
            worst = max(worst, abs(sum(hi(1:n) - lo(1:n))*pb/sin(zeta) - lc)/lc)
         end do
      end do
      ! two sums of a few O(1) terms: rounding
      call check('max relative difference over 3000 positions', worst, 0.0_wp, abs_tol=1.0e-14_wp)
   end subroutine lines_are_eq_6_1

   !> The friction torques by midpoint quadrature along the lines in z: the line of
   !> mesh coordinate c_j = e + j (base pitches) is at roll x = c_j - z tan(beta_b)/p_b.
   subroutine hand_friction(th, wl, wr, w, vr, f1, f2)
      real(wp), intent(in) :: th, wl, wr, w, vr       !< vr > 0: tanh(v_s/vr) for sign(v_s) ('speed')
      real(wp), intent(out) :: f1, f2
      integer, parameter :: nz = 200000
      real(wp) :: u, e, cj, z, x, s, rho1, rho2, v, g1, g2, lc, dz, sg
      integer :: j, i
      u = n1*(th + alpha)/two_pi
      e = u - floor(u)
      g1 = 0.0_wp; g2 = 0.0_wp; lc = 0.0_wp
      dz = face/nz
      do j = 0, 5
         cj = e + j
         do i = 1, nz
            z = (i - 0.5_wp)*dz
            x = cj - z*tan(zeta)/pb
            if (x < 0.0_wp .or. x > mp) cycle
            s = x*pb
            rho1 = t1p + (s - ap); rho2 = t2p - (s - ap)
            v = wl*rho1 - wr*rho2
            sg = sign(1.0_wp, v)
            if (vr > 0.0_wp) sg = tanh(v/vr)
            g1 = g1 + sg*rho1*dz/cos(zeta)
            g2 = g2 + sg*rho2*dz/cos(zeta)
            lc = lc + dz/cos(zeta)
         end do
      end do
      f1 = -mu*(w/cos(zeta))*g1/lc
      f2 = mu*(w/cos(zeta))*g2/lc
   end subroutine hand_friction

   !> The driver at wl, the driven at the matching speed; vr > 0: the 'speed' model.
   subroutine friction_against_quadrature(model, wl, vr)
      character(len=*), intent(in) :: model
      real(wp), intent(in) :: wl, vr
      type(model_t) :: mf_, m0
      real(wp) :: th, thr, tl, tr, tl0, tr0, h1, h2, w, worst, scale, big
      integer :: i, np_
      call test_begin('friction torques over a mesh cycle = quadrature along the lines of contact '// &
                      trim(model)//' at '//real_text(wl)//' rad/s')
      call load_model_text(head//mesh//", face_width = 1.2, tooth_friction = 0.08"//opt(model)//" /", mf_)
      call load_model_text(head//mesh//", face_width = 1.2 /", m0)
      worst = 0.0_wp; big = 0.0_wp
      scale = mu*(30.0e6_wp/17.6_wp)*pen*mp*face/cos(zeta)/cos(zeta)*t1p   ! mu W_n rho1 at the mean load
      np_ = merge(100, 20, vr == 0.0_wp)   ! 'speed': 20 positions (the quadrature's 1.2e7 cells each)
      do i = 0, np_ - 1
         th = (i + 0.5_wp)*(two_pi/n1)/real(np_, wp)
         thr = driven_angle(th)
         call mf_%elements(1)%e%init_mode(th, wl, thr, wl*rb1/rb2)
         call m0%elements(1)%e%init_mode(th, wl, thr, wl*rb1/rb2)
         call mf_%elements(1)%e%torques(th, wl, thr, wl*rb1/rb2, tl, tr)
         call m0%elements(1)%e%torques(th, wl, thr, wl*rb1/rb2, tl0, tr0)
         w = tr0/rb2
         call hand_friction(th, wl, wl*rb1/rb2, w, vr, h1, h2)
         worst = max(worst, abs(tl - tl0 - h1), abs(tr - tr0 - h2))
         big = max(big, abs(h1), abs(h2))
      end do
      ! near rest tanh(v_s/v_reg) ~ v_s/v_reg is small: the error against the torque's own size
      if (vr > 0.0_wp .and. wl < 1.0_wp) scale = big
      ! midpoint rule, dz = 6e-6 in: the sign's jump costs at most one cell per line
      ! (rho dz / L_c ~ 1e-5 of the torque; the lines' ends the same), the smooth part O(dz^2)
      call check('max |T_f - quadrature| / (mu W_n T1P, or the largest T_f near rest)', worst/scale, 0.0_wp, &
                 abs_tol=3.0e-5_wp)
      call check('the friction torque is not negligible (largest / scale > 1e-3)', big/scale > 1.0e-3_wp)
   end subroutine friction_against_quadrature

   subroutine friction_reverses_at_the_pitch_point()
      type(model_t) :: mf_, m0
      real(wp) :: th, thr, tl, tr, tl0, tr0, prev, th_flip, narrow, th_p
      integer :: i, flips
      call test_begin('narrow face: the friction torque reverses as the line passes the pitch point')
      narrow = 0.02_wp*pb/tan(zeta)                        ! m_F = 0.02
      call load_model_text(head//mesh//", face_width = "//real_text(narrow)//", tooth_friction = 0.08 /", mf_)
      call load_model_text(head//mesh//", face_width = "//real_text(narrow)//" /", m0)
      prev = 0.0_wp; flips = 0; th_flip = 0.0_wp
      ! the single-line zone around the pitch point (theta = 0, x = AP/p_b = m_p/2 = 0.775)
      do i = -400, 400
         th = i*(0.2_wp*two_pi/n1)/400.0_wp
         thr = driven_angle(th)
         call mf_%elements(1)%e%init_mode(th, w1, thr, w1*rb1/rb2)
         call m0%elements(1)%e%init_mode(th, w1, thr, w1*rb1/rb2)
         call mf_%elements(1)%e%torques(th, w1, thr, w1*rb1/rb2, tl, tr)
         call m0%elements(1)%e%torques(th, w1, thr, w1*rb1/rb2, tl0, tr0)
         if (prev /= 0.0_wp .and. sign(1.0_wp, tl - tl0) /= sign(1.0_wp, prev)) then
            flips = flips + 1; th_flip = th
         end if
         prev = tl - tl0
      end do
      call check('one reversal in +-0.2 tooth of the pitch point', flips == 1)
      ! the line spans x in [c - m_F, c]: it straddles the pitch point for theta in [0, m_F p_b / r_b1]
      th_p = 0.0_wp
      call check('reversal inside the line''s passage of the pitch point (rad)', &
                 th_flip >= th_p - (0.2_wp*two_pi/n1)/400.0_wp .and. th_flip <= 0.02_wp*pb/rb1 + (0.2_wp*two_pi/n1)/400.0_wp)
      call check('recess: friction opposes the driver (T_f < 0 after the reversal)', prev < 0.0_wp)
   end subroutine friction_reverses_at_the_pitch_point

   subroutine jacobian_with_friction(model, th, wl)
      character(len=*), intent(in) :: model
      real(wp), intent(in) :: th, wl
      type(model_t) :: m
      real(wp) :: worst, scale
      call test_begin('friction '//trim(model)//' at theta = '//real_text(th)//', '//real_text(wl)// &
                      ' rad/s: analytic Jacobian = central differences')
      call load_model_text(head//mesh//", face_width = 1.2, tooth_friction = 0.08, crowning = 2e-4,"// &
                           " initial_contact_velocity = 1.0"//opt(model)//" /"//nl// &
                           "&initial node = 'a', angle = "//real_text(0.01_wp + th)//", speed = "//real_text(wl)// &
                           " /"//nl//"&initial node = 'b', angle = "//real_text(driven_angle(0.01_wp + th))// &
                           ", speed = "//real_text(wl*29.0_wp/60.0_wp)//" /", m)
      call jacobian_fd_error(m, 0.0_wp, worst, scale)
      ! central differences, steps 1e-6 relative: ~1e-8 of the scale; without the friction's
      ! partials the error is ~ mu rho1 / r_b1 ~ 4e-2
      call check('max |J_analytic - J_fd| / max |J|', worst, 0.0_wp, abs_tol=1.0e-6_wp)
   end subroutine jacobian_with_friction

   !> The driver held at 60 rad/s, the driven free under a load W r_b2 from the static
   !> deflection: the ledger closes (with friction, more energy dissipated than without).
   subroutine ledger(extra, more_dissipation)
      character(len=*), intent(in) :: extra
      logical, intent(in) :: more_dissipation
      type(model_t) :: m
      type(run_result_t) :: res, res0
      real(wp) :: load, r1, r0
      call test_begin(extra//' (rk4), driven free under a load: the energy ledger closes')
      load = rb2*(30.0e6_wp/17.6_wp)*mp*face/cos(zeta)*pen
      call load_model_text(loaded(", "//extra, load), m)
      call run_model(m, res)
      r1 = res%energy_residual_max/res%energy_scale
      call load_model_text(loaded("", load), m)
      call run_model(m, res0)
      r0 = res0%energy_residual_max/res0%energy_scale
      ! the kinks of L_c (eq. 6.1) and of the crowning's TE are not events, so the helical
      ! pair's own ledger closes to ~6e-8 at this step (measured; the spur gear's to 1e-10):
      ! friction and crowning must add no more than their own kinks' share
      call check('max |residual| / scale', r1, 0.0_wp, abs_tol=5.0e-7_wp)
      call check('residual < 3 x the plain helical pair''s', r1 < 3.0_wp*r0)
      if (.not. more_dissipation) return
      ! (the plain pair's contact law dissipates little or nothing in held contact: no ratio)
      call check('friction dissipates energy (dissipated with mu > without)', &
                 res%y_final(m%n_states + 1) > res0%y_final(m%n_states + 1))
   end subroutine ledger

   function loaded(extra, load) result(text)
      character(len=*), intent(in) :: extra
      real(wp), intent(in) :: load
      character(len=:), allocatable :: text
      text = "&run t_end = 0.01, dt = 1e-6, integrator = 'rk4', track_energy = .true., output_interval = 1e-4 /"// &
             nl//"&node id = 'a', type = 'inertia', inertia = 0.02 /"//nl// &
             "&node id = 'b', type = 'inertia', inertia = 0.08 /"//nl//mesh//", face_width = 1.2"//extra//" /"//nl// &
             "&load node = 'a', kind = 'constant', quantity = 'speed', value = 60.0 /"//nl// &
             "&load node = 'b', value = -"//real_text(load)//" /"//nl// &
             "&initial node = 'a', angle = 0.0, speed = 60.0 /"//nl// &
             "&initial node = 'b', angle = "//real_text(driven_angle(0.0_wp))//", speed = 30.0 /"
   end function loaded

   !> Crowning C_c (2 z/F - 1)^2 along each line by Simpson's rule (a parabola in z:
   !> exact), the lines' extents in z from the plane of action; mean and least gap.
   subroutine crowning_against_simpson()
      type(model_t) :: m
      real(wp), parameter :: cc = 4.0e-4_wp
      real(wp) :: th, u, e, cj, z0, z1, zm, g, gmin, ltot, gap0, te, worst, worst_u, a, va, tu
      integer :: i, j, pairs
      call test_begin('crowning: loaded TE (mean gap) and unloaded TE (least gap) = Simpson along the lines')
      call load_model_text(head//mesh//", face_width = 1.2, crowning = 4e-4 /", m)
      worst = 0.0_wp; worst_u = 0.0_wp
      do i = 0, 199
         th = (i + 0.5_wp)*(two_pi/n1)/200.0_wp
         u = n1*(th + alpha)/two_pi
         e = u - floor(u)
         g = 0.0_wp; ltot = 0.0_wp; gmin = huge(1.0_wp)
         do j = 0, 5
            cj = e + j
            ! x = c - z tan(beta_b)/p_b in [0, m_p], z in [0, F]
            z0 = max(0.0_wp, (cj - mp)*pb/tan(zeta)); z1 = min(face, cj*pb/tan(zeta))
            if (.not. z1 > z0) cycle
            zm = 0.5_wp*(z0 + z1)
            g = g + (z1 - z0)/6.0_wp*(gap(z0) + 4.0_wp*gap(zm) + gap(z1))
            ltot = ltot + (z1 - z0)
            gmin = min(gmin, gap(z0), gap(z1))
            if (z0 <= 0.5_wp*face .and. z1 >= 0.5_wp*face) gmin = 0.0_wp
         end do
         call m%elements(1)%e%init_mode(th, w1, driven_angle(th), 30.0_wp)
         call shifted(m, th, a, va)
         te = rb1*(th - a)
         worst = max(worst, abs(te - g/ltot)/cc)
         call mesh_row(m, u, gap0, tu, pairs)
         worst_u = max(worst_u, abs(tu - gmin)/cc, abs(gap0 - g/ltot)/cc)
      end do
      ! Simpson is exact for the parabola: rounding (the TE through the driver angle, 1e-16 rad x r_b1 / C_c)
      call check('loaded TE: max |e - mean gap| / C_c', worst, 0.0_wp, abs_tol=1.0e-10_wp)
      call check('trainsim gear rows: max |TE - hand| / C_c (loaded, unloaded)', worst_u, 0.0_wp, abs_tol=1.0e-12_wp)
   end subroutine crowning_against_simpson

   !> The crowning's gap C_c (2 z/F - 1)^2 at z across the face (C_c = 4e-4).
   pure real(wp) function gap(z)
      real(wp), intent(in) :: z
      gap = 4.0e-4_wp*(2.0_wp*z/face - 1.0_wp)**2
   end function gap

   subroutine shifted(m, th, a, va)
      use trainsim_excited_mesh, only: excited_mesh_t
      type(model_t), intent(in) :: m
      real(wp), intent(in) :: th
      real(wp), intent(out) :: a, va
      select type (el => m%elements(1)%e)
      class is (excited_mesh_t)
         call el%shift(th, w1, a, va)
      class default
         a = 0.0_wp; va = 0.0_wp
      end select
   end subroutine shifted

   subroutine mesh_row(m, u, te, tu, pairs)
      use trainsim_excited_mesh, only: excited_mesh_t
      type(model_t), intent(in) :: m
      real(wp), intent(in) :: u
      real(wp), intent(out) :: te, tu
      integer, intent(out) :: pairs
      real(wp) :: c
      select type (el => m%elements(1)%e)
      class is (excited_mesh_t)
         call el%mesh_at_roll(u, c, te, tu, pairs)
      class default
         te = 0.0_wp; tu = 0.0_wp; pairs = 0
      end select
   end subroutine mesh_row

   !> ISO 6336-1 (2006) method B, eqs. (69)-(73) for x = 0 on the standard basic rack:
   !> q' = 0.04723 + 0.15551/z_n1 + 0.25791/z_n2, c' = 0.8 C_B cos(beta)/q', C_B = 0.975 at 20 deg,
   !> c_gamma_alpha = c' (0.75 eps_alpha + 0.25); in psi: x 1e9/6894.757.
   subroutine iso_stiffness_by_hand()
      type(model_t) :: m
      type(param_list_t) :: p
      real(wp) :: zn1, zn2, cp, cg, kmean, k, s, th, tl, tr
      integer :: i
      call test_begin("stiffness_model = 'iso6336': c', c_gamma_alpha by hand; mean k L_c = c_gamma_alpha b")
      call load_model_text(head//mesh//", face_width = 1.2, stiffness_model = 'iso6336' /", m)
      zn1 = n1/(cos(zeta)**2*cos(beta)); zn2 = 48.0_wp/(cos(zeta)**2*cos(beta))
      cp = 0.8_wp*0.975_wp*cos(beta)/(0.04723_wp + 0.15551_wp/zn1 + 0.25791_wp/zn2)
      cg = cp*(0.75_wp*mp + 0.25_wp)
      p = m%elements(1)%e%params()
      call check("c' (N/(mm um)) against the hand value", value_of(p, 'iso_cprime'), cp, rel_tol=1.0e-14_wp)
      call check('c_gamma_alpha (N/(mm um))', value_of(p, 'iso_cgamma_alpha'), cg, rel_tol=1.0e-14_wp)
      call check('mean_mesh_stiffness = c_gamma_alpha b (lbf/in)', value_of(p, 'mean_mesh_stiffness'), &
                 cg*1.0e9_wp/6894.757293168_wp*face, rel_tol=1.0e-13_wp)
      ! the mean over a mesh cycle of the force per unit deflection, sampled (L_c piecewise linear)
      k = 0.0_wp
      do i = 0, 9999
         th = (i + 0.5_wp)*(two_pi/n1)/10000.0_wp
         call m%elements(1)%e%init_mode(th, w1, driven_angle(th), 30.0_wp)
         call m%elements(1)%e%torques(th, 0.0_wp, driven_angle(th), 0.0_wp, tl, tr)
         k = k + tr/rb2/pen
      end do
      kmean = k/10000.0_wp
      s = cg*1.0e9_wp/6894.757293168_wp*face
      ! midpoint sampling of a piecewise linear L_c: exact between kinks, O(h^2) at the 4 kinks
      call check('mean k L_c over a mesh cycle / c_gamma_alpha b - 1', kmean/s - 1.0_wp, 0.0_wp, abs_tol=1.0e-7_wp)
   end subroutine iso_stiffness_by_hand

   real(wp) function value_of(p, name) result(v)
      type(param_list_t), intent(in) :: p
      character(len=*), intent(in) :: name
      integer :: k
      v = -huge(1.0_wp)
      do k = 1, size(p%names)
         if (p%names(k)%s == name) v = p%values(k)
      end do
   end function value_of

   subroutine modes_ignore_friction()
      type(model_t) :: m0, mf_
      type(modes_t) :: d0, df
      type(error_t), allocatable :: err
      character(len=*), parameter :: spur = "&element id = 'mesh', type = 'spur_gear', diametral_pitch = 10.0,"// &
                                            " teeth_driver = 20, teeth_driven = 40, face_width = 1.0, backlash = 0.004"
      call test_begin('modes ignore tooth friction: frequencies with mu = 0.08 = with mu = 0 (spur, helical)')
      call load_model_text(head//mesh//", face_width = 1.2 /"//nl//"&initial node = 'b', angle = -1e-3 /", m0)
      call load_model_text(head//mesh//", face_width = 1.2, tooth_friction = 0.08 /"//nl// &
                           "&initial node = 'b', angle = -1e-3 /", mf_)
      call compute_modes(m0, d0, err, closed=.true.); call compute_modes(mf_, df, err, closed=.true.)
      call check('helical: frequencies equal to the bit', maxval(abs(d0%freq_hz - df%freq_hz)), 0.0_wp, abs_tol=0.0_wp)
      call load_model_text(head//spur//" /"//nl//"&initial node = 'b', angle = -1e-3 /", m0)
      call load_model_text(head//spur//", tooth_friction = 0.08 /"//nl//"&initial node = 'b', angle = -1e-3 /", mf_)
      call compute_modes(m0, d0, err, closed=.true.); call compute_modes(mf_, df, err, closed=.true.)
      call check('spur: frequencies equal to the bit', maxval(abs(d0%freq_hz - df%freq_hz)), 0.0_wp, abs_tol=0.0_wp)
      call check('a mesh mode found (> 0 Hz)', maxval(df%freq_hz) > 0.0_wp)
   end subroutine modes_ignore_friction

   !> ", key = value" for a non-empty model text.
   function opt(model) result(s)
      character(len=*), intent(in) :: model
      character(len=:), allocatable :: s
      s = ''
      if (len_trim(model) > 0) s = ', '//trim(model)
   end function opt
end program test_helical_mesh
