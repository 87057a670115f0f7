!> The keyed joint's bore friction from the force the key transmits
!> (bore_friction = 'key_force', D-80) against a closed form: a hub on a key
!> without clearance (a linear key of angular stiffness K = k (d/2)^2) swings
!> with friction mu |T_key| opposing the slip, so toward the centre it moves on
!> (1 - mu) K and away from it on (1 + mu) K: each half swing's amplitude is
!> sqrt((1 - mu)/(1 + mu)) of the one before, and the half period is
!> (pi/2) (1/sqrt(1 - mu) + 1/sqrt(1 + mu)) / w_n. The default form (the hub's
!> external loads, eqs. 4.38-4.44) gives no friction on the same train (no hub
!> load). The ledger closes on both; the element's Jacobian matches central
!> differences in contact.
program test_key_bore_friction
   use trainsim_kinds, only: wp, pi
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, run_model, nl, jacobian_fd_error, zero_crossings
   implicit none

   ! J = 1, k = 1e4 at d/2 = 1: w_n = 100 rad/s; the hub starts at rest 0.01 rad off centre
   character(len=*), parameter :: train = "&run t_end = 0.2, dt = 1e-5, integrator = 'rk4', track_energy = .true.,"// &
                                          " output_interval = 1e-5 /"//nl// &
                                          "&node id = 'shaft', type = 'fixed' /"//nl// &
                                          "&node id = 'hub', type = 'inertia', inertia = 1.0 /"//nl// &
                                          "&element id = 'key', type = 'keyed_joint', diameter = 2.0, half_clearance = 0.0,"// &
                                          " stiffness = 1.0e4, contact_law = 'linear', contact_damping = 0.0,"// &
                                          " friction = 0.2, friction_velocity = 1e-4, load_radius = 4.0"
   character(len=*), parameter :: start = " /"//nl//"&initial node = 'hub', angle = -0.01 /"

   call suite_begin('keyed joint bore friction from the key force (issue 23 item 2, D-80)')
   call swings('key_force', 0.2_wp)
   call swings('hub_load', 0.0_wp)
   call jacobian_in_contact()
   call suite_end()

contains

   subroutine swings(form, mu)
      character(len=*), intent(in) :: form
      real(wp), intent(in) :: mu
      type(model_t) :: m
      type(run_result_t) :: res
      real(wp) :: tz(16), q, amp, half, worst_a, worst_t
      integer :: n, k, a, b
      call test_begin("bore_friction = '"//form//"': half swings against the closed form")
      call load_model_text(train//", bore_friction = '"//form//"'"//start, m)
      call run_model(m, res)
      q = sqrt((1.0_wp - mu)/(1.0_wp + mu))
      half = 0.5_wp*pi*(1.0_wp/sqrt(1.0_wp - mu) + 1.0_wp/sqrt(1.0_wp + mu))/100.0_wp
      call zero_crossings(res%series_t, res%series_omega(2, :), tz, n)   ! the turning points
      call check('at least four turning points', n >= 4)
      worst_a = 0.0_wp
      worst_t = 0.0_wp
      a = 1
      do k = 1, n
         ! the amplitude of half swing k: the largest |angle| up to the k-th turning point
         b = count(res%series_t <= tz(k))
         amp = maxval(abs(res%series_theta(2, a:b)))
         worst_a = max(worst_a, abs(amp/(0.01_wp*q**(k - 1)) - 1.0_wp))
         worst_t = max(worst_t, abs(tz(k) - k*half))
         a = b
      end do
      ! the tanh law is below full strength only while |slip| < friction_velocity = 1e-4 of
      ! the peak speed ~1 rad/s; the samples are 1e-5 s apart (angle error 5e-7 relative)
      call check('max |amplitude / (0.01 q^k) - 1|', worst_a, 0.0_wp, abs_tol=1.0e-5_wp)
      call check('max |turning time - k T_half| (s)', worst_t, 0.0_wp, abs_tol=1.0e-5_wp)
      ! at a turning point the tanh law's slope mu |T_key| / friction_velocity ~ 2e5 1/s puts
      ! RK4 at lambda dt ~ 2 (stable below 2.785, but its energy error there is ~1e-8)
      call check('energy ledger closes: max |residual| / scale', res%energy_residual_max/res%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-6_wp)
   end subroutine swings

   subroutine jacobian_in_contact()
      type(model_t) :: m
      real(wp) :: worst, scale
      call test_begin("bore_friction = 'key_force': analytic Jacobian = central differences in contact")
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                           "&node type = 'inertia', inertia = 0.5 /"//nl//"&node type = 'inertia', inertia = 2.0 /"//nl// &
                           "&element type = 'keyed_joint', diameter = 2.0, half_clearance = 0.01, stiffness = 1e6,"// &
                           " friction = 0.3, bore_friction = 'key_force', friction_velocity = 0.5,"// &
                           " initial_contact_velocity = 1.0 /"//nl// &
                           "&initial node = 'n1', angle = 0.014, speed = 1.2 /"//nl// &
                           "&initial node = 'n2', speed = 1.0 /", m)
      call jacobian_fd_error(m, 0.0_wp, worst, scale)
      call check('max |J_analytic - J_fd| / max |J|', worst, 0.0_wp, abs_tol=1.0e-6_wp)
   end subroutine jacobian_in_contact
end program test_key_bore_friction
