!> A minimal assertion layer: each test is a subroutine that calls `check`;
!> the suite program runs them and exits non-zero if any failed.
module trainsim_testing
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: check, check_close, check_true, suite_begin, suite_end, test_begin

   integer, save :: n_checks = 0, n_failed = 0, n_tests = 0, n_tests_failed = 0
   logical, save :: current_failed = .false.
   character(len=128), save :: current = ''

   interface check
      module procedure check_close, check_true
   end interface check

contains

   !> Start a suite.
   subroutine suite_begin(name)
      character(len=*), intent(in) :: name
      write (*, '(a)') 'suite '//name
   end subroutine suite_begin

   !> Start a named test (closes the previous one).
   subroutine test_begin(name)
      character(len=*), intent(in) :: name
      call close_current()
      current = name
      current_failed = .false.
      n_tests = n_tests + 1
   end subroutine test_begin

   subroutine close_current()
      if (len_trim(current) == 0) return
      if (current_failed) then
         n_tests_failed = n_tests_failed + 1
         write (*, '(a)') '  FAIL '//trim(current)
      else
         write (*, '(a)') '  ok   '//trim(current)
      end if
      current = ''
   end subroutine close_current

   !> |actual - expected| <= max(abs_tol, rel_tol*|expected|)
   subroutine check_close(what, actual, expected, rel_tol, abs_tol)
      character(len=*), intent(in) :: what
      real(wp), intent(in) :: actual, expected
      real(wp), intent(in), optional :: rel_tol, abs_tol
      real(wp) :: tol
      tol = 0.0_wp
      if (present(rel_tol)) tol = max(tol, rel_tol*abs(expected))
      if (present(abs_tol)) tol = max(tol, abs_tol)
      n_checks = n_checks + 1
      if (.not. (abs(actual - expected) <= tol)) then
         n_failed = n_failed + 1
         current_failed = .true.
         write (*, '(a,es24.16,a,es24.16,a,es10.3,a,es10.3)') '    check failed: '//what//': got ', actual, &
            ' expected ', expected, ' |diff| ', abs(actual - expected), ' tol ', tol
      else
         write (*, '(a,es16.8,a,es16.8,a,es10.3)') '    '//what//': ', actual, ' vs ', expected, ' tol ', tol
      end if
   end subroutine check_close

   !> A logical condition.
   subroutine check_true(what, condition)
      character(len=*), intent(in) :: what
      logical, intent(in) :: condition
      n_checks = n_checks + 1
      if (.not. condition) then
         n_failed = n_failed + 1
         current_failed = .true.
         write (*, '(a)') '    check failed: '//what
      end if
   end subroutine check_true

   !> Finish: print the tally and stop with a non-zero code on failure.
   subroutine suite_end()
      call close_current()
      write (*, '(i0,a,i0,a)') n_tests - n_tests_failed, ' passed, ', n_tests_failed, ' failed'
      if (n_failed > 0 .or. n_tests_failed > 0) error stop 1
   end subroutine suite_end
end module trainsim_testing
