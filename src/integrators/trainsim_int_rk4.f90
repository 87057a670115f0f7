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
module trainsim_int_rk4
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
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
      procedure :: local_instant => rk4_local_instant
   end type rk4_t

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
      allocate (self%g0(self%ng), self%g1(self%ng), self%gs(self%ng))
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
         if (model%elements(e)%e%n_ports() > 2) then   ! an n-port element (D-71): its guards may read every state
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

   !> For each element with guards in a long train: the part of the train its
   !> guards see through one RK4 step (type part_t). Used when that part has
   !> fewer than half the nodes: the step map is then evaluated on the part
   !> only while an event is located, and stays bit for bit the full step's.
   subroutine build_parts(self, model)
      type(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      integer :: nn, ne, e, i
      integer, allocatable :: first(:), list(:), fill(:)
      nn = size(model%nodes)
      ne = size(model%elements)
      allocate (self%part(ne))
      if (self%ng == 0) return
      ! node -> elements (compressed rows, elements in increasing order)
      allocate (first(nn + 1), fill(nn))
      first = 0
      do e = 1, ne
         first(model%elements(e)%e%left + 1) = first(model%elements(e)%e%left + 1) + 1
         first(model%elements(e)%e%right + 1) = first(model%elements(e)%e%right + 1) + 1
      end do
      first(1) = 1
      do i = 1, nn
         first(i + 1) = first(i + 1) + first(i)
      end do
      allocate (list(first(nn + 1) - 1))
      fill = first(1:nn)
      do e = 1, ne
         associate (l => model%elements(e)%e%left, r => model%elements(e)%e%right)
            list(fill(l)) = e; fill(l) = fill(l) + 1
            if (r /= l) then
               list(fill(r)) = e; fill(r) = fill(r) + 1
            end if
         end associate
      end do
      do e = 1, ne
         if (model%elements(e)%e%n_guards() == 0) cycle
         associate (p => self%part(e))
            p%d4 = unique([model%elements(e)%e%left, model%elements(e)%e%right])
            call grow(p%d4, p%e4, p%k4)
            p%d3 = p%k4
            call grow(p%d3, p%e3, p%k3)
            p%d2 = p%k3
            call grow(p%d2, p%e2, p%k2)
            p%used = 2*size(p%k2) < nn .and. .not. model%nport   ! (parts by left and right only)
            p%sk2 = states_of(p%k2)
            p%sk3 = states_of(p%k3)
            p%sk4 = states_of(p%k4)
            p%sd4 = states_of(p%d4)
         end associate
      end do
   contains

      !> The elements of nodes d (increasing) and d with their other ends.
      subroutine grow(d, els, k)
         integer, intent(in) :: d(:)
         integer, allocatable, intent(out) :: els(:), k(:)
         integer :: a, q
         allocate (els(0), k(0))
         do a = 1, size(d)
            do q = first(d(a)), first(d(a) + 1) - 1
               els = [els, list(q)]
            end do
         end do
         els = unique(els)
         k = d
         do a = 1, size(els)
            k = [k, model%elements(els(a))%e%left, model%elements(els(a))%e%right]
         end do
         k = unique(k)
      end subroutine grow

      !> Sorted, without repeats.
      function unique(a) result(u)
         integer, intent(in) :: a(:)
         integer, allocatable :: u(:)
         integer :: q
         logical, allocatable :: seen(:)
         allocate (seen(max(nn, ne)))
         seen = .false.
         do q = 1, size(a)
            seen(a(q)) = .true.
         end do
         u = pack([(q, q=1, size(seen))], seen)
      end function unique

      !> State indices of the free nodes in nodes(:).
      function states_of(nodes) result(st)
         integer, intent(in) :: nodes(:)
         integer, allocatable :: st(:)
         integer :: a, o, q
         allocate (st(0))
         do a = 1, size(nodes)
            if (model%is_held(nodes(a))) cycle
            o = model%nodes(nodes(a))%n%offset
            st = [st, (o + q, q=1, model%nodes(nodes(a))%n%nstates())]
         end do
      end function states_of
   end subroutine build_parts

   !> The RK4 step of size s from (t_loc, y) on the part of element e only: ys
   !> on the states of e's nodes, bit for bit the full step's (k1 of the full
   !> step, the same torque sums per node). k2..k4 and ytmp are scratch.
   subroutine rk4_step_part(self, model, y, e, s)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      integer, intent(in) :: e
      real(wp) :: hh, h6, t
      integer :: q, i
      t = self%t_loc
      hh = 0.5_wp*s
      associate (p => self%part(e))
         do q = 1, size(p%sk2)
            i = p%sk2(q)
            self%ytmp(i) = y(i) + hh*self%k1(i)
         end do
         call model%rhs_part(t + 0.5_wp*s, self%ytmp, self%k2, p%k2, p%e2, p%d2)
         do q = 1, size(p%sk3)
            i = p%sk3(q)
            self%ytmp(i) = y(i) + hh*self%k2(i)
         end do
         call model%rhs_part(t + 0.5_wp*s, self%ytmp, self%k3, p%k3, p%e3, p%d3)
         do q = 1, size(p%sk4)
            i = p%sk4(q)
            self%ytmp(i) = y(i) + s*self%k3(i)
         end do
         call model%rhs_part(t + s, self%ytmp, self%k4, p%k4, p%e4, p%d4)
         h6 = s/6.0_wp
         do q = 1, size(p%sd4)
            i = p%sd4(q)
            self%ys(i) = y(i) + h6*(self%k1(i) + 2.0_wp*(self%k2(i) + self%k3(i)) + self%k4(i))
         end do
      end associate
   end subroutine rk4_step_part

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
      real(wp) :: t4, hh, h6
      integer :: i
      t4 = t + h
      if (left_limit) t4 = t + h - 1.0e-9_wp*h
      hh = 0.5_wp*h
      do i = 1, size(y)
         self%ytmp(i) = y(i) + hh*self%k1(i)
      end do
      ! inner stages: no one reads the model's workspace after them (`rhs_stage`)
      call model%rhs_stage(t + 0.5_wp*h, self%ytmp, self%k2)
      do i = 1, size(y)
         self%ytmp(i) = y(i) + hh*self%k2(i)
      end do
      call model%rhs_stage(t + 0.5_wp*h, self%ytmp, self%k3)
      do i = 1, size(y)
         self%ytmp(i) = y(i) + h*self%k3(i)
      end do
      call model%rhs_stage(t4, self%ytmp, self%k4)
      h6 = h/6.0_wp
      do i = 1, size(y)
         ynew(i) = y(i) + h6*(self%k1(i) + 2.0_wp*(self%k2(i) + self%k3(i)) + self%k4(i))
      end do
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
   !> it), and once t_goal - t <= t_tol (the caller's instant tolerance: a
   !> sliver of a step below it is no step). A step with a guard below zero at
   !> its end is not taken but kept (pend): the next `advance` from here takes
   !> it without computing it again, so the steps, the RHS evaluations and the
   !> results are those of `advance` step by step.
   subroutine rk4_advance_block(self, model, t_goal, t_tol, y_limit, t, y)
      class(rk4_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t_goal, t_tol, y_limit
      real(wp), intent(inout) :: t, y(:)
      real(wp) :: t_grid, h
      integer :: j, i, n
      logical :: ok
      model%blk%n = 0
      if (self%mr_on .or. self%pend .or. .not. self%takes_blocks) return
      n = 0
      ok = .true.
      do j = 1, model%blk%cap
         t_grid = next_grid(self, t)
         if (t_grid > t_goal) exit
         if (self%stop_is_breakpoint .and. t_grid >= self%t_stop - self%tiny_t) exit
         h = t_grid - t
         ! k1 as `advance` takes it; after a step of the block it is that step's
         ! end-of-step RHS
         if (j == 1) then
            call first_stage(self, model, t, y)
            self%k1_next = .false.
         end if
         call rk4_step(self, model, t, y, h, self%ynew, .false.)
         if (self%ng > 0) then
            if (model%guards_below(t + h, self%ynew, self%g1)) then
               self%pend = .true.
               self%t_pend = t
               self%h_pend = h
               exit
            end if
         end if
         do i = 1, size(y)
            y(i) = self%ynew(i)
            if (.not. abs(y(i)) <= y_limit) ok = .false.   ! (also NaN)
         end do
         t = t_grid
         self%istep = self%istep + 1
         model%blk%col = j
         call model%rhs_step_end(t, y, self%k1)
         n = j
         if (.not. ok .or. t_goal - t <= t_tol) exit
      end do
      model%blk%col = 0
      model%blk%n = n
      if (n == 0) return
      ! the counters of n grid steps, and k1 of the last one for the next step
      self%stats%steps = self%stats%steps + n
      self%stats%block_steps = self%stats%block_steps + n
      self%stats%rhs_evals = self%stats%rhs_evals + n
      model%ws_step_end = .true.
      self%k1_next = .true.
      self%t_k1 = t
   end subroutine rk4_advance_block

   !> A guard went negative inside [t, t+h]: locate the earliest zero and end
   !> the step there (t, y at the located point). The zero of each guard that
   !> fired is first found on the step's own dense output (no RHS evaluation);
   !> the earliest is then refined on the step map s -> g(RK4(y, s)), so the
   !> state at the event is a true RK4 step (see `refine`).
   subroutine rk4_end_on_event(self, model, h, t, y)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: h
      real(wp), intent(inout) :: t, y(:)
      real(wp) :: s_ev, sj, gd
      real(wp), allocatable :: swap(:)
      integer :: j, jb, jl, pass
      self%dg_e = 0
      call model%guards(t, y, self%g0)
      ! keep the stages of this step (its dense output): swap, no copy
      call move_alloc(self%k2, swap); call move_alloc(self%d2, self%k2); call move_alloc(swap, self%d2)
      call move_alloc(self%k3, swap); call move_alloc(self%d3, self%k3); call move_alloc(swap, self%d3)
      call move_alloc(self%k4, swap); call move_alloc(self%d4, self%k4); call move_alloc(swap, self%d4)
      self%t_loc = t
      self%h_loc = h
      jb = 0
      s_ev = h
      do j = 1, self%ng
         if (self%g1(j) < 0.0_wp) then
            sj = rk4_dense_root(self, model, y, j, max(self%g0(j), 0.0_wp), h, self%g1(j))
            if (jb == 0 .or. sj < s_ev) then
               s_ev = sj
               jb = j
            end if
         end if
      end do
      s_ev = rk4_refine(self, model, y, jb, s_ev, max(self%g0(jb), 0.0_wp), h, self%g1(jb))
      ! another guard below zero there may have crossed earlier still (its zero
      ! on the dense output was later, within the dense output's error)
      do pass = 1, self%ng
         call model%guards(t + s_ev, self%ys, self%gs)
         jl = jb
         jb = 0
         do j = 1, self%ng
            if (j == jl .or. .not. self%gs(j) < 0.0_wp) cycle
            gd = rk4_dense_guard(self, model, y, j, s_ev)
            if (.not. gd < 0.0_wp) gd = self%gs(j)
            sj = rk4_dense_root(self, model, y, j, max(self%g0(j), 0.0_wp), s_ev, gd)
            if (sj < s_ev - self%event_tol) then
               jb = j
               exit
            end if
         end do
         if (jb == 0) exit
         s_ev = rk4_refine(self, model, y, jb, sj, max(self%g0(jb), 0.0_wp), s_ev, self%gs(jb))
      end do
      t = t + s_ev
      y = self%ys
      self%stats%root_returns = self%stats%root_returns + 1
   end subroutine rk4_end_on_event

   !> Guard j at t_loc + s on the dense output of the step being located (the
   !> RK4 continuous extension, third order: b1 = s - 3s^2/2 + 2s^3/3,
   !> b2 = b3 = s^2 - 2s^3/3, b4 = -s^2/2 + 2s^3/3 in units of h), evaluated
   !> for the states of the guard's element only.
   real(wp) function rk4_dense_guard(self, model, y, j, s) result(g)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      integer, intent(in) :: j
      real(wp) :: th, b1, b2, b4, h, c1, c2, c4
      integer :: e, k, i
      h = self%h_loc
      th = s/h
      b1 = th*(1.0_wp - th*(1.5_wp - th*(2.0_wp/3.0_wp)))
      b2 = th*th*(1.0_wp - th*(2.0_wp/3.0_wp))
      b4 = th*th*(-0.5_wp + th*(2.0_wp/3.0_wp))
      e = self%g_el(j)
      if (.not. self%mr_on) then
         ! guards that read only two plain inertias' angles (the model says which
         ! states): those two on the dense output, the guard from them
         if (e /= self%dg_e) then
            call model%guard_angles(e, self%dg_l, self%dg_r)
            self%dg_e = e
         end if
         if (self%dg_l > 0) then
            associate (il => self%dg_l, ir => self%dg_r)
               g = model%angle_guard(e, self%g_loc(j), &
                                     y(il) + h*(b1*self%k1(il) + b2*(self%d2(il) + self%d3(il)) + b4*self%d4(il)), &
                                     y(ir) + h*(b1*self%k1(ir) + b2*(self%d2(ir) + self%d3(ir)) + b4*self%d4(ir)))
            end associate
            return
         end if
      end if
      do k = 1, 3, 2
         if (self%mr_on) then
            if (.not. self%in_l(self%el_nodes((k + 1)/2, e))) then
               ! a node of B in a local event step: the unsplit step's dense output
               th = (self%t_loc + s - self%mt0)/self%mh
               c1 = th*(1.0_wp - th*(1.5_wp - th*(2.0_wp/3.0_wp)))
               c2 = th*th*(1.0_wp - th*(2.0_wp/3.0_wp))
               c4 = th*th*(-0.5_wp + th*(2.0_wp/3.0_wp))
               do i = self%el_states(k, e), self%el_states(k + 1, e)
                  self%yi(i) = self%my0(i) + self%mh*(c1*self%mk1(i) + c2*(self%md2(i) + self%md3(i)) + c4*self%md4(i))
               end do
               cycle
            end if
         end if
         do i = self%el_states(k, e), self%el_states(k + 1, e)
            self%yi(i) = y(i) + h*(b1*self%k1(i) + b2*(self%d2(i) + self%d3(i)) + b4*self%d4(i))
         end do
      end do
      g = model%element_guard(e, self%g_loc(j), self%t_loc + s, self%yi)
   end function rk4_dense_guard

   !> Guard j at t_loc + s on the step map: ys = RK4(y, s), on the part of the
   !> train the guard sees (on_part) when that is small.
   real(wp) function rk4_map_guard(self, model, y, j, s) result(g)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      integer, intent(in) :: j
      self%on_part = .false.
      if (self%mr_on) then
         ! a local event step: L's step map
         if (s == self%h_loc) then
            call mr_end_copy(self)
         else if (self%n_comp > 1) then
            ! the guard's component of L alone (its states bit for bit those of
            ! L's step: the components do not see each other); refine then
            ! takes L's step to the located time
            call mr_comp_step(self, model, y, self%g_el(j), s)
            self%on_part = .true.
         else
            call self%mr_step(model, y, s)
         end if
         ! (ys holds all of L's step unless on_part: refine may keep it)
      else if (s == self%h_loc) then
         self%ys = self%ynew
      else if (self%part(self%g_el(j))%used) then
         call self%step_part(model, y, self%g_el(j), s)
         self%on_part = .true.
      else
         call rk4_step(self, model, self%t_loc, y, s, self%ys, .false.)
      end if
      g = model%element_guard(self%g_el(j), self%g_loc(j), self%t_loc + s, self%ys)
   end function rk4_map_guard

   !> Zero of guard j on the dense output in [0, b0] (g = ga0 >= 0 at 0,
   !> gb0 < 0 at b0): Illinois false position to the event tolerance; returns
   !> the end of the final bracket where g < 0.
   real(wp) function rk4_dense_root(self, model, y, j, ga0, b0, gb0) result(b)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), ga0, b0, gb0
      integer, intent(in) :: j
      real(wp) :: a, fa, fb, s, fs
      integer :: side, it
      a = 0.0_wp; b = b0; fa = ga0; fb = gb0; side = 0
      self%dg_e = 0
      do it = 1, 100
         if (b - a <= self%event_tol) exit
         s = (a*fb - b*fa)/(fb - fa)
         s = min(max(s, a + 0.01_wp*(b - a)), b - 0.01_wp*(b - a))
         fs = rk4_dense_guard(self, model, y, j, s)
         if (fs < 0.0_wp) then
            b = s; fb = fs
            if (side == -1) fa = 0.5_wp*fa
            side = -1
         else
            a = s; fa = fs
            if (side == 1) fb = 0.5_wp*fb
            side = 1
         end if
      end do
   end function rk4_dense_root

   !> Zero of guard j on the step map in [0, b0] (g = ga0 >= 0 at 0, gb0 < 0 at
   !> b0), from the estimate s0 (its zero on the dense output). The first
   !> correction is a Newton step with the dense output's slope, the next ones
   !> secant steps through the last two step-map points; each is aimed
   !> event_tol/2 past the zero, so that the point evaluated ends the bracket.
   !> It stops when the bracket is within event_tol, or when a point where
   !> g < 0 has the Newton or secant zero within 0.75 event_tol (or the time
   !> resolution t_res |t|, if coarser) before it (the secant error is then of
   !> order (g''/g') (zero - s0) event_tol, far below event_tol). After max_secant points it falls back to Illinois false
   !> position on the bracket. Returns the end where g < 0, ys = RK4 to it.
   real(wp) function rk4_refine(self, model, y, j, s0, ga0, b0, gb0) result(b)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s0, ga0, b0, gb0
      integer, intent(in) :: j
      real(wp) :: a, fa, fb, sc, gc, sp, gp, r, dl, slope, tol, tol_acc
      real(wp), allocatable :: swap(:)
      integer :: it, side
      logical :: have_b, have_r, b_full
      tol = self%event_tol
      self%dg_e = 0
      a = 0.0_wp; fa = ga0; b = b0; fb = gb0; side = 0
      sc = min(max(s0, a + 0.5_wp*tol), b)
      have_b = .false.   ! yb holds RK4(y, b) (all of it when b_full)
      b_full = .false.
      sp = 0.0_wp; gp = 0.0_wp; r = 0.0_wp
      do it = 1, 200
         gc = rk4_map_guard(self, model, y, j, sc)
         if (gc < 0.0_wp) then
            b = sc; fb = gc
            call move_alloc(self%ys, swap); call move_alloc(self%yb, self%ys); call move_alloc(swap, self%yb)
            have_b = .true.
            b_full = .not. self%on_part
            if (side == -1) fa = 0.5_wp*fa
            side = -1
         else
            a = sc; fa = gc
            if (side == 1) fb = 0.5_wp*fb
            side = 1
         end if
         if (b - a <= tol) exit
         have_r = .false.
         if (it <= max_secant) then
            if (it > 1) then
               if (gc /= gp) then
                  r = sc - gc*(sc - sp)/(gc - gp)                       ! secant on the step map
                  have_r = .true.
               end if
            else
               dl = 1.0e-3_wp*self%h_loc
               slope = (rk4_dense_guard(self, model, y, j, sc + dl) - rk4_dense_guard(self, model, y, j, sc - dl))/(2.0_wp*dl)
               if (slope /= 0.0_wp) then
                  r = sc - gc/slope                                     ! Newton, dense-output slope
                  have_r = .true.
               end if
            end if
            ! the correction to a point where g < 0 is below the tolerance: done
            tol_acc = 0.75_wp*max(tol, t_res*abs(self%t_loc + b))
            if (have_r .and. gc < 0.0_wp) then
               if (r <= b .and. b - r <= tol_acc .and. r > a) exit
            end if
         end if
         sp = sc; gp = gc
         if (have_r) have_r = r > a .and. r < b
         if (have_r) then
            sc = min(r + 0.5_wp*tol, b - 0.25_wp*tol)
            if (sc <= a) sc = 0.5_wp*(a + b)
         else
            sc = (a*fb - b*fa)/(fb - fa)                                ! Illinois
            sc = min(max(sc, a + 0.01_wp*(b - a)), b - 0.01_wp*(b - a))
         end if
      end do
      if (have_b .and. b_full) then
         call move_alloc(self%ys, swap); call move_alloc(self%yb, self%ys); call move_alloc(swap, self%yb)
      else if (self%mr_on) then
         if (b == self%h_loc) then
            call mr_end_copy(self)
         else
            call self%mr_step(model, y, b)
         end if
      else if (b == self%h_loc) then
         self%ys = self%ynew
      else
         ! the whole train to the located time (the part's states are bit for bit these)
         call rk4_step(self, model, self%t_loc, y, b, self%ys, .false.)
      end if
   end function rk4_refine
   !> The node graph for local event steps: node -> elements (compressed rows),
   !> each element's nodes, which elements have guards; the marks and lists of
   !> a region, sized once.
   subroutine build_graph(self, model)
      type(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      integer :: nn, ne, n, e, i, side, nd
      integer, allocatable :: fill(:)
      nn = size(model%nodes)
      ne = size(model%elements)
      n = size(self%k1)
      allocate (self%adj_first(nn + 1), self%el_nodes(2, ne), self%has_guards(ne), fill(nn))
      self%adj_first = 0
      do e = 1, ne
         self%el_nodes(1, e) = model%elements(e)%e%left
         self%el_nodes(2, e) = model%elements(e)%e%right
         self%has_guards(e) = model%elements(e)%e%n_guards() > 0
         do side = 1, 2
            nd = self%el_nodes(side, e)
            if (side == 2 .and. nd == self%el_nodes(1, e)) cycle
            self%adj_first(nd + 1) = self%adj_first(nd + 1) + 1
         end do
      end do
      self%adj_first(1) = 1
      do i = 1, nn
         self%adj_first(i + 1) = self%adj_first(i + 1) + self%adj_first(i)
      end do
      allocate (self%adj_list(self%adj_first(nn + 1) - 1))
      fill = self%adj_first(1:nn)
      do e = 1, ne
         do side = 1, 2
            nd = self%el_nodes(side, e)
            if (side == 2 .and. nd == self%el_nodes(1, e)) cycle
            self%adj_list(fill(nd)) = e
            fill(nd) = fill(nd) + 1
         end do
      end do
      allocate (self%in_l(nn), self%in_kin(nn), self%el_in(ne), self%gel_in(ne), self%depth(nn))
      self%in_l = .false.; self%in_kin = .false.; self%el_in = .false.; self%gel_in = .false.
      self%depth = huge(1)
      allocate (self%stack(4*nn + 4), self%l_nodes(nn), self%b_nodes(nn), self%kin(nn), self%els(ne), self%gels(ne), &
                self%in_els(ne))
      allocate (self%sl(n), self%sb(n), self%far(ne))
      allocate (self%comp(nn), self%ns_range(2, nn), self%mark(nn), self%cn(nn), self%ce(ne), self%ck(nn), &
                self%csl(n), self%csb(n))
      self%comp = 0; self%mark = 0; self%stamp = 0; self%n_comp = 0; self%cur_c = 0
      do i = 1, nn
         self%ns_range(1, i) = 1   ! (1:0): a held node has no states
         self%ns_range(2, i) = 0
         if (model%is_held(i)) cycle
         self%ns_range(1, i) = model%nodes(i)%n%offset + 1
         self%ns_range(2, i) = model%nodes(i)%n%offset + model%nodes(i)%n%nstates()
      end do
      self%n_far = 0
      self%far_done = .false.
      allocate (self%my0(n), self%mk1(n), self%md2(n), self%md3(n), self%md4(n), self%mynew(n), self%yc(n))
      self%n_l = 0; self%n_b = 0; self%n_kin = 0; self%n_els = 0; self%n_gels = 0; self%n_sl = 0; self%n_sb = 0
      self%n_in = 0
      self%at_local = .false.
      self%y_partial = .false.
      self%mr_steps = 0; self%mr_events = 0; self%mr_collapses = 0; self%mr_node_rhs = 0
   end subroutine build_graph

   !> Start a local event step, or say that this step is not one (ok false:
   !> the whole train's step is split as before). The guards g1 at the end of
   !> the unsplit step (ynew, stages k1..k4) fired. The region L holds the nodes
   !> within mr_depth elements of the nodes of every element whose guard fired,
   !> and, so that every event in L has its whole reach in L, of every element
   !> with guards that has a node in L (repeated until no such element is
   !> left). Only a region that with its boundary B (the nodes next to L) holds
   !> at most 1/mr_small of the train is used. The unsplit step is kept (its
   !> start, stages and end): every node outside L ends the step at its unsplit
   !> value, which does not depend on any element of L that has guards (see
   !> mr_depth); L alone is integrated again through its events (`mr_continue`),
   !> with the states of B from the unsplit step's dense output.
   subroutine rk4_mr_begin(self, model, t, y, h, t_grid, ok)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:), h, t_grid
      logical, intent(out) :: ok
      real(wp), allocatable :: swap(:)
      integer :: j, k, q, nn, nd, e2, other, top, next_seed, st
      real(wp) :: ts
      ok = .false.
      nn = size(model%nodes)
      if (.not. self%multirate .or. model%nport .or. nn < mr_min_nodes .or. mr_small*(2*mr_depth + 4) > nn) return
      ! clear the marks of the last region
      do k = 1, self%n_l
         self%in_l(self%l_nodes(k)) = .false.
         self%depth(self%l_nodes(k)) = huge(1)
      end do
      do k = 1, self%n_kin
         self%in_kin(self%kin(k)) = .false.
      end do
      do k = 1, self%n_els
         self%el_in(self%els(k)) = .false.
      end do
      do k = 1, self%n_gels
         self%gel_in(self%gels(k)) = .false.
      end do
      self%n_l = 0; self%n_b = 0; self%n_kin = 0; self%n_els = 0; self%n_gels = 0
      ! the region: nodes within mr_depth of the seeds (a stack; a node is pushed
      ! again when a shorter path to it is found)
      do j = 1, self%ng
         if (self%g1(j) < 0.0_wp) call add_seed(self%g_el(j))
      end do
      top = 0
      next_seed = 1
      do
         if (top > 0) then
            nd = self%stack(top)
            top = top - 1
            do q = self%adj_first(nd), self%adj_first(nd + 1) - 1
               e2 = self%adj_list(q)
               other = self%el_nodes(1, e2)
               if (other == nd) other = self%el_nodes(2, e2)
               call relax(other, self%depth(nd) + 1)
            end do
         else if (next_seed <= self%n_gels) then
            call relax(self%el_nodes(1, self%gels(next_seed)), 0)
            call relax(self%el_nodes(2, self%gels(next_seed)), 0)
            next_seed = next_seed + 1
         else
            exit
         end if
         if (mr_small*self%n_l > nn) return
      end do
      ! its boundary and elements
      do k = 1, self%n_l
         nd = self%l_nodes(k)
         self%in_kin(nd) = .true.
         self%n_kin = self%n_kin + 1
         self%kin(self%n_kin) = nd
      end do
      do k = 1, self%n_l
         nd = self%l_nodes(k)
         do q = self%adj_first(nd), self%adj_first(nd + 1) - 1
            e2 = self%adj_list(q)
            if (.not. self%el_in(e2)) then
               self%el_in(e2) = .true.
               self%n_els = self%n_els + 1
               self%els(self%n_els) = e2
            end if
            other = self%el_nodes(1, e2)
            if (other == nd) other = self%el_nodes(2, e2)
            if (.not. self%in_kin(other)) then
               self%in_kin(other) = .true.
               self%n_kin = self%n_kin + 1
               self%kin(self%n_kin) = other
               self%n_b = self%n_b + 1
               self%b_nodes(self%n_b) = other
            end if
         end do
      end do
      if (mr_small*self%n_kin > nn) return
      call sort_int(self%l_nodes(1:self%n_l))
      call sort_int(self%b_nodes(1:self%n_b))
      call sort_int(self%kin(1:self%n_kin))
      call sort_int(self%els(1:self%n_els))
      self%n_in = 0
      do k = 1, self%n_els
         if (self%in_l(self%el_nodes(1, self%els(k))) .and. self%in_l(self%el_nodes(2, self%els(k)))) then
            self%n_in = self%n_in + 1
            self%in_els(self%n_in) = self%els(k)
         end if
      end do
      call states(self%l_nodes(1:self%n_l), self%sl, self%n_sl)
      call states(self%b_nodes(1:self%n_b), self%sb, self%n_sb)
      ! the components of L (joined by elements with both nodes in L)
      do k = 1, self%n_l
         self%comp(self%l_nodes(k)) = 0
      end do
      self%n_comp = 0
      self%cur_c = 0
      do k = 1, self%n_l
         if (self%comp(self%l_nodes(k)) /= 0) cycle
         self%n_comp = self%n_comp + 1
         self%comp(self%l_nodes(k)) = self%n_comp
         top = 1
         self%stack(1) = self%l_nodes(k)
         do while (top > 0)
            nd = self%stack(top)
            top = top - 1
            do q = self%adj_first(nd), self%adj_first(nd + 1) - 1
               e2 = self%adj_list(q)
               other = self%el_nodes(1, e2)
               if (other == nd) other = self%el_nodes(2, e2)
               if (.not. self%in_l(other)) cycle
               if (self%comp(other) /= 0) cycle
               self%comp(other) = self%n_comp
               top = top + 1
               self%stack(top) = other
            end do
         end do
      end do
      ok = .true.
      ! keep the unsplit step: start, stages (swapped, not copied), end
      self%mr_on = .true.
      self%mt0 = t; self%mh = h; self%mt1 = t + h; self%mt_grid = t_grid; self%mt_c = t
      self%my0 = y
      call move_alloc(self%k1, swap); call move_alloc(self%mk1, self%k1); call move_alloc(swap, self%mk1)
      call move_alloc(self%k2, swap); call move_alloc(self%md2, self%k2); call move_alloc(swap, self%md2)
      call move_alloc(self%k3, swap); call move_alloc(self%md3, self%k3); call move_alloc(swap, self%md3)
      call move_alloc(self%k4, swap); call move_alloc(self%md4, self%k4); call move_alloc(swap, self%md4)
      call move_alloc(self%ynew, swap); call move_alloc(self%mynew, self%ynew); call move_alloc(swap, self%mynew)
      self%e_acc = 0.0_wp; self%e_book = 0.0_wp; self%pr = 0.0_wp
      self%mr_steps = self%mr_steps + 1
      self%far_done = .false.
      if (.not. model%run%track_energy) return
      ! the energy rates of L's terms (elements with a node in L, nodes of L, their
      ! loads) at the four stages of the unsplit step, to be replaced by L's own
      do k = 1, 4
         ts = t
         if (k == 2 .or. k == 3) ts = t + 0.5_wp*h
         if (k == 4) ts = t + h
         do q = 1, self%n_sl + self%n_sb
            if (q <= self%n_sl) then
               st = self%sl(q)
            else
               st = self%sb(q - self%n_sl)
            end if
            select case (k)
            case (1)
               self%ytmp(st) = y(st)
            case (2)
               self%ytmp(st) = y(st) + 0.5_wp*h*self%mk1(st)
            case (3)
               self%ytmp(st) = y(st) + 0.5_wp*h*self%md2(st)
            case (4)
               self%ytmp(st) = y(st) + h*self%md3(st)
            end select
         end do
         call self%mr_rhs(model, ts, self%ytmp, self%k4, self%pr(:, k))
      end do
   contains

      subroutine add_seed(e)
         integer, intent(in) :: e
         if (self%gel_in(e)) return
         self%gel_in(e) = .true.
         self%n_gels = self%n_gels + 1
         self%gels(self%n_gels) = e
      end subroutine add_seed

      subroutine relax(nd, d)
         integer, intent(in) :: nd, d
         integer :: qq
         if (d >= self%depth(nd)) return
         if (.not. self%in_l(nd)) then
            self%in_l(nd) = .true.
            self%n_l = self%n_l + 1
            self%l_nodes(self%n_l) = nd
            do qq = self%adj_first(nd), self%adj_first(nd + 1) - 1
               if (self%has_guards(self%adj_list(qq))) call add_seed(self%adj_list(qq))
            end do
         end if
         self%depth(nd) = d
         if (d < mr_depth) then
            top = top + 1
            self%stack(top) = nd
         end if
      end subroutine relax

      subroutine states(nodes, st, ns)
         integer, intent(in) :: nodes(:)
         integer, intent(inout) :: st(:)
         integer, intent(out) :: ns
         integer :: a, b
         ns = 0
         do a = 1, size(nodes)
            do b = self%ns_range(1, nodes(a)), self%ns_range(2, nodes(a))   ! (none for a held node)
               ns = ns + 1
               st(ns) = b
            end do
         end do
      end subroutine states
   end subroutine rk4_mr_begin

   !> A local event instant (see integrator_t%local_instant): the event just
   !> returned is inside a local event step that goes on (L's states are
   !> integration points at t, every other state an interpolation of the
   !> unsplit step; no guard outside L's guard elements is below zero there).
   logical function rk4_local_instant(self, nodes, states, els, gels) result(local)
      class(rk4_t), intent(in), target :: self
      integer, pointer, contiguous, intent(out) :: nodes(:), states(:), els(:), gels(:)
      local = self%at_local .and. self%mr_on
      if (local) then
         nodes => self%l_nodes(1:self%n_l)
         states => self%sl(1:self%n_sl)
         els => self%in_els(1:self%n_in)
         gels => self%gels(1:self%n_gels)
      else
         nodes => null(); states => null(); els => null(); gels => null()
      end if
   end function rk4_local_instant

   !> The guard elements outside L whose guards may be below zero somewhere on
   !> the unsplit step's dense output, into far(1:n_far): all but those whose
   !> guards read two angles (`guard_angles`) and stay above zero for any
   !> angles within the dense output's reach over the whole step
   !> (`guard_floor`). The dense output of a state is y0 + h (b1 k1 + b2 (d2 +
   !> d3) + b4 d4) with 0 <= b1 <= 5/24, 0 <= b2 <= 1/3, -1/24 <= b4 <= 1/6 on
   !> [0, 1]: within y0 +- h (0.21 |k1| + 0.34 (|d2| + |d3|) + 0.17 |d4|). The
   !> check at an instant is then that of every outside element, as the skipped
   !> ones cannot be below zero there.
   subroutine mr_far_list(self, model)
      type(rk4_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      integer :: j, ne, il, ir
      real(wp) :: rl, rr
      self%n_far = 0
      self%far_done = .true.
      do j = 1, self%ng
         ne = self%g_el(j)
         if (self%gel_in(ne) .or. self%g_loc(j) /= 1) cycle
         call model%guard_angles(ne, il, ir)
         if (il > 0) then
            rl = self%mh*(0.21_wp*abs(self%mk1(il)) + 0.34_wp*(abs(self%md2(il)) + abs(self%md3(il))) + &
                          0.17_wp*abs(self%md4(il)))
            rr = self%mh*(0.21_wp*abs(self%mk1(ir)) + 0.34_wp*(abs(self%md2(ir)) + abs(self%md3(ir))) + &
                          0.17_wp*abs(self%md4(ir)))
            if (model%guard_floor(ne, self%my0(il), rl, self%my0(ir), rr) > 0.0_wp) cycle
         end if
         self%n_far = self%n_far + 1
         self%far(self%n_far) = ne
      end do
   end subroutine mr_far_list

   !> ys = the end of L's step (L's and B's states) in a local event step.
   subroutine mr_end_copy(self)
      type(rk4_t), intent(inout) :: self
      integer :: q
      do q = 1, self%n_sl
         self%ys(self%sl(q)) = self%ynew(self%sl(q))
      end do
      do q = 1, self%n_sb
         self%ys(self%sb(q)) = self%ynew(self%sb(q))
      end do
   end subroutine mr_end_copy

   !> Insertion sort (short lists).
   pure subroutine sort_int(a)
      integer, intent(inout) :: a(:)
      integer :: i, j, x
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
   end subroutine sort_int

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

   !> A trial step of event location on the component of L that holds element
   !> e: `mr_step` for its states alone (the same values bit for bit: a node's
   !> derivative reads its own and its neighbours' states, all in the component
   !> or its boundary), into ys; no energy rates (pw_step unchanged).
   subroutine mr_comp_step(self, model, y, e, s)
      type(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      integer, intent(in) :: e
      if (self%comp(self%el_nodes(1, e)) /= self%cur_c) call mr_comp_lists(self, self%comp(self%el_nodes(1, e)))
      call mr_step_on(self, model, y, s, self%csl(1:self%n_csl), self%csb(1:self%n_csb), self%ck(1:self%n_ck), &
                      self%ce(1:self%n_ce), self%cn(1:self%n_cn), .false.)
   end subroutine mr_comp_step

   !> Inside a local event step (t = mt_c, L's states in y at t): step L to
   !> the end of the unsplit step, or to L's next event. At an event, (t, y)
   !> is the located time with L's states from its own steps and every other
   !> state from the unsplit step's dense output (for the driver's use at the
   !> instant: the observer, the mode update; the step still ends with the
   !> unsplit values outside L). At the end, y is the unsplit step's end
   !> outside L and L's own inside; the energy states are the unsplit step's
   !> with L's terms replaced by L's own (and the driver's bookings at the
   !> events added). done is false (and the local step dropped) when the
   !> driver asks for something else than the rest of this step.
   subroutine rk4_mr_continue(self, model, t_goal, t, y, status, done)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t_goal
      real(wp), intent(inout) :: t, y(:)
      integer, intent(out) :: status
      logical, intent(out) :: done
      real(wp), allocatable :: swap(:)
      real(wp) :: s_ev, th, b1, b2, b4, hh
      integer :: q, i, k, j, ne, nst
      logical :: track, far_fired
      done = .false.
      status = adv_step
      nst = model%n_states
      if (abs(t - self%mt_c) > self%tiny_t .or. t_goal < self%mt1 - self%tiny_t) then
         self%mr_on = .false.
         self%mr_collapses = self%mr_collapses + 1
         if (self%y_partial) call shown(self%mt_c)   ! the state shown at the last event becomes the state
         self%y_partial = .false.
         return
      end if
      self%y_partial = .false.
      done = .true.
      track = model%run%track_energy
      if (track .and. self%mt_c > self%mt0) self%e_book = self%e_book + (y(nst + 1:nst + 2) - self%e_shown)
      self%pw_full = 0.0_wp
      if (self%mt1 - self%mt_c > self%tiny_t) then
         ! L's step from mt_c to the end (its dense output: k1, d2..d4)
         self%t_loc = self%mt_c
         self%h_loc = self%mt1 - self%mt_c
         do q = 1, self%n_sl
            self%yc(self%sl(q)) = y(self%sl(q))
         end do
         call self%mr_bnd(self%yc, self%mt_c)
         if (self%mt_c == self%mt0) then
            ! at the start of the step: L's part of the unsplit step's k1 (the same
            ! state, modes and sums: bit for bit) and of its energy rates
            do q = 1, self%n_sl
               self%k1(self%sl(q)) = self%mk1(self%sl(q))
            end do
            self%pk1 = self%pr(:, 1)
         else
            call self%mr_rhs(model, self%mt_c, self%yc, self%k1, self%pk1)
         end if
         call self%mr_step(model, y, self%h_loc)
         self%pw_full = self%pw_step
         call move_alloc(self%ys, swap); call move_alloc(self%ynew, self%ys); call move_alloc(swap, self%ynew)
         call move_alloc(self%k2, swap); call move_alloc(self%d2, self%k2); call move_alloc(swap, self%d2)
         call move_alloc(self%k3, swap); call move_alloc(self%d3, self%k3); call move_alloc(swap, self%d3)
         call move_alloc(self%k4, swap); call move_alloc(self%d4, self%k4); call move_alloc(swap, self%d4)
         far_fired = .false.
         do k = 1, self%n_gels
            ne = self%gels(k)
            call model%element_guards(ne, self%mt1, self%ynew, self%ge)
            do j = 1, model%elements(ne)%e%n_guards()
               self%g1(model%guard_offset(ne) + j) = self%ge(j)
               if (self%ge(j) < 0.0_wp) far_fired = .true.
            end do
         end do
         if (far_fired) then
            ! an event of L inside the rest of the step
            s_ev = self%mr_locate(model, y)
            if (track) call self%mr_step(model, y, s_ev)   ! its energy integral (ys unchanged: the same step)
            t = self%mt_c + s_ev
            ! the state at the instant: the unsplit step's dense output, L's own
            th = (t - self%mt0)/self%mh
            b1 = th*(1.0_wp - th*(1.5_wp - th*(2.0_wp/3.0_wp)))
            b2 = th*th*(1.0_wp - th*(2.0_wp/3.0_wp))
            b4 = th*th*(-0.5_wp + th*(2.0_wp/3.0_wp))
            hh = self%mh
            if (self%region_instants) then
               ! L's states (and the energy states); the rest when the step ends
               do i = nst + 1, size(y)
                  y(i) = self%my0(i) + hh*(b1*self%mk1(i) + b2*(self%md2(i) + self%md3(i)) + b4*self%md4(i))
               end do
               self%y_partial = .true.
            else
               do i = 1, size(y)
                  y(i) = self%my0(i) + hh*(b1*self%mk1(i) + b2*(self%md2(i) + self%md3(i)) + b4*self%md4(i))
               end do
            end if
            do q = 1, self%n_sl
               y(self%sl(q)) = self%ys(self%sl(q))
            end do
            if (track) then
               y(nst + 1:nst + 2) = y(nst + 1:nst + 2) - hh*(b1*self%pr(:, 1) + b2*(self%pr(:, 2) + self%pr(:, 3)) + &
                                    b4*self%pr(:, 4)) + self%e_acc + self%pw_step + self%e_book
               self%e_acc = self%e_acc + self%pw_step
               self%e_shown = y(nst + 1:nst + 2)
            end if
            self%mt_c = t
            self%mr_events = self%mr_events + 1
            self%stats%root_returns = self%stats%root_returns + 1
            status = adv_event
            ! a guard outside L below zero on the dense output (it dips inside the
            ! step): the state shown becomes the state, the local step ends here
            if (self%y_partial) then
               ! the guard elements outside L (none has a node in L) that may be
               ! below zero on the dense output: their nodes' states there, their guards
               if (.not. self%far_done) call mr_far_list(self, model)
               do j = 1, self%n_far
                  ne = self%far(j)
                  do k = 1, 3, 2
                     do i = self%el_states(k, ne), self%el_states(k + 1, ne)
                        y(i) = self%my0(i) + hh*(b1*self%mk1(i) + b2*(self%md2(i) + self%md3(i)) + b4*self%md4(i))
                     end do
                  end do
                  call model%element_guards(ne, t, y, self%ge)
                  if (any(self%ge(1:model%elements(ne)%e%n_guards()) < 0.0_wp)) then
                     self%mr_on = .false.
                     self%mr_collapses = self%mr_collapses + 1
                     call shown(t)
                     self%y_partial = .false.
                     exit
                  end if
               end do
            else
               call model%guards(t, y, self%gs)
               do j = 1, self%ng
                  if (self%gs(j) < 0.0_wp .and. .not. self%gel_in(self%g_el(j))) then
                     self%mr_on = .false.
                     self%mr_collapses = self%mr_collapses + 1
                     exit
                  end if
               end do
            end if
            self%at_local = self%mr_on
            return
         end if
      else
         do q = 1, self%n_sl
            self%ynew(self%sl(q)) = y(self%sl(q))
         end do
      end if
      ! the end of the step: outside L the unsplit step's, L its own (assembled
      ! in mynew, which then becomes ynew: the step's end, as after a plain step)
      do q = 1, self%n_sl
         self%mynew(self%sl(q)) = self%ynew(self%sl(q))
      end do
      if (track) self%mynew(nst + 1:nst + 2) = self%mynew(nst + 1:nst + 2) - (self%mh/6.0_wp)*(self%pr(:, 1) + &
                                               2.0_wp*(self%pr(:, 2) + self%pr(:, 3)) + self%pr(:, 4)) + self%e_acc + &
                                               self%pw_full + self%e_book
      y = self%mynew
      call move_alloc(self%ynew, swap); call move_alloc(self%mynew, self%ynew); call move_alloc(swap, self%mynew)
      self%mr_on = .false.
      t = self%mt1
      if (t >= self%mt_grid - self%tiny_t) then
         t = self%mt_grid
         call self%count_grid_step()
      end if
      ! the RHS at the step's end, as after a plain step (`advance`): the next
      ! step's first stage, and the workspace the observer reads (its short way)
      call model%rhs_step_end(t, y, self%k1)
      self%stats%rhs_evals = self%stats%rhs_evals + 1
      model%ws_step_end = .true.
      self%k1_next = .true.
      self%t_k1 = t
      status = adv_step
      if (t >= t_goal - self%tiny_t) status = adv_reached
   contains
      !> The states outside L at tt (in the unsplit step) into y, from the
      !> unsplit step's dense output: the whole state shown at a local event
      !> instant (L's states and the energy states are kept).
      subroutine shown(tt)
         real(wp), intent(in) :: tt
         real(wp) :: c1, c2, c4, w
         integer :: p
         do p = 1, self%n_sl
            self%yc(self%sl(p)) = y(self%sl(p))
         end do
         w = (tt - self%mt0)/self%mh
         c1 = w*(1.0_wp - w*(1.5_wp - w*(2.0_wp/3.0_wp)))
         c2 = w*w*(1.0_wp - w*(2.0_wp/3.0_wp))
         c4 = w*w*(-0.5_wp + w*(2.0_wp/3.0_wp))
         do p = 1, nst
            y(p) = self%my0(p) + self%mh*(c1*self%mk1(p) + c2*(self%md2(p) + self%md3(p)) + c4*self%md4(p))
         end do
         do p = 1, self%n_sl
            y(self%sl(p)) = self%yc(self%sl(p))
         end do
      end subroutine shown
   end subroutine rk4_mr_continue

   !> L's earliest event in its step from (t_loc, y) (guards g1 at its end):
   !> as `end_on_event`, on L's step map and dense output, for L's guard
   !> elements. Returns the step to it; ys = L's step to it.
   real(wp) function rk4_mr_locate(self, model, y) result(s_ev)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:)
      real(wp) :: sj, gd, h
      integer :: k, j, jb, jl, pass, ne, jj, o
      h = self%h_loc
      ! the guards at t_loc (L's state, B's from the unsplit step: in yc)
      do k = 1, self%n_gels
         ne = self%gels(k)
         o = model%guard_offset(ne)
         call model%element_guards(ne, self%t_loc, self%yc, self%ge)
         self%g0(o + 1:o + model%elements(ne)%e%n_guards()) = self%ge(1:model%elements(ne)%e%n_guards())
      end do
      jb = 0
      s_ev = h
      do k = 1, self%n_gels
         ne = self%gels(k)
         o = model%guard_offset(ne)
         do jj = 1, model%elements(ne)%e%n_guards()
            j = o + jj
            if (.not. self%g1(j) < 0.0_wp) cycle
            sj = self%dense_root(model, y, j, max(self%g0(j), 0.0_wp), h, self%g1(j))
            if (jb == 0 .or. sj < s_ev) then
               s_ev = sj
               jb = j
            end if
         end do
      end do
      s_ev = self%refine(model, y, jb, s_ev, max(self%g0(jb), 0.0_wp), h, self%g1(jb))
      ! another guard of L below zero there may have crossed earlier still
      do pass = 1, self%ng
         jl = jb
         jb = 0
         outer: do k = 1, self%n_gels
            ne = self%gels(k)
            o = model%guard_offset(ne)
            call model%element_guards(ne, self%t_loc + s_ev, self%ys, self%ge)
            do jj = 1, model%elements(ne)%e%n_guards()
               j = o + jj
               self%gs(j) = self%ge(jj)
               if (j == jl .or. .not. self%gs(j) < 0.0_wp) cycle
               gd = self%dense_guard(model, y, j, s_ev)
               if (.not. gd < 0.0_wp) gd = self%gs(j)
               sj = self%dense_root(model, y, j, max(self%g0(j), 0.0_wp), s_ev, gd)
               if (sj < s_ev - self%event_tol) then
                  jb = j
                  exit outer
               end if
            end do
         end do outer
         if (jb == 0) exit
         s_ev = self%refine(model, y, jb, sj, max(self%g0(jb), 0.0_wp), s_ev, self%gs(jb))
      end do
   end function rk4_mr_locate
end module trainsim_int_rk4
