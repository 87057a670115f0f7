!> The model: nodes joined by elements, external torques, prescribed speeds
!> and run settings. A model is a plain value (no global state, no pointers):
!> copy it to re-parameterise a run. The right-hand side, the guards and the
!> mode updates below are the only code the integrators call; they do no
!> allocation, I/O or string work.
module trainsim_model
   use trainsim_kinds, only: wp
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_signal, only: signal_t
   use trainsim_node, only: node_slot_t
   use trainsim_element, only: element_slot_t
   use trainsim_event, only: event_t, max_update_events
   implicit none
   private

   public :: model_t, run_settings_t, load_t

   !> Run conditions from the &run group.
   type :: run_settings_t
      real(wp) :: t_start = 0.0_wp, t_end = 0.0_wp, dt = 0.0_wp
      real(wp) :: output_interval = 0.0_wp      !< 0: every step
      character(len=:), allocatable :: integrator  !< 'rk4', 'rk4-thesis', 'cvode-bdf', 'cvode-adams', 'arkode-dp', 'arkode-verner'
      character(len=:), allocatable :: output      !< HDF5 file name
      real(wp) :: rtol = 1.0e-8_wp
      real(wp) :: atol_angle = 1.0e-10_wp, atol_speed = 1.0e-8_wp, atol_current = 1.0e-8_wp
      real(wp) :: max_step = 0.0_wp             !< CVODE maximum step (0: from the highest frequency)
      real(wp) :: event_tol = 0.0_wp            !< event time tolerance (0: 1e-9 dt)
      real(wp) :: settle_time = 0.0_wp          !< metrics ignore t < t_start + settle_time
      logical :: track_energy = .true.          !< integrate dissipated energy and work input
      logical :: keep_series = .false.          !< keep displacement series in memory (sweeps)
      integer :: compression = 0                !< zlib level of the HDF5 history (0: none)
      logical :: analytic_jacobian = .true.     !< CVODE BDF: model%jacobian, else difference quotients
      logical :: preload = .false.              !< initial_state = 'preload': angles from the static wind-up
   end type run_settings_t

   !> An external torque on a node.
   type :: load_t
      integer :: node = 0
      type(signal_t) :: torque
   end type load_t

   type :: model_t
      character(len=:), allocatable :: title, deck_file, deck_text
      type(units_t) :: units
      type(run_settings_t) :: run
      type(node_slot_t), allocatable :: nodes(:)
      type(element_slot_t), allocatable :: elements(:)
      type(load_t), allocatable :: loads(:)
      type(signal_t), allocatable :: speeds(:)   !< prescribed-speed profiles
      integer, allocatable :: speed_of(:)        !< per node: index into speeds, 0 if free
      integer :: n_states = 0                    !< physical states
      integer :: n_y = 0                         !< + 2 energy-accounting states if tracked
      integer :: n_guards = 0
      integer, allocatable :: guard_offset(:)    !< per element
      real(wp) :: energy0 = 0.0_wp               !< stored energy at t_start
      logical :: any_needs_loads = .false.       !< some element reads its nodes' external loads
      ! workspace (sized once in `finalize`)
      real(wp), allocatable :: theta(:), omega(:), torque(:)
   contains
      procedure :: finalize => model_finalize
      procedure :: initial_state => model_initial_state
      procedure :: kinematics => model_kinematics
      procedure :: rhs => model_rhs
      procedure :: jacobian => model_jacobian
      procedure :: apply_loads => model_apply_loads
      procedure :: breakpoints => model_breakpoints
      procedure :: guards => model_guards
      procedure :: init_modes => model_init_modes
      procedure :: apply_events => model_apply_events
      procedure :: any_contact => model_any_contact
      procedure :: stored_energy => model_stored_energy
      procedure :: node_index => model_node_index
      procedure :: is_held => model_is_held
      procedure :: state_label => model_state_label
   end type model_t

contains

   !> Lay out the state vector and size the workspace; call after nodes,
   !> elements, loads and speeds are set, and again after re-parameterising a
   !> copy in a way that changes the layout (e.g. run%track_energy).
   subroutine model_finalize(self)
      class(model_t), intent(inout) :: self
      integer :: i, nn, ne
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
      do i = 1, ne
         if (self%elements(i)%e%needs_loads) self%any_needs_loads = .true.
      end do
      if (allocated(self%guard_offset)) deallocate (self%guard_offset)
      allocate (self%guard_offset(ne))
      self%n_guards = 0
      do i = 1, ne
         self%guard_offset(i) = self%n_guards
         self%n_guards = self%n_guards + self%elements(i)%e%n_guards()
      end do
      if (allocated(self%theta)) deallocate (self%theta, self%omega, self%torque)
      allocate (self%theta(nn), self%omega(nn), self%torque(nn))
      self%theta = 0.0_wp; self%omega = 0.0_wp; self%torque = 0.0_wp
   end subroutine model_finalize

   !> Whether node i has a prescribed speed.
   pure logical function model_is_held(self, i) result(held)
      class(model_t), intent(in) :: self
      integer, intent(in) :: i
      held = self%speed_of(i) /= 0
   end function model_is_held

   !> Index of the node with this id (0 if none).
   pure integer function model_node_index(self, id) result(idx)
      class(model_t), intent(in) :: self
      character(len=*), intent(in) :: id
      integer :: i
      idx = 0
      do i = 1, size(self%nodes)
         if (self%nodes(i)%n%id == id) then
            idx = i
            return
         end if
      end do
   end function model_node_index

   !> The initial state vector (energy states zero).
   subroutine model_initial_state(self, y)
      class(model_t), intent(inout) :: self
      real(wp), allocatable, intent(out) :: y(:)
      integer :: i
      allocate (y(self%n_y))
      y = 0.0_wp
      do i = 1, size(self%nodes)
         if (self%speed_of(i) == 0) call self%nodes(i)%n%initial_state(y)
      end do
   end subroutine model_initial_state

   !> Node angles and speeds at (t, y) into self%theta, self%omega.
   subroutine model_kinematics(self, t, y)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      integer :: i, s
      do i = 1, size(self%nodes)
         s = self%speed_of(i)
         if (s == 0) then
            call self%nodes(i)%n%kinematics(y, self%theta(i), self%omega(i))
         else
            self%theta(i) = self%nodes(i)%n%theta0 + self%speeds(s)%integral(t)
            self%omega(i) = self%speeds(s)%value(t)
         end if
      end do
   end subroutine model_kinematics

   !> dy/dt at (t, y). Leaves node kinematics and net node torques in the workspace.
   subroutine model_rhs(self, t, y, dydt)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: dydt(:)
      integer :: i, l, r, s
      real(wp) :: tl, tr, pdiss, pin
      call self%kinematics(t, y)
      call self%apply_loads(t)
      do i = 1, size(self%elements)
         l = self%elements(i)%e%left
         r = self%elements(i)%e%right
         call self%elements(i)%e%torques(self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr)
         self%torque(l) = self%torque(l) + tl
         self%torque(r) = self%torque(r) + tr
      end do
      do i = 1, size(self%nodes)
         if (self%speed_of(i) == 0) call self%nodes(i)%n%derivatives(t, y, self%torque(i), dydt)
      end do
      if (.not. self%run%track_energy) return
      pdiss = 0.0_wp
      pin = 0.0_wp
      do i = 1, size(self%nodes)
         s = self%speed_of(i)
         if (s == 0) then
            pdiss = pdiss + self%nodes(i)%n%dissipation_power(y)
            pin = pin + self%nodes(i)%n%input_power(t, y)
         else
            ! torque the drive must supply: J*alpha minus what acts on the node
            pin = pin + (self%nodes(i)%n%inertia()*self%speeds(s)%derivative(t) - self%torque(i))*self%omega(i)
         end if
      end do
      do i = 1, size(self%loads)
         l = self%loads(i)%node
         if (self%speed_of(l) == 0) pin = pin + self%loads(i)%torque%value(t)*self%omega(l)
      end do
      do i = 1, size(self%elements)
         l = self%elements(i)%e%left
         r = self%elements(i)%e%right
         pdiss = pdiss + self%elements(i)%e%dissipation_power(self%theta(l), self%omega(l), self%theta(r), self%omega(r))
         if (self%elements(i)%e%supplies_power) then
            pin = pin + self%elements(i)%e%input_power(self%theta(l), self%omega(l), self%theta(r), self%omega(r))
         end if
      end do
      dydt(self%n_states + 1) = pdiss
      dydt(self%n_states + 2) = pin
   end subroutine model_rhs

   !> External load torques at t into self%torque, and published to the
   !> elements that read their nodes' loads.
   subroutine model_apply_loads(self, t)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      integer :: i, l
      self%torque = 0.0_wp
      do i = 1, size(self%loads)
         l = self%loads(i)%node
         self%torque(l) = self%torque(l) + self%loads(i)%torque%value(t)
      end do
      if (.not. self%any_needs_loads) return
      do i = 1, size(self%elements)
         if (.not. self%elements(i)%e%needs_loads) cycle
         self%elements(i)%e%ext_left = self%torque(self%elements(i)%e%left)
         self%elements(i)%e%ext_right = self%torque(self%elements(i)%e%right)
      end do
   end subroutine model_apply_loads

   !> Dense Jacobian d(dydt)/dy at (t, y) in the current modes, assembled from
   !> the nodes' own blocks and the elements' torque partials. The rows of the
   !> energy-accounting states are left zero: those states feed nothing back,
   !> so Newton's iteration stays exact for every other state.
   subroutine model_jacobian(self, t, y, jac)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: jac(:, :)
      real(wp) :: dtq(3, size(self%nodes)), jt(2, 4)
      integer :: i, a, b, k, na, nb, row, ia, ib
      integer :: ends(2)
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
      do i = 1, size(self%elements)
         associate (e => self%elements(i)%e)
            ends = [e%left, e%right]
            call e%torque_jacobian(self%theta(e%left), self%omega(e%left), self%theta(e%right), &
                                   self%omega(e%right), jt)
            do a = 1, 2
               na = ends(a)
               if (self%speed_of(na) /= 0) cycle
               do k = 1, self%nodes(na)%n%nstates()
                  if (dtq(k, na) == 0.0_wp) cycle
                  row = self%nodes(na)%n%offset + k
                  do b = 1, 2
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
   end subroutine model_jacobian

   !> All elements' guards at (t, y) (a mode is valid while every guard is >= 0).
   subroutine model_guards(self, t, y, g)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: g(:)
      integer :: i, l, r, o, n
      if (self%n_guards == 0) return
      call self%kinematics(t, y)
      do i = 1, size(self%elements)
         n = self%elements(i)%e%n_guards()
         if (n == 0) cycle
         l = self%elements(i)%e%left
         r = self%elements(i)%e%right
         o = self%guard_offset(i)
         call self%elements(i)%e%guards(self%theta(l), self%omega(l), self%theta(r), self%omega(r), g(o + 1:o + n))
      end do
   end subroutine model_guards

   !> Set every element's discrete mode from the state at t_start.
   subroutine model_init_modes(self, t, y)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      integer :: i, l, r
      call self%kinematics(t, y)
      do i = 1, size(self%elements)
         l = self%elements(i)%e%left
         r = self%elements(i)%e%right
         call self%elements(i)%e%init_mode(self%theta(l), self%omega(l), self%theta(r), self%omega(r))
      end do
      self%energy0 = self%stored_energy(t, y)
   end subroutine model_init_modes

   !> Update the modes of the elements whose guards fired; the events that
   !> result are appended to events(nev+1:) (with the time and the element
   !> index filled in; the array grows when full, so no event is dropped).
   !> A mode change that changes the stored energy (a mesh-stiffness switch
   !> while teeth are loaded) is work done on the train: it is booked to the
   !> work-input state, so that the energy balance keeps closing.
   subroutine model_apply_events(self, t, y, fired, events, nev)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      real(wp), intent(inout) :: y(:)
      logical, intent(in) :: fired(:)
      type(event_t), allocatable, intent(inout) :: events(:)
      integer, intent(inout) :: nev
      integer :: i, l, r, o, n, k, m
      type(event_t) :: local(max_update_events)
      type(event_t), allocatable :: grown(:)
      real(wp) :: e_before
      e_before = 0.0_wp   ! read below only if track_energy; set so -Wmaybe-uninitialized need not prove that
      if (self%run%track_energy) e_before = self%stored_energy(t, y)
      call self%kinematics(t, y)
      do i = 1, size(self%elements)
         n = self%elements(i)%e%n_guards()
         if (n == 0) cycle
         o = self%guard_offset(i)
         if (.not. any(fired(o + 1:o + n))) cycle
         l = self%elements(i)%e%left
         r = self%elements(i)%e%right
         call self%elements(i)%e%update_mode(t, self%theta(l), self%omega(l), self%theta(r), self%omega(r), &
                                             fired(o + 1:o + n), local, m)
         if (nev + m > size(events)) then
            allocate (grown(max(2*size(events), nev + m, 16)))
            grown(1:nev) = events(1:nev)
            call move_alloc(grown, events)
         end if
         do k = 1, m
            nev = nev + 1
            events(nev) = local(k)
            events(nev)%t = t
            events(nev)%element = i
         end do
      end do
      if (self%run%track_energy) y(self%n_states + 2) = y(self%n_states + 2) + self%stored_energy(t, y) - e_before
   end subroutine model_apply_events

   !> Whether any clearance element is in contact (thesis-mode step control).
   pure logical function model_any_contact(self) result(c)
      class(model_t), intent(in) :: self
      integer :: i
      c = .false.
      do i = 1, size(self%elements)
         if (self%elements(i)%e%in_contact()) then
            c = .true.
            return
         end if
      end do
   end function model_any_contact

   !> Kinetic + elastic (+ magnetic) energy at (t, y).
   real(wp) function model_stored_energy(self, t, y) result(e)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      integer :: i, l, r
      call self%kinematics(t, y)
      e = 0.0_wp
      do i = 1, size(self%nodes)
         if (self%speed_of(i) == 0) then
            e = e + self%nodes(i)%n%stored_energy(y)
         else
            e = e + 0.5_wp*self%nodes(i)%n%inertia()*self%omega(i)**2
         end if
      end do
      do i = 1, size(self%elements)
         l = self%elements(i)%e%left
         r = self%elements(i)%e%right
         e = e + self%elements(i)%e%potential_energy(self%theta(l), self%theta(r))
      end do
   end function model_stored_energy
   !> Sorted times strictly inside (t0, t1) where a load, a prescribed speed or a
   !> node's own input (motor voltage) jumps or kinks: integrators end steps there.
   subroutine model_breakpoints(model, t0, t1, bp)
      class(model_t), intent(in) :: model
      real(wp), intent(in) :: t0, t1
      real(wp), allocatable, intent(out) :: bp(:)
      real(wp), allocatable :: b(:)
      integer :: i
      allocate (bp(0))
      do i = 1, size(model%loads)
         call model%loads(i)%torque%breakpoints(b)
         bp = [bp, b]
      end do
      do i = 1, size(model%speeds)
         call model%speeds(i)%breakpoints(b)
         bp = [bp, b]
      end do
      do i = 1, size(model%nodes)
         call model%nodes(i)%n%breakpoints(b)
         bp = [bp, b]
      end do
      bp = pack(bp, bp > t0 .and. bp < t1)
      call sort_unique(bp, 1.0e-12_wp*max(abs(t0), abs(t1), 1.0e-300_wp))
   end subroutine model_breakpoints

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

   !> For messages: "state 2 of node 'gear1' (gear1.speed)" for state index s.
   function model_state_label(model, s) result(label)
      class(model_t), intent(in) :: model
      integer, intent(in) :: s
      character(len=:), allocatable :: label
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
   end function model_state_label
end module trainsim_model
