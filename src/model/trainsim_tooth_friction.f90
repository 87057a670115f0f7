!> Sliding friction between meshing spur-gear teeth (thesis §3.1.4, eqs. 3.13,
!> 3.14, Figs. 3.5-3.7; TRAIN did not simulate it; issue 26 item 3, D-98).
!>
!> The contact point of a tooth pair lies on the line of action at s from the
!> start of contact A (s = r_b1 times the driver's roll since the pair entered,
!> 0 <= s <= m_p p_b). Its distances from the base-circle tangent points T1, T2
!> (the involutes' radii of curvature, the moment arms of a force across the line
!> of action) are rho1 = T1P + (s - AP), rho2 = T2P -/+ (s - AP) (external /
!> internal mesh; T_iP = r_bi tan(phi), AP = alpha r_b1 with the approach angle
!> alpha). The teeth slide across the line of action at v_s = w1 rho1 - w2 rho2
!> (each gear's speed in its own sense), zero at the pitch point when
!> w1 r_b1 = w2 r_b2. A pair carrying W_k gets the friction mu W_k against the
!> sliding: torques -e W_k rho1 on the driver and +e W_k rho2 on the driven with
!> e = mu sign(v_s) ('constant') or mu tanh(v_s / v_reg) ('speed'); their power,
!> e W_k v_s >= 0, is dissipated. One pair carries the mesh force W; two pairs
!> share it equally (W/2 each, TRAIN's two-level zones have no stiffness per
!> pair). With equal shares, contacts one base pitch apart and the slides opposed
!> (one pair on each side of the pitch point) the net driver torque is
!> -mu W p_b / 2: eq. (3.14). Rear-face contact takes the same roll map mirrored
!> about the pitch point (TRAIN's zones do not distinguish the faces either).
!>
!> A helical pair (tf_add_lines, D-116): the load spreads uniformly over the
!> lines of contact, which cross the path of contact obliquely, so every point
!> of a line has its own roll s and slide v_s(s), linear in s. The friction is
!> mu W_n per unit normal load with W_n = W / cos(zeta_b) (the normal force on
!> the helicoid; W, the transverse force, gives the torques W r_b), against the
!> slide, in the transverse plane, arm rho1(s):
!>   T_1 = -mu (W / cos zeta_b) sum_j int_{lo_j}^{hi_j} sign(v_s) rho1 ds / S,
!>   S = sum_j (hi_j - lo_j) = L_c sin(zeta_b),
!> [lo_j, hi_j] the roll extent of line j. sign(v_s) changes once along the
!> path, at s* where v_s = 0 (the pitch point at matched speeds), so the
!> integrals are closed-form and continuous in the state: no events. 'speed'
!> takes tanh(v_s / v_reg) for sign(v_s) along the lines, integrated in closed
!> form as well (trainsim_slide_integrals, D-129).
!>
!> 'constant' switches sign(v_s) by events: per pair a guard sigma_k v_s,k with
!> the sign sigma_k held between events (RK4-events and CVODE locate it). Pure
!> functions of the geometry, the roll and the speeds: no allocation, no I/O.
module trainsim_tooth_friction
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, to_lower
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_event, only: event_t, ev_slip_forward, ev_slip_backward
   use trainsim_slide_integrals, only: tanh_integral, signed_integral
   implicit none
   private

   public :: tooth_friction_t, friction_arms, pressure_angle_of

   !> Default regularisation speed of 'speed': 1 mm/s (in the deck's length units per s).
   real(wp), parameter :: v_reg_default_m = 1.0e-3_wp

   type :: tooth_friction_t
      real(wp) :: mu = 0.0_wp            !< tooth_friction (0: off)
      logical :: speed = .false.         !< tooth_friction_model = 'speed': mu tanh(v_s / v_reg)
      real(wp) :: v_reg = 0.0_wp         !< tooth_friction_velocity (length/s)
      real(wp) :: t1p = 0.0_wp, t2p = 0.0_wp   !< T1P = r_b1 tan(phi), T2P = r_b2 tan(phi)
      real(wp) :: ap = 0.0_wp            !< AP = alpha r_b1: from the start of contact to the pitch point
      real(wp) :: pb = 0.0_wp            !< base pitch 2 pi r_b1 / N
      real(wp) :: s2 = -1.0_wp           !< d rho2 / d rho1: -1 external, +1 internal
      real(wp) :: sig(2) = 1.0_wp        !< 'constant': sign of the slide of the trailing and leading pair
   contains
      procedure :: configure => tf_configure
      procedure :: on => tf_on
      procedure :: n_guards => tf_n_guards
      procedure :: add => tf_add
      procedure :: add_jacobian => tf_add_jacobian
      procedure :: guards => tf_guards
      procedure :: set_signs => tf_set_signs
      procedure :: flip => tf_flip
      procedure :: add_lines => tf_add_lines
      procedure :: add_lines_jacobian => tf_add_lines_jacobian
   end type tooth_friction_t

contains

   !> Read tooth_friction, tooth_friction_model, tooth_friction_velocity (and, when
   !> phi = 0, TRAIN's constants form, pressure_angle [deg], default 20) and set the
   !> geometry: base radii rb1, rb2, driver teeth n, contact ratio mp, approach
   !> angle alpha [rad], pressure angle phi [rad].
   subroutine tf_configure(self, grp, units, rb1, rb2, n, mp, alpha, phi, internal, err)
      class(tooth_friction_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      real(wp), intent(in) :: rb1, rb2, n, mp, alpha, phi
      logical, intent(in) :: internal
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: model
      real(wp) :: ph, r1a, r1, r2
      integer :: k
      call grp%get_real('tooth_friction', self%mu, err, default=0.0_wp); if (allocated(err)) return
      call grp%require_nonnegative('tooth_friction', self%mu, err); if (allocated(err)) return
      call grp%get_string('tooth_friction_model', model, err, default='constant'); if (allocated(err)) return
      select case (to_lower(model))
      case ('constant'); self%speed = .false.
      case ('speed'); self%speed = .true.
      case default
         call fatal_error(err, grp%where('tooth_friction_model')//": error: unknown tooth_friction_model '"//model// &
                          "'; valid: constant, speed", err_input)
         return
      end select
      call grp%get_real('tooth_friction_velocity', self%v_reg, err, default=v_reg_default_m/0.0254_wp/units%to_inch)
      if (allocated(err)) return
      call grp%require_positive('tooth_friction_velocity', self%v_reg, err); if (allocated(err)) return
      if (.not. self%on()) return
      call pressure_angle_of(grp, phi, ph, err); if (allocated(err)) return   ! (asked only with friction)
      self%t1p = rb1*tan(ph)
      self%t2p = rb2*tan(ph)
      self%ap = alpha*rb1
      self%pb = two_pi*rb1/n
      self%s2 = merge(1.0_wp, -1.0_wp, internal)
      ! the arms over the path of contact [0, m_p p_b] on either flank: a contact beyond a
      ! tangent point is interference
      r1a = huge(1.0_wp)
      do k = 0, 3
         call friction_arms(self, merge(mp*self%pb, 0.0_wp, mod(k, 2) == 1), merge(1, -1, k < 2), r1, r2)
         r1a = min(r1a, r1, r2)
      end do
      if (.not. r1a >= 0.0_wp) then
         call fatal_error(err, grp%where('tooth_friction')//': error: tooth friction needs the path of contact between '// &
                          'the base-circle tangent points; here a radius of curvature at an end of contact is '// &
                          str(r1a)//' '//units%length//' (interference: check pressure_angle, approach_angle, '// &
                          'contact_ratio)', err_input)
         return
      end if
   end subroutine tf_configure

   !> The pressure angle ph (rad): phi if > 0 (a geometry form's), else the group's
   !> `pressure_angle` in degrees, default 20, in (0, 45) (TRAIN's constants form has none).
   subroutine pressure_angle_of(grp, phi, ph, err)
      type(deck_group_t), intent(inout) :: grp
      real(wp), intent(in) :: phi
      real(wp), intent(out) :: ph
      type(error_t), allocatable, intent(inout) :: err
      ph = phi
      if (ph > 0.0_wp) return
      call grp%get_real('pressure_angle', ph, err, default=20.0_wp); if (allocated(err)) return
      if (.not. (ph > 0.0_wp .and. ph < 45.0_wp)) then
         call fatal_error(err, grp%where('pressure_angle')//': error: pressure_angle must be in (0, 45) degrees, '// &
                          'got '//str(ph), err_input)
         return
      end if
      ph = ph*pi/180.0_wp
   end subroutine pressure_angle_of

   pure logical function tf_on(self) result(on)
      class(tooth_friction_t), intent(in) :: self
      on = self%mu > 0.0_wp
   end function tf_on

   !> Guards the friction adds: one per pair for 'constant' (the slide's sign), none for 'speed'.
   pure integer function tf_n_guards(self) result(ng)
      class(tooth_friction_t), intent(in) :: self
      ng = 0
      if (self%on() .and. .not. self%speed) ng = 2
   end function tf_n_guards

   !> Moment arms rho1, rho2 of the contact at s from A on the front (face >= 0)
   !> or rear (face < 0) flank.
   pure subroutine friction_arms(self, s, face, rho1, rho2)
      type(tooth_friction_t), intent(in) :: self
      real(wp), intent(in) :: s
      integer, intent(in) :: face
      real(wp), intent(out) :: rho1, rho2
      real(wp) :: d
      d = s - self%ap
      if (face < 0) d = -d
      rho1 = self%t1p + d
      rho2 = self%t2p + self%s2*d
   end subroutine friction_arms

   !> Add the friction of `pairs` pairs (the trailing at s, the leading at
   !> s + p_b) under the normal force w >= 0 to the torques tl, tr (own senses)
   !> and its power to p.
   pure subroutine tf_add(self, s, pairs, face, w, wl, wr, tl, tr, p)
      class(tooth_friction_t), intent(in) :: self
      real(wp), intent(in) :: s, w, wl, wr
      integer, intent(in) :: pairs, face
      real(wp), intent(inout) :: tl, tr, p
      real(wp) :: rho1, rho2, v, e, wk
      integer :: k
      wk = w/real(pairs, wp)                          ! equal shares in the two-pair zone
      do k = 1, pairs
         call friction_arms(self, s + (k - 1)*self%pb, face, rho1, rho2)
         v = wl*rho1 - wr*rho2                         ! sliding velocity
         if (self%speed) then
            e = self%mu*tanh(v/self%v_reg)
         else
            e = self%mu*self%sig(k)
         end if
         tl = tl - e*wk*rho1                           ! eq. (3.13) on each pair
         tr = tr + e*wk*rho2
         p = p + e*wk*v
      end do
   end subroutine tf_add

   !> Add the partials of `add`'s torques with respect to (thl, wl, thr, wr) to
   !> jt(2, 4): the normal force w with its partials dw, the roll s (ds/dthl = r_b1).
   pure subroutine tf_add_jacobian(self, s, pairs, face, w, dw, wl, wr, r1, jt)
      class(tooth_friction_t), intent(in) :: self
      real(wp), intent(in) :: s, w, dw(4), wl, wr, r1
      integer, intent(in) :: pairs, face
      real(wp), intent(inout) :: jt(2, 4)
      real(wp) :: rho1, rho2, d1, d2, v, e, de, wk, dv(4)
      integer :: k
      wk = w/real(pairs, wp)
      d1 = merge(-r1, r1, face < 0)                   ! d rho1 / d thl
      d2 = self%s2*d1                                 ! d rho2 / d thl
      do k = 1, pairs
         call friction_arms(self, s + (k - 1)*self%pb, face, rho1, rho2)
         v = wl*rho1 - wr*rho2
         if (self%speed) then
            e = self%mu*tanh(v/self%v_reg)
            de = self%mu*(1.0_wp - tanh(v/self%v_reg)**2)/self%v_reg
         else
            e = self%mu*self%sig(k)
            de = 0.0_wp
         end if
         dv = [wl*d1 - wr*d2, rho1, 0.0_wp, -rho2]
         jt(1, :) = jt(1, :) - (de*dv*wk*rho1 + e*dw/real(pairs, wp)*rho1)
         jt(2, :) = jt(2, :) + (de*dv*wk*rho2 + e*dw/real(pairs, wp)*rho2)
         jt(1, 1) = jt(1, 1) - e*wk*d1
         jt(2, 1) = jt(2, 1) + e*wk*d2
      end do
   end subroutine tf_add_jacobian

   !> 'constant': guards sigma_k v_s,k of the pairs in contact (1: no pair).
   pure subroutine tf_guards(self, s, pairs, face, wl, wr, g)
      class(tooth_friction_t), intent(in) :: self
      real(wp), intent(in) :: s, wl, wr
      integer, intent(in) :: pairs, face
      real(wp), intent(out) :: g(:)
      real(wp) :: rho1, rho2
      integer :: k
      g = 1.0_wp
      do k = 1, min(pairs, size(g))
         call friction_arms(self, s + (k - 1)*self%pb, face, rho1, rho2)
         g(k) = self%sig(k)*(wl*rho1 - wr*rho2)
      end do
   end subroutine tf_guards

   !> The slides' signs from the state (at the start, and when the pairs or the
   !> face change). A pair at rest takes the sign its roll gives past the pitch point.
   pure subroutine tf_set_signs(self, s, pairs, face, wl, wr)
      class(tooth_friction_t), intent(inout) :: self
      real(wp), intent(in) :: s, wl, wr
      integer, intent(in) :: pairs, face
      real(wp) :: rho1, rho2, v
      integer :: k
      self%sig = 1.0_wp
      do k = 1, pairs
         call friction_arms(self, s + (k - 1)*self%pb, face, rho1, rho2)
         v = wl*rho1 - wr*rho2
         if (v == 0.0_wp) v = (rho1 - self%t1p)*(wl + wr)
         if (v < 0.0_wp) self%sig(k) = -1.0_wp
      end do
   end subroutine tf_set_signs

   !> sign(v_s) at roll s (0 at rest).
   pure real(wp) function slide_sign(av, bv, s) result(sg)
      real(wp), intent(in) :: av, bv, s
      sg = 0.0_wp
      if (av + bv*s /= 0.0_wp) sg = sign(1.0_wp, av + bv*s)
   end function slide_sign

   !> Linear coefficients in the roll s of rho1 = a1 + b1 s and rho2 = a2 + b2 s on the face.
   pure subroutine arm_lines(self, face, a1, b1, a2, b2)
      class(tooth_friction_t), intent(in) :: self
      integer, intent(in) :: face
      real(wp), intent(out) :: a1, b1, a2, b2
      b1 = merge(-1.0_wp, 1.0_wp, face < 0)
      b2 = self%s2*b1
      a1 = self%t1p - b1*self%ap
      a2 = self%t2p - b2*self%ap
   end subroutine arm_lines

   !> Add the friction spread over the lines of contact [lo(j), hi(j)] (roll
   !> from A, length) of a helical pair under the transverse mesh force w >= 0,
   !> base helix angle zeta (module note), to tl, tr and its power to p.
   pure subroutine tf_add_lines(self, lo, hi, zeta, face, w, wl, wr, tl, tr, p)
      class(tooth_friction_t), intent(in) :: self
      real(wp), intent(in) :: lo(:), hi(:), zeta, w, wl, wr
      integer, intent(in) :: face
      real(wp), intent(inout) :: tl, tr, p
      real(wp) :: a1, b1, a2, b2, av, bv, g1, g2, gv, x, d, d2, sl
      integer :: j
      call arm_lines(self, face, a1, b1, a2, b2)
      av = wl*a1 - wr*a2; bv = wl*b1 - wr*b2            ! v_s = av + bv s
      g1 = 0.0_wp; g2 = 0.0_wp; gv = 0.0_wp; sl = 0.0_wp
      do j = 1, size(lo)
         if (self%speed) then   ! int tanh(v_s/v_reg) (.) ds
            call tanh_integral(a1, b1, av, bv, self%v_reg, lo(j), hi(j), x, d, d2); g1 = g1 + x
            call tanh_integral(a2, b2, av, bv, self%v_reg, lo(j), hi(j), x, d, d2); g2 = g2 + x
            call tanh_integral(av, bv, av, bv, self%v_reg, lo(j), hi(j), x, d, d2); gv = gv + x
         else
            call signed_integral(a1, b1, av, bv, lo(j), hi(j), x, d); g1 = g1 + x
            call signed_integral(a2, b2, av, bv, lo(j), hi(j), x, d); g2 = g2 + x
            call signed_integral(av, bv, av, bv, lo(j), hi(j), x, d); gv = gv + x   ! int |v_s|
         end if
         sl = sl + (hi(j) - lo(j))
      end do
      if (.not. sl > 0.0_wp) return
      x = self%mu*w/(cos(zeta)*sl)
      tl = tl - x*g1
      tr = tr + x*g2
      p = p + x*gv
   end subroutine tf_add_lines

   !> Partials of `add_lines`'s torques in (thl, wl, thr, wr) added to jt: the
   !> normal force's partials dw, the lines' ends' rates dlo, dhi (d/d thl).
   pure subroutine tf_add_lines_jacobian(self, lo, hi, dlo, dhi, zeta, face, w, dw, wl, wr, jt)
      class(tooth_friction_t), intent(in) :: self
      real(wp), intent(in) :: lo(:), hi(:), dlo(:), dhi(:), zeta, w, dw(4), wl, wr
      integer, intent(in) :: face
      real(wp), intent(inout) :: jt(2, 4)
      real(wp) :: a1, b1, a2, b2, av, bv, g(2), dg(2, 4), x, d(2), e(2), sl, dsl, ds(2), q
      integer :: j
      call arm_lines(self, face, a1, b1, a2, b2)
      av = wl*a1 - wr*a2; bv = wl*b1 - wr*b2
      ds = 0.0_wp                                          ! ds*/dwl, ds*/dwr
      if (bv /= 0.0_wp) ds = [-(a1*bv - av*b1), (a2*bv - av*b2)]/bv**2
      g = 0.0_wp; dg = 0.0_wp; sl = 0.0_wp; dsl = 0.0_wp
      do j = 1, size(lo)
         if (self%speed) then   ! partials in a_v, b_v, then in the speeds (a_v = wl a1 - wr a2, b_v likewise)
            call tanh_integral(a1, b1, av, bv, self%v_reg, lo(j), hi(j), x, d(1), e(1)); g(1) = g(1) + x
            call tanh_integral(a2, b2, av, bv, self%v_reg, lo(j), hi(j), x, d(2), e(2)); g(2) = g(2) + x
            dg(:, 1) = dg(:, 1) + tanh((av + bv*hi(j))/self%v_reg)*[a1 + b1*hi(j), a2 + b2*hi(j)]*dhi(j) &
                       - tanh((av + bv*lo(j))/self%v_reg)*[a1 + b1*lo(j), a2 + b2*lo(j)]*dlo(j)
            dg(:, 2) = dg(:, 2) + a1*d + b1*e
            dg(:, 4) = dg(:, 4) - a2*d - b2*e
         else
            call signed_integral(a1, b1, av, bv, lo(j), hi(j), x, d(1)); g(1) = g(1) + x
            call signed_integral(a2, b2, av, bv, lo(j), hi(j), x, d(2)); g(2) = g(2) + x
            dg(:, 1) = dg(:, 1) + slide_sign(av, bv, hi(j))*[a1 + b1*hi(j), a2 + b2*hi(j)]*dhi(j) &
                       - slide_sign(av, bv, lo(j))*[a1 + b1*lo(j), a2 + b2*lo(j)]*dlo(j)
            dg(:, 2) = dg(:, 2) + d*ds(1)
            dg(:, 4) = dg(:, 4) + d*ds(2)
         end if
         sl = sl + (hi(j) - lo(j)); dsl = dsl + (dhi(j) - dlo(j))
      end do
      if (.not. sl > 0.0_wp) return
      q = self%mu/(cos(zeta)*sl)
      jt(1, :) = jt(1, :) - q*(dw*g(1) + w*dg(1, :))
      jt(2, :) = jt(2, :) + q*(dw*g(2) + w*dg(2, :))
      jt(1, 1) = jt(1, 1) + q*w*g(1)*dsl/sl
      jt(2, 1) = jt(2, 1) - q*w*g(2)*dsl/sl
   end subroutine tf_add_lines_jacobian

   !> A slide's guard fired: reverse its sign and report slip_forward (now
   !> v_s > 0) or slip_backward.
   subroutine tf_flip(self, fired, ev, nev)
      class(tooth_friction_t), intent(inout) :: self
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(inout) :: nev
      integer :: k
      do k = 1, size(fired)
         if (.not. fired(k)) cycle
         self%sig(k) = -self%sig(k)
         nev = nev + 1
         ev(nev) = event_t(kind=merge(ev_slip_forward, ev_slip_backward, self%sig(k) > 0.0_wp))
      end do
   end subroutine tf_flip
end module trainsim_tooth_friction
