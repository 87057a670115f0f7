!> Kinematic constraints of elements in their current modes (D-81): a stuck
!> clutch joins two nodes into one rigid body, a held brake holds a node to a
!> fixed node, a rigid gear couples two speeds. The active rows g (sum_p g_p
!> w_p = 0 over an element's ports) form G; with M the diagonal of the node
!> inertias (held and fixed nodes: M^-1 = 0), the constraint torques lam solve
!>   G M^-1 G^T lam = -G a,   a = the accelerations without the constraints,
!> and the nodes accelerate at a + M^-1 G^T lam.
!>
!> Exact where it matters (no drift): rows of one or two nodes join nodes into
!> clusters with fixed speed ratios rho (w_i = rho_i w_ref). A cluster held by
!> a held or fixed node, or locked by a one-node row, gets rho_i times the held
!> node's prescribed acceleration (0 for a fixed node: exactly 0); a free
!> cluster gets rho_i alpha, alpha = sum rho J a / sum rho^2 J: nodes joined at
!> rho = 1 accelerate bit for bit alike. lam from the solve is used only for
!> the torques the elements report and their limits. A row of three or more
!> nodes leaves its cluster to the solve (roundoff). Redundant rows (a loop of
!> stuck elements, rank deficiency of G M^-1 G^T) are dropped: they carry no
!> torque (lam = 0), the others carry the load.
!>
!> Lossy rows (the rigid lossy gear, D-97): port p of row r gets c_rp g_rp lam_r
!> (H = C.G), so lam solves G M^-1 H^T lam = -G a, factorised by LU (no
!> pivoting, the same dropping) when any row is lossy, and a cluster's exact
!> acceleration weighs each slot by f, f_a c_ra = f_b c_rb along its rows:
!> alpha = sum f rho J a / sum f rho^2 J (the lossy row's work removed).
!> Without a lossy row every f and c is 1 and nothing changes (bit for bit).
!>
!> Plain arrays, sized once by `cn_setup`; nothing here allocates after it.
!> The elements declare their rows in their `con` (trainsim_constraint_rows).
module trainsim_constraints
   use trainsim_kinds, only: wp
   use trainsim_element, only: element_slot_t, max_ports
   use trainsim_constraint_rows, only: max_constraints
   implicit none
   private

   public :: constraint_set_t, cn_setup, cn_gather, cn_factor, cn_solve, cn_project

   !> Relative size of a pivot of G M^-1 G^T below which its row is redundant.
   real(wp), parameter :: rank_tol = 1.0e-10_wp

   !> The constraints of a model: the candidate elements, the active rows, the
   !> nodes they touch (slots) with their clusters, the factorised G M^-1 G^T.
   type :: constraint_set_t
      integer, allocatable :: cand(:)            !< elements with `constrains`
      integer :: m = 0                           !< active rows
      logical :: acc_wanted = .false.            !< a candidate's guards read its ports' accelerations
      integer, allocatable :: row_el(:), row_k(:), row_np(:)
      integer, allocatable :: row_slot(:, :)     !< (max_ports, row): slot of each port's node
      real(wp), allocatable :: row_g(:, :)       !< (max_ports, row)
      real(wp), allocatable :: row_c(:, :)       !< (max_ports, row): torque scale (lossy row; else 1)
      logical :: lossy = .false.                 !< a row with c /= 1: LU, not Cholesky
      real(wp) :: loss = 0.0_wp                  !< power the lossy rows dissipate (set by the model's RHS)
      logical, allocatable :: keep(:)            !< independent row (else dropped, lam = 0)
      real(wp), allocatable :: chol(:, :)        !< Cholesky factor of G M^-1 G^T (kept rows)
      real(wp), allocatable :: lam(:), b(:)
      integer :: nc = 0                          !< nodes touched (slots)
      integer, allocatable :: node(:)            !< slot -> model node
      integer, allocatable :: slot(:)            !< model node -> slot (0: untouched)
      !> per slot: inverse inertia (0 held/fixed), inertia, acceleration without
      !> constraints (held: prescribed), acceleration with them, speed ratio
      real(wp), allocatable :: inv_j(:), jn(:), afree(:), acc(:), rho(:), w(:)
      real(wp), allocatable :: fw(:)             !< per slot: the weight f of a lossy cluster (else 1)
      integer, allocatable :: cl(:)              !< per slot: its cluster
      integer :: ncl = 0
      integer, allocatable :: cl_ref(:)          !< per cluster: its held slot (0: free)
      logical, allocatable :: cl_exact(:), cl_locked(:)
      real(wp), allocatable :: scratch(:)        !< (n_y) a RHS for the guards
      !> (n_y) a node's own derivatives inside the RHS (not scratch: that one is
      !> lent to the RHS by constraints_at, and a motor in a cluster needs this)
      real(wp), allocatable :: node_dydt(:)
   end type constraint_set_t

contains

   !> Size every buffer for the candidate elements of `elements` (those with
   !> `constrains`), n_nodes nodes and n_y states.
   subroutine cn_setup(cn, elements, n_nodes, n_y)
      type(constraint_set_t), intent(inout) :: cn
      type(element_slot_t), intent(in) :: elements(:)
      integer, intent(in) :: n_nodes, n_y
      integer :: i, nmax, ns
      cn%cand = pack([(i, i=1, size(elements))], [(elements(i)%e%con%on, i=1, size(elements))])
      nmax = max(1, max_constraints*size(cn%cand))
      ns = max(1, min(n_nodes, max_ports*nmax))
      cn%m = 0
      cn%nc = 0
      cn%ncl = 0
      if (allocated(cn%row_el)) deallocate (cn%row_el, cn%row_k, cn%row_np, cn%row_slot, cn%row_g, cn%keep, &
                                            cn%chol, cn%lam, cn%b, cn%node, cn%slot, cn%inv_j, cn%jn, cn%afree, &
                                            cn%acc, cn%rho, cn%w, cn%cl, cn%cl_ref, cn%cl_exact, cn%cl_locked, cn%scratch, &
                                            cn%node_dydt, cn%row_c, cn%fw)
      allocate (cn%row_el(nmax), cn%row_k(nmax), cn%row_np(nmax), cn%row_slot(max_ports, nmax), &
                cn%row_g(max_ports, nmax), cn%row_c(max_ports, nmax), cn%keep(nmax), cn%chol(nmax, nmax), cn%lam(nmax), cn%b(nmax))
      allocate (cn%node(ns), cn%slot(n_nodes), cn%inv_j(ns), cn%jn(ns), cn%afree(ns), cn%acc(ns), cn%rho(ns), cn%w(ns), &
                cn%cl(ns), cn%cl_ref(ns), cn%cl_exact(ns), cn%cl_locked(ns), cn%scratch(max(1, n_y)), &
                cn%node_dydt(max(1, n_y)), cn%fw(ns))
      cn%slot = 0
      cn%lam = 0.0_wp
      cn%scratch = 0.0_wp
      cn%node_dydt = 0.0_wp
   end subroutine cn_setup

   !> The rows the candidate elements declare in their current modes; `changed`:
   !> they differ from the rows held (a mode change made or undid a constraint).
   !> The slots of the nodes are assigned here; the caller then sets inv_j and jn
   !> of every slot and calls `cn_factor`.
   subroutine cn_gather(cn, elements, changed)
      type(constraint_set_t), intent(inout) :: cn
      type(element_slot_t), intent(inout) :: elements(:)
      logical, intent(out) :: changed
      integer :: q, i, k, p, np, m, nd, s
      m = 0
      changed = .false.
      cn%acc_wanted = .false.
      cn%lossy = .false.
      do s = 1, cn%nc
         cn%slot(cn%node(s)) = 0
      end do
      cn%nc = 0
      do q = 1, size(cn%cand)
         i = cn%cand(q)
         associate (e => elements(i)%e)
            if (e%con%want_acc) cn%acc_wanted = .true.
            k = e%con%n
            if (k == 0) then
               e%con%lam = 0.0_wp
               cycle
            end if
            np = e%n_ports()
            do k = 1, e%con%n
               m = m + 1
               if (m > cn%m) then
                  changed = .true.
               else if (cn%row_el(m) /= i .or. cn%row_k(m) /= k) then
                  changed = .true.
               else if (any(cn%row_g(1:np, m) /= e%con%g(k, 1:np))) then
                  changed = .true.
               else if (any(cn%row_c(1:np, m) /= e%con%c(k, 1:np))) then
                  changed = .true.
               end if
               cn%row_el(m) = i
               cn%row_k(m) = k
               cn%row_np(m) = np
               cn%row_g(:, m) = 0.0_wp
               cn%row_g(1:np, m) = e%con%g(k, 1:np)
               cn%row_c(:, m) = 1.0_wp
               cn%row_c(1:np, m) = e%con%c(k, 1:np)
               if (any(cn%row_c(1:np, m) /= 1.0_wp)) cn%lossy = .true.
               cn%row_slot(:, m) = 0
               do p = 1, np
                  nd = e%port(p)
                  if (cn%slot(nd) == 0) then
                     cn%nc = cn%nc + 1
                     cn%node(cn%nc) = nd
                     cn%slot(nd) = cn%nc
                  end if
                  cn%row_slot(p, m) = cn%slot(nd)
               end do
            end do
         end associate
      end do
      if (m /= cn%m) changed = .true.
      cn%m = m
   end subroutine cn_gather

   !> Clusters, speed ratios and the Cholesky factor of G M^-1 G^T, from the rows
   !> and the slots' inv_j, jn (after `cn_gather`).
   subroutine cn_factor(cn)
      type(constraint_set_t), intent(inout) :: cn
      call clusters(cn)
      if (cn%lossy) then
         call factor_lu(cn)
      else
         call factor(cn)
      end if
   end subroutine cn_factor

   !> Join the slots into clusters over the rows and carry the speed ratios.
   subroutine clusters(cn)
      type(constraint_set_t), intent(inout) :: cn
      integer :: r, p, a, b, s, c, pass, nz
      logical :: more
      real(wp) :: ga, gb, tol, ca, cb
      ! cluster = smallest slot reachable (label propagation: m, nc are small)
      do s = 1, cn%nc
         cn%cl(s) = s
      end do
      more = .true.
      do while (more)
         more = .false.
         do r = 1, cn%m
            ! (over the row's nonzero ports: a port with g = 0 is not joined, e.g. (0, 1) holds port 2 only)
            c = minval([(cn%cl(cn%row_slot(p, r)), p=1, cn%row_np(r))], &
                       mask=[(cn%row_g(p, r) /= 0.0_wp, p=1, cn%row_np(r))])
            do p = 1, cn%row_np(r)
               if (cn%row_g(p, r) == 0.0_wp) cycle
               if (cn%cl(cn%row_slot(p, r)) /= c) then
                  cn%cl(cn%row_slot(p, r)) = c
                  more = .true.
               end if
            end do
         end do
      end do
      cn%ncl = cn%nc
      cn%cl_ref(1:cn%nc) = 0
      cn%cl_exact(1:cn%nc) = .true.
      cn%cl_locked(1:cn%nc) = .false.
      cn%rho(1:cn%nc) = 0.0_wp
      cn%fw(1:cn%nc) = 1.0_wp
      ! the reference of each cluster: its held slot (a second one: not exact), else its first slot
      do s = 1, cn%nc
         c = cn%cl(s)
         if (cn%inv_j(s) /= 0.0_wp) cycle
         if (cn%cl_ref(c) == 0) then
            cn%cl_ref(c) = s
            cn%rho(s) = 1.0_wp
         else
            cn%cl_exact(c) = .false.
         end if
      end do
      do s = 1, cn%nc
         if (cn%cl(s) == s .and. cn%cl_ref(s) == 0) cn%rho(s) = 1.0_wp
      end do
      do pass = 1, cn%m + 1
         more = .false.
         do r = 1, cn%m
            nz = count(cn%row_g(1:cn%row_np(r), r) /= 0.0_wp)
            c = cn%cl(cn%row_slot(1, r))
            if (nz > 2) then
               cn%cl_exact(c) = .false.
               cycle
            end if
            a = 0; b = 0
            do p = 1, cn%row_np(r)
               if (cn%row_g(p, r) == 0.0_wp) cycle
               if (a == 0) then
                  a = p
               else
                  b = p
               end if
            end do
            if (a == 0) cycle
            if (b == 0) then                                ! a node held at rest: the cluster is locked
               cn%cl_locked(cn%cl(cn%row_slot(a, r))) = .true.
               cycle
            end if
            ga = cn%row_g(a, r); gb = cn%row_g(b, r)
            ca = cn%row_c(a, r); cb = cn%row_c(b, r)
            a = cn%row_slot(a, r); b = cn%row_slot(b, r)
            if (cn%rho(a) /= 0.0_wp .and. cn%rho(b) == 0.0_wp) then
               cn%rho(b) = -ga/gb*cn%rho(a)
               if (ca /= cb) cn%fw(b) = cn%fw(a)*ca/cb          ! f_a c_a = f_b c_b (D-97)
               more = .true.
            else if (cn%rho(b) /= 0.0_wp .and. cn%rho(a) == 0.0_wp) then
               cn%rho(a) = -gb/ga*cn%rho(b)
               if (ca /= cb) cn%fw(a) = cn%fw(b)*cb/ca
               more = .true.
            else if (cn%rho(a) /= 0.0_wp .and. pass > 1) then ! both known: a loop; consistent ratios?
               tol = 1.0e-12_wp*(abs(ga*cn%rho(a)) + abs(gb*cn%rho(b)))
               if (abs(ga*cn%rho(a) + gb*cn%rho(b)) > tol) cn%cl_locked(cn%cl(a)) = .true.
               if (abs(cn%fw(a)*ca - cn%fw(b)*cb) > 1.0e-12_wp*abs(cn%fw(a)*ca)) cn%cl_exact(cn%cl(a)) = .false.
            end if
         end do
         if (.not. more .and. pass > 1) exit
      end do
      ! a locked cluster with a held reference that moves cannot be exact either
      do c = 1, cn%nc
         if (cn%cl_locked(c) .and. cn%cl_ref(c) /= 0) cn%cl_exact(c) = .false.
      end do
   end subroutine clusters

   !> G M^-1 G^T, Cholesky with rows dropped whose pivot is below rank_tol of the
   !> largest diagonal (redundant rows: they carry no torque).
   subroutine factor(cn)
      type(constraint_set_t), intent(inout) :: cn
      integer :: r, q, p, pp, k
      real(wp) :: sum_, dmax
      associate (a => cn%chol, m => cn%m)
         do r = 1, m
            do q = 1, r
               sum_ = 0.0_wp
               do p = 1, cn%row_np(r)
                  do pp = 1, cn%row_np(q)
                     if (cn%row_slot(p, r) /= cn%row_slot(pp, q)) cycle
                     sum_ = sum_ + cn%row_g(p, r)*cn%inv_j(cn%row_slot(p, r))*cn%row_g(pp, q)
                  end do
               end do
               a(r, q) = sum_
               a(q, r) = sum_
            end do
         end do
         dmax = 0.0_wp
         do r = 1, m
            dmax = max(dmax, a(r, r))
         end do
         do r = 1, m
            do k = 1, r - 1
               if (.not. cn%keep(k)) cycle
               a(r, r) = a(r, r) - a(r, k)**2
            end do
            cn%keep(r) = a(r, r) > rank_tol*dmax .and. dmax > 0.0_wp
            if (.not. cn%keep(r)) then
               a(r, :) = 0.0_wp
               a(:, r) = 0.0_wp
               cycle
            end if
            a(r, r) = sqrt(a(r, r))
            do q = r + 1, m
               sum_ = a(q, r)
               do k = 1, r - 1
                  if (cn%keep(k)) sum_ = sum_ - a(q, k)*a(r, k)
               end do
               a(q, r) = sum_/a(r, r)
            end do
         end do
      end associate
   end subroutine factor

   !> G M^-1 H^T (H = C.G, not symmetric: a lossy row, D-97) factorised by LU
   !> without pivoting, rows dropped as in `factor` (pivot below rank_tol of the
   !> largest diagonal): L unit lower and U in cn%chol.
   subroutine factor_lu(cn)
      type(constraint_set_t), intent(inout) :: cn
      integer :: r, q, p, pp, i
      real(wp) :: sum_, dmax, l
      associate (a => cn%chol, m => cn%m)
         do r = 1, m
            do q = 1, m
               sum_ = 0.0_wp
               do p = 1, cn%row_np(r)
                  do pp = 1, cn%row_np(q)
                     if (cn%row_slot(p, r) /= cn%row_slot(pp, q)) cycle
                     sum_ = sum_ + cn%row_g(p, r)*cn%inv_j(cn%row_slot(p, r))*cn%row_c(pp, q)*cn%row_g(pp, q)
                  end do
               end do
               a(r, q) = sum_
            end do
         end do
         dmax = 0.0_wp
         do r = 1, m
            dmax = max(dmax, abs(a(r, r)))
         end do
         do r = 1, m
            cn%keep(r) = abs(a(r, r)) > rank_tol*dmax .and. dmax > 0.0_wp
            if (.not. cn%keep(r)) then
               a(r, 1:m) = 0.0_wp
               a(1:m, r) = 0.0_wp
               cycle
            end if
            do i = r + 1, m
               l = a(i, r)/a(r, r)
               a(i, r) = l
               a(i, r + 1:m) = a(i, r + 1:m) - l*a(r, r + 1:m)
            end do
         end do
      end associate
   end subroutine factor_lu

   !> lam from afree (per slot; held slots: their prescribed acceleration), and
   !> acc per slot (exact per cluster where the cluster allows, see above).
   subroutine cn_solve(cn)
      type(constraint_set_t), intent(inout) :: cn
      integer :: r, p, s
      do r = 1, cn%m
         cn%b(r) = 0.0_wp
         do p = 1, cn%row_np(r)
            cn%b(r) = cn%b(r) - cn%row_g(p, r)*cn%afree(cn%row_slot(p, r))
         end do
      end do
      call chol_solve(cn)
      do s = 1, cn%nc
         cn%acc(s) = 0.0_wp
      end do
      do r = 1, cn%m
         do p = 1, cn%row_np(r)
            s = cn%row_slot(p, r)
            if (cn%lossy) then
               cn%acc(s) = cn%acc(s) + cn%row_c(p, r)*cn%row_g(p, r)*cn%lam(r)
            else
               cn%acc(s) = cn%acc(s) + cn%row_g(p, r)*cn%lam(r)
            end if
         end do
      end do
      do s = 1, cn%nc
         cn%acc(s) = cn%afree(s) + cn%inv_j(s)*cn%acc(s)
      end do
      call exact_clusters(cn, .false.)                 ! exact accelerations per cluster
   end subroutine cn_solve

   !> Per exact cluster c, its reference value v_c from x = afree (per slot: the
   !> accelerations without constraints, or the speeds): 0 if locked, x of its
   !> held slot, else sum rho J x / sum rho^2 J (momentum); then rho v_c on
   !> every free slot of the cluster (ratio 1: the same value, bit for bit),
   !> into acc, or into w if `speeds`.
   subroutine exact_clusters(cn, speeds)
      type(constraint_set_t), intent(inout) :: cn
      logical, intent(in) :: speeds
      integer :: c, s
      real(wp) :: num, den
      do c = 1, cn%nc
         if (cn%cl(c) /= c .or. .not. cn%cl_exact(c)) cycle
         if (cn%cl_locked(c)) then
            num = 0.0_wp
         else if (cn%cl_ref(c) /= 0) then
            num = cn%afree(cn%cl_ref(c))
         else
            num = 0.0_wp
            den = 0.0_wp
            do s = 1, cn%nc
               if (cn%cl(s) /= c) cycle
               if (cn%lossy) then                       ! (weights f: D-97)
                  num = num + cn%rho(s)*cn%fw(s)*cn%jn(s)*cn%afree(s)
                  den = den + cn%rho(s)**2*cn%fw(s)*cn%jn(s)
               else
                  num = num + cn%rho(s)*cn%jn(s)*cn%afree(s)
                  den = den + cn%rho(s)**2*cn%jn(s)
               end if
            end do
            num = num/den
         end if
         do s = 1, cn%nc
            if (cn%cl(s) /= c .or. cn%inv_j(s) == 0.0_wp) cycle
            if (speeds) then
               cn%w(s) = cn%rho(s)*num
            else
               cn%acc(s) = cn%rho(s)*num
            end if
         end do
      end do
   end subroutine exact_clusters

   !> lam = (G M^-1 G^T)^-1 b over the kept rows (dropped rows: lam = 0), by the factor
   !> in cn%chol: its Cholesky factor L (L L^T); for a lossy set (G M^-1 H^T, not
   !> symmetric) `factor_lu`'s unit lower L and upper U (L U).
   subroutine chol_solve(cn)
      type(constraint_set_t), intent(inout) :: cn
      integer :: r, k
      real(wp) :: s
      associate (x => cn%lam, b => cn%b, a => cn%chol)
         do r = 1, cn%m
            x(r) = 0.0_wp
            if (.not. cn%keep(r)) cycle
            s = b(r)
            do k = 1, r - 1
               if (cn%keep(k)) s = s - a(r, k)*x(k)
            end do
            if (.not. cn%lossy) s = s/a(r, r)
            x(r) = s
         end do
         do r = cn%m, 1, -1
            if (.not. cn%keep(r)) cycle
            s = x(r)
            if (cn%lossy) then       ! U's row r
               do k = r + 1, cn%m
                  if (cn%keep(k)) s = s - a(r, k)*x(k)
               end do
            else                     ! L^T's row r: L's column r
               do k = r + 1, cn%m
                  if (cn%keep(k)) s = s - a(k, r)*x(k)
               end do
            end if
            x(r) = s/a(r, r)
         end do
      end associate
   end subroutine chol_solve

   !> Speeds cn%w (per slot) made to satisfy the constraints: per exact cluster its
   !> held reference's times rho (locked: 0), a free cluster its momentum-
   !> conserving common speed (sum rho J w / sum rho^2 J) times rho; any other
   !> cluster by the projection w + M^-1 G^T mu, G M^-1 G^T mu = -G w.
   subroutine cn_project(cn)
      type(constraint_set_t), intent(inout) :: cn
      integer :: r, p, s
      if (cn%m == 0) return
      cn%afree(1:cn%nc) = cn%w(1:cn%nc)
      do r = 1, cn%m
         cn%b(r) = 0.0_wp
         do p = 1, cn%row_np(r)
            cn%b(r) = cn%b(r) - cn%row_g(p, r)*cn%w(cn%row_slot(p, r))
         end do
      end do
      call chol_solve(cn)
      do r = 1, cn%m
         do p = 1, cn%row_np(r)
            s = cn%row_slot(p, r)
            cn%w(s) = cn%w(s) + cn%inv_j(s)*cn%row_c(p, r)*cn%row_g(p, r)*cn%lam(r)
         end do
      end do
      call exact_clusters(cn, .true.)                  ! (afree holds the speeds before)
      cn%lam(1:cn%m) = 0.0_wp
   end subroutine cn_project
end module trainsim_constraints
