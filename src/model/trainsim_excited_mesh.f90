!> A clearance element whose mesh is excited (issue 26): the stiffness factor
!> and the static transmission error e of trainsim_mesh_excitation at the
!> driver's roll position u = N (theta + alpha)/(2 pi) + mesh_phase.
!>
!> The TE is a displacement excitation along the line of action: the contact
!> law sees the penetration of delta - e, delta = r1 theta_l - r2 theta_r, and
!> its rate delta' - e' (`shift`: the driver angle and speed moved by e/r1 and
!> e'/r1). The force acts on the nodes as before (torques -F r1, F r2).
!> Energy: with V = c E(p), p = s (delta - e) - b, the excitation does the work
!>   P_in = dc/dt E(p) - F_s de/dt
!> (the parametric stiffness, 1/2 k p^2 dc/dt for a linear law, and the force
!> moving through the TE), so stored + dissipated - input closes.
!> Without excitation (`ex%active` false) every procedure is the clearance
!> element's, bit for bit (a = theta_l, a' = omega_l).
module trainsim_excited_mesh
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_error, only: error_t
   use trainsim_tooth_friction, only: pressure_angle_of
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_event, only: event_t
   use trainsim_clearance_element, only: clearance_element_t
   use trainsim_mesh_excitation, only: mesh_excitation_t, sm_iso, iso_single_pair_stiffness, model_name
   implicit none
   private

   public :: excited_mesh_t, excited_input_power, configure_mesh_excitation
   ! the torques under names a concrete type's own `torques` can fall back on (tooth friction)
   public :: em_torques, em_torques_dissipation, em_dissipation, em_torque_jacobian, em_status, em_guards

   !> |driver angle| beyond which the roll is taken at this value (D-26).
   real(wp), parameter :: theta_cap = 1.0e250_wp

   type, abstract, extends(clearance_element_t) :: excited_mesh_t
      type(mesh_excitation_t) :: ex
      real(wp) :: teeth = 0.0_wp          !< teeth on the driver
      real(wp) :: alpha = 0.0_wp          !< approach angle, rad
      real(wp) :: phase = 0.0_wp          !< mesh_phase: the zones' shift in teeth, u = N (theta + alpha)/(2 pi) + phase
      integer :: pairs = 1                !< current zone: 1 or 2 pairs
      real(wp) :: zone_m = 0.0_wp         !< the current zone's count of teeth entered (its newest pair's)
   contains
      procedure, non_overridable :: mesh_roll => em_roll
      procedure :: excitation => em_excitation
      procedure :: mesh_at_roll => em_mesh_at_roll
      procedure :: stiffness_name => em_stiffness_name
      procedure, non_overridable :: shift => em_shift
      procedure :: torques => em_torques
      procedure :: torques_dissipation => em_torques_dissipation
      procedure :: dissipation_power => em_dissipation
      procedure :: potential_energy => em_potential
      procedure :: torque_jacobian => em_torque_jacobian
      procedure :: input_power => excited_input_power
      procedure :: factor_derivative => em_factor_derivative
      procedure :: linear_factor => em_linear_factor
      procedure :: guards => em_guards
      procedure :: init_mode => em_init_mode
      procedure :: update_mode => em_update_mode
      procedure :: status => em_status
   end type excited_mesh_t

contains

   !> Read a spur pair's mesh excitation (after its own keys: teeth, r1, r2, the
   !> contact ratio mp and two_pair_factor c2 known). teeth2 = 0 in TRAIN's
   !> constants form: N2 = N r2/r1 when that is whole. stiffness_model =
   !> 'iso6336' (geometry form: pitch module > 0, pressure angle phi in rad,
   !> face width, no explicit stiffness) sets the mean mesh stiffness
   !> c_gamma_alpha b (ISO 6336-1, N/(mm um) = 1e9 Pa; D-100).
   subroutine configure_mesh_excitation(self, grp, units, teeth2, mp, c2, pitch_module, phi, face, internal, err)
      class(excited_mesh_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      real(wp), intent(in) :: teeth2, mp, c2, pitch_module, phi, face
      logical, intent(in) :: internal
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: n2, cp, cg, ph
      logical :: iso_ok
      n2 = teeth2
      if (.not. n2 > 0.0_wp) then
         n2 = self%teeth*self%cl%r2/self%cl%r1
         if (abs(n2 - anint(n2)) > 1.0e-6_wp*n2 .or. n2 < 1.0_wp) n2 = 0.0_wp
         n2 = anint(n2)
      end if
      iso_ok = pitch_module > 0.0_wp .and. .not. (grp%holds('stiffness') .or. grp%holds('stiffness_per_width'))
      if (grp%holds('tip_relief_start_roll')) then   ! T1E for a relief by roll angle (constants form: phi 20 deg default)
         call pressure_angle_of(grp, phi, ph, err); if (allocated(err)) return
         self%ex%rb1 = self%cl%r1
         self%ex%t1e = self%cl%r1*tan(ph) + mp*two_pi*self%cl%r1/self%teeth - self%alpha*self%cl%r1
      end if
      call self%ex%configure(grp, self%teeth, n2, mp, c2, two_pi*self%cl%r1/self%teeth, iso_ok, err)
      if (allocated(err)) return
      if (self%ex%model == sm_iso) then
         call iso_single_pair_stiffness(self%teeth, n2, phi*180.0_wp/pi, mp, internal, cp, cg)
         self%cl%law%k = cg*1.0e9_wp/6894.757293168_wp*units%to_inch**2/units%to_lbf*face
      end if
      self%supplies_power = self%ex%varies .or. self%ex%has_te
   end subroutine configure_mesh_excitation

   !> Roll position u (teeth) of the driver angle thl.
   pure real(wp) function em_roll(self, thl) result(u)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl
      u = (max(min(thl, theta_cap), -theta_cap) + self%alpha)*(self%teeth/two_pi) + self%phase
   end function em_roll

   !> Stiffness factor c, dc/d theta_l, TE e and de/d theta_l at thl in the current zone.
   pure subroutine em_excitation(self, thl, c, dc, e, de)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl
      real(wp), intent(out) :: c, dc, e, de
      call self%ex%at(self%mesh_roll(thl), self%zone_m, self%pairs, c, dc, e, de)
      dc = dc*(self%teeth/two_pi)
      de = de*(self%teeth/two_pi)
   end subroutine em_excitation

   !> The mesh at roll u (teeth) from the geometry alone, for `trainsim gear`:
   !> stiffness factor c, loaded TE te, unloaded TE tu, pairs in contact (0: lines).
   pure subroutine em_mesh_at_roll(self, u, c, te, tu, pairs)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: u
      real(wp), intent(out) :: c, te, tu
      integer, intent(out) :: pairs
      call self%ex%at_roll(u, c, te, pairs)
      tu = self%ex%unloaded_te(u)
   end subroutine em_mesh_at_roll

   !> The deck's word for the stiffness model.
   pure function em_stiffness_name(self) result(w)
      class(excited_mesh_t), intent(in) :: self
      character(len=:), allocatable :: w
      w = model_name(self%ex%model)
   end function em_stiffness_name

   !> The driver angle and speed the contact law sees: a = thl - e/r1, va = wl - e'/r1.
   pure subroutine em_shift(self, thl, wl, a, va)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl
      real(wp), intent(out) :: a, va
      real(wp) :: c, dc, e, de
      a = thl; va = wl
      if (.not. self%ex%has_te) return
      call self%excitation(thl, c, dc, e, de)
      a = thl - e/self%cl%r1
      va = wl - de*wl/self%cl%r1
   end subroutine em_shift

   pure subroutine em_torques(self, thl, wl, thr, wr, tl, tr)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      real(wp) :: fs, a, va
      call self%shift(thl, wl, a, va)
      fs = self%cl%contact_force(self%factor(thl), a, va, thr, wr)   ! eqs. (3.15)-(3.17), (H.3)-(H.25)
      tl = -fs*self%cl%r1
      tr = fs*self%cl%r2
   end subroutine em_torques

   !> `torques` and `dissipation_power` with one factor and one contact force.
   pure subroutine em_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, p
      real(wp) :: c, fs, pen, pdot, a, va
      call self%shift(thl, wl, a, va)
      c = self%factor(thl)
      fs = self%cl%contact_force(c, a, va, thr, wr)
      tl = -fs*self%cl%r1
      tr = fs*self%cl%r2
      p = 0.0_wp
      if (self%cl%mode == 0) return
      pen = self%cl%mode*(self%cl%r1*a - self%cl%r2*thr) - self%cl%b
      pdot = self%cl%mode*(self%cl%r1*va - self%cl%r2*wr)
      p = (self%cl%mode*fs - c*self%cl%law%elastic_force(pen))*pdot
   end subroutine em_torques_dissipation

   pure real(wp) function em_dissipation(self, thl, wl, thr, wr) result(p)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: a, va
      call self%shift(thl, wl, a, va)
      p = self%cl%dissipation(self%factor(thl), a, va, thr, wr)
   end function em_dissipation

   pure real(wp) function em_potential(self, thl, thr) result(e)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      real(wp) :: a, va
      call self%shift(thl, 0.0_wp, a, va)
      e = self%cl%potential(self%factor(thl), a, thr)
   end function em_potential

   !> d(tl, tr)/d(thl, wl, thr, wr). With a TE: p = s (r1 thl - e - r2 thr) - b,
   !> p' = s (r1 wl - e_1 wl - r2 wr), e_1 = de/dthl (e_2 = de_1/dthl by a
   !> central difference: the Jacobian only steers Newton's iterations).
   pure subroutine em_torque_jacobian(self, thl, wl, thr, wr, jt)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      real(wp) :: s, p, pdot, f, dfdp, dfdv, dfdc, dfs(4), c, dc, e, e1, e2, h, cx, dcx, ex, ep, em
      if (.not. self%ex%has_te) then
         call self%cl%torque_jacobian(self%factor(thl), self%factor_derivative(thl), thl, wl, thr, wr, jt)
         return
      end if
      jt = 0.0_wp
      if (self%cl%mode == 0) return
      call self%excitation(thl, c, dc, e, e1)
      c = self%factor(thl)
      dc = self%factor_derivative(thl)
      h = 1.0e-6_wp*two_pi/self%teeth
      call self%excitation(thl + h, cx, dcx, ex, ep)
      call self%excitation(thl - h, cx, dcx, ex, em)
      e2 = (ep - em)/(2.0_wp*h)
      s = real(self%cl%mode, wp)
      p = s*(self%cl%r1*thl - e - self%cl%r2*thr) - self%cl%b
      pdot = s*(self%cl%r1*wl - e1*wl - self%cl%r2*wr)
      call self%cl%law%force_partials(c, p, pdot, f, dfdp, dfdv, dfdc)
      dfs = [dfdp*(self%cl%r1 - e1) - dfdv*e2*wl + s*dfdc*dc, dfdv*(self%cl%r1 - e1), &
             -dfdp*self%cl%r2, -dfdv*self%cl%r2]
      jt(1, :) = -self%cl%r1*dfs
      jt(2, :) = self%cl%r2*dfs
   end subroutine em_torque_jacobian

   !> The excitation's work: dc/dt E(p) - F_s de/dt (see the module's doc).
   pure real(wp) function excited_input_power(self, thl, wl, thr, wr) result(pw)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: c, dc, e, de, a, va, pen, fs
      pw = 0.0_wp
      if (self%cl%mode == 0 .or. .not. self%ex%active) return
      call self%excitation(thl, c, dc, e, de)
      call self%shift(thl, wl, a, va)
      c = self%factor(thl)
      pen = self%cl%mode*(self%cl%r1*a - self%cl%r2*thr) - self%cl%b
      pw = self%factor_derivative(thl)*wl*self%cl%law%elastic_energy(pen)
      if (.not. self%ex%has_te) return
      fs = self%cl%contact_force(c, a, va, thr, wr)
      pw = pw - fs*de*wl
   end function excited_input_power

   !> d factor / d thl: 0 between zone events unless the stiffness varies.
   pure real(wp) function em_factor_derivative(self, thl) result(dc)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl
      real(wp) :: c, e, de
      dc = 0.0_wp
      if (.not. self%ex%varies) return
      call self%excitation(thl, c, dc, e, de)
   end function em_factor_derivative

   !> Stiffness factor to linearise: the current zone's (TRAIN), or the mean
   !> over a tooth period of a stiffness that varies.
   pure real(wp) function em_linear_factor(self) result(c)
      class(excited_mesh_t), intent(in) :: self
      if (self%ex%varies) then
         c = self%ex%cmean
      else
         c = self%factor(0.0_wp)
      end if
   end function em_linear_factor

   !> Guards 1-2: the faces at the shifted driver angle (a type with zones adds its own).
   pure subroutine em_guards(self, thl, wl, thr, wr, g)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      real(wp) :: a, va
      call self%shift(thl, wl, a, va)
      call self%cl%guards(a, thr, g(1:2))
      if (self%cl%law%clip_guard()) call self%cl%tension_guard(self%factor(thl), a, va, thr, wr, g(1:2))   ! (D-136)
   end subroutine em_guards

   subroutine em_init_mode(self, thl, wl, thr, wr)
      class(excited_mesh_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: a, va
      call self%shift(thl, wl, a, va)
      call self%cl%init(a, va, thr, wr, self%factor(thl))
   end subroutine em_init_mode

   subroutine em_update_mode(self, t, thl, wl, thr, wr, fired, ev, nev)
      class(excited_mesh_t), intent(inout) :: self
      real(wp), intent(in) :: t, thl, wl, thr, wr
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      real(wp) :: a, va
      associate (u1 => t, u2 => thr)
      end associate
      nev = 0
      call self%shift(thl, wl, a, va)
      call self%cl%update(va, wr, fired(1:2), ev, nev)
   end subroutine em_update_mode

   !> displacement = delta (the measured TE, e included), force, contact = face, pairs = 0.
   pure subroutine em_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(excited_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      real(wp) :: a, va
      call self%shift(thl, wl, a, va)
      disp = self%cl%delta(thl, thr)
      force = self%cl%contact_force(self%factor(thl), a, va, thr, wr)
      contact = self%cl%mode
      pairs = 0
   end subroutine em_status
end module trainsim_excited_mesh
