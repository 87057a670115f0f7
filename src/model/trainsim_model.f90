!> The model: nodes joined by elements, external torques, prescribed speeds and run settings. A model
!> is a plain value (no global state, no pointers): copy it to re-parameterise a run. The right-hand
!> side, the guards and the mode updates below are the only code the integrators call; they do no
!> allocation, I/O or string work.
!>
!> This module is the model's interface: its types and the signature of every procedure. The bodies live in submodules
!> by role (docs/architecture.md): trainsim_model_layout (assembly, state layout, kinematics), trainsim_model_tables
!> (the hot-path tables of the families, modes), trainsim_model_rhs (the right-hand side and its kernels),
!> trainsim_model_guards (guards and events), trainsim_model_energy (the energy ledger) and trainsim_model_linear (the
!> Jacobian, rigid speeds); the families' row types and hot-form arithmetic are trainsim_model_families.
module trainsim_model
   use trainsim_kinds, only: wp
   use trainsim_strings, only: string_t
   use trainsim_units, only: units_t
   use trainsim_motion, only: motion_t
   use trainsim_speed_law, only: load_t, law_none
   use trainsim_node, only: node_slot_t
   use trainsim_element, only: element_slot_t, hot_form_t
   use trainsim_param_list, only: param_list_t
   use trainsim_event, only: event_t
   use trainsim_model_families, only: fast_node_t, fast_element_t, guard_row_t, fast_load_t, families_t, block_run_t, jac_part_t
   use trainsim_run_settings, only: run_settings_t
   use trainsim_constraints, only: constraint_set_t
   implicit none
   private
   public :: model_t, run_settings_t, load_t, closed_speed_ratio, rigid_speeds, settle_budget

   !> The end-of-step quantities the observer folds, for up to `cap` plain steps an integrator takes in one
   !> call (`advance_block`, D-38). Inside a block, column `col` is written by `rhs_step_end` of a simple model
   !> (col = 0 outside a block: none); the workspace (el_disp, el_force, el_torque, theta, torque) too unless
   !> `ws` is cleared (then the integrator writes it after the block: it holds the last step's end).
   type, public :: step_block_t
      integer :: cap = 1          !< columns
      integer :: col = 0          !< the column the next `rhs_step_end` writes (0: none)
      logical :: ws = .true.      !< with col > 0: the workspace too (see above, D-120)
      integer :: n = 0            !< steps in the block just taken
      real(wp), allocatable :: t(:)                      !< (step) its end time
      !> (element, step): el_disp, el_force and el_torque(2, :) at the step's end
      real(wp), allocatable :: disp(:, :), force(:, :), torque(:, :)
      real(wp), allocatable :: omega(:, :)               !< (node, step): omega at the step's end
      real(wp), allocatable :: stored(:), elastic(:), work(:, :)   !< (step); (2, step): the work states
      type(block_run_t) :: run   !< the block's grid and limits for `rk4_block` (D-168)
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
      type(param_list_t), allocatable :: element_params(:)   !< the builder's params() lists (D-175)
      type(load_t), allocatable :: loads(:)
      type(motion_t), allocatable :: speeds(:)   !< prescribed motions (speed, angle or acceleration)
      integer, allocatable :: speed_of(:)        !< per node: index into speeds, 0 if free
      integer, allocatable :: share_set(:)       !< per element: its set of planet meshes (D-96), 0 none
      integer :: n_states = 0                    !< physical states
      integer :: n_y = 0                         !< + 2 energy-accounting states if tracked
      integer :: n_guards = 0
      integer, allocatable :: guard_offset(:)    !< per element
      real(wp) :: energy0 = 0.0_wp               !< stored energy at t_start
      real(wp), allocatable :: modes_at(:)       !< [t, y] of the last init_modes; unset by a mode change (D-183)
      logical :: any_needs_loads = .false.       !< some element reads its nodes' external loads
      !> some element has more than two ports (D-73): the general path only (no simple kernels, hot forms or linear-spring form for it, no RK4 local steps)
      logical :: nport = .false.
      ! workspace (sized once in `finalize`)
      real(wp), allocatable :: theta(:), omega(:), torque(:)
      !> Per element: its torque on its left (1) and right (2) node at the last full RHS (column ne + 1: zeros, D-95).
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
      !> The stored energy (kinetic + elastic) and its elastic part at the last full RHS if that was
      !> `rhs_step_end`, `workspace_energy`'s to the bit, if ws_energy (D-36: a simple model with energy
      !> tracking whose elements are all linear springs or hot forms with agreeing elastic energy).
      real(wp) :: ws_stored = 0.0_wp, ws_elastic = 0.0_wp
      logical :: ws_energy = .false.
      !> The workspace (theta, omega, torque, el_torque) holds the full RHS at (ws_t, the state an integrator has just
      !> returned): set by the integrator right after it evaluated the RHS there (RK4's end-of-step evaluation, which
      !> is the next step's first stage); cleared by every other use of the workspace (`rhs`, `rhs_part`,
      !> `kinematics`, `apply_events`, ...). The observer then reads the element torques instead of recomputing them.
      logical :: ws_step_end = .false.
      real(wp) :: ws_t = 0.0_wp
      !> The ends of the steps of a block (D-38), sized by `finalize`.
      type(step_block_t) :: blk
      ! The hot path (`build_fast_path`, redone by `finalize` and at the start of every run in `init_modes`, so a
      ! re-parameterised copy is current): nodes that are plain inertias and elements that are linear springs (their
      ! optional capabilities, checked against their own procedures) are evaluated from these arrays, without calls
      ! through the polymorphic objects; every other node and element is asked as before.
      type(fast_node_t), allocatable, private :: fn(:)
      type(fast_element_t), allocatable, private :: fe(:)
      !> Per element: its hot form (D-35) in its current mode, refreshed after every mode change the model
      !> makes (`refresh_hot`); apart from fe (which every element's evaluation reads) so that fe stays small.
      type(hot_form_t), allocatable, private :: fh(:)
      real(wp), allocatable, private :: jdtq(:, :)   !< `jacobian`'s node gains (5, nodes), kept: no allocation a call
      type(guard_row_t), allocatable, private :: gr(:)   !< per element (guards), see guard_row_t
      !> Elements with guards but no guard row (kept by refresh_hot): at 0, every
      !> guard is a row's and `model_guards` runs on plain arrays.
      integer, private :: n_norow = 0
      type(fast_load_t), allocatable, private :: fl(:)
      integer, allocatable, private :: guard_els(:)        !< the elements that have guards
      integer, allocatable, private :: dyn_loads(:)        !< loads summed at t (on nodes with a varying load)
      integer, allocatable, private :: spd_loads(:)        !< loads with a speed law (summed at t and omega)
      logical, private :: loads_vary = .false.             !< dyn_loads or spd_loads not empty
      !> Every node a plain inertia or held at a constant speed, every load
      !> constant, no element reads the loads: `rhs` runs the kernel `rhs_simple`.
      logical, private :: simple = .false.
      !> The families of a simple model, its kernels' tables (built with those above).
      type(families_t), private :: fam
      !> Elements whose elastic energy `rhs_simple` cannot compute (fe%cold), and
      !> that kernel's per-element elastic energies (summed after the kinetic).
      integer, private :: n_cold = 0
      real(wp), allocatable, private :: el_pe(:)
      !> Kinematic constraints (D-81; allocatable: a plain one cost the simple kernels 11 instr/step)
      type(constraint_set_t), allocatable :: cn
      integer :: n_cand = 0   !< size(cn%cand): elements that may constrain (then never simple)
      real(wp), allocatable :: g_el(:)      !< one element's guards: sized to the largest n_guards (finalize)
      logical, allocatable :: fired_el(:)   !< and which of them fired
   contains
      procedure :: finalize => model_finalize
      procedure :: initial_state => model_initial_state
      procedure :: kinematics => model_kinematics
      procedure :: kinematics_part => model_kinematics_part
      procedure :: rhs => model_rhs
      procedure :: rhs_step_end => model_rhs_step_end
      procedure :: rhs_stage => model_rhs_stage
      procedure :: rk4_stages => model_rk4_stages
      procedure :: rk4_block => model_rk4_block
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
      procedure :: guard_windows => model_guard_windows
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

   interface

      !> Lay out the state vector and size the workspace; call after nodes,
      !> elements, loads and speeds are set, and again after re-parameterising a
      !> copy in a way that changes the layout (e.g. run%track_energy).
      module subroutine model_finalize(self)
         class(model_t), intent(inout) :: self
      end subroutine model_finalize

      !> Tables of the hot path from the nodes' and elements' current parameters.
      !> A node that says it is a plain inertia (`plain_inertia`) or an element
      !> that says it is a linear spring (`linear_spring`) is taken at its word
      !> only if its own procedures agree at two probe points (a type extended
      !> from one of them that changes its physics but not the claim is then
      !> still asked through its procedures).
      module subroutine model_build_fast_path(self)
         class(model_t), intent(inout) :: self
      end subroutine model_build_fast_path

      !> Whether node i has a prescribed speed.
      module pure logical function model_is_held(self, i) result(held)
         class(model_t), intent(in) :: self
         integer, intent(in) :: i
      end function model_is_held

      !> Index of the node with this id (0 if none).
      module pure integer function model_node_index(self, id) result(idx)
         class(model_t), intent(in) :: self
         character(len=*), intent(in) :: id
      end function model_node_index

      !> The initial state vector (energy states zero).
      module subroutine model_initial_state(self, y)
         class(model_t), intent(inout) :: self
         real(wp), allocatable, intent(out) :: y(:)
      end subroutine model_initial_state

      !> Node angles and speeds at (t, y) into self%theta, self%omega.
      module subroutine model_kinematics(self, t, y)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
      end subroutine model_kinematics

      !> The kinematics of the nodes `nodes` only, into the workspace (the
      !> observer at a local event instant, D-32).
      module subroutine model_kinematics_part(self, t, y, nodes)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
         integer, intent(in) :: nodes(:)
      end subroutine model_kinematics_part

      !> `model_kinematics` without the dispatch (the hot path calls it directly).
      module subroutine kinematics_all(self, t, y)
         type(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
      end subroutine kinematics_all

      !> dy/dt at (t, y). Leaves node kinematics and net node torques in the workspace. Linear-spring elements
      !> and plain-inertia nodes come from the hot-path tables; the others are asked through their procedures,
      !> in the same order.
      module subroutine model_rhs(self, t, y, dydt)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
         real(wp), intent(out) :: dydt(:)
      end subroutine model_rhs

      !> `rhs_fast` of a simple model: the kernel `rhs_simple` with the model's workspace, and at a step's end inside a
      !> block (D-38) its column. On explicit-size y and dydt (addresses only: called for every step of a block).
      module subroutine rhs_simple_ws(self, t, y, dydt, step_end)
         type(model_t), intent(inout) :: self
         real(wp), intent(in) :: t
         real(wp), intent(in) :: y(self%n_y)
         real(wp), intent(out) :: dydt(self%n_y)
         logical, intent(in) :: step_end   !< leave the stored energy too (`model_rhs_step_end`)
      end subroutine rhs_simple_ws

      !> `model_rk4_stages` with energy tracking, in a file of its own (D-169).
      module subroutine rk4_energy_stages(self, t, h, t4, y, k1, k2, k3, k4, ynew)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, h, t4, y(self%n_y), k1(self%n_y)
         real(wp), intent(out) :: k2(self%n_y), k3(self%n_y), k4(self%n_y), ynew(self%n_y)
      end subroutine rk4_energy_stages
      !> `model_rhs_step_end` with energy tracking inside a block (D-120), a procedure of its own (D-160).
      module subroutine column_energy_end(self, t, y, dydt)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(self%n_y)
         real(wp), intent(out) :: dydt(self%n_y)
      end subroutine column_energy_end

      !> `model_rhs` at the end of an integrator's step, where the observer reads the workspace (RK4, D-33): a
      !> simple model with energy tracking also leaves the stored energy there (D-36). Every other RHS
      !> (CVODE's, the stages, the event location) is `model_rhs`, which does not compute it.
      module subroutine model_rhs_step_end(self, t, y, dydt)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t
         !> (explicit size: their addresses only, no descriptors)
         real(wp), intent(in) :: y(self%n_y)
         real(wp), intent(out) :: dydt(self%n_y)
      end subroutine model_rhs_step_end

      !> dy/dt at (t, y) as `model_rhs`, bit for bit, for an inner stage: a simple model's stage
      !> kernel (energy off or on, D-40) stores only dy/dt and the element torques, and the
      !> workspace then holds nothing to read (`ws_step_end` cleared). Others run `model_rhs`.
      module subroutine model_rhs_stage(self, t, y, dydt)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t
         !> (explicit size: their addresses only, D-41)
         real(wp), intent(in) :: y(self%n_y)
         real(wp), intent(out) :: dydt(self%n_y)
      end subroutine model_rhs_stage

      !> RK4's inner stages and combination (D-77), given k1 = f(t, y): k2 = f(t + h/2, y + h/2 k1), k3 = f(t + h/2,
      !> y + h/2 k2), k4 = f(t4, y + h k3), each bit for bit `model_rhs_stage` there, and ynew = y + h/6 (k1 + 2 (k2
      !> + k3) + k4). A simple model's kernel reads y(j) + c k(j) without forming it (ytmp untouched, D-75); any
      !> other model forms it in ytmp and runs `model_rhs`.
      module subroutine model_rk4_stages(self, t, h, t4, y, k1, k2, k3, k4, ytmp, ynew)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, h, t4
         !> (explicit size: their addresses only, D-41)
         real(wp), intent(in) :: y(self%n_y), k1(self%n_y)
         real(wp), intent(inout) :: k2(self%n_y), k3(self%n_y), k4(self%n_y), ytmp(self%n_y)
         real(wp), intent(out) :: ynew(self%n_y)
      end subroutine model_rk4_stages

      !> A block's further plain RK4 steps in one call (D-168), after its column blk%col: trainsim_model_block.
      module subroutine model_rk4_block(self, t, y, k1, k2, k3, k4, ynew, g1, gw_i, gw)
         class(model_t), intent(inout) :: self
         real(wp), intent(inout) :: t, y(self%n_y), k1(self%n_y), k2(self%n_y), k3(self%n_y), k4(self%n_y), ynew(self%n_y), g1(*)
         integer, intent(in) :: gw_i(2, *)
         real(wp), intent(in) :: gw(6, *)
      end subroutine model_rk4_block
      !> `model_rk4_block` with energy tracking, in a file of its own (D-182).
      module subroutine rk4_block_energy(self, t, y, k1, k2, k3, k4, ynew, g1, gw_i, gw)
         class(model_t), intent(inout) :: self
         real(wp), intent(inout) :: t, y(self%n_y), k1(self%n_y), k2(self%n_y), k3(self%n_y), k4(self%n_y), ynew(self%n_y), g1(*)
         integer, intent(in) :: gw_i(2, *)
         real(wp), intent(in) :: gw(6, *)
      end subroutine rk4_block_energy

      !> Whether an integrator may take a block of steps (D-38) in the current modes: a simple model whose `rhs_step_end`
      !> leaves in the block's columns all the observer folds after a step (every element's status in the workspace,
      !> with energy tracking the stored energy), and room for two steps at least.
      module logical function model_block_ok(self) result(ok)
         class(model_t), intent(in) :: self
      end function model_block_ok

      !> Torques of element i on its left and right node at the kinematics in the workspace (after
      !> `kinematics`): the hot path for linear springs.
      module subroutine model_element_torques(self, i, tl, tr)
         class(model_t), intent(in) :: self
         integer, intent(in) :: i
         real(wp), intent(out) :: tl, tr
      end subroutine model_element_torques

      !> Elastic energy in all elements at the kinematics in the workspace.
      module real(wp) function model_potential_energy(self) result(e)
         class(model_t), intent(in) :: self
      end function model_potential_energy

      !> dy/dt at (t, y) for the states of the nodes der(:) only (event location on a part of a long train).
      !> kin(:) must hold der and every node of the elements els(:), and els every element of a node in der,
      !> in increasing order: the torques then add up in the same order as in `rhs`, and the derivatives of
      !> der are bit for bit those of `rhs`. Other entries of dydt are left as they were; no energy rates.
      module subroutine model_rhs_part(self, t, y, dydt, kin, els, der)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
         real(wp), intent(inout) :: dydt(:)
         integer, intent(in) :: kin(:), els(:), der(:)
      end subroutine model_rhs_part

      !> The energy rates of a part of the train at the kinematics and torques `rhs_part` just left in the
      !> workspace (same t, kin, els, der): pdiss and pin of the elements els, of the nodes der (in_der: the
      !> same set as a mask over the nodes) and of the loads on them; the terms are those of `rhs`, so the
      !> rates of a partition of the train add up to the whole train's.
      module subroutine model_part_power(self, t, y, els, der, in_der, pdiss, pin)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
         integer, intent(in) :: els(:), der(:)
         logical, intent(in) :: in_der(:)
         real(wp), intent(out) :: pdiss, pin
      end subroutine model_part_power

      !> External load torques at t into self%torque, and published to the
      !> elements that read their nodes' loads.
      module subroutine model_apply_loads(self, t)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t
      end subroutine model_apply_loads

      !> Dense Jacobian d(dydt)/dy at (t, y) in the current modes (energy rows zero); constant: it stays constant
      !> until the next event (D-162); part: its constant part, or the varying elements' parts added (D-170, jac_part_t).
      module subroutine model_jacobian(self, t, y, jac, constant, part)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
         real(wp), intent(inout) :: jac(:, :)
         logical, intent(out), optional :: constant
         type(jac_part_t), intent(inout), optional :: part
      end subroutine model_jacobian

      !> All elements' guards at (t, y) (a mode is valid while every guard is >= 0).
      module subroutine model_guards(self, t, y, g)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
         real(wp), intent(out) :: g(:)
      end subroutine model_guards

      !> `model_guards` on an integrator's own arrays (explicit size: their addresses only, no descriptors),
      !> and whether a guard is below zero: the check at the end of every RK4 step (D-38). All rows:
      !> guard_rows.
      module logical function model_guards_below(self, t, y, g) result(below)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t
         real(wp), intent(in) :: y(self%n_y)
         real(wp), intent(inout) :: g(self%n_guards)
      end function model_guards_below

      !> `guards_below`'s test as windows (D-145), valid until the modes change; n = -1 where an element has
      !> no guard row. See trainsim_model_guards.
      module subroutine model_guard_windows(self, n, iw, w)
         class(model_t), intent(in) :: self
         integer, intent(out) :: n, iw(2, *)
         real(wp), intent(out) :: w(6, *)
      end subroutine model_guard_windows

      !> The guards of element i alone at (t, y), into g(1:n_guards of i): only the
      !> kinematics of its two nodes are evaluated (for event location, where one
      !> guard is followed on a trial state; a node's kinematics reads only its own
      !> states y(offset+1:offset+nstates)).
      module subroutine model_element_guards(self, i, t, y, g)
         class(model_t), intent(inout) :: self
         integer, intent(in) :: i
         real(wp), intent(in) :: t, y(:)
         real(wp), intent(out) :: g(:)
      end subroutine model_element_guards

      !> Guard k (1 .. n_guards of i) of element i alone at (t, y): `element_guards`
      !> for one guard (event location follows one guard on trial states), bit for
      !> bit its value; a hot form on two plain inertias reads only their angles.
      module real(wp) function model_element_guard(self, i, k, t, y) result(gk)
         class(model_t), intent(inout) :: self
         integer, intent(in) :: i, k
         real(wp), intent(in) :: t, y(:)
      end function model_element_guard

      !> Where element i's guards are its hot form's (D-35) on two plain inertias
      !> (they read only the two nodes' angles): the state indices of those angles,
      !> else 0 and 0. Valid until the element's mode changes (`apply_events`).
      module pure subroutine model_guard_angles(self, i, yl, yr)
         class(model_t), intent(in) :: self
         integer, intent(in) :: i
         integer, intent(out) :: yl, yr
      end subroutine model_guard_angles

      !> Guard k of element i from its nodes' angles, where `guard_angles` gave
      !> their state indices: bit for bit `element_guard` at a state with those angles.
      module pure real(wp) function model_angle_guard(self, i, k, thl, thr) result(gk)
         class(model_t), intent(in) :: self
         integer, intent(in) :: i, k
         real(wp), intent(in) :: thl, thr
      end function model_angle_guard

      !> A lower bound of element i's guards (where `guard_angles` gave their
      !> state indices) over all angles within thl +- rl, thr +- rr, with room for
      !> the rounding of the angles and of the guards' arithmetic; -huge for an
      !> element without a guard row. Local event steps (D-32) use it to skip the
      !> elements that cannot be below zero anywhere on a step's dense output.
      module pure real(wp) function model_guard_floor(self, i, thl, rl, thr, rr) result(gmin)
         class(model_t), intent(in) :: self
         integer, intent(in) :: i
         real(wp), intent(in) :: thl, rl, thr, rr
      end function model_guard_floor

      !> The element that owns guard j (0 if none).
      module pure integer function model_guard_element(self, j) result(owner)
         class(model_t), intent(in) :: self
         integer, intent(in) :: j
      end function model_guard_element

      !> Angle and speed of node i at (t, y).
      module pure subroutine node_kinematics(self, i, t, y, th, om)
         type(model_t), intent(in) :: self
         integer, intent(in) :: i
         real(wp), intent(in) :: t, y(:)
         real(wp), intent(out) :: th, om
      end subroutine node_kinematics

      !> Set every element's discrete mode from the state at t_start. With
      !> `tables = .false.` (an analysis of the state: the dt advice and
      !> checks, D-74) the fast-path tables are not rebuilt first: the
      !> elements' own procedures are current, the hot path may not be until
      !> a run's own init_modes (every run starts with one).
      module subroutine model_init_modes(self, t, y, tables)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
         logical, intent(in), optional :: tables
      end subroutine model_init_modes

      !> Element j's static-preload mode (`preload_mode` of the element: face +1,
      !> -1 or 0, zones from the angles) at the given kinematics, through the
      !> model, which refreshes the element's hot form (D-35).
      module subroutine model_preload_mode(self, j, face, thl, wl, thr, wr)
         class(model_t), intent(inout) :: self
         integer, intent(in) :: j, face
         real(wp), intent(in) :: thl, wl, thr, wr
      end subroutine model_preload_mode

      !> The hot form (D-35) the model holds for element i: the torque form (hf_*, hf_none
      !> when asked through `torques`) and the guard form (hg_*); the serial chain's links (D-106).
      module pure subroutine model_hot_kinds(self, i, kind, guards, chain)
         class(model_t), intent(in) :: self
         integer, intent(in) :: i
         integer, intent(out) :: kind, guards
         integer, intent(out), optional :: chain
      end subroutine model_hot_kinds

      !> Ask element i for its hot form (D-35) in its current mode and take it only
      !> where the element's own procedures agree bit for bit at three probe
      !> states (`torques`, `torques_dissipation`, `guards`): otherwise the
      !> element is asked through its procedures as before. Torque forms only for
      !> elements that read no loads and supply no power, and not for linear
      !> springs (they have their own form).
      module subroutine refresh_hot(self, i)
         type(model_t), intent(inout) :: self
         integer, intent(in) :: i
      end subroutine refresh_hot

      module subroutine constraints_setup(self)   ! kinematic constraints (D-81; docs: trainsim_model_constraints)
         type(model_t), intent(inout) :: self
      end subroutine constraints_setup
      module subroutine constraints_rhs(self, t, y, dydt, t_now)
         type(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
         real(wp), intent(inout), optional :: dydt(:)
         logical, intent(in), optional :: t_now
      end subroutine constraints_rhs
      module subroutine constraints_settle(self, t, y, events, nev, dstored, project)
         type(model_t), intent(inout) :: self
         real(wp), intent(in) :: t
         real(wp), intent(inout) :: y(:)
         type(event_t), allocatable, intent(inout) :: events(:)
         integer, intent(inout) :: nev
         real(wp), intent(out) :: dstored
         logical, intent(in) :: project
      end subroutine constraints_settle

      !> Update the modes of the elements whose guards fired; the events that
      !> result are appended to events(nev+1:) (with the time and the element
      !> index filled in; the array grows when full, so no event is dropped).
      !> A mode change that changes the stored energy (a mesh-stiffness switch while teeth are loaded) is
      !> work done on the train, booked to the work-input state: the energy balance keeps closing.
      !> With `els` (a local event instant, D-32: the elements with guards of the
      !> region, whose nodes are integration points there), only those elements are
      !> looked at (fired is read only at their guards), only their nodes'
      !> kinematics are computed, and the change of the stored energy is that of
      !> their elastic energy (the only terms a mode change can change).
      module subroutine model_apply_events(self, t, y, fired, events, nev, els)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t
         real(wp), intent(inout) :: y(:)
         logical, intent(in) :: fired(:)
         type(event_t), allocatable, intent(inout) :: events(:)
         integer, intent(inout) :: nev
         integer, intent(in), optional :: els(:)
      end subroutine model_apply_events

      !> Whether any clearance element is in contact (thesis-mode step control).
      module pure logical function model_any_contact(self) result(c)
         class(model_t), intent(in) :: self
      end function model_any_contact

      !> Kinetic + elastic (+ magnetic) energy at (t, y).
      module real(wp) function model_stored_energy(self, t, y) result(e)
         class(model_t), intent(inout) :: self
         real(wp), intent(in) :: t, y(:)
      end function model_stored_energy

      !> Stored energy (the kinetic sum + the elastic sum, D-160) and the elastic part alone at the kinematics
      !> in the workspace and y (nodes with states of their own); bit for bit `stored_energy`'s.
      module subroutine model_workspace_energy(self, y, e, pot)
         class(model_t), intent(in) :: self
         real(wp), intent(in) :: y(:)
         real(wp), intent(out) :: e, pot
      end subroutine model_workspace_energy

      !> Sorted times strictly inside (t0, t1) where a load, a prescribed speed, a node's
      !> or an element's own input (motor voltage, engagement) jumps or kinks: steps end there.
      module subroutine model_breakpoints(model, t0, t1, bp)
         class(model_t), intent(in) :: model
         real(wp), intent(in) :: t0, t1
         real(wp), allocatable, intent(out) :: bp(:)
      end subroutine model_breakpoints

      !> For messages: "state 2 of node 'gear1' (gear1.speed)" for state index s.
      module function model_state_label(model, s) result(label)
         class(model_t), intent(in) :: model
         integer, intent(in) :: s
         character(len=:), allocatable :: label
      end function model_state_label

      !> Speed ratio w_right / w_left of element ie when its clearance is closed and it
      !> turns rigidly: the null vector of its closed-contact stiffness (shaft 1, gear pair
      !> r1/r2), else of its damping (a damper: 1). 0 if the element couples no speeds.
      module real(wp) function closed_speed_ratio(model, ie) result(rho)
         type(model_t), intent(in) :: model
         integer, intent(in) :: ie
      end function closed_speed_ratio

      !> Node speeds when every clearance is closed and the train turns rigidly with
      !> node ref at w_ref: carried from ref along the elements' closed speed ratios
      !> until nothing changes (fixed nodes stop it). known(i): node i was reached.
      !> loop_el: 0, or the first element found joining two reached nodes at a ratio
      !> that disagrees with theirs (relative 1e-9): a loop of gears that cannot turn
      !> (the carrying goes on; a caller that needs a rigid motion reports it).
      module subroutine rigid_speeds(model, ref, w_ref, w, known, loop_el)
         type(model_t), intent(in) :: model
         integer, intent(in) :: ref
         real(wp), intent(in) :: w_ref
         real(wp), allocatable, intent(out) :: w(:)
         logical, allocatable, intent(out) :: known(:)
         integer, intent(out) :: loop_el
      end subroutine rigid_speeds

      !> The settling budget (s after t_start) of a run with settle_tol > 0: settle_max_time,
      !> or 1000 settle periods (at least settle_time) when it is 0.
      module pure real(wp) function settle_budget(r) result(span)
         type(run_settings_t), intent(in) :: r
      end function settle_budget

   end interface
end module trainsim_model
