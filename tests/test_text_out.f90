!> trainsim_text_out writes the same text as Fortran's edit descriptors (the
!> printed tables of `trainsim run` must not change: D-82): every form it is used
!> with, over the values where C's and Fortran's forms part (zero of both signs,
!> subnormals, huge, non-finite, three-digit exponents, ties, rounding across a
!> power of ten) and 200 000 reals of random bits (NaNs among them quiet).
program test_text_out
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf, ieee_negative_inf
   use, intrinsic :: iso_fortran_env, only: int64
   use trainsim_kinds, only: wp
   use trainsim_text_out, only: text_out_t
   use trainsim_testing, only: suite_begin, test_begin, check, suite_end
   implicit none

   call suite_begin('text_out')
   call test_reals_as_fortran_writes_them()
   call test_text_and_integers_as_fortran_writes_them()
   call suite_end()

contains

   !> Count of x where out's ESw.d (or Fw.d) differs from write (buf, fmt).
   integer function mismatches(x, w, d, fixed) result(n)
      real(wp), intent(in) :: x(:)
      integer, intent(in) :: w, d
      logical, intent(in) :: fixed
      type(text_out_t) :: out
      character(len=64) :: ref, fmt
      integer :: i
      n = 0
      if (fixed) then
         write (fmt, '(a,i0,a,i0,a)') '(f', w, '.', d, ')'
      else
         write (fmt, '(a,i0,a,i0,a)') '(es', w, '.', d, ')'
      end if
      do i = 1, size(x)
         out%n = 0
         if (fixed) then
            call out%f(x(i), w, d)
         else
            call out%es(x(i), w, d)
         end if
         write (ref, fmt) x(i)
         if (out%buf(1:out%n) /= ref(1:w)) then
            n = n + 1
            if (n <= 5) write (*, '(4x,a,es25.17,3a)') 'differs at', x(i), ': "', out%buf(1:out%n), '" vs "'//ref(1:w)//'"'
         end if
      end do
   end function mismatches

   subroutine test_reals_as_fortran_writes_them()
      real(wp), allocatable :: x(:), r(:), p(:)
      integer(int64) :: s
      integer :: i, k
      call test_begin('reals_as_fortran_writes_them')
      x = [0.0_wp, -0.0_wp, tiny(1.0_wp), -tiny(1.0_wp), tiny(1.0_wp)*epsilon(1.0_wp), huge(1.0_wp), -huge(1.0_wp), &
           ieee_value(1.0_wp, ieee_quiet_nan), ieee_value(1.0_wp, ieee_positive_inf), &
           ieee_value(1.0_wp, ieee_negative_inf), 1.0e99_wp, 9.99999995e99_wp, 9.9999999e99_wp, 1.0e100_wp, &
           1.0e-99_wp, 9.99999996e-100_wp, 1.0e-100_wp, 0.5_wp, 1.25_wp, 2.5_wp, 0.125_wp, 1.0e4_wp, 1.0_wp, -1.0_wp, &
           12345678.5_wp, 12345677.5_wp, -98765.5_wp, 98764.5_wp, 1234567895.0_wp, 1234567885.0_wp, 0.375_wp, &
           99.995_wp, 99.994999_wp, 100.0_wp, 0.005_wp, -0.004_wp, 1.0e6_wp, -1.0e5_wp, 12345.678_wp, 0.001_wp]
      do k = -30, 30   ! rounding up across a power of ten at every digit count used
         x = [x, 10.0_wp**k, 10.0_wp**k*(1.0_wp - 4.0e-11_wp), 10.0_wp**k*(1.0_wp - 6.0e-8_wp), &
              10.0_wp**k*(1.0_wp - 4.0e-8_wp), -10.0_wp**k*(1.0_wp - 6.0e-6_wp), 10.0_wp**k*(1.0_wp - 5.0e-5_wp)]
      end do
      allocate (r(200000))
      s = 88172645463325252_int64
      do i = 1, size(r)   ! xorshift bits: every exponent and sign, NaNs and infinities among them
         s = ieor(s, ishft(s, 13)); s = ieor(s, ishft(s, -7)); s = ieor(s, ishft(s, 17))
         r(i) = transfer(s, 1.0_wp)
         ! no signalling NaN (no computation makes one; the Debug build's trap fires on any use)
         if (iand(ishft(s, -52), 2047_int64) == 2047_int64) r(i) = ieee_value(1.0_wp, ieee_quiet_nan)
      end do
      allocate (p(50000))
      do i = 1, size(p)   ! 1e-300..1e300 (no overflow: the Debug build traps it)
         p(i) = (1.0_wp + real(mod(i, 9973), wp)/997.0_wp)*10.0_wp**(mod(i, 600) - 300)
         if (mod(i, 2) == 0) p(i) = -p(i)
      end do
      x = [x, r, p]
      call check('es15.7 texts that differ', real(mismatches(x, 15, 7, .false.), wp), 0.0_wp, abs_tol=0.0_wp)
      call check('es15.6 texts that differ', real(mismatches(x, 15, 6, .false.), wp), 0.0_wp, abs_tol=0.0_wp)
      call check('es13.4 texts that differ', real(mismatches(x, 13, 4, .false.), wp), 0.0_wp, abs_tol=0.0_wp)
      call check('es18.9 texts that differ', real(mismatches(x, 18, 9, .false.), wp), 0.0_wp, abs_tol=0.0_wp)
      deallocate (p)
      allocate (p(17430))
      do i = 1, size(p)   ! percentages, -2 to 120, and beyond
         p(i) = real(-2000 + 7*(i - 1), wp)/997.0_wp
      end do
      r = [x(1:40), p, r(1:1000)]
      call check('f8.2 texts that differ', real(mismatches(r, 8, 2, .true.), wp), 0.0_wp, abs_tol=0.0_wp)
      ! the load-sharing factor's f12.6 (about 1; any real here)
      call check('f12.6 texts that differ', real(mismatches([r, x(41:2000)], 12, 6, .true.), wp), 0.0_wp, &
                 abs_tol=0.0_wp)
   end subroutine test_reals_as_fortran_writes_them

   subroutine test_text_and_integers_as_fortran_writes_them()
      type(text_out_t) :: out
      character(len=64) :: ref
      integer :: k, i
      integer, parameter :: ks(7) = [0, 7, -7, 123456789, -12345678, huge(1), -huge(1)]
      call test_begin('text_and_integers_as_fortran_writes_them')
      call out%a('shaft', 12); call out%x(1); call out%a('spur_gear_long_name', 7); call out%a('ab', 0)
      write (ref, '(a12,1x,a7,a)') 'shaft', 'spur_gear_long_name', 'ab'
      call check('a12, 1x, a7 (cut), a', out%buf(1:out%n) == trim(ref))
      do i = 1, size(ks)
         k = ks(i)
         out%n = 0
         call out%i(k, 9)
         write (ref, '(i9)') k
         call check('i9 of '//trim(adjustl(ref)), out%buf(1:out%n) == ref(1:9))
         out%n = 0
         call out%i(k, 0)
         write (ref, '(i0)') k
         call check('i0 of '//trim(ref), out%buf(1:out%n) == trim(ref))
      end do
   end subroutine test_text_and_integers_as_fortran_writes_them
end program test_text_out
