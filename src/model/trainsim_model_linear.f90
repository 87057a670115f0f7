!> The model's linearisation: the Jacobian of the right-hand side and the
!> rigid motion of the train with its clearances closed.
!> Each `module procedure` here is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_linear
   use trainsim_element, only: lin_closed, max_ports
   use trainsim_ports, only: port_kinematics
   use trainsim_element, only: hf_open, hf_linear
   use trainsim_model_families, only: nk_plain
   implicit none

contains

   module procedure model_jacobian
      real(wp) :: dtq(5, size(self%nodes)), jt(max_ports, 2*max_ports), th(max_ports), w(max_ports), jt2(2, 4)
      integer :: i, a, b, k, na, nb, row, ia, ib, np
      integer :: ends(max_ports)
      jac = 0.0_wp
      dtq = 0.0_wp
      call self%kinematics(t, y)
      call self%apply_loads(t)
      do i = 1, size(self%nodes)
         if (self%speed_of(i) /= 0) cycle
         associate (nd => self%nodes(i)%n)
            if (nd%nstates() > 0) call nd%jacobian(t, y, jac, dtq(1:nd%nstates(), i))
         end associate
      end do
      do i = 1, size(self%loads)   ! a load with a speed law: d torque / d omega (D-79)
         na = self%loads(i)%node
         if (self%loads(i)%law%kind == law_none .or. self%speed_of(na) /= 0) cycle
         if (self%nodes(na)%n%nstates() < 2) cycle
         ib = self%nodes(na)%n%offset + 2
         do k = 1, self%nodes(na)%n%nstates()
            row = self%nodes(na)%n%offset + k
            jac(row, ib) = jac(row, ib) + dtq(k, na)*self%loads(i)%slope(t, self%omega(na))
         end do
      end do
      do i = 1, size(self%elements)
         associate (e => self%elements(i)%e)
            np = e%n_ports()
            if (np == 2) then
               ends(1:2) = [e%left, e%right]
               call e%torque_jacobian(self%theta(e%left), self%omega(e%left), self%theta(e%right), &
                                      self%omega(e%right), jt2)
               jt(1:2, 1:4) = jt2            ! (jt(1:2, 1:4) itself is not contiguous: a temporary)
            else                                                  ! an n-port element (D-73)
               call port_kinematics(e, self%theta, self%omega, ends, th, w)
               call e%port_jacobian(th(1:np), w(1:np), jt(1:np, 1:2*np))
            end if
            do a = 1, np
               na = ends(a)
               if (self%speed_of(na) /= 0) cycle
               do k = 1, self%nodes(na)%n%nstates()
                  if (dtq(k, na) == 0.0_wp) cycle
                  row = self%nodes(na)%n%offset + k
                  do b = 1, np
                     nb = ends(b)
                     if (self%speed_of(nb) /= 0 .or. self%nodes(nb)%n%nstates() < 2) cycle
                     ia = self%nodes(nb)%n%offset + 1
                     ib = self%nodes(nb)%n%offset + 2
                     jac(row, ia) = jac(row, ia) + dtq(k, na)*jt(a, 2*b - 1)
                     jac(row, ib) = jac(row, ib) + dtq(k, na)*jt(a, 2*b)
                  end do
               end do
            end do
         end associate
      end do
      ! a node in a rigid cluster (D-81) accelerates with its cluster, exactly: its
      ! row left without partials keeps Newton's updates of joined speeds equal
      do k = 1, self%cn%nc
         if (self%cn%inv_j(k) == 0.0_wp .or. self%cn%m == 0) cycle
         jac(self%nodes(self%cn%node(k))%n%offset + 2, :) = 0.0_wp
      end do
      if (present(constant)) constant = jacobian_constant(self)
   end procedure model_jacobian

   !> Whether the Jacobian is constant between events in the current modes
   !> (D-162): every node with states a plain inertia (or held), no load with
   !> a speed law, no kinematic constraint, no n-port element, and every
   !> element a checked linear spring or in a checked hot form that is linear
   !> in its mode (a clearance open, or closed with the linear law, its
   !> stiffness factor constant until the next event, no no_tension clip).
   !> Anything else (yang_sun, a varying mesh stiffness, tooth friction, an
   !> element without a hot form) says .false.
   pure logical function jacobian_constant(self) result(const)
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
      do i = 1, size(self%elements)
         if (self%fe(i)%linear) cycle
         if (self%fh(i)%kind == hf_open) cycle
         if (self%fh(i)%kind == hf_linear .and. .not. self%fh(i)%no_tension) cycle
         return
      end do
      const = .true.
   end function jacobian_constant

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
