!> An element whose two nodes act through a clearance (trainsim_contact):
!> implements everything the integrators and the recorder ask of it from the
!> clearance and a stiffness factor. Concrete elements (spur and helical gear,
!> keyed joint, clearance coupling) add `configure`, `params` and, where the
!> stiffness depends on the mesh position, `factor`, guards and mode updates.
module trainsim_clearance_element
   use trainsim_kinds, only: wp
   use trainsim_event, only: event_t
   use trainsim_contact, only: clearance_t, law_yang_sun, law_linear, fit_none, v_plausible_ips, ez_full
   use trainsim_element, only: element_t, lin_state_t, lin_contact_closed, hot_form_t, hf_none, hf_open, &
                               hf_yang_sun, hf_linear, hg_faces, hg_none
   implicit none
   private

   public :: clearance_element_t, clearance_hot_form, ce_torques, ce_torques_dissipation, ce_dissipation, &
             ce_torque_jacobian

   type, abstract, extends(element_t) :: clearance_element_t
      type(clearance_t) :: cl
   contains
      procedure :: factor => ce_factor
      procedure :: linear_factor => ce_linear_factor
      procedure :: factor_derivative => ce_factor_derivative
      procedure :: torque_jacobian => ce_torque_jacobian
      procedure :: torques => ce_torques
      procedure :: displacement => ce_displacement
      procedure :: displacement_unit => ce_displacement_unit
      procedure :: stiffness_matrix => ce_stiffness
      procedure :: linearise => ce_linearise
      procedure :: state_factor => ce_state_factor
      procedure :: potential_energy => ce_potential
      procedure :: dissipation_power => ce_dissipation
      procedure :: torques_dissipation => ce_torques_dissipation
      procedure :: n_guards => ce_n_guards
      procedure :: guards => ce_guards
      procedure :: init_mode => ce_init_mode
      procedure :: preload_mode => ce_preload_mode
      procedure :: update_mode => ce_update_mode
      procedure :: in_contact => ce_in_contact
      procedure :: status => ce_status
      procedure :: hot_form => ce_hot_form
      procedure :: displacement_bound => ce_displacement_bound
      procedure, non_overridable :: memory_size => ce_memory_size
      procedure, non_overridable :: get_memory => ce_get_memory
      procedure, non_overridable :: set_memory => ce_set_memory
   end type clearance_element_t

contains

   !> Stiffness factor at driver angle thl (1: the law's stiffness as given).
   pure real(wp) function ce_factor(self, thl) result(c)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl
      associate (u1 => self, u2 => thl)
      end associate
      c = 1.0_wp
   end function ce_factor

   !> Stiffness factor used to linearise (modes): the factor in the current state.
   pure real(wp) function ce_linear_factor(self) result(c)
      class(clearance_element_t), intent(in) :: self
      c = self%factor(0.0_wp)
   end function ce_linear_factor

   !> d factor / d thl (0: the factor is piecewise constant between events).
   pure real(wp) function ce_factor_derivative(self, thl) result(dc)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl
      associate (u1 => self, u2 => thl)
      end associate
      dc = 0.0_wp
   end function ce_factor_derivative

   pure subroutine ce_torque_jacobian(self, thl, wl, thr, wr, jt)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      call self%cl%torque_jacobian(self%factor(thl), self%factor_derivative(thl), thl, wl, thr, wr, jt)
   end subroutine ce_torque_jacobian

   pure subroutine ce_torques(self, thl, wl, thr, wr, tl, tr)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      real(wp) :: fs
      fs = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)   ! eqs. (3.15)-(3.17), (H.3)-(H.25)
      tl = -fs*self%cl%r1                                            ! as cl_torques, one call fewer
      tr = fs*self%cl%r2
   end subroutine ce_torques

   pure real(wp) function ce_displacement(self, thl, thr) result(d)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      d = self%cl%delta(thl, thr)
   end function ce_displacement

   pure function ce_displacement_unit(self) result(u)
      class(clearance_element_t), intent(in) :: self
      character(len=:), allocatable :: u
      associate (unused => self)
      end associate
      u = 'length'
   end function ce_displacement_unit

   !> Linearised in the current contact state (zero across an open clearance).
   pure subroutine ce_stiffness(self, k)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(out) :: k(2, 2)
      real(wp) :: kk
      kk = 0.0_wp
      if (self%cl%mode /= 0) kk = self%cl%law%k*self%linear_factor()
      k(1, 1) = kk*self%cl%r1**2
      k(1, 2) = -kk*self%cl%r1*self%cl%r2
      k(2, 1) = k(1, 2)
      k(2, 2) = kk*self%cl%r2**2
   end subroutine ce_stiffness

   !> Stiffness factor in a linearisation state (default: `linear_factor`;
   !> gears whose stiffness varies with the mesh position override it).
   pure real(wp) function ce_state_factor(self, state) result(c)
      class(clearance_element_t), intent(in) :: self
      type(lin_state_t), intent(in) :: state
      associate (unused => state)
      end associate
      c = self%linear_factor()
   end function ce_state_factor

   !> Linearised in `state`: a closed contact (closed at t_start, or every one in
   !> the closed states) has stiffness c k and the damping of its law
   !> (`linear_damping`, D-25) along g = (r1, -r2): K = c k g g^T, C = d g g^T.
   !> An open contact contributes nothing.
   pure subroutine ce_linearise(self, state, inv_jl, inv_jr, k, c)
      class(clearance_element_t), intent(in) :: self
      type(lin_state_t), intent(in) :: state
      real(wp), intent(in) :: inv_jl, inv_jr
      real(wp), intent(out) :: k(2, 2), c(2, 2)
      real(wp) :: g(2), f, inv_m, m_eff, cd, f_load
      k = 0.0_wp
      c = 0.0_wp
      if (.not. (state%contact == lin_contact_closed .or. self%cl%mode /= 0)) return
      f = self%state_factor(state)
      g = [self%cl%r1, -self%cl%r2]
      ! mass behind the contact along the line: 1/m = r1^2/J_l + r2^2/J_r
      inv_m = self%cl%r1**2*inv_jl + self%cl%r2**2*inv_jr
      m_eff = 0.0_wp
      if (inv_m > 0.0_wp) m_eff = 1.0_wp/inv_m
      f_load = 0.0_wp
      if (min(self%cl%r1, self%cl%r2) > 0.0_wp) f_load = max(state%load_torque, 0.0_wp)/min(self%cl%r1, self%cl%r2)
      cd = self%cl%law%linear_damping(f, m_eff, state%contact == lin_contact_closed, state%impact_scale, f_load)
      k = self%cl%law%k*f*spread(g, 2, 2)*spread(g, 1, 2)
      c = cd*spread(g, 2, 2)*spread(g, 1, 2)
   end subroutine ce_linearise

   pure real(wp) function ce_potential(self, thl, thr) result(e)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      e = self%cl%potential(self%factor(thl), thl, thr)
   end function ce_potential

   pure real(wp) function ce_dissipation(self, thl, wl, thr, wr) result(p)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      p = self%cl%dissipation(self%factor(thl), thl, wl, thr, wr)
   end function ce_dissipation

   !> `torques` and `dissipation_power` with one stiffness factor and one
   !> elastic force (bit for bit the two calls: cl_torques_dissipation).
   pure subroutine ce_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, p
      call self%cl%torques_dissipation(self%factor(thl), thl, wl, thr, wr, tl, tr, p)
   end subroutine ce_torques_dissipation

   pure integer function ce_n_guards(self) result(n)
      class(clearance_element_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 2
   end function ce_n_guards

   !> Guards 1-2: the front and rear faces (with no_tension, the one not in play
   !> the clip's: tension_guard, D-136).
   pure subroutine ce_guards(self, thl, wl, thr, wr, g)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      call self%cl%guards(thl, thr, g(1:2))
      if (self%cl%law%clip_guard()) call self%cl%tension_guard(self%factor(thl), thl, wl, thr, wr, g(1:2))
   end subroutine ce_guards

   subroutine ce_init_mode(self, thl, wl, thr, wr)
      class(clearance_element_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      call self%cl%init(thl, wl, thr, wr, self%factor(thl))
   end subroutine ce_init_mode

   !> Static preload: the clearance closed on `face` whatever the angles (the
   !> Newton solve then finds the penetration), other modes from the angles.
   !> A closed start has no approach speed (D-13: D = 0 unless initial_contact_velocity).
   subroutine ce_preload_mode(self, face, thl, wl, thr, wr)
      class(clearance_element_t), intent(inout) :: self
      integer, intent(in) :: face
      real(wp), intent(in) :: thl, wl, thr, wr
      call self%init_mode(thl, wl, thr, wr)
      self%cl%mode = face
      self%cl%slack = .false.   ! (at rest: the elastic force alone;
      self%cl%ezone = ez_full   ! elasto_backlash: tc + td with td = 0)
      if (face /= 0) call self%cl%law%begin_contact(0.0_wp, .true.)
   end subroutine ce_preload_mode

   subroutine ce_update_mode(self, t, thl, wl, thr, wr, fired, ev, nev)
      class(clearance_element_t), intent(inout) :: self
      real(wp), intent(in) :: t, thl, wl, thr, wr
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      associate (u1 => t, u2 => thl, u3 => thr)
      end associate
      nev = 0
      call self%cl%update(wl, wr, fired(1:2), ev, nev)
   end subroutine ce_update_mode

   pure logical function ce_in_contact(self) result(c)
      class(clearance_element_t), intent(in) :: self
      c = self%cl%mode /= 0
   end function ce_in_contact

   !> The element's memory: state kept outside y that the motion depends on (D-150).
   !> The yang_sun law's contact in progress (D, e, V_i): fixed at the impact that
   !> closed it (eq. 3.12), kept while the contact lasts. 0 for the other laws.
   pure integer function ce_memory_size(self) result(n)
      class(clearance_element_t), intent(in) :: self
      n = merge(3, 0, self%cl%law%law == law_yang_sun)
   end function ce_memory_size

   !> mem(1:memory_size) = the memory now (D, e, V_i).
   pure subroutine ce_get_memory(self, mem)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(out) :: mem(:)
      if (self%memory_size() == 3) mem(1:3) = [self%cl%law%d, self%cl%law%e, self%cl%law%v_i]
   end subroutine ce_get_memory

   !> Hold mem as the memory: a contact found closed when the modes are next
   !> chosen from a state (`init_mode`: the model's `init_modes`, a session's
   !> `set_state`) begins with it instead of the law's start (D-13); a contact
   !> that closes by an impact takes its own. Nothing changes before that
   !> (the model's hot tables hold the mode's D until then).
   pure subroutine ce_set_memory(self, mem)
      class(clearance_element_t), intent(inout) :: self
      real(wp), intent(in) :: mem(:)
      if (self%memory_size() /= 3) return
      self%cl%law%held = mem(1:3)
      self%cl%law%has_held = .true.
   end subroutine ce_set_memory

   !> displacement = delta, force = signed contact force, contact = face, pairs = 0.
   pure subroutine ce_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      disp = self%cl%delta(thl, thr)
      force = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)
      contact = self%cl%mode
      pairs = 0
   end subroutine ce_status

   !> The hot form (D-35) of `torques` (ce_torques: cl_contact_force with the
   !> stiffness factor `factor`) and `guards` (ce_guards: the two faces) in the
   !> current mode: open, or closed with the yang_sun or linear law and a
   !> constant stiffness law (no key fit); elasto_backlash and fitted keys are
   !> declined (kind = hf_none). The factor is taken as `factor(0)`: a type
   !> whose factor varies between events (the helical gear), or that adds to
   !> the torques (the keyed joint's bore friction), overrides this to decline
   !> the torque form; one that changes the guards answers its own guard form.
   pure subroutine ce_hot_form(self, form)
      class(clearance_element_t), intent(in) :: self
      type(hot_form_t), intent(out) :: form
      call clearance_hot_form(self, form)
   end subroutine ce_hot_form

   !> `ce_hot_form` under a name the concrete types call from their own
   !> `hot_form` (an abstract parent's binding cannot be called directly).
   pure subroutine clearance_hot_form(self, form)
      class(clearance_element_t), intent(in) :: self
      type(hot_form_t), intent(out) :: form
      form%guards = hg_faces
      if (self%cl%law%clip_guard()) form%guards = hg_none   ! (the clip's guard reads the speeds, D-136)
      form%mode = self%cl%mode
      form%s = real(self%cl%mode, wp)
      form%b = self%cl%b
      form%r1 = self%cl%r1
      form%r2 = self%cl%r2
      form%k = self%cl%law%k
      form%no_tension = self%cl%law%no_tension
      form%c = self%factor(0.0_wp)
      form%kind = hf_none
      if (self%cl%law%fit /= fit_none) return
      if (self%cl%mode == 0) then
         form%kind = hf_open
      else if (self%cl%law%law == law_yang_sun) then
         form%kind = hf_yang_sun
         form%dmp = self%cl%law%d
      else if (self%cl%law%law == law_linear) then
         form%kind = hf_linear
         form%dmp = self%cl%law%c
      end if
   end subroutine clearance_hot_form

   !> |delta| a physical run can reach (D-55): the half clearance b plus ten
   !> times the largest of b, the static penetration under the loads
   !> F/k (F = load_torque/min(r1, r2), the single-pair stiffness k) and the
   !> penetration of an impact at the largest plausible approach velocity
   !> V sqrt(m_eff/k) (v_plausible_ips, D-25). A mesh beyond it has its teeth
   !> through one another. No bound for a law without a constant stiffness
   !> (the keyed joint's load-dependent fit).
   pure real(wp) function ce_displacement_bound(self, load_torque, inv_jl, inv_jr) result(bound)
      class(clearance_element_t), intent(in) :: self
      real(wp), intent(in) :: load_torque, inv_jl, inv_jr
      real(wp) :: k, r, inv_m, p
      bound = huge(1.0_wp)
      k = self%cl%law%k
      r = min(self%cl%r1, self%cl%r2)
      if (.not. (k > 0.0_wp .and. r > 0.0_wp) .or. self%cl%law%fit /= fit_none) return
      p = max(self%cl%b, load_torque/r/k)
      inv_m = self%cl%r1**2*inv_jl + self%cl%r2**2*inv_jr
      if (inv_m > 0.0_wp) p = max(p, v_plausible_ips/self%cl%law%v_to_ips*sqrt(1.0_wp/(inv_m*k)))
      bound = self%cl%b + 10.0_wp*p
   end function ce_displacement_bound
end module trainsim_clearance_element
