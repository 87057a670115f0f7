!> An engagement table e(t) is piecewise linear: its knots are kinks of the
!> friction torque, which the driver makes step breakpoints (D-87), so RK4
!> never steps across one and keeps its fourth order. A slipping clutch with a
!> ramp engagement (Coulomb + viscous) between a spinning disk and a disk on a
!> shaft to ground, the knots off the step grid: the observed order of the
!> final state (the slope of log error against log h) is >= 3.5; the same
!> clutch without its breakpoints (a test plug-in) falls to about 2 (a kink
!> inside a step: local error O(h^2)).
module clutch_no_breaks_plugin
   use trainsim_kinds, only: wp
   use trainsim_el_clutch, only: clutch_t
   implicit none
   private
   public :: clutch_no_breaks_t

   !> The clutch without its breakpoints (what the driver did before D-87).
   type, extends(clutch_t) :: clutch_no_breaks_t
   contains
      procedure :: breakpoints => no_breakpoints
   end type clutch_no_breaks_t

contains

   pure subroutine no_breakpoints(self, bp)
      class(clutch_no_breaks_t), intent(in) :: self
      real(wp), allocatable, intent(out) :: bp(:)
      associate (unused => self)
      end associate
      allocate (bp(0))
   end subroutine no_breakpoints
end module clutch_no_breaks_plugin

program test_engagement_breakpoints
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_el_clutch, only: clutch_t
   use clutch_no_breaks_plugin, only: clutch_no_breaks_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check, check_true
   use trainsim_test_support, only: load_model_text, run_model, nl
   implicit none

   !> The coarse step (the knots 0.1037, 0.3071, 0.6113 s are off every grid h0/2^j)
   real(wp), parameter :: h0 = 4.0e-3_wp

   call suite_begin('engagement-table knots as step breakpoints (RK4 order)')
   call test_ramp_engagement_keeps_fourth_order()
   call suite_end()

contains

   !> The final state at step h, the clutch with (breaks) or without its breakpoints.
   function final_state(h, breaks) result(y)
      real(wp), intent(in) :: h
      logical, intent(in) :: breaks
      real(wp), allocatable :: y(:)
      type(model_t) :: m
      type(run_result_t) :: r
      type(clutch_no_breaks_t), allocatable :: plain
      character(len=24) :: a
      write (a, '(es22.15)') h
      call load_model_text("&run t_end = 1.0, dt = "//trim(a)//", output_interval = 0.1, integrator = 'rk4' /"//nl// &
                           "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl// &
                           "&node id = 'b', type = 'inertia', inertia = 2.0 /"//nl// &
                           "&node id = 'ground', type = 'fixed' /"//nl// &
                           "&element id = 'clutch', type = 'clutch', left = 'a', right = 'b', torque_sliding = 2.0, "// &
                           "viscous = 0.5, engagement_times = 0.1037, 0.3071, 0.6113, "// &
                           "engagement_values = 0.0, 1.0, 0.5 /"//nl// &
                           "&element id = 'spring', type = 'shaft', left = 'b', right = 'ground', stiffness = 100.0 /"//nl// &
                           "&initial node = 'a', speed = 10.0 /", m)
      if (.not. breaks) then
         select type (c => m%elements(1)%e)
         type is (clutch_t)
            allocate (plain)
            plain%clutch_t = c
         end select
         if (.not. allocated(plain)) error stop 'the deck''s first element is not a clutch'
         call move_alloc(plain, m%elements(1)%e)
         call m%finalize()
      end if
      call run_model(m, r)
      y = r%y_final(1:4)
      ! the clutch slips throughout (else its stick event would be a kink of its own)
      if (size(r%events) /= 0) error stop 'the clutch stuck: the test''s premise failed'
   end function final_state

   !> The order: the least-squares slope of log e(h) against log h over h0/2^j,
   !> j = 0 .. 3, e the error against the breakpoint run at h0/256 (its own error
   !> 256^4 below h0's). A slope over five steps, not one ratio: a kink's O(h^2)
   !> error has a constant that depends on where the knot falls in its step
   !> (Simpson's rule is exact on a ramp at 1/3 and 2/3 of the step), which changes
   !> from grid to grid.
   real(wp) function observed_order(breaks, y_ref, e0) result(p)
      logical, intent(in) :: breaks
      real(wp), intent(in) :: y_ref(:)
      real(wp), intent(out) :: e0
      integer, parameter :: n = 4
      real(wp) :: x(n), e(n)
      integer :: j
      do j = 1, n
         x(j) = log(h0*0.5_wp**(j - 1))
         e(j) = log(maxval(abs(final_state(h0*0.5_wp**(j - 1), breaks) - y_ref)))
      end do
      e0 = exp(e(1))
      print '(a,l2,a,4es10.2)', '    breakpoints', breaks, ': error at h0 / 2^j, j = 0 .. 3:', exp(e)
      p = sum((x - sum(x)/n)*(e - sum(e)/n))/sum((x - sum(x)/n)**2)
   end function observed_order

   subroutine test_ramp_engagement_keeps_fourth_order()
      real(wp) :: p_breaks, p_plain, e_breaks, e_plain
      real(wp), allocatable :: y_ref(:)
      call test_begin('ramp_engagement_keeps_fourth_order')
      y_ref = final_state(h0/256.0_wp, .true.)
      p_breaks = observed_order(.true., y_ref, e_breaks)
      p_plain = observed_order(.false., y_ref, e_plain)
      print '(a,f6.2,a,f6.2)', '    observed order: with the knots as breakpoints', p_breaks, ', without', p_plain
      call check_true('with the breakpoints: order >= 3.5 (RK4: 4)', p_breaks >= 3.5_wp)
      call check_true('without them: order < 3 (a kink inside a step: 2)', p_plain < 3.0_wp)
      call check_true('without them: error at h0 >= 10 x the error with them', e_plain >= 10.0_wp*e_breaks)
   end subroutine test_ramp_engagement_keeps_fourth_order
end program test_engagement_breakpoints
