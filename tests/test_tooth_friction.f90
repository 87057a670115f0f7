!> Tooth friction in the spur gear mesh (thesis §3.1.4, eqs. 3.13-3.14; issue 26
!> item 3, D-98) against the closed forms, by hand from the geometry:
!> a 20/40-tooth pair, diametral pitch 10, 20 deg, full depth, so r_b1 = cos 20,
!> r_b2 = 2 cos 20 and the contact ratio from the addendum circles.
!> 1. Over one mesh cycle, the driver at a constant speed and the driven at the
!>    matching speed with a steady deflection (steady load W = c k (delta - b)):
!>    the friction torque (torques with mu minus torques without) on the driver
!>    is -+mu W rho1 in single-pair contact, reversing at the pitch point
!>    (eq. 3.13, r = rho1 = r_b1 tan 20 + r_b1 (theta - theta_P)), and
!>    -mu W p_b / 2 in two-pair contact (eq. 3.14); on the driven +-mu W rho2
!>    and -mu W p_b / 2.
!> 2. The same motion run (both nodes at prescribed speeds): the slides'
!>    reversals are events at the pitch points theta_P = 2 pi m / N, located to
!>    the event tolerance (rk4) and CVODE's root finding; the power taken by the
!>    drives equals the friction loss, the ledger closes.
!> 3. A loaded run with a free driven gear ('constant' and 'speed'): the ledger
!>    closes; friction takes energy (more dissipated than with mu = 0).
!> 4. tooth_friction = 0 is the element without friction: same torques, the hot form kept.
program test_tooth_friction
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_event, only: ev_slip_forward, ev_slip_backward
   use trainsim_element, only: hot_form_t, hf_none
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, run_model, nl, jacobian_fd_error, real_text
   implicit none

   real(wp), parameter :: mu = 0.06_wp, k = 1.0e7_wp, c2 = 1.8_wp, b = 0.002_wp, pen = 5.0e-4_wp
   real(wp), parameter :: n1 = 20.0_wp, w1 = 100.0_wp
   real(wp) :: phi, rb1, rb2, pb, mp, alpha, ap, t1p, t2p

   character(len=*), parameter :: mesh = "&element id = 'mesh', type = 'spur_gear', diametral_pitch = 10.0,"// &
      " teeth_driver = 20, teeth_driven = 40, face_width = 1.0, backlash = 0.004, stiffness = 1.0e7"

   call suite_begin('tooth friction in the spur gear mesh (issue 26 item 3, eqs. 3.13-3.14, D-98)')
   call hand_geometry()
   call cycle_against_closed_form()
   call located_reversals('rk4', 2.0e-15_wp)
   call located_reversals('cvode-bdf', 1.0e-9_wp)
   call loaded_ledger("tooth_friction_model = 'constant'", 'rk4')
   call loaded_ledger("tooth_friction_model = 'constant'", 'cvode-bdf')
   call loaded_ledger("tooth_friction_model = 'speed', tooth_friction_velocity = 0.5", 'rk4')
   call zero_friction_is_the_plain_element()
   call jacobian_with_friction("tooth_friction_model = 'constant'", 0.0_wp)
   call jacobian_with_friction("tooth_friction_model = 'speed', tooth_friction_velocity = 20.0", 0.0_wp)
   call jacobian_with_friction("tooth_friction_model = 'speed', tooth_friction_velocity = 20.0", 0.16_wp)
   call suite_end()

contains

   !> The pair's geometry by hand (App. F `Contratio`: length of action over the base pitch).
   subroutine hand_geometry()
      real(wp) :: r1, r2, a, lab
      phi = 20.0_wp*pi/180.0_wp
      r1 = 1.0_wp; r2 = 2.0_wp; a = 0.1_wp                     ! N/(2P), addendum 1/P
      rb1 = r1*cos(phi); rb2 = r2*cos(phi)
      lab = sqrt((r1 + a)**2 - rb1**2) + sqrt((r2 + a)**2 - rb2**2) - (r1 + r2)*sin(phi)
      pb = two_pi*rb1/n1
      mp = lab/pb
      alpha = pi*mp/n1                                         ! App. E: the pitch point mid-path
      ap = alpha*rb1
      t1p = rb1*tan(phi); t2p = rb2*tan(phi)
   end subroutine hand_geometry

   !> Driver angle, driven angle at the steady deflection b + pen.
   pure real(wp) function driven_angle(th) result(thr)
      real(wp), intent(in) :: th
      thr = (rb1*th - (b + pen))/rb2
   end function driven_angle

   subroutine cycle_against_closed_form()
      type(model_t) :: mf, m0
      real(wp) :: th, thr, tl, tr, tl0, tr0, w, rho1, rho2, th_p, e1, e2, h1, h2, sgn, scale, u, f
      real(wp) :: worst1, worst2
      integer :: i, n_single, n_two, n_rev
      logical :: single
      call test_begin('one mesh cycle at a steady load: friction torques = eqs. (3.13), (3.14)')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl//"&node id = 'a', type = 'inertia', inertia = 0.01 /"// &
                           nl//"&node id = 'b', type = 'inertia', inertia = 0.04 /"//nl//mesh// &
                           ", tooth_friction = 0.06 /", mf)
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl//"&node id = 'a', type = 'inertia', inertia = 0.01 /"// &
                           nl//"&node id = 'b', type = 'inertia', inertia = 0.04 /"//nl//mesh//" /", m0)
      worst1 = 0.0_wp; worst2 = 0.0_wp
      n_single = 0; n_two = 0; n_rev = 0
      sgn = 0.0_wp
      scale = mu*c2*k*pen*pb/2.0_wp                            ! the two-pair torque
      do i = 0, 1999
         th = -pi/n1 + (i + 0.5_wp)*(two_pi/n1)/2000.0_wp     ! one tooth, centred on the pitch point theta = 0
         thr = driven_angle(th)
         u = n1*(th + alpha)/two_pi
         f = u - floor(u)
         single = f > mp - 1.0_wp
         call mf%elements(1)%e%init_mode(th, w1, thr, w1*rb1/rb2)
         call m0%elements(1)%e%init_mode(th, w1, thr, w1*rb1/rb2)
         call mf%elements(1)%e%torques(th, w1, thr, w1*rb1/rb2, tl, tr)
         call m0%elements(1)%e%torques(th, w1, thr, w1*rb1/rb2, tl0, tr0)
         e1 = tl - tl0; e2 = tr - tr0
         if (single) then
            n_single = n_single + 1
            w = k*pen
            th_p = nint(th*n1/two_pi)*two_pi/n1
            rho1 = t1p + rb1*(th - th_p)                     ! radius of curvature of the driver's involute
            rho2 = t2p - rb1*(th - th_p)
            h1 = -mu*w*rho1*sign(1.0_wp, th - th_p)           ! eq. (3.13): opposes the driver in recess
            h2 = mu*w*rho2*sign(1.0_wp, th - th_p)
            if (sgn /= 0.0_wp .and. sign(1.0_wp, e1) /= sgn) n_rev = n_rev + 1
            sgn = sign(1.0_wp, e1)
         else
            n_two = n_two + 1
            w = c2*k*pen
            h1 = -mu*w*pb/2.0_wp                               ! eq. (3.14)
            h2 = -mu*w*pb/2.0_wp
            sgn = 0.0_wp
         end if
         worst1 = max(worst1, abs(e1 - h1)/scale)
         worst2 = max(worst2, abs(e2 - h2)/scale)
      end do
      call check('samples in single-pair contact', n_single > 500)
      call check('samples in two-pair contact', n_two > 500)
      call check('one reversal inside the single-pair zone', n_rev == 1)
      ! the friction torque is the difference of two torques ~ W r_b1, about 1/(mu p_b/(2 r_b1)) ~ 110
      ! times larger: rounding ~1e-14 of the scale; 1e-10 leaves room for trig in another order
      call check('driver: max |T_f - closed form| / (mu c2 W p_b/2)', worst1, 0.0_wp, abs_tol=1.0e-10_wp)
      call check('driven: max |T_f - closed form| / (mu c2 W p_b/2)', worst2, 0.0_wp, abs_tol=1.0e-10_wp)
   end subroutine cycle_against_closed_form

   !> Both gears at prescribed speeds 100 and 50 rad/s from theta = -0.2 at the steady
   !> deflection: the slide reverses at theta_P = 2 pi m/N, m = 0..3 (t = (theta_P + 0.2)/100).
   subroutine located_reversals(integ, tol)
      character(len=*), intent(in) :: integ
      real(wp), intent(in) :: tol
      type(model_t) :: m
      type(run_result_t) :: res
      real(wp) :: worst, t_p, wrong_kind, d_hand
      integer :: j, n, mm
      call test_begin('both speeds held ('//integ//'): slide reversals at the pitch points')
      call load_model_text("&run t_end = 0.012, dt = 1e-6, integrator = '"//integ//"', track_energy"// &
                           " = .true., output_interval = 1e-4 /"//nl// &
                           "&node id = 'a', type = 'inertia', inertia = 0.01 /"//nl// &
                           "&node id = 'b', type = 'inertia', inertia = 0.04 /"//nl//mesh//", tooth_friction = 0.06 /"//nl// &
                           "&load node = 'a', kind = 'constant', quantity = 'speed', value = 100.0 /"//nl// &
                           "&load node = 'b', kind = 'constant', quantity = 'speed', value = 50.0 /"//nl// &
                           "&initial node = 'a', angle = -0.2, speed = 100.0 /"//nl// &
                           "&initial node = 'b', angle = "//real_text(driven_angle(-0.2_wp))//", speed = 50.0 /", m)
      m%run%keep_events = .true.
      call run_model(m, res)
      n = 0; worst = 0.0_wp; wrong_kind = 0.0_wp
      do j = 1, size(res%events)
         if (res%events(j)%kind /= ev_slip_forward .and. res%events(j)%kind /= ev_slip_backward) cycle
         n = n + 1
         mm = nint((res%events(j)%t*w1 - 0.2_wp)*n1/two_pi)
         t_p = (mm*two_pi/n1 + 0.2_wp)/w1
         worst = max(worst, abs(res%events(j)%t - t_p))
         if (res%events(j)%kind /= ev_slip_forward) wrong_kind = wrong_kind + 1.0_wp   ! approach -> recess
      end do
      call check('four reversals (pitch points at 0, 0.314, 0.628, 0.942 rad)', n == 4)
      call check('every reversal from approach to recess (slip_forward)', wrong_kind, 0.0_wp, abs_tol=0.0_wp)
      ! rk4: the event time tolerance 1e-9 dt = 1e-15 s plus the angle's rounding (~1e-16 rad at 100 rad/s, 1e-18 s);
      ! CVODE: its root finder's tolerance ~ 100 u (|t| + |h|)
      call check('max |t_event - t_pitch| (s)', worst, 0.0_wp, abs_tol=tol)
      ! the energy the friction took: mu (w1 + w2) sum_k W_k |s_k - AP| integrated over the roll,
      ! exact by trapezoids between the kinks (zone bounds, pitch points); CVODE's error control
      ! holds the dissipation state to its tolerances
      d_hand = hand_loss(-0.2_wp, -0.2_wp + w1*0.012_wp)
      call check('dissipated energy / hand integral of mu W |v_s| - 1', res%y_final(m%n_states + 1)/d_hand - 1.0_wp, &
                 0.0_wp, abs_tol=merge(1.0e-12_wp, 1.0e-7_wp, integ == 'rk4'))
      ! held speeds: the drives put in the friction loss; RK4 integrates the piecewise linear loss
      ! exactly between located events (rounding only)
      call check('energy ledger closes: max |residual| / scale', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-9_wp)
   end subroutine located_reversals

   !> The driver held at 300 rad/s, the driven free (J = 0.04) under a brake of W r_b2 (W = 500 lbf),
   !> from the static deflection: the ledger closes, and friction dissipates more than the contact
   !> law alone. (At the pitch point the kinematic sliding acceleration r_b1 w1 (w1 + w2) = 1.3e5
   !> in/s^2 dwarfs the friction's jump 2 mu W rho2^2 / J2 = 690 in/s^2: no sliding mode; at
   !> 100 rad/s and 5000 lbf the jump, 6 900, against 1.4e4 and the mesh vibration, makes the
   !> slide chatter at the pitch point, an event flood: D-98.)
   subroutine loaded_ledger(model, integ)
      character(len=*), intent(in) :: model, integ
      type(model_t) :: m
      type(run_result_t) :: res, res0
      real(wp) :: d_with, d_without
      call test_begin(model//' ('//integ//'), the driven gear free under a load: the ledger closes')
      call load_model_text(loaded_deck(", tooth_friction = 0.06, "//model, integ), m)
      call run_model(m, res)
      d_with = res%y_final(m%n_states + 1)
      call load_model_text(loaded_deck("", integ), m)
      call run_model(m, res0)
      ! dt = 1e-6 against the contact's period 2 pi sqrt(m_eff/k) ~ 2e-4 s: RK4's energy error ~1e-10;
      ! CVODE at its tolerances ~1e-7 of the scale
      call check('energy ledger closes: max |residual| / scale', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=merge(1.0e-8_wp, 1.0e-5_wp, integ == 'rk4'))
      d_without = res0%y_final(m%n_states + 1)                 ! the dissipated energy (a state)
      call check('friction dissipates energy (dissipated with mu / without > 1.01)', d_with/d_without > 1.01_wp)
   end subroutine loaded_ledger

   subroutine zero_friction_is_the_plain_element()
      type(model_t) :: mz, m0
      type(hot_form_t) :: fz, f0, ff
      real(wp) :: tl, tr, tl0, tr0, th, worst
      integer :: i
      call test_begin('tooth_friction = 0: the plain element (torques, hot form); > 0 declines the hot form')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl//"&node type = 'inertia', inertia = 0.01 /"//nl// &
                           "&node type = 'inertia', inertia = 0.04 /"//nl//mesh//", tooth_friction = 0.0 /", mz)
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl//"&node type = 'inertia', inertia = 0.01 /"//nl// &
                           "&node type = 'inertia', inertia = 0.04 /"//nl//mesh//" /", m0)
      worst = 0.0_wp
      do i = 0, 99
         th = -pi/n1 + i*0.0031_wp
         call mz%elements(1)%e%init_mode(th, w1, driven_angle(th), 49.0_wp)
         call m0%elements(1)%e%init_mode(th, w1, driven_angle(th), 49.0_wp)
         call mz%elements(1)%e%torques(th, w1, driven_angle(th), 49.0_wp, tl, tr)
         call m0%elements(1)%e%torques(th, w1, driven_angle(th), 49.0_wp, tl0, tr0)
         worst = max(worst, abs(tl - tl0) + abs(tr - tr0))
      end do
      call check('torques equal to the last bit', worst, 0.0_wp, abs_tol=0.0_wp)
      call mz%elements(1)%e%hot_form(fz)
      call m0%elements(1)%e%hot_form(f0)
      call check('hot form kept', fz%kind == f0%kind .and. fz%kind /= hf_none)
      call check('six guards with constant friction, four without', &
                 mz%elements(1)%e%n_guards() == 4 .and. m0%elements(1)%e%n_guards() == 4)
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl//"&node type = 'inertia', inertia = 0.01 /"//nl// &
                           "&node type = 'inertia', inertia = 0.04 /"//nl//mesh//", tooth_friction = 0.1 /", mz)
      call mz%elements(1)%e%hot_form(ff)
      call check('with friction: the general path (hot form declined)', ff%kind == hf_none)
      call check('with constant friction: six guards', mz%elements(1)%e%n_guards() == 6)
   end subroutine zero_friction_is_the_plain_element

   function loaded_deck(extra, integ) result(text)
      character(len=*), intent(in) :: extra, integ
      character(len=:), allocatable :: text
      text = "&run t_end = 0.01, dt = 1e-6, integrator = '"//integ//"', track_energy = .true.,"// &
             " output_interval = 1e-4 /"//nl//"&node id = 'a', type = 'inertia', inertia = 0.01 /"//nl// &
             "&node id = 'b', type = 'inertia', inertia = 0.04 /"//nl//mesh//extra//" /"//nl// &
             "&load node = 'a', kind = 'constant', quantity = 'speed', value = 300.0 /"//nl// &
             "&load node = 'b', value = -"//real_text(rb2*k*pen/10.0_wp)//" /"//nl// &
             "&initial node = 'a', angle = -0.2, speed = 300.0 /"//nl// &
             "&initial node = 'b', angle = "//real_text((-0.2_wp*rb1 - b - pen/10.0_wp)/rb2)//", speed = 150.0 /"
   end function loaded_deck

   !> The friction loss of the held-speed run from driver angle th0 to th1: per unit driver angle
   !> P/w1 = mu (w1 + w2)/w1 sum_k W_k |s_k - AP| (single pair W = k pen at s; two pairs c2 k pen / 2
   !> each at s and s + p_b), linear between the zone bounds and the pitch points.
   real(wp) function hand_loss(th0, th1) result(e)
      real(wp), intent(in) :: th0, th1
      real(wp) :: knots(64), a, q
      integer :: n, j, i
      n = 0
      do j = -2, 6
         knots(n + 1:n + 3) = [j*two_pi/n1 - alpha, (j + mp - 1.0_wp)*two_pi/n1 - alpha, j*two_pi/n1]
         n = n + 3
      end do
      knots(n + 1:n + 2) = [th0, th1]
      n = n + 2
      knots(1:n) = sorted(knots(1:n))
      e = 0.0_wp
      do i = 1, n - 1
         if (knots(i) < th0 .or. knots(i + 1) > th1) cycle
         a = knots(i); q = knots(i + 1)
         e = e + 0.5_wp*(q - a)*(p_over_w(a + 1.0e-13_wp*(q - a), a) + p_over_w(q - 1.0e-13_wp*(q - a), q))
      end do
   end function hand_loss

   !> Loss per driver angle at th, the zone taken at th_zone's side (th and th_zone within a zone piece)
   real(wp) function p_over_w(th_zone, th) result(p)
      real(wp), intent(in) :: th_zone, th
      real(wp) :: u, f, s
      u = n1*(th_zone + alpha)/two_pi
      f = u - floor(u)
      s = rb1*(th + alpha - floor(u)*two_pi/n1)          ! the trailing pair's roll from A
      if (f > mp - 1.0_wp) then
         p = k*pen*abs(s - ap)
      else
         p = 0.5_wp*c2*k*pen*(abs(s - ap) + abs(s + pb - ap))
      end if
      p = p*mu*(w1 + w1*rb1/rb2)/w1
   end function p_over_w

   pure function sorted(x) result(y)
      real(wp), intent(in) :: x(:)
      real(wp) :: y(size(x)), t
      integer :: i, j
      y = x
      do i = 2, size(y)
         t = y(i); j = i - 1
         do while (j >= 1)
            if (y(j) <= t) exit
            y(j + 1) = y(j); j = j - 1
         end do
         y(j + 1) = t
      end do
   end function sorted

   !> The analytic Jacobian with friction against central differences, in contact and closing
   !> (9.4 in/s), the driver at 0.01 + th: single-pair contact in recess (th = 0) or two-pair (th = 0.16).
   subroutine jacobian_with_friction(model, th)
      character(len=*), intent(in) :: model
      real(wp), intent(in) :: th
      type(model_t) :: m
      real(wp) :: worst, scale
      call test_begin(model//' at theta = '//real_text(th)//': analytic Jacobian = central differences')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl//"&node type = 'inertia', inertia = 0.01 /"//nl// &
                           "&node type = 'inertia', inertia = 0.04 /"//nl//mesh//", tooth_friction = 0.06, "//model// &
                           ", initial_contact_velocity = 1.0 /"//nl// &
                           "&initial node = 'n1', angle = "//real_text(0.01_wp + th)//", speed = 100.0 /"//nl// &
                           "&initial node = 'n2', angle = "//real_text(driven_angle(0.01_wp + th))//", speed = 45.0 /", m)
      call jacobian_fd_error(m, 0.0_wp, worst, scale)
      ! central differences with steps 1e-6 relative: truncation and rounding ~1e-8 of the scale;
      ! without the friction's partials the error is ~mu rho / r_b1 ~ 2e-2
      call check('max |J_analytic - J_fd| / max |J|', worst, 0.0_wp, abs_tol=1.0e-6_wp)
   end subroutine jacobian_with_friction
end program test_tooth_friction
