!> 'rk4': fixed-step classical RK4 with event location.
!>
!> The discrete modes are frozen inside a step, so the right-hand side is
!> smooth there and RK4 keeps its order. After each step the guards are
!> evaluated; if one went negative, its zero is found on the step's dense
!> output (no RHS evaluation) and refined on the RK4 step map itself
!> (s -> g(RK4(y, s)): Newton/secant steps, Illinois as the fallback) to the
!> event tolerance, the step ends there and `advance` returns adv_event; the driver updates the modes and the next
!> step completes the grid step. Steps stay on the t_start + k dt grid; a step
!> also ends at the driver's goal (an output time or a breakpoint of the
!> inputs, where the last stage is taken at the left limit).
!>
!> On a long train an event does not split the step of the whole train: the
!> step stays unsplit, and only the region around the event's element is
!> integrated again through its events (local event steps, `mr_begin`,
!> docs/decisions.md D-32).
!>
!> This module holds the type, the plain step and the step maps that event
!> location evaluates (the whole train, an element's part, the region L, one
!> of its components); its submodules the rest: trainsim_rk4_events (event
!> location), trainsim_rk4_region (the region of a local event step) and
!> trainsim_rk4_local (stepping that region through its events).
module trainsim_int_rk4
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_model_families, only: block_run_t
   use trainsim_integrator, only: integrator_t, adv_step, adv_reached, adv_event
   use trainsim_fixed_step, only: fixed_step_t
   implicit none
   private

   public :: rk4_t, new_rk4

   !> Step-map evaluations of the secant/Newton refinement before it falls back
   !> to Illinois false position on the bracket.
   integer, parameter :: max_secant = 8
   !> Local event steps: the region around an event's element holds the nodes
   !> within this many elements of its nodes. A change of the element's torque
   !> reaches, through the four stages of one RK4 step, the derivatives of its
   !> own nodes (k1), of their neighbours (k2), two elements out (k3) and three
   !> (k4): the unsplit step of every node farther out does not depend on the
   !> element at all.
   integer, parameter :: mr_depth = 3
   !> A local event step is taken only when the region and its boundary hold at
   !> most 1/mr_small of the nodes (a proper, small part of the train).
   integer, parameter :: mr_small = 4
   !> ... and only on trains of at least mr_min_nodes nodes: below that, splitting the
   !> whole train's step costs little (100 nodes: 1.4-1.55x the shaft chain per node-step)
   !> and a train stays on the global path, bit for bit what another tool that splits
   !> every event's step computes (D-32).
   integer, parameter :: mr_min_nodes = 100
   !> Time resolution of a located event, relative to t: the angles grow like
   !> omega t, so a guard that differences them (a clearance) carries rounding
   !> noise of order eps |theta| / (relative speed); some 64 ulps of t on the
   !> Table 5.5 rig at 16 s. The secant step accepts a zero known to this
   !> resolution when it is coarser than event_tol (late in long runs).
   real(wp), parameter :: t_res = 64.0_wp*epsilon(1.0_wp)

   !> The part of the train one element's guards depend on through an RK4 step:
   !> the last stage needs the element's nodes (d4) and their neighbours (k4),
   !> the third stage those (d3 = k4) and theirs (k3), the second stage those
   !> (d2 = k3) and theirs (k2); n*: node lists, e*: element lists, s*: state
   !> indices of the node lists (held nodes have none).
   type :: part_t
      logical :: used = .false.
      integer, allocatable :: k2(:), e2(:), d2(:), k3(:), e3(:), d3(:), k4(:), e4(:), d4(:)
      integer, allocatable :: sk2(:), sk3(:), sk4(:), sd4(:)
   end type part_t

   type, extends(fixed_step_t) :: rk4_t
      integer :: ng = 0
      real(wp), allocatable :: k1(:), k2(:), k3(:), k4(:), ytmp(:), ynew(:), ys(:)
      real(wp), allocatable :: g0(:), g1(:), gs(:)
      !> The guard test of a block's steps as windows (`guard_windows`, D-145)
      integer, allocatable :: gw_i(:, :)
      real(wp), allocatable :: gw(:, :)
      real(wp), allocatable :: yb(:)   !< RK4 to the negative end of the bracket
      ! event location: the stages of the step being located (its dense output),
      ! the dense-output state of one element's nodes, one element's guards
      real(wp), allocatable :: d2(:), d3(:), d4(:), yi(:), ge(:)
      integer, allocatable :: g_el(:), g_loc(:)     !< per guard: owner element, index in its guards
      integer, allocatable :: el_states(:, :)       !< per element: state ranges of its left, right node
      real(wp) :: t_loc = 0.0_wp, h_loc = 0.0_wp    !< the step being located
      !> The element whose guards `dense_guard` last asked `guard_angles` for
      !> (0: ask again; cleared where a location starts) and its answer.
      integer :: dg_e = 0, dg_l = 0, dg_r = 0
      type(part_t), allocatable :: part(:)          !< per element (guard elements of long trains)
      logical :: on_part = .false.                  !< ys holds only the part's states (not a full step)
      ! local (multirate) event steps, see `mr_begin`: the unsplit step of the
      ! whole train (start y0, stages, end) and the local region L (nodes within
      ! mr_depth elements of the elements whose guards fired), its boundary B, the
      ! elements with a node in L, their guard elements, the states of L and B
      logical :: multirate = .true.                 !< off: every event splits the whole train's step
      logical :: mr_on = .false.                    !< inside a local event step
      real(wp) :: mt0 = 0.0_wp, mh = 0.0_wp, mt1 = 0.0_wp, mt_grid = 0.0_wp, mt_c = 0.0_wp
      real(wp), allocatable :: my0(:), mk1(:), md2(:), md3(:), md4(:), mynew(:), yc(:)
      integer, allocatable :: adj_first(:), adj_list(:), el_nodes(:, :)
      logical, allocatable :: has_guards(:), in_l(:), in_kin(:), el_in(:), gel_in(:)
      integer, allocatable :: depth(:), stack(:), l_nodes(:), b_nodes(:), kin(:), els(:), gels(:), sl(:), sb(:)
      integer, allocatable :: in_els(:)             !< the elements with both nodes in L
      integer :: n_l = 0, n_b = 0, n_kin = 0, n_els = 0, n_gels = 0, n_sl = 0, n_sb = 0, n_in = 0
      logical :: at_local = .false.                 !< the event just returned is a local event instant
      logical :: y_partial = .false.                !< y outside L was not set at that instant (region_instants)
      real(wp) :: pr(2, 4) = 0.0_wp                 !< energy rates of L's terms at the unsplit stages
      real(wp) :: pk1(2) = 0.0_wp, pw_step(2) = 0.0_wp, pw_full(2) = 0.0_wp
      real(wp) :: e_acc(2) = 0.0_wp, e_book(2) = 0.0_wp, e_shown(2) = 0.0_wp
      integer(i8) :: mr_steps = 0, mr_events = 0, mr_collapses = 0, mr_node_rhs = 0   !< diagnostics
      !> The guard elements outside L that may be below zero somewhere on the
      !> unsplit step's dense output (`mr_far_list`, made at the step's first
      !> local event instant, far_done): the only ones checked at its instants.
      integer, allocatable :: far(:)
      integer :: n_far = 0
      logical :: far_done = .false.
      !> The connected parts (components) of L: comp(node) for the nodes of L
      !> (`mr_begin`); the lists of component cur_c (`mr_comp_lists`): its nodes
      !> (cn), elements with a node in it (ce), those nodes and their neighbours
      !> outside L (ck), their states (csl: of cn, csb: of the neighbours).
      !> A trial step of event location is taken on the event's component alone.
      integer, allocatable :: comp(:), ns_range(:, :), mark(:)
      integer, allocatable :: cn(:), ce(:), ck(:), csl(:), csb(:)
      integer :: n_comp = 0, cur_c = 0, n_cn = 0, n_ce = 0, n_ck = 0, n_csl = 0, n_csb = 0, stamp = 0
      !> k1 holds f(t_k1, ynew), evaluated at the end of the last plain step (the
      !> next step's first stage; used if the model's workspace is still that
      !> evaluation's, i.e. nothing changed the modes or the state since).
      logical :: k1_next = .false.
      real(wp) :: t_k1 = 0.0_wp
      !> A step `advance_block` computed but did not take (a guard below zero at
      !> its end): from (t_pend, y at the block's end) by h_pend, into ynew and
      !> k2..k4, its end's guards in g1. The next `advance` from there takes it
      !> as its step (D-38); `restart` and `start` drop it.
      logical :: pend = .false.
      real(wp) :: t_pend = 0.0_wp, h_pend = 0.0_wp
   contains
      procedure :: start => rk4_start
      procedure :: advance => rk4_advance
      procedure :: advance_block => rk4_advance_block
      procedure :: restart => rk4_restart
      procedure :: step => rk4_step
      procedure, private :: end_on_event => rk4_end_on_event
      procedure, private :: dense_guard => rk4_dense_guard
      procedure, private :: map_guard => rk4_map_guard
      procedure, private :: dense_root => rk4_dense_root
      procedure, private :: refine => rk4_refine
      procedure, private :: step_part => rk4_step_part
      procedure, private :: mr_begin => rk4_mr_begin
      procedure, private :: mr_continue => rk4_mr_continue
      procedure, private :: mr_locate => rk4_mr_locate
      procedure, private :: mr_step => rk4_mr_step
      procedure, private :: mr_bnd => rk4_mr_bnd
      procedure, private :: mr_rhs => rk4_mr_rhs
      procedure, private :: comp_step => mr_comp_step
      procedure, private :: end_copy => mr_end_copy
      procedure :: local_instant => rk4_local_instant
   end type rk4_t

   ! Event location (submodule trainsim_rk4_events, src/integrators/trainsim_rk4_events.f90)
   interface
      module subroutine build_parts(self, model)
         type(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
      end subroutine build_parts
      module subroutine rk4_step_part(self, model, y, e, s)
         class(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: y(:), s
         integer, intent(in) :: e
      end subroutine rk4_step_part
      module subroutine rk4_end_on_event(self, model, h, t, y)
         class(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: h
         real(wp), intent(inout) :: t, y(:)
      end subroutine rk4_end_on_event
      real(wp) module function rk4_dense_guard(self, model, y, j, s) result(g)
         class(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: y(:), s
         integer, intent(in) :: j
      end function rk4_dense_guard
      real(wp) module function rk4_map_guard(self, model, y, j, s) result(g)
         class(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: y(:), s
         integer, intent(in) :: j
      end function rk4_map_guard
      real(wp) module function rk4_dense_root(self, model, y, j, ga0, b0, gb0) result(b)
         class(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: y(:), ga0, b0, gb0
         integer, intent(in) :: j
      end function rk4_dense_root
      real(wp) module function rk4_refine(self, model, y, j, s0, ga0, b0, gb0) result(b)
         class(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: y(:), s0, ga0, b0, gb0
         integer, intent(in) :: j
      end function rk4_refine
   end interface

   ! Local event steps of a long train (D-32): the region (submodule
   ! trainsim_rk4_region, src/integrators/trainsim_rk4_region.f90) and its steps
   ! (submodule trainsim_rk4_local, src/integrators/trainsim_rk4_local.f90)
   interface
      module subroutine build_graph(self, model)
         type(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
      end subroutine build_graph
      module subroutine rk4_mr_begin(self, model, t, y, h, t_grid, ok)
         class(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: t, y(:), h, t_grid
         logical, intent(out) :: ok
      end subroutine rk4_mr_begin
      module subroutine rk4_mr_continue(self, model, t_goal, t, y, status, done)
         class(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: t_goal
         real(wp), intent(inout) :: t, y(:)
         integer, intent(out) :: status
         logical, intent(out) :: done
      end subroutine rk4_mr_continue
      real(wp) module function rk4_mr_locate(self, model, y) result(s_ev)
         class(rk4_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: y(:)
      end function rk4_mr_locate
      logical module function rk4_local_instant(self, nodes, states, els, gels) result(local)
         class(rk4_t), intent(in), target :: self
         integer, pointer, contiguous, intent(out) :: nodes(:), states(:), els(:), gels(:)
      end function rk4_local_instant
   end interface

contains

   !> Factory (registry row 'rk4').
   subroutine new_rk4(integ)
      class(integrator_t), allocatable, intent(out) :: integ
      allocate (rk4_t :: integ)
      integ%takes_blocks = .true.   ! (not an extension that steps differently, e.g. rk4-thesis)
   end subroutine new_rk4

   subroutine rk4_start(self, model, t, y, err)
      class(rk4_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t, y(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: n, j, i, e, side, nd, ng_max
      n = size(y)
      self%ng = model%n_guards
      self%k1_next = .false.
      self%pend = .false.
      allocate (self%k1(n), self%k2(n), self%k3(n), self%k4(n), self%ytmp(n), self%ynew(n), self%ys(n))
      allocate (self%g0(self%ng), self%g1(self%ng), self%gs(self%ng), self%gw_i(2, self%ng), self%gw(6, self%ng))
      allocate (self%d2(n), self%d3(n), self%d4(n), self%yi(n), self%yb(n))
      self%yi = 0.0_wp
      ! who owns each guard, and which states each element's guards read
      allocate (self%g_el(self%ng), self%g_loc(self%ng), self%el_states(4, size(model%elements)))
      ng_max = 0
      do j = 1, self%ng
         e = model%guard_element(j)
         self%g_el(j) = e
         self%g_loc(j) = j - model%guard_offset(e)
         ng_max = max(ng_max, self%g_loc(j))
      end do
      allocate (self%ge(max(ng_max, 1)))
      self%el_states(1:3:2, :) = 1   ! empty ranges (1:0) for held nodes
      self%el_states(2:4:2, :) = 0
      do e = 1, size(model%elements)
         if (model%elements(e)%e%n_ports() > 2) then   ! an n-port element (D-73): its guards may read every state
            self%el_states(1:2, e) = [1, model%n_states]
            cycle
         end if
         do side = 1, 2
            nd = model%elements(e)%e%left
            if (side == 2) nd = model%elements(e)%e%right
            if (model%is_held(nd)) cycle
            i = model%nodes(nd)%n%offset
            self%el_states(2*side - 1, e) = i + 1
            self%el_states(2*side, e) = i + model%nodes(nd)%n%nstates()
         end do
      end do
      call build_parts(self, model)
      call build_graph(self, model)
      self%mr_on = .false.
      call self%start_grid(model, t)
   end subroutine rk4_start

   !> One classical RK4 step of size h from (t, y) into ynew; k1 = f(t, y) given.
   !> A step that ends on a breakpoint of the inputs takes its last stage at the
   !> left limit there (a load that jumps at t + h acts from t + h on).
   subroutine rk4_step(self, model, t, y, h, ynew, left_limit)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, h
      !> (explicit size: their addresses only, no descriptors, unit stride)
      real(wp), intent(in) :: y(size(self%k1))
      real(wp), intent(out) :: ynew(size(self%k1))
      logical, intent(in) :: left_limit
      real(wp) :: t4
      t4 = t + h
      if (left_limit) t4 = t + h - 1.0e-9_wp*h
      ! inner stages at y + c k and the combination in one call of the model: no
      ! one reads its workspace after them (a simple model does not form the
      ! stages' states, D-75, and runs its kernels in one procedure, D-77)
      call model%rk4_stages(t, h, t4, y, self%k1, self%k2, self%k3, self%k4, self%ytmp, ynew)
      self%stats%rhs_evals = self%stats%rhs_evals + 3
   end subroutine rk4_step

   !> After the caller changed the modes or the state at t, or passed a
   !> breakpoint: k1 (the last step's end-of-step RHS) stays the next step's
   !> first stage only if y is still that step's end state (a change of the
   !> modes clears the model's workspace mark, which `advance` checks).
   subroutine rk4_restart(self, model, t, y, err)
      class(rk4_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t, y(:)
      type(error_t), allocatable, intent(out) :: err
      associate (unused_m => model, unused_t => t)
      end associate
      self%pend = .false.
      if (.not. self%k1_next) return
      if (any(y /= self%ynew)) self%k1_next = .false.
   end subroutine rk4_restart

   !> One sub-step: to the next grid point, or to t_goal if that comes first.
   subroutine rk4_advance(self, model, t_goal, t, y, status, err)
      class(rk4_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t_goal
      real(wp), intent(inout) :: t, y(:)
      integer, intent(out) :: status
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: t_grid, t_sub, h
      logical :: at_bp, done, below
      self%at_local = .false.
      if (self%mr_on) then
         ! inside a local event step: the next event of the region, or its end
         call self%mr_continue(model, t_goal, t, y, status, done)
         if (done) return
      end if
      t_grid = next_grid(self, t)
      t_sub = min(t_grid, t_goal)
      at_bp = self%stop_is_breakpoint .and. t_sub >= self%t_stop - self%tiny_t
      h = t_sub - t
      if (self%pend .and. t == self%t_pend .and. h == self%h_pend .and. .not. at_bp) then
         ! the step the block computed and left (D-38): ynew, k2..k4 and g1 hold it
         below = .true.
      else
         call first_stage(self, model, t, y)
         call rk4_step(self, model, t, y, h, self%ynew, at_bp)
         below = .false.
         if (self%ng > 0) below = model%guards_below(t + h, self%ynew, self%g1)
      end if
      self%pend = .false.
      self%k1_next = .false.
      if (below) then
         if (.not. at_bp) then
            call self%mr_begin(model, t, y, h, t_grid, done)
            if (done) then
               call self%mr_continue(model, t_goal, t, y, status, done)
               return
            end if
         end if
         call self%end_on_event(model, h, t, y)
         status = adv_event
         return
      end if
      y = self%ynew
      t = t_sub
      if (t >= t_grid - self%tiny_t) then
         t = t_grid
         ! count_grid_step, written out
         self%istep = self%istep + 1
         self%stats%steps = self%stats%steps + 1
      end if
      ! the RHS at the step's end is the next step's first stage: evaluated now,
      ! it leaves the end state's kinematics and element torques in the model's
      ! workspace for the observer (which then does not recompute them)
      call model%rhs_step_end(t, y, self%k1)
      self%stats%rhs_evals = self%stats%rhs_evals + 1
      model%ws_step_end = .true.
      self%k1_next = .true.
      self%t_k1 = t
      status = adv_step
      if (t >= t_goal - self%tiny_t) status = adv_reached
   end subroutine rk4_advance

   !> The next grid point after t: `grid_target` written out for the usual case,
   !> t not already on it (a call into fixed_step costs more than the arithmetic).
   real(wp) function next_grid(self, t) result(t_grid)
      class(rk4_t), intent(inout) :: self
      real(wp), intent(in) :: t
      t_grid = min(self%t0 + real(self%istep, wp)*self%dt, self%t_end)
      if (t >= t_grid - self%tiny_t) t_grid = self%grid_target(t)
   end function next_grid

   !> k1 = f(t, y), unless it is the last step's end-of-step RHS (D-33; D-37: a
   !> caller that changes y between two advances calls `restart`, which checks
   !> y against that end).
   subroutine first_stage(self, model, t, y)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:)
      if (self%k1_next .and. model%ws_step_end .and. t == self%t_k1 .and. model%ws_t == t) return
      call model%rhs(t, y, self%k1)
      self%stats%rhs_evals = self%stats%rhs_evals + 1
   end subroutine first_stage

   !> Plain steps toward t_goal in one call (D-38): whole grid steps, none
   !> ending on a breakpoint or past t_goal, none with a guard below zero at
   !> its end, at most model%blk%cap; step j's end goes to column j of
   !> model%blk (`rhs_step_end`), model%blk%n = the steps taken. It stops after
   !> a step whose state has an entry beyond y_limit or NaN (the caller reports
   !> it; also, harmlessly, where the sum of the entries' magnitudes is beyond
   !> y_limit but none is: the caller checks the state itself, D-126), and
   !> once t_goal - t <= t_tol (the caller's instant tolerance: a sliver of a
   !> step below it is no step). A step with a guard below zero at its end is
   !> not taken but kept (pend): the next `advance` from here takes it without
   !> computing it again, so the steps, the RHS evaluations and the results are
   !> those of `advance` step by step.
   subroutine rk4_advance_block(self, model, t_goal, t_tol, y_limit, t, y)
      class(rk4_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t_goal, t_tol, y_limit
      real(wp), intent(inout) :: t
      real(wp), intent(inout), contiguous :: y(:)
      real(wp) :: t_grid, h, t_bp, s, v1, v2
      integer :: j, i, n, nw, ns, n2
      logical :: below, fast
      model%blk%n = 0
      if (self%mr_on .or. self%pend .or. .not. self%takes_blocks) return
      n = 0
      n2 = size(y) - mod(size(y), 2)
      ns = 0   ! steps computed (taken, and one not taken)
      s = 0.0_wp
      t_bp = huge(1.0_wp)   ! a step ending at or after t_bp ends on the stop's breakpoint
      if (self%stop_is_breakpoint) t_bp = self%t_stop - self%tiny_t
      ! the guards' test of this block's modes (D-145); nw = -1: guards_below's
      nw = 0
      if (self%ng > 0) call model%guard_windows(nw, self%gw_i, self%gw)
      model%blk%ws = .false.   ! each step's column only; the workspace after the block
      ! after the first step the model takes the block's further steps in one
      ! call (`rk4_block`, D-168; with energy tracking too, D-182) where it can:
      ! the same steps, tests and values
      fast = .true.
      if (fast) call block_run(model%blk%run)
      j = 0
      do while (j < model%blk%cap)
         if (fast .and. j > 0) then
            model%blk%run%istep = self%istep
            model%blk%run%ns = ns
            call model%rk4_block(t, y, self%k1, self%k2, self%k3, self%k4, self%ynew, self%g1, self%gw_i, self%gw)
            self%istep = model%blk%run%istep
            j = model%blk%col
            n = j
            ns = model%blk%run%ns
            if (model%blk%run%pend) then
               self%pend = .true.
               self%t_pend = t
               self%h_pend = model%blk%run%h
            end if
            if (model%blk%run%done .or. j >= model%blk%cap) exit
            fast = .false.   ! (handed back: the rest here)
         end if
         j = j + 1
         ! next_grid, written out (after the block's first step t is on the grid)
         t_grid = min(self%t0 + real(self%istep, wp)*self%dt, self%t_end)
         if (t >= t_grid - self%tiny_t) t_grid = self%grid_target(t)
         if (t_grid > t_goal .or. t_grid >= t_bp) exit
         h = t_grid - t
         ! k1 as `advance` takes it; after a step of the block it is that step's
         ! end-of-step RHS
         if (j == 1) then
            call first_stage(self, model, t, y)
            self%k1_next = .false.
         end if
         ! rk4_step, written out (no breakpoint at the step's end: t4 = t + h)
         call model%rk4_stages(t, h, t + h, y, self%k1, self%k2, self%k3, self%k4, self%ytmp, self%ynew)
         ns = j
         if (nw /= 0) then
            below = .true.
            if (nw > 0) below = windows_below(nw, self%gw_i, self%gw, self%ynew)
            ! below zero: the guards' values into g1 (and guards_below's own answer)
            if (below) below = model%guards_below(t + h, self%ynew, self%g1)
            if (below) then
               self%pend = .true.
               self%t_pend = t
               self%h_pend = h
               exit
            end if
         end if
         ! y = ynew; the sum of |y(i)| is at least each of them, and NaN or
         ! infinite with one of them: within y_limit, so is each (D-126). Two
         ! entries a pass, summed in order (D-161)
         do i = 1, n2, 2
            v1 = self%ynew(i)
            v2 = self%ynew(i + 1)
            y(i) = v1
            y(i + 1) = v2
            s = s + abs(v1)
            s = s + abs(v2)
         end do
         if (n2 < size(y)) then
            y(n2 + 1) = self%ynew(n2 + 1)
            s = s + abs(self%ynew(n2 + 1))
         end if
         t = t_grid
         self%istep = self%istep + 1
         model%blk%col = j
         call model%rhs_step_end(t, y, self%k1)
         n = j
         if (.not. s <= y_limit .or. t_goal - t <= t_tol) exit
         s = 0.0_wp
      end do
      self%stats%rhs_evals = self%stats%rhs_evals + 3*ns
      model%blk%col = 0
      model%blk%ws = .true.
      model%blk%n = n
      if (n == 0) return
      ! the workspace of the block's last step: its step end again, the same
      ! values (k1 bit for bit; not counted: the same evaluation)
      call model%rhs_step_end(t, y, self%k1)
      ! the counters of n grid steps, and k1 of the last one for the next step
      self%stats%steps = self%stats%steps + n
      self%stats%block_steps = self%stats%block_steps + n
      self%stats%rhs_evals = self%stats%rhs_evals + n
      model%ws_step_end = .true.
      self%k1_next = .true.
      self%t_k1 = t
   contains
      !> The block's grid and limits for `rk4_block`
      subroutine block_run(b)
         type(block_run_t), intent(inout) :: b
         b%t0 = self%t0
         b%dt = self%dt
         b%t_end = self%t_end
         b%tiny_t = self%tiny_t
         b%t_goal = t_goal
         b%t_bp = t_bp
         b%t_tol = t_tol
         b%y_limit = y_limit
         b%nw = nw
      end subroutine block_run
   end subroutine rk4_advance_block

   include '../model/trainsim_model_windows.inc'

   ! The step maps of a local event step (L, one component of L). They stay in this
   ! module, not in a submodule: gfortran gives every procedure of a submodule an
   ! external symbol, and `mr_step_on`, `mr_bnd_on` there cost 16e6 instructions
   ! more (+0.5 %) on the 1000-node backlash chain (bench_rk4_throughput
   ! --profile chain-backlash, D-71).

   !> The RK4 step of L of size s from (t_loc, y) into ys (L's states; B's at
   !> t_loc + s from the unsplit step), k1 (L's, at t_loc) given; its energy
   !> rates' integral into pw_step. k2..k4 and ytmp are scratch.
   subroutine rk4_mr_step(self, model, y, s)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      call mr_step_on(self, model, y, s, self%sl(1:self%n_sl), self%sb(1:self%n_sb), self%kin(1:self%n_kin), &
                      self%els(1:self%n_els), self%l_nodes(1:self%n_l), model%run%track_energy)
   end subroutine rk4_mr_step

   !> The RK4 step of size s from (t_loc, y) into ys of the states sl (k1 given),
   !> with the boundary states sb at t_loc + s from the unsplit step's dense
   !> output; the RHS of the nodes `nodes` (kin: those whose kinematics it reads,
   !> els: their elements). With `power`, the integral of L's energy rates into
   !> pw_step (only for L's own lists: `part_power` reads L's). k2..k4 and ytmp
   !> are scratch. `mr_step` (L) and `mr_comp_step` (one component of L).
   subroutine mr_step_on(self, model, y, s, sl, sb, kin, els, nodes, power)
      type(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      integer, intent(in) :: sl(:), sb(:), kin(:), els(:), nodes(:)
      logical, intent(in) :: power
      real(wp) :: hh, h6, t, p2(2), p3(2), p4(2)
      integer :: q, i
      t = self%t_loc
      hh = 0.5_wp*s
      do q = 1, size(sl)
         i = sl(q)
         self%ytmp(i) = y(i) + hh*self%k1(i)
      end do
      call mr_bnd_on(self, self%ytmp, t + hh, sb)
      call stage(t + hh, self%k2, p2)
      do q = 1, size(sl)
         i = sl(q)
         self%ytmp(i) = y(i) + hh*self%k2(i)
      end do
      call stage(t + hh, self%k3, p3)
      do q = 1, size(sl)
         i = sl(q)
         self%ytmp(i) = y(i) + s*self%k3(i)
      end do
      call mr_bnd_on(self, self%ytmp, t + s, sb)
      call stage(t + s, self%k4, p4)
      h6 = s/6.0_wp
      do q = 1, size(sl)
         i = sl(q)
         self%ys(i) = y(i) + h6*(self%k1(i) + 2.0_wp*(self%k2(i) + self%k3(i)) + self%k4(i))
      end do
      do q = 1, size(sb)
         i = sb(q)
         self%ys(i) = self%ytmp(i)
      end do
      if (power) self%pw_step = h6*(self%pk1 + 2.0_wp*(p2 + p3) + p4)
   contains
      !> dy/dt of the nodes at (ts, ytmp) into k, and L's energy rates into p
      subroutine stage(ts, k, p)
         real(wp), intent(in) :: ts
         real(wp), intent(inout) :: k(:)
         real(wp), intent(out) :: p(2)
         call model%rhs_part(ts, self%ytmp, k, kin, els, nodes)
         self%mr_node_rhs = self%mr_node_rhs + size(nodes)
         p = 0.0_wp
         if (power) call model%part_power(ts, self%ytmp, els, nodes, self%in_l, p(1), p(2))
      end subroutine stage
   end subroutine mr_step_on

   !> The states of B at t (in the unsplit step) into v, from the unsplit
   !> step's dense output (the RK4 continuous extension, see dense_guard).
   subroutine rk4_mr_bnd(self, v, t)
      class(rk4_t), intent(inout) :: self
      real(wp), intent(inout) :: v(:)
      real(wp), intent(in) :: t
      call mr_bnd_on(self, v, t, self%sb(1:self%n_sb))
   end subroutine rk4_mr_bnd

   !> `mr_bnd` for the states sb of B.
   subroutine mr_bnd_on(self, v, t, sb)
      type(rk4_t), intent(inout) :: self
      real(wp), intent(inout) :: v(:)
      real(wp), intent(in) :: t
      integer, intent(in) :: sb(:)
      real(wp) :: th, b1, b2, b4
      integer :: q, i
      th = (t - self%mt0)/self%mh
      b1 = th*(1.0_wp - th*(1.5_wp - th*(2.0_wp/3.0_wp)))
      b2 = th*th*(1.0_wp - th*(2.0_wp/3.0_wp))
      b4 = th*th*(-0.5_wp + th*(2.0_wp/3.0_wp))
      do q = 1, size(sb)
         i = sb(q)
         v(i) = self%my0(i) + self%mh*(b1*self%mk1(i) + b2*(self%md2(i) + self%md3(i)) + b4*self%md4(i))
      end do
   end subroutine mr_bnd_on

   !> dy/dt of L's states at (t, v) (v holds L and B), and with energy tracking
   !> the energy rates of L's terms.
   subroutine rk4_mr_rhs(self, model, t, v, dydt, p)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, v(:)
      real(wp), intent(inout) :: dydt(:)
      real(wp), intent(out) :: p(2)
      call model%rhs_part(t, v, dydt, self%kin(1:self%n_kin), self%els(1:self%n_els), self%l_nodes(1:self%n_l))
      self%mr_node_rhs = self%mr_node_rhs + self%n_l
      p = 0.0_wp
      if (model%run%track_energy) call model%part_power(t, v, self%els(1:self%n_els), self%l_nodes(1:self%n_l), &
                                                      self%in_l, p(1), p(2))
   end subroutine rk4_mr_rhs

   !> A trial step of event location on the component of L that holds element
   !> e: `mr_step` for its states alone (the same values bit for bit: a node's
   !> derivative reads its own and its neighbours' states, all in the component
   !> or its boundary), into ys; no energy rates (pw_step unchanged).
   subroutine mr_comp_step(self, model, y, e, s)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      integer, intent(in) :: e
      if (self%comp(self%el_nodes(1, e)) /= self%cur_c) call mr_comp_lists(self, self%comp(self%el_nodes(1, e)))
      call mr_step_on(self, model, y, s, self%csl(1:self%n_csl), self%csb(1:self%n_csb), self%ck(1:self%n_ck), &
                      self%ce(1:self%n_ce), self%cn(1:self%n_cn), .false.)
   end subroutine mr_comp_step

   !> The lists of L's component c (cn, ce, ck, csl, csb; in the order of L's
   !> lists, so that each node's torque sums its elements in the same order).
   subroutine mr_comp_lists(self, c)
      type(rk4_t), intent(inout) :: self
      integer, intent(in) :: c
      integer :: k, e, nd, side, i
      self%cur_c = c
      self%n_cn = 0; self%n_ce = 0; self%n_ck = 0; self%n_csl = 0; self%n_csb = 0
      if (self%stamp == huge(1)) then   ! (after 2^31 lists: marks start again)
         self%mark = 0
         self%stamp = 0
      end if
      self%stamp = self%stamp + 1
      do k = 1, self%n_l
         nd = self%l_nodes(k)
         if (self%comp(nd) /= c) cycle
         self%n_cn = self%n_cn + 1
         self%cn(self%n_cn) = nd
         self%n_ck = self%n_ck + 1
         self%ck(self%n_ck) = nd
         do i = self%ns_range(1, nd), self%ns_range(2, nd)
            self%n_csl = self%n_csl + 1
            self%csl(self%n_csl) = i
         end do
      end do
      do k = 1, self%n_els
         e = self%els(k)
         if (.not. (in_c(self%el_nodes(1, e)) .or. in_c(self%el_nodes(2, e)))) cycle
         self%n_ce = self%n_ce + 1
         self%ce(self%n_ce) = e
         do side = 1, 2
            nd = self%el_nodes(side, e)
            if (self%in_l(nd) .or. self%mark(nd) == self%stamp) cycle
            self%mark(nd) = self%stamp
            self%n_ck = self%n_ck + 1
            self%ck(self%n_ck) = nd
            do i = self%ns_range(1, nd), self%ns_range(2, nd)
               self%n_csb = self%n_csb + 1
               self%csb(self%n_csb) = i
            end do
         end do
      end do
   contains
      logical function in_c(n)
         integer, intent(in) :: n
         in_c = .false.
         if (self%in_l(n)) in_c = self%comp(n) == c
      end function in_c
   end subroutine mr_comp_lists

   !> ys = the end of L's step (L's and B's states) in a local event step.
   subroutine mr_end_copy(self)
      class(rk4_t), intent(inout) :: self
      integer :: q
      do q = 1, self%n_sl
         self%ys(self%sl(q)) = self%ynew(self%sl(q))
      end do
      do q = 1, self%n_sb
         self%ys(self%sb(q)) = self%ynew(self%sb(q))
      end do
   end subroutine mr_end_copy
end module trainsim_int_rk4
