!> The abstract element: what every element type must answer (TRAIN's
!> LTRQ/RTRQ as `torques`, reading its own parameters) and what elements with
!> clearances add (switching functions, a discrete mode updated at a switch,
!> recorded outputs). Optional capabilities have no-op defaults, so a smooth
!> element is a configure + torques pair and nothing else.
!>
!> Sign convention: `torques` returns the torque the element puts ON its left
!> node (tl) and ON its right node (tr), positive in the direction of positive
!> rotation. TRAIN's RTRQ of element i is -tl, its LTRQ seen by node i+1 is tr.
!>
!> Ports (D-73): left, right are ports 1, 2; an n-port element has more
!> (`more_ports`, deck keys `port_keys`) and answers the `port_*` procedures on
!> arrays over its ports. Their defaults serve two ports and two ports on a
!> carrier (port 3, `accept_carrier`): the element's physics in its frame.
module trainsim_element
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t
   use trainsim_event, only: event_t
   use trainsim_strings, only: string_t
   use trainsim_constraint_rows, only: constraint_rows_t
   use trainsim_lin_state, only: lin_state_t, lin_start, lin_closed, lin_stiffest, lin_contact_initial, &
                                 lin_contact_closed, lin_zone_initial, lin_zone_single, lin_zone_stiffest
   implicit none
   private

   public :: element_t, element_slot_t, max_ports, accept_carrier
   public :: lin_state_t, lin_start, lin_closed, lin_stiffest
   public :: lin_contact_initial, lin_contact_closed
   public :: lin_zone_initial, lin_zone_single, lin_zone_stiffest
   public :: hot_form_t, hf_none, hf_open, hf_yang_sun, hf_linear, hg_none, hg_faces, hg_faces_zone

   !> Most ports of one element (the model's buffers for one element's ports).
   integer, parameter :: max_ports = 4

   !> Torque forms of `hot_form` (D-35): none (asked through `torques`), a
   !> clearance open (no force), a closed clearance with the yang_sun or the
   !> linear law and a stiffness factor that is constant until the next event.
   integer, parameter :: hf_none = 0, hf_open = 1, hf_yang_sun = 2, hf_linear = 3
   !> Guard forms of `hot_form`: none (asked through `guards`), the two faces of
   !> a clearance (trainsim_contact's cl_guards), the faces and a driver-angle
   !> window [th_lo, th_hi] (a gear's mesh zone: guards 3-4).
   integer, parameter :: hg_none = 0, hg_faces = 1, hg_faces_zone = 2

   !> What an element is between two events, as plain numbers (optional
   !> capability `hot_form`, D-35): the model evaluates its torques and guards
   !> from this record, without calls through the element, with the element's
   !> own operations in the element's own order (bit for bit; see
   !> docs/elements.md). Closed clearance, face s = mode (+1 front, -1 rear):
   !>   d = r1 thl - r2 thr, dd = r1 wl - r2 wr, p = s d - b, pdot = s dd,
   !>   yang_sun: F = c (k p + dmp p pdot);  linear: F = c (k p) + dmp pdot,
   !>   F = max(F, 0) if no_tension; fs = s F; tl = -(fs r1), tr = fs r2.
   !> Guards (cl_guards; zone: g3 = thl - th_lo (1 if lo_open), g4 = th_hi - thl).
   type :: hot_form_t
      integer :: kind = hf_none
      integer :: guards = hg_none
      integer :: mode = 0
      logical :: no_tension = .false., lo_open = .false.
      real(wp) :: s = 0.0_wp                  !< real(mode)
      real(wp) :: c = 1.0_wp, k = 0.0_wp, dmp = 0.0_wp, b = 0.0_wp, r1 = 1.0_wp, r2 = 1.0_wp
      real(wp) :: th_lo = 0.0_wp, th_hi = 0.0_wp
      !> The element vouches that this record is its own procedures' arithmetic
      !> in every mode (a house element whose torques, guards, energy and status
      !> are the record's by construction; the conformance suite checks it): the
      !> model then probes it once, not at every mode change (D-167).
      logical :: exact = .false.
   end type hot_form_t

   type, abstract :: element_t
      character(len=:), allocatable :: id
      character(len=:), allocatable :: type_name
      !> where the deck defines it ("deck.nml:5: &element #1"; '' if not from a deck)
      character(len=:), allocatable :: origin
      integer :: left = 0   !< index of the left (driver) node
      integer :: right = 0  !< index of the right (driven) node
      !> Elements that act on the external loads of their nodes (the keyed joint's
      !> bore friction) set this in `configure`; the model then stores the load
      !> torques on the left and right node in ext_left/ext_right before `torques`.
      logical :: needs_loads = .false.
      !> Elements whose `input_power` is not zero (position-dependent stiffness) set
      !> this in `configure`, so the energy ledger asks only them.
      logical :: supplies_power = .false.
      real(wp) :: ext_left = 0.0_wp, ext_right = 0.0_wp
      !> Nodes of the ports after left (port 1) and right (port 2), in the order
      !> of `port_keys` (set by the builder; unallocated or empty: two ports).
      integer, allocatable :: more_ports(:)
      !> The deck keys that name the further ports, set by `configure` (the
      !> builder reads each as a node id into more_ports).
      type(string_t), allocatable :: port_keys(:)
      !> On a carrier (port 3, D-73): thr' = a thr - s thc, thl' = thl - thc. s, the right gear's
      !> sense relative to the carrier: -1 external pair (TRAIN counts each gear in its own sense,
      !> the driven one turns against the driver), +1 internal (ring) gear; a = right_sign: -1
      !> where the right node is counted in the driver's sense (a planetary's members, D-92).
      real(wp) :: carrier_sense = -1.0_wp, right_sign = 1.0_wp
      type(constraint_rows_t) :: con   !< kinematic constraints in its mode (D-81, trainsim_constraint_rows)
   contains
      procedure(configure_i), deferred :: configure
      procedure(torques_i), deferred :: torques
      procedure :: displacement => el_displacement
      procedure :: displacement_unit => el_displacement_unit
      procedure :: stiffness_matrix => el_stiffness_matrix
      procedure :: linearise => el_linearise
      procedure :: potential_energy => el_potential_energy
      procedure :: dissipation_power => el_dissipation_power
      procedure :: torques_dissipation => el_torques_dissipation
      procedure :: input_power => el_input_power
      procedure :: torque_jacobian => el_torque_jacobian
      procedure :: n_guards => el_n_guards
      procedure :: guards => el_guards
      procedure :: init_mode => el_init_mode
      procedure :: preload_mode => el_preload_mode
      procedure :: update_mode => el_update_mode
      procedure :: breakpoints => el_breakpoints
      procedure :: in_contact => el_in_contact
      procedure :: status => el_status
      procedure :: params => el_params
      procedure :: linear_spring => el_linear_spring
      procedure :: hot_form => el_hot_form
      procedure :: displacement_bound => el_displacement_bound
      procedure, non_overridable :: n_ports => el_n_ports
      procedure, non_overridable :: port => el_port
      procedure, non_overridable :: frame => el_frame
      procedure :: port_torques => el_port_torques
      procedure :: port_torques_dissipation => el_port_torques_dissipation
      procedure :: port_input_power => el_port_input_power
      procedure :: port_potential_energy => el_port_potential_energy
      procedure :: port_guards => el_port_guards
      procedure :: port_init_mode => el_port_init_mode
      procedure :: port_update_mode => el_port_update_mode
      procedure :: port_status => el_port_status
      procedure, non_overridable :: status_at => el_status_at
      procedure :: port_jacobian => el_port_jacobian
      procedure :: port_linearise => el_port_linearise
   end type element_t

   !> A slot in the model's element list (arrays of polymorphic objects).
   type :: element_slot_t
      class(element_t), allocatable :: e
   end type element_slot_t

   abstract interface
      !> Read and validate the element's own keys from its deck group.
      subroutine configure_i(self, grp, units, err)
         import :: element_t, deck_group_t, units_t, error_t
         class(element_t), intent(inout) :: self
         type(deck_group_t), intent(inout) :: grp
         type(units_t), intent(in) :: units
         type(error_t), allocatable, intent(out) :: err
      end subroutine configure_i
      !> Torques on the left and right node for the given node kinematics.
      pure subroutine torques_i(self, thl, wl, thr, wr, tl, tr)
         import :: element_t, wp
         class(element_t), intent(in) :: self
         real(wp), intent(in) :: thl, wl, thr, wr
         real(wp), intent(out) :: tl, tr
      end subroutine torques_i
   end interface

contains

   !> Relative displacement (default: twist thl - thr, rad).
   pure real(wp) function el_displacement(self, thl, thr) result(d)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      associate (unused => self)
      end associate
      d = thl - thr
   end function el_displacement

   !> Unit of `displacement` ('rad' by default, 'length' along a line of action).
   pure function el_displacement_unit(self) result(u)
      class(element_t), intent(in) :: self
      character(len=:), allocatable :: u
      associate (unused => self)
      end associate
      u = 'rad'
   end function el_displacement_unit

   !> Linearised stiffness in the node angles (thl, thr), for `trainsim modes`.
   pure subroutine el_stiffness_matrix(self, k)
      class(element_t), intent(in) :: self
      real(wp), intent(out) :: k(2, 2)
      associate (unused => self)
      end associate
      k = 0.0_wp
   end subroutine el_stiffness_matrix

   !> Linearised stiffness k and damping c in the node angles and speeds
   !> (thl, thr): the torques are (tl, tr) = -k (thl, thr) - c (wl, wr) about
   !> the linearisation point, in the given state. inv_jl, inv_jr are the
   !> inverse inertias of the left and right node (0 when held or fixed), for
   !> laws whose damping scales with the mass behind the contact.
   !> Default: `stiffness_matrix` and no damping.
   pure subroutine el_linearise(self, state, inv_jl, inv_jr, k, c)
      class(element_t), intent(in) :: self
      type(lin_state_t), intent(in) :: state
      real(wp), intent(in) :: inv_jl, inv_jr
      real(wp), intent(out) :: k(2, 2), c(2, 2)
      associate (u1 => state, u2 => inv_jl, u3 => inv_jr)
      end associate
      call self%stiffness_matrix(k)
      c = 0.0_wp
   end subroutine el_linearise

   !> Elastic energy stored in the element.
   pure real(wp) function el_potential_energy(self, thl, thr) result(e)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      associate (u1 => self, u2 => thl, u3 => thr)
      end associate
      e = 0.0_wp
   end function el_potential_energy

   !> Power dissipated in the element.
   pure real(wp) function el_dissipation_power(self, thl, wl, thr, wr) result(p)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      associate (u1 => self, u2 => thl, u3 => wl, u4 => thr, u5 => wr)
      end associate
      p = 0.0_wp
   end function el_dissipation_power

   !> `torques` and `dissipation_power` at one state (the energy-tracking RHS
   !> asks both): elements that share work between the two override it, with
   !> results bit for bit those of the two calls. A type that overrides
   !> `torques` or `dissipation_power` of a parent that overrides this one
   !> overrides this one too (as the keyed joint does).
   pure subroutine el_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, p
      call self%torques(thl, wl, thr, wr, tl, tr)
      p = self%dissipation_power(thl, wl, thr, wr)
   end subroutine el_torques_dissipation

   !> Power fed in by the element itself (e.g. a mesh stiffness that varies with
   !> position does work (1/2) p^2 dk/dt on the loaded teeth).
   pure real(wp) function el_input_power(self, thl, wl, thr, wr) result(p)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      associate (u1 => self, u2 => thl, u3 => wl, u4 => thr, u5 => wr)
      end associate
      p = 0.0_wp
   end function el_input_power

   !> Partial derivatives of (tl, tr) with respect to (thl, wl, thr, wr), in the
   !> current mode. Default: central differences of `torques` (any element has
   !> one); elements with a closed form override it.
   pure subroutine el_torque_jacobian(self, thl, wl, thr, wr, jt)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      real(wp) :: x(4), xp(4), h, tlp, trp, tlm, trm
      integer :: j
      x = [thl, wl, thr, wr]
      do j = 1, 4
         h = 1.0e-6_wp*max(1.0_wp, abs(x(j)))
         xp = x; xp(j) = x(j) + h
         call self%torques(xp(1), xp(2), xp(3), xp(4), tlp, trp)
         xp(j) = x(j) - h
         call self%torques(xp(1), xp(2), xp(3), xp(4), tlm, trm)
         jt(1, j) = (tlp - tlm)/(2.0_wp*h)
         jt(2, j) = (trp - trm)/(2.0_wp*h)
      end do
   end subroutine el_torque_jacobian

   !> Number of switching functions (guards). A mode stays valid while all are >= 0.
   pure integer function el_n_guards(self) result(n)
      class(element_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 0
   end function el_n_guards

   !> Times where the element's own time function jumps or kinks (an engagement
   !> table's knots): the driver's stop times (default: none).
   pure subroutine el_breakpoints(self, bp)
      class(element_t), intent(in) :: self
      real(wp), allocatable, intent(out) :: bp(:)
      associate (unused => self)
      end associate
      allocate (bp(0))
   end subroutine el_breakpoints

   !> Evaluate the guards of the current mode.
   pure subroutine el_guards(self, thl, wl, thr, wr, g)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      associate (u1 => self, u2 => thl, u3 => wl, u4 => thr, u5 => wr)
      end associate
      g = 1.0_wp
   end subroutine el_guards

   !> Set the discrete mode consistent with the initial state.
   subroutine el_init_mode(self, thl, wl, thr, wr)
      class(element_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      associate (u1 => self, u2 => thl, u3 => wl, u4 => thr, u5 => wr)
      end associate
   end subroutine el_init_mode

   !> Set the discrete mode of a static preload (trainsim_preload): a clearance
   !> closed on `face` (+1 front, -1 rear, 0 open), other modes (mesh zones) from
   !> the angles. Default (no clearance): as `init_mode`.
   subroutine el_preload_mode(self, face, thl, wl, thr, wr)
      class(element_t), intent(inout) :: self
      integer, intent(in) :: face
      real(wp), intent(in) :: thl, wl, thr, wr
      associate (unused => face)
      end associate
      call self%init_mode(thl, wl, thr, wr)
   end subroutine el_preload_mode

   !> A guard crossed zero (fired(j) for guard j): change mode, report what happened.
   !> `nev` events are returned in ev(1:nev), nev <= max_update_events (trainsim_event).
   subroutine el_update_mode(self, t, thl, wl, thr, wr, fired, ev, nev)
      class(element_t), intent(inout) :: self
      real(wp), intent(in) :: t, thl, wl, thr, wr
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      associate (u1 => self, u2 => t, u3 => thl, u4 => wl, u5 => thr, u6 => wr, u7 => fired, u8 => ev)
      end associate
      nev = 0
   end subroutine el_update_mode

   !> Whether a clearance of this element is closed (always false if it has none).
   pure logical function el_in_contact(self) result(c)
      class(element_t), intent(in) :: self
      associate (unused => self)
      end associate
      c = .false.
   end function el_in_contact

   !> Recorded outputs: relative displacement, contact force, contact face, pairs.
   !> Default (elements without clearance): force = torque on the right node, always engaged.
   pure subroutine el_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      real(wp) :: tl
      call self%torques(thl, wl, thr, wr, tl, force)
      disp = self%displacement(thl, thr)
      contact = 1
      pairs = 0
   end subroutine el_status

   !> Whether the element is a linear spring-damper along a line with lever arms
   !> r1, r2 (optional capability, default no): delta = r1 thl - r2 thr,
   !> F = k delta + c delta', tl = -r1 F, tr = r2 F, potential k delta^2/2,
   !> dissipation c delta'^2, no guards, no input power, no loads read. The
   !> model then evaluates such elements from arrays without calls through the
   !> element (the hot path); it checks the claim against `torques` at the start
   !> of every run.
   pure subroutine el_linear_spring(self, linear, k, c, r1, r2)
      class(element_t), intent(in) :: self
      logical, intent(out) :: linear
      real(wp), intent(out) :: k, c, r1, r2
      associate (unused => self)
      end associate
      k = 0.0_wp; c = 0.0_wp; r1 = 1.0_wp; r2 = 1.0_wp
      linear = .false.
   end subroutine el_linear_spring

   !> The element's torques and guards in its current mode as a plain record
   !> (optional capability, D-35; default: declined, kind = hf_none and guards
   !> = hg_none). Valid until the element's mode or parameters change: the
   !> model asks again after every `init_mode`, `preload_mode` and
   !> `update_mode` it makes, and checks the record against the element's own
   !> `torques` and `guards` (bit for bit, at probe states) each time.
   pure subroutine el_hot_form(self, form)
      class(element_t), intent(in) :: self
      type(hot_form_t), intent(out) :: form
      associate (unused => self)
      end associate
      form%kind = hf_none
      form%guards = hg_none
   end subroutine el_hot_form

   !> Parameters as used (derived values included), for the output file.
   function el_params(self) result(p)
      class(element_t), intent(in) :: self
      type(param_list_t) :: p
      associate (unused => self)
      end associate
      allocate (p%names(0), p%values(0))
   end function el_params

   !> Largest |displacement| a physical run of this element can reach, given the
   !> largest torque the loads can drive through it (`load_torque`) and the
   !> inverse inertias of its nodes; beyond it the run has gone wrong (D-55).
   !> Default: no bound (huge).
   pure real(wp) function el_displacement_bound(self, load_torque, inv_jl, inv_jr) result(bound)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: load_torque, inv_jl, inv_jr
      associate (u1 => self, u2 => load_torque, u3 => inv_jl, u4 => inv_jr)
      end associate
      bound = huge(1.0_wp)
   end function el_displacement_bound

   !> Called in `configure` by a two-port element that may sit on a carrier (a gear's housing, D-73):
   !> the deck key `carrier` names its port 3 (resolved by the builder), and the port defaults evaluate
   !> it in the carrier's frame; `sense`: the right port's sense relative to the carrier (carrier_sense).
   subroutine accept_carrier(self, grp, sense)
      class(element_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      real(wp), intent(in) :: sense
      self%carrier_sense = sense
      self%port_keys = [string_t ::]
      if (grp%has('carrier')) self%port_keys = [string_t('carrier')]
   end subroutine accept_carrier

   !> Number of ports: 2 (left, right) and the further ones.
   pure integer function el_n_ports(self) result(n)
      class(element_t), intent(in) :: self
      n = 2
      if (allocated(self%more_ports)) n = 2 + size(self%more_ports)
   end function el_n_ports

   !> Node of port k (1 left, 2 right, then more_ports).
   pure integer function el_port(self, k) result(node)
      class(element_t), intent(in) :: self
      integer, intent(in) :: k
      select case (k)
      case (1); node = self%left
      case (2); node = self%right
      case default; node = self%more_ports(k - 2)
      end select
   end function el_port

   !> The two-port kinematics x = (thl, wl, thr, wr) the element's own
   !> procedures see at its ports' angles th and speeds w: as given for two
   !> ports, relative to the carrier (port 3) for an element on one:
   !> thl' = thl - thc, thr' = thr - s thc (s = carrier_sense), speeds alike.
   pure subroutine el_frame(self, th, w, x)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: th(:), w(:)
      real(wp), intent(out) :: x(4)
      if (size(th) < 3) then
         x = [th(1), w(1), th(2), w(2)]
      else
         x = [th(1) - th(3), w(1) - w(3), self%right_sign*th(2) - self%carrier_sense*th(3), &
              self%right_sign*w(2) - self%carrier_sense*w(3)]
      end if
   end subroutine el_frame

   !> Torques t(k) on every port k at the ports' angles th and speeds w.
   !> Default: `torques` in the frame (el_frame); on a carrier, the carrier
   !> takes the reaction of both, t3 = -(t1 + s t2) (the housing's torque
   !> balance, D-73; by virtual work on thl', thr').
   pure subroutine el_port_torques(self, th, w, t)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: th(:), w(:)
      real(wp), intent(out) :: t(:)
      real(wp) :: x(4)
      call self%frame(th, w, x)
      call self%torques(x(1), x(2), x(3), x(4), t(1), t(2))
      if (size(t) > 2) t(2:3) = [self%right_sign*t(2), -(t(1) + self%carrier_sense*t(2))]
   end subroutine el_port_torques

   !> `port_torques` and the power dissipated; below, each two-port procedure in the frame.
   pure subroutine el_port_torques_dissipation(self, th, w, t, p)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: th(:), w(:)
      real(wp), intent(out) :: t(:), p
      real(wp) :: x(4)
      call self%frame(th, w, x)
      call self%torques_dissipation(x(1), x(2), x(3), x(4), t(1), t(2), p)
      if (size(t) > 2) t(2:3) = [self%right_sign*t(2), -(t(1) + self%carrier_sense*t(2))]
   end subroutine el_port_torques_dissipation

   pure real(wp) function el_port_input_power(self, th, w) result(p)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: th(:), w(:)
      real(wp) :: x(4)
      call self%frame(th, w, x)
      p = self%input_power(x(1), x(2), x(3), x(4))
   end function el_port_input_power

   pure real(wp) function el_port_potential_energy(self, th) result(e)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: th(:)
      real(wp) :: x(4)
      call self%frame(th, th, x)
      e = self%potential_energy(x(1), x(3))
   end function el_port_potential_energy

   !> (a gear's zone follows the driver's angle relative to its carrier)
   pure subroutine el_port_guards(self, th, w, g)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: th(:), w(:)
      real(wp), intent(out) :: g(:)
      real(wp) :: x(4)
      call self%frame(th, w, x)
      call self%guards(x(1), x(2), x(3), x(4), g)
   end subroutine el_port_guards

   subroutine el_port_init_mode(self, th, w)
      class(element_t), intent(inout) :: self
      real(wp), intent(in) :: th(:), w(:)
      real(wp) :: x(4)
      call self%frame(th, w, x)
      call self%init_mode(x(1), x(2), x(3), x(4))
   end subroutine el_port_init_mode

   subroutine el_port_update_mode(self, t, th, w, fired, ev, nev)
      class(element_t), intent(inout) :: self
      real(wp), intent(in) :: t, th(:), w(:)
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      real(wp) :: x(4)
      call self%frame(th, w, x)
      call self%update_mode(t, x(1), x(2), x(3), x(4), fired, ev, nev)
   end subroutine el_port_update_mode

   !> (the mesh's own displacement and force)
   pure subroutine el_port_status(self, th, w, disp, force, contact, pairs)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: th(:), w(:)
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      real(wp) :: x(4)
      call self%frame(th, w, x)
      call self%status(x(1), x(2), x(3), x(4), disp, force, contact, pairs)
   end subroutine el_port_status

   !> `status` (two ports) or `port_status` at the angles and speeds of every
   !> node of the model (theta, omega): the recorder's one call for any element.
   pure subroutine el_status_at(self, theta, omega, disp, force, contact, pairs)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: theta(*), omega(*)   !< (assumed size: no descriptors, D-41)
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      real(wp) :: th(max_ports), w(max_ports)
      integer :: k, np
      np = self%n_ports()
      if (np == 2) then
         call self%status(theta(self%left), omega(self%left), theta(self%right), omega(self%right), disp, force, &
                          contact, pairs)
         return
      end if
      th(1:np) = [(theta(self%port(k)), k=1, np)]
      w(1:np) = [(omega(self%port(k)), k=1, np)]
      call self%port_status(th(1:np), w(1:np), disp, force, contact, pairs)
   end subroutine el_status_at

   !> Partial derivatives jt(i, 2k-1) = d t_i / d th_k, jt(i, 2k) = d t_i / d w_k
   !> over the np ports. Default: `torque_jacobian` in the frame, by the chain
   !> rule through el_frame's linear map (and t3 = -(t1 + s t2), t2 = a t2').
   pure subroutine el_port_jacobian(self, th, w, jt)
      class(element_t), intent(in) :: self
      real(wp), intent(in) :: th(:), w(:)
      real(wp), intent(out) :: jt(:, :)
      real(wp) :: x(4), j2(2, 4), s
      call self%frame(th, w, x)
      call self%torque_jacobian(x(1), x(2), x(3), x(4), j2)
      jt = 0.0_wp
      jt(1:2, 1:4) = j2
      if (size(th) < 3) return
      s = self%carrier_sense
      jt(1:2, 5) = -(j2(:, 1) + s*j2(:, 3))
      jt(1:2, 6) = -(j2(:, 2) + s*j2(:, 4))
      jt(1:2, 3:4) = self%right_sign*jt(1:2, 3:4)
      jt(3, :) = -(jt(1, :) + s*jt(2, :))
      jt(2, :) = self%right_sign*jt(2, :)
   end subroutine el_port_jacobian

   !> Linearised stiffness k and damping c over the np ports (as `linearise`,
   !> inv_j the ports' inverse inertias). Default: `linearise` in the frame,
   !> k = A^T k2 A with A the frame's map (thl', thr') = A (th_1 .. th_np).
   pure subroutine el_port_linearise(self, state, inv_j, k, c)
      class(element_t), intent(in) :: self
      type(lin_state_t), intent(in) :: state
      real(wp), intent(in) :: inv_j(:)
      real(wp), intent(out) :: k(:, :), c(:, :)
      real(wp) :: k2(2, 2), c2(2, 2), a(2, max_ports)
      integer :: np
      np = size(inv_j)
      call self%linearise(state, inv_j(1), inv_j(2), k2, c2)
      a = 0.0_wp
      a(1, 1) = 1.0_wp; a(2, 2) = self%right_sign
      if (np > 2) a(:, 3) = [-1.0_wp, -self%carrier_sense]
      k = matmul(transpose(a(:, 1:np)), matmul(k2, a(:, 1:np)))
      c = matmul(transpose(a(:, 1:np)), matmul(c2, a(:, 1:np)))
   end subroutine el_port_linearise
end module trainsim_element
