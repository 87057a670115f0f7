!> Contact across a clearance, shared by the spur and helical gear pairs, the
!> keyed joint and the clearance coupling.
!>
!> Geometry: delta = r1 th_l - r2 th_r (a length along the line of action for
!> gears and keys, an angle for a coupling), half clearance b. Front face in
!> contact when delta >= b, rear face when delta <= -b, none in between.
!> Penetration p = |delta| - b, rate pdot = sign(delta) * delta' (MODEL-NOTES 7).
!> The contact force F >= 0 acts along the face's normal: on the front face the
!> driver (left) gets -F r1 and the driven (right) gets +F r2; signs reverse on
!> the rear face.
!>
!> Laws (F for stiffness factor c, e.g. 1 or 1.8 tooth pairs):
!>   yang_sun  F = c (k p + D p pdot),  D = 6(1-e)k / [((2e-1)^2 + 3) V_i]   eq. (3.12), (3.18)-(3.19)
!>   linear    F = c k p + d pdot
!>   elasto    Modelica ElastoBacklash: tc = c k p, td = d pdot; F = 0 if tc + td <= 0,
!>             else tc + min(tc, td)   (never pulls)
!> Restitution for yang_sun: goldsmith e = 1 - 0.019 V^0.48 (App. E.2, default),
!> smith e = (1 - exp(-0.0263 V))/3 (eq. 3.20), or a constant. Both fits take V
!> in in/s: the approach velocity is converted from the deck's units first.
!>
!> The discrete mode (face) changes only at events; inside a mode the force is
!> a smooth function of the state (the penetration may go slightly negative
!> within a step before the event is located). With no_tension (yang_sun,
!> linear) the clip max(F, 0) is a kink where the unclipped force passes zero
!> in contact: the face guard not in play carries it (tension_guard) and a
!> sub-mode `slack` (F clipped) flips there, without an event record (D-136).
!> elasto_backlash's clip and min are located alike: that guard carries the
!> distance to the branch's ends, the sub-mode `ezone` says which branch holds.
module trainsim_contact
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, to_lower, string_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_limits, only: check_magnitude
   use trainsim_event, only: event_t, ev_contact_front, ev_contact_rear, ev_separation
   use trainsim_key_fit, only: fit_none, fit_tight, fit_loose, fit_average, key_lineal_stiffness, key_fit_force
   implicit none
   private

   public :: contact_law_t, clearance_t
   public :: law_yang_sun, law_linear, law_elasto, rest_goldsmith, rest_smith, rest_constant

   integer, parameter :: law_yang_sun = 1, law_linear = 2, law_elasto = 3
   !> elasto_backlash's branches (clearance_t%ezone): F = tc + td, F = 0 (tc + td <= 0), F = 2 tc (tc < td)
   integer, parameter, public :: ez_full = 0, ez_slack = 1, ez_double = 2
   public :: v_plausible_ips
   !> Largest approach velocity (in/s) the linearisation assumes a contact can
   !> see: 100 in/s (2.54 m/s), about five times the fastest impacts of the
   !> thesis's cases and above gear-rattle impact speeds (D-25).
   real(wp), parameter :: v_plausible_ips = 100.0_wp
   integer, parameter :: rest_goldsmith = 1, rest_smith = 2, rest_constant = 3
   public :: fit_none, fit_tight, fit_loose, fit_average, key_lineal_stiffness   ! (trainsim_key_fit's)

   !> A contact law with the state of the contact in progress (D, e, V_i).
   type :: contact_law_t
      integer :: law = law_yang_sun
      integer :: restitution_law = rest_goldsmith
      real(wp) :: k = 0.0_wp            !< contact stiffness (single pair for gears)
      real(wp) :: c = 0.0_wp            !< viscous damping (linear, elasto laws)
      real(wp) :: e_const = 1.0_wp      !< restitution for restitution_law = constant
      real(wp) :: v_min = 0.0_wp        !< smallest approach velocity used in eq. (3.12)
      real(wp) :: v_initial = 0.0_wp    !< approach velocity assumed for a contact closed at t_start
      real(wp) :: v_to_ips = 1.0_wp     !< approach velocity (deck units) -> in/s for the fits
      logical :: no_tension = .false.
      !> keyed joint: stiffness from eqs. (4.35)-(4.37) times key_length (k then unused)
      integer :: fit = fit_none
      real(wp) :: key_length_in = 0.0_wp   !< key length, in
      real(wp) :: to_inch = 1.0_wp, to_lbf = 1.0_wp
      ! the contact in progress
      real(wp) :: d = 0.0_wp, e = 1.0_wp, v_i = 0.0_wp
      !> held memory (D, e, V_i; `held`): what a contact found closed at a (re)start
      !> begins with instead of the law's start (the period map's memory, D-150)
      real(wp) :: held(3) = 0.0_wp
      logical :: has_held = .false.
   contains
      procedure :: configure => law_configure
      procedure :: begin_contact => law_begin_contact
      procedure :: restitution => law_restitution
      procedure, non_overridable :: force => law_force
      procedure, non_overridable :: force_of => law_force_of
      procedure, non_overridable :: fit_elastic_force => law_fit_elastic_force
      procedure, non_overridable :: elastic_force => law_elastic_force
      procedure, non_overridable :: elastic_energy => law_elastic_energy
      procedure :: elastic_stiffness => law_elastic_stiffness
      procedure, non_overridable :: fit_stiffness_at => law_fit_stiffness_at
      procedure :: force_partials => law_force_partials
      procedure :: lowest_restitution => law_lowest_restitution
      procedure, non_overridable :: clip_guard => law_clip_guard
      procedure :: linear_damping => law_linear_damping
      procedure :: gentle_damping => law_gentle_damping
   end type contact_law_t

   !> A clearance between two nodes with lever arms r1, r2 and half clearance b.
   !> (The procedures of the right-hand side, its energy and guards are
   !> non_overridable here and in contact_law_t: they then call one another
   !> without dispatch, on the RHS's hot path.)
   type :: clearance_t
      real(wp) :: r1 = 1.0_wp, r2 = 1.0_wp, b = 0.0_wp
      type(contact_law_t) :: law
      integer :: mode = 0               !< +1 front face, 0 free, -1 rear face
      !> no_tension and in contact: the unclipped force is <= 0 (clipped to 0);
      !> flips where it passes zero (tension_guard, D-136)
      logical :: slack = .false.
      !> elasto_backlash in contact: the branch of its law that holds (ez_*);
      !> changes where tc + td or tc - td passes zero (tension_guard)
      integer :: ezone = ez_full
   contains
      procedure, non_overridable :: delta => cl_delta
      procedure :: init => cl_init
      procedure, non_overridable :: guards => cl_guards
      procedure, non_overridable :: tension_guard => cl_tension_guard
      procedure, non_overridable :: tension => cl_tension
      procedure, non_overridable :: elasto_parts => cl_elasto_parts
      procedure :: update => cl_update
      procedure, non_overridable :: contact_force => cl_contact_force
      procedure, non_overridable :: torques => cl_torques
      procedure, non_overridable :: potential => cl_potential
      procedure, non_overridable :: dissipation => cl_dissipation
      procedure, non_overridable :: torques_dissipation => cl_torques_dissipation
      procedure :: torque_jacobian => cl_torque_jacobian
   end type clearance_t

   ! The linearised damping (modes, the dt bound) and the elastic energy (the energy
   ! ledger): off the RHS's path, in the submodule trainsim_contact_linear.
   interface
      pure real(wp) module function law_lowest_restitution(self) result(e)
         class(contact_law_t), intent(in) :: self
      end function law_lowest_restitution
      pure real(wp) module function law_linear_damping(self, c, m_eff, largest, scale, f_load) result(cd)
         class(contact_law_t), intent(in) :: self
         real(wp), intent(in) :: c, m_eff, scale
         logical, intent(in) :: largest
         real(wp), intent(in), optional :: f_load
      end function law_linear_damping
      pure real(wp) module function law_gentle_damping(self, f) result(cd)
         class(contact_law_t), intent(in) :: self
         real(wp), intent(in) :: f
      end function law_gentle_damping
      !> Read the contact-law keys shared by all clearance elements (`v_scale`: the
      !> element's approach velocity to a line speed in the deck's length unit).
      module subroutine law_configure(self, grp, units, v_scale, default_law, err)
         class(contact_law_t), intent(inout) :: self
         type(deck_group_t), intent(inout) :: grp
         type(units_t), intent(in) :: units
         real(wp), intent(in) :: v_scale
         character(len=*), intent(in) :: default_law
         type(error_t), allocatable, intent(out) :: err
      end subroutine law_configure
      pure real(wp) module function law_elastic_energy(self, p) result(e)
         class(contact_law_t), intent(in) :: self
         real(wp), intent(in) :: p
      end function law_elastic_energy
      !> cl_torques and cl_dissipation at one state from one elastic force (one
      !> key fit, not two): bit for bit the two calls (in trainsim_contact_linear).
      pure module subroutine cl_torques_dissipation(self, c, thl, wl, thr, wr, tl, tr, pw)
         class(clearance_t), intent(in) :: self
         real(wp), intent(in) :: c, thl, wl, thr, wr
         real(wp), intent(out) :: tl, tr, pw
      end subroutine cl_torques_dissipation
   end interface

contains

   !> Coefficient of restitution at approach velocity v (deck units).
   pure real(wp) function law_restitution(self, v) result(e)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: v
      real(wp) :: v_ips
      v_ips = abs(v)*self%v_to_ips
      select case (self%restitution_law)
      case (rest_goldsmith)
         e = 1.0_wp - 0.019_wp*v_ips**0.48_wp           ! App. E.2
      case (rest_smith)
         e = (1.0_wp - exp(-0.0263_wp*v_ips))/3.0_wp     ! eq. (3.20)
      case default
         e = self%e_const
      end select
      e = min(max(e, 0.0_wp), 1.0_wp)
   end function law_restitution

   !> A contact begins with approach velocity v_i: fix e and D for its duration.
   !> `initial` marks a contact already closed at t_start (MODEL-NOTES 11): it
   !> takes the held memory if one was given (`has_held`), else the law's start.
   subroutine law_begin_contact(self, v_i, initial)
      class(contact_law_t), intent(inout) :: self
      real(wp), intent(in) :: v_i
      logical, intent(in) :: initial
      real(wp) :: v
      self%v_i = v_i
      if (self%law /= law_yang_sun) return
      if (initial .and. self%has_held) then   ! a memory given (D-150): the contact goes on with it
         self%d = self%held(1); self%e = self%held(2); self%v_i = self%held(3)
         return
      end if
      if (initial) then
         ! no approach: undamped as the App. F listing (D = 0) unless a velocity is assumed
         if (self%v_initial <= 0.0_wp) then
            self%e = 1.0_wp; self%d = 0.0_wp
            return
         end if
         v = self%v_initial
      else
         v = max(abs(v_i), self%v_min)
      end if
      self%e = self%restitution(v)
      self%d = 6.0_wp*(1.0_wp - self%e)*self%k/(((2.0_wp*self%e - 1.0_wp)**2 + 3.0_wp)*v)   ! eq. (3.12)
   end subroutine law_begin_contact

   !> Contact force (>= 0 compressive) for penetration p, rate pdot, stiffness factor c.
   pure real(wp) function law_force(self, c, p, pdot) result(f)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: c, p, pdot
      f = self%force_of(c, self%elastic_force(p), p, pdot)
   end function law_force

   !> Contact force for the elastic force fel = elastic_force(p) already known.
   pure real(wp) function law_force_of(self, c, fel, p, pdot) result(f)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: c, fel, p, pdot
      real(wp) :: tc, td
      select case (self%law)
      case (law_yang_sun)
         f = c*(fel + self%d*p*pdot)                      ! eqs. (3.18)-(3.19)
         if (self%no_tension) f = max(f, 0.0_wp)
      case (law_linear)
         f = c*fel + self%c*pdot
         if (self%no_tension) f = max(f, 0.0_wp)
      case default
         tc = c*fel
         td = self%c*pdot
         if (tc + td <= 0.0_wp) then
            f = 0.0_wp
         else
            f = tc + min(tc, td)
         end if
      end select
   end function law_force_of

   !> Elastic key force F for penetration p with the load-dependent fit:
   !> F = k(F) L p solved by Newton (trainsim_key_fit's key_fit_force, allocation-free).
   pure real(wp) function law_fit_elastic_force(self, p) result(f)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: p
      f = key_fit_force(self%fit, self%key_length_in*p*self%to_inch)/self%to_lbf   ! L p in in^2
   end function law_fit_elastic_force

   !> The face guard not in play locates a kink of the force inside contact:
   !> no_tension's clip (D-136), elasto_backlash's clip and min.
   pure logical function law_clip_guard(self) result(g)
      class(contact_law_t), intent(in) :: self
      g = self%no_tension .or. self%law == law_elasto
   end function law_clip_guard

   !> Elastic part of the contact force at penetration p (factor 1).
   pure real(wp) function law_elastic_force(self, p) result(f)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: p
      if (self%fit /= fit_none) then
         f = self%fit_elastic_force(p)
      else
         f = self%k*p
      end if
   end function law_elastic_force

   !> d(elastic force)/dp at penetration p (factor 1).
   pure real(wp) function law_elastic_stiffness(self, p) result(kp)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: p
      if (self%fit == fit_none) then
         kp = self%k
         return
      end if
      kp = self%fit_stiffness_at(p, self%fit_elastic_force(p))
   end function law_elastic_stiffness

   !> d(elastic force)/dp at penetration p of a fitted key whose elastic force there,
   !> fit_elastic_force(p), is f.
   pure real(wp) function law_fit_stiffness_at(self, p, f) result(kp)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: p, f
      real(wp) :: k, dk, lp
      ! F = k(F) L p  =>  dF/dp = k L / (1 - k'(F) L p)   (lengths in inch, forces in lbf)
      call key_lineal_stiffness(self%fit, abs(f*self%to_lbf), k, dk)
      lp = self%key_length_in*p*self%to_inch
      kp = k*self%key_length_in/(1.0_wp - dk*lp*sign(1.0_wp, f))*self%to_inch/self%to_lbf
   end function law_fit_stiffness_at

   !> Contact force and its partials with respect to p, pdot and the factor c.
   pure subroutine law_force_partials(self, c, p, pdot, f, dfdp, dfdv, dfdc)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: c, p, pdot
      real(wp), intent(out) :: f, dfdp, dfdv, dfdc
      real(wp) :: fel, kel, tc, td
      fel = self%elastic_force(p)                        ! one key fit for the three
      if (self%fit == fit_none) then
         kel = self%k
      else
         kel = self%fit_stiffness_at(p, fel)
      end if
      f = self%force_of(c, fel, p, pdot)
      select case (self%law)
      case (law_yang_sun)
         dfdp = c*(kel + self%d*pdot); dfdv = c*self%d*p; dfdc = fel + self%d*p*pdot
      case (law_linear)
         dfdp = c*kel; dfdv = self%c; dfdc = fel
      case default
         tc = c*fel; td = self%c*pdot
         if (tc + td <= 0.0_wp) then
            dfdp = 0.0_wp; dfdv = 0.0_wp; dfdc = 0.0_wp
         else if (tc < td) then
            dfdp = 2.0_wp*c*kel; dfdv = 0.0_wp; dfdc = 2.0_wp*fel
         else
            dfdp = c*kel; dfdv = self%c; dfdc = fel
         end if
      end select
      if (self%law /= law_elasto .and. self%no_tension .and. f <= 0.0_wp) then
         dfdp = 0.0_wp; dfdv = 0.0_wp; dfdc = 0.0_wp
      end if
   end subroutine law_force_partials

   !> Relative displacement along the line of action.
   pure real(wp) function cl_delta(self, thl, thr) result(d)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      d = self%r1*thl - self%r2*thr
   end function cl_delta

   !> Mode at t_start from the initial state (c: the stiffness factor there,
   !> for the no_tension sub-mode; 1 if absent).
   subroutine cl_init(self, thl, wl, thr, wr, c)
      class(clearance_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(in), optional :: c
      real(wp) :: d, dd, cf
      d = self%delta(thl, thr)
      dd = self%r1*wl - self%r2*wr
      if (d >= self%b) then
         self%mode = 1
         call self%law%begin_contact(dd, .true.)
      else if (d <= -self%b) then
         self%mode = -1
         call self%law%begin_contact(-dd, .true.)
      else
         self%mode = 0
      end if
      cf = 1.0_wp
      if (present(c)) cf = c
      self%slack = .false.
      self%ezone = ez_full
      if (self%mode == 0) return
      if (self%law%law == law_elasto) then
         self%ezone = elasto_zone(self%elasto_parts(cf, thl, wl, thr, wr))
      else
         self%slack = self%tension(cf, thl, wl, thr, wr) < 0.0_wp
      end if
   end subroutine cl_init

   !> The sign of the unclipped contact force on the face in contact (a
   !> positive multiple of it: yang_sun without a key fit k + D pdot, its
   !> factor c p dropped so that it does not vanish with p at the separation;
   !> else the force itself); 1 unless no_tension clips a yang_sun or linear
   !> law in contact.
   pure real(wp) function cl_tension(self, c, thl, wl, thr, wr) result(h)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: c, thl, wl, thr, wr
      real(wp) :: s, p, pdot
      h = 1.0_wp
      if (self%mode == 0 .or. .not. self%law%no_tension .or. self%law%law == law_elasto) return
      s = real(self%mode, wp)
      p = s*(self%r1*thl - self%r2*thr) - self%b
      pdot = s*(self%r1*wl - self%r2*wr)
      if (self%law%law == law_yang_sun) then
         if (self%law%fit == fit_none) then
            h = self%law%k + self%law%d*pdot
         else
            h = self%law%elastic_force(p) + self%law%d*p*pdot
         end if
      else
         h = c*self%law%elastic_force(p) + self%law%c*pdot
      end if
   end function cl_tension

   !> elasto_backlash's parts [tc, td] = [c k p, d pdot] on the face in contact.
   pure function cl_elasto_parts(self, c, thl, wl, thr, wr) result(tt)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: c, thl, wl, thr, wr
      real(wp) :: tt(2), s
      s = real(self%mode, wp)
      tt(1) = c*self%law%elastic_force(s*(self%r1*thl - self%r2*thr) - self%b)
      tt(2) = self%law%c*s*(self%r1*wl - self%r2*wr)
   end function cl_elasto_parts

   !> The branch of elasto_backlash's law that holds for tt = [tc, td], as
   !> law_force_of chooses it (at the onset, tc = 0: 2 tc while td > 0).
   pure integer function elasto_zone(tt) result(z)
      real(wp), intent(in) :: tt(2)
      z = ez_full
      if (tt(1) + tt(2) <= 0.0_wp) then
         z = ez_slack
         if (tt(1) == 0.0_wp .and. tt(2) == 0.0_wp) z = ez_full
      else if (tt(1) < tt(2)) then
         z = ez_double
      end if
   end function elasto_zone

   !> no_tension in contact: the guard of the face not in play (1 in `guards`)
   !> becomes the unclipped force's sign `tension`, negated while slack, so
   !> that it goes below zero where the clip starts or ends (D-136).
   pure subroutine cl_tension_guard(self, c, thl, wl, thr, wr, g)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: c, thl, wl, thr, wr
      real(wp), intent(inout) :: g(2)
      real(wp) :: h, tt(2)
      if (self%mode == 0 .or. .not. self%law%clip_guard()) return
      if (self%law%law == law_elasto) then
         tt = self%elasto_parts(c, thl, wl, thr, wr)
         select case (self%ezone)
         case (ez_slack); h = -(tt(1) + tt(2))         ! ends where tc + td rises through 0
         case (ez_double); h = tt(2) - tt(1)           ! ends where td falls to tc
         case default; h = tt(1) - abs(tt(2))          ! ends at either (tc + td or tc - td through 0)
         end select
      else
         h = self%tension(c, thl, wl, thr, wr)
         if (self%slack) h = -h
      end if
      if (self%mode == 1) then
         g(2) = h
      else
         g(1) = h
      end if
   end subroutine cl_tension_guard

   !> Guards: g(1) for the front face, g(2) for the rear face.
   pure subroutine cl_guards(self, thl, thr, g)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      real(wp), intent(out) :: g(2)
      real(wp) :: d
      d = self%r1*thl - self%r2*thr
      select case (self%mode)
      case (1)
         g(1) = d - self%b; g(2) = 1.0_wp
      case (-1)
         g(1) = 1.0_wp; g(2) = -d - self%b
      case default
         g(1) = self%b - d; g(2) = d + self%b
      end select
   end subroutine cl_guards

   !> A face guard fired: contact begins or ends (appends 1 event), or with
   !> no_tension the clip starts or ends (`slack` flips; no event, D-136).
   subroutine cl_update(self, wl, wr, fired, ev, nev)
      class(clearance_t), intent(inout) :: self
      real(wp), intent(in) :: wl, wr
      logical, intent(in) :: fired(2)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(inout) :: nev
      real(wp) :: dd
      dd = self%r1*wl - self%r2*wr
      select case (self%mode)
      case (0)
         self%slack = .false.
         if (fired(1)) then
            self%mode = 1
            self%ezone = elasto_zone([0.0_wp, self%law%c*dd])   ! (the onset: p = 0)
            call self%law%begin_contact(dd, .false.)
            call push(ev_contact_front, dd)
         else if (fired(2)) then
            self%mode = -1
            self%ezone = elasto_zone([0.0_wp, -self%law%c*dd])
            call self%law%begin_contact(-dd, .false.)
            call push(ev_contact_rear, -dd)
         end if
      case (1)
         if (fired(1)) then
            self%mode = 0
            self%slack = .false.
            call push(ev_separation, -dd)
         else if (fired(2)) then                ! (no_tension: the clip starts or ends)
            call sub_mode(dd)
         end if
      case (-1)
         if (fired(2)) then
            self%mode = 0
            self%slack = .false.
            call push(ev_separation, dd)
         else if (fired(1)) then
            call sub_mode(-dd)
         end if
      end select
   contains
      !> The clip's sub-mode flips; elasto_backlash's branch leaves for the one
      !> its guard led to (from the full branch: slack if td < 0, else 2 tc).
      subroutine sub_mode(pdot)
         real(wp), intent(in) :: pdot
         if (self%law%law /= law_elasto) then
            self%slack = .not. self%slack
         else if (self%ezone /= ez_full) then
            self%ezone = ez_full
         else
            self%ezone = merge(ez_slack, ez_double, pdot < 0.0_wp)
         end if
      end subroutine sub_mode
      subroutine push(kind, v)
         integer, intent(in) :: kind
         real(wp), intent(in) :: v
         nev = nev + 1
         ev(nev) = event_t(kind=kind, approach_velocity=v)
         if (kind /= ev_separation) then
            ev(nev)%restitution = self%law%e
            ev(nev)%damping = self%law%d
         end if
      end subroutine push
   end subroutine cl_update

   !> Signed contact force along the line (+ on the front face) for factor c.
   pure real(wp) function cl_contact_force(self, c, thl, wl, thr, wr) result(fs)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: c, thl, wl, thr, wr
      real(wp) :: d, dd, p, pdot
      if (self%mode == 0) then
         fs = 0.0_wp
         return
      end if
      d = self%r1*thl - self%r2*thr
      dd = self%r1*wl - self%r2*wr
      if (self%law%law == law_yang_sun .and. self%law%fit == fit_none) then
         ! law_force's yang_sun case written out (the RHS's hot path; the same operations)
         if (self%mode == 1) then
            p = d - self%b
            pdot = dd
         else
            p = -d - self%b
            pdot = -dd
         end if
         fs = c*(self%law%k*p + self%law%d*p*pdot)                    ! eqs. (3.18)-(3.19)
         if (self%law%no_tension) fs = max(fs, 0.0_wp)
         if (self%mode /= 1) fs = -fs
      else if (self%mode == 1) then
         fs = self%law%force(c, d - self%b, dd)
      else
         fs = -self%law%force(c, -d - self%b, -dd)
      end if
   end function cl_contact_force

   !> Torques on the left and right node for factor c.
   pure subroutine cl_torques(self, c, thl, wl, thr, wr, tl, tr)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: c, thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      real(wp) :: fs
      fs = self%contact_force(c, thl, wl, thr, wr)
      tl = -fs*self%r1
      tr = fs*self%r2
   end subroutine cl_torques

   !> d(tl, tr)/d(thl, wl, thr, wr) for factor c with dc/dthl = dc.
   pure subroutine cl_torque_jacobian(self, c, dc, thl, wl, thr, wr, jt)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: c, dc, thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      real(wp) :: s, p, pdot, f, dfdp, dfdv, dfdc, dfs(4)
      jt = 0.0_wp
      if (self%mode == 0) return
      s = real(self%mode, wp)
      p = s*self%delta(thl, thr) - self%b
      pdot = s*(self%r1*wl - self%r2*wr)
      call self%law%force_partials(c, p, pdot, f, dfdp, dfdv, dfdc)
      ! fs = s F(c, p, pdot) with p = s delta - b, pdot = s delta': s^2 = 1
      dfs = [dfdp*self%r1 + s*dfdc*dc, dfdv*self%r1, -dfdp*self%r2, -dfdv*self%r2]
      jt(1, :) = -self%r1*dfs
      jt(2, :) = self%r2*dfs
   end subroutine cl_torque_jacobian

   !> Elastic energy (c k p^2 / 2 for a constant stiffness) while in contact.
   pure real(wp) function cl_potential(self, c, thl, thr) result(e)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: c, thl, thr
      real(wp) :: p
      e = 0.0_wp
      if (self%mode == 0) return
      p = self%mode*(self%r1*thl - self%r2*thr) - self%b
      e = c*self%law%elastic_energy(p)
   end function cl_potential

   !> Power dissipated: (F - c k p) pdot, the force beyond the elastic one times the rate.
   pure real(wp) function cl_dissipation(self, c, thl, wl, thr, wr) result(pw)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: c, thl, wl, thr, wr
      real(wp) :: tl, tr
      call self%torques_dissipation(c, thl, wl, thr, wr, tl, tr, pw)   ! (one key fit, as alone)
   end function cl_dissipation
end module trainsim_contact
