!> The guard windows (`model_t%guard_windows`, docs/decisions.md D-145) with
!> which RK4's block of steps tests its guards: a guard row has a guard below
!> zero exactly when d = r1 y(yl) - r2 y(yr) leaves [w3, w4] or y(yl) leaves
!> [w5, w6]. That rewrites `guards_below`'s `d - b < 0` as `d < b` (and its
!> kin): in IEEE arithmetic the difference of two finite numbers is zero only
!> when they are equal, so the signs agree to the last bit. Checked on the
!> Table 5.5 backlash gear (faces and zones) in each of its three contact
!> modes: the windows' answer equals `guards_below`'s for every state of
!> ulp-by-ulp walks across each face's and each zone's bound (the answer
!> changes in each walk across a guard's zero) and for infinite and NaN angles.
program test_guard_windows
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf, ieee_negative_inf
   use, intrinsic :: ieee_exceptions, only: ieee_get_halting_mode, ieee_set_halting_mode, ieee_set_flag, ieee_invalid
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_model_families, only: windows_below
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text
   implicit none

   type(model_t) :: m
   real(wp), allocatable :: y(:), g(:), w(:, :)
   integer, allocatable :: iw(:, :)
   integer :: mode, e, il, ir, n, n_probe, n_diff, n_below, flips, k
   real(wp) :: b, r1, d_mid, th_lo, th_hi, special(4)
   logical :: last, halt
   character(len=*), parameter :: nl = new_line('a')

   call suite_begin('guard windows of RK4''s blocks (D-145)')
   ! the gear pair alone between two free inertias (a train of one element)
   call load_model_text("&run t_end = 1.0e-3, dt = 8.0e-6, integrator = 'rk4' /"//nl// &
                        "&node id = 'pinion', type = 'inertia', inertia = 0.987 /"//nl// &
                        "&node id = 'wheel', type = 'inertia', inertia = 0.987 /"//nl// &
                        "&element id = 'mesh', type = 'spur_gear', stiffness = 234500.0, rb_driver = 3.7588, "// &
                        "rb_driven = 3.7588, teeth = 32, contact_ratio = 1.6676, approach_angle = 0.1637, "// &
                        "half_backlash = 0.005 /", m)
   call m%initial_state(y)
   allocate (g(m%n_guards), iw(2, m%n_guards), w(6, m%n_guards))
   e = 1
   call m%guard_angles(e, il, ir)
   special = [ieee_value(1.0_wp, ieee_quiet_nan), ieee_value(1.0_wp, ieee_positive_inf), &
              ieee_value(1.0_wp, ieee_negative_inf), 0.0_wp]
   n_probe = 0; n_diff = 0; n_below = 0; flips = 0
   y = 0.0_wp
   call m%init_modes(m%run%t_start, y)   ! free at d = 0: guard 1 is b - d = b
   b = m%angle_guard(e, 1, 0.0_wp, 0.0_wp)
   r1 = 3.7588_wp
   do mode = -1, 1
      ! the gear pressed on its face (mode +-1) or free (0), in the zone of y(il) = 0
      y = 0.0_wp
      y(il) = real(mode, wp)*1.2_wp*b/r1
      call m%init_modes(m%run%t_start, y)
      call m%guard_windows(n, iw, w)
      d_mid = real(mode, wp)*1.1_wp*b
      th_lo = -m%angle_guard(e, 3, 0.0_wp, 0.0_wp)   ! g3 = y(il) - th_lo
      th_hi = m%angle_guard(e, 4, 0.0_wp, 0.0_wp)    ! g4 = th_hi - y(il)
      ! across each face's bound d = +-b (y(ir) = 0: d = r1 y(il))
      call walk(b/r1, 0.0_wp, .false.)
      call walk(-b/r1, 0.0_wp, .false.)
      ! across each zone's bound, d = d_mid inside its window
      call walk(th_lo, d_mid, .true.)
      call walk(th_hi, d_mid, .true.)
      ! (a NaN compared raises 'invalid', which the Debug build traps: not here)
      call ieee_get_halting_mode(ieee_invalid, halt)
      call ieee_set_halting_mode(ieee_invalid, .false.)
      do k = 1, size(special)
         y = 0.0_wp
         y(il) = special(k)
         last = probe()
         y(il) = 0.0_wp
         y(ir) = special(k)
         last = probe()
      end do
      call ieee_set_flag(ieee_invalid, .false.)
      call ieee_set_halting_mode(ieee_invalid, halt)
   end do
   write (*, '(a,i0,a,i0,a,i0,a,i0)') '    states ', n_probe, ', below zero ', n_below, ', answer changes in walks ', &
      flips, ', windows differ from guards_below ', n_diff
   call test_begin('windows: the same answer as guards_below, bit for bit at the bounds')
   call check('one guard row with faces and zones', n == 1 .and. iw(1, 1) == il .and. iw(2, 1) == ir)
   call check('each walk that crosses a guard''s zero changes the answer (10 of the 12)', flips >= 10)
   call check('states on both sides', n_below > 50 .and. n_below < n_probe - 50)
   call check('no state where the windows and guards_below differ', n_diff == 0)
   call suite_end()

contains

   !> 33 states with y(il) from 16 ulps below th to 16 above, y(ir) such that
   !> d = d0 (keep_d; else y(ir) = 0); counts the changes of the answer.
   subroutine walk(th, d0, keep_d)
      real(wp), intent(in) :: th, d0
      logical, intent(in) :: keep_d
      real(wp) :: x
      integer :: q
      logical :: prev, now
      x = th
      do q = 1, 16
         x = nearest(x, -1.0_wp)
      end do
      do q = 1, 33
         y = 0.0_wp
         y(il) = x
         if (keep_d) y(ir) = (r1*x - d0)/r1
         now = probe()
         if (q > 1) then
            if (now .neqv. prev) flips = flips + 1
         end if
         prev = now
         x = nearest(x, 1.0_wp)
      end do
   end subroutine walk

   !> The windows' answer at y against guards_below's; returns guards_below's.
   logical function probe() result(below)
      logical :: win
      below = m%guards_below(0.0_wp, y, g)
      win = windows_below(n, iw, w, y)   ! (the function advance_block and rk4_block use, D-168)
      n_probe = n_probe + 1
      if (below) n_below = n_below + 1
      if (win .neqv. below) n_diff = n_diff + 1
   end function probe
end program test_guard_windows
