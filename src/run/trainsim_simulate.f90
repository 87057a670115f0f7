!> A run as a library call: model in, metrics and events out (in memory),
!> histories to whatever sink the caller passes. No global state: any number
!> of runs per process, on copies of one model.
!>
!> `simulate` holds the one driver loop every integrator runs in. The
!> integrator (trainsim_integrator) only advances the state; the loop owns
!> - the output grid: sample k at t_start + k*output_interval exactly (the
!>   last at t_end), computed from k, never accumulated;
!> - the breakpoints of the inputs (load steps, table knots, duty cycles): the
!>   integrator's stop times, with a restart after each;
!> - the events: `settle_events` updates the modes at an instant until no
!>   guard fires, then the integrator restarts;
!> - the checks after every advance: a state that blew up, an interrupt, and
!>   the event budget (an event flood ends the run instead of hanging it).
module trainsim_simulate
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_internal, err_numeric, err_interrupted, err_input
   use trainsim_interrupt, only: signal_caught
   use trainsim_strings, only: str
   use trainsim_model, only: model_t, settle_budget
   use trainsim_event, only: event_t, ev_name
   use trainsim_sink, only: sink_t
   use trainsim_run_stats, only: run_stats_t
   use trainsim_observer, only: observer_t, run_result_t
   use trainsim_integrator, only: integrator_t, adv_step, adv_reached, adv_event
   use trainsim_integrator_registry, only: make_integrator, integrator_registry, integrator_entry_t
   use trainsim_modes, only: rk4_dt_limit, limiting_part, load_torque_bound, rk4_dt_quick
   use trainsim_element, only: lin_state_t, lin_stiffest, lin_start, lin_contact_closed
   use trainsim_progress, only: progress_t
   implicit none
   private

   public :: simulate, blowup_limit, max_events_per_dt, max_settle_passes, settle_kmax, check_fixed_step

   !> A state beyond this is a blow-up. Far above any physical angle, speed,
   !> current or energy; its square times any sane coefficient stays finite, so
   !> the check fires before a floating-point overflow can.
   real(wp), parameter :: blowup_limit = 1.0e50_wp
   !> More events than this inside one dt is a flood: a contact that chatters
   !> faster than the step can resolve (a run past its stability limit).
   integer, parameter :: max_events_per_dt = 200
   !> Passes of the mode update at one instant before it counts as not settling.
   integer, parameter :: max_settle_passes = 16
   !> A fixed step more than this many times RK4's stability limit of the
   !> starting state multiplies any excitation of the limiting mode by 1e12 or
   !> more per step: the run cannot mean anything, and a step of it can overflow
   !> before the blow-up check sees it. Below this factor the check is in time
   !> (a run 10x above the limit, as Table 5.2's, runs with a warning).
   real(wp), parameter :: max_dt_over_limit = 1.0e3_wp
   !> A limiting eigenvalue with at least this damping ratio (|Re| >= |Im|) is
   !> damping-dominated: a fixed step above its limit is refused (D-55).
   real(wp), parameter :: damped_ratio = 0.7071_wp

   !> Settling until periodic (D-44): the longest attractor period looked for, in
   !> settle periods.
   integer, parameter :: settle_kmax = 8
   !> The tolerance of the verdict at settle_time of a run with no settle_tol (D-44).
   real(wp), parameter :: settle_check_tol = 1.0e-3_wp

   !> Settling until periodic (&run settle_tol, D-44): the state is sampled at
   !> t_start + j T (T = settle_period), once per period, outside the step loop. The
   !> state is every element's displacement (its deformation: relative angle, or
   !> transmission error) and every node's speed; sample j is compared with samples
   !> j - k, k = 1 .. settle_kmax, component by component, relative to the largest
   !> magnitude the component has had at the samples so far (one scale for all
   !> speeds, which share a unit; one per element, whose units differ):
   !>     r_k(j) = max_c |x_c(j) - x_c(j - k)| / s_c.
   !> Settled (periodic) at the first j with t_j >= t_start + settle_time and
   !> r_1(j) <= tol; an attractor of k > 1 periods when r_k <= tol at two successive
   !> samples while r_1 > sqrt(tol) (far from repeating after one period: a transient
   !> decaying towards a 1-periodic state has r_k ~ r_1 and reaches tol with k = 1
   !> within a period or two). Not settled when t_start + settle_max_time passes first.
   !> The metrics then start at t_j and the run ends a measured window later (the
   !> deck's t_end - t_start - settle_time, a whole number of the k periods).
   type :: settle_t
      logical :: on = .false., done = .false.
      !> no settle_tol but a settle_time and a period: only a verdict at settle_time
      !> (to check_tol), the run and its metrics unchanged
      logical :: check_only = .false.
      real(wp) :: period = 0.0_wp, tol = 0.0_wp, t_min = 0.0_wp, t_budget = 0.0_wp, measure = 0.0_wp
      real(wp) :: t0 = 0.0_wp, t_next = 0.0_wp, t_settled = 0.0_wp
      integer :: j = -1                 !< index of the last sample (sample 0: t_start)
      integer :: k = 0                  !< periods of the attractor found (0: none)
      integer :: status = 0             !< run_stats_t%settle_status
      real(wp), allocatable :: x(:, :)  !< (component, 0:settle_kmax) ring of samples
      real(wp), allocatable :: scale(:) !< per component: largest magnitude so far
      integer :: hits(settle_kmax) = 0  !< per k: successive samples with r_k <= tol
   end type settle_t

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
      !> per element: the largest |displacement| a physical run reaches
      !> (element%displacement_bound, D-55), checked at the output times
      real(wp), allocatable :: disp_bound(:)
      !> first output time at which the energy residual exceeded
      !> run%energy_check of the energy scale so far (-1: not yet)
      real(wp) :: t_ledger = -1.0_wp
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
   subroutine simulate(model, sink, result, err, keep_interrupted, progress)
      type(model_t), intent(inout), target :: model
      class(sink_t), intent(inout), target :: sink   ! the observer streams the event rows to it
      type(run_result_t), intent(out) :: result
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: keep_interrupted
      type(progress_t), intent(inout), optional :: progress
      type(error_t), allocatable :: err_close
      type(observer_t) :: obs
      type(run_stats_t) :: stats
      class(integrator_t), allocatable, target :: integ
      real(wp), allocatable :: y(:)
      real(wp) :: t
      integer(i8) :: c0, c1, rate

      type(settle_t) :: settle
      real(wp) :: t_end_deck

      call system_clock(c0, rate)
      call make_integrator(model%run%integrator, integ)
      if (.not. allocated(integ)) then
         call fatal_error(err, "internal: integrator '"//model%run%integrator//"' is not in the registry", err_internal)
         return
      end if
      integ%region_instants = .true.   ! advance_to works on the region alone at local event instants
      call check_fixed_step(model, err)
      if (allocated(err)) return
      t = model%run%t_start
      call model%initial_state(y)
      call model%init_modes(t, y)
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

   !> Settling until periodic (settle_t): set up from &run, and model%run%t_end moved
   !> to the latest end the settling budget allows (simulate puts it back).
   subroutine settle_setup(model, st, err)
      type(model_t), intent(inout) :: model
      type(settle_t), intent(inout) :: st
      type(error_t), allocatable, intent(out) :: err
      integer :: n
      if (.not. model%run%settle_tol > 0.0_wp) then
         ! a fixed settle_time: say whether the response has settled by then
         if (.not. (model%run%settle_time > 0.0_wp .and. model%run%settle_period > 0.0_wp)) return
         st%check_only = .true.
      else if (.not. model%run%settle_period > 0.0_wp) then
         call fatal_error(err, '&run settle_tol = '//str(model%run%settle_tol)//' needs a settle_period: give '// &
                          '&run settle_period (s), or a gear pair with teeth whose mesh period sets it', err_input)
         return
      end if
      st%on = .true.
      st%period = model%run%settle_period
      st%tol = model%run%settle_tol
      st%t0 = model%run%t_start
      st%t_min = model%run%t_start + model%run%settle_time
      st%t_budget = model%run%t_start + settle_budget(model%run)
      if (st%check_only) then
         st%tol = settle_check_tol
         st%t_budget = st%t_min
      end if
      st%measure = model%run%t_end - st%t_min
      st%t_next = st%t0
      n = size(model%elements) + size(model%nodes)
      allocate (st%x(n, 0:settle_kmax), st%scale(n))
      st%x = 0.0_wp
      st%scale = 0.0_wp
      if (st%check_only) return
      model%run%t_end = st%t_budget + st%measure + real(settle_kmax + 1, wp)*st%period
   end subroutine settle_setup

   !> Sample the state at (t, y), a settle instant t0 + j T, and decide whether the
   !> response has settled (settle_t); when it has (or the budget is spent), the
   !> observer's metrics start at t and `t_end` becomes the end of the measured window.
   subroutine settle_sample(model, obs, sink, st, t, y, t_end)
      type(model_t), intent(inout) :: model
      type(observer_t), intent(inout) :: obs
      class(sink_t), intent(inout) :: sink
      type(settle_t), intent(inout) :: st
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: t_end
      integer :: ne, e, l, r, c, p, slot, k, kk
      real(wp) :: f, w, r1, measure
      ne = size(model%elements)
      st%j = st%j + 1
      slot = modulo(st%j, settle_kmax + 1)
      call model%kinematics(t, y)
      do e = 1, ne
         associate (el => model%elements(e)%e)
            l = el%left; r = el%right
            call el%status(model%theta(l), model%omega(l), model%theta(r), model%omega(r), st%x(e, slot), f, c, p)
         end associate
      end do
      st%x(ne + 1:, slot) = model%omega
      st%scale(1:ne) = max(st%scale(1:ne), abs(st%x(1:ne, slot)))
      w = max(maxval(st%scale(ne + 1:)), maxval(abs(model%omega)))
      st%scale(ne + 1:) = w
      st%t_next = st%t0 + real(st%j + 1, wp)*st%period
      r1 = huge(1.0_wp)
      do k = 1, min(settle_kmax, st%j)
         f = maxval(abs(st%x(:, slot) - st%x(:, modulo(st%j - k, settle_kmax + 1)))/max(st%scale, tiny(1.0_wp)))
         if (k == 1) r1 = f
         if (f <= st%tol) then
            st%hits(k) = st%hits(k) + 1
         else
            st%hits(k) = 0
         end if
      end do
      if (t < st%t_min - 1.0e-9_wp*st%period) return
      kk = 0
      if (st%hits(1) >= 1) then
         kk = 1
      else if (r1 > sqrt(st%tol)) then
         do k = 2, min(settle_kmax, st%j)
            if (st%hits(k) >= 2) then
               kk = k
               exit
            end if
         end do
      end if
      if (kk > 0) then
         st%status = 1
         st%k = kk
      else if (t >= st%t_budget - 1.0e-9_wp*st%period) then
         st%status = 2
      else
         return
      end if
      st%done = .true.
      st%t_settled = t
      if (st%check_only) return
      measure = st%measure
      if (kk > 1) measure = real(kk, wp)*st%period*max(1.0_wp, aint(measure/(real(kk, wp)*st%period) + 1.0_wp - &
                                                                      1.0e-9_wp))
      t_end = t + measure
      obs%t_metrics = t
      call sink%metrics_from(t)
   end subroutine settle_sample

   !> The driver loop: from (t, y) at t_start to t_end.
   subroutine drive(model, integ, obs, sink, t, y, st, err, progress)
      type(model_t), intent(inout), target :: model
      class(integrator_t), intent(inout), target :: integ
      type(observer_t), intent(inout) :: obs
      class(sink_t), intent(inout) :: sink
      real(wp), intent(inout) :: t, y(:)
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
      d%tol = 1.0e-9_wp*model%run%dt
      d%t_window = t
      d%may_miss = integ%may_miss_events()
      ! blocks when no step but the output times' needs a whole sample: the
      ! samples are not taken whole, or there are steps between output times
      ! (a block then ends on each output time, where the sample is filled from
      ! the workspace of its last step)
      d%blocks = integ%takes_blocks .and. model%run%step_blocks .and. .not. (d%may_miss .or. obs%refine_peaks) .and. &
                 (.not. obs%want_whole .or. dout /= model%run%dt)
      d%block_samples = d%blocks .and. dout == model%run%dt .and. .not. obs%want_whole
      allocate (d%g(model%n_guards), d%fired(model%n_guards), d%ev(64))
      call displacement_bounds(model, d%disp_bound)
      call model%breakpoints(t, t_end, d%bp)
      call set_next_stop(d, integ, t, t_end)
      call integ%start(model, t, y, err)
      if (allocated(err)) return
      ! a guard already negative at t_start: settle it before the first step
      call settle_if_fired(model, integ, obs, d, t, y, .false., err)
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
               ! the block's steps ended on output times k, k + 1, ... (one grid)
               do j = 1, model%blk%n
                  if (model%blk%t(j) /= out_time(k + j - 1)) then
                     call fatal_error(err, 'internal: a step of a block ended at t = '//str(model%blk%t(j))// &
                                      ' s, off the output time '//str(out_time(k + j - 1))//' s', err_internal)
                     return
                  end if
               end do
               k = k + model%blk%n
               call check_physical(model, obs, d, t, err)
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
         call check_physical(model, obs, d, t, err)
         if (allocated(err)) return
         if (present(progress)) call progress%poll(t, obs%n_events)
         k = k + 1
      end do
      t = t_end
      call check_ledger(model, obs, d, t, err)
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
      real(wp), intent(inout) :: t, y(:)
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
      real(wp), intent(inout) :: t, y(:)
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

   !> Each element's displacement bound (element%displacement_bound) from the
   !> loads (trainsim_modes' load_torque_bound) and its nodes' inertias.
   subroutine displacement_bounds(model, bound)
      type(model_t), intent(in) :: model
      real(wp), allocatable, intent(out) :: bound(:)
      real(wp) :: tq
      integer :: i
      allocate (bound(size(model%elements)))
      tq = load_torque_bound(model)
      do i = 1, size(model%elements)
         associate (e => model%elements(i)%e)
            bound(i) = e%displacement_bound(tq, inv_inertia(e%left), inv_inertia(e%right))
         end associate
      end do
   contains
      real(wp) function inv_inertia(j) result(r)
         integer, intent(in) :: j
         r = 0.0_wp
         if (model%is_held(j) .or. model%nodes(j)%n%is_fixed()) return
         if (model%nodes(j)%n%inertia() > 0.0_wp) r = 1.0_wp/model%nodes(j)%n%inertia()
      end function inv_inertia
   end subroutine displacement_bounds

   !> The checks that a run is still physical, at each output time from the
   !> observer's running metrics (D-55): no element's displacement beyond its
   !> bound (a mesh with its teeth through one another) ends the run at once;
   !> the first time the energy residual passes run%energy_check of the
   !> scale so far is kept for `check_ledger`. A run that fails them ends with
   !> exit 1 naming the element, the time, the check and a remedy for the
   !> integrator in use, instead of a wrong answer with exit 0.
   subroutine check_physical(model, obs, d, t, err)
      type(model_t), intent(inout) :: model
      type(observer_t), intent(in) :: obs
      type(drive_t), intent(inout) :: d
      real(wp), intent(in) :: t
      type(error_t), allocatable, intent(out) :: err
      integer :: i
      real(wp) :: worst
      do i = 1, size(d%disp_bound)
         worst = max(abs(obs%res%el(i)%disp_min), abs(obs%res%el(i)%disp_max))
         if (.not. worst > d%disp_bound(i)) cycle
         if (obs%res%el(i)%disp_min > obs%res%el(i)%disp_max) cycle   ! nothing folded yet (settle_time)
         call fatal_error(err, "integrator '"//model%run%integrator//"': the displacement of element '"// &
                          model%elements(i)%e%id//"' reached "//str(sign(worst, obs%res%el(i)%disp_max + &
                          obs%res%el(i)%disp_min), 4)//' by t = '//str(t)//' s, beyond the '//str(d%disp_bound(i), 4)// &
                          ' a physical run can reach (the clearance plus ten times the largest of the clearance, '// &
                          'the static deflection under the loads and an impact at 100 in/s): the solution is wrong '// &
                          '(the displacement-bound check). '//physical_advice(model), err_numeric)
         return
      end do
      if (d%t_ledger < 0.0_wp .and. model%run%track_energy .and. model%run%energy_check > 0.0_wp) then
         if (obs%res%energy_residual_max > model%run%energy_check*obs%res%energy_scale) d%t_ledger = t
      end if
   end subroutine check_physical

   !> The energy ledger at the end of the run (D-55): a residual above
   !> run%energy_check (default 0.1) of the run's energy scale is a wrong
   !> solution, not an integration error: a correct run keeps it near 1e-6,
   !> RK4 at 0.95 x its stability limit below 1e-3 (check_dt_advice); a
   !> blown-up one has it equal to the scale. Judged at the end, where the scale
   !> is the run's: early on, one coarse step at an impact can be comparable to
   !> a scale that is still small (loads_table_ramp at 0.95 x its limit: 0.67
   !> at t = 0.022 s, 4e-4 at the end).
   subroutine check_ledger(model, obs, d, t, err)
      type(model_t), intent(inout) :: model
      type(observer_t), intent(in) :: obs
      type(drive_t), intent(in) :: d
      real(wp), intent(in) :: t
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: h_part, t_first
      type(model_t) :: tmp
      character(len=:), allocatable :: part
      if (.not. model%run%track_energy .or. .not. model%run%energy_check > 0.0_wp) return
      if (.not. obs%res%energy_residual_max > model%run%energy_check*obs%res%energy_scale) return
      t_first = t
      if (d%t_ledger >= 0.0_wp) t_first = d%t_ledger
      tmp = model
      call limiting_part(tmp, lin_stiffest, part, h_part)
      call fatal_error(err, "integrator '"//model%run%integrator//"': the energy ledger does not balance: at t = "// &
                       str(t)//' s the largest residual is '//str(obs%res%energy_residual_max, 4)// &
                       ' against an energy scale of '//str(obs%res%energy_scale, 4)//' (more than energy_check = '// &
                       str(model%run%energy_check)//' of it, first at t = '//str(t_first)//' s; the energy-ledger '// &
                       'check): the solution is wrong. The stiffest part of the train is '//part// &
                       ', with a step limit of its own of '//str(h_part, 4)//' s. '//physical_advice(model), &
                       err_numeric)
   end subroutine check_ledger

   !> What to try when a run is no longer physical: for a fixed step, a smaller
   !> dt than RK4's stability limit of the stiffest state (a step near the limit
   !> of a strongly damped mode is stable but does not resolve it) or an
   !> implicit method; for an adaptive one, its tolerances.
   function physical_advice(model) result(text)
      type(model_t), intent(inout) :: model
      character(len=:), allocatable :: text
      type(model_t) :: tmp
      type(error_t), allocatable :: lim_err
      real(wp) :: dt_safe, omega
      if (.not. is_fixed_step(model%run%integrator)) then
         text = remedy(model)
         if (index(model%run%integrator, 'arkode') == 1) text = text//"; or use integrator = 'cvode-bdf' if the train is stiff"
         return
      end if
      tmp = model
      call rk4_dt_limit(tmp, lin_stiffest, dt_safe, omega, lim_err)
      text = "Take a smaller dt, or use integrator = 'cvode-bdf'"
      if (.not. allocated(lim_err) .and. dt_safe < huge(1.0_wp)) text = 'Take dt well below '//str(dt_safe, 4)// &
         ' s, the RK4 stability limit of the stiffest state the run can reach (a step near the limit of a strongly '// &
         "damped mode is stable but does not resolve it), or use integrator = 'cvode-bdf'"
   end function physical_advice

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

   !> NaN or runaway state after a step -> an error naming the time, the node
   !> and quantity, and the likely cause.
   !> With `states`, only those entries of y (a local event instant).
   subroutine check_state(model, integ, t, y, err, states)
      type(model_t), intent(inout) :: model
      class(integrator_t), intent(in) :: integ
      real(wp), intent(in) :: t, y(:)
      type(error_t), allocatable, intent(out) :: err
      integer, intent(in), optional :: states(:)
      integer :: i, k
      if (present(states)) then
         do k = 1, size(states)
            if (.not. abs(y(states(k))) <= blowup_limit) then   ! also true for NaN
               call blew_up(states(k))
               return
            end if
         end do
         return
      end if
      do i = 1, size(y)
         if (.not. abs(y(i)) <= blowup_limit) then   ! also true for NaN
            call blew_up(i)
            return
         end if
      end do
   contains
      subroutine blew_up(j)
         integer, intent(in) :: j
         call fatal_error(err, "integrator '"//model%run%integrator//"': the solution blew up at t = "//str(t)// &
                          ' s ('//model%state_label(j)//' is '//trim(merge('NaN    ', 'runaway', y(j) /= y(j)))// &
                          '). '//blowup_advice(model, integ), err_numeric)
      end subroutine blew_up
   end subroutine check_state

   !> What to try after a blow-up: the step if it is above the stability
   !> limit (fixed-step methods), else the tolerances, else the inputs.
   function blowup_advice(model, integ) result(text)
      type(model_t), intent(inout) :: model
      class(integrator_t), intent(in) :: integ
      character(len=:), allocatable :: text
      associate (unused => integ)
      end associate
      text = remedy(model)
   end function blowup_advice

   !> What to try after a numerical failure, for the integrator in use: the
   !> step dt against RK4's stability limit (fixed-step methods), or the
   !> tolerances and max_step (adaptive ones, which do not use dt but as the
   !> output grid when output_interval is 0).
   function remedy(model) result(text)
      type(model_t), intent(inout) :: model
      character(len=:), allocatable :: text
      character(len=:), allocatable :: h
      if (is_fixed_step(model%run%integrator)) then
         text = stability_advice(model)
         return
      end if
      h = 'a smaller max_step'
      if (model%run%max_step > 0.0_wp) h = 'a smaller max_step (now '//str(model%run%max_step)//' s)'
      text = "Integrator '"//model%run%integrator//"' chooses its own steps: tighten rtol (now "//str(model%run%rtol)// &
             ') and the absolute tolerances, or set '//h//'; if that does not help, check the loads, stiffnesses '// &
             'and inertias of the deck for values out of proportion'
   end function remedy

   !> The event budget's window in words: dt for a fixed-step method, else the
   !> same span of time named as the deck's dt (an adaptive method does not step by it).
   function window_text(model) result(text)
      type(model_t), intent(in) :: model
      character(len=:), allocatable :: text
      if (is_fixed_step(model%run%integrator)) then
         text = 'dt = '//str(model%run%dt)//' s'
      else
         text = str(model%run%dt)//' s, the deck''s dt'
      end if
   end function window_text

   !> dt against the RK4 stability limit of the stiffest state the run can
   !> reach (every clearance closed, gears at their largest stiffness factor,
   !> the largest impact damping): blame the step if it is above, the inputs if not.
   function stability_advice(model) result(text)
      type(model_t), intent(inout) :: model
      character(len=:), allocatable :: text
      type(model_t) :: tmp
      type(error_t), allocatable :: err
      real(wp) :: dt_safe, omega, f_hz
      tmp = model
      call rk4_dt_limit(tmp, lin_stiffest, dt_safe, omega, err, freq_hz=f_hz)
      if (allocated(err)) then
         text = 'Check the deck for absurd loads or stiffnesses, and try a smaller dt'
         return
      end if
      if (.not. omega > 0.0_wp) then
         text = 'The train has no elastic mode: check the loads and inertias of the deck for absurd values'
         return
      end if
      if (model%run%dt > dt_safe) then
         text = 'The time step dt = '//str(model%run%dt)//' s is above the RK4 stability limit '//str(dt_safe, 4)// &
                ' s of the stiffest state the run can reach (every clearance closed, gears in their two-pair zone; '// &
                'its mode at '//str(f_hz, 5)//' Hz): take dt below that'
      else
         text = 'The time step dt = '//str(model%run%dt)//' s is within the RK4 stability limit '//str(dt_safe, 4)// &
                ' s of the stiffest state the run can reach: the inputs are more likely to blame; '// &
                'check the loads, stiffnesses, inertias and initial speeds of the deck for values out of proportion'
      end if
   end function stability_advice

   !> Whether the registry row of `name` is a fixed-step method.
   logical function is_fixed_step(name) result(fixed)
      character(len=*), intent(in) :: name
      type(integrator_entry_t), allocatable :: rows(:)
      integer :: i
      allocate (rows, source=integrator_registry())   ! not `rows = ...`: gfortran 12 false -Wuninitialized
      fixed = .false.
      do i = 1, size(rows)
         if (rows(i)%name == name) fixed = rows(i)%fixed_step
      end do
   end function is_fixed_step

   !> A fixed-step method is refused before the first step (exit 2) when
   !> - dt is absurdly far above the stability limit of the train as it starts,
   !>   or with every clearance closed and the gears at their stiffest
   !>   (max_dt_over_limit; impact damping left out: it moves RK4's radius only
   !>   between 2.6 and 2.95, nothing against a factor of 1000); or
   !> - dt is above the limit of either state (the stiffest with every contact
   !>   law's damping at its largest, a gentle closure under the loads included,
   !>   D-55) and the limiting eigenvalue is damping-dominated (damping ratio >=
   !>   1/sqrt 2): a step beyond the real-axis radius multiplies every state
   !>   change by |R(h lambda)| > 1, so no such mode stays unexcited (unlike an
   !>   undamped mode that the inputs may never touch, D-4).
   !> The message names the node or element that limits the step alone
   !> (`limiting_part`), its deck group, and the dt that would do.
   !> rk4-thesis steps dt/10 in contact; Euler's region reaches 2 on the real axis.
   subroutine check_fixed_step(model, err)
      type(model_t), intent(inout) :: model
      type(error_t), allocatable, intent(out) :: err
      type(integrator_entry_t), allocatable :: rows(:)
      type(lin_state_t) :: states(4)
      character(len=40), parameter :: state_text(4) = [character(len=40) :: 'the train as it starts', &
                                                       'the closed contacts', 'the train as it starts', &
                                                       'the stiffest state the run can reach']
      real(wp) :: dt_safe, omega, f_hz, zeta, h, rescale
      character(len=:), allocatable :: part, name, limit_name
      integer :: i, k
      type(model_t) :: quick   ! one copy for the four O(n) bounds (each re-initialises it)
      allocate (rows, source=integrator_registry())   ! not `rows = ...`: gfortran 12 false -Wuninitialized
      do i = 1, size(rows)
         if (rows(i)%name == model%run%integrator) exit
      end do
      if (i > size(rows)) return
      if (.not. rows(i)%fixed_step) return
      name = model%run%integrator
      limit_name = "the stability limit of integrator '"//name//"',"
      if (name(1:3) == 'rk4') limit_name = 'the RK4 stability limit'
      rescale = 1.0_wp
      if (name == 'euler') rescale = 2.0_wp/2.785_wp   ! real-axis radius of Euler's region against RK4's
      states = [lin_start, lin_stiffest, lin_start, lin_stiffest]
      states(2)%impact_scale = 0.0_wp
      ! contacts that may close later: the impact damping of D-25, not a gentle
      ! closure at the floor velocity under load, which a run need not reach
      ! (Chapter III case II with Smith's law closes at 21 in/s and runs right);
      ! the contacts closed at t_start have their own D (states(3)), and what a
      ! run does reach is caught at the output times (check_physical)
      states(4)%load_torque = -1.0_wp
      quick = model
      do k = 1, 4
         h = model%run%dt
         if (name == 'rk4-thesis' .and. states(k)%contact == lin_contact_closed) h = h/10.0_wp   ! App. F: dt/10 in contact
         ! the O(n) bound first: within it, every eigenvalue is stable (no eigenvalue problem)
         call quick_limit(states(k), dt_safe)
         if (k <= 2) then
            if (.not. h/max_dt_over_limit > dt_safe*rescale) cycle
         else
            if (.not. h > dt_safe*rescale) cycle
         end if
         call limit_of(states(k), dt_safe, f_hz, zeta)
         dt_safe = dt_safe*rescale
         if (k <= 2) then
            if (.not. h/max_dt_over_limit > dt_safe) cycle
         else
            if (.not. (h > dt_safe .and. zeta >= damped_ratio)) cycle
         end if
         call part_of(states(k), part)
         if (k <= 2) then
            call fatal_error(err, 'dt = '//str(model%run%dt)//' s is more than '//str(max_dt_over_limit)// &
                             ' times '//limit_name//' '//str(dt_safe, 4)//' s of '// &
                             trim(state_text(k))//' ('//mode_text(f_hz, zeta, omega)//'), set by '//part// &
                             ': any excitation of that mode would grow by 1e12 or more per step. Take dt below '// &
                             str(dt_safe, 4)//' s, or check the deck for a stiffness, damping, radius or inertia '// &
                             'out of proportion (a unit slip?)', err_input)
         else
            call fatal_error(err, 'dt = '//str(model%run%dt)//' s is above '//limit_name//' '// &
                             str(dt_safe, 4)//' s of '//trim(state_text(k))//' ('// &
                             mode_text(f_hz, zeta, omega)//'), set by '//part//'. That mode is damped, so '// &
                             'every step beyond the limit amplifies it (no wrong answer is given with exit 0 '// &
                             'instead, D-55): take dt below '//str(dt_safe, 4)//' s'// &
                             thesis_note(name == 'rk4-thesis' .and. states(k)%contact == lin_contact_closed)// &
                             ", or use integrator = 'cvode-bdf' (implicit: its step has no stability limit)"// &
                             gentle_hint(part), err_input)
         end if
         return
      end do
   contains
      subroutine quick_limit(state, dt_lim)
         type(lin_state_t), intent(in) :: state
         real(wp), intent(out) :: dt_lim
         real(wp) :: bound
         call rk4_dt_quick(quick, state, dt_lim, bound)
      end subroutine quick_limit
      subroutine limit_of(state, dt_lim, f, z)
         type(lin_state_t), intent(in) :: state
         real(wp), intent(out) :: dt_lim, f, z
         type(model_t) :: tmp
         type(error_t), allocatable :: lim_err
         tmp = model
         f = 0.0_wp; z = 0.0_wp
         call rk4_dt_limit(tmp, state, dt_lim, omega, lim_err, freq_hz=f, damping_ratio=z)
         if (allocated(lim_err)) dt_lim = huge(1.0_wp)
      end subroutine limit_of
      subroutine part_of(state, text)
         type(lin_state_t), intent(in) :: state
         character(len=:), allocatable, intent(out) :: text
         type(model_t) :: tmp
         real(wp) :: h_part
         tmp = model
         call limiting_part(tmp, state, text, h_part)
      end subroutine part_of
   end subroutine check_fixed_step

   !> rk4-thesis in contact: its step there is dt/10.
   function thesis_note(in_contact) result(text)
      logical, intent(in) :: in_contact
      character(len=:), allocatable :: text
      text = ''
      if (in_contact) text = ' x 10 (rk4-thesis steps dt/10 in contact)'
   end function thesis_note

   !> "the mode at 5690.8 Hz, damping ratio 0.17" or "an overdamped mode, |lambda| = 9.1E6 1/s".
   function mode_text(f_hz, zeta, omega) result(text)
      real(wp), intent(in) :: f_hz, zeta, omega
      character(len=:), allocatable :: text
      character(len=8) :: z
      if (f_hz > 0.0_wp .and. zeta < 1.0_wp) then
         write (z, '(f4.2)') max(zeta, 0.0_wp)
         text = 'the mode at '//str(f_hz, 5)//' Hz, damping ratio '//trim(z)
      else
         text = 'an overdamped mode, |lambda| = '//str(omega, 4)//' 1/s'
      end if
   end function mode_text

   !> The remedy for a yang_sun contact whose damping at the floor velocity sets the limit.
   function gentle_hint(part) result(text)
      character(len=*), intent(in) :: part
      character(len=:), allocatable :: text
      text = ''
      if (index(part, 'contact law') > 0) text = '; if it is a yang_sun contact: one that closes slower than '// &
         'min_approach_velocity gets the damping of that floor (D = 6(1-e)k/[((2e-1)^2+3) V], eq. (3.12)), '// &
         'which grows with the load it then carries: a larger min_approach_velocity (or '// &
         'initial_contact_velocity) lowers it'
   end function gentle_hint

   !> "element 'mesh'" for guard index j of the model.
   function guard_owner(model, j) result(text)
      type(model_t), intent(in) :: model
      integer, intent(in) :: j
      character(len=:), allocatable :: text
      integer :: i
      text = 'guard '//str(j)
      do i = size(model%elements), 1, -1
         if (model%guard_offset(i) < j) then
            text = "element '"//model%elements(i)%e%id//"'"
            return
         end if
      end do
   end function guard_owner
end module trainsim_simulate
