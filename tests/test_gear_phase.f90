!> The tooth-phase arithmetic of the spur and helical gears is safe for any
!> finite angle (D-26): mesh_zone used a default-integer floor that overflowed
!> beyond u = 2**31 (reproducer C_mesh_zone_floor_overflow: approach_angle =
!> 1e12, Debug SIGFPE, Release garbage with exit 0). And the keys that feed it
!> are range-checked with the key named: teeth in [1, 1e4], approach_angle on
!> the path of contact, [0, 2 pi m_p / N] (App. E uses pi m_p / N).
program test_gear_phase
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_deck, only: deck_t, parse_deck
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_el_spur_gear, only: mesh_zone
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, nl, expect_build_error
   implicit none

   character(len=*), parameter :: head = "&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                                         "&node type = 'inertia', inertia = 1.0 /"//nl// &
                                         "&node type = 'inertia', inertia = 1.0 /"//nl
   character(len=*), parameter :: spur = "&element type='spur_gear', stiffness=1e6, rb_driver=1.0, rb_driven=1.0, "// &
                                         "contact_ratio=1.6, half_backlash=0.01, "
   character(len=*), parameter :: helical = "&element type='helical_gear', rb_driver=2.0, rb_driven=2.0, "// &
                                            "profile_contact_ratio=1.55, base_helix_angle=20.0, face_width=1.1, "// &
                                            "half_backlash=0.002, "

   call suite_begin('gear tooth phase: any finite angle, checked keys')
   call test_mesh_zone_is_exact_beyond_default_integer_range()
   call test_gears_do_not_trap_at_runaway_angles()
   call test_spur_gear_rejects_bad_teeth_and_approach_angle()
   call test_helical_gear_rejects_bad_teeth_and_approach_angle()
   call suite_end()

contains

   !> u = 1e12 + 0.25 (exact in binary): phase 0.25 <= m_p - 1 = 0.6, two pairs
   !> on [1e12, 1e12 + 0.6]; u = -(1e12 + 0.75): phase 0.25 again. u = 1e300 is
   !> an integer in double precision: phase 0, two pairs, and no trap.
   subroutine test_mesh_zone_is_exact_beyond_default_integer_range()
      integer :: pairs
      real(wp) :: lo, hi
      call test_begin('mesh_zone_is_exact_beyond_default_integer_range')
      call mesh_zone(1.0e12_wp + 0.25_wp, 1.6_wp, .false., pairs, lo, hi)
      call check('u = 1e12 + 0.25: two pairs', pairs == 2)
      call check('  from 1e12', lo, 1.0e12_wp, abs_tol=0.0_wp)
      call check('  to 1e12 + 0.6', hi, 1.0e12_wp + 0.6_wp, abs_tol=1.0e-3_wp)
      call mesh_zone(-1.0e12_wp - 0.75_wp, 1.6_wp, .false., pairs, lo, hi)
      call check('u = -1e12 - 0.75: two pairs from -1e12 - 1', pairs == 2 .and. lo == -1.0e12_wp - 1.0_wp)
      call mesh_zone(-1.0e12_wp - 0.25_wp, 1.6_wp, .false., pairs, lo, hi)
      call check('u = -1e12 - 0.25: one pair up to -1e12', pairs == 1 .and. hi == -1.0e12_wp)
      call mesh_zone(1.0e300_wp, 1.6_wp, .false., pairs, lo, hi)
      call check('u = 1e300: two pairs, bounds finite', pairs == 2 .and. lo == 1.0e300_wp .and. hi >= lo)
      call mesh_zone(-1.0e300_wp, 1.6_wp, .true., pairs, lo, hi)
      call check('truncate, u = -1e300: two pairs up to m_p - 1', pairs == 2 .and. abs(hi - 0.6_wp) < 1.0e-15_wp)
   end subroutine test_mesh_zone_is_exact_beyond_default_integer_range

   !> A runaway driver angle (1e200 and 1e305 rad) sets zones, guards and
   !> torques without a floating-point trap (the Debug build traps overflow and
   !> invalid), with finite guards.
   subroutine test_gears_do_not_trap_at_runaway_angles()
      type(model_t) :: m
      real(wp) :: g(4), tl, tr, th(4)
      integer :: i, j
      call test_begin('gears_do_not_trap_at_runaway_angles')
      th = [1.0e200_wp, -1.0e200_wp, 1.0e305_wp, -1.0e305_wp]
      call load_model_text(head//spur//"teeth = 28, approach_angle = 0.18 /", m)
      do i = 1, size(th)
         call m%elements(1)%e%init_mode(th(i), 1.0_wp, 0.0_wp, 0.0_wp)
         call m%elements(1)%e%guards(th(i), 1.0_wp, 0.0_wp, 0.0_wp, g)
         call check('spur guards 3-4 finite at theta = '//trim(fmt(th(i))), all(abs(g(3:4)) <= huge(1.0_wp)))
      end do
      call load_model_text(head//helical//"teeth = 30 /", m)
      do j = 1, size(th)
         call m%elements(1)%e%init_mode(th(j), 1.0_wp, th(j), 0.0_wp)
         call m%elements(1)%e%torques(th(j), 1.0_wp, th(j), 0.0_wp, tl, tr)
         call check('helical torques finite at theta = '//trim(fmt(th(j))), abs(tl) <= huge(1.0_wp) .and. &
                    abs(tr) <= huge(1.0_wp))
      end do
   end subroutine test_gears_do_not_trap_at_runaway_angles

   subroutine test_spur_gear_rejects_bad_teeth_and_approach_angle()
      call test_begin('spur_gear_rejects_bad_teeth_and_approach_angle')
      ! 2 pi m_p / N = 2 pi 1.6 / 28 = 0.359 rad
      call expect_error(head//spur//"teeth = 28, approach_angle = 1e12 /", "key 'approach_angle'")
      call expect_error(head//spur//"teeth = 28, approach_angle = -0.01 /", "key 'approach_angle'")
      call expect_error(head//spur//"teeth = 28, approach_angle = 0.36 /", "key 'approach_angle'")
      call expect_ok(head//spur//"teeth = 28, approach_angle = 0.359 /")
      call expect_error(head//spur//"teeth = 0.5, approach_angle = 0.1 /", "key 'teeth'")
      call expect_error(head//spur//"teeth = 2e4, approach_angle = 0.0 /", "key 'teeth'")
      call expect_error(head//"&element type='spur_gear', teeth_driver=20, teeth_driven=1e7, module=2.0, "// &
                        "face_width=20.0, backlash=0.1 /", "key 'teeth_driven'")
   end subroutine test_spur_gear_rejects_bad_teeth_and_approach_angle

   subroutine test_helical_gear_rejects_bad_teeth_and_approach_angle()
      call test_begin('helical_gear_rejects_bad_teeth_and_approach_angle')
      call expect_error(head//helical//"teeth = 30, approach_angle = 1e12 /", "key 'approach_angle'")
      call expect_error(head//helical//"teeth = 30, approach_angle = -0.1 /", "key 'approach_angle'")
      call expect_ok(head//helical//"teeth = 30, approach_angle = 0.3 /")
      call expect_error(head//helical//"teeth = 1e9 /", "key 'teeth'")
      call expect_error(head//helical//"teeth = 0.2 /", "key 'teeth'")
   end subroutine test_helical_gear_rejects_bad_teeth_and_approach_angle

   !> Building the deck fails with an input error whose message names `key`.
   subroutine expect_error(text, key)
      character(len=*), intent(in) :: text, key
      call expect_build_error(text, key, where=.false.)
   end subroutine expect_error

   subroutine expect_ok(text)
      character(len=*), intent(in) :: text
      type(deck_t) :: deck
      type(model_t) :: m
      type(error_t), allocatable :: err
      call parse_deck(text, 'inline.nml', deck, err)
      if (.not. allocated(err)) call build_model(deck, m, err)
      if (allocated(err)) then
         call check('accepted: '//err%message, .false.)
      else
         call check('accepted: '//text(index(text, '&element'):), .true.)
      end if
   end subroutine expect_ok

   function fmt(x) result(s)
      real(wp), intent(in) :: x
      character(len=16) :: s
      write (s, '(es10.2)') x
   end function fmt
end program test_gear_phase
