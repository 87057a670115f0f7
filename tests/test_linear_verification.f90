!> Issue 2 must-shows: Table 5.1 and 5.2 of the thesis, RK4 order, energy
!> balance, branched trains against closed forms.
program test_linear_verification
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_modes, only: modes_t, compute_modes, rk4_stability_limit
   use trainsim_strings, only: str
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: zero_crossings, load_model, load_model_text, run_model, nl
   implicit none

   call suite_begin('linear verification (thesis ch. V, issue 2)')
   call test_table5_1_response_is_cosine_at_fundamental()
   call test_table5_1_modes_match_holzer()
   call test_table5_2_ideal_gear_speeds_stay_constant_and_dt_is_flagged()
   call test_rk4_is_fourth_order_on_single_oscillator()
   call test_undamped_train_conserves_energy()
   call test_damped_driven_train_energy_balance_closes()
   call test_branched_pinion_two_gears_matches_closed_form()
   call test_star_of_shafts_matches_closed_form()
   call test_rk4_is_exact_through_an_off_grid_load_step()
   call suite_end()

contains

   subroutine test_table5_1_response_is_cosine_at_fundamental()
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: tz(8), f, amp(3)
      integer :: n, i
      call test_begin('table5_1_response_is_cosine_at_fundamental')
      call load_model('verification/table5_1/table5_1.nml', m)
      call run_model(m, r)
      ! one period (0.0508 s) holds two zero crossings, at T/4 and 3T/4
      call zero_crossings(r%series_t, r%series_theta(1, :), tz, n)
      call check('zero crossings of disk 1 in one period', real(n, wp), 2.0_wp, abs_tol=0.0_wp)
      f = 1.0_wp/(2.0_wp*(tz(2) - tz(1)))
      call check('measured frequency (Hz) vs 19.68, 0.2 %', f, 19.68_wp, rel_tol=2.0e-3_wp)
      do i = 1, 3
         amp(i) = 0.5_wp*(maxval(r%series_theta(i, :)) - minval(r%series_theta(i, :)))
      end do
      amp(3) = -amp(3)   ! disk 3 moves against disk 1 (starts negative)
      call check('amplitude ratio disk 2 / disk 1 vs 0.2353, 1 %', amp(2)/amp(1), 0.2353_wp, rel_tol=1.0e-2_wp)
      call check('amplitude ratio disk 3 / disk 1 vs -0.3449, 1 %', amp(3)/amp(1), -0.3449_wp, rel_tol=1.0e-2_wp)
      call check('disk 1 amplitude equals its initial displacement 0.1, 1 %', amp(1), 0.1_wp, rel_tol=1.0e-2_wp)
   end subroutine test_table5_1_response_is_cosine_at_fundamental

   subroutine test_table5_1_modes_match_holzer()
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      call test_begin('table5_1_modes_match_holzer')
      call load_model('verification/table5_1/table5_1.nml', m)
      call compute_modes(m, md, err)
      call check('modes computed', .not. allocated(err))
      call check('first mode is the rigid-body mode', md%rigid(1))
      call check('fundamental (Hz) vs Holzer 19.68, 0.05 %', md%freq_hz(2), 19.68_wp, rel_tol=5.0e-4_wp)
      call check('mode shape disk 1', md%shape(1, 2), 1.0_wp, rel_tol=1.0e-3_wp)
      call check('mode shape disk 2 vs 0.2353, 0.1 %', md%shape(2, 2), 0.2353_wp, rel_tol=1.0e-3_wp)
      call check('mode shape disk 3 vs -0.3449, 0.1 %', md%shape(3, 2), -0.3449_wp, rel_tol=1.0e-3_wp)
   end subroutine test_table5_1_modes_match_holzer

   subroutine test_table5_2_ideal_gear_speeds_stay_constant_and_dt_is_flagged()
      type(model_t) :: m
      type(run_result_t) :: r
      type(modes_t) :: md
      type(error_t), allocatable :: err
      call test_begin('table5_2_ideal_gear_speeds_stay_constant_and_dt_is_flagged')
      call load_model('verification/table5_2/table5_2.nml', m)
      call compute_modes(m, md, err)
      call check('modes computed', .not. allocated(err))
      ! mesh mode: omega^2 = k (r1^2/J1 + r2^2/J2)
      call check('mesh mode frequency (Hz) vs closed form', md%freq_hz(2), &
                 sqrt(18e6_wp*(1.6445_wp**2/7.5e-3_wp + 3.2890_wp**2/15e-3_wp))/two_pi, rel_tol=1.0e-10_wp)
      call check('dt is above the RK4 stability limit (the run warns)', m%run%dt > rk4_stability_limit/md%omega_max)
      call run_model(m, r)
      call check('driver speed unchanged to 1e-9', maxval(abs(r%series_omega(1, :) - 10.0_wp)), 0.0_wp, &
                 abs_tol=1.0e-8_wp)
      call check('driven speed unchanged to 1e-9', maxval(abs(r%series_omega(2, :) - 5.0_wp)), 0.0_wp, &
                 abs_tol=5.0e-9_wp)
      call check('run reached t_end', r%t_final, 0.1_wp, rel_tol=1.0e-12_wp)
   end subroutine test_table5_2_ideal_gear_speeds_stay_constant_and_dt_is_flagged

   !> Error at t_end of theta'' = -w^2 theta (a disk on a shaft to ground).
   !> t_end = 1.125 periods: not at a peak, where the O(h^4) phase error would
   !> vanish and only the O(h^5) amplitude error of RK4 would show.
   real(wp) function oscillator_error(dt) result(e)
      real(wp), intent(in) :: dt
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp), parameter :: k = (two_pi*10.0_wp)**2
      call load_model_text('&run t_end = 0.1125, dt = '//str(dt)//', track_energy = .false. /'//nl// &
                           "&node id='g', type='fixed' /"//nl//"&node id='d', type='inertia', inertia=1.0 /"//nl// &
                           "&element type='shaft', stiffness="//str(k)//' /'//nl// &
                           "&initial node='d', angle=1.0 /", m)
      call run_model(m, r)
      e = abs(r%y_final(1) - cos(sqrt(k)*0.1125_wp))
   end function oscillator_error

   subroutine test_rk4_is_fourth_order_on_single_oscillator()
      real(wp) :: e1, e2, e3
      call test_begin('rk4_is_fourth_order_on_single_oscillator')
      e1 = oscillator_error(1.25e-3_wp)
      e2 = oscillator_error(6.25e-4_wp)
      e3 = oscillator_error(3.125e-4_wp)
      call check('error ratio dt -> dt/2 is 16 +- 2', e1/e2, 16.0_wp, abs_tol=2.0_wp)
      call check('error ratio dt/2 -> dt/4 is 16 +- 2', e2/e3, 16.0_wp, abs_tol=2.0_wp)
   end subroutine test_rk4_is_fourth_order_on_single_oscillator

   subroutine test_undamped_train_conserves_energy()
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: wh, bound
      call test_begin('undamped_train_conserves_energy')
      call load_model('verification/table5_1/table5_1.nml', m)
      call run_model(m, r)
      ! RK4 on a harmonic oscillator loses (wh)^6/72 of its energy per step:
      ! bound by the highest mode (32.25 Hz), with a factor 2 margin
      wh = two_pi*32.254_wp*m%run%dt
      bound = 2.0_wp*254.0_wp*wh**6/72.0_wp
      call check('max |E - E0| / E0 within the RK4 energy drift bound '//str(bound), &
                 r%energy_residual_max/r%energy_scale, 0.0_wp, abs_tol=bound)
      call check('no dissipation recorded', r%y_final(m%n_states + 1), 0.0_wp, abs_tol=1.0e-12_wp)
   end subroutine test_undamped_train_conserves_energy

   real(wp) function damped_residual(dt) result(res)
      real(wp), intent(in) :: dt
      type(model_t) :: m
      type(run_result_t) :: r
      call load_model_text('&run t_end = 0.2, dt = '//str(dt)//' /'//nl// &
                           "&node type='inertia', inertia=5.0, damping=2.0 /"//nl// &
                           "&node type='inertia', inertia=11.0 /"//nl// &
                           "&node type='inertia', inertia=22.0, damping=5.0 /"//nl// &
                           "&element type='shaft', stiffness=1e5, damping=40.0 /"//nl// &
                           "&element type='shaft', stiffness=2e5, damping=10.0 /"//nl// &
                           "&load node='n1', kind='sine', amplitude=500.0, frequency=15.0 /"//nl// &
                           "&load node='n3', kind='ramp', value1=-200.0, t1=0.1 /"//nl// &
                           "&initial node='n1', angle=0.01, speed=1.0 /", m)
      call run_model(m, r)
      res = r%energy_residual_max/r%energy_scale
      call check('energy was dissipated', r%y_final(m%n_states + 1) > 0.0_wp)
   end function damped_residual

   subroutine test_damped_driven_train_energy_balance_closes()
      real(wp) :: r1, r2
      call test_begin('damped_driven_train_energy_balance_closes')
      r1 = damped_residual(2.0e-4_wp)
      r2 = damped_residual(1.0e-4_wp)
      ! the residual is integration error of the energy states: O(dt^4)
      call check('relative residual at dt = 2e-4 below 1e-7', r1, 0.0_wp, abs_tol=1.0e-7_wp)
      call check('residual falls ~16x when dt halves (>= 8x)', r1/max(r2, tiny(1.0_wp)) >= 8.0_wp)
   end subroutine test_damped_driven_train_energy_balance_closes

   subroutine test_branched_pinion_two_gears_matches_closed_form()
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      real(wp), parameter :: k = 2.0e5_wp, r0 = 1.0_wp, rg = 3.0_wp, j0 = 0.01_wp, jg = 0.5_wp
      real(wp) :: f_anti, f_sym
      call test_begin('branched_pinion_two_gears_matches_closed_form')
      call load_model_text('&run t_end = 0.01, dt = 1e-6 /'//nl// &
                           "&node id='p', type='inertia', inertia="//str(j0)//' /'//nl// &
                           "&node id='g1', type='inertia', inertia="//str(jg)//' /'//nl// &
                           "&node id='g2', type='inertia', inertia="//str(jg)//' /'//nl// &
                           "&element type='ideal_gear', left='p', right='g1', stiffness="//str(k)// &
                           ', rb_driver='//str(r0)//', rb_driven='//str(rg)//' /'//nl// &
                           "&element type='ideal_gear', left='p', right='g2', stiffness="//str(k)// &
                           ', rb_driver='//str(r0)//', rb_driven='//str(rg)//' /', m)
      call compute_modes(m, md, err)
      call check('modes computed', .not. allocated(err))
      f_anti = sqrt(k*rg**2/jg)/two_pi                       ! pinion still, gears opposite
      f_sym = sqrt(k*(2.0_wp*r0**2/j0 + rg**2/jg))/two_pi      ! both meshes breathe together
      call check('one rigid-body mode', md%rigid(1) .and. .not. md%rigid(2))
      call check('antisymmetric mode (Hz)', md%freq_hz(2), f_anti, rel_tol=1.0e-10_wp)
      call check('symmetric mode (Hz)', md%freq_hz(3), f_sym, rel_tol=1.0e-10_wp)
   end subroutine test_branched_pinion_two_gears_matches_closed_form

   subroutine test_star_of_shafts_matches_closed_form()
      type(model_t) :: m
      type(modes_t) :: md
      type(run_result_t) :: r
      type(error_t), allocatable :: err
      real(wp), parameter :: k = 1.0e4_wp, j0 = 2.0_wp, j = 1.0_wp
      real(wp) :: tz(64), f_meas
      integer :: n
      call test_begin('star_of_shafts_matches_closed_form')
      ! a hub driving two branches; the antisymmetric start excites only sqrt(k/J)
      call load_model_text('&run t_end = 0.5, dt = 1e-4 /'//nl// &
                           "&node id='hub', type='inertia', inertia="//str(j0)//' /'//nl// &
                           "&node id='a', type='inertia', inertia="//str(j)//' /'//nl// &
                           "&node id='b', type='inertia', inertia="//str(j)//' /'//nl// &
                           "&element type='shaft', left='hub', right='a', stiffness="//str(k)//' /'//nl// &
                           "&element type='shaft', left='hub', right='b', stiffness="//str(k)//' /'//nl// &
                           "&initial node='a', angle=0.01 /"//nl//"&initial node='b', angle=-0.01 /", m)
      call compute_modes(m, md, err)
      call check('modes computed', .not. allocated(err))
      call check('antisymmetric branch mode (Hz)', md%freq_hz(2), sqrt(k/j)/two_pi, rel_tol=1.0e-10_wp)
      call check('symmetric mode (Hz)', md%freq_hz(3), sqrt(k/j + 2.0_wp*k/j0)/two_pi, rel_tol=1.0e-10_wp)
      call run_model(m, r)
      call zero_crossings(r%series_t, r%series_theta(2, :), tz, n)
      f_meas = real(n - 1, wp)/(2.0_wp*(tz(n) - tz(1)))
      call check('simulated branch frequency (Hz), 0.05 %', f_meas, sqrt(k/j)/two_pi, rel_tol=5.0e-4_wp)
      call check('hub stays still in the antisymmetric mode', maxval(abs(r%series_theta(1, :))), 0.0_wp, &
                 abs_tol=1.0e-12_wp)
   end subroutine test_star_of_shafts_matches_closed_form
   subroutine test_rk4_is_exact_through_an_off_grid_load_step()
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp), parameter :: ts = 0.0123456_wp, te = 0.05_wp
      call test_begin('rk4_is_exact_through_an_off_grid_load_step')
      ! a free disk (J = 2) under a torque step 0 -> 10 at an instant off the dt grid:
      ! theta = (10/J)(t - ts)^2/2, a quadratic RK4 integrates exactly if no step straddles ts
      call load_model_text('&run t_end = 0.05, dt = 1e-3 /'//nl//"&node type='inertia', inertia=2.0 /"//nl// &
                           "&load node='n1', kind='step', value0=0.0, value1=10.0, t_step="//str(ts)//' /', m)
      call run_model(m, r)
      call check('angle at t_end = 2.5 (t_end - ts)^2 (exact to rounding)', r%y_final(1), 2.5_wp*(te - ts)**2, &
                 rel_tol=1.0e-12_wp)
      call check('speed at t_end = 5 (t_end - ts)', r%y_final(2), 5.0_wp*(te - ts), rel_tol=1.0e-12_wp)
      call check('energy balance exact through the jump', r%energy_residual_max/r%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-12_wp)
   end subroutine test_rk4_is_exact_through_an_off_grid_load_step
end program test_linear_verification
