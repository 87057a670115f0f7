!> A run as a library call: model in, metrics and events out (in memory), histories to
!> whatever sink the caller passes. No global state: any number of runs per process, on
!> copies of one model. `simulate` holds the one driver loop every integrator runs in.
!> The integrator (trainsim_integrator) only advances the state; the loop owns
!> - the output grid: sample k at t_start + k*output_interval (the last at t_end), from k;
!> - the breakpoints of the inputs (load steps, table knots, duty cycles): the
!>   integrator's stop times, with a restart after each;
!> - the events: `settle_events` updates the modes at an instant until no guard fires,
!>   then the integrator restarts;
!> - the checks after every advance: a state that blew up, an interrupt, and the
!>   event budget (an event flood ends the run instead of hanging it).
module trainsim_simulate
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_internal, err_numeric, err_interrupted
   use trainsim_interrupt, only: signal_caught
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_event, only: event_t, ev_name
   use trainsim_sink, only: sink_t
   use trainsim_run_stats, only: run_stats_t
   use trainsim_observer, only: observer_t, run_result_t
   use trainsim_quasi_static, only: static_reference
   use trainsim_integrator, only: integrator_t, adv_step, adv_reached, adv_event
   use trainsim_integrator_registry, only: make_integrator
   use trainsim_progress, only: progress_t
   use trainsim_settle, only: settle_t, settle_setup, settle_sample, settle_kmax
   use trainsim_run_checks, only: check_fixed_step, check_state, check_physical, check_ledger, displacement_bounds, &
                                  blowup_limit, guard_owner, is_fixed_step, remedy, window_text, modes_kept
   implicit none
   private

   public :: simulate, blowup_limit, max_events_per_dt, max_settle_passes, settle_kmax, check_fixed_step
   !> for a run advanced by its caller (trainsim_session): the loop's set-up and its advance
   public :: drive_t, drive_setup, advance_to

   !> More events than this inside one dt is a flood: a contact that chatters
   !> faster than the step can resolve (a run past its stability limit).
   integer, parameter :: max_events_per_dt = 200
   !> Passes of the mode update at one instant before it counts as not settling.
   integer, parameter :: max_settle_passes = 16

   !> The loop's own bookkeeping (allocated once per run).
   type :: drive_t
      real(wp), allocatable :: g(:), bp(:)
      logical, allocatable :: fired(:)
      type(event_t), allocatable :: ev(:)
      integer :: ibp = 1                   !< next breakpoint
      real(wp) :: tol = 0.0_wp             !< times closer than this are one instant
      real(wp) :: t_window = 0.0_wp        !< start of the current event-budget window
      integer :: window_events = 0         !< events since t_window
      !> the last event recorded (element, kind), named by an event flood: a
      !> settle that took several passes leaves only its last pass in ev
      integer :: last_element = 0, last_kind = 0
      integer :: last_guard = 0            !< the first guard that fired at the last event instant
      logical :: may_miss = .false.        !< integ%may_miss_events(), asked once per run
      !> plain steps in blocks (D-38): the integrator takes them, and the
      !> observer's short way folds them (no peak refinement; whole samples at
      !> the output times only, from the workspace of a block's last step)
      logical :: blocks = .false.
      !> blocks, and the output times are the integrator's grid (output_interval = dt)
      logical :: block_samples = .false.
      !> per element: the largest |displacement| a physical run reaches (element%displacement_bound,
      !> D-55), checked at the output times; taken at each drive_setup unless kept (a session, D-173)
      real(wp), allocatable :: disp_bound(:)
      logical :: bounds_kept = .false.
      real(wp) :: t_ledger = -1.0_wp   !< first output time the energy residual exceeded run%energy_check (-1: not yet)
   end type drive_t

contains

   !> Integrate `model` from t_start to t_end with its integrator.
   !> On error the sink is aborted (no partial output left as if good), except
   !> an interrupt (SIGINT/SIGTERM) with `keep_interrupted`: the sink is then
   !> closed with what was computed (the samples up to the last output time
   !> reached, the events so far, the metrics of that span), its run statistics
   !> saying `completed = .false.`, and `result` holds that part of the run
   !> (result%stats%t_final: the time reached; result%t_sampled: the last
   !> output time written); `err` is still the interrupt. With `progress`, the
   !> driver reports to it once per output time or block of steps.
   subroutine simulate(model, sink, result, err, keep_interrupted, progress, step_checked, tables_built)
      type(model_t), intent(inout), target :: model
      class(sink_t), intent(inout), target :: sink   ! the observer streams the event rows to it
      type(run_result_t), intent(out) :: result
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: keep_interrupted
      type(progress_t), intent(inout), optional :: progress
      logical, intent(in), optional :: step_checked   !< the caller ran check_fixed_step on this model (D-82)
      logical, intent(in), optional :: tables_built   !< its fast-path tables are its parameters' (D-114)
      type(error_t), allocatable :: err_close
      type(observer_t) :: obs
      type(run_stats_t) :: stats
      class(integrator_t), allocatable, target :: integ
      real(wp), allocatable :: y(:)
      real(wp) :: t, t_end_deck
      integer(i8) :: c0, c1, rate
      type(settle_t) :: settle
      logical :: checked, fresh

      call system_clock(c0, rate)
      call make_integrator(model%run%integrator, integ)
      if (.not. allocated(integ)) then
         call fatal_error(err, "internal: integrator '"//model%run%integrator//"' is not in the registry", err_internal)
         return
      end if
      integ%region_instants = .true.   ! advance_to works on the region alone at local event instants
      checked = .false.; fresh = .false.
      if (present(step_checked)) checked = step_checked
      if (present(tables_built)) fresh = tables_built   ! (finalize's tables: not built again)
      if (.not. checked) call check_fixed_step(model, err)
      if (allocated(err)) return
      t = model%run%t_start
      call static_reference(model, obs%qs)   ! each gear mesh's static force and TE, for Kv (D-103)
      call model%initial_state(y)
      ! the modes the step check set at this state, unless anything changed them since (D-183)
      if (.not. (fresh .and. modes_kept(model, t, y))) call model%init_modes(t, y, tables=.not. fresh)
      obs%refine_peaks = .not. is_fixed_step(model%run%integrator)
      ! settling until periodic: the integrator and the loop run to the latest end the
      ! budget allows; the loop ends the run a measured window after the settling
      t_end_deck = model%run%t_end
      call settle_setup(model, settle, err)
      if (allocated(err)) return
      call obs%start(model, t, y, sink, err)
      if (present(progress)) call progress%start(t, model%run%t_end)
      if (.not. allocated(err)) call drive(model, integ, obs, sink, t, y, settle, err, progress)
      if (present(progress)) call progress%finish()
      model%run%t_end = t_end_deck
      call integ%statistics(stats)
      stats%t_metrics = obs%t_metrics
      stats%settle_status = settle%status
      stats%settle_k = settle%k
      if (settle%on) stats%settle_periods = settle%j
      if (settle%check_only) stats%settle_status = stats%settle_status + 2   ! 3 settled, 4 not (at settle_time)
      call integ%finish()
      call system_clock(c1)
      stats%wall_time = real(c1 - c0, wp)/real(rate, wp)
      if (allocated(err)) then
         if (err%code == err_interrupted .and. obs%started) then
            if (present(keep_interrupted)) then
               if (keep_interrupted) then
                  ! what was computed, closed as a run that did not complete
                  call obs%finish(model, t, y, stats, sink, result, err_close, interrupted=.true.)
                  if (allocated(err_close)) then
                     call sink%abort()
                     err%message = err%message//'; the history could not be kept: '//err_close%message
                  end if
                  return
               end if
            end if
         end if
         call sink%abort()
         return
      end if
      call obs%finish(model, t, y, stats, sink, result, err)
      if (allocated(err)) call sink%abort()
   end subroutine simulate

   !> The driver loop: from (t, y) at t_start to t_end.
   subroutine drive(model, integ, obs, sink, t, y, st, err, progress)
      type(model_t), intent(inout), target :: model
      class(integrator_t), intent(inout), target :: integ
      type(observer_t), intent(inout) :: obs
      class(sink_t), intent(inout) :: sink
      real(wp), intent(inout) :: t
      real(wp), intent(inout), contiguous :: y(:)
      type(settle_t), intent(inout) :: st
      type(error_t), allocatable, intent(out) :: err
      type(progress_t), intent(inout), optional :: progress   !< polled per output time or block
      type(drive_t) :: d
      real(wp) :: t0, t_end, dout, t_out, x, n_real
      integer(i8) :: k, n_out, k_last
      integer :: j
      logical :: folded

      t0 = model%run%t_start
      t_end = model%run%t_end
      dout = model%run%output_interval
      if (.not. dout > 0.0_wp) dout = model%run%dt
      ! output times t0 + k dout, k = 1 .. n_out, the last one moved to t_end
      x = max((t_end - t0)/dout - 1.0e-6_wp, 0.0_wp)
      n_real = aint(x)
      if (x > n_real) n_real = n_real + 1.0_wp
      n_out = int(min(max(n_real, 1.0_wp), 9.0e18_wp), i8)
      call drive_setup(model, integ, obs, d, dout, t_end, t, y, err)
      if (allocated(err)) return

      if (st%on) then   ! sample 0: the start
         call settle_sample(model, obs, sink, st, t, y, t_end)
         if (st%done) call end_moved()
      end if

      k = 1
      do while (k <= n_out)
         if (st%on .and. .not. st%done) then
            ! the next settle instant before the next output time: advance to it
            if (st%t_next <= out_time(k) + d%tol) then
               ! (an instant within the tolerance of the output time is that time)
               t_out = st%t_next
               if (abs(t_out - out_time(k)) <= d%tol) t_out = out_time(k)
               call advance_to(model, integ, obs, d, t_out, t_end, t, y, err)
               if (allocated(err)) return
               call settle_sample(model, obs, sink, st, t, y, t_end)
               if (st%done) call end_moved()
               cycle
            end if
         end if
         if (d%block_samples .and. k < n_out .and. t < out_time(k) - d%tol) then
            ! plain steps in blocks (D-38), each step's end an output time:
            ! k .. k_last at most (not the last, t_end, which may lie off the grid
            ! by less than the instant tolerance), nor past the next settle instant
            k_last = min(k + int(model%blk%cap, i8) - 1, n_out - 1)
            if (st%on .and. .not. st%done) then
               do while (k_last >= k .and. out_time(k_last) > st%t_next - d%tol)
                  k_last = k_last - 1
               end do
            end if
            folded = .false.
            if (k_last >= k) call run_block(model, integ, obs, d, min(out_time(k_last), integ%t_stop), .true., t, y, folded, err)
            if (allocated(err)) return
            if (k_last >= k .and. folded) then
               ! steps on output times k, k + 1, ... (none the last): the first and last checked (D-161)
               do j = 1, model%blk%n, max(model%blk%n - 1, 1)
                  if (model%blk%t(j) /= t0 + real(k + j - 1, wp)*dout) then
                     call fatal_error(err, 'internal: a step of a block ended at t = '//str(model%blk%t(j))// &
                                      ' s, off the output time '//str(out_time(k + j - 1))//' s', err_internal)
                     return
                  end if
               end do
               k = k + model%blk%n
               call check_physical(model, obs, d%disp_bound, d%t_ledger, t, err)
               if (allocated(err)) return
               if (present(progress)) call progress%poll(t, obs%n_events)
               cycle
            end if
         end if
         t_out = out_time(k)
         call advance_to(model, integ, obs, d, t_out, t_end, t, y, err)
         if (allocated(err)) return
         if (abs(t - t_out) > d%tol) then
            ! a sample is the solution at its own time, never a later state (D-49)
            call fatal_error(err, "internal: integrator '"//model%run%integrator//"' left the state at t = "// &
                             str(t)//' s for the output time '//str(t_out)//' s', err_internal)
            return
         end if
         call obs%sample(model, t_out, t, y, sink, err)
         if (allocated(err)) return
         call check_physical(model, obs, d%disp_bound, d%t_ledger, t, err)
         if (allocated(err)) return
         if (present(progress)) call progress%poll(t, obs%n_events)
         k = k + 1
      end do
      t = t_end
      call check_ledger(model, obs, d%t_ledger, t, err)
   contains
      !> The settling moved t_end (earlier than the budget's end): the output times
      !> up to the new t_end, the last one moved to it.
      subroutine end_moved()
         x = max((t_end - t0)/dout - 1.0e-6_wp, 0.0_wp)
         n_real = aint(x)
         if (x > n_real) n_real = n_real + 1.0_wp
         n_out = max(int(min(max(n_real, 1.0_wp), 9.0e18_wp), i8), k)
         model%run%t_end = t_end
         call set_next_stop(d, integ, t, t_end)
      end subroutine end_moved
      !> Output time k: t0 + k dout, the last one t_end.
      real(wp) function out_time(kk) result(tk)
         integer(i8), intent(in) :: kk
         tk = t0 + real(kk, wp)*dout
         if (kk == n_out) tk = t_end
      end function out_time
   end subroutine drive

   !> The loop's set-up at (t, y): its bookkeeping d, the breakpoints of the
   !> inputs up to t_end, the integrator started, a guard already below zero at
   !> t settled. dout: the interval of the output times (blocks of plain steps
   !> when the observer's samples allow them, D-38).
   subroutine drive_setup(model, integ, obs, d, dout, t_end, t, y, err)
      type(model_t), intent(inout), target :: model
      class(integrator_t), intent(inout), target :: integ
      type(observer_t), intent(inout) :: obs
      type(drive_t), intent(inout) :: d
      real(wp), intent(in) :: dout, t_end, t
      real(wp), intent(inout) :: y(:)
      type(error_t), allocatable, intent(out) :: err
      ! one instant: 1e-9 dt, never below 4 ulp of the run's times (a breakpoint one ulp off)
      d%tol = max(1.0e-9_wp*model%run%dt, 4.0_wp*spacing(max(abs(model%run%t_start), abs(t_end))))
      d%t_window = t
      d%may_miss = integ%may_miss_events()
      ! blocks when no step but the output times' needs a whole sample: the
      ! samples are not taken whole, or there are steps between output times
      ! (a block then ends on each output time, where the sample is filled from
      ! the workspace of its last step)
      d%blocks = integ%takes_blocks .and. model%run%step_blocks .and. .not. (d%may_miss .or. obs%refine_peaks) .and. &
                 (.not. obs%want_whole .or. dout /= model%run%dt)
      d%block_samples = d%blocks .and. dout == model%run%dt .and. .not. obs%want_whole
      if (allocated(d%g)) deallocate (d%g, d%fired, d%ev)
      allocate (d%g(model%n_guards), d%fired(model%n_guards), d%ev(64))
      if (.not. (d%bounds_kept .and. allocated(d%disp_bound))) call displacement_bounds(model, d%disp_bound)
      d%ibp = 1
      call model%breakpoints(t, t_end, d%bp)
      call set_next_stop(d, integ, t, t_end)
      call integ%start(model, t, y, err)
      if (allocated(err)) return
      ! a guard already negative at t_start: settle it before the first step
      call settle_if_fired(model, integ, obs, d, t, y, .false., err)
   end subroutine drive_setup

   !> Plain steps toward t_goal in a block (D-38), if the integrator and the
   !> model's modes allow one (folded: it took steps; the observer has folded
   !> them; with `samples`, each step's end is an output time, sampled by the
   !> fold: `drive`'s blocks of output times, d%block_samples). The state is
   !> checked after the block (the integrator stops a block at a step beyond
   !> the blow-up limit), and the interrupt flag.
   subroutine run_block(model, integ, obs, d, t_goal, samples, t, y, folded, err)
      type(model_t), intent(inout), target :: model
      class(integrator_t), intent(inout), target :: integ
      type(observer_t), intent(inout) :: obs
      type(drive_t), intent(in) :: d
      real(wp), intent(in) :: t_goal
      logical, intent(in) :: samples
      real(wp), intent(inout) :: t
      real(wp), intent(inout), contiguous :: y(:)
      logical, intent(out) :: folded
      type(error_t), allocatable, intent(out) :: err
      folded = .false.
      if (.not. model%block_ok()) return
      call integ%advance_block(model, t_goal, d%tol, blowup_limit, t, y)
      if (model%blk%n == 0) return
      folded = .true.
      if (.not. within_limit(y)) then
         call check_state(model, integ, t, y, err)
         return
      end if
      call obs%fold_block(model, samples, err)
      if (allocated(err)) return
      if (signal_caught /= 0) call fatal_error(err, 'interrupted at t = '//str(t)//' s', err_interrupted)
   end subroutine run_block

   !> Advance (t, y) to the output time t_out: through the breakpoints of the
   !> inputs and the events on the way, checking the state after every step.
   subroutine advance_to(model, integ, obs, d, t_out, t_end, t, y, err)
      type(model_t), intent(inout), target :: model
      class(integrator_t), intent(inout), target :: integ
      type(observer_t), intent(inout) :: obs
      type(drive_t), intent(inout) :: d
      real(wp), intent(in) :: t_out, t_end
      real(wp), intent(inout) :: t
      real(wp), intent(inout), contiguous :: y(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: t_goal
      integer :: status
      integer, pointer, contiguous :: r_nodes(:), r_states(:), r_els(:), r_gels(:)
      logical :: local, folded
      do
         t_goal = min(t_out, integ%t_stop)
         if (t_goal - t > d%tol) then
            if (d%blocks) then
               call run_block(model, integ, obs, d, t_goal, .false., t, y, folded, err)
               if (allocated(err)) return
               if (folded) cycle
            end if
            call integ%advance(model, t_goal, t, y, status, err)
            if (allocated(err)) return
            ! a local event instant (D-32): only the region's states are
            ! integration points at t; the rest of the train is checked and
            ! observed at the end of its step
            local = .false.
            if (status == adv_event) local = integ%local_instant(r_nodes, r_states, r_els, r_gels)
            if (local) then
               call check_state(model, integ, t, y, err, r_states)
            else if (.not. within_limit(y)) then
               call check_state(model, integ, t, y, err)
            end if
            if (allocated(err)) return
            if (signal_caught /= 0) then   ! SIGINT/SIGTERM: stop at this step
               call fatal_error(err, 'interrupted at t = '//str(t)//' s', err_interrupted)
               return
            end if
            if (local) then
               call obs%step_part(model, t, y, r_nodes, r_els)
               call settle_local(model, integ, obs, d, t, y, r_nodes, r_els, r_gels, err)
               if (allocated(err)) return
               cycle
            end if
            call obs%step(model, t, y)
            if (status == adv_event) then
               call settle_if_fired(model, integ, obs, d, t, y, .true., err)
               if (allocated(err)) return
               cycle
            end if
            if (status == adv_step) cycle
         end if
         ! t_goal reached: a breakpoint of the inputs, or the output time
         if (integ%stop_is_breakpoint .and. t_goal >= integ%t_stop - d%tol) then
            d%ibp = d%ibp + 1
            call set_next_stop(d, integ, t, t_end)
            call settle_if_fired(model, integ, obs, d, t, y, .false., err, force_restart=.true.)
            if (allocated(err)) return
         else if (d%may_miss) then
            ! a guard below zero that the integrator did not report (safety net)
            call settle_if_fired(model, integ, obs, d, t, y, .false., err)
            if (allocated(err)) return
         end if
         if (t_goal >= t_out - d%tol) return
      end do
   end subroutine advance_to

   !> The next stop of the integrator: the next breakpoint after t, else t_end.
   subroutine set_next_stop(d, integ, t, t_end)
      type(drive_t), intent(inout) :: d
      class(integrator_t), intent(inout) :: integ
      real(wp), intent(in) :: t, t_end
      do while (d%ibp <= size(d%bp))
         if (d%bp(d%ibp) > t + d%tol) exit
         d%ibp = d%ibp + 1
      end do
      if (d%ibp <= size(d%bp)) then
         call integ%set_stop(d%bp(d%ibp), .true.)
      else
         call integ%set_stop(t_end, .false.)
      end if
   end subroutine set_next_stop

   !> Settle the modes at (t, y) if any guard fired (`from_integrator`: the
   !> integrator returned an event and says which guards it saw cross), then
   !> restart the integrator; with force_restart, restart even without events.
   subroutine settle_if_fired(model, integ, obs, d, t, y, from_integrator, err, force_restart)
      type(model_t), intent(inout), target :: model
      class(integrator_t), intent(inout), target :: integ
      type(observer_t), intent(inout) :: obs
      type(drive_t), intent(inout) :: d
      real(wp), intent(in) :: t
      real(wp), intent(inout) :: y(:)
      logical, intent(in) :: from_integrator
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: force_restart
      logical :: restart
      integer :: nev
      restart = .false.
      if (present(force_restart)) restart = force_restart
      if (model%n_guards > 0) then
         call model%guards(t, y, d%g)
         if (from_integrator) then
            call integ%fired(d%g, d%fired)
         else
            d%fired = d%g < 0.0_wp
         end if
         if (any(d%fired)) then
            d%last_guard = findloc(d%fired, .true., 1)
            call settle_events(model, obs, d, t, y, nev, err)
            if (allocated(err)) return
            call count_events(model, d, t, nev, err)
            if (allocated(err)) return
            restart = .true.
         end if
      end if
      if (restart) call integ%restart(model, t, y, err)
   end subroutine settle_if_fired

   !> `settle_if_fired` at a local event instant (D-32): the guards of the
   !> region's guard elements gels alone (the integrator saw no other below
   !> zero at t), their mode updates and cascades, the observer on the
   !> region's nodes and elements (both nodes among `nodes`) alone. The same
   !> events as `settle_if_fired` would find at this state.
   subroutine settle_local(model, integ, obs, d, t, y, nodes, els, gels, err)
      type(model_t), intent(inout), target :: model
      class(integrator_t), intent(inout), target :: integ
      type(observer_t), intent(inout) :: obs
      type(drive_t), intent(inout) :: d
      real(wp), intent(in) :: t
      real(wp), intent(inout) :: y(:)
      integer, intent(in) :: nodes(:), els(:), gels(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: pass, nev, n_total, j
      if (.not. region_fired()) return
      d%last_guard = j
      n_total = 0
      do pass = 1, max_settle_passes
         nev = 0
         call model%apply_events(t, y, d%fired, d%ev, nev, gels)
         call obs%record_events(model, t, y, d%ev, nev, err, nodes, els)
         if (allocated(err)) return
         call keep_last_event(d, nev)
         n_total = n_total + nev
         if (.not. region_fired()) exit
      end do
      if (pass > max_settle_passes) then
         call fatal_error(err, 'the modes did not settle at t = '//str(t)//' s: after '//str(max_settle_passes)// &
                          ' passes of the mode update, a guard of '//guard_owner(model, j)// &
                          ' is still below zero; the state there is not consistent with any contact state '// &
                          '(a runaway state). '//remedy(model), err_numeric)
         return
      end if
      call count_events(model, d, t, n_total, err)
      if (allocated(err)) return
      call integ%restart(model, t, y, err)
   contains
      !> The guards of gels at (t, y) into d%g, d%fired; j: the first that fired.
      logical function region_fired() result(any_fired)
         integer :: k, e, o, n
         any_fired = .false.
         j = 0
         do k = 1, size(gels)
            e = gels(k)
            o = model%guard_offset(e)
            n = model%elements(e)%e%n_guards()
            call model%element_guards(e, t, y, d%g(o + 1:o + n))
            d%fired(o + 1:o + n) = d%g(o + 1:o + n) < 0.0_wp
            if (j == 0 .and. any(d%fired(o + 1:o + n))) j = o + findloc(d%fired(o + 1:o + n), .true., 1)
         end do
         any_fired = j > 0
      end function region_fired
   end subroutine settle_local

   !> The one routine that settles the events at an instant: update the modes
   !> of the elements whose guards fired (d%fired on entry), record the events,
   !> and repeat while a guard of the new modes is below zero (cascades: a zone
   !> change and a contact at once). Every event is kept (the buffer grows); a
   !> cascade that does not settle is an error, not a silent drop.
   subroutine settle_events(model, obs, d, t, y, n_total, err)
      type(model_t), intent(inout) :: model
      type(observer_t), intent(inout) :: obs
      type(drive_t), intent(inout) :: d
      real(wp), intent(in) :: t
      real(wp), intent(inout) :: y(:)
      integer, intent(out) :: n_total
      type(error_t), allocatable, intent(out) :: err
      integer :: pass, nev, j
      n_total = 0
      do pass = 1, max_settle_passes
         nev = 0
         call model%apply_events(t, y, d%fired, d%ev, nev)
         call obs%record_events(model, t, y, d%ev, nev, err)
         if (allocated(err)) return
         call keep_last_event(d, nev)
         n_total = n_total + nev
         call model%guards(t, y, d%g)
         d%fired = d%g < 0.0_wp
         if (.not. any(d%fired)) return
      end do
      j = findloc(d%fired, .true., 1)
      call fatal_error(err, 'the modes did not settle at t = '//str(t)//' s: after '//str(max_settle_passes)// &
                       ' passes of the mode update, a guard of '//guard_owner(model, j)// &
                       ' is still below zero; the state there is not consistent with any contact state '// &
                       '(a runaway state). '//remedy(model), err_numeric)
   end subroutine settle_events

   !> The last of the nev events just recorded in d%ev, for `count_events`.
   subroutine keep_last_event(d, nev)
      type(drive_t), intent(inout) :: d
      integer, intent(in) :: nev
      if (nev < 1) return
      d%last_element = d%ev(nev)%element
      d%last_kind = d%ev(nev)%kind
   end subroutine keep_last_event

   !> Event budget: more than max_events_per_dt events (or event instants) inside one dt is a flood.
   !> The message names the last event recorded (d%last_element; the events of
   !> this call may be spread over several settle passes, or be none).
   subroutine count_events(model, d, t, nev, err)
      type(model_t), intent(inout) :: model
      type(drive_t), intent(inout) :: d
      real(wp), intent(in) :: t
      integer, intent(in) :: nev
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: last
      if (t - d%t_window > model%run%dt) then
         d%t_window = t
         d%window_events = 0
      end if
      ! an instant where guards fired counts once even if no element reported an
      ! event there (a guard that fires again and again with no mode change is a
      ! flood too, and was not counted: event_flood_segv.sh ran ~20 s)
      d%window_events = d%window_events + max(nev, 1)
      if (d%window_events <= max_events_per_dt) return
      last = ''
      if (nev > 0 .and. d%last_element >= 1 .and. d%last_element <= size(model%elements)) then
         last = " (the last: '"//ev_name(d%last_kind)//"' of element '"//model%elements(d%last_element)%e%id//"')"
      else if (d%last_guard > 0) then
         last = ' (the last: a guard of '//guard_owner(model, d%last_guard)//' fired without a change of mode)'
      end if
      call fatal_error(err, 'event flood at t = '//str(t)//' s: more than '//str(max_events_per_dt)// &
                       ' events within '//window_text(model)//last//'. '// &
                       remedy(model), err_numeric)
   end subroutine count_events

   !> Every entry of y within the blow-up limit (NaN is not): the test of
   !> check_state without the error path, small enough to be inlined.
   pure logical function within_limit(y) result(ok)
      real(wp), intent(in) :: y(:)
      integer :: i
      ok = .true.
      do i = 1, size(y)
         if (.not. abs(y(i)) <= blowup_limit) then
            ok = .false.
            return
         end if
      end do
   end function within_limit

end module trainsim_simulate
