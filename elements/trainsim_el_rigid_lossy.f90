!> Rigid lossy gear pair (`rigid_lossy_gear`, D-97): the constraint of
!> `rigid_gear`, r1 wl = r2 wr (row (r1, -r2)), whose driven side receives eta
!> times the power the driving side puts in, the loss booked on the left
!> (driver) node as in the compliant `lossy_gear` (D-91). With lam the row's
!> torque and fs = -lam the mesh force (tl0 = -fs r1, tr0 = fs r2):
!>   forward  (left drives,  fs wl > 0): tl = tl0 / eta_f, tr = tr0  (c = 1/eta_f on port 1)
!>   backward (right drives, fs wl < 0): tl = eta_b tl0,   tr = tr0  (c = eta_b on port 1)
!>   held     (wl = wr = 0, rows (r1, -r2) and (1, 0)): while the left's
!>            holding torque lam_h lies between forward's and backward's,
!>            -(1/eta_f - 1) |fs| r1 <= s lam_h <= (1 - eta_b) |fs| r1 (s the force's sign)
!> The model's solve (trainsim_constraints) carries the scale c on the row's
!> torques, not on its kinematics; the loss, (c - 1) tl0 wl, is its cn%loss.
module trainsim_el_rigid_lossy
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_event, only: event_t, ev_stick, ev_slip_forward, ev_slip_backward, ev_flow_forward, ev_flow_backward
   use trainsim_param_list, only: param_list_t, make_param_list, guarded_ratio
   use trainsim_element, only: element_t
   use trainsim_el_rigid, only: rigid_gear_t
   use trainsim_el_lossy_gear, only: read_efficiencies, flow_forward, flow_backward, flow_hold_left
   implicit none
   private

   public :: rigid_lossy_gear_t, new_rigid_lossy_gear

   type, extends(rigid_gear_t) :: rigid_lossy_gear_t
      real(wp) :: eta_f = 1.0_wp, eta_b = 1.0_wp   !< forward (left drives), backward (right drives)
      integer :: flow = flow_hold_left
      real(wp) :: sig = 1.0_wp                     !< the mesh force's sign as the moving mode began
   contains
      procedure :: configure => rl_configure
      procedure :: n_guards => rl_n_guards
      procedure :: guards => rl_guards
      procedure :: init_mode => rl_init_mode
      procedure :: update_mode => rl_update_mode
      procedure :: status => rl_status
      procedure :: params => rl_params
      procedure :: set_flow => rl_set_flow
   end type rigid_lossy_gear_t

contains

   !> Registry factory: a new, unconfigured rigid lossy gear pair.
   subroutine new_rigid_lossy_gear(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (rigid_lossy_gear_t :: el)
   end subroutine new_rigid_lossy_gear

   !> Base radii as `rigid_gear`; one efficiency (`efficiency`) or the two
   !> (`efficiency_forward`, `efficiency_backward`), each in (0, 1].
   subroutine rl_configure(self, grp, units, err)
      class(rigid_lossy_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      call grp%get_real('rb_driver', self%r1, err); if (allocated(err)) return
      call grp%get_real('rb_driven', self%r2, err); if (allocated(err)) return
      if (.not. self%r1 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driver')//': error: base radius must be > 0, got '//str(self%r1), err_input)
         return
      else if (.not. self%r2 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driven')//': error: base radius must be > 0, got '//str(self%r2), err_input)
         return
      end if
      call read_efficiencies(grp, self%eta_f, self%eta_b, err); if (allocated(err)) return
      self%con%on = .true.
      self%con%rigid = .false.   ! (its held mode adds a row: not merged in the RK4 advice, D-86)
      call self%set_flow(flow_hold_left)
   end subroutine rl_configure

   pure integer function rl_n_guards(self) result(n)
      class(rigid_lossy_gear_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 2
   end function rl_n_guards

   !> Moving (forward, backward): guard 1 the left stopping, max(s wl, s al)
   !> with s = sg forward, -sg backward (as lossy_gear, D-91: al the left's
   !> acceleration), guard 2 the force passing zero, sg fs. Held: the band's
   !> edges, s lam_h + (1/eta_f - 1) |fs| r1 (driven on: forward) and
   !> (1 - eta_b) |fs| r1 - s lam_h (driven back: backward).
   pure subroutine rl_guards(self, thl, wl, thr, wr, g)
      class(rigid_lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      real(wp) :: fs, s
      associate (u1 => thl, u2 => thr, u3 => wr)
      end associate
      fs = -self%con%lam(1)
      select case (self%flow)
      case (flow_forward)
         g(1) = max(self%sig*wl, self%sig*self%con%acc(1))
         g(2) = self%sig*fs
      case (flow_backward)
         g(1) = max(-self%sig*wl, -self%sig*self%con%acc(1))
         g(2) = self%sig*fs
      case default
         s = sign(1.0_wp, fs)
         g(1) = s*self%con%lam(2) + (1.0_wp/self%eta_f - 1.0_wp)*abs(fs)*self%r1
         g(2) = (1.0_wp - self%eta_b)*abs(fs)*self%r1 - s*self%con%lam(2)
      end select
   end subroutine rl_guards

   !> At rest held (the model releases it at once if its torque lies outside
   !> the band); moving, forward along the speed (a force against it turns the
   !> flow at the first guard check).
   subroutine rl_init_mode(self, thl, wl, thr, wr)
      class(rigid_lossy_gear_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      associate (u1 => thl, u2 => thr, u3 => wr)
      end associate
      self%con%lam = 0.0_wp
      if (wl == 0.0_wp) then
         call self%set_flow(flow_hold_left)
      else
         self%sig = sign(1.0_wp, wl)
         call self%set_flow(flow_forward)
      end if
   end subroutine rl_init_mode

   !> Held: released forward (guard 1) or backward (guard 2), the left moving
   !> along d = -sign(lam_h), the force's sign d forward, -d backward (so a
   !> force of roundoff at the release cannot pick a wrong sign for long: the
   !> moving mode's own force turns it at once). Moving: the left stopped
   !> (guard 1): held; the force passed zero (guard 2): its sign and the flow
   !> turn, the motion goes on (the force's sign does not depend on the flow
   !> for a gear alone: lam = -G a / (G M^-1 H^T), whose denominator is > 0).
   subroutine rl_update_mode(self, t, thl, wl, thr, wr, fired, ev, nev)
      class(rigid_lossy_gear_t), intent(inout) :: self
      real(wp), intent(in) :: t, thl, wl, thr, wr
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      integer :: before, flow
      real(wp) :: fs, lam
      associate (u1 => t)
      end associate
      nev = 0
      before = self%flow
      flow = before
      fs = -self%con%lam(1)
      lam = self%con%lam(2)
      if (before == flow_hold_left) then              ! the left moves along -lam_h, d
         if (fired(1)) flow = flow_forward
         if (fired(2)) flow = flow_backward
         self%sig = -sign(1.0_wp, lam)                 ! forward: the force along d
         if (flow == flow_backward) self%sig = -self%sig
      else if (fired(1)) then
         flow = flow_hold_left
      else if (fired(2)) then                          ! the motion goes on, the flow turns
         self%sig = -self%sig
         flow = merge(flow_backward, flow_forward, before == flow_forward)
      end if
      call self%set_flow(flow)
      if (flow == before .or. size(ev) < 1) return
      nev = 1
      ev(1) = event_t()
      ev(1)%theta_left = thl; ev(1)%omega_left = wl; ev(1)%theta_right = thr; ev(1)%omega_right = wr
      ev(1)%displacement = self%r1*thl - self%r2*thr
      ev(1)%force = lam                                ! the holding torque (0 as it sticks)
      if (flow == flow_hold_left) then
         ev(1)%kind = ev_stick
      else if (before == flow_hold_left) then
         ev(1)%kind = merge(ev_slip_forward, ev_slip_backward, flow == flow_forward)
      else
         ev(1)%kind = merge(ev_flow_forward, ev_flow_backward, flow == flow_forward)
         ev(1)%force = fs
      end if
   end subroutine rl_update_mode

   !> The rows of a flow mode: the gear row (r1, -r2), its torque on the left
   !> scaled by 1/eta_f (forward) or eta_b (backward); held, lossless with the
   !> left held by a second row (1, 0).
   subroutine rl_set_flow(self, flow)
      class(rigid_lossy_gear_t), intent(inout) :: self
      integer, intent(in) :: flow
      self%flow = flow
      self%con%g(1, 1:2) = [self%r1, -self%r2]
      self%con%c(1, 1:2) = 1.0_wp
      self%con%want_acc = flow /= flow_hold_left     ! guard 1 reads the left's acceleration (D-91)
      select case (flow)
      case (flow_forward)
         self%con%n = 1
         self%con%c(1, 1) = 1.0_wp/self%eta_f
      case (flow_backward)
         self%con%n = 1
         self%con%c(1, 1) = self%eta_b
      case default
         self%con%n = 2
         self%con%g(2, 1:2) = [1.0_wp, 0.0_wp]
      end select
      if (self%con%n < 2) self%con%lam(2) = 0.0_wp
   end subroutine rl_set_flow

   !> As rigid_gear's (displacement r1 thl - r2 thr, the mesh force fs = -lam),
   !> with the flow in `pairs`: 1 forward, -1 backward, 2 held.
   pure subroutine rl_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(rigid_lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      call self%rigid_gear_t%status(thl, wl, thr, wr, disp, force, contact, pairs)
      pairs = self%flow
   end subroutine rl_status

   function rl_params(self) result(p)
      class(rigid_lossy_gear_t), intent(in) :: self
      type(param_list_t) :: p
      p = make_param_list([character(len=40) :: 'rb_driver', 'rb_driven', 'efficiency_forward', &
                           'efficiency_backward', 'gear_ratio'], &
                          [self%r1, self%r2, self%eta_f, self%eta_b, guarded_ratio(self%r2, self%r1)])
   end function rl_params
end module trainsim_el_rigid_lossy
