!> Lossy gear pair: a gear mesh through the shared clearance model (stiffness,
!> optional backlash, contact law) whose driven side receives eta times the
!> power the driving side puts in. Which side drives follows the power flow
!> (a discrete mode with guards, docs/elements.md "lossy_gear"): with fs the
!> signed mesh force (+ on the front face) and the lossless torques
!> tl0 = -fs r1, tr0 = fs r2,
!>   forward  (left drives,  fs wr > 0): tl = tl0,         tr = eta_f tr0
!>   backward (right drives, fs wl < 0): tl = eta_b tl0,   tr = tr0
!>   neutral  (otherwise: no force, or speeds of opposite sign): tl = tl0, tr = tr0
!>   held left  (wl = 0, row (1, 0), D-81): tl = tl0 + lam, tr = tr0, while the
!>            left's mesh torque lies between backward's and neutral's:
!>            0 <= lam fs <= (1 - eta_b) fs^2 r1
!>   held right (wr = 0, row (0, 1)): tl = tl0, tr = tr0 + lam, while the right's
!>            lies between forward's and neutral's: 0 <= -lam fs <= (1 - eta_f) fs^2 r2
!> (a side stops where neither adjacent mode can continue: the losses exceed
!> the torque that would drive it on; the self-locking worm, eta_b <= 0, is
!> held back-driven whatever the wheel's torque) so the mesh loss, (1 - eta_f) fs r2 wr forward and -(1 - eta_b) fs r1 wl
!> backward, is never negative. The worm gear (trainsim_el_worm_gear) is this
!> element with its efficiencies from the lead angle and friction coefficient.
module trainsim_el_lossy_gear
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_event, only: event_t, ev_stick, ev_slip_forward, ev_slip_backward
   use trainsim_param_list, only: param_list_t, make_param_list, guarded_ratio
   use trainsim_clearance_element, only: clearance_element_t, clearance_hot_form
   use trainsim_element, only: element_t, hot_form_t, hf_none, hg_none
   implicit none
   private

   public :: lossy_gear_t, new_lossy_gear, flow_forward, flow_backward, flow_neutral, choose_flow, &
             read_mesh, get_efficiency, flow_hold_left, flow_hold_right

   !> Power-flow modes.
   integer, parameter :: flow_neutral = 0, flow_forward = 1, flow_backward = -1, flow_hold_left = 2, &
                         flow_hold_right = 3

   type, extends(clearance_element_t) :: lossy_gear_t
      real(wp) :: eta_f = 1.0_wp, eta_b = 1.0_wp   !< forward (left drives), backward (right drives)
      integer :: flow = flow_neutral
      !> sign of the mesh force as the flow mode began (0: no force then); the
      !> guards follow the force and each speed apart, so a speed reaching zero
      !> (a side stops: held) is told from the force reaching zero (re-chosen)
      real(wp) :: sig = 0.0_wp
   contains
      procedure :: configure => lossy_configure
      procedure :: torques => lossy_torques
      procedure :: dissipation_power => lossy_dissipation
      procedure :: torques_dissipation => lossy_torques_dissipation
      procedure :: torque_jacobian => lossy_jacobian
      procedure :: n_guards => lossy_n_guards
      procedure :: guards => lossy_guards
      procedure :: init_mode => lossy_init_mode
      procedure :: update_mode => lossy_update_mode
      procedure :: hot_form => lossy_hot_form
      procedure :: params => lossy_params
      procedure :: status => lossy_status
      procedure :: mesh_loss
      procedure :: self_locking
      procedure :: set_flow
   end type lossy_gear_t

contains

   !> Registry factory: a new, unconfigured lossy gear pair.
   subroutine new_lossy_gear(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (lossy_gear_t :: el)
   end subroutine new_lossy_gear

   !> The power-flow mode at a = fs wr, b = fs wl: forward if a > 0, backward if
   !> b < 0 (both: the previous one, or forward), else neutral. Its guards are
   !> then >= 0 at this state (forward a, backward -b, neutral -a and b).
   pure integer function choose_flow(a, b, prev) result(flow)
      real(wp), intent(in) :: a, b
      integer, intent(in) :: prev
      if (a > 0.0_wp .and. b < 0.0_wp) then
         flow = flow_forward
         if (prev == flow_backward) flow = flow_backward
      else if (a > 0.0_wp) then
         flow = flow_forward
      else if (b < 0.0_wp) then
         flow = flow_backward
      else
         flow = flow_neutral
      end if
   end function choose_flow

   !> The mesh keys both gears share: stiffness (force/length along the line),
   !> backlash (total, length; default 0) and the contact law (default linear,
   !> whose contact_damping is then required).
   subroutine read_mesh(self, grp, units, err)
      class(lossy_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: backlash
      call grp%get_real('stiffness', self%cl%law%k, err); if (allocated(err)) return
      call grp%get_real('backlash', backlash, err, default=0.0_wp); if (allocated(err)) return
      if (.not. self%cl%law%k > 0.0_wp) then
         call fatal_error(err, grp%where('stiffness')//': error: mesh stiffness must be > 0, got '// &
                          str(self%cl%law%k), err_input)
         return
      end if
      if (.not. backlash >= 0.0_wp) then
         call fatal_error(err, grp%where('backlash')//': error: backlash must be >= 0, got '//str(backlash), err_input)
         return
      end if
      self%cl%b = 0.5_wp*backlash
      self%con%on = .true.   ! a side held where the losses exceed the driving torque (D-81)
      call self%cl%law%configure(grp, units, 1.0_wp, 'linear', err)
   end subroutine read_mesh

   !> One efficiency (`efficiency`) or the two (`efficiency_forward`,
   !> `efficiency_backward`), each in (0, 1].
   subroutine lossy_configure(self, grp, units, err)
      class(lossy_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      call grp%get_real('rb_driver', self%cl%r1, err); if (allocated(err)) return
      call grp%get_real('rb_driven', self%cl%r2, err); if (allocated(err)) return
      if (.not. self%cl%r1 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driver')//': error: base radius must be > 0, got '//str(self%cl%r1), &
                          err_input)
         return
      else if (.not. self%cl%r2 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driven')//': error: base radius must be > 0, got '//str(self%cl%r2), &
                          err_input)
         return
      end if
      if (grp%has('efficiency')) then
         if (grp%holds('efficiency_forward') .or. grp%holds('efficiency_backward')) then
            call fatal_error(err, grp%where('efficiency')//': error: give efficiency, or efficiency_forward and '// &
                             'efficiency_backward, not both', err_input)
            return
         end if
         call get_efficiency(grp, 'efficiency', self%eta_f, .false., err); if (allocated(err)) return
         self%eta_b = self%eta_f
      else
         call get_efficiency(grp, 'efficiency_forward', self%eta_f, .false., err); if (allocated(err)) return
         call get_efficiency(grp, 'efficiency_backward', self%eta_b, .false., err); if (allocated(err)) return
      end if
      call read_mesh(self, grp, units, err)
   end subroutine lossy_configure

   !> An efficiency key: in (0, 1], or in (-1, 1] with `may_lock` (a backward
   !> efficiency <= 0 is a self-locking pair).
   subroutine get_efficiency(grp, key, eta, may_lock, err)
      type(deck_group_t), intent(inout) :: grp
      character(len=*), intent(in) :: key
      real(wp), intent(out) :: eta
      logical, intent(in) :: may_lock
      type(error_t), allocatable, intent(out) :: err
      call grp%get_real(key, eta, err); if (allocated(err)) return
      if (may_lock) then
         if (.not. (eta > -1.0_wp .and. eta <= 1.0_wp)) call fatal_error(err, grp%where(key)//': error: '//key// &
            ' must be in (-1, 1] (<= 0: self-locking), got '//str(eta), err_input)
      else if (.not. (eta > 0.0_wp .and. eta <= 1.0_wp)) then
         call fatal_error(err, grp%where(key)//': error: '//key//' must be in (0, 1], got '//str(eta), err_input)
      end if
   end subroutine get_efficiency

   pure subroutine lossy_torques(self, thl, wl, thr, wr, tl, tr)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      real(wp) :: fs
      fs = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)
      tl = -fs*self%cl%r1
      tr = fs*self%cl%r2
      select case (self%flow)
      case (flow_forward); tr = self%eta_f*tr
      case (flow_backward); tl = self%eta_b*tl
      end select
   end subroutine lossy_torques

   !> The mesh loss at signed force fs (>= 0 in a mode whose guards hold).
   pure real(wp) function mesh_loss(self, fs, wl, wr) result(p)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: fs, wl, wr
      select case (self%flow)
      case (flow_forward); p = (1.0_wp - self%eta_f)*fs*self%cl%r2*wr
      case (flow_backward); p = -(1.0_wp - self%eta_b)*fs*self%cl%r1*wl
      case default; p = 0.0_wp
      end select
   end function mesh_loss

   !> The contact law's dissipation and the mesh loss.
   pure real(wp) function lossy_dissipation(self, thl, wl, thr, wr) result(p)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: c
      c = self%factor(thl)
      p = self%cl%dissipation(c, thl, wl, thr, wr) + &
          self%mesh_loss(self%cl%contact_force(c, thl, wl, thr, wr), wl, wr)
   end function lossy_dissipation

   pure subroutine lossy_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, p
      call self%torques(thl, wl, thr, wr, tl, tr)
      p = self%dissipation_power(thl, wl, thr, wr)
   end subroutine lossy_torques_dissipation

   !> The law's Jacobian with the driven side's row scaled by its efficiency.
   pure subroutine lossy_jacobian(self, thl, wl, thr, wr, jt)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      call self%cl%torque_jacobian(self%factor(thl), 0.0_wp, thl, wl, thr, wr, jt)
      select case (self%flow)
      case (flow_forward); jt(2, :) = self%eta_f*jt(2, :)
      case (flow_backward); jt(1, :) = self%eta_b*jt(1, :)
      end select
   end subroutine lossy_jacobian

   pure integer function lossy_n_guards(self) result(n)
      class(lossy_gear_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 4   ! (the model's buffers take at most 4 guards an element)
   end function lossy_n_guards

   !> Guards 1-2 the faces; 3-4 the power flow, with sg the force's sign as the
   !> mode began: forward sg wr, sg fs (self-locking: min(sg fs, sg wl)); backward
   !> -sg wl, sg fs; neutral -sg wr, min(sg wl, sg fs) (no force as it began:
   !> -fs wr, fs wl); held left lam fs, (1 - eta_b) fs^2 r1 - lam fs; held right
   !> -lam fs, (1 - eta_f) fs^2 r2 + lam fs (all 1 while the faces are open).
   !> Guard 3 of forward, backward and neutral is a side stopping (it is held);
   !> guard 4 the force passing zero (the flow re-chosen), or the self-locking
   !> worm or neutral's left side stopping, told apart at the event (next_flow).
   pure subroutine lossy_guards(self, thl, wl, thr, wr, g)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      real(wp) :: fs, sg
      call self%cl%guards(thl, thr, g(1:2))
      g(3:4) = 1.0_wp
      if (self%cl%mode == 0) return   ! open: no force, no flow (the flow is chosen as a face closes)
      fs = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)
      sg = self%sig
      select case (self%flow)
      case (flow_forward)
         g(3) = sg*wr; g(4) = sg*fs
         if (self%self_locking()) g(4) = min(sg*fs, sg*wl)   ! the worm stops: it is held
      case (flow_backward); g(3) = -sg*wl; g(4) = sg*fs
      case (flow_hold_left)                      ! the holding torque within the friction
         g(3) = self%con%lam(1)*fs
         g(4) = (1.0_wp - self%eta_b)*fs*fs*self%cl%r1 - self%con%lam(1)*fs
      case (flow_hold_right)
         g(3) = -self%con%lam(1)*fs
         g(4) = (1.0_wp - self%eta_f)*fs*fs*self%cl%r2 + self%con%lam(1)*fs
      case default
         if (sg /= 0.0_wp) then
            g(3) = -sg*wr; g(4) = min(sg*wl, sg*fs)
         else
            g(3) = -fs*wr; g(4) = fs*wl
         end if
      end select
   end subroutine lossy_guards

   subroutine lossy_init_mode(self, thl, wl, thr, wr)
      class(lossy_gear_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: fs
      call self%cl%init(thl, wl, thr, wr)
      fs = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)
      call self%set_flow(choose_flow(fs*wr, fs*wl, flow_neutral), fs)
      self%con%lam = 0.0_wp
      if (self%self_locking() .and. self%cl%mode /= 0 .and. wl == 0.0_wp) call self%set_flow(flow_hold_left, fs)
   end subroutine lossy_init_mode

   !> A face or the power flow changed: the clearance first, then the flow from
   !> the force in the new contact state (no event of its own: the flow is in
   !> the recorded `pairs` column, see `lossy_status`).
   subroutine lossy_update_mode(self, t, thl, wl, thr, wr, fired, ev, nev)
      class(lossy_gear_t), intent(inout) :: self
      real(wp), intent(in) :: t, thl, wl, thr, wr
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      real(wp) :: fs
      integer :: before, flow
      real(wp) :: lam
      associate (u1 => t)
      end associate
      nev = 0
      before = self%flow
      call self%cl%update(wl, wr, fired(1:2), ev, nev)
      fs = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)
      flow = next_flow(self, before, fired, fs, wl, wr)
      lam = self%con%lam(1)
      call self%set_flow(flow, fs)
      if (flow == before .or. nev >= size(ev)) return
      if (.not. (held(flow) .or. held(before))) return
      nev = nev + 1                                    ! sticking and its end are events
      ev(nev) = event_t()
      ev(nev)%theta_left = thl; ev(nev)%omega_left = wl; ev(nev)%theta_right = thr; ev(nev)%omega_right = wr
      ev(nev)%displacement = self%cl%delta(thl, thr)
      ev(nev)%force = lam                              ! the holding torque (0 as it sticks)
      if (held(flow)) then
         ev(nev)%kind = ev_stick
      else if (flow == flow_forward) then
         ev(nev)%kind = ev_slip_forward
      else
         ev(nev)%kind = ev_slip_backward
      end if
   end subroutine lossy_update_mode

   !> The flow after guards `fired` (3-4; faces 1-2 already applied) at force fs.
   pure integer function next_flow(self, before, fired, fs, wl, wr) result(flow)
      class(lossy_gear_t), intent(in) :: self
      integer, intent(in) :: before
      logical, intent(in) :: fired(:)
      real(wp), intent(in) :: fs, wl, wr
      logical :: left_stopped
      ! guard 4 of a self-locking forward, or of neutral, is min(sg fs, sg wl): the
      ! smaller at the event is the one that reached zero
      left_stopped = self%sig /= 0.0_wp .and. self%sig*wl <= self%sig*fs .and. &
                     (before == flow_neutral .or. (before == flow_forward .and. self%self_locking()))
      flow = before
      if (self%cl%mode == 0) then
         flow = flow_neutral                           ! open: no force, nothing held
      else if (before == flow_hold_left .and. (fired(3) .or. fired(4))) then
         flow = merge(flow_forward, flow_backward, fired(3))   ! the left driven on / back
      else if (before == flow_hold_right .and. (fired(3) .or. fired(4))) then
         flow = merge(flow_neutral, flow_forward, fired(3))    ! pulled back past lossless / driven on
      else if (held(before)) then
         continue
      else if ((before == flow_forward .and. fired(3)) .or. (before == flow_neutral .and. fired(3) .and. &
                                                              self%sig /= 0.0_wp)) then
         flow = flow_hold_right                        ! the right stops under load
      else if ((before == flow_backward .and. fired(3)) .or. (fired(4) .and. left_stopped)) then
         flow = flow_hold_left                         ! the left stops under load
      else
         flow = choose_flow(fs*wr, fs*wl, before)      ! the force changed sign, a face, or no force before
      end if
      ! self-locking, the worm turning back while the wheel still turns on: the
      ! mesh brakes the worm (forward's guard fs wl would be negative at once)
      if (self%self_locking() .and. flow == flow_forward .and. fs*wl < 0.0_wp) flow = flow_backward
   end function next_flow

   pure logical function held(flow)
      integer, intent(in) :: flow
      held = flow == flow_hold_left .or. flow == flow_hold_right
   end function held

   !> A self-locking pair (eta_b <= 0): back-driven, the mesh holds the driver.
   pure logical function self_locking(self)
      class(lossy_gear_t), intent(in) :: self
      self_locking = self%eta_b <= 0.0_wp
   end function self_locking

   !> The flow mode and, with it, the constraint row in force (D-81): held
   !> left (1, 0), held right (0, 1), else none.
   subroutine set_flow(self, flow, fs)
      class(lossy_gear_t), intent(inout) :: self
      integer, intent(in) :: flow
      real(wp), intent(in) :: fs   !< the mesh force now
      self%flow = flow
      self%sig = 0.0_wp
      if (fs /= 0.0_wp) self%sig = sign(1.0_wp, fs)
      self%con%n = merge(1, 0, held(flow))
      self%con%g(1, 1:2) = merge([1.0_wp, 0.0_wp], [0.0_wp, 1.0_wp], flow /= flow_hold_right)
      if (.not. held(flow)) self%con%lam = 0.0_wp
   end subroutine set_flow

   !> Declined (torques and guards through the element): the efficiency scales
   !> one side and the flow guards read the force.
   pure subroutine lossy_hot_form(self, form)
      class(lossy_gear_t), intent(in) :: self
      type(hot_form_t), intent(out) :: form
      call clearance_hot_form(self, form)
      form%kind = hf_none
      form%guards = hg_none
   end subroutine lossy_hot_form

   !> As the clearance elements (displacement, signed force, face), with the
   !> power flow in `pairs`: 1 forward, -1 backward, 0 neutral.
   pure subroutine lossy_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      disp = self%cl%delta(thl, thr)
      force = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)
      contact = self%cl%mode
      pairs = self%flow
   end subroutine lossy_status

   function lossy_params(self) result(p)
      class(lossy_gear_t), intent(in) :: self
      type(param_list_t) :: p
      p = make_param_list([character(len=40) :: 'rb_driver', 'rb_driven', 'stiffness', 'backlash', &
                           'efficiency_forward', 'efficiency_backward', 'gear_ratio'], &
                          [self%cl%r1, self%cl%r2, self%cl%law%k, 2.0_wp*self%cl%b, self%eta_f, self%eta_b, &
                           guarded_ratio(self%cl%r2, self%cl%r1)])
   end function lossy_params
end module trainsim_el_lossy_gear
