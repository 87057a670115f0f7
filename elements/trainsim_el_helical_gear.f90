!> Helical gear pair with backlash (Ch. VI): as the spur pair, but the mesh
!> stiffness follows the total length of the lines of contact, eq. (6.1)
!> (Colbourne 1987), times the stiffness per unit length E/17.6 (Quandt 1986):
!>   L_c(e) = p_tb [ (n_c+1)(m_c - e - n_c/2) - (n_F+1)(m_F - e - n_F/2)
!>                   - (n_p+1)(m_p - e - n_p/2) ] / sin(zeta_b),  n_x = floor(m_x - e)
!> with e the mesh position in base pitches (the fractional tooth phase of the
!> driver, u = N (theta + alpha)/(2 pi)), m_c = m_p + m_F. L_c is continuous and
!> periodic in e, so the stiffness changes without events (kinks only).
!> A static transmission error (te_harmonics, te_phases, run-out; issue 26)
!> excites the mesh as the spur gear's does (trainsim_excited_mesh).
!>
!> Issue 26 (D-116): stiffness_model = 'contact_lines' (default, the above) or
!> 'iso6336': the same shape L_c(e) scaled so that the mean mesh stiffness is
!> c_gamma_alpha b of ISO 6336-1 method B for the virtual spur pair (z_n =
!> z / (cos^2 beta_b cos beta)), c' times cos(beta). Crowning (a parabolic lead
!> modification C_c (2 z/b - 1)^2, C_c at either face end) as a static TE: the
!> mean gap over the lines of contact (the loaded TE of lines that all carry
!> load, as the spur gear's stiffness-weighted mean) and, unloaded, the least
!> gap. Tooth friction spread over the lines of contact (trainsim_tooth_friction,
!> add_lines; 'constant' or 'speed' (D-129): continuous in the state, without events).
module trainsim_el_helical_gear
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t, to_lower
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list, guarded_product, guarded_ratio
   use trainsim_element, only: lin_state_t, lin_zone_single, lin_zone_stiffest
   use trainsim_clearance_element, only: clearance_hot_form
   use trainsim_element, only: element_t, accept_carrier, hot_form_t, hf_none, hg_none
   use trainsim_excited_mesh, only: excited_input_power, em_torques_dissipation
   use trainsim_friction_mesh, only: friction_mesh_t
   use trainsim_el_spur_gear, only: tooth_phase, max_teeth
   use trainsim_mesh_excitation, only: iso_single_pair_stiffness
   use trainsim_tooth_friction, only: pressure_angle_of
   use trainsim_param_list, only: append_params, add_choice
   implicit none
   private

   public :: helical_gear_t, new_helical_gear, helical_contact_length, contact_lines, max_lines

   !> Most lines of contact at once (m_p + m_F + 1); crowning and friction need m_p + m_F < max_lines - 1.
   integer, parameter :: max_lines = 64

   !> teeth, alpha and the displacement excitation: excited_mesh_t; the tooth friction
   !> (over the lines of contact, D-116): friction_mesh_t.
   type, extends(friction_mesh_t) :: helical_gear_t
      real(wp) :: mp = 1.0_wp, mf = 0.0_wp, ptb = 0.0_wp, zeta = 0.0_wp, youngs = 0.0_wp, face = 0.0_wp
      real(wp) :: alpha_n = 0.0_wp, beta = 0.0_wp, alpha_t = 0.0_wp   !< normal pressure, reference helix, transverse pressure angles
      real(wp) :: crown = 0.0_wp          !< crowning C_c at either face end (length)
      logical :: iso = .false.            !< stiffness_model = 'iso6336'
      real(wp) :: cprime = 0.0_wp, cgamma = 0.0_wp   !< ISO c', c_gamma_alpha, N/(mm um)
   contains
      procedure :: excitation => hel_excitation
      procedure :: mesh_at_roll => hel_mesh_at_roll
      procedure :: stiffness_name => hel_stiffness_name
      procedure :: torques_dissipation => hel_torques_dissipation
      procedure :: friction_jacobian => hel_friction_jacobian
      procedure :: configure => hel_configure
      procedure :: factor => hel_factor
      procedure :: linear_factor => hel_linear_factor
      procedure :: state_factor => hel_state_factor
      procedure :: input_power => hel_input_power
      procedure :: factor_derivative => hel_factor_derivative
      procedure :: params => hel_params
      procedure :: hot_form => hel_hot_form
   end type helical_gear_t

contains

   !> Registry factory: a new, unconfigured helical gear pair.
   subroutine new_helical_gear(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (helical_gear_t :: el)
   end subroutine new_helical_gear

   !> Total length of the lines of contact at mesh position e (eq. 6.1).
   pure real(wp) function helical_contact_length(e, mp, mf, ptb, zeta) result(lc)
      real(wp), intent(in) :: e, mp, mf, ptb, zeta
      lc = ptb*(term(mp + mf) - term(mf) - term(mp))/sin(zeta)
   contains
      pure real(wp) function term(m)
         real(wp), intent(in) :: m
         real(wp) :: n
         n = real_floor(m - e)
         term = (n + 1.0_wp)*(m - e - 0.5_wp*n)
      end function term
   end function helical_contact_length

   subroutine hel_configure(self, grp, units, err)
      class(helical_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: zeta_deg, e_default
      call accept_carrier(self, grp, -1.0_wp)   ! an external pair on an optional housing (D-73)
      if (grp%holds('backlash')) then   ! the spur geometry form's key (D-62)
         call fatal_error(err, grp%where('backlash')//": error: a helical_gear takes 'half_backlash', half the "// &
                          "TOTAL backlash along the line of action ('backlash' is the spur_gear geometry form's key): "// &
                          'give half_backlash = half your value, in '//units%length, err_input)
         return
      end if
      call grp%expect([character(len=9) :: 'rb_driver', 'rb_driven'])   ! a step apart (D-62)
      call grp%get_real('rb_driver', self%cl%r1, err); if (allocated(err)) return
      call grp%get_real('rb_driven', self%cl%r2, err); if (allocated(err)) return
      call grp%get_real('teeth', self%teeth, err); if (allocated(err)) return
      call grp%get_real('profile_contact_ratio', self%mp, err); if (allocated(err)) return
      call grp%get_real('base_helix_angle', zeta_deg, err); if (allocated(err)) return
      call grp%get_real('face_width', self%face, err); if (allocated(err)) return
      call grp%get_real('approach_angle', self%alpha, err, default=0.0_wp); if (allocated(err)) return
      call grp%get_real('half_backlash', self%cl%b, err); if (allocated(err)) return
      e_default = 30.0e6_wp*units%to_inch**2/units%to_lbf          ! steel, 30e6 psi
      call grp%get_real('youngs_modulus', self%youngs, err, default=e_default); if (allocated(err)) return
      if (.not. self%cl%r1 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driver')//': error: base radius must be > 0, got '//str(self%cl%r1), err_input)
      else if (.not. self%cl%r2 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driven')//': error: base radius must be > 0, got '//str(self%cl%r2), err_input)
      else if (.not. (self%teeth >= 1.0_wp .and. self%teeth <= max_teeth .and. self%teeth == aint(self%teeth))) then
         call fatal_error(err, grp%where('teeth')//': error: teeth must be in [1, '//str(max_teeth)// &
                          '] and a whole number of teeth, got '//str(self%teeth), err_input)
      else if (.not. (self%mp >= 1.0_wp .and. self%mp <= 2.0_wp)) then
         call fatal_error(err, grp%where('profile_contact_ratio')//': error: must be in [1, 2], got '//str(self%mp), &
                          err_input)
      else if (.not. (zeta_deg > 0.0_wp .and. zeta_deg < 60.0_wp)) then
         call fatal_error(err, grp%where('base_helix_angle')//': error: must be in (0, 60) degrees, got '// &
                          str(zeta_deg), err_input)
      else if (.not. self%face > 0.0_wp) then
         call fatal_error(err, grp%where('face_width')//': error: must be > 0, got '//str(self%face)//' '// &
                          units%length, err_input)
      else if (.not. self%cl%b >= 0.0_wp) then
         call fatal_error(err, grp%where('half_backlash')//': error: must be >= 0, got '//str(self%cl%b)//' '//units%length, &
                          err_input)
      else if (.not. self%youngs > 0.0_wp) then
         call fatal_error(err, grp%where('youngs_modulus')//': error: must be > 0, got '//str(self%youngs), err_input)
      end if
      if (allocated(err)) return
      self%zeta = zeta_deg*pi/180.0_wp
      self%ptb = two_pi*self%cl%r1/self%teeth                   ! transverse base pitch
      self%mf = self%face*tan(self%zeta)/self%ptb                ! face contact ratio
      ! the phase of the pattern lies on the path of contact: 0 <= alpha <= 2 pi (m_p + m_F)/N
      if (.not. (self%alpha >= 0.0_wp .and. self%alpha <= two_pi*(self%mp + self%mf)/self%teeth)) then
         call fatal_error(err, grp%where('approach_angle')//': error: approach_angle must be in [0, 2 pi (m_p + m_F)/N] = [0, '// &
                          str(two_pi*(self%mp + self%mf)/self%teeth)//'] rad (the angle of the path of contact), got '// &
                          str(self%alpha), err_input)
         return
      end if
      self%cl%law%k = self%youngs/17.6_wp                        ! stiffness per unit length of contact line
      self%supplies_power = .true.
      call self%cl%law%configure(grp, units, 1.0_wp, 'yang_sun', err); if (allocated(err)) return
      e_default = anint(self%teeth*self%cl%r2/self%cl%r1)     ! N2 when the radii give a whole number
      if (abs(self%teeth*self%cl%r2/self%cl%r1 - e_default) > 1.0e-6_wp*e_default) e_default = 0.0_wp
      call self%ex%configure_te(grp, self%teeth, e_default, err); if (allocated(err)) return
      call configure_issue26(self, grp, units, e_default, err)
   end subroutine hel_configure

   !> pressure_angle, stiffness_model, crowning and tooth friction (D-116); n2 the
   !> driven gear's teeth (0: not a whole number).
   subroutine configure_issue26(self, grp, units, n2, err)
      class(helical_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      real(wp), intent(in) :: n2
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: word
      real(wp) :: an_deg, zn1, zn2
      call pressure_angle_of(grp, 0.0_wp, self%alpha_n, err); if (allocated(err)) return   ! normal
      an_deg = self%alpha_n*180.0_wp/pi
      self%beta = asin(min(1.0_wp, sin(self%zeta)/cos(self%alpha_n)))   ! sin beta_b = sin beta cos alpha_n
      self%alpha_t = atan(tan(self%alpha_n)/cos(self%beta))
      call grp%get_string('stiffness_model', word, err, default='contact_lines'); if (allocated(err)) return
      select case (to_lower(word))
      case ('contact_lines'); self%iso = .false.
      case ('iso6336'); self%iso = .true.
      case default
         call fatal_error(err, grp%where('stiffness_model')//": error: unknown stiffness_model '"//word// &
                          "' for a helical_gear; valid: contact_lines, iso6336", err_input)
         return
      end select
      if (self%iso) then
         if (grp%holds('youngs_modulus') .or. .not. n2 > 0.0_wp) then
            call fatal_error(err, grp%where('stiffness_model')//": error: stiffness_model = 'iso6336' takes the "// &
                             'stiffness from the geometry: no youngs_modulus, and rb_driven/rb_driver * teeth '// &
                             'a whole number of teeth', err_input)
            return
         end if
         zn1 = self%teeth/(cos(self%zeta)**2*cos(self%beta))   ! virtual numbers of teeth
         zn2 = n2/(cos(self%zeta)**2*cos(self%beta))
         call iso_single_pair_stiffness(zn1, zn2, an_deg, self%mp, .false., self%cprime, self%cgamma)
         self%cprime = self%cprime*cos(self%beta)
         self%cgamma = self%cgamma*cos(self%beta)
         ! k L_c has the mean c_gamma_alpha b: k = c_gamma_alpha cos(zeta_b)/m_p (N/(mm um) = 1e9 Pa)
         self%cl%law%k = self%cgamma*1.0e9_wp/6894.757293168_wp*units%to_inch**2/units%to_lbf*cos(self%zeta)/self%mp
      end if
      call grp%get_real('crowning', self%crown, err, default=0.0_wp); if (allocated(err)) return
      call grp%require_nonnegative('crowning', self%crown, err); if (allocated(err)) return
      call self%fric%configure(grp, units, self%cl%r1, self%cl%r2, self%teeth, self%mp, self%alpha, self%alpha_t, &
                               .false., err)
      if (allocated(err)) return
      if (self%fric%on() .and. .not. self%alpha <= two_pi*self%mp/self%teeth) then
         call fatal_error(err, grp%where('approach_angle')//': error: with tooth_friction the approach_angle places '// &
                          'the pitch point on the path of contact: it must be in [0, 2 pi m_p/N] = [0, '// &
                          str(two_pi*self%mp/self%teeth)//'] rad, got '//str(self%alpha), err_input)
      else if ((self%fric%on() .or. self%crown > 0.0_wp) .and. .not. self%mp + self%mf < max_lines - 1) then
         call fatal_error(err, grp%where('face_width')//': error: crowning and tooth friction follow at most '// &
                          str(max_lines - 2)//' lines of contact; this pair has m_p + m_F = '//str(self%mp + self%mf), &
                          err_input)
      end if
      if (allocated(err)) return
      if (self%crown > 0.0_wp) then   ! the crowning's TE: the general path (trainsim_excited_mesh)
         self%ex%has_te = .true.
         self%ex%active = .true.
      end if
   end subroutine configure_issue26

   !> The lines of contact at mesh position e in [0, 1) (base pitches): line j
   !> (c_j = e + j - 1 of the m_p + m_F path-plus-face) spans the roll [lo, hi]
   !> from the start of contact (base pitches) with rates dlo, dhi in e (0 or 1).
   pure subroutine contact_lines(e, mp, mf, c, lo, hi, dlo, dhi, n)
      real(wp), intent(in) :: e, mp, mf
      real(wp), intent(out) :: c(:), lo(:), hi(:), dlo(:), dhi(:)
      integer, intent(out) :: n
      real(wp) :: cj, x0, x1
      integer :: j
      n = 0
      do j = 0, size(c) - 1
         cj = e + j
         if (.not. cj < mp + mf) exit
         x0 = max(0.0_wp, cj - mf); x1 = min(mp, cj)
         if (.not. x1 > x0) cycle
         n = n + 1
         c(n) = cj; lo(n) = x0; hi(n) = x1
         dlo(n) = merge(1.0_wp, 0.0_wp, cj > mf)
         dhi(n) = merge(1.0_wp, 0.0_wp, cj < mp)
      end do
   end subroutine contact_lines

   !> Crowning's TE at mesh position e: the mean gap C_c t^2, t = 2 y/m_F - 1
   !> (y = c - x across the face), over the lines (te), its rate in e (dte),
   !> and the least gap (tu). int t^2 dx over a line = m_F (t_lo^3 - t_hi^3)/6.
   pure subroutine crowning_te(self, e, te, dte, tu)
      class(helical_gear_t), intent(in) :: self
      real(wp), intent(in) :: e
      real(wp), intent(out) :: te, dte, tu
      real(wp) :: c(max_lines), lo(max_lines), hi(max_lines), dlo(max_lines), dhi(max_lines)
      real(wp) :: tlo, thi, num, dnum, sl, dsl
      integer :: j, n
      te = 0.0_wp; dte = 0.0_wp; tu = 0.0_wp
      if (.not. self%crown > 0.0_wp) return
      call contact_lines(e, self%mp, self%mf, c, lo, hi, dlo, dhi, n)
      num = 0.0_wp; dnum = 0.0_wp; sl = 0.0_wp; dsl = 0.0_wp; tu = huge(1.0_wp)
      do j = 1, n
         tlo = 2.0_wp*(c(j) - lo(j))/self%mf - 1.0_wp
         thi = 2.0_wp*(c(j) - hi(j))/self%mf - 1.0_wp
         num = num + self%mf*(tlo**3 - thi**3)/6.0_wp
         dnum = dnum + tlo**2*(1.0_wp - dlo(j)) - thi**2*(1.0_wp - dhi(j))
         sl = sl + (hi(j) - lo(j)); dsl = dsl + (dhi(j) - dlo(j))
         if (thi <= 0.0_wp .and. tlo >= 0.0_wp) then
            tu = 0.0_wp
         else
            tu = min(tu, thi**2, tlo**2)
         end if
      end do
      if (.not. sl > 0.0_wp) then
         tu = 0.0_wp
         return
      end if
      te = self%crown*num/sl
      dte = self%crown*(dnum*sl - num*dsl)/sl**2
      tu = self%crown*tu
   end subroutine crowning_te

   !> The excited mesh's TE (harmonics, run-out) plus the crowning's; c, dc: the length of contact.
   pure subroutine hel_excitation(self, thl, c, dc, e, de)
      class(helical_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl
      real(wp), intent(out) :: c, dc, e, de
      real(wp) :: u, ec, dec, eu
      call self%ex%at(self%mesh_roll(thl), self%zone_m, self%pairs, c, dc, e, de)
      c = self%factor(thl)
      dc = self%factor_derivative(thl)
      de = de*(self%teeth/two_pi)
      if (.not. self%crown > 0.0_wp) return
      u = tooth_phase(thl, self%alpha, self%teeth)
      call crowning_te(self, u - real_floor(u), ec, dec, eu)
      e = e + ec
      de = de + dec*(self%teeth/two_pi)
   end subroutine hel_excitation

   !> `trainsim gear`: L_c at roll u, the loaded and unloaded TE; pairs: the lines in contact.
   pure subroutine hel_mesh_at_roll(self, u, c, te, tu, pairs)
      class(helical_gear_t), intent(in) :: self
      real(wp), intent(in) :: u
      real(wp), intent(out) :: c, te, tu
      integer, intent(out) :: pairs
      real(wp) :: e, ec, dec, eu, cc(max_lines), lo(max_lines), hi(max_lines), dlo(max_lines), dhi(max_lines)
      call self%ex%at_roll(u, c, te)
      tu = self%ex%unloaded_te(u)
      e = u - real_floor(u)
      c = helical_contact_length(e, self%mp, self%mf, self%ptb, self%zeta)
      call crowning_te(self, e, ec, dec, eu)
      te = te + ec
      tu = tu + eu
      call contact_lines(e, self%mp, self%mf, cc, lo, hi, dlo, dhi, pairs)
   end subroutine hel_mesh_at_roll

   pure function hel_stiffness_name(self) result(w)
      class(helical_gear_t), intent(in) :: self
      character(len=:), allocatable :: w
      w = trim(merge('iso6336      ', 'contact_lines', self%iso))
   end function hel_stiffness_name

   !> The lines of contact at thl in length from A, with d/d thl of their ends.
   pure subroutine lines_at(self, thl, lo, hi, dlo, dhi, n)
      class(helical_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl
      real(wp), intent(out) :: lo(:), hi(:), dlo(:), dhi(:)
      integer, intent(out) :: n
      real(wp) :: u, c(max_lines)
      u = tooth_phase(thl, self%alpha, self%teeth)
      call contact_lines(u - real_floor(u), self%mp, self%mf, c, lo, hi, dlo, dhi, n)
      lo(1:n) = lo(1:n)*self%ptb; hi(1:n) = hi(1:n)*self%ptb
      dlo(1:n) = dlo(1:n)*self%ptb*self%teeth/two_pi; dhi(1:n) = dhi(1:n)*self%ptb*self%teeth/two_pi
   end subroutine lines_at

   !> Torques and dissipated power: the excited mesh's plus the tooth friction over the lines.
   pure subroutine hel_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
      class(helical_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, p
      real(wp) :: fs, lo(max_lines), hi(max_lines), dlo(max_lines), dhi(max_lines)
      integer :: n
      call em_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
      if (.not. self%fric%on()) return
      fs = tr/self%cl%r2
      if (.not. self%cl%mode*fs > 0.0_wp) return
      call lines_at(self, thl, lo, hi, dlo, dhi, n)
      call self%fric%add_lines(lo(1:n), hi(1:n), self%zeta, self%cl%mode, self%cl%mode*fs, wl, wr, tl, tr, p)
   end subroutine hel_torques_dissipation

   !> The friction's partials over the lines (friction_mesh_t's torque_jacobian; tf_add_lines_jacobian).
   pure subroutine hel_friction_jacobian(self, thl, wl, wr, w, dw, jt)
      class(helical_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, wr, w, dw(4)
      real(wp), intent(inout) :: jt(2, 4)
      real(wp) :: lo(max_lines), hi(max_lines), dlo(max_lines), dhi(max_lines)
      integer :: n
      call lines_at(self, thl, lo, hi, dlo, dhi, n)
      call self%fric%add_lines_jacobian(lo(1:n), hi(1:n), dlo(1:n), dhi(1:n), self%zeta, self%cl%mode, w, dw, wl, wr, jt)
   end subroutine hel_friction_jacobian

   !> floor(x) in real arithmetic (no default-integer overflow for any finite x).
   elemental real(wp) function real_floor(x) result(f)
      real(wp), intent(in) :: x
      f = aint(x)
      if (f > x) f = f - 1.0_wp
   end function real_floor

   !> Stiffness factor in a linearisation state: the mean length at t_start
   !> (as `linear_factor`), the shortest (single) or the longest (stiffest)
   !> length of the lines of contact over a mesh period. L_c is piecewise
   !> linear in e with kinks where m - e is an integer, so its extremes are at
   !> e = 0 or the fractional parts of m_p, m_F and m_p + m_F.
   pure real(wp) function hel_state_factor(self, state) result(c)
      class(helical_gear_t), intent(in) :: self
      type(lin_state_t), intent(in) :: state
      real(wp) :: e(4), lc(4)
      integer :: i
      if (state%zone /= lin_zone_single .and. state%zone /= lin_zone_stiffest) then
         c = self%linear_factor()
         return
      end if
      e = [0.0_wp, self%mp - real_floor(self%mp), self%mf - real_floor(self%mf), &
           self%mp + self%mf - real_floor(self%mp + self%mf)]
      do i = 1, 4
         lc(i) = helical_contact_length(e(i), self%mp, self%mf, self%ptb, self%zeta)
      end do
      if (state%zone == lin_zone_single) then
         c = minval(lc)
      else
         c = maxval(lc)
      end if
   end function hel_state_factor

   !> Length of the lines of contact at the driver angle (multiplies E/17.6).
   pure real(wp) function hel_factor(self, thl) result(c)
      class(helical_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl
      real(wp) :: u
      u = tooth_phase(thl, self%alpha, self%teeth)
      c = helical_contact_length(u - real_floor(u), self%mp, self%mf, self%ptb, self%zeta)
   end function hel_factor

   !> dL_c/d theta_driver = dL_c/de * N/(2 pi) (dL_c/de is piecewise constant).
   pure real(wp) function hel_factor_derivative(self, thl) result(dc)
      class(helical_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl
      real(wp) :: u, e
      u = tooth_phase(thl, self%alpha, self%teeth)
      e = u - real_floor(u)
      dc = self%ptb*(-dterm(self%mp + self%mf) + dterm(self%mf) + dterm(self%mp))/sin(self%zeta)*self%teeth/two_pi
   contains
      pure real(wp) function dterm(m)
         real(wp), intent(in) :: m
         dterm = real_floor(m - e) + 1.0_wp
      end function dterm
   end function hel_factor_derivative

   !> Work done by the varying stiffness on loaded teeth: (1/2) k p^2 dL_c/dt.
   pure real(wp) function hel_input_power(self, thl, wl, thr, wr) result(pw)
      class(helical_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: p
      if (self%ex%has_te) then   ! the stiffness's work and the force through the TE
         pw = excited_input_power(self, thl, wl, thr, wr)
         return
      end if
      pw = 0.0_wp
      if (self%cl%mode == 0) return
      p = self%cl%mode*self%cl%delta(thl, thr) - self%cl%b
      pw = self%cl%law%elastic_energy(p)*self%factor_derivative(thl)*wl
   end function hel_input_power

   !> Mean length of the lines of contact, m_p F / cos(zeta_b), for modes.
   pure real(wp) function hel_linear_factor(self) result(c)
      class(helical_gear_t), intent(in) :: self
      c = self%mp*self%face/cos(self%zeta)
   end function hel_linear_factor

   !> Hot form (D-35): the faces' guards only; the torques stay with `torques`
   !> (the stiffness factor varies with the driver angle between events).
   pure subroutine hel_hot_form(self, form)
      class(helical_gear_t), intent(in) :: self
      type(hot_form_t), intent(out) :: form
      call clearance_hot_form(self, form)
      form%kind = hf_none
      if (self%ex%has_te) form%guards = hg_none   ! (the TE moves the faces)
   end subroutine hel_hot_form

   function hel_params(self) result(p)
      class(helical_gear_t), intent(in) :: self
      type(param_list_t) :: p
      p = make_param_list([character(len=40) :: 'rb_driver', 'rb_driven', 'teeth', &
                       'profile_contact_ratio', 'face_contact_ratio', &
                       'base_helix_angle_rad', 'transverse_base_pitch', &
                       'face_width', 'youngs_modulus', 'stiffness_per_length', &
                       'mean_mesh_stiffness', 'approach_angle', &
                       'half_backlash', 'gear_ratio', 'total_contact_ratio', 'mesh_period_angle'], &
                       [self%cl%r1, self%cl%r2, self%teeth, self%mp, self%mf, self%zeta, self%ptb, &
                        self%face, self%youngs, self%cl%law%k, &
                        self%cl%law%k*self%mp*self%face/cos(self%zeta), self%alpha, self%cl%b, &
                        guarded_ratio(self%cl%r2, self%cl%r1), self%mp + self%mf, guarded_ratio(two_pi, self%teeth)])
      ! run-out: the static reference spans the hunting period (trainsim_quasi_static, D-118)
      if (self%ex%hunting_period() > 1.0_wp) &
         call append_params(p, [character(len=40) :: 'hunting_period'], [self%ex%hunting_period()])
      ! issue 26 (D-116): only when used (bundled decks: as before)
      if (self%iso) then
         call add_choice(p, 'stiffness_model', 3.0_wp, 'iso6336')
         call append_params(p, [character(len=40) :: 'iso_cprime', 'iso_cgamma_alpha', 'pressure_angle_rad', &
                                'helix_angle_rad'], [self%cprime, self%cgamma, self%alpha_n, self%beta])
      end if
      if (self%crown > 0.0_wp) call append_params(p, [character(len=40) :: 'crowning'], [self%crown])
      if (self%fric%on()) then
         call append_params(p, [character(len=40) :: 'tooth_friction', 'transverse_pressure_angle_rad'], &
                            [self%fric%mu, self%alpha_t])
         if (self%fric%speed) then   ! (D-129; 'constant': as before)
            call append_params(p, [character(len=40) :: 'tooth_friction_velocity'], [self%fric%v_reg])
            call add_choice(p, 'tooth_friction_speed', 1.0_wp, 'speed')
         end if
      end if
   end function hel_params
end module trainsim_el_helical_gear
