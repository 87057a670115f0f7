!> A banded linear solve for the sparse stiffness of a train (D-152): the
!> unknowns renumbered by reverse Cuthill-McKee (a breadth-first sweep from a node of
!> least degree, reversed; neighbours in element order, without the degree sort, which
!> a train's few branches hardly need) over the graph of the elements that join them (a
!> chain keeps bandwidth 1, a tree about its widest level), the matrix assembled in
!> LAPACK's band storage and solved by dgbsv (LU with partial pivoting inside the band),
!> O(n bw^2) instead of the dense O(n^3).
!>
!> A numbering as narrow as the reverse Cuthill-McKee one is kept (a chain in deck order):
!> LU with partial pivoting then meets the same pivots as the dense LU, and the band's
!> sums differ from the dense ones by exact zeros only.
!>
!> Use: `band_plan` once per pattern, then per matrix `band_zero`, `band_add` per
!> entry (in the unknowns' own numbering), `band_solve` (factors, solves, keeps nothing).
module trainsim_band_solve
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: band_plan_t, band_plan, band_zero, band_add, band_solve

   !> A numbering and bandwidth of n unknowns, and the band storage of one matrix.
   type :: band_plan_t
      integer :: n = 0
      integer :: kl = 0                  !< lower (= upper) bandwidth in the new numbering
      integer, allocatable :: new(:)     !< new(i): position of unknown i in the band
      real(wp), allocatable :: ab(:, :)  !< the matrix, LAPACK band storage (2 kl + kl + 1, n)
   end type band_plan_t

   interface
      subroutine dgbsv(n, kl, ku, nrhs, ab, ldab, ipiv, b, ldb, info)
         import :: wp
         integer, intent(in) :: n, kl, ku, nrhs, ldab, ldb
         real(wp), intent(inout) :: ab(ldab, *), b(ldb, *)
         integer, intent(out) :: ipiv(*), info
      end subroutine dgbsv
   end interface

contains

   !> The reverse Cuthill-McKee numbering of unknowns 1..n joined by the edges
   !> (ea(k), eb(k)) (an edge with an end 0 or both ends equal joins nothing), its
   !> bandwidth, and the band storage allocated. O(n + edges), and O(n) more for each part
   !> of the graph not joined to the others.
   subroutine band_plan(n, ea, eb, plan)
      integer, intent(in) :: n, ea(:), eb(:)
      type(band_plan_t), intent(out) :: plan
      integer, allocatable :: first(:), adj(:), deg(:), order(:), fill(:)
      logical, allocatable :: seen(:)
      integer :: k, i, head, tail, start, v, natural
      plan%n = n
      allocate (first(n + 1), deg(n), order(n), seen(n), plan%new(n))
      deg = 0
      do k = 1, size(ea)
         if (.not. joins(k)) cycle
         deg(ea(k)) = deg(ea(k)) + 1; deg(eb(k)) = deg(eb(k)) + 1
      end do
      first(1) = 1
      do i = 1, n
         first(i + 1) = first(i) + deg(i)
      end do
      allocate (adj(first(n + 1) - 1), fill(n))
      fill = first(1:n)
      do k = 1, size(ea)
         if (.not. joins(k)) cycle
         adj(fill(ea(k))) = eb(k); fill(ea(k)) = fill(ea(k)) + 1
         adj(fill(eb(k))) = ea(k); fill(eb(k)) = fill(eb(k)) + 1
      end do
      seen = .false.
      tail = 0
      do while (tail < n)   ! one breadth-first sweep per part, from a node of least degree
         start = minloc(deg, 1, mask=.not. seen)
         tail = tail + 1; order(tail) = start; seen(start) = .true.
         head = tail
         do while (head <= tail)
            v = order(head)
            do k = first(v), first(v + 1) - 1
               if (seen(adj(k))) cycle
               seen(adj(k)) = .true.
               tail = tail + 1; order(tail) = adj(k)
            end do
            head = head + 1
         end do
      end do
      do i = 1, n
         plan%new(order(i)) = n + 1 - i
      end do
      plan%kl = 0
      natural = 0
      do k = 1, size(ea)
         if (.not. joins(k)) cycle
         plan%kl = max(plan%kl, abs(plan%new(ea(k)) - plan%new(eb(k))))
         natural = max(natural, abs(ea(k) - eb(k)))
      end do
      if (natural <= plan%kl) then   ! the given numbering is as narrow: kept (a chain in order)
         plan%new = [(i, i=1, n)]
         plan%kl = natural
      end if
      allocate (plan%ab(3*plan%kl + 1, n))
   contains
      logical function joins(k)
         integer, intent(in) :: k
         joins = ea(k) > 0 .and. eb(k) > 0 .and. ea(k) /= eb(k)
      end function joins

   end subroutine band_plan

   !> Clear the plan's matrix.
   subroutine band_zero(plan)
      type(band_plan_t), intent(inout) :: plan
      plan%ab = 0.0_wp
   end subroutine band_zero

   !> A(i, j) += v (i, j in the unknowns' own numbering; they must be joined by an edge
   !> of the plan or equal).
   subroutine band_add(plan, i, j, v)
      type(band_plan_t), intent(inout) :: plan
      integer, intent(in) :: i, j
      real(wp), intent(in) :: v
      integer :: p, q
      p = plan%new(i); q = plan%new(j)
      plan%ab(2*plan%kl + 1 + p - q, q) = plan%ab(2*plan%kl + 1 + p - q, q) + v
   end subroutine band_add

   !> Solve A x = b for every column of b (in the unknowns' own numbering, x returned in
   !> b). The plan's matrix is overwritten by its factors. info as LAPACK's dgbsv
   !> (> 0: A is singular).
   subroutine band_solve(plan, b, info)
      type(band_plan_t), intent(inout) :: plan
      real(wp), intent(inout) :: b(:, :)
      integer, intent(out) :: info
      real(wp), allocatable :: x(:, :)
      integer, allocatable :: ipiv(:)
      integer :: i
      info = 0
      if (plan%n == 0) return
      allocate (x(plan%n, size(b, 2)), ipiv(plan%n))
      do i = 1, plan%n
         x(plan%new(i), :) = b(i, :)
      end do
      call dgbsv(plan%n, plan%kl, plan%kl, size(b, 2), plan%ab, size(plan%ab, 1), ipiv, x, plan%n, info)
      do i = 1, plan%n
         b(i, :) = x(plan%new(i), :)
      end do
   end subroutine band_solve
end module trainsim_band_solve
