!> A run its caller advances: start at t_start, advance to any later time
!> (within t_end), read the state, save it and restore it. The base of
!> co-simulation (a train as an FMU, issue 24): the importer asks for the
!> state at its communication points and may go back to a saved point.
!>
!> The session runs `simulate`'s own loop (trainsim_simulate's drive_setup
!> and advance_to): the same integrator, breakpoints of the inputs, event
!> location and mode updates, blow-up and flood checks. Advancing a session
!> through the output times of a run gives that run's states bit for bit
!> (tests/test_session.f90).
!>
!> Save and restore (D-83): a saved state is a copy of the model (its
!> parameters and every element's discrete mode), the time, the state vector
!> and a fixed-step integrator's grid. Both `save` and `restore` start the
!> integrator afresh at that point (an integrator's history, such as CVODE's
!> Nordsieck array, is not saved), so a session that saved at t1 and one
!> restored to t1 continue identically, bit for bit, with every integrator.
!> With a fixed-step integrator (rk4, rk4-thesis, euler) a save does not
!> change the run at all (the grid goes on from t_start); with an adaptive
!> one it restarts the solver there, as a breakpoint of the inputs does (a
!> change within the tolerance). The metrics and events the observer gathers
!> are not rolled back by `restore`. With `defer` (D-186) neither starts one: the
!> next `set_state`, `set_input`, `save` or `advance` does, on the same grid.
!>
!> A session must not be copied once started (the integrator holds the
!> address of the session's model): declare it with `target` or allocate it.
module trainsim_session
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_input, err_internal
   use trainsim_strings, only: str, string_t
   use trainsim_model, only: model_t, load_t
   use trainsim_signal, only: constant_signal
   use trainsim_observer, only: observer_t, run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_run_stats, only: run_stats_t
   use trainsim_integrator, only: integrator_t
   use trainsim_integrator_registry, only: make_integrator
   use trainsim_fixed_step, only: fixed_step_t
   use trainsim_run_checks, only: is_fixed_step
   use trainsim_simulate, only: drive_t, drive_setup, advance_to, check_fixed_step
   use trainsim_quasi_static, only: static_ref_t, static_reference
   use trainsim_session_inputs, only: in_torque, in_speed, input_of, check_input, input_start_value, &
                                      hold_speed, hold_voltage, own_sequences, release_sequences, &
                                      sequence_progress, set_sequence_progress
   implicit none
   private

   public :: session_t, session_state_t

   !> Session starts so far (each start's number tells its saved points apart)
   integer, save :: n_starts = 0

   !> A saved point of a session (`session_t%save`, `restore`).
   type :: session_state_t
      type(model_t), private :: model
      real(wp), private :: t = 0.0_wp, t_int = 0.0_wp
      real(wp), allocatable, private :: y(:)
      type(drive_t), private :: d
      integer, allocatable, private :: input_load(:)
      integer, allocatable, private :: input_kinds(:)
      integer, allocatable, private :: reached(:)   !< each positioning sequence's progress
      logical, private :: saved = .false.
      integer, private :: start_no = 0   !< the start of the session run that saved it
      !> a fixed-step integrator's grid (t0 + k dt, the next k)
      real(wp), private :: grid_t0 = 0.0_wp
      integer(i8), private :: grid_next = 0
   end type session_state_t

   type :: session_t
      !> The model being run (its modes change as the run goes).
      type(model_t) :: model
      !> The time reached (the last goal) and the state there (model%state_label
      !> names y's entries). The integrator's own time `t_int` may lie off the goal
      !> by less than the instant tolerance (1e-9 dt: a fixed-step grid point
      !> t_start + k dt), as a run's sample at its output time.
      real(wp) :: t = 0.0_wp
      real(wp), allocatable :: y(:)
      real(wp), private :: t_int = 0.0_wp
      logical :: started = .false.
      class(integrator_t), allocatable, private :: integ
      type(observer_t), private :: obs
      type(null_sink_t), private :: sink
      type(drive_t), private :: d
      type(run_stats_t), private :: stats   !< counters of integrators already finished
      real(wp), private :: t_end = 0.0_wp, dout = 0.0_wp
      !> per node: its input torque's index in model%loads (0: none yet)
      integer, allocatable, private :: input_load(:)
      !> per node: its inputs of speed and voltage (bits in_speed, in_voltage set)
      integer, allocatable, private :: input_kinds(:)
      logical, private :: owns_sequences = .false.
      integer, private :: start_no = 0   !< this start's number (n_starts)
      !> no integrator running (`save` or `restore` with `defer`, D-186): the next
      !> `set_state`, `set_input`, `save` or `advance` starts one on this grid
      logical, private :: idle = .false.
      real(wp), private :: idle_t0 = 0.0_wp
      integer(i8), private :: idle_next = 0
   contains
      procedure :: start => session_start
      procedure :: advance => session_advance
      procedure :: save => session_save
      procedure :: restore => session_restore
      procedure :: set_state => session_set_state
      procedure :: set_torque => session_set_torque
      procedure :: set_input => session_set_input
      procedure :: kinematics => session_kinematics
      procedure :: element_status => session_element_status
      procedure :: finish => session_finish
   end type session_t

contains

   !> Start a session of `model` (a copy is taken, with positioning sequences of
   !> its own) at its t_start; the run may be advanced up to its t_end. `inputs`
   !> names the co-simulation inputs (trainsim_session_inputs): `NODE` or
   !> `NODE.tau`, an external torque of 0 beside the deck's loads (the sums are
   !> unchanged: x + 0 = x); `NODE.speed`, `NODE.voltage`, the deck's prescribed
   !> speed or motor voltage there, held at its value at t_start.
   subroutine session_start(self, model, err, inputs, reference, step_checked)
      class(session_t), intent(inout), target :: self
      type(model_t), intent(in) :: model
      type(error_t), allocatable, intent(out) :: err
      !> the inputs (`set_input`, `set_torque`)
      type(string_t), intent(in), optional :: inputs(:)
      !> .false.: no quasi-static reference (the run's Kv, mesh orders and rattle
      !> indices then absent), for a caller that reads only states (the period map, D-131)
      logical, intent(in), optional :: reference
      !> .true.: the caller vouches that `check_fixed_step` passed on a model that
      !> differs from this one in nothing it reads (the period map at another
      !> mesh frequency of a branch, D-163); as `simulate`'s step_checked (D-82)
      logical, intent(in), optional :: step_checked
      logical :: with_reference, checked
      type(observer_t) :: fresh_obs
      type(run_stats_t) :: fresh_stats
      type(drive_t) :: fresh_d
      type(static_ref_t) :: qs
      if (self%started) call self%finish()
      if (self%owns_sequences) call release_sequences(self%model)
      if (allocated(self%input_load)) deallocate (self%input_load)
      if (allocated(self%input_kinds)) deallocate (self%input_kinds)
      n_starts = n_starts + 1
      self%start_no = n_starts
      self%model = model
      call own_sequences(self%model)
      self%owns_sequences = .true.
      allocate (self%input_load(size(self%model%nodes)), self%input_kinds(size(self%model%nodes)), source=0)
      self%t = self%model%run%t_start
      self%t_int = self%t
      call self%model%initial_state(self%y)
      if (present(inputs)) then
         call add_inputs(self, inputs, err)
         if (allocated(err)) return
      end if
      self%stats = fresh_stats
      checked = .false.
      if (present(step_checked)) checked = step_checked
      if (.not. checked) call check_fixed_step(self%model, err)
      if (allocated(err)) return
      self%obs%qs = fresh_obs%qs
      with_reference = .true.
      if (present(reference)) with_reference = reference
      if (with_reference) call static_reference(self%model, self%obs%qs)   ! Kv, mesh orders, rattle as a run's (D-103, D-118)
      self%t_end = self%model%run%t_end
      self%dout = self%model%run%output_interval
      if (.not. self%dout > 0.0_wp) self%dout = self%model%run%dt
      call self%model%init_modes(self%t, self%y)
      qs = self%obs%qs
      self%obs = fresh_obs
      self%obs%qs = qs
      self%obs%refine_peaks = .not. is_fixed_step(self%model%run%integrator)
      call self%obs%start(self%model, self%t, self%y, self%sink, err)
      if (allocated(err)) return
      self%d = fresh_d
      call fresh_integrator(self, err)
      if (allocated(err)) return
      self%started = .true.
   end subroutine session_start

   !> Advance the run to t_goal (t <= t_goal <= t_end); events on the way are
   !> located and the modes updated as in a run.
   subroutine session_advance(self, t_goal, err)
      class(session_t), intent(inout), target :: self
      real(wp), intent(in) :: t_goal
      type(error_t), allocatable, intent(out) :: err
      if (.not. self%started) then
         call fatal_error(err, 'internal: a session advanced before it was started', err_internal)
         return
      end if
      if (.not. (t_goal >= self%t - self%d%tol .and. t_goal <= self%t_end + self%d%tol)) then
         call fatal_error(err, 'a session at t = '//str(self%t)//' s cannot advance to t = '//str(t_goal)// &
                          ' s: the goal must lie between the time reached and t_end = '//str(self%t_end)//' s', &
                          err_input)
         return
      end if
      if (t_goal - self%t_int <= self%d%tol) return
      if (self%idle) call restart_on_grid(self, self%idle_t0, self%idle_next, err)
      if (allocated(err)) return
      call advance_to(self%model, self%integ, self%obs, self%d, t_goal, self%t_end, self%t_int, self%y, err)
      if (.not. allocated(err)) self%t = t_goal
   end subroutine session_advance

   !> The session's point (time, state, modes, parameters) into `state`; the
   !> integrator starts afresh here (as after `restore`). `defer`: the caller goes
   !> on only by `restore` or `set_state` (the period map, D-186): no integrator is
   !> started here; one is started on the grid when the run goes on.
   subroutine session_save(self, state, err, defer)
      class(session_t), intent(inout), target :: self
      type(session_state_t), intent(out) :: state
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: defer
      if (.not. self%started) then
         call fatal_error(err, 'internal: a session saved before it was started', err_internal)
         return
      end if
      state%model = self%model
      state%t = self%t
      state%t_int = self%t_int
      state%y = self%y
      state%d = self%d
      state%input_load = self%input_load
      state%input_kinds = self%input_kinds
      call sequence_progress(self%model, state%reached)
      state%saved = .true.
      state%start_no = self%start_no
      call current_grid(self, state%grid_t0, state%grid_next)
      call restart_on_grid(self, state%grid_t0, state%grid_next, err, defer)
   end subroutine session_save

   !> Go back (or forward) to a point `save` took of this session's run (since its
   !> last start; a point of another run is refused: err_input). `defer`: the
   !> caller's next call is `set_state` (the period map, D-186), which starts the
   !> integrator: none is started here for it to replace.
   subroutine session_restore(self, state, err, defer)
      class(session_t), intent(inout), target :: self
      type(session_state_t), intent(in) :: state
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: defer
      if (.not. (self%started .and. state%saved)) then
         call fatal_error(err, 'internal: a session restored from a state it did not save', err_internal)
         return
      end if
      if (state%start_no /= self%start_no) then   ! (its sequences are another run's)
         call fatal_error(err, 'a session restored from a point saved by another session run (a point '// &
                          'belongs to the run between one start and the next)', err_input)
         return
      end if
      call stop_integrator(self)
      self%model = state%model
      self%t = state%t
      self%t_int = state%t_int
      self%y = state%y
      self%d = state%d
      self%input_load = state%input_load
      self%input_kinds = state%input_kinds
      call set_sequence_progress(self%model, state%reached)   ! (the model's sequences are the session's own)
      call restart_on_grid(self, state%grid_t0, state%grid_next, err, defer)
   end subroutine session_restore

   !> Replace the state at the session's point by y (the layout of `y`): every
   !> element's mode chosen afresh from it (as at a run's start) and the
   !> integrator started afresh there, its grid kept. For callers that integrate
   !> from states of their own (the period map, trainsim_period_map).
   subroutine session_set_state(self, y, err)
      class(session_t), intent(inout), target :: self
      real(wp), intent(in) :: y(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: t0
      integer(i8) :: next
      if (.not. (self%started .and. size(y) == size(self%y))) then
         call fatal_error(err, 'internal: a session given a state before it was started, or of another size', &
                          err_internal)
         return
      end if
      self%y = y
      call self%model%init_modes(self%t_int, self%y)
      call current_grid(self, t0, next)
      call restart_on_grid(self, t0, next, err)
   end subroutine session_set_state

   !> An input of the run from now on: the external torque `value` on node
   !> `node` (an id among the session's inputs), as `set_input(node//'.tau', value)`.
   subroutine session_set_torque(self, node, value, err)
      class(session_t), intent(inout), target :: self
      character(len=*), intent(in) :: node
      real(wp), intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      call self%set_input(node//'.tau', value, err)
   end subroutine session_set_torque

   !> An input of the run from now on (`name` among the session's inputs:
   !> NODE.tau or NODE, NODE.speed, NODE.voltage), held constant until the next
   !> call (a co-simulation input): a torque beside the deck's loads, the node's
   !> speed (its angle continuous) or the motor's voltage. The change acts as a
   !> breakpoint of the inputs: the integrator starts afresh at t (a fixed-step
   !> one on its grid). Saved and restored with the point.
   subroutine session_set_input(self, name, value, err)
      class(session_t), intent(inout), target :: self
      character(len=*), intent(in) :: name
      real(wp), intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: node
      real(wp) :: t0
      integer(i8) :: next
      integer :: i, kind
      logical :: is_input, changed
      if (.not. self%started) then
         call fatal_error(err, 'internal: a session given an input before it was started', err_internal)
         return
      end if
      call input_of(name, node, kind)
      i = self%model%node_index(node)
      is_input = i > 0
      if (is_input) then
         if (kind == in_torque) then
            is_input = self%input_load(i) > 0
         else
            is_input = btest(self%input_kinds(i), kind)
         end if
      end if
      if (.not. is_input) then
         call fatal_error(err, "input '"//name//"' (node '"//node//"'): not an input of this session "// &
                          '(name it among the inputs when the session starts)', err_input)
         return
      end if
      if (.not. (abs(value) <= huge(1.0_wp))) then
         call fatal_error(err, "input '"//name//"' (node '"//node//"'): the value is not a finite number", err_input)
         return
      end if
      call set_value(self, i, kind, value, changed)
      if (.not. changed) return
      call current_grid(self, t0, next)
      call fresh_integrator(self, err, new_inputs=.true.)
      if (.not. allocated(err)) call keep_grid(self%integ, t0, next)
   end subroutine session_set_input

   !> Input `kind` of node i takes `value` at the session's point (the model only).
   subroutine set_value(self, i, kind, value, changed)
      type(session_t), intent(inout) :: self
      integer, intent(in) :: i, kind
      real(wp), intent(in) :: value
      logical, intent(out) :: changed
      integer :: k
      select case (kind)
      case (in_torque)
         k = self%input_load(i)
         changed = self%model%loads(k)%torque%value0 /= value
         if (.not. changed) return
         self%model%loads(k)%torque = constant_signal(value)
         call self%model%build_fast_path()
      case (in_speed)
         call hold_speed(self%model, i, self%t_int, self%y, value, changed)
      case default
         call hold_voltage(self%model, i, value, changed)
      end select
   end subroutine set_value

   !> Every node's angle and speed at the session's point into model%theta,
   !> model%omega (as a run's sample there).
   subroutine session_kinematics(self)
      class(session_t), intent(inout) :: self
      call self%model%kinematics(self%t_int, self%y)
   end subroutine session_kinematics

   !> Every element's status at the session's point, as a run records it
   !> (/elements/disp, force, contact): its displacement, its force (or torque)
   !> and its contact state (0 open, +1 / -1 a face in contact, 1 a smooth
   !> element).
   subroutine session_element_status(self, disp, force, contact)
      class(session_t), intent(inout) :: self
      real(wp), intent(out) :: disp(:), force(:)
      integer, intent(out) :: contact(:)
      integer :: i, pairs
      call self%model%kinematics(self%t_int, self%y)
      do i = 1, size(self%model%elements)
         call self%model%elements(i)%e%status_at(self%model%theta, self%model%omega, disp(i), force(i), contact(i), pairs)
      end do
   end subroutine session_element_status

   !> The inputs `names` (checked): a load of 0 on each node of a torque input
   !> (its index in input_load); the deck's speed or voltage at t_start held
   !> on each node of a speed or voltage input.
   subroutine add_inputs(self, names, err)
      type(session_t), intent(inout) :: self
      type(string_t), intent(in) :: names(:)
      type(error_t), allocatable, intent(out) :: err
      type(load_t) :: l
      character(len=:), allocatable :: node
      integer :: j, i, kind
      logical :: changed
      do j = 1, size(names)
         call input_of(names(j)%s, node, kind)
         i = self%model%node_index(node)
         call check_input(self%model, i, node, kind, err)
         if (allocated(err)) return
         if (kind /= in_torque) then
            self%input_kinds(i) = ibset(self%input_kinds(i), kind)
            call set_value(self, i, kind, input_start_value(self%model, i, kind, self%t), changed)
            cycle
         end if
         if (self%input_load(i) > 0) cycle
         l%node = i
         l%torque = constant_signal(0.0_wp)
         self%model%loads = [self%model%loads, l]
         self%input_load(i) = size(self%model%loads)
      end do
   end subroutine add_inputs

   !> End the session: the run's metrics, events and statistics up to t into
   !> `result` (if present).
   subroutine session_finish(self, result, err)
      class(session_t), intent(inout), target :: self
      type(run_result_t), intent(out), optional :: result
      type(error_t), allocatable, intent(out), optional :: err
      type(run_result_t) :: r
      type(error_t), allocatable :: e
      if (.not. self%started) return
      self%started = .false.
      call stop_integrator(self)
      self%idle = .false.
      self%stats%t_metrics = self%obs%t_metrics
      call self%obs%finish(self%model, self%t_int, self%y, self%stats, self%sink, r, e)
      if (present(result)) result = r
      if (present(err)) then
         if (allocated(e)) call move_alloc(e, err)
      end if
   end subroutine session_finish

   !> A new integrator started at (t, y), the loop's bookkeeping set up there
   !> (the previous integrator's counters kept in self%stats). The displacement
   !> bounds of the run's checks are taken again only at a start or when an input
   !> changed (`new_inputs`): a save, restore or new state changes none of the
   !> loads, inertias or the run's window they are computed from (D-173).
   subroutine fresh_integrator(self, err, new_inputs)
      type(session_t), intent(inout), target :: self
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: new_inputs
      self%d%bounds_kept = allocated(self%d%disp_bound)
      if (present(new_inputs)) self%d%bounds_kept = self%d%bounds_kept .and. .not. new_inputs
      call stop_integrator(self)
      self%idle = .false.
      call make_integrator(self%model%run%integrator, self%integ)
      if (.not. allocated(self%integ)) then
         call fatal_error(err, "internal: integrator '"//self%model%run%integrator//"' is not in the registry", &
                          err_internal)
         return
      end if
      self%integ%region_instants = .true.
      call drive_setup(self%model, self%integ, self%obs, self%d, self%dout, self%t_end, self%t_int, self%y, err)
   end subroutine fresh_integrator

   !> The integrator finished (its counters kept in self%stats), if one runs.
   subroutine stop_integrator(self)
      type(session_t), intent(inout) :: self
      if (.not. allocated(self%integ)) return
      call self%integ%statistics(self%stats)
      call self%integ%finish()
      deallocate (self%integ)
   end subroutine stop_integrator

   !> A new integrator at the session's point on the fixed-step grid (t0, next);
   !> with `defer`, none: the session idles until the run goes on (D-186).
   subroutine restart_on_grid(self, t0, next, err, defer)
      type(session_t), intent(inout), target :: self
      real(wp), intent(in) :: t0
      integer(i8), intent(in) :: next
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: defer
      logical :: later
      later = .false.
      if (present(defer)) later = defer
      if (later) then
         call stop_integrator(self)
         self%idle = .true.
         self%idle_t0 = t0
         self%idle_next = next
         return
      end if
      call fresh_integrator(self, err)
      if (.not. allocated(err)) call keep_grid(self%integ, t0, next)
   end subroutine restart_on_grid

   !> The grid the run is on: the integrator's, or the idle session's.
   subroutine current_grid(self, t0, next)
      type(session_t), intent(in) :: self
      real(wp), intent(out) :: t0
      integer(i8), intent(out) :: next
      if (self%idle) then
         t0 = self%idle_t0
         next = self%idle_next
      else
         call grid_of(self%integ, t0, next)
      end if
   end subroutine current_grid

   !> A fixed-step integrator's grid (its start and the index of the next point).
   subroutine grid_of(integ, t0, next)
      class(integrator_t), intent(in) :: integ
      real(wp), intent(out) :: t0
      integer(i8), intent(out) :: next
      t0 = 0.0_wp
      next = 0
      select type (integ)
      class is (fixed_step_t)
         t0 = integ%t0
         next = integ%istep
      end select
   end subroutine grid_of

   !> A fixed-step integrator started afresh goes on on the grid it had (its
   !> steps end at t0 + k dt as before, not at t + k dt: a save leaves the run
   !> bit for bit as without it).
   subroutine keep_grid(integ, t0, next)
      class(integrator_t), intent(inout) :: integ
      real(wp), intent(in) :: t0
      integer(i8), intent(in) :: next
      select type (integ)
      class is (fixed_step_t)
         integ%t0 = t0
         integ%istep = next
      end select
   end subroutine keep_grid

end module trainsim_session
