!> The model's linearisation: the Jacobian of the right-hand side and the
!> rigid motion of the train with its clearances closed.
!> Each `module procedure` here is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_linear
   use trainsim_element, only: lin_closed, max_ports
   use trainsim_ports, only: port_kinematics
   use trainsim_element, only: hf_open, hf_linear
   use trainsim_model_families, only: nk_plain, jac_part_t
   implicit none

contains

   module procedure model_jacobian
      integer :: i, k, na, row, ib
      if (.not. allocated(self%jdtq)) allocate (self%jdtq(5, size(self%nodes)))
      if (present(part)) then
         if (part%varying) then                  ! the varying elements' parts alone, added (D-170)
            call add_varying_parts(self, t, y, part, jac)
            return
         end if
         call jacobian_parts(self, part)
      end if
      jac = 0.0_wp
      self%jdtq = 0.0_wp
      call self%kinematics(t, y)
      call self%apply_loads(t)
      do i = 1, size(self%nodes)
         if (self%speed_of(i) /= 0) cycle
         associate (nd => self%nodes(i)%n)
            if (nd%nstates() > 0) call nd%jacobian(t, y, jac, self%jdtq(1:nd%nstates(), i))
         end associate
      end do
      do i = 1, size(self%loads)   ! a load with a speed law: d torque / d omega (D-79)
         na = self%loads(i)%node
         if (self%loads(i)%law%kind == law_none .or. self%speed_of(na) /= 0) cycle
         if (self%nodes(na)%n%nstates() < 2) cycle
         ib = self%nodes(na)%n%offset + 2
         do k = 1, self%nodes(na)%n%nstates()
            row = self%nodes(na)%n%offset + k
            jac(row, ib) = jac(row, ib) + self%jdtq(k, na)*self%loads(i)%slope(t, self%omega(na))
         end do
      end do
      do i = 1, size(self%elements)
         if (present(part)) then
            if (part%vary(i)) cycle
         end if
         call add_element_part(self, i, self%jdtq, jac)
      end do
      ! a node in a rigid cluster (D-81) accelerates with its cluster, exactly: its
      ! row left without partials keeps Newton's updates of joined speeds equal
      do k = 1, self%cn%nc
         if (self%cn%inv_j(k) == 0.0_wp .or. self%cn%m == 0) cycle
         jac(self%nodes(self%cn%node(k))%n%offset + 2, :) = 0.0_wp
      end do
      if (present(constant)) constant = jacobian_constant(self)
      if (present(part)) then
         part%dtq = self%jdtq
         if (part%ok) call varying_entries(self, part)
      end if
   end procedure model_jacobian

   !> Element i's part of the Jacobian added to jac at the kinematics in the
   !> workspace: its torques' partials (`port_partials`) through its nodes'
   !> gains dtq, entry by entry as `element_scatter` lists them.
   subroutine add_element_part(self, i, dtq, jac)
      class(model_t), intent(inout) :: self
      integer, intent(in) :: i
      real(wp), intent(in) :: dtq(:, :)
      real(wp), intent(inout) :: jac(:, :)
      real(wp) :: jt(max_ports, 2*max_ports)
      integer :: sc(8, 5*max_ports*max_ports), m, l
      call element_scatter(self, i, dtq, sc, m)
      if (m == 0) return
      call port_partials(self, i, jt)
      do l = 1, m
         call add_entry(sc(:, l), size(dtq, 2), dtq, jt, size(jac, 1), jac)
      end do
   end subroutine add_element_part

   !> jac(row, ia : ib) += dtq(k, node) * d(torque at port a) / d(angle, speed at port b).
   pure subroutine add_entry(e, nn, dtq, jt, ny, jac)
      integer, intent(in) :: e(8), nn, ny
      real(wp), intent(in) :: dtq(5, nn), jt(max_ports, 2*max_ports)
      real(wp), intent(inout) :: jac(ny, ny)
      jac(e(2), e(3)) = jac(e(2), e(3)) + dtq(e(7), e(8))*jt(e(5), 2*e(6) - 1)
      jac(e(2), e(4)) = jac(e(2), e(4)) + dtq(e(7), e(8))*jt(e(5), 2*e(6))
   end subroutine add_entry

   !> The entries element i adds to the Jacobian, in the order they are added:
   !> for each port a whose node has states, each state k with a gain, each port
   !> b whose node has an angle and a speed: (i, row of k, columns of b's angle
   !> and speed, a, b, k, a's node).
   subroutine element_scatter(self, i, dtq, sc, m)
      class(model_t), intent(in) :: self
      integer, intent(in) :: i
      real(wp), intent(in) :: dtq(:, :)
      integer, intent(inout) :: sc(:, :)
      integer, intent(out) :: m
      real(wp) :: th(max_ports), w(max_ports)
      integer :: a, b, k, na, nb, np, ends(max_ports)
      m = 0
      associate (e => self%elements(i)%e)
         np = e%n_ports()
         if (np == 2) then
            ends(1:2) = [e%left, e%right]
         else
            call port_kinematics(e, self%theta, self%omega, ends, th, w)
         end if
      end associate
      do a = 1, np
         na = ends(a)
         if (self%speed_of(na) /= 0) cycle
         do k = 1, self%nodes(na)%n%nstates()
            if (dtq(k, na) == 0.0_wp) cycle
            do b = 1, np
               nb = ends(b)
               if (self%speed_of(nb) /= 0 .or. self%nodes(nb)%n%nstates() < 2) cycle
               m = m + 1
               sc(:, m) = [i, self%nodes(na)%n%offset + k, self%nodes(nb)%n%offset + 1, self%nodes(nb)%n%offset + 2, &
                           a, b, k, na]
            end do
         end do
      end do
   end subroutine element_scatter

   !> Element i's torques' partials at the kinematics in the workspace: jt(a, 2b - 1 : 2b),
   !> d(torque at port a) / d(angle, speed at port b).
   subroutine port_partials(self, i, jt)
      class(model_t), intent(inout) :: self
      integer, intent(in) :: i
      real(wp), intent(out) :: jt(max_ports, 2*max_ports)
      real(wp) :: th(max_ports), w(max_ports), jt2(2, 4)
      integer :: np, ends(max_ports)
      associate (e => self%elements(i)%e)
         np = e%n_ports()
         if (np == 2) then
            call e%torque_jacobian(self%theta(e%left), self%omega(e%left), self%theta(e%right), &
                                   self%omega(e%right), jt2)
            jt(1:2, 1:4) = jt2            ! (jt(1:2, 1:4) itself is not contiguous: a temporary)
         else                                                  ! an n-port element (D-73)
            call port_kinematics(e, self%theta, self%omega, ends, th, w)
            call e%port_jacobian(th(1:np), w(1:np), jt(1:np, 1:2*np))
         end if
      end associate
   end subroutine port_partials

   !> The varying elements' parts (part%sc, two-ports: part%ok) added to jac at
   !> (t, y), through the node gains part%dtq of the constant part's call (D-170).
   subroutine add_varying_parts(self, t, y, part, jac)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      type(jac_part_t), intent(in) :: part
      real(wp), intent(inout) :: jac(:, :)
      real(wp) :: jt(max_ports, 2*max_ports)
      integer :: i, l, last, ends(2)
      last = 0
      do l = 1, part%nsc
         i = part%sc(1, l)
         if (i /= last) then
            ends = [self%elements(i)%e%left, self%elements(i)%e%right]
            call self%kinematics_part(t, y, ends)
            call port_partials(self, i, jt)
            last = i
         end if
         call add_entry(part%sc(:, l), size(part%dtq, 2), part%dtq, jt, size(jac, 1), jac)
      end do
   end subroutine add_varying_parts

   !> The varying elements' entries (part%sc) from the node gains part%dtq.
   subroutine varying_entries(self, part)
      class(model_t), intent(in) :: self
      type(jac_part_t), intent(inout) :: part
      integer :: i, m, sc(8, 5*max_ports*max_ports)
      if (.not. allocated(part%sc)) allocate (part%sc(8, 4*size(self%elements)))
      part%nsc = 0
      do i = 1, size(part%vary)
         if (.not. part%vary(i)) cycle
         call element_scatter(self, i, part%dtq, sc, m)
         if (part%nsc + m > size(part%sc, 2)) part%sc = reshape(part%sc, [8, 2*(part%nsc + m)], pad=[0])
         part%sc(:, part%nsc + 1:part%nsc + m) = sc(:, 1:m)
         part%nsc = part%nsc + m
      end do
   end subroutine varying_entries

   !> The split of the Jacobian in the current modes (D-170): part%vary, the
   !> elements that are not linear in their mode (`element_constant`); part%ok,
   !> the rest stays constant until the next event and every varying element is
   !> a two-port.
   subroutine jacobian_parts(self, part)
      class(model_t), intent(in) :: self
      type(jac_part_t), intent(inout) :: part
      integer :: i
      if (allocated(part%vary)) then
         if (size(part%vary) /= size(self%elements)) deallocate (part%vary)
      end if
      if (.not. allocated(part%vary)) allocate (part%vary(size(self%elements)))
      part%vary = .false.
      part%ok = rest_constant(self)
      if (.not. part%ok) return                ! (jac then the whole Jacobian)
      do i = 1, size(self%elements)
         part%vary(i) = .not. element_constant(self, i)
      end do
   end subroutine jacobian_parts

   !> Whether the Jacobian is constant between events in the current modes
   !> (D-162): the rest of the train (`rest_constant`) and every element
   !> (`element_constant`).
   pure logical function jacobian_constant(self) result(const)
      class(model_t), intent(in) :: self
      integer :: i
      const = .false.
      if (.not. rest_constant(self)) return
      do i = 1, size(self%elements)
         if (.not. element_constant(self, i)) return
      end do
      const = .true.
   end function jacobian_constant

   !> Every node with states a plain inertia (or held), no load with a speed
   !> law, no kinematic constraint, no n-port element (the hot-path tables built).
   pure logical function rest_constant(self) result(const)
      class(model_t), intent(in) :: self
      integer :: i
      const = .false.
      if (self%nport .or. .not. (allocated(self%fn) .and. allocated(self%fe) .and. allocated(self%fh))) return
      if (allocated(self%spd_loads)) then
         if (size(self%spd_loads) > 0) return
      end if
      if (allocated(self%cn)) then
         if (self%cn%nc > 0 .or. size(self%cn%cand) > 0) return
      end if
      do i = 1, size(self%nodes)
         if (self%speed_of(i) /= 0) cycle
         if (self%fn(i)%kind /= nk_plain .and. self%nodes(i)%n%nstates() > 0) return
      end do
      const = .true.
   end function rest_constant

   !> Element i is linear in its mode: a checked linear spring or in a checked
   !> hot form (D-35) that is linear in its mode (a clearance open, or closed
   !> with the linear law, its stiffness factor constant until the next event,
   !> no no_tension clip). yang_sun, a varying mesh stiffness, tooth friction,
   !> an element without a hot form are not (the caller checks the tables exist).
   pure logical function element_constant(self, i) result(const)
      class(model_t), intent(in) :: self
      integer, intent(in) :: i
      const = .true.
      if (self%fe(i)%linear) return
      if (self%fh(i)%kind == hf_open) return
      if (self%fh(i)%kind == hf_linear .and. .not. self%fh(i)%no_tension) return
      const = .false.
   end function element_constant

   module procedure closed_speed_ratio
      real(wp) :: k(2, 2), c(2, 2)
      call model%elements(ie)%e%linearise(lin_closed, 1.0_wp, 1.0_wp, k, c)
      rho = 0.0_wp
      if (abs(k(2, 2)) > 0.0_wp) then
         rho = -k(1, 2)/k(2, 2)
      else if (abs(c(2, 2)) > 0.0_wp) then
         rho = -c(1, 2)/c(2, 2)
      end if
   end procedure closed_speed_ratio

   module procedure rigid_speeds
      integer :: pass, j, l, r
      real(wp) :: rho
      logical :: changed
      allocate (w(size(model%nodes)), known(size(model%nodes)))
      w = 0.0_wp
      known = .false.
      w(ref) = w_ref
      known(ref) = .true.
      loop_el = 0
      do pass = 1, size(model%elements) + 1
         changed = .false.
         do j = 1, size(model%elements)
            l = model%elements(j)%e%left
            r = model%elements(j)%e%right
            if (model%nodes(l)%n%is_fixed() .or. model%nodes(r)%n%is_fixed()) cycle
            if (.not. (known(l) .or. known(r))) cycle
            rho = closed_speed_ratio(model, j)
            if (rho == 0.0_wp) cycle
            if (known(l) .and. known(r)) then
               if (loop_el == 0 .and. abs(w(r) - rho*w(l)) > 1.0e-9_wp*max(abs(w(r)), abs(w(l)))) loop_el = j
            else if (known(l)) then
               w(r) = rho*w(l)
               known(r) = .true.
               changed = .true.
            else
               w(l) = w(r)/rho
               known(l) = .true.
               changed = .true.
            end if
         end do
         if (.not. changed) exit
      end do
   end procedure rigid_speeds
end submodule trainsim_model_linear
