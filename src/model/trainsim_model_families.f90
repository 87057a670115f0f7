!> The model's families on the hot path: the row types of its tables (a node
!> that is a plain inertia or held, an element that is a linear spring or a
!> clearance in its hot form, D-35, a guard row, a load) and the families as
!> structure of arrays that the kernels (trainsim_model_kernels) evaluate.
module trainsim_model_families
   use trainsim_kinds, only: wp, i8
   use trainsim_element, only: hg_none
   implicit none
   private

   public :: fast_node_t, fast_element_t, guard_row_t, fast_load_t, jac_part_t
   public :: nk_other, nk_plain, nk_held
   public :: lf_general, lf_undamped, lf_unit, lf_open, lf_yang_sun, lf_cl_linear
   public :: families_t, table_t, spring_ni, spring_nr, contact_ni, contact_nr, free_ni, free_nr, held_ni, held_nr, &
             load_ni, load_nr, row_ends, chain_ni, chain_nr, build_chain, chain_laws
   public :: ch_spring, ch_damper, ch_open, ch_ys, ch_lin, ch_unit, windows_below, block_run_t

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
      !> Its hot form vouches for itself (hot_form_t%exact) and passed
      !> `hot_probe` since the last `init_modes`: not probed again (D-167).
      logical :: vouched = .false.
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

   !> The variational pass's split of the model's Jacobian (D-170, `model%jacobian`'s
   !> part): J = its constant part (every element but the varying ones, the nodes)
   !> + each varying element's part, its torques' 2 x 4 Jacobian through its
   !> nodes' gains dtq. varying = .false.: jac is the constant part and vary, ok,
   !> dtq are set; .true.: the varying elements' parts are added to jac.
   type :: jac_part_t
      logical :: varying = .false.
      !> the rest of J stays constant until the next event (every node a plain
      !> inertia or held, no speed-law load, no constraint, no n-port element)
      logical :: ok = .false.
      logical, allocatable :: vary(:)       !< per element: its part varies in its mode
      real(wp), allocatable :: dtq(:, :)    !< (5, nodes) d(dydt of state k) / d(net torque)
      !> the varying elements' entries (`element_scatter`), in element order: element,
      !> row, the columns of node b's angle and speed, ports a and b, the gain dtq(k, node)
      integer, allocatable :: sc(:, :)      !< (8, nsc)
      integer :: nsc = 0
   end type jac_part_t

   !> A table of the families: n rows, row q at iw(i0 + ni (q - 1) + 1 : i0 + ni q)
   !> and rw(r0 + nr (q - 1) + 1 : r0 + nr q) of the families' two arrays (ni and
   !> nr are the table's column counts, below).
   type :: table_t
      integer :: n = 0, i0 = 0, r0 = 0
   end type table_t

   !> Columns of the tables. The linear-spring family (a shaft, a damper, an
   !> ideal gear pair: eqs. (H.1), (H.15)), in two tables (springs: c = 0,
   !> dampers: c /= 0): (element, left node, right node), (k, c, r1, r2).
   integer, parameter :: spring_ni = 3, spring_nr = 4
   !> The clearance family (every element whose torques are its hot form, D-35;
   !> a row refreshed when its element changes mode): (element, left node, right
   !> node, no_tension 0 or 1), (s, c, k, dmp, b, r1, r2), its rows by law in
   !> three tables one after another (`contacts` is all three): open, closed
   !> with the yang_sun law, closed with the linear law; a row that changes law
   !> moves to its table by swaps at the tables' borders (D-75). An open
   !> row carries k = dmp = b = 0 (its force is zero, and no stale parameter
   !> reaches the arithmetic).
   integer, parameter :: contact_ni = 4, contact_nr = 7
   !> Plain inertias: (node, state offset, x, y), (J, d, the sum of its constant
   !> loads), in two tables of the same width one after another (`free` is
   !> both, for their kinematics): an undamped node with one or two element
   !> torques on it (x, y: their indices into the element torques; with one, y
   !> is the zero after the last element's, D-95), any other (its incidences
   !> iw(x : y)). Nodes held at a constant speed: (node, x, y), (theta0, w,
   !> load sum), in node order (their drive powers are summed in it), in two
   !> tables one after another (`held` is both): the first ones with at most
   !> two element torques (x, y as a free node's), the rest (the range of its
   !> incidences in iw). Constant loads on
   !> free nodes: (node), (value). Damped plain inertias in node order (their
   !> dissipated power): (state offset), (d).
   integer, parameter :: free_ni = 4, free_nr = 3, held_ni = 3, held_nr = 3, load_ni = 1, load_nr = 1
   !> The serial chain (D-106): a train whose elements, in element order, join
   !> its nodes one after another (element q: node q - 1 left, node q right),
   !> every node an undamped plain inertia but the head, which may also be
   !> held, and every element a linear spring or a clearance. Row 0 is the
   !> head, row q element q and its right-hand node: (law, a, b, element,
   !> node, state offset: -1 for a held head), (J or theta0, w, constant load);
   !> the head's law: 1 if the loads' power is summed in the links, its load
   !> then the second real of a link's row (`chain_loads`, D-153); the head's
   !> a: 1 if the chain passes the nodes in node order (head node 1, row q's
   !> node q + 1: the step end sums the kinetic energies in the links, D-160);
   !> a, b: the element's row in its family's table, law: which (ch_*; ch_unit:
   !> an undamped spring with unit lever arms, a shaft, whose row the kernel
   !> reads without r1 = r2 = 1, D-124).
   integer, parameter :: chain_ni = 6, chain_nr = 3
   integer, parameter :: ch_spring = 1, ch_damper = 2, ch_open = 3, ch_ys = 4, ch_lin = 5, ch_unit = 6

   !> The families of a simple model (every node a plain inertia or held at a
   !> constant speed, every load constant), which the stage and step-end kernels
   !> (trainsim_model_kernels) evaluate family by family, each in one loop
   !> without a branch on an element form or a node kind. An element in no
   !> family is asked through its procedures (`general`). Structure of arrays:
   !> every table lives in the two arrays iw and rw (a kernel gets their
   !> addresses once, whatever the number of tables).
   type :: families_t
      integer :: nn = 0, ne = 0, ns = 0
      integer, allocatable :: iw(:)
      real(wp), allocatable :: rw(:)
      type(table_t) :: springs, dampers, contacts, c_open, c_ys, c_lin, general, free, free2, free_n, &
                       damped, held, held2, held_n, loads, chain
      !> per node i: its inertia (kinetic energy) at rw(jn + i)
      integer :: jn = 0
      !> per element: its row in the clearance family (0: none; its law's
      !> table: c_open, c_ys or c_lin by where the row lies)
      integer, allocatable :: contact_row(:)
      !> More than one table adds dissipated power (springs with damping,
      !> contacts, general), or more than one clearance (their rows move between
      !> the law's tables): each row then leaves its power in pw and the powers
      !> are summed in element order, as the element loop of the general path does.
      logical :: mixed = .false.
      real(wp), allocatable :: th(:), w(:), pw(:)   !< scratch: node angles, speeds; element powers
   end type families_t

   !> A block's plain RK4 steps as the model takes them (`rk4_block`, D-168): the
   !> grid (step istep ends at min(t0 + istep dt, t_end)), the block's limits and
   !> guard windows (nw, set by the integrator), the steps computed (ns) and how
   !> it ended (done: the block ends, pend: with the step of size h not taken).
   type :: block_run_t
      real(wp) :: t0 = 0.0_wp, dt = 0.0_wp, t_end = 0.0_wp, tiny_t = 0.0_wp
      real(wp) :: t_goal = 0.0_wp, t_bp = 0.0_wp, t_tol = 0.0_wp, y_limit = 0.0_wp, h = 0.0_wp
      integer(i8) :: istep = 1
      integer :: nw = 0, ns = 0
      logical :: done = .false., pend = .false.
   end type block_run_t

contains

   !> The serial chain of the families f (table `chain`, n = 0: none) from
   !> the node and element tables, when the train is one and simple (its
   !> kernels run): its rows placed after the other tables in iw and rw.
   subroutine build_chain(f, fn, fe, simple)
      type(families_t), intent(inout) :: f
      type(fast_node_t), intent(in) :: fn(:)
      type(fast_element_t), intent(in) :: fe(:)
      logical, intent(in) :: simple
      integer :: q, nd, ne, i0, r0
      logical :: ok
      logical, allocatable :: seen(:)
      integer, allocatable :: iw(:)
      real(wp), allocatable :: rw(:)
      f%chain = table_t(0, size(f%iw), size(f%rw))
      ne = size(fe)
      ok = simple .and. ne > 0 .and. size(fn) == ne + 1 .and. f%general%n == 0 .and. f%damped%n == 0
      if (ok) ok = all(fe(2:ne)%l == fe(1:ne - 1)%r) .and. fn(fe(1)%l)%kind /= nk_other
      if (ok) ok = all(fn(fe(:)%r)%kind == nk_plain .and. fn(fe(:)%r)%d == 0.0_wp)
      if (ok) ok = fn(fe(1)%l)%d == 0.0_wp .or. fn(fe(1)%l)%kind == nk_held
      if (.not. ok) return
      allocate (seen(size(fn)))   ! (n + 1 nodes, each reached once: a path)
      seen = .false.
      seen(fe(1)%l) = .true.
      do q = 1, ne
         if (seen(fe(q)%r)) return
         seen(fe(q)%r) = .true.
      end do
      i0 = size(f%iw); r0 = size(f%rw)
      ! the chain's rows after the tables, cleared (one copy each, not an implied-do
      ! constructor grown by realloc: 10 M instructions at 20 000 nodes, startup8b)
      allocate (iw(i0 + chain_ni*(ne + 1)), rw(r0 + chain_nr*(ne + 1)))
      iw(1:i0) = f%iw
      iw(i0 + 1:) = 0
      rw(1:r0) = f%rw
      rw(r0 + 1:) = 0.0_wp
      call move_alloc(iw, f%iw)
      call move_alloc(rw, f%rw)
      f%chain = table_t(ne, i0, r0)
      nd = fe(1)%l
      associate (h => fn(nd))
         f%iw(i0 + 5:i0 + 6) = [nd, merge(-1, h%off, h%kind == nk_held)]
         f%rw(r0 + 1:r0 + 3) = [merge(h%theta0, h%j, h%kind == nk_held), h%w, h%load0]
      end associate
      do q = 1, ne
         nd = fe(q)%r
         f%iw(i0 + chain_ni*q + 4:i0 + chain_ni*q + 6) = [q, nd, fn(nd)%off]
         f%rw(r0 + chain_nr*q + 1:r0 + chain_nr*q + 3) = [fn(nd)%j, 0.0_wp, fn(nd)%load0]
      end do
      if (fe(1)%l == 1 .and. all(fe(:)%r == [(q + 1, q=1, ne)])) f%iw(i0 + 2) = 1   ! (in node order, D-160)
      do q = 1, f%springs%n
         associate (r1 => f%rw(f%springs%r0 + spring_nr*(q - 1) + 3), r2 => f%rw(f%springs%r0 + spring_nr*(q - 1) + 4))
            call link(f%springs, q, spring_ni, spring_nr, merge(ch_unit, ch_spring, r1 == 1.0_wp .and. r2 == 1.0_wp))
         end associate
      end do
      do q = 1, f%dampers%n
         call link(f%dampers, q, spring_ni, spring_nr, ch_damper)
      end do
      call chain_laws(f)
      f%mixed = .false.   ! (the chain sums each row's power straight, in element order)
      call chain_loads(f, fe, size(fn))
   contains
      !> Row q of table tab as its element's link, with law
      subroutine link(tab, q, ni, nr, law)
         type(table_t), intent(in) :: tab
         integer, intent(in) :: q, ni, nr, law
         integer :: a
         a = tab%i0 + ni*(q - 1)
         f%iw(i0 + chain_ni*f%iw(a + 1) + 1:i0 + chain_ni*f%iw(a + 1) + 3) = [law, a, tab%r0 + nr*(q - 1)]
      end subroutine link
   end subroutine build_chain

   !> The chain's loads in its links (D-153) when the loads'
   !> power loop adds the same products in the same order: each load on a link's
   !> node (not the head's), the links in load order, one load a node; a link
   !> without a load adds a zero product, which leaves the sum as it is. Then
   !> the head's row has 1 as its law (else 0) and row q's second real (else
   !> unused) holds its node's load (0 without one).
   subroutine chain_loads(f, fe, nn)
      type(families_t), intent(inout) :: f
      type(fast_element_t), intent(in) :: fe(:)
      integer, intent(in) :: nn
      integer :: q, last, row(nn)
      row = 0
      do q = 1, size(fe)
         row(fe(q)%r) = q
      end do
      last = 0
      do q = 1, f%loads%n
         if (row(f%iw(f%loads%i0 + q)) <= last) return
         last = row(f%iw(f%loads%i0 + q))
      end do
      do q = 1, f%loads%n
         f%rw(f%chain%r0 + chain_nr*row(f%iw(f%loads%i0 + q)) + 2) = f%rw(f%loads%r0 + q)
      end do
      f%iw(f%chain%i0 + 1) = 1
   end subroutine chain_loads

   !> The links of the chain's clearances to their rows and laws (a row moves
   !> between the law's tables when its element changes mode, by swaps at the
   !> tables' borders, D-75): all of them, or with `e` (its row just set; p0
   !> its row before) e's, row p0's (a swap's other row) and the rows next
   !> to the two borders, where a second swap puts the others.
   subroutine chain_laws(f, e, p0)
      type(families_t), intent(inout) :: f
      integer, intent(in), optional :: e, p0
      integer :: p, j, b1, b2
      if (f%chain%n == 0) return
      if (.not. present(e)) then
         do p = 1, f%contacts%n
            call point(p)
         end do
         return
      end if
      call point(f%contact_row(e))
      call point(p0)
      b1 = f%c_open%n
      b2 = f%c_open%n + f%c_ys%n
      do j = -1, 2
         if (b1 + j >= 1 .and. b1 + j <= f%contacts%n) call point(b1 + j)
         if (b2 + j >= 1 .and. b2 + j <= f%contacts%n) call point(b2 + j)
      end do
   contains
      !> Row p's element's link
      subroutine point(p)
         integer, intent(in) :: p
         integer :: a, law
         a = f%contacts%i0 + contact_ni*(p - 1)
         law = ch_open
         if (p > f%c_open%n) law = ch_ys
         if (p > f%c_open%n + f%c_ys%n) law = ch_lin
         f%iw(f%chain%i0 + chain_ni*f%iw(a + 1) + 1:f%chain%i0 + chain_ni*f%iw(a + 1) + 3) = &
            [law, a, f%contacts%r0 + contact_nr*(p - 1)]
      end subroutine point
   end subroutine chain_laws

   !> A node row's element torques: with `straight` (at most two), their
   !> indices into el_torque (for one it has not, its zero column ne + 1,
   !> D-95), else the range i1 : i2 of its incidences in iw.
   pure function row_ends(iw, i1, i2, ne, straight) result(x)
      integer, intent(in) :: iw(:), i1, i2, ne
      logical, intent(in) :: straight
      integer :: x(2)
      x = [i1, i2]
      if (.not. straight) return
      x = [2*ne + 1, 2*ne + 2]
      if (i2 >= i1) x(1) = iw(i1)
      if (i2 == i1 + 1) x(2) = iw(i2)
   end function row_ends

   include 'trainsim_model_windows.inc'
end module trainsim_model_families
