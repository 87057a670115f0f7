!> Floquet multipliers of a periodic orbit: the eigenvalues of its monodromy
!> matrix (LAPACK dgeev), largest modulus first. The orbit is asymptotically
!> stable when every |mu| < 1 (a multiplier at 1 in modulus, to the
!> accuracy of M, is a bifurcation: a fold or period-doubling at +-1, a
!> Neimark-Sacker pair on the unit circle).
module trainsim_floquet
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_numeric
   use trainsim_strings, only: str
   implicit none
   private

   public :: floquet_multipliers, stability_of, neutral_tol

   !> |mu| within this of 1 is marginal: the monodromy by central differences moves the
   !> multipliers of the Table 5.5 rig's undamped modes by up to 1.3e-7 between steps
   !> of 1e-4 and 1e-8 of the state scale (docs/periodic.md)
   real(wp), parameter :: neutral_tol = 1.0e-6_wp

   interface
      subroutine dgeev(jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info)
         import :: wp
         character(len=1), intent(in) :: jobvl, jobvr
         integer, intent(in) :: n, lda, ldvl, ldvr, lwork
         real(wp), intent(inout) :: a(lda, *)
         real(wp), intent(out) :: wr(*), wi(*), vl(ldvl, *), vr(ldvr, *), work(*)
         integer, intent(out) :: info
      end subroutine dgeev
   end interface

contains

   !> The eigenvalues mu of m, sorted by decreasing modulus (a conjugate pair:
   !> the positive imaginary part first).
   subroutine floquet_multipliers(m, mu, err)
      real(wp), intent(in) :: m(:, :)
      complex(wp), allocatable, intent(out) :: mu(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: a(:, :), wr(:), wi(:), work(:)
      real(wp) :: vl(1, 1), vr(1, 1)
      complex(wp) :: c
      integer :: n, info, i, j
      n = size(m, 1)
      allocate (mu(n))
      if (n == 0) return
      a = m
      allocate (wr(n), wi(n), work(max(1, 8*n)))
      call dgeev('N', 'N', n, a, n, wr, wi, vl, 1, vr, 1, work, size(work), info)
      if (info /= 0) then
         call fatal_error(err, 'the eigenvalue solver (LAPACK dgeev) failed on the monodromy matrix with info = '// &
                          str(info), err_numeric)
         return
      end if
      mu = cmplx(wr, wi, kind=wp)
      do i = 2, n   ! insertion sort: |mu| down, then the imaginary part down
         c = mu(i)
         j = i - 1
         do while (j >= 1)
            if (.not. before(c, mu(j))) exit
            mu(j + 1) = mu(j)
            j = j - 1
         end do
         mu(j + 1) = c
      end do
   contains
      logical function before(p, q)
         complex(wp), intent(in) :: p, q
         if (abs(abs(p) - abs(q)) > 1.0e-14_wp*max(abs(p), abs(q))) then
            before = abs(p) > abs(q)
         else
            before = aimag(p) > aimag(q)
         end if
      end function before
   end subroutine floquet_multipliers

   !> 'stable' (every |mu| < 1 - neutral_tol), 'marginal' (the largest within
   !> neutral_tol of 1: an undamped mode) or 'unstable'.
   function stability_of(mu) result(word)
      complex(wp), intent(in) :: mu(:)
      character(len=:), allocatable :: word
      real(wp) :: a
      a = 0.0_wp
      if (size(mu) > 0) a = maxval(abs(mu))
      if (a < 1.0_wp - neutral_tol) then
         word = 'stable'
      else if (a <= 1.0_wp + neutral_tol) then
         word = 'marginal'
      else
         word = 'unstable'
      end if
   end function stability_of
end module trainsim_floquet
