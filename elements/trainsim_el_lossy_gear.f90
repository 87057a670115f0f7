!> Lossy gear pair: a gear mesh through the shared clearance model (stiffness,
!> optional backlash, contact law) whose driven side receives eta times the
!> power the driving side puts in. Which side drives follows the power at the
!> left (driver) node, the side that carries the loss (a discrete mode with
!> guards, docs/elements.md "lossy_gear", D-91): with fs the signed mesh force
!> (+ on the front face) and the lossless torques tl0 = -fs r1, tr0 = fs r2,
!>   forward  (left drives,  fs wl > 0): tl = tl0 / eta_f, tr = tr0
!>   backward (right drives, fs wl < 0): tl = eta_b tl0,   tr = tr0
!>   neutral  (faces open: no force):    tl = tl0 = 0,     tr = tr0 = 0
!>   held left (wl = 0, row (1, 0), D-81): tl = tl0 + lam, tr = tr0, while the
!>            left's mesh torque lies between forward's and backward's:
!>            -(1/eta_f - 1) fs r1 <= s lam <= (1 - eta_b) fs r1 (s the force's sign)
!> so the mesh loss, (1/eta_f - 1) fs r1 wl forward and -(1 - eta_b) fs r1 wl
!> backward, is never negative, and the right side's torque is tr0 in every
!> mode (a change of flow never jumps it). A left side at rest is held while
!> the losses exceed the torque that would drive it on; the self-locking worm
!> (eta_b <= 0) is held back-driven whatever the wheel's torque. The worm gear
!> (trainsim_el_worm_gear) is this element with its efficiencies from the lead
!> angle and friction coefficient.
module trainsim_el_lossy_gear
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_event, only: event_t, ev_stick, ev_slip_forward, ev_slip_backward, ev_flow_forward, ev_flow_backward
   use trainsim_param_list, only: param_list_t, make_param_list, guarded_ratio
   use trainsim_clearance_element, only: clearance_element_t, clearance_hot_form
   use trainsim_element, only: element_t, hot_form_t, hf_none, hg_none
   implicit none
   private

   public :: lossy_gear_t, new_lossy_gear, flow_forward, flow_backward, flow_neutral, &
             read_mesh, get_efficiency, flow_hold_left, read_efficiencies

   !> Power-flow modes.
   integer, parameter :: flow_neutral = 0, flow_forward = 1, flow_backward = -1, flow_hold_left = 2

   type, extends(clearance_element_t) :: lossy_gear_t
      real(wp) :: eta_f = 1.0_wp, eta_b = 1.0_wp   !< forward (left drives), backward (right drives)
      integer :: flow = flow_neutral
      !> sign of the mesh force as the flow mode began (its face's if 0; 0 while
      !> open); the guards follow the force and the left's speed apart, so the
      !> left stopping (held) is told from the force reaching zero (re-chosen)
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
      call read_efficiencies(grp, self%eta_f, self%eta_b, err); if (allocated(err)) return
      call read_mesh(self, grp, units, err)
   end subroutine lossy_configure

   !> One efficiency (`efficiency`, both ways) or the two (`efficiency_forward`,
   !> `efficiency_backward`), each in (0, 1] (also `rigid_lossy_gear`'s keys).
   subroutine read_efficiencies(grp, eta_f, eta_b, err)
      type(deck_group_t), intent(inout) :: grp
      real(wp), intent(out) :: eta_f, eta_b
      type(error_t), allocatable, intent(out) :: err
      if (grp%has('efficiency')) then
         if (grp%holds('efficiency_forward') .or. grp%holds('efficiency_backward')) then
            call fatal_error(err, grp%where('efficiency')//': error: give efficiency, or efficiency_forward and '// &
                             'efficiency_backward, not both', err_input)
            return
         end if
         call get_efficiency(grp, 'efficiency', eta_f, .false., err); if (allocated(err)) return
         eta_b = eta_f
      else
         call get_efficiency(grp, 'efficiency_forward', eta_f, .false., err); if (allocated(err)) return
         call get_efficiency(grp, 'efficiency_backward', eta_b, .false., err); if (allocated(err)) return
      end if
   end subroutine read_efficiencies

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
      case (flow_forward); tl = tl/self%eta_f
      case (flow_backward); tl = self%eta_b*tl
      end select
   end subroutine lossy_torques

   !> The mesh loss at signed force fs (>= 0 in a mode whose guards hold).
   pure real(wp) function mesh_loss(self, fs, wl) result(p)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: fs, wl
      select case (self%flow)
      case (flow_forward); p = (1.0_wp/self%eta_f - 1.0_wp)*fs*self%cl%r1*wl
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
          self%mesh_loss(self%cl%contact_force(c, thl, wl, thr, wr), wl)
   end function lossy_dissipation

   pure subroutine lossy_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, p
      call self%torques(thl, wl, thr, wr, tl, tr)
      p = self%dissipation_power(thl, wl, thr, wr)
   end subroutine lossy_torques_dissipation

   !> The law's Jacobian with the left side's row scaled as its torque.
   pure subroutine lossy_jacobian(self, thl, wl, thr, wr, jt)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      call self%cl%torque_jacobian(self%factor(thl), 0.0_wp, thl, wl, thr, wr, jt)
      select case (self%flow)
      case (flow_forward); jt(1, :) = jt(1, :)/self%eta_f
      case (flow_backward); jt(1, :) = self%eta_b*jt(1, :)
      end select
   end subroutine lossy_jacobian

   pure integer function lossy_n_guards(self) result(n)
      class(lossy_gear_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 4   ! (the model's buffers take at most 4 guards an element)
   end function lossy_n_guards

   !> Guards 1-2 the faces; 3-4 the power flow (all 1 while the faces are open),
   !> with sg the force's sign as the mode began: forward moving(sg, wl), sg fs;
   !> backward moving(-sg, wl), sg fs; held left sg lam + (1/eta_f - 1) sg fs
   !> r1 (driven on: forward), (1 - eta_b) sg fs r1 - sg lam (driven back:
   !> backward). moving(s, w, a) = max(s w, s a) with a the left's acceleration
   !> (con%acc): the left stops where its speed has reached zero with its
   !> acceleration against s, not while it starts from rest (D-91). Guard 3 of
   !> forward and backward is the left stopping (it is held); guard 4 the force
   !> passing zero (the flow re-chosen from the left's speed).
   pure subroutine lossy_guards(self, thl, wl, thr, wr, g)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      real(wp) :: fs, sg
      call self%cl%guards(thl, thr, g(1:2))
      if (self%cl%law%clip_guard()) call self%cl%tension_guard(self%factor(thl), thl, wl, thr, wr, g(1:2))   ! (D-136)
      g(3:4) = 1.0_wp
      if (self%cl%mode == 0) return   ! open: no force, no flow (the flow is chosen as a face closes)
      fs = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)
      sg = self%sig
      select case (self%flow)
      case (flow_forward); g(3) = moving(sg, wl, self%con%acc(1)); g(4) = sg*fs
      case (flow_backward); g(3) = moving(-sg, wl, self%con%acc(1)); g(4) = sg*fs
      case (flow_hold_left)                      ! the holding torque within the friction
         g(3) = sg*self%con%lam(1) + (1.0_wp/self%eta_f - 1.0_wp)*sg*fs*self%cl%r1
         g(4) = (1.0_wp - self%eta_b)*sg*fs*self%cl%r1 - sg*self%con%lam(1)
      end select
   end subroutine lossy_guards

   !> A side moving (or starting to move) in direction s: >= 0 while its speed w
   !> or its acceleration a points along s; below zero once both point against
   !> it. A side released from rest starts with w = 0 and a along s, so the
   !> integrator's error in w (which may have either sign) cannot stop it again.
   pure real(wp) function moving(s, w, a) result(g)
      real(wp), intent(in) :: s, w, a
      g = max(s*w, s*a)
   end function moving

   subroutine lossy_init_mode(self, thl, wl, thr, wr)
      class(lossy_gear_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: fs
      call self%cl%init(thl, wl, thr, wr, self%factor(thl))
      fs = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)
      self%con%lam = 0.0_wp
      call self%set_flow(closed_flow(self, fs, wl), fs)
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
      integer :: before, flow, face
      real(wp) :: lam
      associate (u1 => t)
      end associate
      nev = 0
      before = self%flow
      face = self%cl%mode
      call self%cl%update(wl, wr, fired(1:2), ev, nev)
      if (self%cl%b == 0.0_wp .and. face /= 0 .and. self%cl%mode == 0) then
         ! no backlash: the faces coincide, the one separating hands over to the
         ! other at once (an open mode of zero width would start both its face
         ! guards at 0, where an integrator's root finding cannot see them leave)
         call self%cl%update(wl, wr, [face == -1, face == 1], ev, nev)
      end if
      fs = self%cl%contact_force(self%factor(thl), thl, wl, thr, wr)
      flow = next_flow(self, before, fired, fs, wl)
      lam = self%con%lam(1)
      call self%set_flow(flow, fs)
      if (flow == before .or. nev >= size(ev) .or. flow == flow_neutral) return   ! (opened: the face's event)
      if (before == flow_neutral .and. .not. held(flow)) return                  ! (closed: the face's event)
      nev = nev + 1                                    ! sticking, its end and a turn of the flow are events
      ev(nev) = event_t()
      ev(nev)%theta_left = thl; ev(nev)%omega_left = wl; ev(nev)%theta_right = thr; ev(nev)%omega_right = wr
      ev(nev)%displacement = self%cl%delta(thl, thr)
      ev(nev)%force = lam                              ! the holding torque (0 as it sticks)
      if (held(flow)) then
         ev(nev)%kind = ev_stick
      else if (held(before)) then
         ev(nev)%kind = merge(ev_slip_forward, ev_slip_backward, flow == flow_forward)
      else                                             ! forward <-> backward: the force passed zero
         ev(nev)%kind = merge(ev_flow_forward, ev_flow_backward, flow == flow_forward)
         ev(nev)%force = fs
      end if
   end subroutine lossy_update_mode

   !> The flow after guards `fired` (3-4; faces 1-2 already applied) at force fs.
   pure integer function next_flow(self, before, fired, fs, wl) result(flow)
      class(lossy_gear_t), intent(in) :: self
      integer, intent(in) :: before
      logical, intent(in) :: fired(:)
      real(wp), intent(in) :: fs, wl
      flow = before
      if (self%cl%mode == 0) then
         flow = flow_neutral                           ! open: no force, nothing held
      else if (before == flow_hold_left) then
         if (fired(3)) flow = flow_forward             ! driven on past the forward losses
         if (fired(4)) flow = flow_backward            ! driven back past the backward losses
      else if (before /= flow_neutral .and. fired(3)) then
         flow = flow_hold_left                         ! the left stops under load
      else if (before == flow_neutral .or. fired(4) .or. any(fired(1:2))) then
         flow = closed_flow(self, fs, wl)              ! a face closed, or the force passed zero
      end if
   end function next_flow

   !> The flow of a closed mesh at force fs (its face's sign if fs = 0): the
   !> left at rest held (the model lets it go at once if its torque lies outside
   !> the band, constraints_settle, as friction sticks at equal speeds), else
   !> forward where it moves along the force, backward against it.
   pure integer function closed_flow(self, fs, wl) result(flow)
      class(lossy_gear_t), intent(in) :: self
      real(wp), intent(in) :: fs, wl
      real(wp) :: s
      if (self%cl%mode == 0) then
         flow = flow_neutral
         return
      end if
      s = real(self%cl%mode, wp)
      if (fs /= 0.0_wp) s = sign(1.0_wp, fs)
      if (wl == 0.0_wp) then
         flow = flow_hold_left
      else if (s*wl > 0.0_wp) then
         flow = flow_forward
      else
         flow = flow_backward
      end if
   end function closed_flow

   pure logical function held(flow)
      integer, intent(in) :: flow
      held = flow == flow_hold_left
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
      self%sig = real(self%cl%mode, wp)            ! the face's sign where the force is 0
      if (fs /= 0.0_wp .and. self%cl%mode /= 0) self%sig = sign(1.0_wp, fs)
      self%con%n = merge(1, 0, held(flow))
      self%con%g(1, 1:2) = [1.0_wp, 0.0_wp]
      if (.not. held(flow)) self%con%lam = 0.0_wp
      self%con%want_acc = self%cl%mode /= 0 .and. .not. held(flow)   ! the guards read acc (D-91)
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
