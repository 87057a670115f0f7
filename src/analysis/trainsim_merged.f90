!> Merged coordinates of a train's kinematic constraint rows (D-81): the null
!> space of the rows over the free inertias (`null_space`, what `trainsim modes`
!> merges), and the projection of the first-order system onto it for the RK4
!> step advice (`rigid_projection`, D-86): nodes joined by an element that
!> is rigid in every mode (rigid_gear, rigid_join: con%rigid) move as one body,
!> so their joined inertia, not each node's own, sets the frequencies.
module trainsim_merged
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_numeric
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   implicit none
   private

   public :: null_space, rigid_projection

   interface
      subroutine dsyev(jobz, uplo, n, a, lda, w, work, lwork, info)
         import :: wp
         character(len=1), intent(in) :: jobz, uplo
         integer, intent(in) :: n, lda, lwork
         real(wp), intent(inout) :: a(lda, *)
         real(wp), intent(out) :: w(*), work(*)
         integer, intent(out) :: info
      end subroutine dsyev
   end interface

contains

   !> An orthonormal basis (n, nr) of the free inertias' motions that keep every
   !> constraint row in force (D-81: rigid gears and joins, elements stuck as the
   !> run starts; with `rigid_only` the rows of the rigid elements alone): the
   !> null space of G over the degrees of freedom (a held or fixed node's column
   !> is 0), from the eigenvectors of G^T G (eigenvalue below 1e-12 of the
   !> largest). No rows: the identity. n_rows: the rows counted.
   subroutine null_space(model, dof, n, basis, n_rows, err, rigid_only)
      type(model_t), intent(in) :: model
      integer, intent(in) :: dof(:), n
      real(wp), allocatable, intent(out) :: basis(:, :)
      integer, intent(out) :: n_rows
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: rigid_only
      real(wp), allocatable :: gtg(:, :), w(:), work(:), row(:)
      integer :: j, r, p, d, info, nr
      logical :: only_rigid
      only_rigid = .false.
      if (present(rigid_only)) only_rigid = rigid_only
      allocate (gtg(n, n), row(n), w(n), work(max(1, 3*n)))
      gtg = 0.0_wp
      n_rows = 0
      do j = 1, size(model%elements)
         associate (e => model%elements(j)%e)
            if (only_rigid .and. .not. e%con%rigid) cycle
            do r = 1, e%con%n
               row = 0.0_wp
               do p = 1, e%n_ports()
                  d = dof(e%port(p))
                  if (d > 0) row(d) = row(d) + e%con%g(r, p)
               end do
               n_rows = n_rows + 1
               gtg = gtg + spread(row, 2, n)*spread(row, 1, n)
            end do
         end associate
      end do
      if (n_rows == 0) then
         allocate (basis(n, n))
         basis = 0.0_wp
         do j = 1, n
            basis(j, j) = 1.0_wp
         end do
         return
      end if
      call dsyev('V', 'U', n, gtg, n, w, work, size(work), info)
      if (info /= 0) then
         call fatal_error(err, 'the eigenvalue solver (LAPACK dsyev) failed with info = '//str(info), err_numeric)
         return
      end if
      nr = count(w <= 1.0e-12_wp*max(maxval(abs(w)), tiny(1.0_wp)))   ! ascending: the first nr
      basis = gtg(:, 1:nr)
   end subroutine null_space

   !> The first-order system x' = A x restricted to the rigid elements' rows:
   !> x = tr z (each node's angle and speed from the merged coordinates q, q',
   !> x_node = B q; every other state as it is) and z' = lp A tr z, lp taking an
   !> angle or speed row through M_r^-1 B^T M (M the nodes' inertias, M_r = B^T M B:
   !> the constraint torques, along G^T, drop out, as in `compute_modes`). Not
   !> allocated when no rigid element constrains the free inertias.
   subroutine rigid_projection(model, lp, tr, err)
      type(model_t), intent(in) :: model
      real(wp), allocatable, intent(out) :: lp(:, :), tr(:, :)
      type(error_t), allocatable, intent(out) :: err
      integer, allocatable :: dof(:), node(:)
      real(wp), allocatable :: basis(:, :), mr(:, :), pr(:, :), jd(:)
      integer :: i, n, nr, n_rows, nz, k, o, c, s
      if (.not. any([(model%elements(i)%e%con%rigid, i=1, size(model%elements))])) return
      allocate (dof(size(model%nodes)), node(size(model%nodes)))
      dof = 0
      n = 0
      do i = 1, size(model%nodes)
         if (model%is_held(i) .or. model%nodes(i)%n%is_fixed()) cycle
         if (model%nodes(i)%n%nstates() < 2 .or. .not. model%nodes(i)%n%inertia() > 0.0_wp) cycle
         n = n + 1
         dof(i) = n
         node(n) = i
      end do
      if (n == 0) return
      call null_space(model, dof, n, basis, n_rows, err, rigid_only=.true.)
      if (allocated(err)) return
      nr = size(basis, 2)
      if (n_rows == 0 .or. nr == n) return
      allocate (jd(n))
      jd = [(model%nodes(node(k))%n%inertia(), k=1, n)]
      mr = matmul(transpose(basis), spread(jd, 2, nr)*basis)
      call invert_spd(mr, err); if (allocated(err)) return
      pr = matmul(mr, transpose(basis)*spread(jd, 1, nr))          ! M_r^-1 B^T M (nr, n)
      nz = model%n_states - 2*(n - nr)
      allocate (lp(nz, model%n_states), tr(model%n_states, nz))
      lp = 0.0_wp
      tr = 0.0_wp
      ! z: the merged angles (1:nr), the merged speeds (nr+1:2 nr), then every
      ! state that is not the angle or speed of a free inertia, in order
      do k = 1, n
         o = model%nodes(node(k))%n%offset
         do c = 1, nr
            tr(o + 1, c) = basis(k, c)
            tr(o + 2, nr + c) = basis(k, c)
            lp(c, o + 1) = pr(c, k)
            lp(nr + c, o + 2) = pr(c, k)
         end do
      end do
      s = 2*nr
      do i = 1, size(model%nodes)
         if (model%is_held(i)) cycle
         o = model%nodes(i)%n%offset
         do k = 1, model%nodes(i)%n%nstates()
            if (dof(i) > 0 .and. k <= 2) cycle
            s = s + 1
            tr(o + k, s) = 1.0_wp
            lp(s, o + k) = 1.0_wp
         end do
      end do
   end subroutine rigid_projection

   !> a = a^-1 for a small symmetric positive definite a (Gauss-Jordan: the
   !> merged inertias, a few rows).
   subroutine invert_spd(a, err)
      real(wp), intent(inout) :: a(:, :)
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: b(:, :)
      real(wp) :: piv
      integer :: n, k, i
      n = size(a, 1)
      allocate (b(n, 2*n))
      b = 0.0_wp
      b(:, 1:n) = a
      do k = 1, n
         b(k, n + k) = 1.0_wp
      end do
      do k = 1, n
         piv = b(k, k)
         if (.not. piv > 0.0_wp) then
            call fatal_error(err, 'the merged inertia matrix of the rigid connections is singular', err_numeric)
            return
         end if
         b(k, :) = b(k, :)/piv
         do i = 1, n
            if (i /= k) b(i, :) = b(i, :) - b(i, k)*b(k, :)
         end do
      end do
      a = b(:, n + 1:2*n)
   end subroutine invert_spd
end module trainsim_merged
