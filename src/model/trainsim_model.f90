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
   use trainsim_node, only: node_t, node_slot_t
   use trainsim_element, only: element_t, element_slot_t, lin_closed, hot_form_t, hf_none, hf_open, hf_yang_sun, &
                               hf_linear, hg_none, hg_faces, hg_faces_zone, max_ports
   use trainsim_event, only: event_t, max_update_events
   implicit none
   private

   public :: model_t, run_settings_t, load_t, closed_speed_ratio, rigid_speeds, settle_budget

   !> Kinds of node on the hot path.
   integer, parameter :: nk_other = 0, nk_plain = 1, nk_held = 2

   !> A node on the hot path: its kind, state offset and, for a plain inertia,
   !> J and d; for a held node its inertia J and, with a constant speed, that speed.
   type :: fast_node_t
      integer :: kind = nk_other
      integer :: off = 0
      logical :: const_speed = .false.
      real(wp) :: j = 1.0_wp, d = 0.0_wp, w = 0.0_wp, theta0 = 0.0_wp
      real(wp) :: load0 = 0.0_wp   !< sum of its loads if all are constant (else 0: summed at t)
   end type fast_node_t

   !> An element on the hot path: its nodes and, for a linear spring, k, c, r1, r2.
   type :: fast_element_t
      integer :: l = 0, r = 0, ng = 0
      logical :: linear = .false.
      real(wp) :: k = 0.0_wp, c = 0.0_wp, r1 = 1.0_wp, r2 = 1.0_wp
      !> The form of a linear spring in `rhs_simple` (lf_*), and the state index
      !> of the angle of its left and right node if a plain inertia, else 0
      !> (`rhs_simple` and `guards` read those straight from y).
      integer :: form = 0, yl = 0, yr = 0
      !> The form of the element's hot form (D-35, the record in the model's fh)
      !> for its guards (hg_*); its torque form is `form` (lf_open, lf_yang_sun,
      !> lf_cl_linear).
      integer :: gform = hg_none
      !> The hot form's elastic energy (`hot_potential`) and its status (the
      !> displacement and signed force `rhs_simple` leaves in el_disp, el_force,
      !> the contact its mode) agree bit for bit with the element's own
      !> `potential_energy` and `status` at `refresh_hot`'s probe states (D-36).
      logical :: hot_pe = .false., hot_status = .false.
      !> The element's elastic energy is neither a linear spring's nor its hot
      !> form's (counted in n_cold: `rhs_simple` then leaves no energy).
      logical :: cold = .true.
   end type fast_element_t

   !> An element with guards, as `model_guards` reads it: where its guards are
   !> its hot form's (D-35) and both its nodes are plain inertias (form 1:
   !> faces, 2: faces and the zone window; 0: asked as before), the record's
   !> guard fields and the state indices of its nodes' angles, in one place
   !> (refreshed with the hot form, `refresh_hot`).
   type :: guard_row_t
      integer :: form = 0, o = 0, yl = 0, yr = 0, mode = 0
      logical :: lo_open = .false.
      real(wp) :: r1 = 1.0_wp, r2 = 1.0_wp, b = 0.0_wp, th_lo = 0.0_wp, th_hi = 0.0_wp
   end type guard_row_t

   !> Forms of a linear spring in `rhs_simple`: the terms that are exactly zero
   !> or exactly a factor 1 are left out (the same values, fewer operations on
   !> the RHS's critical path): general, undamped (c = 0), undamped with unit
   !> lever arms (a shaft: c = 0, r1 = r2 = 1).
   integer, parameter :: lf_general = 1, lf_undamped = 2, lf_unit = 3
   !> Forms of a clearance element in its current mode (its hot form, D-35):
   !> open, closed with the yang_sun law, closed with the linear law.
   integer, parameter :: lf_open = 4, lf_yang_sun = 5, lf_cl_linear = 6

   !> A load on the hot path: its node and, when constant, its value.
   type :: fast_load_t
      integer :: node = 0
      logical :: const = .false.
      real(wp) :: v = 0.0_wp
   end type fast_load_t

   !> Run conditions from the &run group.
   type :: run_settings_t
      real(wp) :: t_start = 0.0_wp, t_end = 0.0_wp, dt = 0.0_wp
      real(wp) :: output_interval = 0.0_wp      !< 0: every step
      character(len=:), allocatable :: integrator  !< 'rk4', 'rk4-thesis', 'cvode-bdf', 'cvode-adams', 'arkode-dp', 'arkode-verner'
      character(len=:), allocatable :: output      !< HDF5 file name
      real(wp) :: rtol = 1.0e-8_wp
      real(wp) :: atol_angle = 1.0e-14_wp, atol_speed = 1.0e-8_wp, atol_current = 1.0e-8_wp
      real(wp) :: max_step = 0.0_wp             !< CVODE maximum step (0: from the highest frequency)
      real(wp) :: event_tol = 0.0_wp            !< event time tolerance (0: 1e-9 dt)
      real(wp) :: settle_time = 0.0_wp          !< metrics ignore t < t_start + settle_time
      !> settle until periodic (docs/sweeps.md#settling): 0 off; else the state sampled
      !> every settle_period must repeat to this relative tolerance (or with k <= 8
      !> periods) before the metrics start, within settle_max_time after t_start
      real(wp) :: settle_tol = 0.0_wp
      real(wp) :: settle_period = 0.0_wp        !< s (0: the first gear pair's mesh period at t_start)
      real(wp) :: settle_max_time = 0.0_wp      !< s (0: 1000 settle periods)
      logical :: track_energy = .true.          !< integrate dissipated energy and work input
      !> a run whose energy residual ends above this fraction of its energy
      !> scale fails (exit 1, D-55); 0: no such check
      real(wp) :: energy_check = 0.1_wp
      logical :: keep_series = .false.          !< keep displacement series in memory (sweeps)
      logical :: keep_events = .false.          !< keep the whole event table in the result (else streamed to the sink only)
      integer :: compression = 0                !< zlib level of the HDF5 history (0: none)
      logical :: analytic_jacobian = .true.     !< CVODE BDF: model%jacobian, else difference quotients
      logical :: preload = .false.              !< initial_state = 'preload': angles from the static wind-up
      !> plain steps in blocks where the output allows (D-38); .false.: step by
      !> step (a switch for comparing the two paths; not a deck key)
      logical :: step_blocks = .true.
   end type run_settings_t

   !> An external torque on a node.
   type :: load_t
      integer :: node = 0
      type(signal_t) :: torque
   end type load_t

   !> The end-of-step quantities the observer folds, for up to `cap` plain
   !> steps an integrator takes in one call (`advance_block`, D-38). Inside a
   !> block, column `col` is written by `rhs_step_end` of a simple model (col =
   !> 0 outside a block: no column written); the workspace (el_disp, el_force,
   !> el_torque, ws_stored, ws_elastic) is written as always, so it holds the
   !> last step's end.
   type, public :: step_block_t
      integer :: cap = 1          !< columns
      integer :: col = 0          !< the column the next `rhs_step_end` writes (0: none)
      integer :: n = 0            !< steps in the block just taken
      real(wp), allocatable :: t(:)                      !< (step) its end time
      !> (element, step): el_disp, el_force and el_torque(2, :) at the step's end
      real(wp), allocatable :: disp(:, :), force(:, :), torque(:, :)
      !> (node, step): omega at the step's end
      real(wp), allocatable :: omega(:, :)
      !> (step): ws_stored, ws_elastic (if ws_energy); (2, step): the energy
      !> states y(n_states + 1 : n_states + 2) (if energy tracking)
      real(wp), allocatable :: stored(:), elastic(:), work(:, :)
   end type step_block_t

   type :: model_t
      character(len=:), allocatable :: title, deck_file, deck_text
      !> the overrides (--set, a sweep's values) applied to the deck, as `--set` writes them
      character(len=:), allocatable :: overrides
      !> Plausibility warnings of the deck (trainsim_plausibility), with file, line and key
      type(string_t), allocatable :: warnings(:)
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
      !> Some element has more than two ports (D-63): such elements go the
      !> general path only (no simple kernels, no local steps of RK4).
      logical :: nport = .false.
      ! workspace (sized once in `finalize`)
      real(wp), allocatable :: theta(:), omega(:), torque(:)
      !> Per element: its torque on its left (1) and right (2) node at the last full RHS.
      real(wp), allocatable :: el_torque(:, :)
      !> Per element whose `status` is known to be (delta, F, 1, 0) of its linear
      !> spring (status_in_ws, checked bit for bit at build time, simple models
      !> only): delta = r1 thl - r2 thr and F, at the last full RHS.
      real(wp), allocatable :: el_disp(:), el_force(:)
      logical, allocatable :: status_in_ws(:)
      !> Per element: its status's displacement, force and contact are el_disp,
      !> el_force and el_contact at the last full RHS of a simple model (D-36):
      !> the status_in_ws elements (contact 1) and the clearance elements in a
      !> hot form whose status agrees (contact: the hot form's mode, set by
      !> `refresh_hot`). The pairs of their status are not in the workspace.
      logical, allocatable :: ws_status(:)
      integer, allocatable :: el_contact(:)
      !> The stored energy (kinetic + elastic) and its elastic part at the last
      !> full RHS if that was `rhs_step_end`, bit for bit `workspace_energy`'s
      !> there, if ws_energy (D-36:
      !> a simple model with energy tracking whose elements are all linear
      !> springs or hot forms with agreeing elastic energy, n_cold = 0).
      real(wp) :: ws_stored = 0.0_wp, ws_elastic = 0.0_wp
      logical :: ws_energy = .false.
      !> The workspace (theta, omega, torque, el_torque) holds the full RHS at
      !> (ws_t, the state an integrator has just returned): set by the integrator
      !> right after it evaluated the RHS there (RK4's end-of-step evaluation,
      !> which is the next step's first stage); cleared by every other use of
      !> the workspace (`rhs`, `rhs_part`, `kinematics`, `apply_events`, ...).
      !> The observer then reads the element torques instead of recomputing them.
      logical :: ws_step_end = .false.
      real(wp) :: ws_t = 0.0_wp
      !> The ends of the steps of a block (D-38), sized by `finalize`.
      type(step_block_t) :: blk
      ! The hot path (`build_fast_path`, redone by `finalize` and at the start of
      ! every run in `init_modes`, so a re-parameterised copy is current): nodes
      ! that are plain inertias and elements that are linear springs (their
      ! optional capabilities, checked against their own procedures) are
      ! evaluated from these arrays, without calls through the polymorphic
      ! objects; every other node and element is asked as before.
      type(fast_node_t), allocatable, private :: fn(:)
      type(fast_element_t), allocatable, private :: fe(:)
      !> Per element: its hot form (D-35) in its current mode, refreshed after every
      !> mode change the model makes (`refresh_hot`); apart from fe (which every
      !> element's evaluation reads) so that fe stays small.
      type(hot_form_t), allocatable, private :: fh(:)
      type(guard_row_t), allocatable, private :: gr(:)   !< per element (guards), see guard_row_t
      !> Elements with guards but no guard row (kept by refresh_hot): at 0, every
      !> guard is a row's and `model_guards` runs on plain arrays.
      integer, private :: n_norow = 0
      type(fast_load_t), allocatable, private :: fl(:)
      integer, allocatable, private :: guard_els(:)        !< the elements that have guards
      integer, allocatable, private :: dyn_loads(:)        !< loads summed at t (on nodes with a varying load)
      !> Every node a plain inertia or held at a constant speed, every load
      !> constant, no element reads the loads: `rhs` runs the kernel `rhs_simple`.
      logical, private :: simple = .false.
      !> Element i joins nodes i and i + 1, for every i (a serial chain; the
      !> stage kernel then sums the node torques in registers).
      logical, private :: chain = .false.
      !> Per node i: the element torques acting on it, node_inc(node_first(i) :
      !> node_first(i+1) - 1), as indices into el_torque (2 (e - 1) + side), in
      !> the order the generic RHS adds them (elements in order, left side first).
      integer, allocatable, private :: node_first(:), node_inc(:)
      !> Elements whose elastic energy `rhs_simple` cannot compute (fe%cold), and
      !> that kernel's per-element elastic energies (summed after the kinetic).
      integer, private :: n_cold = 0
      real(wp), allocatable, private :: el_pe(:)
   contains
      procedure :: finalize => model_finalize
      procedure :: initial_state => model_initial_state
      procedure :: kinematics => model_kinematics
      procedure :: kinematics_part => model_kinematics_part
      procedure :: rhs => model_rhs
      procedure :: rhs_step_end => model_rhs_step_end
      procedure :: rhs_stage => model_rhs_stage
      procedure :: block_ok => model_block_ok
      procedure :: rhs_part => model_rhs_part
      procedure :: part_power => model_part_power
      procedure :: element_torques => model_element_torques
      procedure :: potential_energy => model_potential_energy
      procedure :: jacobian => model_jacobian
      procedure :: apply_loads => model_apply_loads
      procedure :: breakpoints => model_breakpoints
      procedure :: guards => model_guards
      procedure :: guards_below => model_guards_below
      procedure, private :: guards_general => model_guards_general
      procedure :: element_guards => model_element_guards
      procedure :: element_guard => model_element_guard
      procedure :: guard_angles => model_guard_angles
      procedure :: angle_guard => model_angle_guard
      procedure :: guard_floor => model_guard_floor
      procedure :: guard_element => model_guard_element
      procedure :: build_fast_path => model_build_fast_path
      procedure :: init_modes => model_init_modes
      procedure :: preload_mode => model_preload_mode
      procedure :: hot_kinds => model_hot_kinds
      procedure :: apply_events => model_apply_events
      procedure :: any_contact => model_any_contact
      procedure :: stored_energy => model_stored_energy
      procedure :: workspace_energy => model_workspace_energy
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
      self%nport = .false.
      do i = 1, ne
         if (self%elements(i)%e%needs_loads) self%any_needs_loads = .true.
         if (self%elements(i)%e%n_ports() > 2) self%nport = .true.
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
      if (allocated(self%el_torque)) deallocate (self%el_torque, self%el_disp, self%el_force, self%el_pe)
      allocate (self%el_torque(2, ne), self%el_disp(ne), self%el_force(ne), self%el_pe(ne))
      self%el_torque = 0.0_wp; self%el_disp = 0.0_wp; self%el_force = 0.0_wp; self%el_pe = 0.0_wp
      ! a block of steps (D-38): at most 64, its columns 32 KiB at most (they
      ! stay in the first-level cache; a long train gains little from blocks, its
      ! steps are long already, and measured slower with columns beyond the cache)
      associate (b => self%blk)
         b%cap = max(1, min(64, 32768/(8*(3*ne + nn + 4))))
         b%col = 0
         b%n = 0
         if (allocated(b%t)) deallocate (b%t, b%disp, b%force, b%torque, b%omega, b%stored, b%elastic, b%work)
         allocate (b%t(b%cap), b%disp(ne, b%cap), b%force(ne, b%cap), b%torque(ne, b%cap), b%omega(nn, b%cap), &
                   b%stored(b%cap), b%elastic(b%cap), b%work(2, b%cap))
         b%t = 0.0_wp; b%disp = 0.0_wp; b%force = 0.0_wp; b%torque = 0.0_wp; b%omega = 0.0_wp
         b%stored = 0.0_wp; b%elastic = 0.0_wp; b%work = 0.0_wp
      end associate
      call self%build_fast_path()
   end subroutine model_finalize

   !> Tables of the hot path from the nodes' and elements' current parameters.
   !> A node that says it is a plain inertia (`plain_inertia`) or an element
   !> that says it is a linear spring (`linear_spring`) is taken at its word
   !> only if its own procedures agree at two probe points (a type extended
   !> from one of them that changes its physics but not the claim is then
   !> still asked through its procedures).
   subroutine model_build_fast_path(self)
      class(model_t), intent(inout) :: self
      integer :: i, nn, ne
      real(wp) :: j, d, k, c, r1, r2
      logical :: plain, lin
      real(wp), allocatable :: y(:), dydt(:)
      integer, allocatable :: inc_n(:)
      nn = size(self%nodes)
      ne = size(self%elements)
      if (allocated(self%fn)) deallocate (self%fn)
      allocate (self%fn(nn))
      allocate (y(max(self%n_y, 1)), dydt(max(self%n_y, 1)))
      do i = 1, nn
         self%fn(i)%off = self%nodes(i)%n%offset
         if (self%speed_of(i) /= 0) then
            self%fn(i)%kind = nk_held
            self%fn(i)%const_speed = self%speeds(self%speed_of(i))%is_constant()
            self%fn(i)%w = self%speeds(self%speed_of(i))%value(0.0_wp)
            self%fn(i)%theta0 = self%nodes(i)%n%theta0
            self%fn(i)%j = self%nodes(i)%n%inertia()
         else
            call self%nodes(i)%n%plain_inertia(plain, j, d)
            if (plain) plain = plain_node_agrees(self%nodes(i)%n, j, d)
            if (plain) then
               self%fn(i)%kind = nk_plain
               self%fn(i)%j = j
               self%fn(i)%d = d
            end if
         end if
      end do
      if (allocated(self%fe)) deallocate (self%fe, self%fh, self%gr)
      allocate (self%fe(ne), self%fh(ne), self%gr(ne))
      self%n_norow = 0   ! (each element with guards counted below, then by refresh_hot)
      ! (refresh_hot keeps ws_status, el_contact and n_cold only once they exist: below)
      if (allocated(self%ws_status)) deallocate (self%ws_status)
      if (allocated(self%el_contact)) deallocate (self%el_contact)
      do i = 1, ne
         associate (e => self%elements(i)%e)
            self%fe(i)%l = e%left
            self%fe(i)%r = e%right
            self%fe(i)%ng = e%n_guards()
            if (self%fe(i)%ng > 0) self%n_norow = self%n_norow + 1   ! its row: not yet (form 0)
            call e%linear_spring(lin, k, c, r1, r2)
            if (lin) lin = linear_element_agrees(e, k, c, r1, r2) .and. e%n_ports() == 2
            self%fe(i)%linear = lin
            self%fe(i)%form = 0
            if (lin) then
               self%fe(i)%k = k; self%fe(i)%c = c; self%fe(i)%r1 = r1; self%fe(i)%r2 = r2
               self%fe(i)%form = lf_general
               if (c == 0.0_wp) self%fe(i)%form = lf_undamped
               if (c == 0.0_wp .and. r1 == 1.0_wp .and. r2 == 1.0_wp) self%fe(i)%form = lf_unit
            end if
            self%fe(i)%yl = 0
            self%fe(i)%yr = 0
            if (self%fn(e%left)%kind == nk_plain) self%fe(i)%yl = self%fn(e%left)%off + 1
            if (self%fn(e%right)%kind == nk_plain) self%fe(i)%yr = self%fn(e%right)%off + 1
         end associate
         call refresh_hot(self, i)
      end do
      self%guard_els = pack([(i, i=1, ne)], self%fe(:)%ng > 0)
      if (allocated(self%fl)) deallocate (self%fl)
      allocate (self%fl(size(self%loads)))
      do i = 1, size(self%loads)
         self%fl(i)%node = self%loads(i)%node
         self%fl(i)%const = self%loads(i)%torque%is_constant()
         self%fl(i)%v = self%loads(i)%torque%value(0.0_wp)
      end do
      ! a node whose loads are all constant starts each RHS from their sum (in
      ! load order, as summing them at t would); the others sum theirs at t
      do i = 1, size(self%loads)
         if (.not. self%fl(i)%const) self%fn(self%fl(i)%node)%load0 = huge(1.0_wp)
      end do
      do i = 1, size(self%loads)
         associate (nd => self%fn(self%fl(i)%node))
            if (nd%load0 /= huge(1.0_wp)) nd%load0 = nd%load0 + self%fl(i)%v
         end associate
      end do
      do i = 1, nn
         if (self%fn(i)%load0 == huge(1.0_wp)) self%fn(i)%load0 = 0.0_wp
      end do
      self%dyn_loads = pack([(i, i=1, size(self%loads))], [(self%fn(self%fl(i)%node)%load0 == 0.0_wp .and. &
                                                             .not. all_const_on(self%fl(i)%node), i=1, size(self%loads))])
      allocate (inc_n(nn + 1))
      inc_n = 0
      do i = 1, ne
         inc_n(self%fe(i)%l) = inc_n(self%fe(i)%l) + 1
         inc_n(self%fe(i)%r) = inc_n(self%fe(i)%r) + 1
      end do
      if (allocated(self%node_first)) deallocate (self%node_first, self%node_inc)
      allocate (self%node_first(nn + 1), self%node_inc(2*ne))
      self%node_first(1) = 1
      do i = 1, nn
         self%node_first(i + 1) = self%node_first(i) + inc_n(i)
      end do
      inc_n(1:nn) = self%node_first(1:nn)
      do i = 1, ne
         self%node_inc(inc_n(self%fe(i)%l)) = 2*i - 1
         inc_n(self%fe(i)%l) = inc_n(self%fe(i)%l) + 1
         self%node_inc(inc_n(self%fe(i)%r)) = 2*i
         inc_n(self%fe(i)%r) = inc_n(self%fe(i)%r) + 1
      end do
      self%chain = ne == nn - 1 .and. ne > 0
      do i = 1, ne
         if (self%fe(i)%l /= i .or. self%fe(i)%r /= i + 1) self%chain = .false.
      end do
      self%simple = all(self%fn(:)%kind == nk_plain .or. (self%fn(:)%kind == nk_held .and. self%fn(:)%const_speed)) &
                    .and. all(self%fl(:)%const) .and. .not. self%any_needs_loads .and. size(self%dyn_loads) == 0 &
                    .and. .not. self%nport
      ! elements whose recorded status the observer may take from the workspace
      if (allocated(self%status_in_ws)) deallocate (self%status_in_ws)
      allocate (self%status_in_ws(ne))
      do i = 1, ne
         self%status_in_ws(i) = self%simple .and. self%fe(i)%form >= lf_general .and. self%fe(i)%form <= lf_unit
         if (self%status_in_ws(i)) self%status_in_ws(i) = status_agrees(self%elements(i)%e, self%fe(i))
      end do
      allocate (self%ws_status(ne), self%el_contact(ne))
      self%ws_status = .false.
      self%el_contact = 0
      self%n_cold = 0
      do i = 1, ne
         self%fe(i)%cold = .false.   ! (counted by ws_flags)
         call ws_flags(self, i)
      end do
      self%ws_step_end = .false.
      self%ws_energy = .false.
   contains

      !> The element's own `status` gives, bit for bit at two probe points, the
      !> displacement and force `rhs_simple` computes for its form of linear
      !> spring, contact 1 and pairs 0 (an element that records something else,
      !> e.g. a gear pair's force without its damping, is asked as before).
      logical function status_agrees(e, q) result(ok)
         class(element_t), intent(in) :: e
         type(fast_element_t), intent(in) :: q
         real(wp) :: x(4), disp, force, d, f
         integer :: p, contact, pairs
         ok = .true.
         do p = 1, 2
            x = [0.37_wp, -1.3_wp, -0.52_wp, 2.1_wp]*real(p, wp)**[1, -1, 2, 1]
            call e%status(x(1), x(2), x(3), x(4), disp, force, contact, pairs)
            select case (q%form)
            case (lf_unit)
               d = x(1) - x(3)
               f = q%k*d
            case (lf_undamped)
               d = q%r1*x(1) - q%r2*x(3)
               f = q%k*d
            case default
               d = q%r1*x(1) - q%r2*x(3)
               f = q%k*d + q%c*(q%r1*x(2) - q%r2*x(4))
            end select
            ok = ok .and. disp == d .and. force == f .and. contact == 1 .and. pairs == 0
         end do
      end function status_agrees

      !> The node's own procedures give what a plain inertia (J, d) would.
      logical function plain_node_agrees(nd, jj, dd) result(ok)
         class(node_t), intent(in) :: nd
         real(wp), intent(in) :: jj, dd
         real(wp) :: th, om, w
         integer :: p, o
         ok = nd%nstates() == 2 .and. jj > 0.0_wp .and. dd >= 0.0_wp
         if (.not. ok) return
         o = nd%offset
         do p = 1, 2
            y = 0.0_wp
            y(o + 1) = 0.37_wp*p
            y(o + 2) = -1.3_wp/p
            w = y(o + 2)
            dydt = 0.0_wp
            call nd%derivatives(0.25_wp*p, y, 2.5_wp*p, dydt)
            call nd%kinematics(y, th, om)
            ok = ok .and. th == y(o + 1) .and. om == w .and. dydt(o + 1) == w &
                 .and. close_to(dydt(o + 2), (2.5_wp*p - dd*w)/jj) &
                 .and. close_to(nd%stored_energy(y), 0.5_wp*jj*w**2) &
                 .and. close_to(nd%dissipation_power(y), dd*w**2) &
                 .and. nd%input_power(0.25_wp*p, y) == 0.0_wp
         end do
      end function plain_node_agrees

      !> The element's own procedures give what a linear spring (k, c, r1, r2) would.
      logical function linear_element_agrees(e, kk, cc, rr1, rr2) result(ok)
         class(element_t), intent(in) :: e
         real(wp), intent(in) :: kk, cc, rr1, rr2
         real(wp) :: x(4), tl, tr, dl, dv, f
         integer :: p
         ok = e%n_guards() == 0 .and. .not. e%needs_loads .and. .not. e%supplies_power
         do p = 1, 2
            if (.not. ok) return
            x = [0.37_wp, -1.3_wp, -0.52_wp, 2.1_wp]*real(p, wp)**[1, -1, 2, 1]
            call e%torques(x(1), x(2), x(3), x(4), tl, tr)
            dl = rr1*x(1) - rr2*x(3)
            dv = rr1*x(2) - rr2*x(4)
            f = kk*dl + cc*dv
            ok = close_to(tl, -rr1*f) .and. close_to(tr, rr2*f) &
                 .and. close_to(e%potential_energy(x(1), x(3)), 0.5_wp*kk*dl**2) &
                 .and. close_to(e%dissipation_power(x(1), x(2), x(3), x(4)), cc*dv**2)
         end do
      end function linear_element_agrees

      !> Whether every load on node nd is constant.
      logical function all_const_on(nd) result(c)
         integer, intent(in) :: nd
         integer :: q
         c = .true.
         do q = 1, size(self%fl)
            if (self%fl(q)%node == nd .and. .not. self%fl(q)%const) c = .false.
         end do
      end function all_const_on

      !> Equal to rounding (the claim and the procedure may order operations differently).
      pure logical function close_to(a, b)
         real(wp), intent(in) :: a, b
         close_to = abs(a - b) <= 1.0e-12_wp*max(abs(a), abs(b)) + tiny(1.0_wp)
      end function close_to
   end subroutine model_build_fast_path

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
      call kinematics_all(self, t, y)
   end subroutine model_kinematics

   !> The kinematics of the nodes `nodes` only, into the workspace (the
   !> observer at a local event instant, D-32).
   subroutine model_kinematics_part(self, t, y, nodes)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      integer, intent(in) :: nodes(:)
      integer :: k
      real(wp) :: th, om
      self%ws_step_end = .false.
      do k = 1, size(nodes)
         call node_kinematics(self, nodes(k), t, y, th, om)
         self%theta(nodes(k)) = th
         self%omega(nodes(k)) = om
      end do
   end subroutine model_kinematics_part

   !> `model_kinematics` without the dispatch (the hot path calls it directly).
   subroutine kinematics_all(self, t, y)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
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
   end subroutine kinematics_all

   !> dy/dt at (t, y). Leaves node kinematics and net node torques in the workspace.
   !> Linear-spring elements and plain-inertia nodes come from the hot-path
   !> tables; the others are asked through their procedures, in the same order.
   subroutine model_rhs(self, t, y, dydt)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: dydt(:)
      call rhs_fast(self, t, y, dydt, .false.)
   end subroutine model_rhs

   !> `model_rhs` at the end of an integrator's step, where the observer reads
   !> the workspace (RK4, D-33): a simple model with energy tracking also leaves
   !> the stored energy there (D-36). Every other RHS (CVODE's, the stages, the
   !> event location) is `model_rhs`, which does not compute it.
   subroutine model_rhs_step_end(self, t, y, dydt)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      !> (explicit size: their addresses only, no descriptors)
      real(wp), intent(in) :: y(self%n_y)
      real(wp), intent(out) :: dydt(self%n_y)
      if (self%simple) then
         ! straight to the kernel (every step of a block, D-38): no second layer
         ! of descriptors
         call rhs_simple_ws(self, t, y, dydt, .true.)
      else
         call rhs_fast(self, t, y, dydt, .true.)
      end if
   end subroutine model_rhs_step_end

   !> dy/dt at (t, y) as `model_rhs`, the same values bit for bit, for an
   !> integrator's inner stage, after which no one reads the workspace: a
   !> simple model runs the kernel `rhs_stage_simple` (with energy tracking
   !> `rhs_stage_energy`, D-40: two kernels, each called once here, so that the
   !> compiler inlines and compiles each apart), which stores nothing but
   !> dy/dt and the element torques (no node angles, speeds and torques, no
   !> element displacements and forces), and the workspace then holds nothing
   !> a caller may read (`ws_step_end` cleared). Other models run `model_rhs`.
   subroutine model_rhs_stage(self, t, y, dydt)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      !> (explicit size: their addresses only, D-41)
      real(wp), intent(in) :: y(self%n_y)
      real(wp), intent(out) :: dydt(self%n_y)
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
   end subroutine model_rhs_stage

   !> Whether an integrator may take a block of steps (D-38) in the current
   !> modes: a simple model whose `rhs_step_end` leaves in the block's columns
   !> everything the observer folds after a step (every element's status in
   !> the workspace, and with energy tracking the stored energy), and room
   !> for two steps at least.
   logical function model_block_ok(self) result(ok)
      class(model_t), intent(in) :: self
      ok = self%simple .and. self%blk%cap >= 4
      if (.not. ok) return
      if (self%run%track_energy) ok = self%n_cold == 0
      if (ok) ok = all(self%ws_status)
   end function model_block_ok

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
               call nport_torques(self, i, track, tl, tr, pdiss, pin)      ! (its further ports' torques added)
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

   !> `rhs_fast` of a simple model: the kernel `rhs_simple` with the model's
   !> workspace, and at a step's end inside a block (D-38) its column. On
   !> explicit-size y and dydt (their addresses only: `model_rhs_step_end` calls
   !> it for every step of a block).
   subroutine rhs_simple_ws(self, t, y, dydt, step_end)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      real(wp), intent(in) :: y(self%n_y)
      real(wp), intent(out) :: dydt(self%n_y)
      logical, intent(in) :: step_end   !< leave the stored energy too (`model_rhs_step_end`)
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
   end subroutine rhs_simple_ws

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

   !> Torques of element i on its left and right node at the kinematics in the
   !> workspace (after `kinematics`): the hot path for linear springs.
   subroutine model_element_torques(self, i, tl, tr)
      class(model_t), intent(in) :: self
      integer, intent(in) :: i
      real(wp), intent(out) :: tl, tr
      real(wp) :: f
      integer :: l, r
      associate (e => self%fe(i))
         l = e%l
         r = e%r
         if (e%linear) then
            f = e%k*(e%r1*self%theta(l) - e%r2*self%theta(r)) + e%c*(e%r1*self%omega(l) - e%r2*self%omega(r))
            tl = -(f*e%r1)
            tr = f*e%r2
         else if (e%form >= lf_open) then                                  ! a clearance's hot form (D-35)
            call hot_torques(self%fh(i), self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr, f)
         else if (self%nport) then
            call port_torques_2(self, i, tl, tr)
         else
            call self%elements(i)%e%torques(self%theta(l), self%omega(l), self%theta(r), self%omega(r), tl, tr)
         end if
      end associate
   end subroutine model_element_torques

   !> The nodes of element i's ports and their angles and speeds in the
   !> workspace (th, w, ends: 1 .. n_ports of the element; D-63).
   pure subroutine port_kinematics(self, i, ends, th, w)
      type(model_t), intent(in) :: self
      integer, intent(in) :: i
      integer, intent(out) :: ends(max_ports)
      real(wp), intent(out) :: th(max_ports), w(max_ports)
      integer :: k
      ends = 0; th = 0.0_wp; w = 0.0_wp
      do k = 1, self%elements(i)%e%n_ports()
         ends(k) = self%elements(i)%e%port(k)
         th(k) = self%theta(ends(k))
         w(k) = self%omega(ends(k))
      end do
   end subroutine port_kinematics

   !> An n-port element i (D-63) at the workspace's kinematics, in the general
   !> RHS: its torques on ports 1 and 2 in tl, tr (added by the caller as a
   !> two-port element's), those on its further ports added to their nodes
   !> here; with `track` its dissipation and input power added to pdiss, pin.
   !> A two-port element: `torques` (and its powers), as the general RHS asks.
   subroutine nport_torques(self, i, track, tl, tr, pdiss, pin)
      type(model_t), intent(inout) :: self
      integer, intent(in) :: i
      logical, intent(in) :: track
      real(wp), intent(out) :: tl, tr
      real(wp), intent(inout) :: pdiss, pin
      real(wp) :: th(max_ports), w(max_ports), t(max_ports), p
      integer :: np, k, ends(max_ports)
      associate (e => self%elements(i)%e)
         np = e%n_ports()
         call port_kinematics(self, i, ends, th, w)
         if (np == 2) then
            call e%torques(th(1), w(1), th(2), w(2), tl, tr)
            if (track) then
               pdiss = pdiss + e%dissipation_power(th(1), w(1), th(2), w(2))
               if (e%supplies_power) pin = pin + e%input_power(th(1), w(1), th(2), w(2))
            end if
            return
         end if
         call e%port_torques_dissipation(th(1:np), w(1:np), t(1:np), p)
         if (track) then
            pdiss = pdiss + p
            if (e%supplies_power) pin = pin + e%port_input_power(th(1:np), w(1:np))
         end if
         do k = 3, np
            self%torque(ends(k)) = self%torque(ends(k)) + t(k)
         end do
         tl = t(1)
         tr = t(2)
      end associate
   end subroutine nport_torques

   !> Element i's torques on its ports 1 and 2 (left, right) at the
   !> workspace's kinematics, through `port_torques` (any number of ports).
   subroutine port_torques_2(self, i, tl, tr)
      type(model_t), intent(in) :: self
      integer, intent(in) :: i
      real(wp), intent(out) :: tl, tr
      real(wp) :: th(max_ports), w(max_ports), t(max_ports)
      integer :: np, ends(max_ports)
      np = self%elements(i)%e%n_ports()
      call port_kinematics(self, i, ends, th, w)
      call self%elements(i)%e%port_torques(th(1:np), w(1:np), t(1:np))
      tl = t(1)
      tr = t(2)
   end subroutine port_torques_2

   !> Elastic energy of element i (not a linear spring of the fast path) at
   !> the workspace's angles: `potential_energy`, or over its ports (D-63).
   real(wp) function element_potential(self, i) result(e)
      type(model_t), intent(in) :: self
      integer, intent(in) :: i
      real(wp) :: th(max_ports), w(max_ports)
      integer :: np, ends(max_ports)
      np = self%elements(i)%e%n_ports()
      if (np == 2) then
         e = self%elements(i)%e%potential_energy(self%theta(self%fe(i)%l), self%theta(self%fe(i)%r))
      else
         call port_kinematics(self, i, ends, th, w)
         e = self%elements(i)%e%port_potential_energy(th(1:np))
      end if
   end function element_potential

   !> `update_mode` of an n-port element i (D-63) at the workspace's kinematics.
   subroutine port_update(self, i, t, fired, ev, nev)
      type(model_t), intent(inout) :: self
      integer, intent(in) :: i
      real(wp), intent(in) :: t
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      real(wp) :: th(max_ports), w(max_ports)
      integer :: np, ends(max_ports)
      np = self%elements(i)%e%n_ports()
      call port_kinematics(self, i, ends, th, w)
      call self%elements(i)%e%port_update_mode(t, th(1:np), w(1:np), fired, ev, nev)
   end subroutine port_update

   !> Elastic energy in all elements at the kinematics in the workspace.
   real(wp) function model_potential_energy(self) result(e)
      class(model_t), intent(in) :: self
      integer :: i, l, r
      e = 0.0_wp
      do i = 1, size(self%fe)
         l = self%fe(i)%l
         r = self%fe(i)%r
         if (self%fe(i)%linear) then
            e = e + 0.5_wp*self%fe(i)%k*(self%fe(i)%r1*self%theta(l) - self%fe(i)%r2*self%theta(r))**2
         else
            e = e + element_potential(self, i)
         end if
      end do
   end function model_potential_energy

   !> dy/dt at (t, y) for the states of the nodes der(:) only (event location on
   !> a part of a long train). kin(:) must hold der and every node of the
   !> elements els(:), and els every element of a node in der, in increasing
   !> order: the torques then add up in the same order as in `rhs`, and the
   !> derivatives of der are bit for bit those of `rhs`. Other entries of dydt
   !> are left as they were; no energy rates.
   subroutine model_rhs_part(self, t, y, dydt, kin, els, der)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: dydt(:)
      integer, intent(in) :: kin(:), els(:), der(:)
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
   end subroutine model_rhs_part

   !> The energy rates of a part of the train at the kinematics and torques
   !> `rhs_part` just left in the workspace (same t, kin, els, der): pdiss and pin
   !> of the elements els, of the nodes der (in_der: the same set as a mask over
   !> the nodes) and of the loads on them; the terms are those of `rhs`, so the
   !> rates of a partition of the train add up to the whole train's.
   subroutine model_part_power(self, t, y, els, der, in_der, pdiss, pin)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      integer, intent(in) :: els(:), der(:)
      logical, intent(in) :: in_der(:)
      real(wp), intent(out) :: pdiss, pin
      integer :: k, i, l, r, s
      real(wp) :: dv
      pdiss = 0.0_wp
      pin = 0.0_wp
      do i = 1, size(self%fl)
         l = self%fl(i)%node
         if (.not. in_der(l) .or. self%fn(l)%kind == nk_held) cycle
         if (self%fl(i)%const) then
            pin = pin + self%fl(i)%v*self%omega(l)
         else
            pin = pin + self%loads(i)%torque%value(t)*self%omega(l)
         end if
      end do
      do k = 1, size(els)
         i = els(k)
         associate (e => self%fe(i))
            l = e%l
            r = e%r
            if (e%linear) then
               dv = e%r1*self%omega(l) - e%r2*self%omega(r)
               pdiss = pdiss + e%c*dv**2
            else
               pdiss = pdiss + self%elements(i)%e%dissipation_power(self%theta(l), self%omega(l), self%theta(r), &
                                                                    self%omega(r))
               if (self%elements(i)%e%supplies_power) pin = pin + self%elements(i)%e%input_power(self%theta(l), &
                                                             self%omega(l), self%theta(r), self%omega(r))
            end if
         end associate
      end do
      do k = 1, size(der)
         i = der(k)
         associate (nd => self%fn(i))
            select case (nd%kind)
            case (nk_plain)
               pdiss = pdiss + nd%d*self%omega(i)**2
            case (nk_held)
               if (nd%const_speed) then
                  pin = pin - self%torque(i)*self%omega(i)
               else
                  s = self%speed_of(i)
                  pin = pin + (self%nodes(i)%n%inertia()*self%speeds(s)%derivative(t) - self%torque(i))*self%omega(i)
               end if
            case default
               pdiss = pdiss + self%nodes(i)%n%dissipation_power(y)
               pin = pin + self%nodes(i)%n%input_power(t, y)
            end select
         end associate
      end do
   end subroutine model_part_power

   !> External load torques at t into self%torque, and published to the
   !> elements that read their nodes' loads.
   subroutine model_apply_loads(self, t)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      call loads_at(self, t)
   end subroutine model_apply_loads

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

   !> Dense Jacobian d(dydt)/dy at (t, y) in the current modes, assembled from
   !> the nodes' own blocks and the elements' torque partials. The rows of the
   !> energy-accounting states are left zero: those states feed nothing back,
   !> so Newton's iteration stays exact for every other state.
   subroutine model_jacobian(self, t, y, jac)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: jac(:, :)
      real(wp) :: dtq(3, size(self%nodes)), jt(max_ports, 2*max_ports), th(max_ports), w(max_ports)
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
      do i = 1, size(self%elements)
         associate (e => self%elements(i)%e)
            np = e%n_ports()
            if (np == 2) then
               ends(1:2) = [e%left, e%right]
               call e%torque_jacobian(self%theta(e%left), self%omega(e%left), self%theta(e%right), &
                                      self%omega(e%right), jt(1:2, 1:4))
            else                                                  ! an n-port element (D-63)
               call port_kinematics(self, i, ends, th, w)
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
   end subroutine model_jacobian

   !> All elements' guards at (t, y) (a mode is valid while every guard is >= 0).
   subroutine model_guards(self, t, y, g)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: g(:)
      logical :: below
      if (self%n_guards == 0) return
      ! only the elements with guards (a long train has few of them); when each
      ! has a guard row (the element's hot form on two plain inertias, D-39), on
      ! plain arrays; else the general loop (through the binding: kept out of line)
      if (self%n_norow == 0 .and. is_contiguous(y) .and. is_contiguous(g)) then
         below = self%guards_below(t, y, g)   ! (guard_rows; whether one is below zero unused)
      else
         call self%guards_general(t, y, g)
      end if
   end subroutine model_guards

   !> `model_guards` on an integrator's own arrays (explicit size: their
   !> addresses only, no descriptors), and whether a guard is below zero: the
   !> check at the end of every RK4 step (D-38). All rows: guard_rows.
   logical function model_guards_below(self, t, y, g) result(below)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      real(wp), intent(in) :: y(self%n_y)
      real(wp), intent(inout) :: g(self%n_guards)
      integer :: j
      below = .false.
      if (self%n_guards == 0) return
      if (self%n_norow == 0) then
         below = guard_rows(size(self%guard_els), self%guard_els, self%gr, y, g)
         return
      end if
      call self%guards_general(t, y, g)
      do j = 1, self%n_guards
         if (g(j) < 0.0_wp) below = .true.
      end do
   end function model_guards_below

   !> `model_guards` element by element: a guard row by row_guard, any other
   !> element by guards_other (its nodes' kinematics, its hot form or `guards`).
   subroutine model_guards_general(self, t, y, g)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: g(:)
      integer :: k, i, j
      do k = 1, size(self%guard_els)
         i = self%guard_els(k)
         if (self%gr(i)%form == 0) then
            call guards_other(self, i, t, y, g, self%guard_offset(i))
         else
            associate (q => self%gr(i))
               do j = 1, self%fe(i)%ng
                  g(q%o + j) = row_guard(q, j, y(q%yl), y(q%yr))
               end do
            end associate
         end if
      end do
   end subroutine model_guards_general

   !> The guards of the elements els(1:n), each with a guard row (rows(els(k))%form
   !> > 0), at the state y into g, and whether one of them is below zero (tested
   !> on the values as they are written: no second pass over g; NaN is not below
   !> zero, as in `g(j) < 0`): hot_guards written out, the angles straight from
   !> y (plain arrays: no descriptor, no stride).
   logical function guard_rows(n, els, rows, y, g) result(below)
      integer, intent(in) :: n, els(n)
      type(guard_row_t), intent(in) :: rows(*)
      real(wp), intent(in) :: y(*)
      real(wp), intent(inout) :: g(*)
      integer :: k, o
      real(wp) :: d, g1, g2, g3, g4
      below = .false.
      do k = 1, n
         associate (q => rows(els(k)))
            o = q%o
            d = q%r1*y(q%yl) - q%r2*y(q%yr)
            select case (q%mode)
            case (1)
               g1 = d - q%b; g2 = 1.0_wp
            case (-1)
               g1 = 1.0_wp; g2 = -d - q%b
            case default
               g1 = q%b - d; g2 = d + q%b
            end select
            g(o + 1) = g1; g(o + 2) = g2
            if (g1 < 0.0_wp .or. g2 < 0.0_wp) below = .true.
            if (q%form == 2) then
               if (q%lo_open) then
                  g3 = 1.0_wp
               else
                  g3 = y(q%yl) - q%th_lo
               end if
               g4 = q%th_hi - y(q%yl)
               g(o + 3) = g3; g(o + 4) = g4
               if (g3 < 0.0_wp .or. g4 < 0.0_wp) below = .true.
            end if
         end associate
      end do
   end function guard_rows

   !> The guards of element i at (t, y) into g(o + 1 : o + ng) (`model_guards` for
   !> an element without a guard row, `element_guards`): the kinematics of its two
   !> nodes (a plain inertia's straight from y), then its hot guard form or its
   !> own `guards`.
   subroutine guards_other(self, i, t, y, g, o)
      class(model_t), intent(inout) :: self
      integer, intent(in) :: i, o
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: g(:)
      integer :: n, k, np
      real(wp) :: thl, wl, thr, wr, gh(4), th(max_ports), w(max_ports)
      n = self%fe(i)%ng
      if (self%nport) then
         np = self%elements(i)%e%n_ports()
         if (np > 2) then                                   ! an n-port element (D-63): every port from y
            do k = 1, np
               call node_kinematics(self, self%elements(i)%e%port(k), t, y, th(k), w(k))
            end do
            call self%elements(i)%e%port_guards(th(1:np), w(1:np), g(o + 1:o + n))
            return
         end if
      end if
      ! a plain inertia's angle and speed straight from y (no call on every step)
      if (self%fe(i)%yl > 0) then
         thl = y(self%fe(i)%yl)
         wl = y(self%fe(i)%yl + 1)
      else
         call node_kinematics(self, self%fe(i)%l, t, y, thl, wl)
      end if
      if (self%fe(i)%yr > 0) then
         thr = y(self%fe(i)%yr)
         wr = y(self%fe(i)%yr + 1)
      else
         call node_kinematics(self, self%fe(i)%r, t, y, thr, wr)
      end if
      if (self%fe(i)%gform /= hg_none) then             ! the element's hot form (D-35)
         call hot_guards(self%fh(i), thl, thr, gh)
         g(o + 1:o + n) = gh(1:n)
      else
         call self%elements(i)%e%guards(thl, wl, thr, wr, g(o + 1:o + n))
      end if
   end subroutine guards_other

   !> The guards of element i alone at (t, y), into g(1:n_guards of i): only the
   !> kinematics of its two nodes are evaluated (for event location, where one
   !> guard is followed on a trial state; a node's kinematics reads only its own
   !> states y(offset+1:offset+nstates)).
   subroutine model_element_guards(self, i, t, y, g)
      class(model_t), intent(inout) :: self
      integer, intent(in) :: i
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: g(:)
      call guards_other(self, i, t, y, g, 0)
   end subroutine model_element_guards

   !> Guard k (1 .. n_guards of i) of element i alone at (t, y): `element_guards`
   !> for one guard (event location follows one guard on trial states), bit for
   !> bit its value; a hot form on two plain inertias reads only their angles.
   real(wp) function model_element_guard(self, i, k, t, y) result(gk)
      class(model_t), intent(inout) :: self
      integer, intent(in) :: i, k
      real(wp), intent(in) :: t, y(:)
      real(wp) :: g(4)
      if (self%gr(i)%form > 0) then
         gk = row_guard(self%gr(i), k, y(self%gr(i)%yl), y(self%gr(i)%yr))
         return
      end if
      call model_element_guards(self, i, t, y, g(1:self%fe(i)%ng))
      gk = g(k)
   end function model_element_guard

   !> Where element i's guards are its hot form's (D-35) on two plain inertias
   !> (they read only the two nodes' angles): the state indices of those angles,
   !> else 0 and 0. Valid until the element's mode changes (`apply_events`).
   pure subroutine model_guard_angles(self, i, yl, yr)
      class(model_t), intent(in) :: self
      integer, intent(in) :: i
      integer, intent(out) :: yl, yr
      yl = 0
      yr = 0
      if (self%gr(i)%form == 0) return
      yl = self%gr(i)%yl
      yr = self%gr(i)%yr
   end subroutine model_guard_angles

   !> Guard k of element i from its nodes' angles, where `guard_angles` gave
   !> their state indices: bit for bit `element_guard` at a state with those angles.
   pure real(wp) function model_angle_guard(self, i, k, thl, thr) result(gk)
      class(model_t), intent(in) :: self
      integer, intent(in) :: i, k
      real(wp), intent(in) :: thl, thr
      gk = row_guard(self%gr(i), k, thl, thr)
   end function model_angle_guard

   !> A lower bound of element i's guards (where `guard_angles` gave their
   !> state indices) over all angles within thl +- rl, thr +- rr, with room for
   !> the rounding of the angles and of the guards' arithmetic; -huge for an
   !> element without a guard row. Local event steps (D-32) use it to skip the
   !> elements that cannot be below zero anywhere on a step's dense output.
   pure real(wp) function model_guard_floor(self, i, thl, rl, thr, rr) result(gmin)
      class(model_t), intent(in) :: self
      integer, intent(in) :: i
      real(wp), intent(in) :: thl, rl, thr, rr
      real(wp), parameter :: rel = 1.0e-12_wp   ! far above a few ulps
      real(wp) :: d, dr, al, slack
      gmin = -huge(1.0_wp)
      if (self%gr(i)%form == 0) return
      associate (q => self%gr(i))
         al = abs(thl) + rl
         slack = rel*(abs(q%r1)*al + abs(q%r2)*(abs(thr) + rr) + q%b)
         d = q%r1*thl - q%r2*thr
         dr = abs(q%r1)*rl + abs(q%r2)*rr + slack
         select case (q%mode)
         case (1)
            gmin = min(1.0_wp, d - dr - q%b)
         case (-1)
            gmin = min(1.0_wp, -d - dr - q%b)
         case default
            gmin = min(q%b - d - dr, d - dr + q%b)
         end select
         if (q%form == 2) then
            slack = rel*(al + abs(q%th_lo) + abs(q%th_hi))
            if (.not. q%lo_open) gmin = min(gmin, thl - rl - q%th_lo - slack)
            gmin = min(gmin, q%th_hi - thl - rl - slack)
         end if
      end associate
   end function model_guard_floor

   !> Guard k of a guard row at the angles thl, thr: `model_guards`' arithmetic
   !> (hot_guards') for that guard alone.
   pure real(wp) function row_guard(q, k, thl, thr) result(gk)
      type(guard_row_t), intent(in) :: q
      integer, intent(in) :: k
      real(wp), intent(in) :: thl, thr
      real(wp) :: d
      select case (k)
      case (1, 2)
         d = q%r1*thl - q%r2*thr
         select case (q%mode)
         case (1)
            gk = 1.0_wp
            if (k == 1) gk = d - q%b
         case (-1)
            gk = 1.0_wp
            if (k == 2) gk = -d - q%b
         case default
            if (k == 1) then
               gk = q%b - d
            else
               gk = d + q%b
            end if
         end select
      case (3)
         gk = 1.0_wp
         if (.not. q%lo_open) gk = thl - q%th_lo
      case default
         gk = q%th_hi - thl
      end select
   end function row_guard

   !> The element that owns guard j (0 if none).
   pure integer function model_guard_element(self, j) result(owner)
      class(model_t), intent(in) :: self
      integer, intent(in) :: j
      integer :: k, i
      owner = 0
      do k = 1, size(self%guard_els)
         i = self%guard_els(k)
         if (j > self%guard_offset(i) .and. j <= self%guard_offset(i) + self%fe(i)%ng) then
            owner = i
            return
         end if
      end do
   end function model_guard_element

   !> Angle and speed of node i at (t, y).
   pure subroutine node_kinematics(self, i, t, y, th, om)
      type(model_t), intent(in) :: self
      integer, intent(in) :: i
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(out) :: th, om
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
   end subroutine node_kinematics

   !> Set every element's discrete mode from the state at t_start.
   subroutine model_init_modes(self, t, y)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      integer :: i, l, r, np, ends(max_ports)
      real(wp) :: th(max_ports), w(max_ports)
      call self%build_fast_path()   ! a copy may have been re-parameterised since finalize
      call self%kinematics(t, y)
      do i = 1, size(self%elements)
         l = self%elements(i)%e%left
         r = self%elements(i)%e%right
         np = self%elements(i)%e%n_ports()
         if (np > 2) then                                   ! an n-port element (D-63)
            call port_kinematics(self, i, ends, th, w)
            call self%elements(i)%e%port_init_mode(th(1:np), w(1:np))
         else
            call self%elements(i)%e%init_mode(self%theta(l), self%omega(l), self%theta(r), self%omega(r))
         end if
         call refresh_hot(self, i)
      end do
      self%energy0 = self%stored_energy(t, y)
   end subroutine model_init_modes

   !> Element j's static-preload mode (`preload_mode` of the element: face +1,
   !> -1 or 0, zones from the angles) at the given kinematics, through the
   !> model, which refreshes the element's hot form (D-35).
   subroutine model_preload_mode(self, j, face, thl, wl, thr, wr)
      class(model_t), intent(inout) :: self
      integer, intent(in) :: j, face
      real(wp), intent(in) :: thl, wl, thr, wr
      call self%elements(j)%e%preload_mode(face, thl, wl, thr, wr)
      call refresh_hot(self, j)
   end subroutine model_preload_mode

   !> The hot form (D-35) the model holds for element i: the torque form
   !> (hf_*, hf_none when asked through `torques`) and the guard form (hg_*).
   pure subroutine model_hot_kinds(self, i, kind, guards)
      class(model_t), intent(in) :: self
      integer, intent(in) :: i
      integer, intent(out) :: kind, guards
      kind = self%fh(i)%kind
      guards = self%fe(i)%gform
   end subroutine model_hot_kinds

   !> Ask element i for its hot form (D-35) in its current mode and take it only
   !> where the element's own procedures agree bit for bit at three probe
   !> states (`torques`, `torques_dissipation`, `guards`): otherwise the
   !> element is asked through its procedures as before. Torque forms only for
   !> elements that read no loads and supply no power, and not for linear
   !> springs (they have their own form).
   subroutine refresh_hot(self, i)
      type(model_t), intent(inout) :: self
      integer, intent(in) :: i
      type(hot_form_t) :: h
      real(wp) :: x(4), g(4), gh(4), tl, tr, pw, htl, htr, hpw, pen, sd, sf
      integer :: p, ng, sc, sp
      logical :: pe_ok, st_ok
      ! hot_pe is read only with energy tracking (ws_energy needs run%track_energy,
      ! which every run's init_modes refreshes with): without, it stays false
      pe_ok = self%run%track_energy
      st_ok = .true.
      associate (e => self%elements(i)%e, q => self%fe(i))
         call e%hot_form(h)
         if (q%linear .or. e%needs_loads .or. e%supplies_power) h%kind = hf_none
         if (e%n_ports() > 2) then                         ! the hot forms have two ports (D-63)
            h%kind = hf_none
            h%guards = hg_none
         end if
         ng = q%ng
         if (.not. ((h%guards == hg_faces .and. ng == 2) .or. (h%guards == hg_faces_zone .and. ng == 4))) &
            h%guards = hg_none
         do p = 1, 3
            if (h%kind == hf_none .and. h%guards == hg_none) exit
            ! two states with the face penetrated by a little, one anywhere
            x = [0.0_wp, 1.1_wp*p, 0.3_wp*p, -0.7_wp/p]
            pen = 0.25_wp*p*max(h%b, 1.0e-3_wp)
            if (h%r1 /= 0.0_wp) x(1) = (h%r2*x(3) + h%s*(h%b + pen))/h%r1
            if (p == 3) x = [0.37_wp, -1.3_wp, -0.52_wp, 2.1_wp]
            if (h%kind /= hf_none) then
               call e%torques(x(1), x(2), x(3), x(4), tl, tr)
               call hot_torques(h, x(1), x(2), x(3), x(4), htl, htr, hpw)
               if (.not. (tl == htl .and. tr == htr)) h%kind = hf_none
               call e%torques_dissipation(x(1), x(2), x(3), x(4), tl, tr, pw)
               if (.not. (tl == htl .and. tr == htr .and. pw == hpw)) h%kind = hf_none
               ! D-36: its elastic energy and status as `rhs_simple` leaves them
               ! (each until it disagrees; the energy only where it can be read)
               if (pe_ok) then
                  if (.not. e%potential_energy(x(1), x(3)) == hot_potential(h, x(1), x(3))) pe_ok = .false.
               end if
               if (st_ok) then
                  call e%status(x(1), x(2), x(3), x(4), sd, sf, sc, sp)
                  if (.not. (sd == h%r1*x(1) - h%r2*x(3) .and. sf == hot_force(h, x(1), x(2), x(3), x(4)) .and. &
                             sc == h%mode)) st_ok = .false.
               end if
            end if
            if (h%guards /= hg_none) then
               call e%guards(x(1), x(2), x(3), x(4), g(1:ng))
               call hot_guards(h, x(1), x(3), gh)
               if (any(g(1:ng) /= gh(1:ng))) h%guards = hg_none
            end if
         end do
         self%fh(i) = h
         q%gform = h%guards
         q%hot_pe = pe_ok .and. h%kind /= hf_none
         q%hot_status = st_ok .and. h%kind /= hf_none
         if (.not. q%linear) then
            select case (h%kind)
            case (hf_open); q%form = lf_open
            case (hf_yang_sun); q%form = lf_yang_sun
            case (hf_linear); q%form = lf_cl_linear
            case default; q%form = 0
            end select
         end if
      end associate
      associate (q => self%gr(i), f => self%fe(i), h => self%fh(i))
         if (f%ng > 0 .and. q%form == 0) self%n_norow = self%n_norow - 1
         q%form = 0
         if (f%yl > 0 .and. f%yr > 0) then
            if (f%gform == hg_faces) q%form = 1
            if (f%gform == hg_faces_zone) q%form = 2
         end if
         if (f%ng > 0 .and. q%form == 0) self%n_norow = self%n_norow + 1
         q%o = 0
         if (allocated(self%guard_offset)) q%o = self%guard_offset(i)
         q%yl = f%yl; q%yr = f%yr; q%mode = h%mode; q%lo_open = h%lo_open
         q%r1 = h%r1; q%r2 = h%r2; q%b = h%b; q%th_lo = h%th_lo; q%th_hi = h%th_hi
      end associate
      if (allocated(self%ws_status)) call ws_flags(self, i)
   end subroutine refresh_hot

   !> Element i's entries of ws_status and el_contact, and whether its elastic
   !> energy is cold (kept in n_cold), from its current form (D-36).
   subroutine ws_flags(self, i)
      type(model_t), intent(inout) :: self
      integer, intent(in) :: i
      logical :: cold
      if (self%fe(i)%linear) then
         self%ws_status(i) = self%status_in_ws(i)
         self%el_contact(i) = 1
         cold = .false.
      else if (self%fe(i)%form >= lf_open) then
         self%ws_status(i) = self%simple .and. self%fe(i)%hot_status
         self%el_contact(i) = self%fh(i)%mode
         cold = .not. self%fe(i)%hot_pe
      else
         self%ws_status(i) = .false.
         self%el_contact(i) = 0
         cold = .true.
      end if
      if (cold .neqv. self%fe(i)%cold) then
         if (cold) then
            self%n_cold = self%n_cold + 1
         else
            self%n_cold = self%n_cold - 1
         end if
         self%fe(i)%cold = cold
      end if
   end subroutine ws_flags

   !> Elastic energy of a hot form (D-36): cl_potential's arithmetic (c k p^2/2
   !> closed, 0 open), the operations `rhs_simple` does.
   pure real(wp) function hot_potential(h, thl, thr) result(e)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, thr
      real(wp) :: d, p
      e = 0.0_wp
      if (h%kind == hf_open) return
      d = h%r1*thl - h%r2*thr
      p = h%s*d - h%b
      e = h%c*(0.5_wp*h%k*p**2)
   end function hot_potential

   !> Signed contact force of a hot form (D-36): fs of `hot_torques`.
   pure real(wp) function hot_force(h, thl, wl, thr, wr) result(fs)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: d, dd, p, pdot, f
      fs = 0.0_wp
      if (h%kind == hf_open) return
      d = h%r1*thl - h%r2*thr
      dd = h%r1*wl - h%r2*wr
      p = h%s*d - h%b
      pdot = h%s*dd
      if (h%kind == hf_yang_sun) then
         f = h%c*(h%k*p + h%dmp*p*pdot)
      else
         f = h%c*(h%k*p) + h%dmp*pdot
      end if
      if (h%no_tension) f = max(f, 0.0_wp)
      fs = h%s*f
   end function hot_force

   !> Torques (and the power dissipated) of a hot form (D-35): ce_torques and
   !> ce_torques_dissipation's arithmetic, the same operations in the same order.
   pure subroutine hot_torques(h, thl, wl, thr, wr, tl, tr, pw)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, pw
      real(wp) :: d, dd, p, pdot, f, fs
      if (h%kind == hf_open) then
         fs = 0.0_wp
         tl = -(fs*h%r1)
         tr = fs*h%r2
         pw = 0.0_wp
         return
      end if
      d = h%r1*thl - h%r2*thr
      dd = h%r1*wl - h%r2*wr
      p = h%s*d - h%b
      pdot = h%s*dd
      if (h%kind == hf_yang_sun) then
         f = h%c*(h%k*p + h%dmp*p*pdot)                                  ! eqs. (3.18)-(3.19)
      else
         f = h%c*(h%k*p) + h%dmp*pdot
      end if
      if (h%no_tension) f = max(f, 0.0_wp)
      fs = h%s*f
      tl = -(fs*h%r1)
      tr = fs*h%r2
      pw = (h%s*fs - h%c*(h%k*p))*pdot
   end subroutine hot_torques

   !> Guards of a hot form (D-35): cl_guards' faces, and a zone window.
   pure subroutine hot_guards(h, thl, thr, g)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, thr
      real(wp), intent(out) :: g(4)
      real(wp) :: d
      d = h%r1*thl - h%r2*thr
      select case (h%mode)
      case (1)
         g(1) = d - h%b; g(2) = 1.0_wp
      case (-1)
         g(1) = 1.0_wp; g(2) = -d - h%b
      case default
         g(1) = h%b - d; g(2) = d + h%b
      end select
      if (h%lo_open) then
         g(3) = 1.0_wp
      else
         g(3) = thl - h%th_lo
      end if
      g(4) = h%th_hi - thl
   end subroutine hot_guards

   !> Update the modes of the elements whose guards fired; the events that
   !> result are appended to events(nev+1:) (with the time and the element
   !> index filled in; the array grows when full, so no event is dropped).
   !> A mode change that changes the stored energy (a mesh-stiffness switch
   !> while teeth are loaded) is work done on the train: it is booked to the
   !> work-input state, so that the energy balance keeps closing.
   !> With `els` (a local event instant, D-32: the elements with guards of the
   !> region, whose nodes are integration points there), only those elements are
   !> looked at (fired is read only at their guards), only their nodes'
   !> kinematics are computed, and the change of the stored energy is that of
   !> their elastic energy (the only terms a mode change can change).
   subroutine model_apply_events(self, t, y, fired, events, nev, els)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      real(wp), intent(inout) :: y(:)
      logical, intent(in) :: fired(:)
      type(event_t), allocatable, intent(inout) :: events(:)
      integer, intent(inout) :: nev
      integer, intent(in), optional :: els(:)
      integer :: i, l, r, o, n, k, m, q, nq
      type(event_t) :: local(max_update_events)
      type(event_t), allocatable :: grown(:)
      real(wp) :: e_before
      e_before = 0.0_wp   ! read below only if track_energy; set so -Wmaybe-uninitialized need not prove that
      if (present(els)) then
         self%ws_step_end = .false.
         do q = 1, size(els)
            i = els(q)
            call self%kinematics_part(t, y, [self%fe(i)%l, self%fe(i)%r])
         end do
         if (self%run%track_energy) e_before = els_energy()
         nq = size(els)
      else
         if (self%run%track_energy) e_before = self%stored_energy(t, y)
         call kinematics_all(self, t, y)
         nq = size(self%elements)
      end if
      do q = 1, nq
         i = q
         if (present(els)) i = els(q)
         n = self%fe(i)%ng                  ! the element's n_guards (build_fast_path)
         if (n == 0) cycle
         o = self%guard_offset(i)
         if (.not. any(fired(o + 1:o + n))) cycle
         l = self%fe(i)%l
         r = self%fe(i)%r
         if (self%elements(i)%e%n_ports() > 2) then          ! an n-port element (D-63; all kinematics known:
            call port_update(self, i, t, fired(o + 1:o + n), local, m)   ! no local steps with one)
         else
            call self%elements(i)%e%update_mode(t, self%theta(l), self%omega(l), self%theta(r), self%omega(r), &
                                                fired(o + 1:o + n), local, m)
         end if
         call refresh_hot(self, i)
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
      if (.not. self%run%track_energy) return
      if (present(els)) then
         y(self%n_states + 2) = y(self%n_states + 2) + (els_energy() - e_before)
      else
         y(self%n_states + 2) = y(self%n_states + 2) + self%stored_energy(t, y) - e_before
      end if
   contains
      !> The elastic energy of the elements els at the kinematics in the workspace.
      real(wp) function els_energy() result(e)
         integer :: p
         e = 0.0_wp
         do p = 1, size(els)
            e = e + element_potential(self, els(p))
         end do
      end function els_energy
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
      real(wp) :: pot
      call kinematics_all(self, t, y)
      call self%workspace_energy(y, e, pot)
   end function model_stored_energy

   !> Stored energy (kinetic + elastic (+ magnetic)) and the elastic part alone,
   !> at the kinematics in the workspace and the state y (for nodes with states
   !> of their own); the stored energy is bit for bit `stored_energy`'s.
   subroutine model_workspace_energy(self, y, e, pot)
      class(model_t), intent(in) :: self
      real(wp), intent(in) :: y(:)
      real(wp), intent(out) :: e, pot
      integer :: i, l, r
      real(wp) :: pe
      e = 0.0_wp
      pot = 0.0_wp
      do i = 1, size(self%nodes)
         select case (self%fn(i)%kind)
         case (nk_plain)
            e = e + 0.5_wp*self%fn(i)%j*self%omega(i)**2
         case (nk_held)
            e = e + 0.5_wp*self%fn(i)%j*self%omega(i)**2     ! j: the held node's inertia
         case default
            e = e + self%nodes(i)%n%stored_energy(y)
         end select
      end do
      do i = 1, size(self%elements)
         l = self%fe(i)%l
         r = self%fe(i)%r
         if (self%fe(i)%linear) then
            pe = 0.5_wp*self%fe(i)%k*(self%fe(i)%r1*self%theta(l) - self%fe(i)%r2*self%theta(r))**2
         else
            pe = element_potential(self, i)
         end if
         e = e + pe
         pot = pot + pe
      end do
   end subroutine model_workspace_energy

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
   !> Speed ratio w_right / w_left of element ie when its clearance is closed and it
   !> turns rigidly: the null vector of its closed-contact stiffness (shaft 1, gear pair
   !> r1/r2), else of its damping (a damper: 1). 0 if the element couples no speeds.
   real(wp) function closed_speed_ratio(model, ie) result(rho)
      type(model_t), intent(in) :: model
      integer, intent(in) :: ie
      real(wp) :: k(2, 2), c(2, 2)
      call model%elements(ie)%e%linearise(lin_closed, 1.0_wp, 1.0_wp, k, c)
      rho = 0.0_wp
      if (abs(k(2, 2)) > 0.0_wp) then
         rho = -k(1, 2)/k(2, 2)
      else if (abs(c(2, 2)) > 0.0_wp) then
         rho = -c(1, 2)/c(2, 2)
      end if
   end function closed_speed_ratio

   !> Node speeds when every clearance is closed and the train turns rigidly with
   !> node ref at w_ref: carried from ref along the elements' closed speed ratios
   !> until nothing changes (fixed nodes stop it). known(i): node i was reached.
   !> loop_el: 0, or the first element found joining two reached nodes at a ratio
   !> that disagrees with theirs (relative 1e-9): a loop of gears that cannot turn
   !> (the carrying goes on; a caller that needs a rigid motion reports it).
   subroutine rigid_speeds(model, ref, w_ref, w, known, loop_el)
      type(model_t), intent(in) :: model
      integer, intent(in) :: ref
      real(wp), intent(in) :: w_ref
      real(wp), allocatable, intent(out) :: w(:)
      logical, allocatable, intent(out) :: known(:)
      integer, intent(out) :: loop_el
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
   end subroutine rigid_speeds
   !> The settling budget (s after t_start) of a run with settle_tol > 0: settle_max_time,
   !> or 1000 settle periods (at least settle_time) when it is 0.
   pure real(wp) function settle_budget(r) result(span)
      type(run_settings_t), intent(in) :: r
      span = r%settle_max_time
      if (span == 0.0_wp) span = max(1000.0_wp*r%settle_period, r%settle_time)
   end function settle_budget
end module trainsim_model
