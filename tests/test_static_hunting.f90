!> The quasi-static reference (D-103) over the hunting period (D-118) and in a session.
!> A 20-tooth driver with one pitch error x on tooth 3 (the pair that entered at count
!> m = 2), TRAIN's two levels k, c2 k, the driver held at a speed and the driven gear
!> under a torque T_b: the static mesh force is F = T_b / r_b2 at every position and the
!> static deflection delta = b + F/(k c) + e(u), e the stiffness-weighted mean deviation:
!>   single-pair zone of tooth 3:   b + F/k + x          (the largest)
!>   two-pair zone with tooth 3:    b + F/(c2 k) + x/2
!>   two-pair zone without it:      b + F/(c2 k)         (the smallest)
!> so over the hunting period (20 mesh cycles) the static TE p-p is F/k (1 - 1/c2) + x;
!> over the first mesh cycle only (teeth 1 and 20) it would be F/k (1 - 1/c2).
!> A session of the same deck reports the same static figures and a Kv.
program test_static_hunting
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_error, only: error_t
   use trainsim_observer, only: run_result_t
   use trainsim_session, only: session_t
   use trainsim_quasi_static, only: static_ref_t, static_reference
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, run_model, nl
   implicit none

   real(wp), parameter :: k = 1.0e6_wp, c2 = 1.8_wp, b = 0.01_wp, x = 1.0e-4_wp, tb = 200.0_wp, rb2 = 2.0_wp
   real(wp), parameter :: f = tb/rb2

   call suite_begin('static reference over the hunting period, and in a session (D-118)')
   call hunting_period_static_te()
   call both_gears_two_driver_turns()
   call session_has_the_static_reference()
   call suite_end()

contains

   function deck(errors, driven) result(text)
      logical, intent(in) :: errors
      logical, intent(in), optional :: driven
      character(len=:), allocatable :: text
      character(len=:), allocatable :: pe
      integer :: i
      pe = ''
      if (errors) pe = ", pitch_errors_driver = 0, 0, 1e-4"//repeat(", 0", 17)
      if (present(driven)) then   ! every driver tooth 1e-5, driven teeth 1, 4, 7, ... 2e-5
         pe = ", pitch_errors_driver = 1e-5"//repeat(", 1e-5", 19)//", pitch_errors_driven = 2e-5"
         do i = 2, 40
            pe = pe//merge(', 2e-5', ', 0   ', mod(i - 1, 3) == 0)
         end do
      end if
      text = "&run t_end = 0.02, dt = 1e-6, integrator = 'rk4', output_interval = 1e-4 /"//nl// &
             "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl// &
             "&node id = 'b', type = 'inertia', inertia = 1.0 /"//nl// &
             "&element id = 'mesh', type = 'spur_gear', stiffness = 1e6, rb_driver = 1.0, rb_driven = 2.0, "// &
             "teeth = 20, contact_ratio = 1.6, approach_angle = 0.0, half_backlash = 0.01"//pe//" /"//nl// &
             "&load node = 'a', kind = 'constant', quantity = 'speed', value = 1.0 /"//nl// &
             "&load node = 'b', value = -200.0 /"//nl// &
             "&initial node = 'a', speed = 1.0 /"//nl//"&initial node = 'b', angle = -0.006, speed = 0.5 /"
   end function deck

   subroutine hunting_period_static_te()
      type(model_t) :: m
      type(static_ref_t) :: ref
      real(wp) :: p2p0
      call test_begin('one pitch error on tooth 3: static TE p-p over 20 mesh cycles = F/k (1 - 1/c2) + x')
      call load_model_text(deck(.true.), m)
      call static_reference(m, ref)
      call check('computed ('//ref%note//')', ref%computed)
      ! the angles reach a driver turn over the hunting period: their rounding, ulp(2 pi) r_b2 k / F
      ! = 1.8e-11 of F, bounds the force from the deflection
      call check('static force = T_b / r_b2', ref%force(1), f, rel_tol=5.0e-11_wp)
      p2p0 = f/k*(1.0_wp - 1.0_wp/c2)
      call check('te_max = b + F/k + x', ref%te_max(1), b + f/k + x, rel_tol=1.0e-12_wp)
      call check('te_min = b + F/(c2 k)', ref%te_min(1), b + f/(c2*k), rel_tol=1.0e-12_wp)
      call check('p-p - F/k (1 - 1/c2) = x (of x)', (ref%te_max(1) - ref%te_min(1) - p2p0)/x, 1.0_wp, abs_tol=1.0e-9_wp)
      call load_model_text(deck(.false.), m)
      call static_reference(m, ref)
      call check('without errors: p-p = F/k (1 - 1/c2) (one mesh cycle)', ref%te_max(1) - ref%te_min(1), p2p0, &
                 rel_tol=1.0e-9_wp)
   end subroutine hunting_period_static_te

   !> Errors on both gears: H = lcm(20, 40) = 40 mesh cycles, two driver turns (960
   !> static solves, angles to 4 pi: the preload accepts the angles' rounding). The largest
   !> deflection meets a driven tooth with 2e-5 in the single-pair zone, the smallest a
   !> two-pair zone of driven teeth without (adjacent teeth: never both): p-p = F/k (1 - 1/c2) + 2e-5.
   subroutine both_gears_two_driver_turns()
      type(model_t) :: m
      type(static_ref_t) :: ref
      call test_begin('pitch errors on both gears: static TE over 40 mesh cycles (two driver turns)')
      call load_model_text(deck(.false., driven=.true.), m)
      call static_reference(m, ref)
      call check('computed ('//ref%note//')', ref%computed)
      call check('te_max = b + F/k + 3e-5', ref%te_max(1), b + f/k + 3.0e-5_wp, rel_tol=1.0e-12_wp)
      call check('te_min = b + F/(c2 k) + 1e-5', ref%te_min(1), b + f/(c2*k) + 1.0e-5_wp, rel_tol=1.0e-12_wp)
      call check('static force = T_b / r_b2 (rounding of angles to 4 pi: 4e-11)', ref%force(1), f, rel_tol=2.0e-10_wp)
   end subroutine both_gears_two_driver_turns

   subroutine session_has_the_static_reference()
      type(model_t) :: m
      type(session_t), target :: s
      type(run_result_t) :: rs, rr
      type(error_t), allocatable :: err
      call test_begin('a session reports the static reference and Kv as the run does')
      call load_model_text(deck(.true.), m)
      call s%start(m, err)
      call check('session starts', .not. allocated(err))
      call s%advance(0.02_wp, err)
      call s%finish(rs)
      call load_model_text(deck(.true.), m)
      call run_model(m, rr)
      call check('static force: session = run', rs%el(1)%static_force, rr%el(1)%static_force, abs_tol=0.0_wp)
      call check('static TE p-p: session = run', rs%el(1)%static_te_p2p, rr%el(1)%static_te_p2p, abs_tol=0.0_wp)
      call check('static force = T_b / r_b2', rs%el(1)%static_force, f, rel_tol=5.0e-11_wp)
      call check('Kv > 0 in the session', rs%el(1)%kv > 0.0_wp)
      call check('Kv: session = run', rs%el(1)%kv, rr%el(1)%kv, rel_tol=1.0e-12_wp)
   end subroutine session_has_the_static_reference
end program test_static_hunting
