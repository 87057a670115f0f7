!> The static preload (trainsim_preload): Table 7.1's printed angles, the distance
!> of Table 5.5's printed angles from equilibrium, the loaded face, a free train's
!> constant-acceleration wind-up, and the modes about the preload.
program test_preload
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t
   use trainsim_deck, only: deck_t, read_deck, parse_deck
   use trainsim_model, only: model_t
   use trainsim_overrides, only: override_t, parse_set_argument
   use trainsim_prepare, only: prepare_model
   use trainsim_preload, only: preload_info_t
   use trainsim_modes, only: modes_t, compute_modes
   use trainsim_observer, only: run_result_t
   use trainsim_el_spur_gear, only: mesh_zone
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: run_model
   implicit none

   !> Tolerance of the Newton solve: its residual against the torque scale.
   real(wp), parameter :: newton_tol = 1.0e-11_wp

   call suite_begin('static preload (Tables 5.5 and 7.1, Ch. III)')
   call test_table7_1_preload_reproduces_printed_angles()
   call test_table7_1_preload_zone_of_start_angle()
   call test_ghm_printed_angles_off_equilibrium()
   call test_reversed_load_closes_the_rear_face()
   call test_free_train_constant_acceleration()
   call test_modes_about_preload_closed_mesh_mode()
   call suite_end()

contains

   !> Model of deck `path` with the --set overrides `sets` (and the preload info).
   subroutine prepare(path, sets, model, info)
      character(len=*), intent(in) :: path
      character(len=*), intent(in) :: sets(:)
      type(model_t), intent(out) :: model
      type(preload_info_t), intent(out) :: info
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      type(override_t), allocatable :: ovs(:)
      integer :: i
      allocate (ovs(size(sets)))
      call read_deck(path, deck, err)
      do i = 1, size(sets)
         if (.not. allocated(err)) call parse_set_argument(trim(sets(i)), ovs(i), err)
      end do
      if (.not. allocated(err)) call prepare_model(deck, ovs, model, err, info)
      if (allocated(err)) then
         write (*, '(a)') 'test setup failed: '//err%message
         error stop 2
      end if
      model%run%output = ''
   end subroutine prepare

   subroutine test_table7_1_preload_reproduces_printed_angles()
      type(model_t) :: m
      type(preload_info_t) :: info
      real(wp), parameter :: printed(6) = [-0.196834_wp, -0.212810_wp, -0.214203_wp, -0.215801_wp, -0.217194_wp, &
                                           -0.233170_wp]
      integer :: i
      call test_begin('table7_1_preload_reproduces_printed_angles')
      ! both meshes two-pair at their (negative) start angles, as the printed wind-up
      ! (c = 1.8) assumes: the listing's TRUNC zones
      call prepare('inputs/two_clearance.nml', [character(len=40) :: 'run.initial_state=preload', &
                   'mesh1.zone_function=truncate', 'mesh2.zone_function=truncate'], m, info)
      call check('Newton residual / torque scale', info%residual/info%torque_scale, 0.0_wp, abs_tol=newton_tol)
      call check('torque scale is the 798.8 lb-in load', info%torque_scale, 798.8_wp, rel_tol=1.0e-12_wp)
      do i = 1, 6
         ! printed to 6 decimals: within half a unit of the last digit (+ rounding of the sums)
         call check('node '//m%nodes(i)%n%id//' angle = printed to its 6 decimals', m%nodes(i)%n%theta0, printed(i), &
                    abs_tol=0.5e-6_wp + 1.0e-12_wp)
      end do
      call check('the printed angles were off equilibrium by their rounding only (< 1 lb-in)', &
                 info%deck_residual < 1.0_wp)
   end subroutine test_table7_1_preload_reproduces_printed_angles

   subroutine test_table7_1_preload_zone_of_start_angle()
      type(model_t) :: m
      type(preload_info_t) :: info
      real(wp) :: f, dth
      call test_begin('table7_1_preload_takes_the_zone_of_the_start_angle')
      ! the deck's periodic zones: node 2 at -0.212810 rad is at tooth phase 0.75, a
      ! single-pair zone (verification/README), so each mesh winds up by F/k, not F/(1.8 k)
      call prepare('inputs/two_clearance.nml', [character(len=40) :: 'run.initial_state=preload'], m, info)
      f = 798.8_wp/3.7588_wp
      dth = (0.005_wp + f/500000.0_wp)/3.7588_wp
      call check('mesh 1 wind-up (single pair) = (b + F/k)/r_b', m%nodes(2)%n%theta0 - m%nodes(3)%n%theta0, dth, &
                 rel_tol=1.0e-10_wp)
      call check('mesh 2 wind-up (single pair) = (b + F/k)/r_b', m%nodes(4)%n%theta0 - m%nodes(5)%n%theta0, dth, &
                 rel_tol=1.0e-10_wp)
      call check('so node 6 lies 2 (F/k)(1 - 1/1.8)/r_b below the printed angle', &
                 -0.233170_wp - m%nodes(6)%n%theta0, 2.0_wp*f/500000.0_wp*(1.0_wp - 1.0_wp/1.8_wp)/3.7588_wp, &
                 abs_tol=0.5e-6_wp)
   end subroutine test_table7_1_preload_zone_of_start_angle

   subroutine test_ghm_printed_angles_off_equilibrium()
      type(model_t) :: m
      type(preload_info_t) :: info
      real(wp) :: f, d_print, d_eq, k2
      call test_begin('ghm_printed_angles_off_equilibrium_by_the_wind_up_error')
      call prepare('inputs/gregory_harris_munro.nml', [character(len=40) :: 'run.initial_state=preload', &
                   'mesh.zone_function=truncate'], m, info)
      f = 798.8_wp/3.7588_wp
      k2 = 1.8_wp*234500.0_wp
      d_eq = 0.005_wp + f/k2
      d_print = 3.7588_wp*(-0.212810_wp + 0.214283_wp)
      call check('Newton residual / torque scale', info%residual/info%torque_scale, 0.0_wp, abs_tol=newton_tol)
      call check('equilibrium mesh wind-up = b + F/(1.8 k)', 3.7588_wp*(m%nodes(2)%n%theta0 - m%nodes(3)%n%theta0), &
                 d_eq, rel_tol=1.0e-10_wp)
      ! the printed mesh wind-up 5.537e-3 in exceeds 5.503e-3 by 3.4e-5 in (c ~ 1.69): far
      ! beyond its print rounding (2 x 3.76e-6 in), so the printed state is not at rest
      call check('printed wind-up is off by more than the print rounding', abs(d_print - d_eq) > 2.0_wp*3.7588e-6_wp)
      ! net torque on node 3 at the printed angles: r_b c k (delta_printed - delta_eq),
      ! known to the print rounding of delta (+-7.5e-6 in)
      call check('residual at the printed angles = r_b 1.8 k (wind-up error)', info%deck_residual, &
                 3.7588_wp*k2*(d_print - d_eq), abs_tol=3.7588_wp*k2*7.52e-6_wp)
   end subroutine test_ghm_printed_angles_off_equilibrium

   subroutine test_reversed_load_closes_the_rear_face()
      type(model_t) :: m
      type(preload_info_t) :: info
      real(wp) :: f
      call test_begin('reversed_load_closes_the_rear_face')
      ! the load drives instead of brakes: the teeth are taken up on the rear face
      call prepare('inputs/gregory_harris_munro.nml', [character(len=40) :: 'run.initial_state=preload', &
                   'mesh.zone_function=truncate', 'load#2.value=798.8'], m, info)
      f = 798.8_wp/3.7588_wp
      call check('mesh closed on its rear face', info%face(2) == -1)
      call check('Newton residual / torque scale', info%residual/info%torque_scale, 0.0_wp, abs_tol=newton_tol)
      ! the zone of the driver's preloaded angle sets c
      call check('mesh wind-up = -(b + F/(c k)) with the zone''s c', &
                 3.7588_wp*(m%nodes(2)%n%theta0 - m%nodes(3)%n%theta0), &
                 -(0.005_wp + f/(zone_factor(m%nodes(2)%n%theta0, 32.0_wp, 1.6676_wp, 0.1637_wp, .true.)*234500.0_wp)), &
                 rel_tol=1.0e-10_wp)
   end subroutine test_reversed_load_closes_the_rear_face

   !> Stiffness factor (1 or 1.8) of a spur mesh at driver angle th.
   real(wp) function zone_factor(th, n, mp, alpha, trunc) result(c)
      real(wp), intent(in) :: th, n, mp, alpha
      logical, intent(in) :: trunc
      integer :: pairs
      real(wp) :: lo, hi
      call mesh_zone(n*(th + alpha)/two_pi, mp, trunc, pairs, lo, hi)
      c = merge(1.8_wp, 1.0_wp, pairs == 2)
   end function zone_factor

   subroutine test_free_train_constant_acceleration()
      type(model_t) :: m
      type(preload_info_t) :: info
      type(run_result_t) :: r
      real(wp) :: a, f, c, te0
      integer :: k
      call test_begin('free_train_winds_up_for_constant_acceleration')
      ! Ch. III case III: 1000 lb-in on gear 1 only, nothing held: the train accelerates
      ! at T/(J1 + J2) and gear 2 is pushed by F = J2 a / r_b through the mesh
      call prepare('verification/chapter3/case3.nml', [character(len=40) :: 'run.initial_state=preload', &
                   'run.t_end=0.002'], m, info)
      a = 1000.0_wp/(7.537e-3_wp + 10.082_wp)
      call check('free train: reference acceleration = T/(J1 + J2)', info%acceleration, a, rel_tol=1.0e-12_wp)
      call check('reference node kept (gear 1 at its deck angle 0)', m%nodes(1)%n%theta0, 0.0_wp, abs_tol=0.0_wp)
      call check('Newton residual / torque scale', info%residual/info%torque_scale, 0.0_wp, abs_tol=newton_tol)
      f = 10.082_wp*a/1.6445_wp
      c = zone_factor(0.0_wp, 28.0_wp, 1.6380_wp, 0.1838_wp, .false.)
      te0 = 0.001_wp + f/(c*18.03e6_wp)
      call check('mesh wind-up = b + F/(c k)', 1.6445_wp*(m%nodes(1)%n%theta0 - m%nodes(2)%n%theta0), te0, &
                 rel_tol=1.0e-10_wp)
      ! from rest the deck's own start makes 18 impacts (verification/README); from the
      ! preload the pair accelerates as one body: no event, the TE stays at te0 (RK4
      ! is exact to round-off on a state that moves as a quadratic in t)
      call run_model(m, r)
      call check('no impact, separation or zone change in 2 ms', size(r%events) == 0)
      k = size(r%series_t)
      call check('TE constant over the run (1e-9 of the wind-up)', &
                 (maxval(r%series_disp(1, 1:k)) - minval(r%series_disp(1, 1:k)))/te0, 0.0_wp, abs_tol=1.0e-9_wp)
   end subroutine test_free_train_constant_acceleration

   subroutine test_modes_about_preload_closed_mesh_mode()
      type(model_t) :: m, m0
      type(preload_info_t) :: info
      type(modes_t) :: md, md0
      type(error_t), allocatable :: err
      real(wp) :: c, fexp
      call test_begin('modes_about_the_preload_have_the_closed_mesh_mode')
      ! Ch. III case II: +-1000 lb-in, the tooth centred in its backlash at the start,
      ! so the linearisation as the run starts has no mesh stiffness (two rigid-body
      ! modes); about the preload the mesh is closed: one rigid-body mode and the mesh
      ! mode sqrt(c k r_b^2 (1/J1 + 1/J2))/2 pi at the zone of the preloaded angle
      call prepare('verification/chapter3/case2.nml', [character(len=40) :: 'run.t_end=0.002'], m0, info)
      call compute_modes(m0, md0, err)
      call check('deck start: no elastic mode (contact open)', all(md0%rigid))
      call prepare('verification/chapter3/case2.nml', [character(len=40) :: 'run.initial_state=preload'], m, info)
      call check('balanced loads: acceleration 0', info%acceleration, 0.0_wp, abs_tol=1.0e-12_wp)
      call compute_modes(m, md, err)
      c = zone_factor(m%nodes(1)%n%theta0, 28.0_wp, 1.6380_wp, 0.1838_wp, .false.)
      fexp = sqrt(c*18.03e6_wp*1.6445_wp**2*(1.0_wp/7.537e-3_wp + 1.0_wp/10.082_wp))/two_pi
      call check('one rigid-body mode', count(md%rigid) == 1)
      call check('mesh mode about the preload = closed form', md%freq_hz(2), fexp, rel_tol=1.0e-10_wp)
   end subroutine test_modes_about_preload_closed_mesh_mode
end program test_preload
