!> The RK4 step's derivatives for the variational pass (trainsim_monodromy):
!> its partials in its length and start time (exact_step), J Phi over J's
!> nonzeros, and the tangent map S of a step in a mode whose Jacobian J is
!> constant between events (D-162). Plain loops over explicit shapes.
module trainsim_step_tangent
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   implicit none
   private

   public :: step_partials, nonzeros, split_pattern, gather, sparse_product, dense_product, tangent_map

contains

   !> The RK4 step map R(t, x, l)'s partials in its length l and its start
   !> time t at (t, x, hs), through its stages: dk/dl and dk/dt from the
   !> model's Jacobian at each stage and df/dt (central differences in t:
   !> 0 exactly for a model whose RHS does not read t).
   subroutine step_partials(model, t, hs, x, jac, rl, rt)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, hs, x(:)
      real(wp), intent(inout) :: jac(:, :)   !< scratch: the model's Jacobian
      real(wp), intent(out) :: rl(:), rt(:)
      real(wp), dimension(size(x)) :: k1, k2, k3, k4, l2, l3, l4, d2, d3, d4, f1
      call model%rhs(t, x, k1)
      f1 = f_t(t, x)
      call model%rhs(t + 0.5_wp*hs, x + 0.5_wp*hs*k1, k2)
      call model%jacobian(t + 0.5_wp*hs, x + 0.5_wp*hs*k1, jac)
      l2 = 0.5_wp*f_t(t + 0.5_wp*hs, x + 0.5_wp*hs*k1)
      d2 = 2.0_wp*l2 + jv(jac, 0.5_wp*hs*f1)
      l2 = l2 + jv(jac, 0.5_wp*k1)
      call model%rhs(t + 0.5_wp*hs, x + 0.5_wp*hs*k2, k3)
      call model%jacobian(t + 0.5_wp*hs, x + 0.5_wp*hs*k2, jac)
      l3 = 0.5_wp*f_t(t + 0.5_wp*hs, x + 0.5_wp*hs*k2)
      d3 = 2.0_wp*l3 + jv(jac, 0.5_wp*hs*d2)
      l3 = l3 + jv(jac, 0.5_wp*k2 + 0.5_wp*hs*l2)
      call model%rhs(t + hs, x + hs*k3, k4)
      call model%jacobian(t + hs, x + hs*k3, jac)
      l4 = f_t(t + hs, x + hs*k3)
      d4 = l4 + jv(jac, hs*d3)
      l4 = l4 + jv(jac, k3 + hs*l3)
      rl = (k1 + 2.0_wp*(k2 + k3) + k4)/6.0_wp + hs/6.0_wp*(2.0_wp*(l2 + l3) + l4)
      rt = hs/6.0_wp*(f1 + 2.0_wp*(d2 + d3) + d4)
   contains
      !> a v (gfortran 12 -O2 warns of an inline matmul on an expression's temporary)
      pure function jv(a, v) result(r)
         real(wp), intent(in) :: a(:, :), v(:)
         real(wp) :: r(size(a, 1))
         r = matmul(a, v)
      end function jv

      function f_t(ts, xs) result(ft)
         real(wp), intent(in) :: ts, xs(:)
         real(wp) :: ft(size(xs)), fp(size(xs)), fm(size(xs)), dt
         dt = 1.0e-6_wp*max(abs(ts), abs(hs), 1.0e-9_wp)
         call model%rhs(ts + dt, xs, fp)
         call model%rhs(ts - dt, xs, fm)
         ft = (fp - fm)/(2.0_wp*dt)
      end function f_t
   end subroutine step_partials

   !> The nonzeros of jac(1:n, 1:n) by rows (row i's in jv(rs(i) : rs(i+1) - 1),
   !> their columns jc in increasing order; explicit shapes: plain loops without
   !> the descriptors of the pass's components).
   pure subroutine nonzeros(n, ny, jac, rs, jc, jv)
      integer, intent(in) :: n, ny
      real(wp), intent(in) :: jac(ny, ny)
      integer, intent(out) :: rs(n + 1), jc(n*n)
      real(wp), intent(out) :: jv(n*n)
      integer :: i, k, nz
      nz = 0
      do i = 1, n
         rs(i) = nz + 1
         do k = 1, n
            if (jac(i, k) == 0.0_wp) cycle
            nz = nz + 1
            jc(nz) = k
            jv(nz) = jac(i, k)
         end do
      end do
      rs(n + 1) = nz + 1
   end subroutine nonzeros

   !> The places of J(1:n, 1:n)'s nonzeros in a mode with a split Jacobian (D-170):
   !> the constant part ja's and the varying elements' entries (sc rows 2-4: row, the
   !> columns of an angle and a speed), by rows as `nonzeros` lists them (D-186).
   pure subroutine split_pattern(n, ny, ja, sc, nsc, rs, jc)
      integer, intent(in) :: n, ny, nsc, sc(8, *)
      real(wp), intent(in) :: ja(ny, ny)
      integer, intent(out) :: rs(n + 1), jc(n*n)
      logical :: used(n, n)
      integer :: i, k, l, nz
      used = ja(1:n, 1:n) /= 0.0_wp
      do l = 1, nsc
         if (sc(2, l) > n) cycle
         if (sc(3, l) <= n) used(sc(2, l), sc(3, l)) = .true.
         if (sc(4, l) <= n) used(sc(2, l), sc(4, l)) = .true.
      end do
      nz = 0
      do i = 1, n
         rs(i) = nz + 1
         do k = 1, n
            if (.not. used(i, k)) cycle
            nz = nz + 1
            jc(nz) = k
         end do
      end do
      rs(n + 1) = nz + 1
   end subroutine split_pattern

   !> J's values at the places of a pattern (`split_pattern`): an entry that is
   !> zero at this stage is kept, and adds +0 to a sum that is never -0, so
   !> `sparse_product` gives what it gives over `nonzeros` (D-186).
   pure subroutine gather(n, ny, jac, rs, jc, jv)
      integer, intent(in) :: n, ny, rs(n + 1), jc(*)
      real(wp), intent(in) :: jac(ny, ny)
      real(wp), intent(out) :: jv(*)
      integer :: i, l
      do i = 1, n
         do l = rs(i), rs(i + 1) - 1
            jv(l) = jac(i, jc(l))
         end do
      end do
   end subroutine gather

   !> dphi = J phi from J's nonzeros by rows (`nonzeros`): each entry summed
   !> over k in increasing order from 0, as matmul does, in a register (D-170:
   !> the values of the column-order scatter it replaces, bit for bit).
   pure subroutine sparse_product(n, rs, jc, jv, phi, dphi)
      integer, intent(in) :: n, rs(n + 1), jc(*)
      real(wp), intent(in) :: jv(*), phi(n, n)
      real(wp), intent(out) :: dphi(n, n)
      integer :: i, j, l
      real(wp) :: acc
      do j = 1, n
         do i = 1, n
            acc = 0.0_wp
            do l = rs(i), rs(i + 1) - 1
               acc = acc + jv(l)*phi(jc(l), j)
            end do
            dphi(i, j) = acc
         end do
      end do
   end subroutine sparse_product

   !> c = a b (n x n), each entry summed over k in order.
   pure subroutine dense_product(n, a, b, c)
      integer, intent(in) :: n
      real(wp), intent(in) :: a(n, n), b(n, n)
      real(wp), intent(out) :: c(n, n)
      integer :: i, j, k
      c = 0.0_wp
      do j = 1, n
         do k = 1, n
            if (b(k, j) == 0.0_wp) cycle
            do i = 1, n
               c(i, j) = c(i, j) + a(i, k)*b(k, j)
            end do
         end do
      end do
   end subroutine dense_product

   !> The variational RK4 step of Phi = I with the constant J over hs:
   !> S = I + hs/6 (P1 + 2 P2 + 2 P3 + P4), P1 = J, P2 = J (I + hs/2 P1),
   !> P3 = J (I + hs/2 P2), P4 = J (I + hs P3) = I + hJ + ... + (hJ)^4/24.
   pure subroutine tangent_map(n, j, hs, s)
      integer, intent(in) :: n
      real(wp), intent(in) :: j(n, n), hs
      real(wp), intent(out) :: s(n, n)
      real(wp), dimension(n, n) :: p1, p2, p3, p4, e
      integer :: k
      e = 0.0_wp
      do k = 1, n
         e(k, k) = 1.0_wp
      end do
      p1 = j
      call dense_product(n, j, e + 0.5_wp*hs*p1, p2)
      call dense_product(n, j, e + 0.5_wp*hs*p2, p3)
      call dense_product(n, j, e + hs*p3, p4)
      s = e + hs/6.0_wp*(p1 + 2.0_wp*(p2 + p3) + p4)
   end subroutine tangent_map
end module trainsim_step_tangent
