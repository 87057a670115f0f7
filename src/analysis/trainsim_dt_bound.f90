!> RK4's stability region along rays from the origin, and an O(n) bound on the
!> eigenvalues of the linearised train: the RK4 step advice of a train above
!> `dense_state_limit` states, and the quick check before any eigenvalue
!> problem (D-64).
!>
!> Power iteration on the absolute values of the symmetrically scaled
!> stiffness B = M^-1/2 K M^-1/2 bounds its spectrum from above at every step
!> (Collatz-Wielandt: for any positive x, rho(|B|) <= max_i (|B| x)_i / x_i;
!> the best iterate is kept): mu_K >= omega_max^2, and on a train without
!> loops |B| is a signature similarity of B, so mu_K tends to omega_max^2
!> itself; likewise mu_C for the damping. When the node blocks and the
!> elements' K and C are symmetric (no motor), an eigenvalue satisfies
!> lambda^2 + c lambda + k = 0 with 0 <= k <= mu_K, |c| <= mu_C (Rayleigh
!> quotients): the complex ones lie in {|lambda| <= sqrt(mu_K), |Re lambda|
!> <= mu_C/2}, the real ones on [-r, 0], r <= mu_C shortened by a signed
!> Gershgorin bound (`real_extent`), and the step is RK4's radius ray by ray
!> over that region (2 sqrt 2 / sqrt(mu_K) undamped). Otherwise the weighted
!> infinity norm of the whole first-order system bounds |lambda|, against
!> RK4's least radius over the left half-plane.
module trainsim_dt_bound
   use trainsim_kinds, only: wp, two_pi
   use trainsim_model, only: model_t
   use trainsim_element, only: lin_state_t
   implicit none
   private

   public :: rk4_ray_radius, rk4_min_radius, rk4_dt_bound, rk4_dt_bounds, inverse_inertias

   !> Rays of RK4's region tabulated from the positive imaginary axis (psi = 0)
   !> to the negative real axis (psi = 90 deg): 0.5 deg apart.
   integer, parameter :: n_ray = 180
   !> A bound on |dr/dpsi| of RK4's radius (2.12 per radian at most, measured
   !> on 3601 rays): between two tabulated rays r is above the smaller of the
   !> two less radius_slope times half the spacing (0.37 % at most).
   real(wp), parameter :: radius_slope = 2.5_wp
   !> Power-iteration steps: each gives an upper bound; the best is kept.
   integer, parameter :: n_power = 8
   !> Quarter octaves of beta below mu_C in the real-eigenvalue bound (down to mu_C/2^6).
   integer, parameter :: n_beta = 24
   !> Floor of a weight after normalisation (a weight must stay positive).
   real(wp), parameter :: weight_floor = 1.0e-12_wp

contains

   !> Inverse inertia of every node (0 for fixed and prescribed-speed nodes).
   subroutine inverse_inertias(model, inv_j)
      type(model_t), intent(in) :: model
      real(wp), allocatable, intent(out) :: inv_j(:)
      integer :: i
      allocate (inv_j(size(model%nodes)))
      inv_j = 0.0_wp
      do i = 1, size(model%nodes)
         if (model%is_held(i) .or. model%nodes(i)%n%is_fixed()) cycle
         if (model%nodes(i)%n%inertia() > 0.0_wp) inv_j(i) = 1.0_wp/model%nodes(i)%n%inertia()
      end do
   end subroutine inverse_inertias

   !> |R(z)|^2 - 1 for RK4's amplification factor R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24.
   pure real(wp) function rk4_growth(z) result(g)
      complex(wp), intent(in) :: z
      g = abs(1.0_wp + z*(1.0_wp + z*(0.5_wp + z*(1.0_wp/6.0_wp + z/24.0_wp))))**2 - 1.0_wp
   end function rk4_growth

   !> Radius of RK4's stability region along the ray z = r d, |d| = 1, Re d <= 0:
   !> the first r > 0 where |R(r d)| = 1 (2 sqrt 2 on the imaginary axis, 2.785
   !> on the negative real axis). Stepped to a bracket, then bisected. `from`: the
   !> first step (of 0.01) to try, where every step below it is known inside the
   !> region (250 for a ray into the closed left half-plane: its least radius is
   !> 2.6156), so that the same bracket is found with fewer steps.
   pure real(wp) function rk4_ray_radius(d, from) result(r)
      complex(wp), intent(in) :: d
      integer, intent(in), optional :: from
      real(wp) :: lo, hi, mid
      integer :: i, i0
      i0 = 1
      if (present(from)) i0 = from
      lo = 0.0_wp
      if (i0 > 1) lo = 0.01_wp*(i0 - 1)
      hi = 0.0_wp
      do i = i0, 400
         hi = 0.01_wp*i
         if (rk4_growth(hi*d) > 0.0_wp) exit
         lo = hi
      end do
      do i = 1, 60
         mid = 0.5_wp*(lo + hi)
         if (rk4_growth(mid*d) > 0.0_wp) then
            hi = mid
         else
            lo = mid
         end if
      end do
      r = lo
   end function rk4_ray_radius

   !> RK4's radius along the tabulated rays, psi_k = k/2 deg from the imaginary
   !> axis (the region is symmetric about the real axis). Computed once per
   !> process (about 16 million instructions) and kept.
   function rk4_radii() result(r)
      real(wp) :: r(0:n_ray)
      real(wp), save :: kept(0:n_ray) = -1.0_wp
      logical, save :: ready = .false.
      real(wp) :: psi
      integer :: k
      if (ready) then
         r = kept
         return
      end if
      do k = 0, n_ray
         psi = 0.25_wp*two_pi*real(k, wp)/n_ray
         r(k) = rk4_ray_radius(cmplx(-sin(psi), cos(psi), wp), from=250)   ! (test_stability: the same radii)
      end do
      kept = r
      ready = .true.   ! the same values from any thread: a race here is benign
   end function rk4_radii

   !> A lower bound on RK4's radius over the closed left half-plane (2.6156 at
   !> 32.75 deg from the imaginary axis; the tabulated minimum less the slope margin).
   real(wp) function rk4_min_radius() result(r)
      real(wp) :: rr(0:n_ray)
      rr = rk4_radii()
      r = minval(rr) - radius_slope*0.125_wp*two_pi/n_ray
   end function rk4_min_radius

   !> O(n) step bound of the train linearised in `state` at y (D-64):
   !> RK4 is stable for every h <= dt_max, and |lambda| <= bound for every
   !> eigenvalue of the first-order system over the physical states. `omega_k`
   !> (>= the highest undamped circular frequency) is sqrt of the stiffness
   !> bound; `freq_hz` the imaginary part of the point of the bounding region
   !> that limits the step, / 2 pi. Nodes write their derivatives into their
   !> own states only, and a node's angle feeds none of its own rates but its
   !> angle's (`node_t` contract).
   subroutine rk4_dt_bound(model, state, y, dt_max, bound, omega_k, freq_hz)
      type(model_t), intent(inout) :: model
      type(lin_state_t), intent(in) :: state
      real(wp), intent(in) :: y(:)
      real(wp), intent(out) :: dt_max, bound
      real(wp), intent(out), optional :: omega_k, freq_hz
      real(wp) :: dt1(1), bd1(1), om1(1), f1(1)
      call rk4_dt_bounds(model, [state], y, dt1, bd1, om1, f1)
      dt_max = dt1(1)
      bound = bd1(1)
      if (present(omega_k)) omega_k = om1(1)
      if (present(freq_hz)) freq_hz = f1(1)
   end subroutine rk4_dt_bound

   !> `rk4_dt_bound` for each of `states` at the same y: the node blocks once, and
   !> the iterations only for a state whose element blocks differ from the last
   !> state's (a train without contacts or gears is the same train in every state:
   !> its bound once, D-139).
   subroutine rk4_dt_bounds(model, states, y, dt_max, bound, omega_k, freq_hz)
      type(model_t), intent(inout) :: model
      type(lin_state_t), intent(in) :: states(:)
      real(wp), intent(in) :: y(:)
      real(wp), intent(out) :: dt_max(:), bound(:), omega_k(:), freq_hz(:)
      real(wp), allocatable :: inv_j(:), p(:), own(:), tq(:), bk(:, :, :), bc(:, :, :), bk0(:, :, :), bc0(:, :, :)
      integer, allocatable :: ends(:, :)
      logical, allocatable :: has(:)
      logical :: general_nodes, general, general0
      integer :: s

      call node_blocks(model, y, p, own, tq, has, general_nodes)
      call inverse_inertias(model, inv_j)
      general0 = .false.
      do s = 1, size(states)
         general = general_nodes
         call element_blocks(model, states(s), inv_j, p, bk, bc, ends, general)
         if (s > 1) then
            if ((general .eqv. general0) .and. same_flat(size(bk), bk, bk0) .and. same_flat(size(bc), bc, bc0)) then
               dt_max(s) = dt_max(s - 1)
               bound(s) = bound(s - 1)
               omega_k(s) = omega_k(s - 1)
               freq_hz(s) = freq_hz(s - 1)
               cycle
            end if
         end if
         call bound_of_blocks(model, p, own, tq, has, general, bk, bc, ends, dt_max(s), bound(s), &
                              omega_k(s), freq_hz(s))
         call move_alloc(bk, bk0)
         call move_alloc(bc, bc0)
         general0 = general
      end do
   contains
      !> a and b hold the same n doubles, bit for bit (a NaN is never the same).
      !> (One pass that stops at the first difference, not two whole-array
      !> comparisons: 9 M instructions at 20 000 elements, startup8b.)
      pure logical function same_flat(n, a, b) result(yes)
         integer, intent(in) :: n
         real(wp), intent(in) :: a(n), b(n)
         integer :: i
         yes = .false.
         do i = 1, n
            if (.not. a(i) == b(i)) return
            if (a(i) == 0.0_wp) then   ! 0 and -0
               if (sign(1.0_wp, a(i)) /= sign(1.0_wp, b(i))) return
            end if
         end do
         yes = .true.
      end function same_flat
   end subroutine rk4_dt_bounds

   !> The bound of `rk4_dt_bound` from the node blocks (p, own, tq, has) and the
   !> element blocks (bk, bc on ends) of one state.
   subroutine bound_of_blocks(model, p, own, tq, states, general, bk, bc, ends, dt_max, bound, omega_k, freq_hz)
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: p(:), own(:), tq(:)
      real(wp), intent(in), contiguous :: bk(:, :, :), bc(:, :, :)
      logical, intent(in) :: states(:), general
      integer, intent(in), contiguous :: ends(:, :)
      real(wp), intent(out) :: dt_max, bound, omega_k, freq_hz
      real(wp), allocatable :: x(:), zk(:), zc(:), d(:), xk(:)
      real(wp) :: mu_k, mu_c, s_star, f_lim
      integer :: it

      ! stiffness: power iteration on |B|, each iterate an upper bound of mu_K;
      ! with a node block or element that is not symmetric, also of the
      ! general weighted norm s* (the same weights on every state of a node)
      allocate (x(size(p)), zk(size(p)), zc(size(p)))
      x = merge(1.0_wp, 0.0_wp, states)
      mu_k = huge(1.0_wp)
      s_star = huge(1.0_wp)
      do it = 0, n_power
         call abs_product(bk, ends, x, zk)
         mu_k = min(mu_k, max_ratio(zk, x))
         if (general) then
            call abs_product(bc, ends, x, zc)
            s_star = min(s_star, general_bound(zk, zc, x))
         end if
         call normalise(zk, x)
      end do
      xk = x
      ! damping (element C scaled like K, plus each node's own speed row)
      d = own_speed()
      x = merge(1.0_wp, 0.0_wp, states)
      mu_c = huge(1.0_wp)
      do it = 0, n_power
         call abs_product(bc, ends, x, zc)
         zc = zc + d*x
         mu_c = min(mu_c, max_ratio(zc, x))
         if (.not. mu_c > 0.0_wp) exit       ! undamped
         call normalise(zc, x)
      end do
      omega_k = sqrt(mu_k)

      dt_max = huge(1.0_wp)
      f_lim = 0.0_wp
      if (general) then
         ! any direction in the left half-plane, |lambda| <= s*
         bound = s_star
         if (s_star > 0.0_wp) dt_max = rk4_min_radius()/s_star
         f_lim = s_star
      else
         ! complex lambda: |lambda| = sqrt(k) <= sqrt(mu_K); real: |lambda| <= c <= mu_C
         bound = max(sqrt(mu_k), mu_c)
         call region_step(mu_k, mu_c, real_extent(), dt_max, f_lim)
      end if
      freq_hz = f_lim/two_pi

   contains

      !> A real eigenvalue -r has r^2 - c r + k = 0 (k = r (c - r), c <= mu_C).
      !> With g >= the largest eigenvalue of beta C - B, beta c - k <= g, so r > beta
      !> needs r^2 - mu_C r + mu_C beta - g <= 0: r is below that root, or beta.
      !> A stiff element that is also damped (a mesh with impact damping) thus
      !> keeps its overdamped range short. The least over beta = mu_C 2^(-j/4).
      real(wp) function real_extent() result(r)
         real(wp) :: beta(n_beta), g(n_beta), disc, r_beta
         integer :: j
         r = mu_c
         if (.not. mu_c > 0.0_wp) return
         do j = 1, n_beta
            beta(j) = mu_c*2.0_wp**(-0.25_wp*j)
         end do
         call signed_gershgorin(bk, bc, d, ends, xk, states, beta, g)
         do j = 1, n_beta
            disc = mu_c*mu_c - 4.0_wp*(mu_c*beta(j) - g(j))
            r_beta = beta(j)
            if (disc >= 0.0_wp) r_beta = max(beta(j), 0.5_wp*(mu_c + sqrt(disc)))
            r = min(r, r_beta)
         end do
      end function real_extent

      !> Each node's |d(speed rate)/d(speed)|: the diagonal of the damping.
      function own_speed() result(ds)
         real(wp) :: ds(size(p))
         integer :: i
         ds = 0.0_wp
         do i = 1, size(p)
            if (states(i)) ds(i) = own(model%nodes(i)%n%offset + 2)
         end do
      end function own_speed

      !> The weighted norm over every state (angle weight x_i sqrt(tq_i) / s,
      !> the node's other states x_i sqrt(tq_i)) at its best scale s: every
      !> row sum is a/s + b, below s for s >= (b + sqrt(b^2 + 4a))/2.
      real(wp) function general_bound(zk_, zc_, w) result(s)
         real(wp), intent(in) :: zk_(:), zc_(:), w(:)
         real(wp) :: a, b, ratio
         integer :: i, r, o, ns
         s = 0.0_wp
         do i = 1, size(w)
            if (.not. states(i)) cycle
            o = model%nodes(i)%n%offset
            ns = model%nodes(i)%n%nstates()
            do r = 2, ns
               ! the torque reaches state r in proportion tq(o + r)/tq(o + 2)
               ratio = 0.0_wp
               if (tq(o + 2) > 0.0_wp) ratio = tq(o + r)/tq(o + 2)
               a = ratio*zk_(i)/w(i)
               b = ratio*zc_(i)/w(i) + own(o + r)
               s = max(s, 0.5_wp*(b + sqrt(b*b + 4.0_wp*a)))
            end do
         end do
      end function general_bound

      !> max_i z_i / w_i over the nodes with states (Collatz-Wielandt).
      real(wp) function max_ratio(z, w) result(m)
         real(wp), intent(in), contiguous :: z(:), w(:)
         integer :: i
         m = 0.0_wp
         do i = 1, size(w)
            if (states(i)) m = max(m, z(i)/w(i))
         end do
      end function max_ratio

      !> The next weights: z / max z, kept positive.
      subroutine normalise(z, w)
         real(wp), intent(in), contiguous :: z(:)
         real(wp), intent(inout), contiguous :: w(:)
         real(wp) :: big
         integer :: i
         big = -huge(1.0_wp)   ! (maxval(z, mask=states) and a where, as loops: the same values)
         do i = 1, size(z)
            if (states(i) .and. z(i) > big) big = z(i)
         end do
         if (.not. big > 0.0_wp) return
         do i = 1, size(w)
            if (states(i)) w(i) = max(z(i)/big, weight_floor)
         end do
      end subroutine normalise
   end subroutine bound_of_blocks

   !> RK4's largest step for eigenvalues in {|lambda| <= sqrt(mu_k), |Re lambda|
   !> <= mu_c/2} and on [-r_real, 0]: the least, over the tabulated rays, of the
   !> radius over the region's extent; f_lim the imaginary part of the limiting point.
   subroutine region_step(mu_k, mu_c, r_real, dt_max, f_lim)
      real(wp), intent(in) :: mu_k, mu_c, r_real
      real(wp), intent(out) :: dt_max, f_lim
      real(wp) :: rr(0:n_ray), dpsi, psi, ext, r_lo, h
      integer :: k
      rr = rk4_radii()
      dpsi = 0.25_wp*two_pi/n_ray
      dt_max = huge(1.0_wp)
      f_lim = 0.0_wp
      do k = 0, n_ray - 1
         ! the region's extent along the rays of [psi_k, psi_k+1] is largest at psi_k
         psi = dpsi*k
         ext = sqrt(mu_k)
         if (k > 0) ext = min(ext, 0.5_wp*mu_c/sin(psi))
         if (.not. ext > 0.0_wp) cycle
         r_lo = min(rr(k), rr(k + 1)) - radius_slope*0.5_wp*dpsi
         h = r_lo/ext
         if (h < dt_max) then
            dt_max = h
            f_lim = ext*cos(psi)
         end if
      end do
      if (r_real > 0.0_wp) then
         if (rr(n_ray)/r_real < dt_max) then
            dt_max = rr(n_ray)/r_real
            f_lim = 0.0_wp
         end if
      end if
   end subroutine region_step

   !> Each node's own block, by differences of `derivatives` (only its own
   !> states are written and read back): p = sqrt(d(speed rate)/d(torque)),
   !> tq(o + r) = |d(rate of state r)/d(torque)|, own(o + r) = the row sum of
   !> |d(rate of state r)/d(state k)| over its states k >= 2. `general`: a node
   !> with more than angle and speed (its block is not symmetric).
   subroutine node_blocks(model, y, p, own, tq, states, general)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:)
      real(wp), allocatable, intent(out) :: p(:), own(:), tq(:)
      logical, allocatable, intent(out) :: states(:)
      logical, intent(out) :: general
      real(wp), allocatable :: f0(:), f1(:), yp(:)
      real(wp) :: t0, h
      integer :: i, k, r, o, ns
      t0 = model%run%t_start
      allocate (p(size(model%nodes)), states(size(model%nodes)))
      allocate (own(size(y)), tq(size(y)), f0(size(y)), f1(size(y)))
      p = 0.0_wp
      states = .false.
      general = .false.
      yp = y
      do i = 1, size(model%nodes)
         if (model%is_held(i)) cycle
         associate (nd => model%nodes(i)%n)
            ns = nd%nstates()
            if (ns < 2) cycle
            o = nd%offset
            states(i) = .true.
            if (ns > 2) general = .true.
            f0(o + 1:o + ns) = 0.0_wp
            f1(o + 1:o + ns) = 0.0_wp
            call nd%derivatives(t0, y, 0.0_wp, f0)
            call nd%derivatives(t0, y, 1.0_wp, f1)
            tq(o + 1:o + ns) = abs(f1(o + 1:o + ns) - f0(o + 1:o + ns))
            p(i) = sqrt(tq(o + 2))
            own(o + 1:o + ns) = 0.0_wp
            do k = 2, ns                       ! the angle column feeds nothing of the node's own
               h = 1.0e-6_wp*max(1.0_wp, abs(y(o + k)))
               yp(o + k) = y(o + k) + h
               f1(o + 1:o + ns) = 0.0_wp
               call nd%derivatives(t0, yp, 0.0_wp, f1)
               yp(o + k) = y(o + k)
               do r = 2, ns
                  own(o + r) = own(o + r) + abs(f1(o + r) - f0(o + r))/h
               end do
            end do
         end associate
      end do
   end subroutine node_blocks

   !> Every element's K and C scaled by p on both sides (p_a K_ab p_b),
   !> and its end nodes. `general` is set by a K or C that is not symmetric, or
   !> a K that is not positive semi-definite (the Rayleigh quotient k >= 0).
   subroutine element_blocks(model, state, inv_j, p, bk, bc, ends, general)
      type(model_t), intent(inout) :: model
      type(lin_state_t), intent(in) :: state
      real(wp), intent(in) :: inv_j(:), p(:)
      real(wp), allocatable, intent(out) :: bk(:, :, :), bc(:, :, :)
      integer, allocatable, intent(out) :: ends(:, :)
      logical, intent(inout) :: general
      real(wp) :: ke(2, 2), ce(2, 2)
      integer :: j, a, b
      allocate (bk(2, 2, size(model%elements)), bc(2, 2, size(model%elements)), ends(2, size(model%elements)))
      do j = 1, size(model%elements)
         associate (e => model%elements(j)%e)
            call e%linearise(state, inv_j(e%left), inv_j(e%right), ke, ce)
            ends(:, j) = [e%left, e%right]
         end associate
         if (.not. (symmetric(ke) .and. symmetric(ce) .and. semidefinite(ke))) general = .true.
         do b = 1, 2
            do a = 1, 2
               bk(a, b, j) = p(ends(a, j))*ke(a, b)*p(ends(b, j))
               bc(a, b, j) = p(ends(a, j))*ce(a, b)*p(ends(b, j))
            end do
         end do
      end do
   contains
      pure logical function symmetric(m)
         real(wp), intent(in) :: m(2, 2)
         symmetric = abs(m(1, 2) - m(2, 1)) <= 1.0e-12_wp*(abs(m(1, 2)) + abs(m(2, 1)))
      end function symmetric
      pure logical function semidefinite(m)
         real(wp), intent(in) :: m(2, 2)
         semidefinite = m(1, 1) >= 0.0_wp .and. m(2, 2) >= 0.0_wp .and. &
                        m(1, 1)*m(2, 2) - m(1, 2)*m(2, 1) >= -1.0e-12_wp*m(1, 1)*m(2, 2)
      end function semidefinite
   end subroutine element_blocks

   !> An upper bound g(k) of the largest eigenvalue of beta(k) C - B (C with the nodes'
   !> own speed damping d on its diagonal) for each beta(k): Gershgorin's discs of
   !> W^-1 (beta C - B) W, W = diag(w) > 0, centred on the signed diagonal. Every beta
   !> in one pass over the elements (the same sums in the same order as one pass per
   !> beta: 24 passes and their arrays were 15 M instructions at 20 000 nodes, startup8b).
   pure subroutine signed_gershgorin(bk, bc, d, ends, w, states, beta, g)
      real(wp), intent(in), contiguous :: bk(:, :, :), bc(:, :, :), d(:), w(:)
      real(wp), intent(in) :: beta(:)
      integer, intent(in), contiguous :: ends(:, :)
      logical, intent(in) :: states(:)
      real(wp), intent(out) :: g(:)
      real(wp), allocatable :: diag(:, :), radius(:, :)
      integer :: j, a, b, k, nb
      nb = size(beta)
      allocate (diag(nb, size(w)), radius(nb, size(w)))
      do j = 1, size(w)
         diag(:, j) = beta*d(j)
      end do
      radius = 0.0_wp
      do j = 1, size(ends, 2)
         a = ends(1, j)
         b = ends(2, j)
         if (a == b) then
            do k = 1, nb
               diag(k, a) = diag(k, a) + sum(beta(k)*bc(:, :, j) - bk(:, :, j))
            end do
            cycle
         end if
         do k = 1, nb
            diag(k, a) = diag(k, a) + beta(k)*bc(1, 1, j) - bk(1, 1, j)
            diag(k, b) = diag(k, b) + beta(k)*bc(2, 2, j) - bk(2, 2, j)
            radius(k, a) = radius(k, a) + abs(beta(k)*bc(1, 2, j) - bk(1, 2, j))*w(b)
            radius(k, b) = radius(k, b) + abs(beta(k)*bc(2, 1, j) - bk(2, 1, j))*w(a)
         end do
      end do
      g = -huge(1.0_wp)
      do j = 1, size(w)
         if (states(j)) g = max(g, diag(:, j) + radius(:, j)/w(j))
      end do
   end subroutine signed_gershgorin

   !> z = |B| w summed element by element (B held as 2 x 2 blocks on `ends`;
   !> the absolute value of each block's entries).
   pure subroutine abs_product(b, ends, w, z)
      real(wp), intent(in), contiguous :: b(:, :, :), w(:)
      integer, intent(in), contiguous :: ends(:, :)
      real(wp), intent(out), contiguous :: z(:)
      integer :: j, l, r
      z = 0.0_wp
      do j = 1, size(ends, 2)
         l = ends(1, j)
         r = ends(2, j)
         z(l) = z(l) + abs(b(1, 1, j))*w(l) + abs(b(1, 2, j))*w(r)
         z(r) = z(r) + abs(b(2, 1, j))*w(l) + abs(b(2, 2, j))*w(r)
      end do
   end subroutine abs_product
end module trainsim_dt_bound
