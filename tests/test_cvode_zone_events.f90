!> CVODE applies a spur gear's mesh-zone change at the crossing, not late
!> (D-26). With zone_function = 'truncate' the zone of a negative tooth phase
!> has no lower bound and ends at the same bound (u = m_p - 1) as the two-pair
!> zone [0, m_p - 1] of u >= 0. When CVODE's root finder returned with the
!> angle a rounding short of that bound, the zone was recomputed as the same
!> two-pair zone, its guard stayed at zero (an inactive root), and the change
!> was applied at the next output time: Table 5.5 at 285 teeth/s had its first
!> zone change at 0.003224 s instead of 0.00322012 s, Table 7.1 at 640 teeth/s
!> 11 impacts on the first mesh instead of 10.
!>
!> Reference: event-located RK4 at dt/16 (fourth order: its approach
!> velocities are within ~1e-8 of the dt/4 run's 2e-6 spread on Table 7.1).
!> At the decks' own tolerances (rtol 1e-10) CVODE must give the same events
!> (count, kinds, elements, order) and the first zone change within 1e-7 s:
!> the angle error rtol |theta| ~ 2e-11 rad moves a crossing at >= 56 rad/s by
!> < 1e-12 s, so 1e-7 s is the root finder's own resolution with a margin, and
!> 40 times finer than the 3.9e-6 s delay. At rtol 1e-14, event times within
!> 1e-9 s and approach velocities within 1e-6 relative: an approach velocity
!> of ~0.5 in/s is the difference of two line speeds of ~470 in/s, so its
!> relative error is the speeds' amplified ~1000 times (at rtol 1e-13 BDF still
!> leaves 2.4e-6 on Table 7.1's 56th event).
program test_cvode_zone_events
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_event, only: ev_zone, ev_contact_front, ev_contact_rear
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, run_model
   implicit none

   call suite_begin('cvode-bdf applies mesh-zone changes at the crossing (truncate zones)')
   call test_cvode_zone_change_on_time_table5_5_285()
   call test_cvode_impacts_match_rk4_table7_1_640()
   call suite_end()

contains

   subroutine test_cvode_zone_change_on_time_table5_5_285()
      type(run_result_t) :: ref, r
      call test_begin('cvode_zone_change_on_time_table5_5_285')
      call run_pair('tests/decks/cvode_zone_late_table5_5_285.nml', ref, r)
      call compare(ref, r)
      ! RK4's first zone change, 0.00322012 s (reproducer README)
      call check('first zone change at 0.00322012 s (not 0.003224)', first_zone_change(r), 0.00322012_wp, &
                 abs_tol=1.0e-8_wp)
   end subroutine test_cvode_zone_change_on_time_table5_5_285

   subroutine test_cvode_impacts_match_rk4_table7_1_640()
      type(run_result_t) :: ref, r
      call test_begin('cvode_impacts_match_rk4_table7_1_640')
      call run_pair('tests/decks/cvode_zone_late_table7_1_640.nml', ref, r)
      call compare(ref, r)
      call check('10 impacts on the first mesh (e2), not 11: cvode-bdf '//itoa(count_impacts(r, 2))//', rk4 '// &
                 itoa(count_impacts(ref, 2)), count_impacts(r, 2) == 10 .and. count_impacts(ref, 2) == 10)
   end subroutine test_cvode_impacts_match_rk4_table7_1_640

   !> Event-located RK4 at dt/16, and the deck's cvode-bdf at its own
   !> tolerances (checked here) and at rtol 1e-14 (returned for `compare`).
   subroutine run_pair(path, ref, r)
      character(len=*), intent(in) :: path
      type(run_result_t), intent(out) :: ref, r
      type(model_t) :: m0, m
      type(run_result_t) :: rd
      integer :: i, n
      logical :: same
      real(wp) :: tz_ref, tz
      call load_model(path, m0)
      m = m0
      m%run%integrator = 'rk4'
      m%run%dt = m0%run%dt/16.0_wp
      call run_model(m, ref)
      m = m0
      call run_model(m, rd)
      call check('deck tolerances: same number of events as rk4 ('//itoa(size(ref%events))//'), got '// &
                 itoa(size(rd%events)), size(rd%events) == size(ref%events))
      n = min(size(rd%events), size(ref%events))
      same = .true.
      do i = 1, n
         same = same .and. rd%events(i)%kind == ref%events(i)%kind .and. rd%events(i)%element == ref%events(i)%element
      end do
      call check('deck tolerances: same event kinds and elements in the same order', same)
      tz_ref = first_zone_change(ref)
      tz = first_zone_change(rd)
      call check('deck tolerances: first zone change at rk4''s time within 1e-7 s', tz, tz_ref, abs_tol=1.0e-7_wp)
      m = m0
      m%run%rtol = 1.0e-14_wp
      m%run%atol_angle = 1.0e-4_wp*m%run%rtol
      m%run%atol_speed = 1.0e-2_wp*m%run%rtol
      call run_model(m, r)
   end subroutine run_pair

   real(wp) function first_zone_change(r) result(t)
      type(run_result_t), intent(in) :: r
      integer :: i
      t = -1.0_wp
      do i = 1, size(r%events)
         if (r%events(i)%kind == ev_zone) then
            t = r%events(i)%t
            return
         end if
      end do
   end function first_zone_change

   subroutine compare(ref, r)
      type(run_result_t), intent(in) :: ref, r
      integer :: i, n
      real(wp) :: et, ev
      logical :: same
      n = min(size(r%events), size(ref%events))
      call check('rtol 1e-14: same number of events as rk4 ('//itoa(size(ref%events))//'), got '//itoa(size(r%events)), &
                 size(r%events) == size(ref%events))
      same = .true.
      et = 0.0_wp; ev = 0.0_wp
      do i = 1, n
         same = same .and. r%events(i)%kind == ref%events(i)%kind .and. r%events(i)%element == ref%events(i)%element
         et = max(et, abs(r%events(i)%t - ref%events(i)%t))
         if (ref%events(i)%approach_velocity /= 0.0_wp) ev = max(ev, abs(r%events(i)%approach_velocity - &
                                                             ref%events(i)%approach_velocity)/abs(ref%events(i)%approach_velocity))
      end do
      call check('rtol 1e-14: same event kinds and elements in the same order', same)
      call check('rtol 1e-14: event times within 1e-9 s', et, 0.0_wp, abs_tol=1.0e-9_wp)
      call check('rtol 1e-14: approach velocities within 1e-6 relative', ev, 0.0_wp, abs_tol=1.0e-6_wp)
   end subroutine compare

   integer function count_impacts(r, element) result(n)
      type(run_result_t), intent(in) :: r
      integer, intent(in) :: element
      n = count((r%events%kind == ev_contact_front .or. r%events%kind == ev_contact_rear) .and. &
                r%events%element == element)
   end function count_impacts

   function itoa(i) result(s)
      integer, intent(in) :: i
      character(len=:), allocatable :: s
      character(len=12) :: b
      write (b, '(i0)') i
      s = trim(b)
   end function itoa
end program test_cvode_zone_events
