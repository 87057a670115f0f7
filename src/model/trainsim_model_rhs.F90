!> The model's right-hand side: the general path (every node and element in
!> order, the linear springs and clearances with the kernels' row arithmetic,
!> any other through its procedures), a simple model's stage and step end (the
!> family kernels of trainsim_model_kernels), a part of the train, the loads.
!> Each `module procedure` here is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_rhs
   use trainsim_model_families, only: nk_other, nk_plain, nk_held, lf_open
   use trainsim_model_families, only: spring_ni, spring_nr, contact_ni, contact_nr, free_ni, free_nr, held_ni, held_nr
   use trainsim_model_families, only: chain_ni, chain_nr, ch_spring, ch_damper, ch_open, ch_ys, ch_unit
   use trainsim_model_kernels, only: spring, hot_torques
   use trainsim_ports, only: port_torques_at, general_torques
   use trainsim_element, only: max_ports
   use trainsim_kinds, only: i8
   implicit none

contains

   module procedure model_rhs
      if (self%simple) then
         call rhs_simple_ws(self, t, y, dydt, .false.)
      else
         call rhs_fast(self, t, y, dydt)
      end if
   end procedure model_rhs

   ! (the step-end kernels' arguments but the element powers, and the
   ! workspace's and the block column's, spelled once: D-113)
#define SE_HEAD self%fam, self%fam%iw, self%fam%rw, self%elements, t, y, dydt, self%el_torque, self%theta, self%omega
#define SE_WS self%torque, self%el_disp, self%el_force
#define SE_COL b%disp(:, c), b%force(:, c), b%torque(:, c), b%omega(:, c)
#define SE_STORED self%el_pe, self%ws_energy, self%ws_stored, self%ws_elastic

   module procedure model_rhs_step_end
      integer :: c
      if (self%run%track_energy .and. self%blk%col > 0) then
         if (self%simple .and. .not. self%blk%ws) then
            ! (first: before the energy-off kernel's set-up, D-169)
            call column_energy_end(self, t, y, dydt)   ! (a procedure of its own, D-160)
            return
         end if
      end if
      if (.not. self%simple) then
         call rhs_fast(self, t, y, dydt)
         return
      else if (self%blk%col == 0 .or. self%blk%ws) then
         ! straight to the kernel (every step of a block, D-38): no second layer
         ! of descriptors
         call rhs_simple_ws(self, t, y, dydt, .true.)
         return
      end if
      ! a block's step before its last: its column only, not the workspace
      ! (D-120), here rather than in rhs_simple_ws: a procedure of one kernel
      ! variant, not six (D-124)
      call ws_mark(self, t, .true., .false.)
      c = self%blk%col
      associate (b => self%blk)
         if (self%fam%chain%n > 0) then
            call column_chain(SE_HEAD, SE_COL)
         else
            call column_plain(SE_HEAD, SE_COL)
         end if
      end associate
      call column_end(self, t, y, c, .false.)
   contains
      ! a block's step before its last: the column, not the workspace (D-120)
#include "trainsim_model_rk4_kernels.inc"
   end procedure model_rhs_step_end

   module procedure model_rhs_stage
      self%ws_step_end = .false.
      if (.not. self%simple) then
         call rhs_fast(self, t, y, dydt)
      else if (self%run%track_energy) then
         call stage_energy(self%fam, self%fam%iw, self%fam%rw, self%elements, t, y, dydt, self%el_torque, &
                           self%fam%th, self%fam%w, self%fam%pw)
      else
         call stage_plain(self%fam, self%fam%iw, self%fam%rw, self%elements, t, y, dydt, self%el_torque, &
                          self%fam%th, self%fam%w)
      end if
   contains
      ! the stage kernel, energy off and on (internal: inlined here, D-70)
#define KERNEL stage_plain
#define ENERGY 0
#define STEP_END 0
#include "trainsim_model_stage.inc"
#undef KERNEL
#undef ENERGY
#define KERNEL stage_energy
#define ENERGY 1
#include "trainsim_model_stage.inc"
#undef KERNEL
#undef ENERGY
#undef STEP_END
   end procedure model_rhs_stage

   module procedure model_rk4_stages
      integer :: j
      real(wp) :: hh, h6
      if (self%run%track_energy .and. self%simple) then
         ! (first: before the energy-off stages' set-up, D-169)
         call rk4_energy_stages(self, t, h, t4, y, k1, k2, k3, k4, ynew)   ! (the combination too)
         return
      end if
      self%ws_step_end = .false.
      hh = 0.5_wp*h
      if (.not. self%simple) then
         call stage_formed(t + hh, hh, k1, k2)
         call stage_formed(t + hh, hh, k2, k3)
         call stage_formed(t4, h, k3, k4)
      else
#include "trainsim_model_rk4_inner.inc"
      end if
      h6 = h/6.0_wp
      do j = 1, self%n_y
         ynew(j) = y(j) + h6*(k1(j) + 2.0_wp*(k2(j) + k3(j)) + k4(j))
      end do
   contains
      ! a model that is not simple: the stage's state formed in ytmp, `rhs_fast` there
      subroutine stage_formed(ts, c, k, dydt)
         real(wp), intent(in) :: ts, c, k(self%n_y)
         real(wp), intent(out) :: dydt(self%n_y)
         integer :: i
         do i = 1, self%n_y
            ytmp(i) = y(i) + c*k(i)
         end do
         call rhs_fast(self, ts, ytmp, dydt)
      end subroutine stage_formed
      ! the stage kernel at y + c k (internal: inlined here)
#define RK4_INNER 1
#include "trainsim_model_rk4_kernels.inc"
#undef RK4_INNER
   end procedure model_rk4_stages

   module procedure model_block_ok
      ok = self%simple .and. self%blk%cap >= 4
      if (.not. ok) return
      if (self%run%track_energy) ok = self%n_cold == 0
      if (ok) ok = all(self%ws_status)
   end procedure model_block_ok

   !> `model_rhs` of a model that is not simple, without the dispatch.
   subroutine rhs_fast(self, t, y, dydt)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: dydt(:)
      integer :: i, l, r, s, o, nc
      real(wp) :: tl, tr, f, pdiss, pin
      logical :: track
      track = self%run%track_energy
      self%ws_step_end = .false.
      self%ws_t = t
      self%ws_energy = .false.
      nc = self%n_cand                                 ! elements that may constrain (D-81)
      if (nc > 0) call constraints_rhs(self, t, y, t_now=.true.)
      pdiss = 0.0_wp
      pin = 0.0_wp
      ! kinematics and constant loads in one pass (the branch of kinematics_all, written
      ! out here on purpose: as a called procedure it costs 20 % of the RHS, measured)
      do i = 1, size(self%fn)
         associate (nd => self%fn(i))
            if (nd%kind == nk_plain) then
               o = nd%off
               self%theta(i) = y(o + 1)
               self%omega(i) = y(o + 2)
            else if (nd%kind == nk_held .and. nd%const_speed) then
               self%theta(i) = nd%theta0 + nd%w*t
               self%omega(i) = nd%w
            else
               call node_kinematics(self, i, t, y, self%theta(i), self%omega(i))
            end if
            self%torque(i) = nd%load0
         end associate
      end do
      if (self%loads_vary .or. self%any_needs_loads) call loads_varying(self, t)
      if (track) then
         ! power of the external loads (before the elements add to self%torque); on a
         ! held node the drive's power below counts it against: the drive takes it
         do i = 1, size(self%fl)
            l = self%fl(i)%node
            if (self%fl(i)%const) then
               pin = pin + self%fl(i)%v*self%omega(l)
            else
               pin = pin + self%loads(i)%at(t, self%omega(l))*self%omega(l)
            end if
         end do
      end if
      do i = 1, size(self%fe)
         associate (e => self%fe(i))
            l = e%l
            r = e%r
            if (e%linear .or. e%form >= lf_open) then                      ! a family's row
               call family_row(self, i, tl, tr, f)
               if (track) pdiss = pdiss + f
            else if (self%nport) then
               call general_torques(self%elements(i)%e, self%theta, self%omega, self%torque, track, tl, tr, &
                                    pdiss, pin)                     ! (its further ports' torques added: D-73)
            else if (track) then
               ! (one call: an element that shares work between the two, e.g. a
               ! keyed joint's key fit, does it once; bit for bit the two calls)
               call self%elements(i)%e%torques_dissipation(self%theta(l), self%omega(l), self%theta(r), &
                                                           self%omega(r), tl, tr, f)
               pdiss = pdiss + f
               if (self%elements(i)%e%supplies_power) then
                  pin = pin + self%elements(i)%e%input_power(self%theta(l), self%omega(l), self%theta(r), &
                                                             self%omega(r))
               end if
            else
               call self%elements(i)%e%torques(self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr)
            end if
         end associate
         self%el_torque(1, i) = tl
         self%el_torque(2, i) = tr
         self%torque(l) = self%torque(l) + tl
         self%torque(r) = self%torque(r) + tr
      end do
      if (nc > 0) then
         call constraints_rhs(self, t, y)                                ! constraint torques (D-81)
         if (track .and. self%cn%lossy) pdiss = pdiss + self%cn%loss      ! a lossy row's (D-97)
      end if
      do i = 1, size(self%fn)
         associate (nd => self%fn(i))
            select case (nd%kind)
            case (nk_plain)
               o = nd%off
               dydt(o + 1) = y(o + 2)                                      ! eq. (G.1)
               dydt(o + 2) = (self%torque(i) - nd%d*y(o + 2))/nd%j          ! eq. (G.2)
               if (track .and. nd%d /= 0.0_wp) pdiss = pdiss + nd%d*self%omega(i)**2
            case (nk_held)
               if (track) then
                  ! torque the drive must supply: J*alpha minus what acts on the node
                  if (nd%const_speed) then
                     pin = pin - self%torque(i)*self%omega(i)   ! alpha = 0
                  else
                     s = self%speed_of(i)
                     pin = pin + (self%nodes(i)%n%inertia()*self%speeds(s)%derivative(t) - self%torque(i))*self%omega(i)
                  end if
               end if
            case default
               call self%nodes(i)%n%derivatives(t, y, self%torque(i), dydt)
               if (track) then
                  pdiss = pdiss + self%nodes(i)%n%dissipation_power(y)
                  pin = pin + self%nodes(i)%n%input_power(t, y)
               end if
            end select
         end associate
      end do
      if (nc > 0) call constraints_rhs(self, t, y, dydt)               ! exact per rigid cluster
      if (.not. track) return
      dydt(self%n_states + 1) = pdiss
      dydt(self%n_states + 2) = pin
   end subroutine rhs_fast

   module procedure rhs_simple_ws
      integer :: c
      logical :: track
      track = self%run%track_energy
      call ws_mark(self, t, step_end, track)
      c = max(self%blk%col, 1)
      associate (b => self%blk)
         ! (the column is written by the _col variants, D-38; inside a block
         ! without the workspace by `model_rhs_step_end`, D-120)
         if (track .and. b%col > 0) then
            call step_end_energy_col(SE_HEAD, self%fam%pw, SE_WS, SE_STORED, SE_COL)
         else if (track) then
            call step_end_energy(SE_HEAD, self%fam%pw, SE_WS, SE_STORED)
         else if (b%col > 0) then
            call step_end_plain_col(SE_HEAD, SE_WS, SE_COL)
         else
            call step_end_plain(SE_HEAD, SE_WS)
         end if
      end associate
      if (step_end .and. self%blk%col > 0) call column_end(self, t, y, c, track)
   contains
      ! the step-end kernel, energy off and on, without and with the block's
      ! column (STEP_END 1, 2) and the column alone (3; internal: each inlined
      ! at its one call)
#define STEP_END 1
#define KERNEL step_end_plain
#define ENERGY 0
#include "trainsim_model_stage.inc"
#undef KERNEL
#undef ENERGY
#define KERNEL step_end_energy
#define ENERGY 1
#include "trainsim_model_stage.inc"
#undef KERNEL
#undef ENERGY
#undef STEP_END
#define STEP_END 2
#define KERNEL step_end_plain_col
#define ENERGY 0
#include "trainsim_model_stage.inc"
#undef KERNEL
#undef ENERGY
#define KERNEL step_end_energy_col
#define ENERGY 1
#include "trainsim_model_stage.inc"
#undef KERNEL
#undef ENERGY
#undef STEP_END
   end procedure rhs_simple_ws
#undef SE_HEAD
#undef SE_WS
#undef SE_COL
#undef SE_STORED

   !> The workspace's marks as a simple model's kernel leaves them at t (the
   !> stored energy there if a step end's with energy tracking and no cold element).
   subroutine ws_mark(self, t, step_end, track)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      logical, intent(in) :: step_end, track
      self%ws_step_end = .false.
      self%ws_t = t
      self%ws_energy = step_end .and. track .and. self%n_cold == 0
   end subroutine ws_mark

   !> A step's end in the block's column c (D-38): its time and, with energy
   !> tracking, the energy states at y and the stored energy the kernel left.
   subroutine column_end(self, t, y, c, track)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(*)
      integer, intent(in) :: c
      logical, intent(in) :: track
      associate (b => self%blk)
         b%t(c) = t
         if (track) then
            b%work(1, c) = y(self%n_states + 1)
            b%work(2, c) = y(self%n_states + 2)
            b%stored(c) = self%ws_stored
            b%elastic(c) = self%ws_elastic
         end if
      end associate
   end subroutine column_end

   !> Element i's torques (and the power it dissipates) at the kinematics in the
   !> workspace through its family's row (trainsim_model_kernels): a linear
   !> spring, a clearance in its hot form (D-35). The general path, one element
   !> and a part of the train evaluate an element of a family here, with the
   !> stage kernel's arithmetic.
   subroutine family_row(self, i, tl, tr, pw)
      type(model_t), intent(in) :: self
      integer, intent(in) :: i
      real(wp), intent(out) :: tl, tr, pw
      real(wp) :: d, dv, f
      associate (e => self%fe(i), thl => self%theta(self%fe(i)%l), wl => self%omega(self%fe(i)%l), &
                 thr => self%theta(self%fe(i)%r), wr => self%omega(self%fe(i)%r))
         if (e%linear) then
            call spring(e%c /= 0.0_wp, e%k, e%c, e%r1, e%r2, thl, wl, thr, wr, d, dv, f, tl, tr)
            pw = e%c*dv**2                                                 ! (0 without damping)
         else
            call hot_torques(self%fh(i), thl, wl, thr, wr, tl, tr, pw)
         end if
      end associate
   end subroutine family_row

   module procedure model_element_torques
      real(wp) :: pw, tp(max_ports)
      integer :: ends(max_ports)
      if (self%fe(i)%linear .or. self%fe(i)%form >= lf_open) then
         call family_row(self, i, tl, tr, pw)
      else if (self%nport) then                                            ! (over its ports: D-73)
         call port_torques_at(self%elements(i)%e, self%theta, self%omega, ends, tp, pw)
         tl = tp(1)
         tr = tp(2)
      else
         associate (l => self%fe(i)%l, r => self%fe(i)%r)
            call self%elements(i)%e%torques(self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr)
         end associate
      end if
   end procedure model_element_torques

   module procedure model_rhs_part
      integer :: k, i, l, r, o
      real(wp) :: tl, tr, f
      self%ws_step_end = .false.
      do k = 1, size(kin)
         i = kin(k)
         if (self%fn(i)%kind == nk_plain) then   ! (node_kinematics written out: as in rhs_fast)
            o = self%fn(i)%off
            self%theta(i) = y(o + 1)
            self%omega(i) = y(o + 2)
         else
            call node_kinematics(self, i, t, y, self%theta(i), self%omega(i))
         end if
         self%torque(i) = self%fn(i)%load0
      end do
      do k = 1, size(self%dyn_loads)
         i = self%dyn_loads(k)
         l = self%fl(i)%node
         self%torque(l) = self%torque(l) + self%loads(i)%torque%value(t)
      end do
      do k = 1, size(self%spd_loads)   ! (a node in `der` is in `kin`: its omega is current)
         i = self%spd_loads(k)
         l = self%fl(i)%node
         self%torque(l) = self%torque(l) + self%loads(i)%at(t, self%omega(l))
      end do
      if (self%any_needs_loads) then
         do k = 1, size(els)
            i = els(k)
            if (.not. self%elements(i)%e%needs_loads) cycle
            self%elements(i)%e%ext_left = self%torque(self%fe(i)%l)
            self%elements(i)%e%ext_right = self%torque(self%fe(i)%r)
         end do
      end if
      do k = 1, size(els)
         i = els(k)
         associate (e => self%fe(i))
            l = e%l
            r = e%r
            if (e%linear .or. e%form >= lf_open) then                      ! a family's row
               call family_row(self, i, tl, tr, f)
            else
               call self%elements(i)%e%torques(self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr)
            end if
         end associate
         self%torque(l) = self%torque(l) + tl
         self%torque(r) = self%torque(r) + tr
      end do
      do k = 1, size(der)
         i = der(k)
         associate (nd => self%fn(i))
            select case (nd%kind)
            case (nk_plain)
               o = nd%off
               dydt(o + 1) = y(o + 2)
               dydt(o + 2) = (self%torque(i) - nd%d*y(o + 2))/nd%j
            case (nk_other)
               call self%nodes(i)%n%derivatives(t, y, self%torque(i), dydt)
            end select
         end associate
      end do
   end procedure model_rhs_part

   module procedure model_apply_loads
      call loads_at(self, t)
   end procedure model_apply_loads

   !> `model_apply_loads` without the dispatch.
   subroutine loads_at(self, t)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      integer :: i
      do i = 1, size(self%fn)
         self%torque(i) = self%fn(i)%load0
      end do
      call loads_varying(self, t)
   end subroutine loads_at

   !> The loads that vary with t or with their node's speed (at the speeds in
   !> the workspace), and the loads published to the elements that read them
   !> (after the constant sums are in self%torque).
   subroutine loads_varying(self, t)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      integer :: i, k, l
      do k = 1, size(self%dyn_loads)
         i = self%dyn_loads(k)
         l = self%fl(i)%node
         self%torque(l) = self%torque(l) + self%loads(i)%torque%value(t)
      end do
      do k = 1, size(self%spd_loads)
         i = self%spd_loads(k)
         l = self%fl(i)%node
         self%torque(l) = self%torque(l) + self%loads(i)%at(t, self%omega(l))
      end do
      if (.not. self%any_needs_loads) return
      do i = 1, size(self%elements)
         if (.not. self%elements(i)%e%needs_loads) cycle
         self%elements(i)%e%ext_left = self%torque(self%elements(i)%e%left)
         self%elements(i)%e%ext_right = self%torque(self%elements(i)%e%right)
      end do
   end subroutine loads_varying
end submodule trainsim_model_rhs
