!> The public API of trainsim: one module, `use trainsim`, for programs that build on it.
!>
!> A `simulation_t` holds a parsed deck, the model built from it and the result of its
!> last run. Read a deck (a file or a string), change parameters by their deck path,
!> build (the plug-ins check every value, as for a deck), run (in memory; an HDF5 history
!> if asked) and read the per-element metrics and the event table:
!>
!>```fortran
!> use trainsim, only: simulation_t, error_t, wp
!> type(simulation_t) :: sim
!> type(error_t), allocatable :: err
!> call sim%read_file('inputs/gregory_harris_munro.nml', err)
!> if (.not. allocated(err)) call sim%set('mesh.half_backlash', 0.002_wp, err)
!> if (.not. allocated(err)) call sim%run(err)              ! builds first if needed
!> if (.not. allocated(err)) call sim%metric('mesh', 'p2p_mean', x, err)
!> if (allocated(err)) print '(a)', err%message
!>```
!>
!> Every procedure with an `err` argument returns an allocated `error_t` on failure and
!> never stops the program; `err%code` is `err_input` (bad deck or value), `err_io`
!> (unreadable deck, unwritable history), `err_numeric` (the run failed) or `err_internal`.
!>
!> A parameter path is `GROUP.KEY`: GROUP is the `id` of a `&node` or `&element` group
!> (`n<k>`/`e<k>` for the k-th group without an id, as the builder names it) or `run`
!> for the `&run` group, or `GROUP#K` for the K-th group of a kind (`load#2`); KEY is any
!> key of that group or a derived parameter of a gear element (`mesh_frequency`,
!> `settle_cycles`, `measure_cycles`). One parser reads these paths for `set`, the command
!> line's `--set GROUP.KEY=VALUE` and the deck's `&sweep parameter` (trainsim_overrides).
module trainsim
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input, err_io, err_numeric, err_internal
   use trainsim_strings, only: string_t, to_lower, str
   use trainsim_version, only: version_string, version_full, git_revision
   use trainsim_deck, only: deck_t, deck_group_t, read_deck, parse_deck
   use trainsim_overrides, only: override_t, make_override, check_override, split_sweep_groups
   use trainsim_sweep_spec, only: sweep_spec_t, read_sweep_spec
   use trainsim_prepare, only: prepare_model
   use trainsim_model, only: model_t
   use trainsim_simulate, only: simulate
   use trainsim_session, only: session_t, session_state_t
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: sink_t, null_sink_t, event_t, element_metrics_t, run_stats_t, ev_name, &
                            ev_contact_front, ev_contact_rear, ev_separation, ev_zone
   use trainsim_hdf5, only: hdf5_sink_t
   use trainsim_capture, only: tee_sink_t
   use trainsim_continuation, only: chain_state_t, save_end_state
   implicit none
   private

   public :: simulation_t
   public :: wp, error_t, string_t, version_string, version_full, git_revision
   public :: err_input, err_io, err_numeric, err_internal
   public :: event_t, element_metrics_t, run_stats_t, run_result_t, model_t
   public :: ev_name, ev_contact_front, ev_contact_rear, ev_separation, ev_zone
   public :: metric_names, sweep_spec_t, chain_state_t
   public :: session_t, session_state_t   !< a run advanced by its caller (trainsim_session)

   !> Names accepted by `simulation_t%metric` (fields of element_metrics_t, in its order).
   character(len=*), parameter :: metric_list(*) = [character(len=21) :: &
      'force_min', 'force_max', 'torque_min', 'torque_max', 'disp_min', 'disp_max', &
      'impacts', 'separations', 'zone_changes', 'max_approach_velocity', 'max_peak_force', &
      'time_out_of_contact', 'p2p_range', 'p2p_mean', 'p2p_swings', 'load_sharing', 'kv', 'static_force', &
      'static_te_mean', 'static_te_p2p', 'force_mean', 'te_order_1', 'te_order_2', 'te_order_3', 'te_order_4', &
      'force_order_1', 'force_order_2', 'force_order_3', 'force_order_4', 'rattle_impacts', 'rattle_open', 'rattle_criterion', &
      'rattle_energy', 'rattle_power']

   !> A deck, the model built from it and the result of its last run.
   type :: simulation_t
      private
      type(deck_t) :: deck
      type(model_t) :: model
      type(run_result_t) :: res
      logical :: has_deck = .false.   ! read_file or read_text succeeded
      logical :: built = .false.      ! model is up to date with deck
      logical :: has_run = .false.    ! res is the run of the current model
      type(override_t), allocatable :: sets(:)   ! set() calls, applied in order at build
      type(deck_group_t), allocatable :: sweeps(:)   ! the deck's &sweep groups (not built)
      type(chain_state_t) :: last_end                ! node angles and speeds at the end of the last run
   contains
      procedure :: read_file => sim_read_file
      procedure :: read_text => sim_read_text
      procedure, private :: set_text => sim_set_text
      procedure, private :: set_real => sim_set_real
      procedure, private :: set_int => sim_set_int
      !> Set a parameter by its deck path: `set('mesh.half_backlash', 0.002_wp, err)`,
      !> `set('run.integrator', "'cvode-bdf'", err)` (a character value is deck text).
      generic :: set => set_text, set_real, set_int
      procedure :: set_string => sim_set_string
      procedure :: clear_sets => sim_clear_sets
      procedure :: sweep_spec => sim_sweep_spec
      procedure :: build => sim_build
      procedure :: run => sim_run
      procedure :: get_model => sim_get_model
      procedure :: result => sim_result
      procedure :: element_ids => sim_element_ids
      procedure :: element_index => sim_element_index
      procedure :: element_metrics => sim_element_metrics
      procedure :: metric => sim_metric
      procedure :: events => sim_events
      procedure :: event_element_id => sim_event_element_id
      procedure :: stats => sim_stats
      procedure :: end_state => sim_end_state
   end type simulation_t

contains

   ! ------------------------------------------------------------------ reading

   !> Read and parse the deck file `path` (nothing is built yet). A deck's &sweep groups
   !> are kept apart, as `trainsim run` ignores them: the deck's own values are built and
   !> run; `sweep_spec` gives the sweep's runs (also for `read_text`).
   subroutine sim_read_file(self, path, err)
      class(simulation_t), intent(inout) :: self
      character(len=*), intent(in) :: path
      type(error_t), allocatable, intent(out) :: err
      call forget(self)
      call read_deck(path, self%deck, err)
      self%has_deck = .not. allocated(err)
      if (self%has_deck) call split_sweep_groups(self%deck, self%sweeps)
   end subroutine sim_read_file

   !> Parse a deck given as text (lines separated by new_line('a')); `name` stands for
   !> the file name in messages (default '<text>').
   subroutine sim_read_text(self, text, err, name)
      class(simulation_t), intent(inout) :: self
      character(len=*), intent(in) :: text
      type(error_t), allocatable, intent(out) :: err
      character(len=*), intent(in), optional :: name
      call forget(self)
      if (present(name)) then
         call parse_deck(text, name, self%deck, err)
      else
         call parse_deck(text, '<text>', self%deck, err)
      end if
      self%has_deck = .not. allocated(err)
      if (self%has_deck) call split_sweep_groups(self%deck, self%sweeps)
   end subroutine sim_read_text

   subroutine forget(self)
      class(simulation_t), intent(inout) :: self
      self%has_deck = .false.
      self%built = .false.
      self%has_run = .false.
      self%sets = [override_t ::]
   end subroutine forget

   ! ------------------------------------------------------------------ parameters

   !> Set the key at `path` (GROUP.KEY) to `value`, written in deck syntax (`0.002`,
   !> `'cvode-bdf'`, `1.0, 2.0`). Paths and values are read by the same parser as the
   !> command line's `--set` and the deck's `&sweep` (trainsim_overrides): GROUP is a
   !> node or element id, `run`, or `GROUP#K` (`load#2`); KEY a deck key or a derived
   !> parameter (`mesh_frequency`, `settle_cycles`, `measure_cycles`). The path is
   !> checked against the deck here; the value when the model is built (run does that).
   !> Later sets of one path win: a set of a path given before replaces it.
   subroutine sim_set_text(self, path, value, err)
      class(simulation_t), intent(inout) :: self
      character(len=*), intent(in) :: path, value
      type(error_t), allocatable, intent(out) :: err
      type(override_t) :: ov
      integer :: ig, i

      if (.not. self%has_deck) then
         call fatal_error(err, "set '"//path//"': no deck has been read", err_input)
         return
      end if
      call make_override(path, value, "set '"//path//"'", ov, err); if (allocated(err)) return
      call check_override(self%deck, ov, ig, err); if (allocated(err)) return
      ! a set of a path set before replaces it (a sweep of many values keeps one set)
      do i = 1, size(self%sets)
         if (to_lower(self%sets(i)%target) == to_lower(ov%target) .and. self%sets(i)%key == ov%key) then
            self%sets = [self%sets(:i - 1), self%sets(i + 1:), ov]
            exit
         end if
      end do
      if (i > size(self%sets)) self%sets = [self%sets, ov]
      self%built = .false.
      self%has_run = .false.
   end subroutine sim_set_text

   !> Set a real parameter (written with 17 significant digits, so it reads back exactly).
   subroutine sim_set_real(self, path, value, err)
      class(simulation_t), intent(inout) :: self
      character(len=*), intent(in) :: path
      real(wp), intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      character(len=32) :: buf
      write (buf, '(es26.17e3)') value
      call self%set_text(path, trim(adjustl(buf)), err)
   end subroutine sim_set_real

   !> Set an integer parameter.
   subroutine sim_set_int(self, path, value, err)
      class(simulation_t), intent(inout) :: self
      character(len=*), intent(in) :: path
      integer, intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      call self%set_text(path, str(value), err)
   end subroutine sim_set_int

   !> Set a string parameter (quoted for you): `set_string('run.integrator', 'cvode-bdf', err)`.
   subroutine sim_set_string(self, path, value, err)
      class(simulation_t), intent(inout) :: self
      character(len=*), intent(in) :: path, value
      type(error_t), allocatable, intent(out) :: err
      if (index(value, "'") > 0) then
         call self%set_text(path, '"'//value//'"', err)
      else
         call self%set_text(path, "'"//value//"'", err)
      end if
   end subroutine sim_set_string

   !> Forget every `set` (the deck's own values again).
   subroutine sim_clear_sets(self)
      class(simulation_t), intent(inout) :: self
      self%sets = [override_t ::]
      self%built = .false.
      self%has_run = .false.
   end subroutine sim_clear_sets

   !> The runs of the deck's &sweep groups (one run and no parameter without any), as
   !> `trainsim sweep` makes them: `spec%names(j)`, `spec%values(j, irun)`.
   subroutine sim_sweep_spec(self, spec, err)
      class(simulation_t), intent(in) :: self
      type(sweep_spec_t), intent(out) :: spec
      type(error_t), allocatable, intent(out) :: err
      type(deck_group_t), allocatable :: groups(:)
      if (.not. self%has_deck) then
         call fatal_error(err, 'sweep_spec: no deck has been read', err_input)
         return
      end if
      groups = self%sweeps
      call read_sweep_spec(groups, spec, err)
   end subroutine sim_sweep_spec

   ! ------------------------------------------------------------------ build and run

   !> Build the model from the deck (every node and element checks its own values).
   subroutine sim_build(self, err)
      class(simulation_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      if (.not. self%has_deck) then
         call fatal_error(err, 'build: no deck has been read', err_input)
         return
      end if
      call prepare_model(self%deck, self%sets, self%model, err)   ! as run and sweep build
      self%built = .not. allocated(err)
      self%has_run = .false.
   end subroutine sim_build

   !> Run the model (built first if the deck changed since). In memory; with `output`,
   !> the HDF5 history goes to that file too (docs/output-format.md). The deck's
   !> `&run output` is not used here: pass it as `output` if you want it.
   !> The event table is kept for `events` unless `keep_events = .false.`: then
   !> memory does not grow with the run (the table is in `output` only, if given).
   !> `sink`, if given, is handed the run too (beside `output`'s file, if any).
   subroutine sim_run(self, err, output, keep_events, sink)
      class(simulation_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      character(len=*), intent(in), optional :: output
      logical, intent(in), optional :: keep_events
      class(sink_t), intent(inout), target, optional :: sink
      type(model_t) :: m
      type(hdf5_sink_t), target :: h5
      type(null_sink_t) :: none
      type(tee_sink_t) :: tee
      self%has_run = .false.
      if (.not. self%built) then
         call self%build(err); if (allocated(err)) return
      end if
      m = self%model                  ! a run changes modes and workspace: run a copy
      m%run%keep_events = .true.
      if (present(keep_events)) m%run%keep_events = keep_events
      if (present(output)) h5%path = output
      if (present(output) .and. present(sink)) then
         tee%a => h5
         tee%b => sink
         call simulate(m, tee, self%res, err)
      else if (present(sink)) then
         call simulate(m, sink, self%res, err)
      else if (present(output)) then
         call simulate(m, h5, self%res, err)
      else
         call simulate(m, none, self%res, err)
      end if
      self%has_run = .not. allocated(err)
      if (self%has_run) call save_end_state(m, self%res%t_final, self%res%y_final, 0, self%last_end)
   end subroutine sim_run

   ! ------------------------------------------------------------------ results

   !> The model as built (for the lower-level modules: trainsim_modes, ...).
   subroutine sim_get_model(self, model, err)
      class(simulation_t), intent(in) :: self
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      if (.not. self%built) then
         call fatal_error(err, 'get_model: the model has not been built since the deck was read or changed', err_input)
         return
      end if
      model = self%model
   end subroutine sim_get_model

   !> The whole in-memory result of the last run (stats, events, metrics, final state).
   subroutine sim_result(self, res, err)
      class(simulation_t), intent(in) :: self
      type(run_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      if (.not. ran(self, 'result', err)) return
      res = self%res
   end subroutine sim_result

   logical function ran(self, what, err)
      class(simulation_t), intent(in) :: self
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      ran = self%has_run
      if (.not. ran) call fatal_error(err, what//': no run since the deck was read or changed', err_input)
   end function ran

   !> Ids of the elements, in deck order (empty before a build). A subroutine, not a
   !> function: `ids = f()` into an unallocated array of strings trips gfortran 12's
   !> false -Wuninitialized in the caller.
   subroutine sim_element_ids(self, ids)
      class(simulation_t), intent(in) :: self
      type(string_t), allocatable, intent(out) :: ids(:)
      integer :: i
      if (.not. self%built) then
         allocate (ids(0))
         return
      end if
      allocate (ids(size(self%model%elements)))
      do i = 1, size(ids)
         ids(i)%s = self%model%elements(i)%e%id
      end do
   end subroutine sim_element_ids

   !> Index of element `id` in deck order (the `element` column of the event table);
   !> 0 if there is none or the model is not built.
   integer function sim_element_index(self, id) result(k)
      class(simulation_t), intent(in) :: self
      character(len=*), intent(in) :: id
      integer :: i
      k = 0
      if (.not. self%built) return
      do i = 1, size(self%model%elements)
         if (self%model%elements(i)%e%id == id) then
            k = i
            return
         end if
      end do
   end function sim_element_index

   !> All metrics of element `id` from the last run (extremes, impacts, peak-to-peak).
   subroutine sim_element_metrics(self, id, metrics, err)
      class(simulation_t), intent(in) :: self
      character(len=*), intent(in) :: id
      type(element_metrics_t), intent(out) :: metrics
      type(error_t), allocatable, intent(out) :: err
      integer :: k
      if (.not. ran(self, 'element_metrics', err)) return
      k = self%element_index(id)
      if (k == 0) then
         call fatal_error(err, "element_metrics: no element with id '"//id//"'", err_input)
         return
      end if
      metrics = self%res%el(k)
   end subroutine sim_element_metrics

   !> One metric of element `id` by name (see metric_names): 'p2p_mean', 'force_max', ...
   !> Counts (impacts, separations, zone_changes, p2p_swings) come back as reals.
   subroutine sim_metric(self, id, name, value, err)
      class(simulation_t), intent(in) :: self
      character(len=*), intent(in) :: id, name
      real(wp), intent(out) :: value
      type(error_t), allocatable, intent(out) :: err
      type(element_metrics_t) :: m
      value = 0.0_wp
      call self%element_metrics(id, m, err); if (allocated(err)) return
      select case (to_lower(name))
      case ('force_min'); value = m%force_min
      case ('force_max'); value = m%force_max
      case ('torque_min'); value = m%torque_min
      case ('torque_max'); value = m%torque_max
      case ('disp_min'); value = m%disp_min
      case ('disp_max'); value = m%disp_max
      case ('impacts'); value = real(m%impacts, wp)
      case ('separations'); value = real(m%separations, wp)
      case ('zone_changes'); value = real(m%zone_changes, wp)
      case ('max_approach_velocity'); value = m%max_approach_velocity
      case ('max_peak_force'); value = m%max_peak_force
      case ('time_out_of_contact'); value = m%time_out_of_contact
      case ('p2p_range'); value = m%p2p_range
      case ('p2p_mean'); value = m%p2p_mean
      case ('p2p_swings'); value = real(m%p2p_swings, wp)
      case ('load_sharing'); value = m%load_sharing
      case ('kv'); value = m%kv
      case ('static_force'); value = m%static_force
      case ('static_te_mean'); value = m%static_te_mean
      case ('static_te_p2p'); value = m%static_te_p2p
      case ('force_mean'); value = m%force_mean
      case ('te_order_1', 'te_order_2', 'te_order_3', 'te_order_4'); value = m%te_order(index('1234', name(10:10)))
      case ('force_order_1', 'force_order_2', 'force_order_3', 'force_order_4')
         value = m%force_order(index('1234', name(13:13)))
      case ('rattle_impacts'); value = m%rattle_impacts
      case ('rattle_open'); value = m%rattle_open
      case ('rattle_criterion'); value = m%rattle_criterion
      case ('rattle_energy'); value = m%rattle_energy
      case ('rattle_power'); value = m%rattle_power
      case default
         call fatal_error(err, "metric: unknown metric '"//name//"'; valid: "//metric_names(), err_input)
      end select
   end subroutine sim_metric

   !> The metric names `metric` accepts, comma separated.
   function metric_names() result(s)
      character(len=:), allocatable :: s
      integer :: i
      s = trim(metric_list(1))
      do i = 2, size(metric_list)
         s = s//', '//trim(metric_list(i))
      end do
   end function metric_names

   !> The event table of the last run (time order; `element` is the index in deck order,
   !> `event_element_id` names it, `ev_name(kind)` names the kind). Empty if the run
   !> was made with `keep_events = .false.`.
   subroutine sim_events(self, events, err)
      class(simulation_t), intent(in) :: self
      type(event_t), allocatable, intent(out) :: events(:)
      type(error_t), allocatable, intent(out) :: err
      if (.not. ran(self, 'events', err)) then
         allocate (events(0))
         return
      end if
      if (allocated(self%res%events)) then
         events = self%res%events
      else
         allocate (events(0))
      end if
   end subroutine sim_events

   !> The id of the element an event row belongs to ('' if out of range).
   function sim_event_element_id(self, ev) result(id)
      class(simulation_t), intent(in) :: self
      type(event_t), intent(in) :: ev
      character(len=:), allocatable :: id
      id = ''
      if (.not. self%built) return
      if (ev%element >= 1 .and. ev%element <= size(self%model%elements)) id = self%model%elements(ev%element)%e%id
   end function sim_event_element_id

   !> Counters and timings of the last run.
   subroutine sim_stats(self, stats, err)
      class(simulation_t), intent(in) :: self
      type(run_stats_t), intent(out) :: stats
      type(error_t), allocatable, intent(out) :: err
      if (.not. ran(self, 'stats', err)) return
      stats = self%res%stats
   end subroutine sim_stats

   !> The node angles and speeds at the end of the last run (`theta`, `omega`) and the
   !> run's initial speeds (`omega0`), as a sweep records them (trainsim_continuation).
   subroutine sim_end_state(self, st, err)
      class(simulation_t), intent(in) :: self
      type(chain_state_t), intent(out) :: st
      type(error_t), allocatable, intent(out) :: err
      if (.not. ran(self, 'end_state', err)) return
      st = self%last_end
   end subroutine sim_end_state
end module trainsim
