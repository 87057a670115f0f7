!> n-port elements (D-73): the `port_*` defaults of a two-port element give its
!> own answers bit for bit, and a gear pair on a carrier (port 3) is its own
!> physics in the carrier's frame: the torques are minus the gradient of its
!> elastic energy over all three ports (virtual work), the carrier takes
!> F (r1 + r2), turning the whole gearbox (gears locked in it) changes nothing,
!> and the port Jacobian and linearisation agree with difference quotients of
!> the port torques and with that rigid motion. tests/check_gear_housing.py
!> checks the same pair in a train against closed forms.
program test_ports
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_element, only: lin_closed
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check, check_true
   use trainsim_test_support, only: load_model_text, nl
   implicit none

   !> r1 = 1.5, r2 = 2.5 (n = 5/3), 24 teeth, half backlash 0.01: a gear on a
   !> carrier 'h' between a driver 'a' and a driven 'b' (and the same without).
   character(len=*), parameter :: nodes = "&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                                          "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl// &
                                          "&node id = 'b', type = 'inertia', inertia = 2.0 /"//nl// &
                                          "&node id = 'h', type = 'inertia', inertia = 5.0 /"//nl
   character(len=*), parameter :: spur = "type = 'spur_gear', left = 'a', right = 'b', stiffness = 1.0e6, "// &
                                         "rb_driver = 1.5, rb_driven = 2.5, teeth = 24, contact_ratio = 1.6, "// &
                                         "approach_angle = 0.1, half_backlash = 0.01"
   real(wp), parameter :: r1 = 1.5_wp, r2 = 2.5_wp

   call suite_begin('n-port elements (ports, a gear pair on a carrier)')
   call test_two_port_defaults_are_the_element_itself()
   call test_carrier_torques_are_minus_the_energy_gradient()
   call test_carrier_takes_f_times_r1_plus_r2()
   call test_turning_the_gearbox_changes_nothing()
   call test_port_jacobian_matches_differences()
   call test_port_linearise_is_the_frame_map()
   call suite_end()

contains

   !> A closed state of the spur pair on its carrier: the driver penetrated past
   !> the front face (d - b = 2e-4 in the carrier's frame), some speeds.
   subroutine closed_state(th, w)
      real(wp), intent(out) :: th(3), w(3)
      th(3) = 0.013_wp
      th(2) = 0.2_wp
      ! d = r1 (th1 - thc) - r2 (th2 + thc) = 0.01 + 2e-4
      th(1) = th(3) + (0.0102_wp + r2*(th(2) + th(3)))/r1
      w = [3.0_wp, 1.7_wp, -0.4_wp]
   end subroutine closed_state

   !> The spur pair on its carrier, in its mode at closed_state's angles and speeds.
   subroutine closed_pair(m, th, w)
      type(model_t), intent(out) :: m
      real(wp), intent(out) :: th(3), w(3)
      call load_model_text(nodes//"&element id = 'g', "//spur//", carrier = 'h' /", m)
      call closed_state(th, w)
      call m%elements(1)%e%port_init_mode(th, w)
   end subroutine closed_pair

   subroutine test_two_port_defaults_are_the_element_itself()
      type(model_t) :: m
      real(wp) :: th(2), w(2), t(2), tl, tr, d1, f1, d2, f2
      integer :: c1, p1, c2, p2
      call test_begin('two_port_defaults_are_the_element_itself')
      call load_model_text(nodes//"&element id = 'g', "//spur//" /"//nl// &
                           "&element id = 's', type = 'shaft', left = 'h', right = 'a', stiffness = 1.0e3 /", m)
      associate (e => m%elements(1)%e)
         call check_true('two ports', e%n_ports() == 2)
         th = [0.3_wp, 0.17_wp]
         w = [2.0_wp, 1.1_wp]
         call e%port_init_mode(th, w)
         call e%torques(th(1), w(1), th(2), w(2), tl, tr)
         call e%port_torques(th, w, t)
         call check_true('port_torques = torques, bit for bit', t(1) == tl .and. t(2) == tr)
         call check_true('port_potential_energy = potential_energy', &
                         e%port_potential_energy(th) == e%potential_energy(th(1), th(2)))
         call e%status(th(1), w(1), th(2), w(2), d1, f1, c1, p1)
         call e%port_status(th, w, d2, f2, c2, p2)
         call check_true('port_status = status', d1 == d2 .and. f1 == f2 .and. c1 == c2 .and. p1 == p2)
      end associate
   end subroutine test_two_port_defaults_are_the_element_itself

   !> t_k = -dV/dth_k for all three ports (speeds 0: no damping), central
   !> differences with h = 1e-7: error O(h^2 V''') far below 1e-6 relative.
   subroutine test_carrier_torques_are_minus_the_energy_gradient()
      type(model_t) :: m
      real(wp) :: th(3), w(3), t(3), tp(3), h, dv
      integer :: k
      call test_begin('carrier_torques_are_minus_the_energy_gradient')
      call load_model_text(nodes//"&element id = 'g', "//spur//", carrier = 'h' /", m)
      associate (e => m%elements(1)%e)
         call check_true('three ports, the third the carrier', e%n_ports() == 3 .and. e%port(3) == 3)
         call closed_state(th, w)
         w = 0.0_wp
         call e%port_init_mode(th, w)
         call e%port_torques(th, w, t)
         h = 1.0e-7_wp
         do k = 1, 3
            tp = th
            tp(k) = th(k) + h
            dv = e%port_potential_energy(tp)
            tp(k) = th(k) - h
            dv = (dv - e%port_potential_energy(tp))/(2.0_wp*h)
            call check('t_'//achar(48 + k)//' = -dV/dth_'//achar(48 + k), t(k), -dv, rel_tol=1.0e-6_wp)
         end do
      end associate
   end subroutine test_carrier_torques_are_minus_the_energy_gradient

   !> The mesh force F (status) acts at r1 on the driver, r2 on the driven gear
   !> and, through both bearings, F (r1 + r2) on the carrier (t_c = -t_l + t_r).
   subroutine test_carrier_takes_f_times_r1_plus_r2()
      type(model_t) :: m
      real(wp) :: th(3), w(3), t(3), d, f
      integer :: c, p
      call test_begin('carrier_takes_f_times_r1_plus_r2')
      call closed_pair(m, th, w)
      associate (e => m%elements(1)%e)
         call e%port_torques(th, w, t)
         call e%port_status(th, w, d, f, c, p)
         call check('displacement in the carrier frame', d, r1*(th(1) - th(3)) - r2*(th(2) + th(3)), &
                    rel_tol=1.0e-13_wp)
         call check_true('in contact, front face', c == 1 .and. f > 0.0_wp)
         call check('driver: -F r1', t(1), -f*r1, rel_tol=1.0e-13_wp)
         call check('driven: +F r2', t(2), f*r2, rel_tol=1.0e-13_wp)
         call check('carrier: F (r1 + r2)', t(3), f*(r1 + r2), rel_tol=1.0e-13_wp)
      end associate
   end subroutine test_carrier_takes_f_times_r1_plus_r2

   !> The gearbox turned by phi with its gears locked in it (driver +phi, the
   !> driven gear -phi in its own sense, the carrier +phi), speeds likewise:
   !> the same torques (to the rounding of the shifted angles).
   subroutine test_turning_the_gearbox_changes_nothing()
      type(model_t) :: m
      real(wp) :: th(3), w(3), t(3), t2(3), sh(3)
      call test_begin('turning_the_gearbox_changes_nothing')
      call closed_pair(m, th, w)
      associate (e => m%elements(1)%e)
         call e%port_torques(th, w, t)
         sh = [1.0_wp, -1.0_wp, 1.0_wp]
         call e%port_torques(th + 0.03125_wp*sh, w + 2.0_wp*sh, t2)
         call check('driver', t2(1), t(1), rel_tol=1.0e-9_wp)
         call check('driven', t2(2), t(2), rel_tol=1.0e-9_wp)
         call check('carrier', t2(3), t(3), rel_tol=1.0e-9_wp)
      end associate
   end subroutine test_turning_the_gearbox_changes_nothing

   !> port_jacobian (the two-port closed form through the frame map) against
   !> central differences of port_torques, h = 1e-7 relative: 1e-5 of the largest entry.
   subroutine test_port_jacobian_matches_differences()
      type(model_t) :: m
      real(wp) :: th(3), w(3), jt(3, 6), x(6), xp(6), tp(3), tm(3), h, scale
      integer :: j
      call test_begin('port_jacobian_matches_differences')
      call closed_pair(m, th, w)
      associate (e => m%elements(1)%e)
         call e%port_jacobian(th, w, jt)
         scale = maxval(abs(jt))
         x = [th(1), w(1), th(2), w(2), th(3), w(3)]
         do j = 1, 6
            h = 1.0e-7_wp*max(1.0_wp, abs(x(j)))
            xp = x
            xp(j) = x(j) + h
            call e%port_torques(xp(1:5:2), xp(2:6:2), tp)
            xp(j) = x(j) - h
            call e%port_torques(xp(1:5:2), xp(2:6:2), tm)
            call check_true('column '//achar(48 + j)//' within 1e-5 of the largest entry', &
                            all(abs((tp - tm)/(2.0_wp*h) - jt(:, j)) <= 1.0e-5_wp*scale))
         end do
      end associate
   end subroutine test_port_jacobian_matches_differences

   !> port_linearise: symmetric, its gear block the two-port one, and the
   !> gearbox turning as a whole, v = (1, -1, 1), in its null space.
   subroutine test_port_linearise_is_the_frame_map()
      type(model_t) :: m
      real(wp) :: th(3), w(3), k3(3, 3), c3(3, 3), k2(2, 2), c2(2, 2), v(3)
      call test_begin('port_linearise_is_the_frame_map')
      call closed_pair(m, th, w)
      associate (e => m%elements(1)%e)
         call e%port_linearise(lin_closed, [1.0_wp, 0.5_wp, 0.2_wp], k3, c3)
         call e%linearise(lin_closed, 1.0_wp, 0.5_wp, k2, c2)
         call check_true('symmetric', all(abs(k3 - transpose(k3)) <= 1.0e-12_wp*maxval(abs(k3))))
         call check_true('gear block = the two-port stiffness', all(k3(1:2, 1:2) == k2))
         call check('k_cc = k (r1 + r2)^2', k3(3, 3), k2(1, 1)/r1**2*(r1 + r2)**2, rel_tol=1.0e-13_wp)
         v = [1.0_wp, -1.0_wp, 1.0_wp]
         call check_true('the gearbox turning as a whole stores nothing', &
                         all(abs(matmul(k3, v)) <= 1.0e-12_wp*maxval(abs(k3))))
         call check_true('nor dissipates', all(abs(matmul(c3, v)) <= 1.0e-12_wp*max(maxval(abs(c3)), 1.0_wp)))
      end associate
   end subroutine test_port_linearise_is_the_frame_map
end program test_ports
