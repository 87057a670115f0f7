!> Natural frequencies and mode shapes of the linearised train: the
!> generalised symmetric eigenproblem K phi = omega^2 M phi (LAPACK dsygv)
!> over the free node angles; fixed and prescribed-speed nodes are held.
!> Every element is linearised by its own `linearise` in a state (lin_state_t:
!> as the run starts, every clearance closed, or the stiffest state a run can
!> reach), so no element type is known here.
!>
!> The RK4 step advice (`rk4_dt_limit`) uses the damped first-order system
!> dy/dt = A y over the physical states (node angles, speeds, motor currents):
!> the nodes' own blocks plus the elements' -K, -C, and the eigenvalues of A
!> (LAPACK dgeev). The largest stable step is the smallest, over the
!> eigenvalues, of r(arg lambda)/|lambda|, with r the radius of RK4's stability
!> region |1 + z + z^2/2 + z^3/6 + z^4/24| <= 1 along the ray (D-25).
module trainsim_modes
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t, fatal_error, err_numeric, err_input
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_element, only: element_t, lin_state_t, lin_start, lin_closed, lin_contact_closed, max_ports
   use trainsim_dt_bound, only: rk4_ray_radius, rk4_dt_bound, rk4_dt_bounds, inverse_inertias
   use trainsim_merged, only: null_space, rigid_projection
   implicit none
   private

   public :: modes_t, compute_modes, rk4_stability_limit, rk4_dt_bound, rk4_dt_limit, rk4_ray_radius
   public :: load_torque_bound, limiting_part, with_loads, rk4_dt_quick, rk4_dt_quick_states

   !> |lambda h| on the imaginary axis inside which classical RK4 is stable (2 sqrt 2).
   real(wp), parameter :: rk4_stability_limit = 2.0_wp*sqrt(2.0_wp)

   type :: modes_t
      integer :: n = 0
      integer, allocatable :: node(:)         !< model node index of each degree of freedom
      real(wp), allocatable :: freq_hz(:)     !< ascending
      real(wp), allocatable :: shape(:, :)    !< (dof, mode), largest component +1
      logical, allocatable :: rigid(:)        !< rigid-body (zero-frequency) mode
      real(wp) :: omega_max = 0.0_wp          !< highest circular frequency, rad/s
      !> modes found: n, less one per independent constraint row in force as the
      !> run starts (rigid gears and joins, stuck elements: D-81), whose nodes then
      !> move together (merged coordinates); shape(:, 1:nm), freq_hz(1:nm)
      integer :: nm = 0
      integer :: n_rows = 0                   !< constraint rows in force
   end type modes_t

   !> Impact-damping fractions sampled between none and the law's largest
   !> when every clearance is closed (RK4's region is not monotone in the
   !> damping ratio: D-25); the smallest limit is then refined.
   integer, parameter :: n_scale = 8
   !> Golden-section steps refining the worst impact-damping fraction (0.618^12:
   !> the fraction to 0.3 % of its bracket; the limit is flat at its minimum).
   integer, parameter :: n_golden = 12
   !> Above this many states the step advice is the O(n) bound of
   !> `rk4_dt_bound` instead of the dense eigenvalue problems (O(n^3) each, up
   !> to 24 of them: D-64); `rk4_dt_limit(..., dense=.true.)` asks for them.
   integer, parameter, public :: dense_state_limit = 64

   interface
      subroutine dgeev(jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info)
         import :: wp
         character, intent(in) :: jobvl, jobvr
         integer, intent(in) :: n, lda, ldvl, ldvr, lwork
         real(wp), intent(inout) :: a(lda, *)
         real(wp), intent(out) :: wr(*), wi(*), vl(ldvl, *), vr(ldvr, *), work(*)
         integer, intent(out) :: info
      end subroutine dgeev
      subroutine dsygv(itype, jobz, uplo, n, a, lda, b, ldb, w, work, lwork, info)
         import :: wp
         integer, intent(in) :: itype, n, lda, ldb, lwork
         character, intent(in) :: jobz, uplo
         real(wp), intent(inout) :: a(lda, *), b(ldb, *)
         real(wp), intent(out) :: w(*), work(*)
         integer, intent(out) :: info
      end subroutine dsygv
   end interface

contains

   !> Linearised (undamped) modes of `model` about its initial state, every
   !> element linearised in `state` (default: as the run starts). `closed`
   !> (kept for callers of the earlier interface) selects `lin_closed`: every
   !> clearance closed, zones as at t_start. `state` wins if both are given.
   subroutine compute_modes(model, modes, err, closed, state)
      type(model_t), intent(inout) :: model
      type(modes_t), intent(out) :: modes
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: closed
      type(lin_state_t), intent(in), optional :: state
      integer, allocatable :: dof(:)
      real(wp), allocatable :: k(:, :), m(:, :), w(:), work(:), y(:), inv_j(:), basis(:, :), kr(:, :), mr(:, :), &
                               phi(:)
      real(wp) :: ke(max_ports, max_ports), ce(max_ports, max_ports), lam_max, big
      integer :: i, n, info, a, b, j, imax, np, ends(max_ports), nr
      type(lin_state_t) :: st

      allocate (dof(size(model%nodes)))
      dof = 0
      n = 0
      do i = 1, size(model%nodes)
         if (model%is_held(i) .or. model%nodes(i)%n%is_fixed()) cycle
         if (.not. model%nodes(i)%n%inertia() > 0.0_wp) cycle
         n = n + 1
         dof(i) = n
      end do
      modes%n = n
      allocate (modes%node(n), modes%freq_hz(n), modes%shape(n, n), modes%rigid(n))
      if (n == 0) then
         call fatal_error(err, 'the train has no free inertia: every node is fixed or has a prescribed speed', err_input)
         return
      end if
      do i = 1, size(model%nodes)
         if (dof(i) > 0) modes%node(dof(i)) = i
      end do
      st = lin_start
      if (present(closed)) then
         if (closed) st = lin_closed
      end if
      if (present(state)) st = state
      ! the elements' discrete modes (contact face, zone) as the run starts
      call model%initial_state(y)
      call model%init_modes(model%run%t_start, y)
      call inverse_inertias(model, inv_j)
      allocate (k(n, n), m(n, n), w(n), work(max(1, 3*n*n)))
      k = 0.0_wp; m = 0.0_wp
      do i = 1, n
         m(i, i) = model%nodes(modes%node(i))%n%inertia()
      end do
      do j = 1, size(model%elements)
         call linearise_ports(model%elements(j)%e, st, inv_j, ends, np, ke, ce)
         do a = 1, np                                      ! over the element's ports (D-73)
            do b = 1, np
               i = dof(ends(a))
               info = dof(ends(b))
               if (i > 0 .and. info > 0) k(i, info) = k(i, info) + ke(a, b)
            end do
         end do
      end do
      call null_space(model, dof, n, basis, modes%n_rows, err); if (allocated(err)) return
      nr = size(basis, 2)
      modes%nm = nr
      modes%freq_hz = 0.0_wp
      modes%shape = 0.0_wp
      modes%rigid = .false.
      if (nr == 0) then
         modes%omega_max = 0.0_wp
         return
      end if
      kr = matmul(transpose(basis), matmul(k, basis))   ! the merged coordinates (basis = I without rows)
      mr = matmul(transpose(basis), matmul(m, basis))
      call dsygv(1, 'V', 'U', nr, kr, nr, mr, nr, w, work, size(work), info)
      if (info /= 0) then
         call fatal_error(err, 'the eigenvalue solver (LAPACK dsygv) failed with info = '//str(info), err_numeric)
         return
      end if
      lam_max = max(maxval(abs(w(1:nr))), tiny(1.0_wp))
      do i = 1, nr
         modes%rigid(i) = abs(w(i)) <= 1.0e-9_wp*lam_max
         if (modes%rigid(i)) then
            modes%freq_hz(i) = 0.0_wp
         else
            modes%freq_hz(i) = sqrt(max(w(i), 0.0_wp))/two_pi
         end if
         phi = matmul(basis, kr(:, i))
         imax = maxloc(abs(phi), 1)
         big = phi(imax)
         modes%shape(:, i) = phi/big
      end do
      modes%omega_max = two_pi*maxval(modes%freq_hz(1:nr))
   end subroutine compute_modes

   !> Element e linearised over its np ports (D-73): their nodes ends(1:np), ke and
   !> ce (1:np, 1:np); `linearise` for two, `port_linearise` beyond (inv_j: all nodes').
   pure subroutine linearise_ports(e, state, inv_j, ends, np, ke, ce)
      class(element_t), intent(in) :: e
      type(lin_state_t), intent(in) :: state
      real(wp), intent(in) :: inv_j(:)
      integer, intent(out) :: ends(max_ports), np
      real(wp), intent(out) :: ke(max_ports, max_ports), ce(max_ports, max_ports)
      integer :: p
      real(wp) :: k2(2, 2), c2(2, 2)   ! linearise's explicit 2 x 2 (a section of ke would be a temporary)
      np = e%n_ports()
      ends = 0; ke = 0.0_wp; ce = 0.0_wp
      ends(1:np) = [(e%port(p), p=1, np)]
      if (np == 2) then
         call e%linearise(state, inv_j(e%left), inv_j(e%right), k2, c2)
         ke(1:2, 1:2) = k2
         ce(1:2, 1:2) = c2
      else
         call e%port_linearise(state, inv_j(ends(1:np)), ke(1:np, 1:np), ce(1:np, 1:np))
      end if
   end subroutine linearise_ports

   !> The largest step h for which every h lambda of the linearised train in
   !> `state` lies in RK4's stability region (D-25). With every clearance closed
   !> the impact damping is swept from none to the law's largest and the
   !> smallest limit is returned; so is the damping of a contact closed gently
   !> under the loads (`with_loads`, D-55). `omega_crit` is |lambda| of the limiting
   !> eigenvalue (rad/s); `freq_hz` its damped frequency |Im lambda|/2 pi and
   !> `damping_ratio` -Re lambda/|lambda|. dt_max = huge when nothing limits it.
   !> Above dense_state_limit states, unless `dense`, the limit is the O(n)
   !> bound (`rk4_dt_bound`, safe: never above the dense limit): omega_crit is
   !> then the bound on |lambda|, freq_hz that of the limiting point of its
   !> region and damping_ratio 0 (no eigenvalue is known, D-64).
   subroutine rk4_dt_limit(model, state_in, dt_max, omega_crit, err, freq_hz, damping_ratio, dense)
      type(model_t), intent(inout) :: model
      type(lin_state_t), intent(in) :: state_in
      real(wp), intent(out) :: dt_max, omega_crit
      type(error_t), allocatable, intent(out) :: err
      real(wp), intent(out), optional :: freq_hz, damping_ratio
      logical, intent(in), optional :: dense
      real(wp), allocatable :: y(:), inv_j(:), lp(:, :), tr(:, :)
      real(wp) :: h(0:n_scale), a, b, c, d, fc, fd, f_bound
      complex(wp) :: lam(0:n_scale), lc, ld
      type(lin_state_t) :: st, state
      integer :: j, jmin, it
      logical :: use_dense
      real(wp), parameter :: gr = 0.6180339887498949_wp   ! golden section

      state = with_loads(model, state_in)
      call model%initial_state(y)
      call model%init_modes(model%run%t_start, y, tables=.false.)   ! the elements' own procedures only (D-74)
      use_dense = model%n_states <= dense_state_limit .or. model%nport   ! (the O(n) bound has two-port blocks: D-73)
      if (present(dense)) use_dense = use_dense .or. dense
      if (.not. use_dense) then
         call rk4_dt_bound(model, state, y, dt_max, omega_crit, freq_hz=f_bound)
         if (present(freq_hz)) freq_hz = f_bound
         if (present(damping_ratio)) damping_ratio = 0.0_wp
         return
      end if
      call inverse_inertias(model, inv_j)
      call rigid_projection(model, lp, tr, err); if (allocated(err)) return   ! rigid gears and joins merged (D-86)
      st = state
      ! impact damping exists only where there are clearances (guards)
      if (state%contact /= lin_contact_closed .or. state%impact_scale == 0.0_wp .or. model%n_guards == 0) then
         call limit_at(state, dt_max, lam(0), err)
         if (allocated(err)) return
      else
         do j = 0, n_scale
            st%impact_scale = state%impact_scale*real(j, wp)/n_scale
            call limit_at(st, h(j), lam(j), err)
            if (allocated(err)) return
         end do
         jmin = minloc(h, 1) - 1
         dt_max = h(jmin)
         lam(0) = lam(jmin)
         ! refine inside the neighbouring samples by golden section
         a = state%impact_scale*real(max(jmin - 1, 0), wp)/n_scale
         b = state%impact_scale*real(min(jmin + 1, n_scale), wp)/n_scale
         c = b - gr*(b - a); d = a + gr*(b - a)
         st%impact_scale = c; call limit_at(st, fc, lc, err); if (allocated(err)) return
         st%impact_scale = d; call limit_at(st, fd, ld, err); if (allocated(err)) return
         do it = 1, n_golden
            if (fc < fd) then
               b = d; d = c; fd = fc; ld = lc
               c = b - gr*(b - a)
               st%impact_scale = c; call limit_at(st, fc, lc, err); if (allocated(err)) return
            else
               a = c; c = d; fc = fd; lc = ld
               d = a + gr*(b - a)
               st%impact_scale = d; call limit_at(st, fd, ld, err); if (allocated(err)) return
            end if
         end do
         if (fc < dt_max) then
            dt_max = fc; lam(0) = lc
         end if
         if (fd < dt_max) then
            dt_max = fd; lam(0) = ld
         end if
      end if
      omega_crit = abs(lam(0))
      if (present(freq_hz)) freq_hz = abs(aimag(lam(0)))/two_pi
      if (present(damping_ratio)) then
         damping_ratio = 0.0_wp
         if (omega_crit > 0.0_wp) damping_ratio = max(-real(lam(0), wp), 0.0_wp)/omega_crit
      end if

   contains

      !> Limit for one state: assemble A, its eigenvalues, the smallest r/|lambda|.
      subroutine limit_at(s, hmax, lam_crit, err)
         type(lin_state_t), intent(in) :: s
         real(wp), intent(out) :: hmax
         complex(wp), intent(out) :: lam_crit
         type(error_t), allocatable, intent(out) :: err
         real(wp), allocatable :: amat(:, :), wr(:), wi(:), work(:)
         real(wp) :: dtq(5, size(model%nodes)), ke(max_ports, max_ports), ce(max_ports, max_ports), &
                     jt(max_ports, 2*max_ports), vl(1, 1), vr(1, 1), big, hl, re
         integer :: n, i, k, p, q, na, nb, row, ends(max_ports), info, np
         complex(wp) :: l
         n = model%n_states
         hmax = huge(1.0_wp)
         lam_crit = (0.0_wp, 0.0_wp)
         if (n == 0) return
         allocate (amat(n, n), wr(n), wi(n), work(8*n))
         amat = 0.0_wp
         dtq = 0.0_wp
         do i = 1, size(model%nodes)
            if (model%is_held(i)) cycle
            associate (nd => model%nodes(i)%n)
               if (nd%nstates() > 0) call nd%jacobian(model%run%t_start, y, amat, dtq(1:nd%nstates(), i))
            end associate
         end do
         ! element torques -K theta - C omega on the node rows (as model%jacobian)
         do i = 1, size(model%elements)
            call linearise_ports(model%elements(i)%e, s, inv_j, ends, np, ke, ce)
            do q = 1, np
               jt(:, 2*q - 1) = -ke(:, q); jt(:, 2*q) = -ce(:, q)
            end do
            do p = 1, np
               na = ends(p)
               if (model%is_held(na)) cycle
               do k = 1, model%nodes(na)%n%nstates()
                  if (dtq(k, na) == 0.0_wp) cycle
                  row = model%nodes(na)%n%offset + k
                  do q = 1, np
                     nb = ends(q)
                     if (model%is_held(nb) .or. model%nodes(nb)%n%nstates() < 2) cycle
                     amat(row, model%nodes(nb)%n%offset + 1) = amat(row, model%nodes(nb)%n%offset + 1) + &
                                                                dtq(k, na)*jt(p, 2*q - 1)
                     amat(row, model%nodes(nb)%n%offset + 2) = amat(row, model%nodes(nb)%n%offset + 2) + &
                                                                dtq(k, na)*jt(p, 2*q)
                  end do
               end do
            end do
         end do
         if (allocated(lp)) then                    ! in the merged coordinates of the rigid connections
            amat = matmul(lp, matmul(amat, tr))
            n = size(amat, 1)
         end if
         call dgeev('N', 'N', n, amat, n, wr, wi, vl, 1, vr, 1, work, size(work), info)
         if (info /= 0) then
            call fatal_error(err, 'the eigenvalue solver (LAPACK dgeev) failed with info = '//str(info), err_numeric)
            return
         end if
         big = maxval(abs(cmplx(wr(1:n), wi(1:n), wp)))   ! (n: the merged size; beyond it wr is unset)
         do i = 1, n
            l = cmplx(wr(i), wi(i), wp)
            ! rigid-body modes (lambda = 0 as a Jordan block: round-off of order
            ! sqrt(eps) |lambda|max) do not limit the step; nor can any |lambda|
            ! below 0.88 |lambda|max, as RK4's radius is within [2.62, 2.96]
            if (abs(l) <= 1.0e-6_wp*big) cycle
            ! a passive train has Re lambda <= 0: a positive part is round-off
            re = min(real(l, wp), 0.0_wp)
            if (abs(cmplx(re, aimag(l), wp)) == 0.0_wp) cycle
            hl = rk4_ray_radius(cmplx(re, aimag(l), wp)/abs(cmplx(re, aimag(l), wp)))/abs(l)
            if (hl < hmax) then
               hmax = hl
               lam_crit = l
            end if
         end do
      end subroutine limit_at
   end subroutine rk4_dt_limit

   !> O(n) bounds for the train in `state` (loads as `with_loads`): |lambda| <=
   !> `bound` for every eigenvalue, and RK4 is stable for any h <= dt_max
   !> (`rk4_dt_bound`, D-64). A check that passes with them needs no
   !> eigenvalues (check_fixed_step, the explicit SUNDIALS check).
   subroutine rk4_dt_quick(model, state_in, dt_max, bound)
      type(model_t), intent(inout) :: model
      type(lin_state_t), intent(in) :: state_in
      real(wp), intent(out) :: dt_max, bound
      real(wp), allocatable :: y(:)
      if (model%nport) then   ! the O(n) bound has two-port blocks (D-73): no quick pass, the dense limit decides
         dt_max = 0.0_wp
         bound = huge(1.0_wp)
         return
      end if
      call model%initial_state(y)
      call model%init_modes(model%run%t_start, y, tables=.false.)   ! the elements' own procedures only (D-74)
      call rk4_dt_bound(model, with_loads(model, state_in), y, dt_max, bound)
   end subroutine rk4_dt_quick

   !> `rk4_dt_quick` for each of `states`, the modes initialised once and the
   !> bound computed once for states whose element blocks agree (`rk4_dt_bounds`,
   !> D-139); `freq_hz` as `rk4_dt_limit` gives it above the dense limit.
   subroutine rk4_dt_quick_states(model, states, dt_max, bound, freq_hz)
      type(model_t), intent(inout) :: model
      type(lin_state_t), intent(in) :: states(:)
      real(wp), intent(out) :: dt_max(:), bound(:), freq_hz(:)
      real(wp), allocatable :: y(:)
      real(wp) :: omega_k(size(states))
      type(lin_state_t) :: st(size(states))
      integer :: k
      if (model%nport) then   ! as rk4_dt_quick
         dt_max = 0.0_wp
         bound = huge(1.0_wp)
         freq_hz = 0.0_wp
         return
      end if
      call model%initial_state(y)
      call model%init_modes(model%run%t_start, y, tables=.false.)   ! the elements' own procedures only (D-74)
      do k = 1, size(states)
         st(k) = with_loads(model, states(k))
      end do
      call rk4_dt_bounds(model, st, y, dt_max, bound, omega_k, freq_hz)
   end subroutine rk4_dt_quick_states

   !> `state` gets the largest torque the loads can drive through one element
   !> (`load_torque_bound`), unless it has one (a negative one: leave the
   !> loads out, D-55).
   function with_loads(model, state) result(st)
      type(model_t), intent(in) :: model
      type(lin_state_t), intent(in) :: state
      type(lin_state_t) :: st
      st = state
      if (st%load_torque == 0.0_wp) st%load_torque = load_torque_bound(model)
   end function with_loads

   !> The largest torque the external loads can drive through one element over
   !> the run (D-55): the larger of the sum of every load's largest positive
   !> value and the sum of its largest negative one, each sampled at 1001 points
   !> of [t_start, t_end] and at its table knots. Exact for one driving load
   !> against a held node, for a drive balanced by a load, and for a free train
   !> driven on one side; a bound, not a solution of the static problem.
   real(wp) function load_torque_bound(model) result(tq)
      type(model_t), intent(in) :: model
      real(wp), allocatable :: bp(:)
      real(wp) :: pos, neg, v, t0, t1, vp, vn
      integer :: i, j
      integer, parameter :: n_sample = 1000
      pos = 0.0_wp; neg = 0.0_wp
      t0 = model%run%t_start; t1 = model%run%t_end
      if (.not. allocated(model%loads)) then
         tq = 0.0_wp
         return
      end if
      do i = 1, size(model%loads)
         vp = 0.0_wp; vn = 0.0_wp
         do j = 0, n_sample
            v = model%loads(i)%torque%value(t0 + (t1 - t0)*real(j, wp)/n_sample)
            if (v == v) then
               vp = max(vp, v); vn = min(vn, v)
            end if
         end do
         call model%loads(i)%torque%breakpoints(bp)
         do j = 1, size(bp)
            if (bp(j) < t0 .or. bp(j) > t1) cycle
            v = model%loads(i)%torque%value(bp(j))
            if (v == v) then
               vp = max(vp, v); vn = min(vn, v)
            end if
         end do
         pos = pos + vp
         neg = neg - vn
      end do
      tq = min(max(pos, neg), huge(1.0_wp))
   end function load_torque_bound

   !> The node or element of `model` that alone (its own inertias behind it,
   !> the rest of the train held) has the smallest RK4 step limit in `state`:
   !> a node's own damping (-d(speed rate)/d(speed)), an element's reduced
   !> two-inertia system lambda^2 + (c/m) lambda + k/m = 0 from its
   !> `linearise` (the contact damping of its law at its worst, D-25/D-55).
   !> `text` names it, its deck group and what limits it; `h_part` is its limit.
   !> For messages only (refusals and advice), never on the hot path.
   subroutine limiting_part(model, state_in, text, h_part)
      type(model_t), intent(inout) :: model
      type(lin_state_t), intent(in) :: state_in
      character(len=:), allocatable, intent(out) :: text
      real(wp), intent(out) :: h_part
      type(lin_state_t) :: state
      real(wp), allocatable :: y(:), inv_j(:), f0(:), f1(:), yp(:)
      real(wp) :: ke(max_ports, max_ports), ce(max_ports, max_ports), a, b, disc, h, hl, dl
      complex(wp) :: lam
      integer :: i, o, p, np, ends(max_ports)
      state = with_loads(model, state_in)
      call model%initial_state(y)
      call model%init_modes(model%run%t_start, y, tables=.false.)   ! the elements' own procedures only (D-74)
      call inverse_inertias(model, inv_j)
      allocate (f0(size(y)), f1(size(y)))
      yp = y
      h_part = huge(1.0_wp)
      text = 'no single node or element'
      do i = 1, size(model%nodes)
         if (model%is_held(i)) cycle
         associate (nd => model%nodes(i)%n)
            if (nd%nstates() < 2) cycle
            o = nd%offset
            ! a node writes its own states only: clear and perturb those (O(n) in all)
            f0(o + 1:o + nd%nstates()) = 0.0_wp; f1(o + 1:o + nd%nstates()) = 0.0_wp
            call nd%derivatives(model%run%t_start, y, 0.0_wp, f0)
            h = 1.0e-6_wp*max(1.0_wp, abs(y(o + 2)))
            yp(o + 2) = y(o + 2) + h
            call nd%derivatives(model%run%t_start, yp, 0.0_wp, f1)
            yp(o + 2) = y(o + 2)
            dl = -(f1(o + 2) - f0(o + 2))/h          ! decay rate of the node's speed alone, 1/s
            if (.not. dl > 0.0_wp) cycle
            hl = rk4_ray_radius((-1.0_wp, 0.0_wp))/dl
            if (hl < h_part) then
               h_part = hl
               text = "node '"//nd%id//"'"//origin_of(nd%origin)//': its own damping (key damping) '// &
                      'decays its speed at '//str(dl, 4)//' 1/s'
            end if
         end associate
      end do
      do i = 1, size(model%elements)
         associate (e => model%elements(i)%e)
            call linearise_ports(e, state, inv_j, ends, np, ke, ce)
            a = ke(1, 1)*inv_j(ends(1)) + ke(2, 2)*inv_j(ends(2))     ! k/m of the relative motion
            b = ce(1, 1)*inv_j(ends(1)) + ce(2, 2)*inv_j(ends(2))     ! c/m
            do p = 3, np                                              ! further ports (D-73)
               a = a + ke(p, p)*inv_j(ends(p))
               b = b + ce(p, p)*inv_j(ends(p))
            end do
            if (.not. (a > 0.0_wp .or. b > 0.0_wp)) cycle
            disc = b*b - 4.0_wp*a
            if (disc >= 0.0_wp) then
               lam = cmplx(-0.5_wp*(b + sqrt(disc)), 0.0_wp, wp)
            else
               lam = cmplx(-0.5_wp*b, 0.5_wp*sqrt(-disc), wp)
            end if
            if (.not. abs(lam) > 0.0_wp) cycle
            hl = rk4_ray_radius(lam/abs(lam))/abs(lam)
            if (hl < h_part) then
               h_part = hl
               if (b*b >= a) then
                  text = "element '"//e%id//"'"//origin_of(e%origin)//': its damping (c/m = '//str(b, 4)// &
                         ' 1/s against sqrt(k/m) = '//str(sqrt(max(a, 0.0_wp)), 4)//' 1/s'
                  if (e%n_guards() > 0) text = text//'; its contact law''s damping'
                  text = text//')'
               else
                  text = "element '"//e%id//"'"//origin_of(e%origin)//': its stiffness (sqrt(k/m) = '// &
                         str(sqrt(a), 4)//' rad/s)'
               end if
            end if
         end associate
      end do
   contains
      function origin_of(where) result(s)
         character(len=:), allocatable, intent(in) :: where
         character(len=:), allocatable :: s
         s = ''
         if (allocated(where)) then
            if (len(where) > 0) s = ' ('//where//')'
         end if
      end function origin_of
   end subroutine limiting_part
end module trainsim_modes
