!> The model's assembly and state layout: the state vector's offsets, the
!> workspace, node kinematics, breakpoints and state labels.
!> Each `module procedure` here is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_layout
   use trainsim_strings, only: str
   use trainsim_model_families, only: nk_plain, nk_held
   implicit none

contains

   module procedure model_finalize
      integer :: i, nn, ne, ng
      nn = size(self%nodes)
      ne = size(self%elements)
      if (.not. allocated(self%speed_of)) then
         allocate (self%speed_of(nn))
         self%speed_of = 0
      end if
      if (.not. allocated(self%loads)) allocate (self%loads(0))
      if (.not. allocated(self%speeds)) allocate (self%speeds(0))
      self%n_states = 0
      do i = 1, nn
         self%nodes(i)%n%offset = self%n_states
         if (self%speed_of(i) == 0) self%n_states = self%n_states + self%nodes(i)%n%nstates()
      end do
      self%n_y = self%n_states
      if (self%run%track_energy) self%n_y = self%n_states + 2
      self%any_needs_loads = .false.
      self%nport = .false.
      do i = 1, ne
         if (self%elements(i)%e%needs_loads) self%any_needs_loads = .true.
         if (self%elements(i)%e%n_ports() > 2) self%nport = .true.
      end do
      if (allocated(self%guard_offset)) deallocate (self%guard_offset)
      allocate (self%guard_offset(ne))
      self%n_guards = 0
      ng = 0
      do i = 1, ne
         self%guard_offset(i) = self%n_guards
         self%n_guards = self%n_guards + self%elements(i)%e%n_guards()
         ng = max(ng, self%elements(i)%e%n_guards())
      end do
      ! one element's guards at a time (element_guard, constraints_settle): as
      ! many as the element with the most declares (a plug-in may declare any number)
      if (allocated(self%g_el)) deallocate (self%g_el, self%fired_el)
      allocate (self%g_el(max(ng, 1)), self%fired_el(max(ng, 1)))
      if (allocated(self%theta)) deallocate (self%theta, self%omega, self%torque)
      allocate (self%theta(nn), self%omega(nn), self%torque(nn))
      self%theta = 0.0_wp; self%omega = 0.0_wp; self%torque = 0.0_wp
      if (allocated(self%el_torque)) deallocate (self%el_torque, self%el_disp, self%el_force, self%el_pe)
      ! (one column more, always zero: the second torque of a plain inertia with
      ! one element torque in the stage kernel's node rows, D-95)
      allocate (self%el_torque(2, ne + 1), self%el_disp(ne), self%el_force(ne), self%el_pe(ne))
      self%el_torque = 0.0_wp; self%el_disp = 0.0_wp; self%el_force = 0.0_wp; self%el_pe = 0.0_wp
      ! a block of steps (D-38): at most 128 (D-147), its columns 32 KiB at most
      ! (they stay in the first-level cache; a long train gains little from blocks,
      ! its steps are long already, and measured slower with columns beyond the cache)
      associate (b => self%blk)
         b%cap = max(1, min(128, 32768/(8*(3*ne + nn + 4))))
         b%col = 0
         b%n = 0
         if (allocated(b%t)) deallocate (b%t, b%disp, b%force, b%torque, b%omega, b%stored, b%elastic, b%work)
         allocate (b%t(b%cap), b%disp(ne, b%cap), b%force(ne, b%cap), b%torque(ne, b%cap), b%omega(nn, b%cap), &
                   b%stored(b%cap), b%elastic(b%cap), b%work(2, b%cap))
         b%t = 0.0_wp; b%disp = 0.0_wp; b%force = 0.0_wp; b%torque = 0.0_wp; b%omega = 0.0_wp
         b%stored = 0.0_wp; b%elastic = 0.0_wp; b%work = 0.0_wp
      end associate
      call self%build_fast_path()
   end procedure model_finalize

   module procedure model_is_held
      held = self%speed_of(i) /= 0
   end procedure model_is_held

   module procedure model_node_index
      integer :: i
      idx = 0
      do i = 1, size(self%nodes)
         if (self%nodes(i)%n%id == id) then
            idx = i
            return
         end if
      end do
   end procedure model_node_index

   module procedure model_initial_state
      integer :: i
      allocate (y(self%n_y))
      y = 0.0_wp
      do i = 1, size(self%nodes)
         if (self%speed_of(i) == 0) call self%nodes(i)%n%initial_state(y)
      end do
   end procedure model_initial_state

   module procedure model_kinematics
      call kinematics_all(self, t, y)
   end procedure model_kinematics

   module procedure model_kinematics_part
      integer :: k
      real(wp) :: th, om
      self%ws_step_end = .false.
      do k = 1, size(nodes)
         call node_kinematics(self, nodes(k), t, y, th, om)
         self%theta(nodes(k)) = th
         self%omega(nodes(k)) = om
      end do
   end procedure model_kinematics_part

   module procedure kinematics_all
      integer :: i, o
      self%ws_step_end = .false.
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
         end associate
      end do
   end procedure kinematics_all

   module procedure node_kinematics
      integer :: s
      select case (self%fn(i)%kind)
      case (nk_plain)
         th = y(self%fn(i)%off + 1)
         om = y(self%fn(i)%off + 2)
      case (nk_held)
         if (self%fn(i)%const_speed) then
            th = self%fn(i)%theta0 + self%fn(i)%w*t
            om = self%fn(i)%w
         else
            s = self%speed_of(i)
            th = self%nodes(i)%n%theta0 + self%speeds(s)%integral(t)
            om = self%speeds(s)%value(t)
         end if
      case default
         call self%nodes(i)%n%kinematics(y, th, om)
      end select
   end procedure node_kinematics

   module procedure model_breakpoints
      real(wp), allocatable :: b(:)
      integer :: i
      allocate (bp(0))
      do i = 1, size(model%loads)
         call model%loads(i)%torque%breakpoints(b)
         if (size(b) > 0) bp = [bp, b]   ! (most have none: no copy of bp a node)
      end do
      do i = 1, size(model%speeds)
         call model%speeds(i)%breakpoints(b)
         if (size(b) > 0) bp = [bp, b]   ! (most have none: no copy of bp a node)
      end do
      do i = 1, size(model%nodes)
         call model%nodes(i)%n%breakpoints(b)
         if (size(b) > 0) bp = [bp, b]   ! (most have none: no copy of bp a node)
      end do
      do i = 1, size(model%elements)                 ! (an engagement table's knots: D-87)
         call model%elements(i)%e%breakpoints(b)
         if (size(b) > 0) bp = [bp, b]   ! (most have none: no copy of bp a node)
      end do
      bp = pack(bp, bp > t0 .and. bp < t1)
      call sort_unique(bp, 1.0e-12_wp*max(abs(t0), abs(t1), 1.0e-300_wp))
   end procedure model_breakpoints

   !> Insertion sort, dropping values within tol of the previous one.
   pure subroutine sort_unique(a, tol)
      real(wp), allocatable, intent(inout) :: a(:)
      real(wp), intent(in) :: tol
      integer :: i, j, n
      real(wp) :: x
      do i = 2, size(a)
         x = a(i)
         j = i - 1
         do while (j >= 1)
            if (a(j) <= x) exit
            a(j + 1) = a(j)
            j = j - 1
         end do
         a(j + 1) = x
      end do
      if (size(a) < 2) return
      n = 1
      do i = 2, size(a)
         if (a(i) - a(n) > tol) then
            n = n + 1
            a(n) = a(i)
         end if
      end do
      a = a(1:n)
   end subroutine sort_unique

   module procedure model_state_label
      type(string_t), allocatable :: names(:)
      integer :: i, o, ns
      label = 'state '//str(s)
      if (model%run%track_energy) then
         if (s == model%n_states + 1) label = 'state '//str(s)//' (energy.dissipated, the dissipated-energy integral)'
         if (s == model%n_states + 2) label = 'state '//str(s)//' (energy.input, the work-input integral)'
      end if
      do i = 1, size(model%nodes)
         if (model%speed_of(i) /= 0) cycle
         ns = model%nodes(i)%n%nstates()
         o = model%nodes(i)%n%offset
         if (s > o .and. s <= o + ns) then
            allocate (names(ns))
            call model%nodes(i)%n%state_names(names)
            label = 'state '//str(s - o)//" of node '"//model%nodes(i)%n%id//"'"
            if (allocated(names(s - o)%s)) label = label//' ('//names(s - o)%s//')'
            return
         end if
      end do
   end procedure model_state_label

   module procedure settle_budget
      span = r%settle_max_time
      if (span == 0.0_wp) span = max(1000.0_wp*r%settle_period, r%settle_time)
   end procedure settle_budget
end submodule trainsim_model_layout
