!> A run is a library call on a model object with no global state (the sweeps
!> to come rely on it): repeated and interleaved runs in one process give
!> bit-identical results, copies are independent, and HDF5 histories can be
!> written run after run from one process.
program test_library_runs
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t, observer_t
   use trainsim_integrator, only: integrator_t, adv_event, adv_reached
   use trainsim_integrator_registry, only: make_integrator
   use trainsim_run_stats, only: run_stats_t
   use trainsim_simulate, only: simulate
   use trainsim_hdf5, only: hdf5_sink_t
   use trainsim_sink, only: null_sink_t, element_metrics_t, event_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, run_model
   implicit none

   call suite_begin('runs as library calls (no global state)')
   call test_interleaved_runs_are_bit_identical()
   call test_copies_are_independent()
   call test_many_hdf5_histories_from_one_process()
   call test_metrics_do_not_depend_on_who_takes_the_samples()
   call test_short_way_of_the_observer_equals_the_whole_sample()
   call test_restart_after_the_caller_changed_the_state()
   call suite_end()

contains

   logical function same(a, b)
      type(run_result_t), intent(in) :: a, b
      integer :: i
      same = size(a%events) == size(b%events) .and. all(a%y_final == b%y_final)
      if (.not. same) return
      do i = 1, size(a%events)
         same = same .and. a%events(i)%t == b%events(i)%t .and. &
                a%events(i)%approach_velocity == b%events(i)%approach_velocity
      end do
      do i = 1, size(a%el)
         same = same .and. a%el(i)%torque_max == b%el(i)%torque_max .and. a%el(i)%p2p_mean == b%el(i)%p2p_mean
      end do
   end function same

   subroutine test_interleaved_runs_are_bit_identical()
      type(model_t) :: ghm, key, m
      type(run_result_t) :: r1, r2, rk, rc
      call test_begin('interleaved_runs_are_bit_identical')
      call load_model('inputs/gregory_harris_munro.nml', ghm)
      call load_model('verification/table5_4/table5_4.nml', key)
      m = ghm; call run_model(m, r1)
      m = key; call run_model(m, rk)
      m = ghm; m%run%integrator = 'cvode-bdf'; call run_model(m, rc)
      m = ghm; call run_model(m, r2)
      call check('GHM run, then other runs and integrators, then GHM again: identical to the bit', same(r1, r2))
      call check('the keyed-joint run in between had its own single impact', rk%el(1)%impacts == 1)
   end subroutine test_interleaved_runs_are_bit_identical

   subroutine test_copies_are_independent()
      type(model_t) :: base, fast
      type(run_result_t) :: r0, r1, rf
      integer :: i
      call test_begin('copies_are_independent')
      call load_model('inputs/gregory_harris_munro.nml', base)
      call run_model(base, r0)
      ! re-parameterise a copy: another mesh frequency (as a sweep would)
      fast = base
      do i = 1, size(fast%nodes)
         fast%nodes(i)%n%omega0 = two_pi*300.0_wp/32.0_wp
      end do
      fast%speeds(1)%f%value0 = two_pi*300.0_wp/32.0_wp
      call run_model(fast, rf)
      call run_model(base, r1)
      call check('the copy ran at its own speed', abs(rf%y_final(2) - r0%y_final(2)) > 1.0_wp)
      call check('the original is untouched by running the copy', same(r0, r1))
   end subroutine test_copies_are_independent

   subroutine test_many_hdf5_histories_from_one_process()
      type(model_t) :: base, m
      type(run_result_t) :: r
      type(hdf5_sink_t) :: h5
      type(error_t), allocatable :: err
      character(len=64) :: path
      integer :: k, ok, u, ios
      logical :: exists
      call test_begin('many_hdf5_histories_from_one_process')
      call load_model('verification/table5_3/table5_3.nml', base)
      ok = 0
      do k = 1, 20
         m = base
         write (path, '(a,i0,a)') '/tmp/trainsim_library_run_', k, '.h5'
         h5%path = trim(path)
         call simulate(m, h5, r, err)
         if (allocated(err)) exit
         inquire (file=trim(path), exist=exists)
         if (exists .and. r%stats%events == 2) ok = ok + 1
         open (newunit=u, file=trim(path), iostat=ios)
         if (ios == 0) close (u, status='delete')
      end do
      call check('20 runs in one process each wrote a complete history', ok == 20)
   end subroutine test_many_hdf5_histories_from_one_process

   !> D-34: on a fixed-step run the observer folds the metrics straight from
   !> the model's workspace and builds a sample only when someone takes it
   !> (a sink that stores samples, keep_series). The two-clearance deck (two
   !> backlash gears, shafts, impacts and separations; settle_time so that the
   !> metrics start mid-run) with an output every step and every 3rd step:
   !> the null sink (no sample built), an HDF5 file with keep_series (every
   !> sample whole) and a run with energy tracking (two more states, the
   !> energies folded each step) give the same metrics, p2p figures and event
   !> table, to the bit. (The short way against the whole sample at each step:
   !> test_short_way_of_the_observer_equals_the_whole_sample.)
   subroutine test_metrics_do_not_depend_on_who_takes_the_samples()
      type(model_t) :: base, m
      type(run_result_t) :: r_null, r_file, r_long
      type(hdf5_sink_t) :: h5
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      character(len=*), parameter :: path = '/tmp/trainsim_library_samples_taken.h5'
      integer :: every, u, ios, n_states
      logical :: ok_file, ok_long
      call test_begin('metrics_do_not_depend_on_who_takes_the_samples')
      call load_model('inputs/two_clearance.nml', base)
      base%run%settle_time = 0.3_wp*(base%run%t_end - base%run%t_start)
      base%run%keep_events = .true.
      base%run%track_energy = .false.   ! (the deck tracks it: that takes the long way)
      call base%finalize()
      n_states = base%n_states
      do every = 1, 3, 2
         base%run%output_interval = real(every, wp)*base%run%dt
         m = base
         call simulate(m, none, r_null, err)
         call check('null sink: the run completes', .not. allocated(err))
         if (allocated(err)) return
         m = base
         m%run%keep_series = .true.
         h5%path = path
         call simulate(m, h5, r_file, err)
         call check('HDF5 file and keep_series: the run completes', .not. allocated(err))
         if (allocated(err)) return
         open (newunit=u, file=path, iostat=ios)
         if (ios == 0) close (u, status='delete')
         m = base
         m%run%track_energy = .true.
         call m%finalize()
         call simulate(m, none, r_long, err)
         call check('energy tracking: the run completes', .not. allocated(err))
         if (allocated(err)) return
         ok_file = same_run(r_null, r_file, n_states)
         ok_long = same_run(r_null, r_long, n_states)
         call check('output every '//merge('step    ', '3rd step', every == 1)//': file + keep_series = null sink, '// &
                    'to the bit', ok_file)
         call check('output every '//merge('step    ', '3rd step', every == 1)//': energy tracked = '// &
                    'null sink, to the bit', ok_long)
      end do
      call check('the deck exercises the metrics: impacts on both gears, swings counted', &
                 all(r_null%el(2:4:2)%impacts > 0) .and. all(r_null%el(2:4:2)%p2p_swings > 0) .and. &
                 size(r_null%events) > 10)
   end subroutine test_metrics_do_not_depend_on_who_takes_the_samples

   !> D-34 at the level of one step: two copies of the two-clearance deck (energy
   !> tracked, settle_time mid-run) advanced by RK4 side by side up to the first
   !> event, each step given to an observer. Observer A takes the short way
   !> (the model's workspace holds the RHS at the step's end, at a located event
   !> too: D-146); for observer B
   !> the mark is cleared first, so it fills the whole sample (recomputing the
   !> kinematics, torques and statuses) and folds it as before. The metrics and
   !> the energy balance figures are the same to the bit; so are, at every
   !> step, the sample's displacements and energies (D-36: A reads the gears'
   !> statuses and the stored energy the RHS kernel left in the workspace).
   subroutine test_short_way_of_the_observer_equals_the_whole_sample()
      type(model_t) :: ma, mb
      class(integrator_t), allocatable :: ia, ib
      type(observer_t) :: oa, ob
      type(null_sink_t), target :: sa, sb
      type(run_result_t) :: ra, rb
      type(run_stats_t) :: stats
      type(error_t), allocatable :: err
      real(wp), allocatable :: ya(:), yb(:)
      real(wp) :: ta, tb, t_goal
      integer :: k, sta, stb, n_short, n_steps, n_events, n_ws
      logical :: same_y, same_s
      call test_begin('short_way_of_the_observer_equals_the_whole_sample')
      call load_model('inputs/two_clearance.nml', ma)
      call check('the deck tracks the energy', ma%run%track_energy)
      ma%run%settle_time = 0.002_wp
      mb = ma
      call begin_run(ma, ia, oa, sa, ta, ya, err)
      if (allocated(err)) return
      call begin_run(mb, ib, ob, sb, tb, yb, err)
      if (allocated(err)) return
      n_short = 0; n_steps = 0; n_events = 0; same_y = .true.; same_s = .true.; n_ws = 0
      do k = 1, 200
         t_goal = ma%run%t_start + real(k, wp)*ma%run%dt
         do   ! to the grid point, through the events on the way
            call ia%advance(ma, t_goal, ta, ya, sta, err)
            if (allocated(err)) exit
            call ib%advance(mb, t_goal, tb, yb, stb, err)
            if (allocated(err)) exit
            n_steps = n_steps + 1
            same_y = same_y .and. ta == tb .and. all(ya == yb) .and. sta == stb
            if (ma%ws_step_end) n_short = n_short + 1
            if (ma%ws_step_end .and. ma%ws_energy .and. any(ma%ws_status .and. .not. ma%status_in_ws)) n_ws = n_ws + 1
            call oa%step(ma, ta, ya)
            mb%ws_step_end = .false.   ! the long way: the whole sample, recomputed
            call ob%step(mb, tb, yb)
            same_s = same_s .and. all(oa%s%displacement == ob%s%displacement) .and. all(oa%s%energy == ob%s%energy)
            if (sta /= adv_event) exit
            n_events = n_events + 1
            call settle(ma, ia, oa, ta, ya, err)
            if (allocated(err)) exit
            call settle(mb, ib, ob, tb, yb, err)
            if (allocated(err)) exit
         end do
         if (allocated(err)) exit
      end do
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      write (*, '(a,i0,a,i0,a,i0,a)') '    ', n_steps, ' steps, ', n_short, ' the short way, ', n_events, ' events'
      call check('steps on both sides of settle_time and events among them; every step the short way for A, '// &
                 'the located events too (D-146)', &
                 n_steps - n_events > nint(ma%run%settle_time/ma%run%dt) + 10 .and. n_events > 2 .and. &
                 n_short == n_steps)
      call check('the two copies step alike, to the bit', same_y)
      call check('D-36: the short way read the gears'' statuses and the stored energy from the workspace', &
                 n_ws == n_short)
      call check('each step: displacements and energies of the two samples equal to the bit', same_s)
      call oa%finish(ma, ta, ya, stats, sa, ra, err)
      call ob%finish(mb, tb, yb, stats, sb, rb, err)
      call check('metrics (extremes, p2p, time out of contact) equal to the bit', same_run(ra, rb, ma%n_states))
      call check('energy balance figures equal to the bit', ra%energy_residual_max == rb%energy_residual_max .and. &
                 ra%energy_scale == rb%energy_scale .and. ra%energy_scale > 0.0_wp)
   end subroutine test_short_way_of_the_observer_equals_the_whole_sample

   !> D-37: RK4 reuses the RHS at the last step's end as the next step's first
   !> stage; a caller that changes the state between two advances calls
   !> `restart`, which then drops it. Three copies of the two-clearance deck
   !> step alike to t1; the state is then nudged in all three: A calls
   !> restart, B clears the model's workspace mark (the first stage
   !> recomputed, as after a mode change), C does neither (the contract
   !> broken: the old first stage is used). After the next steps A is B to the
   !> bit, and C is not (the check has something to catch).
   subroutine test_restart_after_the_caller_changed_the_state()
      type(model_t) :: ma, mb, mc
      class(integrator_t), allocatable :: ia, ib, ic
      type(observer_t) :: oa, ob, oc
      type(null_sink_t), target :: sa, sb, sc
      type(error_t), allocatable :: err
      real(wp), allocatable :: ya(:), yb(:), yc(:)
      real(wp) :: ta, tb, tc, t_goal
      integer :: k, st
      call test_begin('restart_after_the_caller_changed_the_state')
      call load_model('inputs/two_clearance.nml', ma)
      mb = ma
      mc = ma
      call begin_run(ma, ia, oa, sa, ta, ya, err)
      if (allocated(err)) return
      call begin_run(mb, ib, ob, sb, tb, yb, err)
      if (allocated(err)) return
      call begin_run(mc, ic, oc, sc, tc, yc, err)
      if (allocated(err)) return
      do k = 1, 6
         t_goal = ma%run%t_start + real(k, wp)*ma%run%dt
         call ia%advance(ma, t_goal, ta, ya, st, err)
         call check('A: a plain step to the grid point', st == adv_reached .and. .not. allocated(err))
         call ib%advance(mb, t_goal, tb, yb, st, err)
         call ic%advance(mc, t_goal, tc, yc, st, err)
         if (k == 3) then
            ya(2) = ya(2)*1.001_wp
            yb(2) = yb(2)*1.001_wp
            yc(2) = yc(2)*1.001_wp
            call ia%restart(ma, ta, ya, err)
            mb%ws_step_end = .false.
         end if
      end do
      call check('the nudge is not zero', ya(2) /= 0.0_wp)
      call check('restart after the change = the first stage recomputed, to the bit', &
                 ta == tb .and. all(ya == yb))
      call check('without restart the old first stage is used (the state differs)', any(yc /= yb))
   end subroutine test_restart_after_the_caller_changed_the_state

   !> The modes settled at an event, as the driver does, and RK4 restarted.
   subroutine settle(m, integ, obs, t, y, err)
      type(model_t), intent(inout) :: m
      class(integrator_t), intent(inout) :: integ
      type(observer_t), intent(inout) :: obs
      real(wp), intent(in) :: t
      real(wp), intent(inout) :: y(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: g(:)
      logical, allocatable :: fired(:)
      type(event_t), allocatable :: ev(:)
      integer :: pass, nev
      allocate (g(m%n_guards), fired(m%n_guards), ev(64))
      do pass = 1, 16
         call m%guards(t, y, g)
         fired = g < 0.0_wp
         if (.not. any(fired)) exit
         nev = 0
         call m%apply_events(t, y, fired, ev, nev)
         call obs%record_events(m, t, y, ev, nev, err)
         if (allocated(err)) return
      end do
      call integ%restart(m, t, y, err)
   end subroutine settle

   !> As simulate starts a run: RK4 and the observer at (t_start, initial state).
   subroutine begin_run(m, integ, obs, sink, t, y, err)
      type(model_t), intent(inout) :: m
      class(integrator_t), allocatable, intent(out) :: integ
      type(observer_t), intent(inout) :: obs
      type(null_sink_t), intent(inout), target :: sink
      real(wp), intent(out) :: t
      real(wp), allocatable, intent(out) :: y(:)
      type(error_t), allocatable, intent(out) :: err
      call make_integrator('rk4', integ)
      t = m%run%t_start
      call m%initial_state(y)
      call m%init_modes(t, y)
      call integ%set_stop(m%run%t_end, .false.)
      call integ%start(m, t, y, err)
      if (.not. allocated(err)) call obs%start(m, t, y, sink, err)
      call check('start', .not. allocated(err))
   end subroutine begin_run

   !> Same final physical state, metrics and event table, to the bit.
   logical function same_run(a, b, n_states) result(same)
      type(run_result_t), intent(in) :: a, b
      integer, intent(in) :: n_states
      integer :: i
      same = all(a%y_final(1:n_states) == b%y_final(1:n_states)) .and. size(a%el) == size(b%el) .and. &
             size(a%events) == size(b%events)
      if (.not. same) return
      do i = 1, size(a%el)
         same = same .and. same_metrics(a%el(i), b%el(i))
      end do
      do i = 1, size(a%events)
         same = same .and. same_event(a%events(i), b%events(i))
      end do
   end function same_run

   logical function same_metrics(a, b) result(same)
      type(element_metrics_t), intent(in) :: a, b
      same = a%force_min == b%force_min .and. a%force_max == b%force_max .and. a%torque_min == b%torque_min .and. &
             a%torque_max == b%torque_max .and. a%disp_min == b%disp_min .and. a%disp_max == b%disp_max .and. &
             a%impacts == b%impacts .and. a%separations == b%separations .and. a%zone_changes == b%zone_changes .and. &
             a%max_approach_velocity == b%max_approach_velocity .and. a%max_peak_force == b%max_peak_force .and. &
             a%time_out_of_contact == b%time_out_of_contact .and. a%p2p_range == b%p2p_range .and. &
             a%p2p_mean == b%p2p_mean .and. a%p2p_swings == b%p2p_swings .and. (a%p2p_exact .eqv. b%p2p_exact)
   end function same_metrics

   logical function same_event(a, b) result(same)
      type(event_t), intent(in) :: a, b
      same = a%t == b%t .and. a%element == b%element .and. a%kind == b%kind .and. &
             a%approach_velocity == b%approach_velocity .and. a%peak_force == b%peak_force .and. &
             a%duration == b%duration .and. a%theta_left == b%theta_left .and. a%omega_left == b%omega_left .and. &
             a%theta_right == b%theta_right .and. a%omega_right == b%omega_right .and. &
             a%displacement == b%displacement .and. a%force == b%force
   end function same_event
end program test_library_runs
