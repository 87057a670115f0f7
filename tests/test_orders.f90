!> The order tracker (trainsim_orders, D-104) on prescribed signals: a single harmonic
!> comes back with its amplitude at its order and nothing at the others, to rounding
!> (the trapezoidal rule on samples evenly spaced over whole cycles is the DFT, exact
!> for orders below half the samples a cycle); the mean to rounding; a window that ends
!> inside a cycle is cut at the last whole cycle, so a large mean does not leak.
program test_orders
   use trainsim_kinds, only: wp, two_pi
   use trainsim_strings, only: str
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_orders, only: order_tracker_t, n_orders
   implicit none

   call suite_begin('orders of a rotation (TE spectrum in mesh orders)')
   call test_single_harmonic()
   call test_partial_cycle_no_leak()
   call suite_end()

contains

   !> x = a0 + A cos(3 phi + psi), y = B sin(phi), 10 cycles, 200 samples a cycle, rate 2 pi 400.
   subroutine test_single_harmonic()
      type(order_tracker_t) :: ot
      real(wp), parameter :: a0 = 5.0e-3_wp, amp = 7.0e-5_wp, psi = 0.3_wp, bf = 12.5_wp, w = two_pi*400.0_wp
      real(wp) :: a(0:n_orders, 2), t, phi, err
      integer :: j, k, n
      call test_begin('a single harmonic at order 3 and one at order 1: amplitudes to 1e-10')
      n = 10*200
      do j = 0, n
         t = real(j, wp)/(400.0_wp*200.0_wp)
         phi = w*t
         call ot%push(t, w, [a0 + amp*cos(3.0_wp*phi + psi), bf*sin(phi)])
      end do
      call ot%amplitudes(a)
      err = abs(a(3, 1) - amp)/amp
      call check('order 3 amplitude '//str(a(3, 1))//' = '//str(amp)//' (rel. '//str(err)//')', err < 1.0e-10_wp)
      call check('mean '//str(a(0, 1))//' = '//str(a0), abs(a(0, 1) - a0)/a0 < 1.0e-10_wp)
      do k = 1, n_orders
         if (k == 3) cycle
         call check('order '//str(k)//' of x: '//str(a(k, 1))//' < 1e-10 A', a(k, 1) < 1.0e-10_wp*amp)
      end do
      call check('order 1 of y '//str(a(1, 2))//' = '//str(bf), abs(a(1, 2) - bf)/bf < 1.0e-10_wp)
      call check('cycles '//str(ot%cycles())//' = 10', abs(ot%cycles() - 10.0_wp) < 1.0e-10_wp)
   end subroutine test_single_harmonic

   !> 10.37 cycles of a0 + A cos(2 phi), a0 = 100 A: cut at 10 whole cycles, order 2 to 1e-10.
   subroutine test_partial_cycle_no_leak()
      type(order_tracker_t) :: ot
      real(wp), parameter :: amp = 1.0_wp, a0 = 100.0_wp, w = two_pi*50.0_wp
      real(wp) :: a(0:n_orders, 2), t, phi
      integer :: j
      call test_begin('a window ending inside a cycle: the mean 100 x the harmonic does not leak')
      do j = 0, nint(10.37_wp*256.0_wp)
         t = real(j, wp)/(50.0_wp*256.0_wp)
         phi = w*t
         call ot%push(t, w, [a0 + amp*cos(2.0_wp*phi), 0.0_wp])
      end do
      call ot%amplitudes(a)
      call check('order 2 '//str(a(2, 1))//' = 1', abs(a(2, 1) - amp) < 1.0e-10_wp)
      call check('mean '//str(a(0, 1))//' = 100', abs(a(0, 1) - a0) < 1.0e-10_wp*a0)
      call check('orders 1 and 3: '//str(a(1, 1))//', '//str(a(3, 1)), a(1, 1) < 1.0e-10_wp .and. a(3, 1) < 1.0e-10_wp)
   end subroutine test_partial_cycle_no_leak
end program test_orders
