!> The thesis's gear rigs (Table 5.5, Table 7.1) and the mesh-zone logic.
program test_gear_rigs
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_modes, only: modes_t, compute_modes
   use trainsim_el_spur_gear, only: mesh_zone, contact_ratio
   use trainsim_metrics, only: peak_to_peak, p2p_detector_t, peak_to_peak_values, push_samples
   use trainsim_observer, only: p2p_hysteresis
   use trainsim_sink, only: ev_zone
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, run_model
   implicit none

   call suite_begin('gear rigs (thesis 5.2.5, ch. VII) and mesh zones')
   call test_mesh_zone_periodic_matches_pascal_mode()
   call test_mesh_zone_truncate_makes_negative_angles_two_pair()
   call test_contact_ratio_of_appendix_e_gears()
   call test_ghm_mesh_frequencies_single_and_two_pair()
   call test_table7_1_natural_frequencies()
   call test_table7_1_initial_angles_are_static_windup_with_1_8()
   call test_ghm_run_energy_balance_closes_with_zone_switching()
   call test_peak_to_peak_of_a_known_signal()
   call test_online_detector_gives_the_same_figures()
   call test_online_detector_on_random_signals()
   call test_online_detector_says_when_not_exact()
   call test_online_detector_replay_over_a_full_log()
   call test_every_bundled_deck_metrics_equal_the_full_series_figures()
   call suite_end()

contains

   !> The listing's Mode function, transcribed (periodic variant: floor).
   integer function pascal_pairs(theta, n1, mp, alpha) result(pairs)
      real(wp), intent(in) :: theta, n1, mp, alpha
      real(wp) :: n, lo, hi
      n = floor(n1*(theta + alpha)/two_pi) + 1.0_wp
      lo = two_pi*(n - 2.0_wp + mp)/n1 - alpha
      hi = two_pi*n/n1 - alpha
      pairs = 2
      if (theta > lo .and. theta < hi) pairs = 1
   end function pascal_pairs

   subroutine test_mesh_zone_periodic_matches_pascal_mode()
      integer :: i, pairs, mism
      real(wp) :: th, u, ulo, uhi
      call test_begin('mesh_zone_periodic_matches_pascal_mode')
      mism = 0
      do i = -2000, 2000
         th = real(i, wp)*1.0e-3_wp + 1.234e-6_wp
         u = 32.0_wp*(th + 0.1637_wp)/two_pi
         call mesh_zone(u, 1.6676_wp, .false., pairs, ulo, uhi)
         if (pairs /= pascal_pairs(th, 32.0_wp, 1.6676_wp, 0.1637_wp)) mism = mism + 1
         if (.not. (u >= ulo .and. u <= uhi)) mism = mism + 1
      end do
      call check('zone = App. F Mode() at 4001 angles, and the angle inside its bounds', mism == 0)
      ! a tooth period holds a two-pair zone of width m_p - 1 and a single-pair zone of 2 - m_p
      call mesh_zone(0.5_wp, 1.6676_wp, .false., pairs, ulo, uhi)
      call check('u = 0.5: two pairs, zone width m_p - 1', pairs == 2 .and. abs(uhi - ulo - 0.6676_wp) < 1.0e-12_wp)
      call mesh_zone(0.9_wp, 1.6676_wp, .false., pairs, ulo, uhi)
      call check('u = 0.9: one pair, zone width 2 - m_p', pairs == 1 .and. abs(uhi - ulo - 0.3324_wp) < 1.0e-12_wp)
   end subroutine test_mesh_zone_periodic_matches_pascal_mode

   subroutine test_mesh_zone_truncate_makes_negative_angles_two_pair()
      integer :: pairs
      real(wp) :: ulo, uhi
      call test_begin('mesh_zone_truncate_makes_negative_angles_two_pair')
      call mesh_zone(-0.25_wp, 1.6676_wp, .true., pairs, ulo, uhi)
      call check('truncate: u = -0.25 is two-pair', pairs == 2)
      call mesh_zone(-0.25_wp, 1.6676_wp, .false., pairs, ulo, uhi)
      call check('periodic: u = -0.25 (phase 0.75 > m_p - 1) is single-pair', pairs == 1)
      call mesh_zone(0.75_wp, 1.6676_wp, .true., pairs, ulo, uhi)
      call check('truncate = periodic for u >= 0', pairs == 1)
   end subroutine test_mesh_zone_truncate_makes_negative_angles_two_pair

   subroutine test_contact_ratio_of_appendix_e_gears()
      call test_begin('contact_ratio_of_appendix_e_gears')
      ! 28/28 teeth, P = 8, 20 deg: Table 5.3 prints m_p = 1.6380; App. E's 1.6376
      ! comes from its base radius rounded to 1.6445 in (exact: 1.644462 in)
      call check('contact ratio vs Table 5.3 1.6380', contact_ratio(20.0_wp*two_pi/360.0_wp, 1.75_wp, 1.75_wp, &
                 0.125_wp), 1.6380_wp, abs_tol=1.0e-4_wp)
   end subroutine test_contact_ratio_of_appendix_e_gears

   subroutine test_ghm_mesh_frequencies_single_and_two_pair()
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      integer :: i
      call test_begin('ghm_mesh_frequencies_single_and_two_pair')
      call load_model('inputs/gregory_harris_munro.nml', m)
      call compute_modes(m, md, err)
      call check('modes computed', .not. allocated(err))
      ! sec. 5.2.5: 412 Hz in single-pair contact (the printed angles are single-pair)
      call check('single-pair mesh mode vs 412 Hz (thesis rounding, 0.5 %)', md%freq_hz(md%n), 412.0_wp, &
                 rel_tol=5.0e-3_wp)
      ! shift the whole train by 0.02 rad (same wind-up) into the two-pair zone
      call load_model('inputs/gregory_harris_munro.nml', m)
      do i = 1, size(m%nodes)
         m%nodes(i)%n%theta0 = m%nodes(i)%n%theta0 - 0.02_wp
      end do
      call compute_modes(m, md, err)
      call check('two-pair mesh mode (c = 1.8) vs 553 Hz (0.5 %)', md%freq_hz(md%n), 553.0_wp, rel_tol=5.0e-3_wp)
   end subroutine test_ghm_mesh_frequencies_single_and_two_pair

   subroutine test_table7_1_natural_frequencies()
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      call test_begin('table7_1_natural_frequencies')
      call load_model('inputs/two_clearance.nml', m)
      call compute_modes(m, md, err)
      call check('five free inertias (node 1 at constant speed)', md%n == 5)
      ! sec. 7.1: 2.67, 26.2, 118, 621, 632 Hz in single-pair contact. The lowest
      ! is not reproduced (2.44 Hz with node 1 held, 3.46 Hz free): docs/decisions.md D-16
      call check('mode 2 vs 26.2 Hz (0.5 %)', md%freq_hz(2), 26.2_wp, rel_tol=5.0e-3_wp)
      call check('mode 3 vs 118 Hz (0.5 %)', md%freq_hz(3), 118.0_wp, rel_tol=5.0e-3_wp)
      call check('mode 4 vs 621 Hz (0.5 %)', md%freq_hz(4), 621.0_wp, rel_tol=5.0e-3_wp)
      call check('mode 5 vs 632 Hz (0.5 %)', md%freq_hz(5), 632.0_wp, rel_tol=5.0e-3_wp)
   end subroutine test_table7_1_natural_frequencies

   subroutine test_table7_1_initial_angles_are_static_windup_with_1_8()
      real(wp) :: p, d_print, d18, d1, d2
      call test_begin('table7_1_initial_angles_are_static_windup_with_1_8')
      ! mesh 1: delta = rb (th2 - th3) from the printed angles (6 decimals: +-1e-6 rad)
      d_print = 3.7588_wp*(-0.212810_wp + 0.214203_wp)
      p = 798.8_wp/3.7588_wp                        ! mesh force under the load
      d18 = 0.005_wp + p/(1.8_wp*500000.0_wp)
      d1 = 0.005_wp + p/(1.0_wp*500000.0_wp)
      d2 = 0.005_wp + p/(2.0_wp*500000.0_wp)
      call check('printed wind-up = static deflection with c = 1.8 (print rounding 3.76e-6 in)', d_print, d18, &
                 abs_tol=2.0_wp*3.7588_wp*1.0e-6_wp)
      call check('and not with c = 1', abs(d_print - d1) > 1.0e-4_wp)
      call check('and not with c = 2', abs(d_print - d2) > 2.0e-5_wp)
   end subroutine test_table7_1_initial_angles_are_static_windup_with_1_8

   subroutine test_ghm_run_energy_balance_closes_with_zone_switching()
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: i, nz
      call test_begin('ghm_run_energy_balance_closes_with_zone_switching')
      call load_model('inputs/gregory_harris_munro.nml', m)
      call run_model(m, r)
      nz = 0
      do i = 1, size(r%events)
         if (r%events(i)%kind == ev_zone) nz = nz + 1
      end do
      ! 485 teeth/s for 0.02 s: two zone changes per tooth, ~19 of them
      call check('zone changes ~ 2 x 485 x 0.02 (+-2)', real(nz, wp), 2.0_wp*485.0_wp*0.02_wp, abs_tol=2.0_wp)
      call check('energy balance closes to 1e-12 of the energy scale', r%energy_residual_max/r%energy_scale, 0.0_wp, &
                 abs_tol=1.0e-12_wp)
   end subroutine test_ghm_run_energy_balance_closes_with_zone_switching

   subroutine test_peak_to_peak_of_a_known_signal()
      real(wp) :: t(2001), x(2001), rng, mean
      integer :: i, n
      call test_begin('peak_to_peak_of_a_known_signal')
      do i = 1, size(t)
         t(i) = real(i - 1, wp)*1.0e-3_wp
         ! 2 Hz swing of amplitude 1 plus a 0.05 ripple at 40 Hz (not peaks)
         x(i) = sin(two_pi*2.0_wp*t(i)) + 0.05_wp*sin(two_pi*40.0_wp*t(i))
      end do
      call peak_to_peak(t, x, 0.0_wp, 0.1_wp, rng, mean, n)
      call check('four full swings in 2 s at 2 Hz', n == 4)
      call check('mean swing = 2 x amplitude (+ripple, 0.05 %)', mean, 2.0_wp, abs_tol=0.1_wp + 1.0e-3_wp)
      call check('range = max - min', rng, maxval(x) - minval(x), rel_tol=1.0e-14_wp)
   end subroutine test_peak_to_peak_of_a_known_signal

   !> The online peak detector (O(1) memory) gives the figures of the whole
   !> series, bit for bit (what lets a run keep memory independent of length).
   subroutine test_online_detector_gives_the_same_figures()
      real(wp) :: t(4001), x(4001), r1, m1, r2, m2
      integer :: i, n1, n2
      type(p2p_detector_t) :: det
      call test_begin('online_detector_gives_the_same_figures')
      do i = 1, size(t)
         t(i) = real(i - 1, wp)*1.0e-3_wp
         ! swings of growing amplitude (the threshold rises all along), a
         ! ripple, and a plateau (repeated values)
         x(i) = (1.0_wp + t(i))*sin(two_pi*2.0_wp*t(i)) + 0.05_wp*sin(two_pi*40.0_wp*t(i))
         if (i > 1500 .and. i < 1600) x(i) = x(1500)
      end do
      call peak_to_peak(t, x, 0.0_wp, 0.1_wp, r1, m1, n1)
      det%hyst = 0.1_wp
      do i = 1, size(t)
         call det%push(x(i))
      end do
      call det%figures(r2, m2, n2)
      call check('same swing count ('//trim(adjustl(itoa(n1)))//')', n1 == n2 .and. n1 > 0)
      call check('same range, to the bit', r1 == r2)
      call check('same mean swing, to the bit', m1 == m2)
      call check('the detector says its figures are exact', det%exact)
   end subroutine test_online_detector_gives_the_same_figures

   !> 3000 random signals: random walks, noisy sines of growing amplitude and
   !> noise with late bursts (2 to 400 samples: the range grows after short
   !> edges, so the detector re-runs over its logged extremes), and long sines
   !> of slowly growing amplitude (2000 to 6000 samples, up to ~1900 extremes:
   !> the log folds its older half). Whenever the detector says `exact`, its
   !> figures are those of peak_to_peak_values on the whole signal, to the bit;
   !> with fewer extremes than the log holds it is always exact.
   subroutine test_online_detector_on_random_signals()
      integer, parameter :: n_sig = 3000
      real(wp) :: x(6000), u(6000), r1, m1, r2, m2, a
      integer :: k, i, n, n1, n2, n_exact, n_bad, n_short_inexact, n_long, n_replayed, n_differ
      integer, allocatable :: seed(:)
      type(p2p_detector_t) :: det, dets(2)
      call test_begin('online_detector_on_random_signals')
      call random_seed(size=n)
      allocate (seed(n))
      seed = 20261123
      call random_seed(put=seed)
      n_exact = 0; n_bad = 0; n_short_inexact = 0; n_long = 0; n_replayed = 0; n_differ = 0
      do k = 1, n_sig
         call random_number(u)
         call random_number(a)
         n = 2 + int(a*398.0_wp)
         select case (mod(k, 4))
         case (0)   ! random walk: the range grows now and then, by steps of any size
            x(1) = 0.0_wp
            do i = 2, n
               x(i) = x(i - 1) + (u(i) - 0.5_wp)
            end do
         case (1)   ! growing sine plus noise
            do i = 1, n
               x(i) = (1.0_wp + 0.01_wp*i)*sin(0.3_wp*i) + 0.3_wp*(u(i) - 0.5_wp)
            end do
         case (2)   ! noise with rare bursts: the range jumps late
            do i = 1, n
               x(i) = u(i) - 0.5_wp
               if (u(i) > 0.97_wp) x(i) = 8.0_wp*(u(i) - 0.96_wp)*merge(1, -1, mod(i, 2) == 0)
            end do
         case default   ! long: more extremes than the log holds
            n = 2000 + int(a*4000.0_wp)
            n_long = n_long + 1
            do i = 1, n
               x(i) = (1.0_wp + 1.0e-4_wp*i)*sin(1.1_wp*i) + 0.3_wp*(u(i) - 0.5_wp)
            end do
         end select
         det = p2p_detector_t(hyst=0.1_wp)
         dets = p2p_detector_t(hyst=0.1_wp)
         do i = 1, n
            call det%push(x(i))
            call push_samples(dets, [x(i), -x(i)])   ! the observer's way, one sample per detector
         end do
         if (.not. same_state(det, dets(1))) n_differ = n_differ + 1
         det = p2p_detector_t(hyst=0.1_wp)
         do i = 1, n
            call det%push(-x(i))
         end do
         if (.not. same_state(det, dets(2))) n_differ = n_differ + 1
         det = p2p_detector_t(hyst=0.1_wp)
         do i = 1, n
            call det%push(x(i))
         end do
         call det%figures(r2, m2, n2)
         call peak_to_peak_values(x(1:n), 0.1_wp, r1, m1, n1)
         if (det%replays > 0) n_replayed = n_replayed + 1
         if (det%exact) then
            n_exact = n_exact + 1
            if (.not. (r1 == r2 .and. m1 == m2 .and. n1 == n2)) n_bad = n_bad + 1
         else if (n <= 400) then
            n_short_inexact = n_short_inexact + 1
         end if
      end do
      write (*, '(a,i0,a,i0,a,i0,a,i0,a)') '    ', n_exact, ' of ', n_sig, ' signals exact (', n_long, &
         ' long ones), ', n_replayed, ' re-run over the log'
      call check('every signal the detector calls exact has the whole-series figures, to the bit', n_bad == 0)
      call check('every short signal is exact (fewer extremes than the log holds)', n_short_inexact == 0)
      call check('the re-run was exercised (> 100 signals)', n_replayed > 100)
      call check('the long signals are exact too (folded edges far above the threshold)', n_exact == n_sig)
      call check('push_samples (the observer''s path) leaves each detector as det_push does, to the bit', n_differ == 0)
   end subroutine test_online_detector_on_random_signals

   !> Two detectors in the same state, every field to the bit.
   logical function same_state(a, b) result(same)
      type(p2p_detector_t), intent(in) :: a, b
      same = a%n == b%n .and. a%x1 == b%x1 .and. a%xmin == b%xmin .and. a%xmax == b%xmax .and. a%h == b%h .and. &
             (a%exact .eqv. b%exact) .and. a%e_min == b%e_min .and. a%e_min_f == b%e_min_f .and. &
             a%n_log == b%n_log .and. a%replays == b%replays
      ! the detector now and its folded part
      same = same .and. a%s%dir == b%s%dir .and. a%s%cand == b%s%cand .and. a%s%last_ext == b%s%last_ext .and. &
             (a%s%have_max .eqv. b%s%have_max) .and. a%s%last_max == b%s%last_max .and. a%s%total == b%s%total .and. &
             a%s%n_swings == b%s%n_swings
      same = same .and. a%f%dir == b%f%dir .and. a%f%cand == b%f%cand .and. a%f%last_ext == b%f%last_ext .and. &
             (a%f%have_max .eqv. b%f%have_max) .and. a%f%last_max == b%f%last_max .and. a%f%total == b%f%total .and. &
             a%f%n_swings == b%f%n_swings
      if (same .and. a%n_log > 0) same = all(a%log(1:a%n_log) == b%log(1:b%n_log))
   end function same_state

   !> Swings of 1 for 3000 samples (more extremes than the log holds), then the
   !> range grows to 20 (threshold 2): the swings already folded would not be
   !> swings with the final threshold. The detector cannot re-decide them
   !> without the series, and says so.
   subroutine test_online_detector_says_when_not_exact()
      type(p2p_detector_t) :: det
      real(wp) :: x(3001), r1, m1, r2, m2
      integer :: i, n1, n2
      call test_begin('online_detector_says_when_not_exact')
      do i = 1, 3000
         x(i) = merge(1.0_wp, 0.0_wp, mod(i, 2) == 0)
      end do
      x(3001) = 20.0_wp
      det%hyst = 0.1_wp
      do i = 1, size(x)
         call det%push(x(i))
      end do
      call det%figures(r2, m2, n2)
      call peak_to_peak_values(x, 0.1_wp, r1, m1, n1)
      call check('whole series: no swing of 2 or more', n1 == 0)
      call check('online: swings of 1 were counted', n2 > 0)
      call check('and the detector says its figures are not exact', .not. det%exact)
      call check('the range is exact all the same', r1 == r2)
   end subroutine test_online_detector_says_when_not_exact

   !> The replay when the log is full (issue 20, item 11): short edges early
   !> (0.3 against a range of 2), folded away by a long square wave; then, at
   !> a moment the log holds p2p_log_size extremes, a sample that widens the
   !> range to 3.2 (threshold 0.32 > 0.3). The replay from the folded state
   !> confirms that state's own running extreme too: one extreme more than the
   !> log held. (Before, it was written past the log's end: Debug named
   !> d%log(513), a long Release run ended in SIGSEGV.)
   subroutine test_online_detector_replay_over_a_full_log()
      type(p2p_detector_t) :: det
      real(wp), allocatable :: x(:)
      real(wp) :: r1, m1, r2, m2
      integer :: i, n1, n2, n_full
      logical :: hit
      call test_begin('online_detector_replay_over_a_full_log')
      x = [-1.0_wp, 1.0_wp, 0.7_wp, 1.0_wp, 0.7_wp, 1.0_wp]   ! edges of 0.3, confirmed with h = 0.2
      det%hyst = 0.1_wp
      do i = 1, size(x)
         call det%push(x(i))
      end do
      hit = .false.; n_full = 0
      do i = 1, 4000   ! a square wave of +-1: one extreme confirmed per sample
         x = [x, merge(-1.0_wp, 1.0_wp, mod(i, 2) == 1)]
         call det%push(x(size(x)))
         if (det%n_log == size(det%log) .and. det%n > size(det%log) + 100) then
            n_full = det%n_log
            hit = .true.
            exit
         end if
      end do
      call check('the log was folded and is full again', hit)
      x = [x, -2.2_wp]
      call det%push(x(size(x)))
      call check('the replay kept the log within its size', det%n_log <= size(det%log) .and. det%replays > 0)
      call check('... with every extreme it held (folded, not dropped)', det%n_log >= n_full/2)
      do i = 1, 600   ! and it goes on: the wave between -2.2 and 1
         x = [x, merge(-2.2_wp, 1.0_wp, mod(i, 2) == 1)]
         call det%push(x(size(x)))
      end do
      call det%figures(r2, m2, n2)
      call peak_to_peak_values(x, 0.1_wp, r1, m1, n1)
      call check('the range is the whole series one (3.2)', r2 == r1 .and. abs(r2 - 3.2_wp) < 1.0e-12_wp)
      call check('the detector says its figures are not exact (a folded edge of 0.3 is below 0.32)', &
                 .not. det%exact)
      call check('its mean swing is a swing of the signal (2 or 3.2)', abs(m2 - 2.0_wp) < 1.0e-12_wp .or. &
                 abs(m2 - 3.2_wp) < 1.0e-12_wp .or. (m2 > 2.0_wp .and. m2 < 3.2_wp))
   end subroutine test_online_detector_replay_over_a_full_log

   !> Every bundled deck, every element: the p2p figures of the run take the
   !> extremes between output samples (D-48), so p2p_range is at least the range
   !> of the samples and of the step ends (disp_max - disp_min, from the same
   !> t_metrics on), and exceeds the latter by no more than an extreme can lie
   !> past the step ends around it: (w dt)^2/8 of the amplitude for a mode at w,
   !> below 1e-2 for any RK4 run that resolves its modes (w dt < 0.28, 22 steps
   !> a period; the largest here, 1.1e-3, is the branched train's). The swings
   !> are those of the samples' own detector where the samples resolve them
   !> (every element but the ones printed). The detector says
   !> its figures are exact (D-17) on every deck, start-up runs whose range grows
   !> for a long time included (dc motor, start-stop, helical pair).
   subroutine test_every_bundled_deck_metrics_equal_the_full_series_figures()
      character(len=*), parameter :: decks(*) = [character(len=40) :: 'inputs/branched_train.nml', &
         'inputs/dc_motor_geared_load.nml', 'inputs/gregory_harris_munro.nml', 'inputs/helical_pair.nml', &
         'inputs/loads_table_ramp.nml', 'inputs/start_stop_two_clearances.nml', 'inputs/two_clearance.nml', &
         'verification/chapter3/case1.nml', 'verification/chapter3/case2.nml', 'verification/chapter3/case3.nml', &
         'verification/table5_1/table5_1.nml', 'verification/table5_4/table5_4.nml']
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: rng, mean, step_rng, worst
      integer :: k, i, n, n_el, n_swung, n_same_swings
      logical :: bounded, exact
      call test_begin('every_bundled_deck_p2p_between_samples_and_step_ends')
      n_el = 0; n_swung = 0; n_same_swings = 0; bounded = .true.; exact = .true.; worst = 0.0_wp
      do k = 1, size(decks)
         call load_model(trim(decks(k)), m)
         call run_model(m, r)   ! keeps the series
         do i = 1, size(r%el)
            call peak_to_peak(r%series_t, r%series_disp(i, :), m%run%t_start + m%run%settle_time, p2p_hysteresis, &
                              rng, mean, n)
            step_rng = r%el(i)%disp_max - r%el(i)%disp_min
            n_el = n_el + 1
            if (r%el(i)%p2p_swings > 0) n_swung = n_swung + 1
            if (n == r%el(i)%p2p_swings) n_same_swings = n_same_swings + 1
            if (step_rng > 0.0_wp) worst = max(worst, (r%el(i)%p2p_range - step_rng)/step_rng)
            if (.not. (r%el(i)%p2p_range >= rng .and. r%el(i)%p2p_range >= step_rng .and. &
                       r%el(i)%p2p_range <= step_rng*(1.0_wp + 1.0e-2_wp))) then
               bounded = .false.
               write (*, '(a,i0,a,3es24.16)') '    '//trim(decks(k))//' element ', i, ': ', r%el(i)%p2p_range, &
                  step_rng, rng
            end if
            if (n /= r%el(i)%p2p_swings) write (*, '(a,i0,a,i0,a,i0,a)') '    '//trim(decks(k))//' element ', i, &
               ': ', r%el(i)%p2p_swings, ' swings, the samples ', n, ' (resolved between samples)'
            exact = exact .and. r%el(i)%p2p_exact
         end do
      end do
      write (*, '(a,i0,a,i0,a,i0,a,es10.3)') '    ', n_el, ' elements, ', n_swung, ' with swings, ', n_same_swings, &
         ' with the samples'' swing count; largest p2p_range past the step ends: ', worst
      call check('p2p range between the samples'' and 1e-2 past the step ends'' range', bounded .and. n_swung >= 20)
      call check('the swings of the samples on all but a few elements', n_same_swings >= n_el - 3)
      call check('the detector says its figures are exact (p2p_exact)', exact)
   end subroutine test_every_bundled_deck_metrics_equal_the_full_series_figures

   function itoa(i) result(s)
      integer, intent(in) :: i
      character(len=16) :: s
      write (s, '(i0)') i
   end function itoa
end program test_gear_rigs
