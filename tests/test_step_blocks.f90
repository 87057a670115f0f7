!> Plain steps in blocks (docs/decisions.md D-38): RK4 takes its plain steps in
!> blocks and the observer folds each block's columns afterwards, wherever no
!> step but the output times' needs a whole sample. That is a second path to
!> the same numbers, so it must give them bit for bit: every deck that ships
!> with trainsim (and the benchmark's rig and a long chain), with energy
!> tracking off and on, with output every step, every 7th step and as written,
!> and metrics starting half-way, is run three times:
!> - step by step (run%step_blocks off), keeping the in-memory series: the reference;
!> - with blocks, a null sink and no series (samples never whole);
!> - with blocks, keeping the series (whole samples at the output times, filled
!>   from the workspace of a block's last step);
!> every metric of every element, the event table, the energy ledger, the final
!> state, the counters and the series must equal the reference's (==, not within
!> a tolerance). Most runs must have taken most of their steps in blocks (else
!> this compares the step-by-step path with itself), the reference none. A run
!> that fails (a deck whose state runs away) must fail alike, with the same message.
!> A sink that reads the speeds only (as a sweep run's) and keeps every sample's
!> time and speeds: test_step_blocks checks that blocks hand it the same samples.
module step_blocks_sink
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_sink, only: sink_t, sample_t, run_meta_t, event_t, run_stats_t, element_metrics_t
   implicit none
   private
   public :: speeds_sink_t

   type, extends(sink_t) :: speeds_sink_t
      integer :: n = 0
      real(wp), allocatable :: t(:), w(:, :)
   contains
      procedure :: open => ss_open
      procedure :: write_sample => ss_sample
      procedure :: close => ss_close
      procedure :: speeds_only => ss_speeds_only
   end type speeds_sink_t

contains

   subroutine ss_open(self, meta, err)
      class(speeds_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      self%n = 0
      allocate (self%t(1024), self%w(size(meta%node_ids), 1024))
   end subroutine ss_open

   subroutine ss_sample(self, s, err)
      class(speeds_sink_t), intent(inout) :: self
      type(sample_t), intent(in) :: s
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: t2(:), w2(:, :)
      if (self%n == size(self%t)) then
         allocate (t2(2*self%n), w2(size(self%w, 1), 2*self%n))
         t2(1:self%n) = self%t
         w2(:, 1:self%n) = self%w
         call move_alloc(t2, self%t)
         call move_alloc(w2, self%w)
      end if
      self%n = self%n + 1
      self%t(self%n) = s%t
      self%w(:, self%n) = s%omega
   end subroutine ss_sample

   subroutine ss_close(self, events, stats, metrics, err)
      class(speeds_sink_t), intent(inout) :: self
      type(event_t), intent(in) :: events(:)
      type(run_stats_t), intent(in) :: stats
      type(element_metrics_t), intent(in) :: metrics(:)
      type(error_t), allocatable, intent(out) :: err
      associate (unused_s => self, unused_e => events, unused_t => stats, unused_m => metrics)
      end associate
   end subroutine ss_close

   pure logical function ss_speeds_only(self) result(only)
      class(speeds_sink_t), intent(in) :: self
      associate (unused => self)
      end associate
      only = .true.
   end function ss_speeds_only
end module step_blocks_sink

program test_step_blocks
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_simulate, only: simulate
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, load_model_text, nl
   use step_blocks_sink, only: speeds_sink_t
   implicit none

   character(len=*), parameter :: decks(*) = [character(len=48) :: &
                                  'inputs/two_clearance.nml', 'inputs/gregory_harris_munro.nml', &
                                  'inputs/start_stop_two_clearances.nml', 'inputs/branched_train.nml', &
                                  'inputs/dc_motor_geared_load.nml', 'inputs/helical_pair.nml', &
                                  'inputs/loads_table_ramp.nml', 'verification/table5_1/table5_1.nml', &
                                  'verification/table5_2/table5_2.nml', 'verification/table5_3/table5_3.nml', &
                                  'verification/table5_4/table5_4.nml', 'verification/chapter3/case1.nml', &
                                  'verification/chapter3/case2.nml', 'verification/chapter3/case3.nml', &
                                  'tests/decks/tracker_si_start_stop.nml', 'tests/decks/cvode_zone_late_table5_5_285.nml', &
                                  'tests/decks/cvode_zone_late_table7_1_640.nml', 'tests/decks/runaway_at_safe_dt.nml']
   integer :: i, n_blocked, n_blocked_series

   call suite_begin('step blocks (D-38): the same numbers as step by step')
   n_blocked = 0
   n_blocked_series = 0
   do i = 1, size(decks)
      call test_begin(trim(decks(i)))
      call deck_variants(trim(decks(i)), '')
   end do
   call test_begin('the Table 5.5 rig with backlash (26 thousand events in 2e6 steps: 0.05 s of it)')
   call deck_variants('', rig_text())
   call test_begin('a 120-node chain with a backlash gear every 10th element (local event steps)')
   call deck_variants('', chain_text(120))
   call test_begin('a sweep run''s sink (speeds only) gets the same samples, each once')
   call speeds_samples()
   call test_begin('blocks were taken')
   write (*, '(a,i0,a,i0,a,i0,a)') '  runs that took most of their steps in blocks: ', n_blocked, ' of ', &
      6*(size(decks) + 2), ' without the series, ', n_blocked_series, ' with it'
   ! 12 of the 20 trains are simple models (constant loads, plain inertias or nodes
   ! held at a constant speed: model_t%block_ok), 72 runs in their 6 variants; a
   ! run whose gear spends much of it in a mode without a hot form steps singly
   call check('most runs of a simple model took blocks', n_blocked >= 60)
   ! (the 12 simple trains with output every 7th step, energy off and on, at least)
   call check('runs keeping the series took blocks too (output every 7th step, or as written)', n_blocked_series >= 24)
   call suite_end()

contains

   !> The deck in its variants: as written; output every step; every 7th step
   !> with the metrics from half-way; each with energy tracking off and on.
   subroutine deck_variants(path, text)
      character(len=*), intent(in) :: path, text
      integer :: v, e
      do v = 1, 3
         do e = 0, 1
            call compare(path, text, v, e == 1)
         end do
      end do
   end subroutine deck_variants

   !> The deck in one variant: step by step (the reference, keeping the series),
   !> then with blocks and no series (the null-sink path: samples not whole) and
   !> with blocks and the series (whole samples at the output times).
   subroutine compare(path, text, variant, energy)
      character(len=*), intent(in) :: path, text
      integer, intent(in) :: variant
      logical, intent(in) :: energy
      type(model_t) :: base, m
      type(run_result_t) :: ref, a, c
      type(error_t), allocatable :: err_ref, err_a, err_c
      character(len=:), allocatable :: what
      if (len(path) > 0) then
         call load_model(path, base)
      else
         call load_model_text(text, base)
      end if
      base%run%integrator = 'rk4'   ! (the blocks are RK4's; a CVODE deck's dt is RK4-safe too)
      base%run%track_energy = energy
      select case (variant)
      case (2)
         base%run%output_interval = base%run%dt
      case (3)
         base%run%output_interval = 7.0_wp*base%run%dt
         base%run%settle_time = 0.5_wp*(base%run%t_end - base%run%t_start)
      end select
      call base%finalize()
      what = trim(merge('as written   ', 'every step   ', variant == 1))
      if (variant == 3) what = 'every 7th, metrics from half-way'
      what = what//merge(', energy on ', ', energy off', energy)//': '
      m = base
      call run(m, .false., .true., ref, err_ref)
      m = base
      call run(m, .true., .false., a, err_a)
      m = base
      call run(m, .true., .true., c, err_c)
      call check(what//'no blocks when switched off', ref%stats%block_steps == 0)
      if (a%stats%block_steps > a%stats%steps/2) n_blocked = n_blocked + 1
      if (c%stats%block_steps > c%stats%steps/2) n_blocked_series = n_blocked_series + 1
      call same_run(what//'blocks, no series: ', a, err_a, ref, err_ref, .false.)
      call same_run(what//'blocks, series: ', c, err_c, ref, err_ref, .true.)
   end subroutine compare

   !> Run r (with error er) the same as the reference ref (err_ref), bit for bit;
   !> series: its series too.
   subroutine same_run(label, r, er, ref, err_ref, series)
      character(len=*), intent(in) :: label
      type(run_result_t), intent(in) :: r, ref
      type(error_t), allocatable, intent(in) :: er, err_ref
      logical, intent(in) :: series
      integer :: j
      call check(label//'both runs succeed or both fail', allocated(er) .eqv. allocated(err_ref))
      if (allocated(er) .or. allocated(err_ref)) then
         if (allocated(er) .and. allocated(err_ref)) call check(label//'the same error', er%message == err_ref%message)
         return
      end if
      call check(label//'same steps, RHS evaluations, events', r%stats%steps == ref%stats%steps .and. &
                 r%stats%rhs_evals == ref%stats%rhs_evals .and. r%stats%events == ref%stats%events)
      call check(label//'same final time and state', r%t_final == ref%t_final .and. all(r%y_final == ref%y_final))
      call check(label//'same energy ledger', r%energy_residual_max == ref%energy_residual_max .and. &
                 r%energy_scale == ref%energy_scale)
      call check(label//'same event table', same_events(r, ref))
      do j = 1, size(r%el)
         associate (p => r%el(j), q => ref%el(j))
            call check(label//'element '//str(j)//': same extremes', p%force_min == q%force_min .and. &
                       p%force_max == q%force_max .and. p%torque_min == q%torque_min .and. &
                       p%torque_max == q%torque_max .and. p%disp_min == q%disp_min .and. p%disp_max == q%disp_max)
            call check(label//'element '//str(j)//': same impacts, peaks, time out of contact', &
                       p%impacts == q%impacts .and. p%separations == q%separations .and. &
                       p%zone_changes == q%zone_changes .and. p%max_approach_velocity == q%max_approach_velocity .and. &
                       p%max_peak_force == q%max_peak_force .and. p%time_out_of_contact == q%time_out_of_contact)
            call check(label//'element '//str(j)//': same peak-to-peak figures', p%p2p_range == q%p2p_range .and. &
                       p%p2p_mean == q%p2p_mean .and. p%p2p_swings == q%p2p_swings .and. &
                       (p%p2p_exact .eqv. q%p2p_exact))
         end associate
      end do
      if (.not. series) return
      call check(label//'same series (times, displacements, angles, speeds)', &
                 size(r%series_t) == size(ref%series_t) .and. all(r%series_t == ref%series_t) .and. &
                 all(r%series_disp == ref%series_disp) .and. all(r%series_theta == ref%series_theta) .and. &
                 all(r%series_omega == ref%series_omega))
   end subroutine same_run

   !> The rig with backlash (an event every 77 steps), output every step, to a
   !> sink that reads the speeds only: with blocks (the samples from the
   !> block's columns) it gets the samples step by step gets, the same times
   !> and speeds, each once (one per output time, and the start).
   subroutine speeds_samples()
      type(model_t) :: base, m
      type(speeds_sink_t) :: sa, sb
      type(run_result_t) :: ra, rb
      type(error_t), allocatable :: ea, eb
      integer :: n_out
      call load_model_text(rig_text(), base)
      base%run%output_interval = 0.0_wp
      m = base
      m%run%step_blocks = .false.
      call simulate(m, sb, rb, eb)
      m = base
      call simulate(m, sa, ra, ea)
      call check('both runs succeed', .not. (allocated(ea) .or. allocated(eb)))
      if (allocated(ea) .or. allocated(eb)) return
      call check('blocks taken', ra%stats%block_steps > ra%stats%steps/2 .and. rb%stats%block_steps == 0)
      n_out = nint((base%run%t_end - base%run%t_start)/base%run%dt)
      call check('one sample per output time and the start ('//str(n_out + 1)//'), got '//str(sa%n)//' and '// &
                 str(sb%n), sa%n == n_out + 1 .and. sb%n == n_out + 1)
      if (sa%n /= sb%n) return
      call check('the same sample times', all(sa%t(1:sa%n) == sb%t(1:sb%n)))
      call check('the sample times increase', all(sa%t(2:sa%n) > sa%t(1:sa%n - 1)))
      call check('the same speeds', all(sa%w(:, 1:sa%n) == sb%w(:, 1:sb%n)))
   end subroutine speeds_samples

   !> The two event tables equal, row by row.
   logical function same_events(a, b) result(same)
      type(run_result_t), intent(in) :: a, b
      integer :: k
      same = size(a%events) == size(b%events)
      if (.not. same) return
      do k = 1, size(a%events)
         associate (p => a%events(k), q => b%events(k))
            same = p%t == q%t .and. p%element == q%element .and. p%kind == q%kind .and. &
                   p%peak_force == q%peak_force .and. p%duration == q%duration .and. &
                   p%approach_velocity == q%approach_velocity .and. p%force == q%force .and. &
                   p%displacement == q%displacement
         end associate
         if (.not. same) return
      end do
   end function same_events

   !> One run with a null sink; blocks: plain steps in blocks (run%step_blocks);
   !> series: keep the in-memory series (whole samples at the output times).
   subroutine run(model, blocks, series, res, err)
      type(model_t), intent(inout) :: model
      logical, intent(in) :: blocks, series
      type(run_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      type(null_sink_t) :: none
      model%run%step_blocks = blocks
      model%run%keep_series = series
      model%run%keep_events = .true.
      call simulate(model, none, res, err)
   end subroutine run

   !> bench_rk4_throughput's rig with the spur gear (Table 5.5), 0.05 s.
   function rig_text() result(text)
      character(len=:), allocatable :: text
      text = "&run t_end = 0.05, dt = 8.0e-6, integrator = 'rk4' /"//nl// &
             "&node id = 'n1', type = 'inertia', inertia = 100.0 /"//nl// &
             "&node id = 'n2', type = 'inertia', inertia = 0.987 /"//nl// &
             "&node id = 'n3', type = 'inertia', inertia = 0.987 /"//nl// &
             "&node id = 'n4', type = 'inertia', inertia = 100.0 /"//nl// &
             "&element id = 'e1', type = 'shaft', stiffness = 32000.0 /"//nl// &
             "&element id = 'e2', type = 'spur_gear', stiffness = 234500.0, rb_driver = 3.7588, "// &
             'rb_driven = 3.7588, teeth = 32, contact_ratio = 1.6676, approach_angle = 0.1637, '// &
             'half_backlash = 0.005 /'//nl// &
             "&element id = 'e3', type = 'shaft', stiffness = 32000.0 /"//nl// &
             "&initial node = 'all', speed = 80.0 /"//nl// &
             "&initial node = 'n1', angle = -0.187847 /"//nl// &
             "&initial node = 'n2', angle = -0.212810 /"//nl// &
             "&initial node = 'n3', angle = -0.214283 /"//nl// &
             "&initial node = 'n4', angle = -0.239246 /"//nl// &
             "&load node = 'n1', quantity = 'speed', kind = 'constant', value = 80.0 /"//nl// &
             "&load node = 'n4', kind = 'constant', value = -798.8 /"
   end function rig_text

   !> bench_rk4_throughput's chain: n unit inertias, shafts of stiffness 1e4, a
   !> spur gear with half backlash 1e-3 as every 10th element; node 1 starts at
   !> 1 rad/s, the others at rest (a wave runs down the chain and back).
   function chain_text(n) result(text)
      integer, intent(in) :: n
      character(len=:), allocatable :: text
      integer :: k
      text = "&run t_end = 0.5, dt = 5.0e-3, integrator = 'rk4' /"//nl
      do k = 1, n
         text = text//"&node id = 'n"//str(k)//"', type = 'inertia', inertia = 1.0 /"//nl
      end do
      do k = 1, n - 1
         if (mod(k, 10) == 0) then
            text = text//"&element id = 'e"//str(k)//"', type = 'spur_gear', stiffness = 1.0e4, "// &
                   'rb_driver = 1.0, rb_driven = 1.0, teeth = 32, contact_ratio = 1.6, approach_angle = 0.1, '// &
                   'half_backlash = 1.0e-3 /'//nl
         else
            text = text//"&element id = 'e"//str(k)//"', type = 'shaft', stiffness = 1.0e4 /"//nl
         end if
      end do
      text = text//"&initial node = 'n1', speed = 1.0 /"
   end function chain_text

end program test_step_blocks
