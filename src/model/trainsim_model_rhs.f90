!> The model's right-hand side: the general path (every node and element
!> through its procedures, the families from their tables) and the kernels of
!> a simple model (stage, stage with energy, step end), and a part of the train.
!> Each `module procedure` here is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_rhs
   use trainsim_model_families, only: nk_other, nk_plain, nk_held, lf_general, lf_undamped, lf_unit, lf_open, &
                                      lf_yang_sun, lf_cl_linear, hot_torques
   use trainsim_ports, only: port_torques_at, general_torques
   use trainsim_element, only: max_ports
   implicit none

contains

   module procedure model_rhs
      call rhs_fast(self, t, y, dydt, .false.)
   end procedure model_rhs

   module procedure model_rhs_step_end
      if (self%simple) then
         ! straight to the kernel (every step of a block, D-38): no second layer
         ! of descriptors
         call rhs_simple_ws(self, t, y, dydt, .true.)
      else
         call rhs_fast(self, t, y, dydt, .true.)
      end if
   end procedure model_rhs_step_end

   module procedure model_rhs_stage
      self%ws_step_end = .false.
      if (.not. self%simple) then
         call rhs_fast(self, t, y, dydt, .false.)
         return
      end if
      if (self%run%track_energy) then
         call rhs_stage_energy(size(self%fn), size(self%fe), size(self%fl), self%fn, self%fe, self%fh, self%fl, &
                               self%elements, self%el_torque, self%node_first, self%node_inc, t, y, dydt, &
                               self%n_states, self%chain)
      else
         call rhs_stage_simple(size(self%fn), size(self%fe), self%fn, self%fe, self%fh, self%elements, &
                               self%el_torque, self%node_first, self%node_inc, t, y, dydt, self%chain)
      end if
   contains

      !> `rhs_simple` for an inner stage (`model_rhs_stage`) without energy
      !> tracking: the same values bit for bit from the same operations in the
      !> same order, but only et and dydt are stored; a node's angle and speed are
      !> read where they are used, from y (a plain inertia) or by the expression
      !> `rhs_simple` stores (a held node). About a tenth of the kernel's time on
      !> the Table 5.5 rig (issue 11). With energy tracking: `rhs_stage_energy`.
      subroutine rhs_stage_simple(nn, ne, fn, fe, fh, els, et, first, inc, t, y, dydt, chain)
         integer, intent(in) :: nn, ne
         type(fast_node_t), intent(in) :: fn(nn)
         type(fast_element_t), intent(in) :: fe(ne)
         type(hot_form_t), intent(in) :: fh(ne)
         type(element_slot_t), intent(in) :: els(ne)
         real(wp), intent(inout) :: et(2*ne)
         integer, intent(in) :: first(nn + 1), inc(2*ne)
         real(wp), intent(in) :: t
         real(wp), intent(in), contiguous :: y(:)            ! (model_rhs_stage's: no packing)
         real(wp), intent(inout), contiguous :: dydt(:)
         !> The train is a serial chain (element i joins nodes i and i + 1): each
         !> node's torque is finished as soon as its right-hand element is
         !> evaluated (load0 + tr of element i-1 + tl of element i, the node_inc
         !> order), in a register (no store and reload of et on the path).
         logical, intent(in) :: chain
         integer :: i, l, r, o, k
         real(wp) :: f, d, dv, tq, thl, wl, thr, wr, p, pdot, fs, tl, tr, tqc
         tqc = fn(1)%load0
         do i = 1, ne
            if (fe(i)%yl > 0) then
               thl = y(fe(i)%yl)
               wl = y(fe(i)%yl + 1)
            else                                   ! held at a constant speed
               l = fe(i)%l
               thl = fn(l)%theta0 + fn(l)%w*t
               wl = fn(l)%w
            end if
            if (fe(i)%yr > 0) then
               thr = y(fe(i)%yr)
               wr = y(fe(i)%yr + 1)
            else
               r = fe(i)%r
               thr = fn(r)%theta0 + fn(r)%w*t
               wr = fn(r)%w
            end if
            select case (fe(i)%form)
            case (lf_unit)                                                    ! eq. (H.1), c = 0
               f = fe(i)%k*(thl - thr)
               tl = -f
               tr = f
            case (lf_undamped)                                                ! eq. (H.15)
               f = fe(i)%k*(fe(i)%r1*thl - fe(i)%r2*thr)
               tl = -(f*fe(i)%r1)
               tr = f*fe(i)%r2
            case (lf_general)
               dv = fe(i)%r1*wl - fe(i)%r2*wr
               d = fe(i)%r1*thl - fe(i)%r2*thr
               f = fe(i)%k*d + fe(i)%c*dv
               tl = -(f*fe(i)%r1)
               tr = f*fe(i)%r2
            case (lf_open)                                                    ! a clearance open (D-35)
               f = 0.0_wp
               tl = -(f*fh(i)%r1)
               tr = f*fh(i)%r2
            case (lf_yang_sun, lf_cl_linear)                                  ! a clearance closed (D-35)
               ! hot_torques written out (a call costs more than the arithmetic)
               associate (h => fh(i))
                  d = h%r1*thl - h%r2*thr
                  dv = h%r1*wl - h%r2*wr
                  p = h%s*d - h%b
                  pdot = h%s*dv
                  if (fe(i)%form == lf_yang_sun) then
                     f = h%c*(h%k*p + h%dmp*p*pdot)                           ! eqs. (3.18)-(3.19)
                  else
                     f = h%c*(h%k*p) + h%dmp*pdot
                  end if
                  if (h%no_tension) f = max(f, 0.0_wp)
                  fs = h%s*f
                  tl = -(fs*h%r1)
                  tr = fs*h%r2
               end associate
            case default
               call els(i)%e%torques(thl, wl, thr, wr, et(2*i - 1), et(2*i))
               tl = et(2*i - 1)
               tr = et(2*i)
            end select
            et(2*i - 1) = tl
            et(2*i) = tr
            if (chain) then
               ! node i is done: its torque load0 + tr(i-1) + tl(i) (from the register)
               tq = tqc + tl
               if (fn(i)%kind == nk_plain) then
                  o = fn(i)%off
                  dydt(o + 1) = y(o + 2)                                      ! eq. (G.1)
                  if (fn(i)%d == 0.0_wp) then
                     dydt(o + 2) = tq/fn(i)%j                                   ! eq. (G.2), d = 0
                  else
                     dydt(o + 2) = (tq - fn(i)%d*y(o + 2))/fn(i)%j              ! eq. (G.2)
                  end if
               end if
               tqc = fn(i + 1)%load0 + tr
            end if
         end do
         if (chain) then
            ! the last node: load0 + tr of the last element
            if (fn(nn)%kind == nk_plain) then
               o = fn(nn)%off
               dydt(o + 1) = y(o + 2)
               if (fn(nn)%d == 0.0_wp) then
                  dydt(o + 2) = tqc/fn(nn)%j
               else
                  dydt(o + 2) = (tqc - fn(nn)%d*y(o + 2))/fn(nn)%j
               end if
            end if
            return
         end if
         do i = 1, nn
            tq = fn(i)%load0
            do k = first(i), first(i + 1) - 1
               tq = tq + et(inc(k))
            end do
            if (fn(i)%kind == nk_plain) then
               o = fn(i)%off
               dydt(o + 1) = y(o + 2)                                         ! eq. (G.1)
               if (fn(i)%d == 0.0_wp) then
                  dydt(o + 2) = tq/fn(i)%j                                      ! eq. (G.2), d = 0
               else
                  dydt(o + 2) = (tq - fn(i)%d*y(o + 2))/fn(i)%j                 ! eq. (G.2)
               end if
            end if
         end do
      end subroutine rhs_stage_simple

      !> `rhs_stage_simple` with energy tracking: also the dissipated power pdiss
      !> and the input power pin (dydt(ns + 1 : ns + 2)), bit for bit `rhs_simple`'s:
      !> the same terms summed in the same order (the loads, the elements, the
      !> nodes). A kernel of its own (D-40): sharing one with the energy-off stage
      !> made the compiler's code for that path slower (measured, benchmarks.md).
      !> On a serial chain the nodes' dy/dt come from registers as there, and so
      !> do their power terms, summed apart (pdn; pinc from the loads' sum on) and
      !> joined at the end where that gives the same sums: pin = pinc if no
      !> element supplies power, pdiss = pdn if no element dissipates; else the
      !> nodes' terms are added again in a pass of their own (a held node's torque
      !> summed from et in the node_inc order, as the general node loop sums it).
      subroutine rhs_stage_energy(nn, ne, nl, fn, fe, fh, fl, els, et, first, inc, t, y, dydt, ns, chain)
         integer, intent(in) :: nn, ne, nl, ns
         type(fast_node_t), intent(in) :: fn(nn)
         type(fast_element_t), intent(in) :: fe(ne)
         type(hot_form_t), intent(in) :: fh(ne)
         type(fast_load_t), intent(in) :: fl(nl)
         type(element_slot_t), intent(in) :: els(ne)
         real(wp), intent(inout) :: et(2*ne)
         integer, intent(in) :: first(nn + 1), inc(2*ne)
         real(wp), intent(in) :: t
         real(wp), intent(in), contiguous :: y(:)            ! (model_rhs_stage's: no packing)
         real(wp), intent(inout), contiguous :: dydt(:)
         logical, intent(in) :: chain   !< as in `rhs_stage_simple`
         integer :: i, l, r, o, k
         real(wp) :: f, d, dv, pdiss, pin, pw, tq, thl, wl, thr, wr, p, pdot, fs, tl, tr, tqc, pdn, pinc
         logical :: el_d, el_p, nd_d   ! a term from an element in pdiss, in pin; from a node in pdn
         pdiss = 0.0_wp
         pin = 0.0_wp
         pdn = 0.0_wp
         el_d = .false.
         el_p = .false.
         nd_d = .false.
         tqc = fn(1)%load0
         do i = 1, nl
            l = fl(i)%node
            if (fn(l)%kind == nk_held) cycle
            pin = pin + fl(i)%v*y(fn(l)%off + 2)
         end do
         pinc = pin
         do i = 1, ne
            if (fe(i)%yl > 0) then
               thl = y(fe(i)%yl)
               wl = y(fe(i)%yl + 1)
            else                                   ! held at a constant speed
               l = fe(i)%l
               thl = fn(l)%theta0 + fn(l)%w*t
               wl = fn(l)%w
            end if
            if (fe(i)%yr > 0) then
               thr = y(fe(i)%yr)
               wr = y(fe(i)%yr + 1)
            else
               r = fe(i)%r
               thr = fn(r)%theta0 + fn(r)%w*t
               wr = fn(r)%w
            end if
            select case (fe(i)%form)
            case (lf_unit)                                                    ! eq. (H.1), c = 0
               f = fe(i)%k*(thl - thr)
               tl = -f
               tr = f
            case (lf_undamped)                                                ! eq. (H.15)
               f = fe(i)%k*(fe(i)%r1*thl - fe(i)%r2*thr)
               tl = -(f*fe(i)%r1)
               tr = f*fe(i)%r2
            case (lf_general)
               dv = fe(i)%r1*wl - fe(i)%r2*wr
               d = fe(i)%r1*thl - fe(i)%r2*thr
               f = fe(i)%k*d + fe(i)%c*dv
               tl = -(f*fe(i)%r1)
               tr = f*fe(i)%r2
               pdiss = pdiss + fe(i)%c*dv**2
               el_d = .true.
            case (lf_open)                                                    ! a clearance open (D-35)
               f = 0.0_wp
               tl = -(f*fh(i)%r1)
               tr = f*fh(i)%r2
               pdiss = pdiss + 0.0_wp
               el_d = .true.
            case (lf_yang_sun, lf_cl_linear)                                  ! a clearance closed (D-35)
               associate (h => fh(i))
                  d = h%r1*thl - h%r2*thr
                  dv = h%r1*wl - h%r2*wr
                  p = h%s*d - h%b
                  pdot = h%s*dv
                  if (fe(i)%form == lf_yang_sun) then
                     f = h%c*(h%k*p + h%dmp*p*pdot)                           ! eqs. (3.18)-(3.19)
                  else
                     f = h%c*(h%k*p) + h%dmp*pdot
                  end if
                  if (h%no_tension) f = max(f, 0.0_wp)
                  fs = h%s*f
                  tl = -(fs*h%r1)
                  tr = fs*h%r2
                  pdiss = pdiss + (h%s*fs - h%c*(h%k*p))*pdot
               end associate
               el_d = .true.
            case default
               call els(i)%e%torques_dissipation(thl, wl, thr, wr, et(2*i - 1), et(2*i), pw)
               pdiss = pdiss + pw
               el_d = .true.
               if (els(i)%e%supplies_power) then
                  pin = pin + els(i)%e%input_power(thl, wl, thr, wr)
                  el_p = .true.
               end if
               tl = et(2*i - 1)
               tr = et(2*i)
            end select
            et(2*i - 1) = tl
            et(2*i) = tr
            if (chain) then
               ! node i is done (as in rhs_stage_simple), and its power terms
               tq = tqc + tl
               if (fn(i)%kind == nk_plain) then
                  o = fn(i)%off
                  dydt(o + 1) = y(o + 2)                                      ! eq. (G.1)
                  if (fn(i)%d == 0.0_wp) then
                     dydt(o + 2) = tq/fn(i)%j                                   ! eq. (G.2), d = 0
                  else
                     dydt(o + 2) = (tq - fn(i)%d*y(o + 2))/fn(i)%j              ! eq. (G.2)
                     pdn = pdn + fn(i)%d*y(o + 2)**2
                     nd_d = .true.
                  end if
               else
                  pinc = pinc - tq*fn(i)%w         ! the drive's torque (alpha = 0) times the speed
               end if
               tqc = fn(i + 1)%load0 + tr
            end if
         end do
         if (chain) then
            if (fn(nn)%kind == nk_plain) then
               o = fn(nn)%off
               dydt(o + 1) = y(o + 2)
               if (fn(nn)%d == 0.0_wp) then
                  dydt(o + 2) = tqc/fn(nn)%j
               else
                  dydt(o + 2) = (tqc - fn(nn)%d*y(o + 2))/fn(nn)%j
                  pdn = pdn + fn(nn)%d*y(o + 2)**2
                  nd_d = .true.
               end if
            else
               pinc = pinc - tqc*fn(nn)%w
            end if
            if (.not. el_p) pin = pinc                 ! the loads' terms, then the nodes'
            if (nd_d) then
               if (.not. el_d) pdiss = pdn             ! (0 + the nodes' terms)
            end if
            if (el_p .or. (nd_d .and. el_d)) then
               ! both an element's and a node's terms: the nodes' again, after the elements'
               do i = 1, nn
                  if (fn(i)%kind == nk_plain) then
                     if (fn(i)%d /= 0.0_wp .and. el_d) pdiss = pdiss + fn(i)%d*y(fn(i)%off + 2)**2
                  else if (el_p) then
                     tq = fn(i)%load0
                     do k = first(i), first(i + 1) - 1
                        tq = tq + et(inc(k))
                     end do
                     pin = pin - tq*fn(i)%w
                  end if
               end do
            end if
         else
            do i = 1, nn
               tq = fn(i)%load0
               do k = first(i), first(i + 1) - 1
                  tq = tq + et(inc(k))
               end do
               if (fn(i)%kind == nk_plain) then
                  o = fn(i)%off
                  dydt(o + 1) = y(o + 2)                                      ! eq. (G.1)
                  if (fn(i)%d == 0.0_wp) then
                     dydt(o + 2) = tq/fn(i)%j                                   ! eq. (G.2), d = 0
                  else
                     dydt(o + 2) = (tq - fn(i)%d*y(o + 2))/fn(i)%j              ! eq. (G.2)
                     pdiss = pdiss + fn(i)%d*y(o + 2)**2
                  end if
               else
                  pin = pin - tq*fn(i)%w           ! the drive's torque (alpha = 0) times the speed
               end if
            end do
         end if
         dydt(ns + 1) = pdiss
         dydt(ns + 2) = pin
      end subroutine rhs_stage_energy
   end procedure model_rhs_stage

   module procedure model_block_ok
      ok = self%simple .and. self%blk%cap >= 4
      if (.not. ok) return
      if (self%run%track_energy) ok = self%n_cold == 0
      if (ok) ok = all(self%ws_status)
   end procedure model_block_ok

   !> `model_rhs` without the dispatch.
   subroutine rhs_fast(self, t, y, dydt, step_end)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: dydt(:)
      logical, intent(in) :: step_end   !< leave the stored energy too (`model_rhs_step_end`)
      integer :: i, l, r, s, o
      real(wp) :: tl, tr, f, dv, pdiss, pin
      logical :: track
      if (self%simple) then
         call rhs_simple_ws(self, t, y, dydt, step_end)
         return
      end if
      track = self%run%track_energy
      self%ws_step_end = .false.
      self%ws_t = t
      self%ws_energy = .false.
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
      if (size(self%dyn_loads) > 0 .or. self%any_needs_loads) call loads_varying(self, t)
      if (track) then
         ! power of the external loads on free nodes (before the elements add to self%torque)
         do i = 1, size(self%fl)
            l = self%fl(i)%node
            if (self%fn(l)%kind == nk_held) cycle
            if (self%fl(i)%const) then
               pin = pin + self%fl(i)%v*self%omega(l)
            else
               pin = pin + self%loads(i)%torque%value(t)*self%omega(l)
            end if
         end do
      end if
      do i = 1, size(self%fe)
         associate (e => self%fe(i))
            l = e%l
            r = e%r
            if (e%linear) then
               dv = e%r1*self%omega(l) - e%r2*self%omega(r)
               f = e%k*(e%r1*self%theta(l) - e%r2*self%theta(r)) + e%c*dv     ! eqs. (H.1), (H.15)
               tl = -(f*e%r1)
               tr = f*e%r2
               if (track .and. e%c /= 0.0_wp) pdiss = pdiss + e%c*dv**2
            else if (e%form >= lf_open) then                               ! a clearance's hot form (D-35)
               call hot_torques(self%fh(i), self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr, f)
               if (track) pdiss = pdiss + f
            else if (self%nport) then
               call general_torques(self%elements(i)%e, self%theta, self%omega, self%torque, track, tl, tr, &
                                    pdiss, pin)                     ! (its further ports' torques added: D-63)
            else
               call self%elements(i)%e%torques(self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr)
               if (track) then
                  pdiss = pdiss + self%elements(i)%e%dissipation_power(self%theta(l), self%omega(l), self%theta(r), &
                                                                       self%omega(r))
                  if (self%elements(i)%e%supplies_power) then
                     pin = pin + self%elements(i)%e%input_power(self%theta(l), self%omega(l), self%theta(r), &
                                                                self%omega(r))
                  end if
               end if
            end if
         end associate
         self%el_torque(1, i) = tl
         self%el_torque(2, i) = tr
         self%torque(l) = self%torque(l) + tl
         self%torque(r) = self%torque(r) + tr
      end do
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
      if (.not. track) return
      dydt(self%n_states + 1) = pdiss
      dydt(self%n_states + 2) = pin
   end subroutine rhs_fast

   module procedure rhs_simple_ws
      integer :: c
      logical :: track
      track = self%run%track_energy
      self%ws_step_end = .false.
      self%ws_t = t
      self%ws_energy = step_end .and. track .and. self%n_cold == 0
      c = max(self%blk%col, 1)
      call rhs_simple(size(self%fn), size(self%fe), size(self%fl), self%fn, self%fe, self%fh, self%fl, self%elements, &
                      self%theta, self%omega, self%torque, self%el_torque, self%el_disp, self%el_force, self%el_pe, &
                      self%blk%disp(:, c), self%blk%force(:, c), self%blk%torque(:, c), self%blk%omega(:, c), &
                      self%node_first, self%node_inc, t, y, dydt, track, self%n_states, &
                      self%chain .and. .not. track, self%ws_energy, self%ws_stored, self%ws_elastic, &
                      self%blk%col > 0)
      if (step_end .and. self%blk%col > 0) then
         ! the step's end in the block's column (D-38)
         self%blk%t(c) = t
         if (track) then
            self%blk%work(1, c) = y(self%n_states + 1)
            self%blk%work(2, c) = y(self%n_states + 2)
            self%blk%stored(c) = self%ws_stored
            self%blk%elastic(c) = self%ws_elastic
         end if
      end if
   contains

   end procedure rhs_simple_ws

   !> `rhs_fast` for a simple model (component `simple`): the same values (bit
   !> for bit, but for the sign of a zero: terms that are exactly 0 or factors
   !> exactly 1 are left out, see lf_*), on explicit-shape arrays, which the
   !> compiler knows do not alias (it keeps their addresses in registers
   !> instead of reloading them from the model after every store). The element
   !> torques go to et first; each node then adds its own (node_inc) in a
   !> register, in the order `rhs_fast` adds them to self%torque.
   !> With `energy` (D-36) it also leaves the stored energy and its elastic part
   !> (est, epot), bit for bit `model_workspace_energy`'s: the same terms in the
   !> same order (the kinetic energies node by node, then the elastic energies,
   !> pe, element by element).
   subroutine rhs_simple(nn, ne, nl, fn, fe, fh, fl, els, theta, omega, torque, et, disp, force, pe, bd, bf, bt, bo, &
                         first, inc, t, y, dydt, track, ns, chain, energy, est, epot, to_col)
      integer, intent(in) :: nn, ne, nl, ns
      type(fast_node_t), intent(in) :: fn(nn)
      type(fast_element_t), intent(in) :: fe(ne)
      type(hot_form_t), intent(in) :: fh(ne)
      type(fast_load_t), intent(in) :: fl(nl)
      type(element_slot_t), intent(in) :: els(ne)
      real(wp), intent(inout) :: theta(nn), omega(nn), torque(nn), et(2*ne), disp(ne), force(ne), pe(ne)
      !> the block's column (D-38): disp, force, et(2, :) and omega again
      real(wp), intent(inout) :: bd(ne), bf(ne), bt(ne), bo(nn)
      integer, intent(in) :: first(nn + 1), inc(2*ne)
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: dydt(:)
      logical, intent(in) :: track
      logical, intent(in) :: chain   !< as in `rhs_stage_simple` (a serial chain, energy off)
      !> track, and every element a linear spring or a hot form whose elastic
      !> energy is `hot_potential` (not with chain)
      logical, intent(in) :: energy
      real(wp), intent(inout) :: est, epot
      logical, intent(in) :: to_col   !< write the block's column (bd, bf, bt, bo)
      integer :: i, l, r, o, k
      real(wp) :: f, d, dv, pdiss, pin, pw, tq, thl, wl, thr, wr, p, pdot, fs, tl, tr, tqc, ek, ep
      pdiss = 0.0_wp
      pin = 0.0_wp
      tqc = fn(1)%load0
      ek = 0.0_wp
      ep = 0.0_wp
      do i = 1, nn
         if (fn(i)%kind == nk_plain) then
            o = fn(i)%off
            theta(i) = y(o + 1)
            omega(i) = y(o + 2)
         else                                   ! held at a constant speed
            theta(i) = fn(i)%theta0 + fn(i)%w*t
            omega(i) = fn(i)%w
         end if
         if (to_col) bo(i) = omega(i)
      end do
      if (energy) then
         ! the stored energy (model_workspace_energy's order): the kinetic
         ! energies node by node, then (in the element loop) the elastic ones
         do i = 1, nn
            ek = ek + 0.5_wp*fn(i)%j*omega(i)**2                        ! (held: j its inertia)
         end do
      end if
      if (track) then
         do i = 1, nl
            l = fl(i)%node
            if (fn(l)%kind == nk_held) cycle
            pin = pin + fl(i)%v*omega(l)
         end do
      end if
      do i = 1, ne
         l = fe(i)%l
         r = fe(i)%r
         ! the angles and speeds from y where it holds them (one load fewer on the critical path)
         if (fe(i)%yl > 0) then
            thl = y(fe(i)%yl)
            wl = y(fe(i)%yl + 1)
         else
            thl = theta(l)
            wl = omega(l)
         end if
         if (fe(i)%yr > 0) then
            thr = y(fe(i)%yr)
            wr = y(fe(i)%yr + 1)
         else
            thr = theta(r)
            wr = omega(r)
         end if
         select case (fe(i)%form)
         case (lf_unit)                                                    ! eq. (H.1), c = 0
            d = thl - thr
            f = fe(i)%k*d
            tl = -f
            tr = f
            disp(i) = d
            force(i) = f
            if (energy) pe(i) = 0.5_wp*fe(i)%k*d**2                       ! (r1 = r2 = 1: d is r1 thl - r2 thr)
         case (lf_undamped)                                                ! eq. (H.15)
            d = fe(i)%r1*thl - fe(i)%r2*thr
            f = fe(i)%k*d
            tl = -(f*fe(i)%r1)
            tr = f*fe(i)%r2
            disp(i) = d
            force(i) = f
            if (energy) pe(i) = 0.5_wp*fe(i)%k*d**2
         case (lf_general)
            dv = fe(i)%r1*wl - fe(i)%r2*wr
            d = fe(i)%r1*thl - fe(i)%r2*thr
            f = fe(i)%k*d + fe(i)%c*dv
            tl = -(f*fe(i)%r1)
            tr = f*fe(i)%r2
            disp(i) = d
            force(i) = f
            if (track) pdiss = pdiss + fe(i)%c*dv**2
            if (energy) pe(i) = 0.5_wp*fe(i)%k*d**2
         case (lf_open)                                                    ! a clearance open (D-35)
            f = 0.0_wp
            tl = -(f*fh(i)%r1)
            tr = f*fh(i)%r2
            if (track) pdiss = pdiss + 0.0_wp
            ! its status (D-36): delta, force 0 (contact: el_contact); no elastic energy
            disp(i) = fh(i)%r1*thl - fh(i)%r2*thr
            force(i) = f
            if (energy) pe(i) = 0.0_wp
         case (lf_yang_sun, lf_cl_linear)                                  ! a clearance closed (D-35)
            ! hot_torques written out (a call costs more than the arithmetic)
            associate (h => fh(i))
               d = h%r1*thl - h%r2*thr
               dv = h%r1*wl - h%r2*wr
               p = h%s*d - h%b
               pdot = h%s*dv
               if (fe(i)%form == lf_yang_sun) then
                  f = h%c*(h%k*p + h%dmp*p*pdot)                           ! eqs. (3.18)-(3.19)
               else
                  f = h%c*(h%k*p) + h%dmp*pdot
               end if
               if (h%no_tension) f = max(f, 0.0_wp)
               fs = h%s*f
               tl = -(fs*h%r1)
               tr = fs*h%r2
               if (track) pdiss = pdiss + (h%s*fs - h%c*(h%k*p))*pdot
               ! its status (D-36): delta and the signed contact force; its
               ! elastic energy as `hot_potential`
               disp(i) = d
               force(i) = fs
               if (energy) pe(i) = h%c*(0.5_wp*h%k*p**2)
            end associate
         case default
            if (track) then
               call els(i)%e%torques_dissipation(thl, wl, thr, wr, et(2*i - 1), et(2*i), pw)
               pdiss = pdiss + pw
               if (els(i)%e%supplies_power) pin = pin + els(i)%e%input_power(thl, wl, thr, wr)
            else
               call els(i)%e%torques(thl, wl, thr, wr, et(2*i - 1), et(2*i))
            end if
            tl = et(2*i - 1)
            tr = et(2*i)
         end select
         et(2*i - 1) = tl
         et(2*i) = tr
         if (energy) then          ! the elastic energies after the kinetic
            ek = ek + pe(i)
            ep = ep + pe(i)
         end if
         if (to_col) then          ! the block's column (D-38)
            bd(i) = disp(i)
            bf(i) = force(i)
            bt(i) = tr
         end if
         if (chain) then
            ! node i is done (as in rhs_stage_simple)
            tq = tqc + tl
            torque(i) = tq
            if (fn(i)%kind == nk_plain) then
               o = fn(i)%off
               dydt(o + 1) = y(o + 2)                                      ! eq. (G.1)
               if (fn(i)%d == 0.0_wp) then
                  dydt(o + 2) = tq/fn(i)%j                                   ! eq. (G.2), d = 0
               else
                  dydt(o + 2) = (tq - fn(i)%d*y(o + 2))/fn(i)%j              ! eq. (G.2)
               end if
            end if
            tqc = fn(i + 1)%load0 + tr
         end if
      end do
      if (chain) then
         torque(nn) = tqc
         if (fn(nn)%kind == nk_plain) then
            o = fn(nn)%off
            dydt(o + 1) = y(o + 2)
            if (fn(nn)%d == 0.0_wp) then
               dydt(o + 2) = tqc/fn(nn)%j
            else
               dydt(o + 2) = (tqc - fn(nn)%d*y(o + 2))/fn(nn)%j
            end if
         end if
         return
      end if
      do i = 1, nn
         tq = fn(i)%load0
         do k = first(i), first(i + 1) - 1
            tq = tq + et(inc(k))
         end do
         torque(i) = tq
         if (fn(i)%kind == nk_plain) then
            o = fn(i)%off
            dydt(o + 1) = y(o + 2)                                         ! eq. (G.1)
            if (fn(i)%d == 0.0_wp) then
               dydt(o + 2) = tq/fn(i)%j                                      ! eq. (G.2), d = 0
            else
               dydt(o + 2) = (tq - fn(i)%d*y(o + 2))/fn(i)%j                 ! eq. (G.2)
               if (track) pdiss = pdiss + fn(i)%d*omega(i)**2
            end if
         else if (track) then
            pin = pin - tq*omega(i)             ! the drive's torque (alpha = 0) times the speed
         end if
      end do
      if (.not. track) return
      dydt(ns + 1) = pdiss
      dydt(ns + 2) = pin
      if (.not. energy) return
      est = ek
      epot = ep
   end subroutine rhs_simple

   module procedure model_element_torques
      real(wp) :: f, tp(max_ports)
      integer :: l, r, ends(max_ports)
      associate (e => self%fe(i))
         l = e%l
         r = e%r
         if (e%linear) then
            f = e%k*(e%r1*self%theta(l) - e%r2*self%theta(r)) + e%c*(e%r1*self%omega(l) - e%r2*self%omega(r))
            tl = -(f*e%r1)
            tr = f*e%r2
         else if (e%form >= lf_open) then                                  ! a clearance's hot form (D-35)
            call hot_torques(self%fh(i), self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr, f)
         else if (self%nport) then                                         ! (over its ports: D-63)
            call port_torques_at(self%elements(i)%e, self%theta, self%omega, ends, tp, f)
            tl = tp(1)
            tr = tp(2)
         else
            call self%elements(i)%e%torques(self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr)
         end if
      end associate
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
            if (e%form == lf_unit) then                                    ! (rhs_simple's forms: the same values)
               f = e%k*(self%theta(l) - self%theta(r))
               tl = -f
               tr = f
            else if (e%form == lf_undamped) then
               f = e%k*(e%r1*self%theta(l) - e%r2*self%theta(r))
               tl = -(f*e%r1)
               tr = f*e%r2
            else if (e%linear) then
               f = e%k*(e%r1*self%theta(l) - e%r2*self%theta(r)) + e%c*(e%r1*self%omega(l) - e%r2*self%omega(r))
               tl = -(f*e%r1)
               tr = f*e%r2
            else if (e%form >= lf_open) then                               ! a clearance's hot form (D-35)
               call hot_torques(self%fh(i), self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr, f)
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

   !> The loads that vary with t, and the loads published to the elements that
   !> read them (after the constant sums are in self%torque).
   subroutine loads_varying(self, t)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      integer :: i, k, l
      do k = 1, size(self%dyn_loads)
         i = self%dyn_loads(k)
         l = self%fl(i)%node
         self%torque(l) = self%torque(l) + self%loads(i)%torque%value(t)
      end do
      if (.not. self%any_needs_loads) return
      do i = 1, size(self%elements)
         if (.not. self%elements(i)%e%needs_loads) cycle
         self%elements(i)%e%ext_left = self%torque(self%elements(i)%e%left)
         self%elements(i)%e%ext_right = self%torque(self%elements(i)%e%right)
      end do
   end subroutine loads_varying
end submodule trainsim_model_rhs
