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
module trainsim_el_helical_gear
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list, guarded_product, guarded_ratio
   use trainsim_element, only: lin_state_t, lin_zone_single, lin_zone_stiffest
   use trainsim_clearance_element, only: clearance_hot_form
   use trainsim_element, only: element_t, accept_carrier, hot_form_t, hf_none, hg_none
   use trainsim_excited_mesh, only: excited_mesh_t, excited_input_power
   use trainsim_el_spur_gear, only: tooth_phase, max_teeth
   implicit none
   private

   public :: helical_gear_t, new_helical_gear, helical_contact_length

   !> teeth, alpha and the displacement excitation: excited_mesh_t.
   type, extends(excited_mesh_t) :: helical_gear_t
      real(wp) :: mp = 1.0_wp, mf = 0.0_wp, ptb = 0.0_wp, zeta = 0.0_wp, youngs = 0.0_wp, face = 0.0_wp
   contains
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
      call self%ex%configure_te(grp, self%teeth, e_default, err)
   end subroutine hel_configure

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
                       'half_backlash', 'gear_ratio', 'total_contact_ratio'], &
                       [self%cl%r1, self%cl%r2, self%teeth, self%mp, self%mf, self%zeta, self%ptb, &
                        self%face, self%youngs, self%cl%law%k, &
                        self%cl%law%k*self%mp*self%face/cos(self%zeta), self%alpha, self%cl%b, &
                        guarded_ratio(self%cl%r2, self%cl%r1), self%mp + self%mf])
   end function hel_params
end module trainsim_el_helical_gear
