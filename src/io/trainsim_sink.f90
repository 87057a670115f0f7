!> What a run hands to an output sink: the run's description, samples at the
!> output interval, the event table and the run statistics. Sinks (HDF5 file,
!> in-memory, none) extend sink_t; the integrators never see a file format.
!>
!> The event table is streamed: each row goes to `write_event` as it happens
!> (row numbers 1, 2, ... in time order), so neither the run nor the sink needs
!> the whole table in memory. A contact row is handed over at its onset with the
!> peak force so far and duration -1; when the contact ends (or the run ends with
!> it still open) `update_event` gives the row again with its final peak_force
!> and duration (the only fields that change). Sinks that store no events keep
!> the default no-op procedures.
module trainsim_sink
   use trainsim_kinds, only: wp, i8
   use trainsim_strings, only: string_t
   use trainsim_error, only: error_t
   use trainsim_event, only: event_t, ev_contact_front, ev_contact_rear, ev_separation, ev_zone, ev_name
   use trainsim_param_list, only: param_list_t
   use trainsim_run_stats, only: run_stats_t
   use trainsim_orders, only: n_orders
   implicit none
   private

   public :: run_meta_t, param_list_t, sample_t, event_t, run_stats_t, element_metrics_t, sink_t, null_sink_t
   public :: ev_contact_front, ev_contact_rear, ev_separation, ev_zone, ev_name

   !> Everything that says how a run was made; written as attributes.
   type :: run_meta_t
      character(len=:), allocatable :: title, deck_file, deck_text, units, version, integrator
      character(len=:), allocatable :: overrides   !< --set TARGET.KEY=VALUE applied to the deck, blank-separated
      type(string_t), allocatable :: state_names(:)
      type(string_t), allocatable :: node_ids(:), node_types(:)
      type(string_t), allocatable :: element_ids(:), element_types(:)
      integer, allocatable :: element_left(:), element_right(:)  !< node indices
      type(param_list_t), allocatable :: element_params(:)
      type(param_list_t), allocatable :: node_params(:)
      !> Unit of each element's relative displacement, e.g. "in" or "rad".
      type(string_t), allocatable :: element_disp_units(:)
      !> Files the deck read (table_file): the path as the deck wrote it, the path
      !> opened, and the text, embedded beside the deck (unallocated: none).
      type(string_t), allocatable :: input_keys(:), input_files(:), input_texts(:)
      !> The input series (loads, prescribed speeds, motor voltages) of /inputs: names
      !> and units (trainsim_input_series; unallocated: none).
      type(string_t), allocatable :: input_series_names(:), input_series_units(:)
      !> Why the gear meshes have no static reference, Kv or static TE (trainsim_quasi_static's
      !> kv_absent; unallocated or '': computed, or no gear mesh; D-138)
      character(len=:), allocatable :: kv_absent
   end type run_meta_t

   !> One output sample (all arrays sized at run start; no allocation per sample).
   type :: sample_t
      real(wp) :: t = 0.0_wp
      real(wp), allocatable :: y(:)          !< full state vector
      real(wp), allocatable :: theta(:)      !< node angles (prescribed nodes included)
      real(wp), allocatable :: omega(:)      !< node speeds
      real(wp), allocatable :: torque_left(:)  !< torque each element puts on its left node
      real(wp), allocatable :: torque_right(:) !< torque each element puts on its right node
      real(wp), allocatable :: displacement(:) !< relative displacement (TE for gears)
      real(wp), allocatable :: force(:)        !< contact/mesh force (or shaft torque)
      integer, allocatable :: contact(:)       !< +1 front, 0 none, -1 rear
      integer, allocatable :: pairs(:)         !< tooth pairs in contact (0 if n/a)
      real(wp), allocatable :: inputs(:)       !< the input series at t (run_meta_t%input_series_names)
      !> kinetic, potential, dissipated, work input, balance residual
      real(wp) :: energy(5) = 0.0_wp
   end type sample_t

   !> Per-element figures of a run (over t >= t_start + settle_time).
   type :: element_metrics_t
      real(wp) :: force_min = huge(1.0_wp), force_max = -huge(1.0_wp)   !< contact force / shaft torque
      real(wp) :: torque_min = huge(1.0_wp), torque_max = -huge(1.0_wp) !< torque on the right node
      real(wp) :: disp_min = huge(1.0_wp), disp_max = -huge(1.0_wp)     !< relative displacement (TE)
      integer :: impacts = 0, separations = 0, zone_changes = 0
      real(wp) :: max_approach_velocity = 0.0_wp
      real(wp) :: max_peak_force = 0.0_wp
      real(wp) :: time_out_of_contact = 0.0_wp
      !> peak-to-peak displacement (TE for gears): max - min, and the mean
      !> swing between successive peaks (trainsim_metrics), after settle_time
      real(wp) :: p2p_range = 0.0_wp, p2p_mean = 0.0_wp
      integer :: p2p_swings = 0
      !> K = N max F_i / sum F_i of the element's set of planet meshes (D-96), F_i =
      !> max(force_max, -force_min); 0 for an element of no set (set by the observer)
      real(wp) :: load_sharing = 0.0_wp
      !> gear meshes (D-103): the dynamic factor Kv = max dynamic / max static mesh force on
      !> the face the loads press; the static reference (trainsim_quasi_static): the static
      !> mesh force (signed) and the loaded static TE's mean and peak-to-peak over a mesh
      !> cycle. 0 for any other element and when no static reference was computed.
      real(wp) :: kv = 0.0_wp, static_force = 0.0_wp, static_te_mean = 0.0_wp, static_te_p2p = 0.0_wp
      !> gear meshes (D-104): the amplitudes of the TE and of the mesh force at mesh orders
      !> 1..n_orders and the mean mesh force, over the output samples of the metrics
      !> window (trainsim_orders); 0 for any other element
      real(wp) :: te_order(n_orders) = 0.0_wp, force_order(n_orders) = 0.0_wp, force_mean = 0.0_wp
      !> gear meshes, rattle indices (D-105): impacts per mesh cycle of the window and the
      !> fraction of the window's time the mesh was out of contact
      real(wp) :: rattle_impacts = 0.0_wp, rattle_open = 0.0_wp
      !> gear meshes, rattle indices from the literature (D-134, trainsim_rattle):
      !> Brosey's inertial criterion J2 alpha1_max (r1/r2) / (|force_mean| r2) (rattle above
      !> 1), the impact energy sum 1/2 m_eq V_i^2 of the window per mesh cycle and per
      !> second; NaN where undefined (no drag, a held driven gear, both gears held)
      real(wp) :: rattle_criterion = 0.0_wp, rattle_energy = 0.0_wp, rattle_power = 0.0_wp
      !> the online peak detector could confirm p2p_mean/p2p_swings are the
      !> whole-series figures (D-17); .false. if the range grew after a swing
      !> to over ten times that swing (memory only, not in the file)
      logical :: p2p_exact = .true.
      !> contact in progress: its slot in the observer's table of open rows (0: none)
      integer :: open_event = 0
   end type element_metrics_t

   !> An output sink.
   type, abstract :: sink_t
   contains
      procedure(open_i), deferred :: open
      procedure(write_sample_i), deferred :: write_sample
      procedure(close_i), deferred :: close
      procedure :: abort => sink_abort
      procedure :: write_event => sink_write_event
      procedure :: update_event => sink_update_event
      procedure :: stores_samples => sink_stores_samples
      procedure :: speeds_only => sink_speeds_only
      procedure :: needs_meta => sink_needs_meta
      procedure :: metrics_from => sink_metrics_from
   end type sink_t

   abstract interface
      !> Prepare for a run described by `meta` (create files, datasets).
      subroutine open_i(self, meta, err)
         import :: sink_t, run_meta_t, error_t
         class(sink_t), intent(inout) :: self
         type(run_meta_t), intent(in) :: meta
         type(error_t), allocatable, intent(out) :: err
      end subroutine open_i
      !> Store one sample (called at the output interval and at every event).
      subroutine write_sample_i(self, s, err)
         import :: sink_t, sample_t, error_t
         class(sink_t), intent(inout) :: self
         type(sample_t), intent(in) :: s
         type(error_t), allocatable, intent(out) :: err
      end subroutine write_sample_i
      !> Finish a successful run: write the statistics and per-element metrics,
      !> publish. `events`: rows appended to the event table after those given to
      !> `write_event` (the observer streams every row and passes none here).
      subroutine close_i(self, events, stats, metrics, err)
         import :: sink_t, event_t, run_stats_t, element_metrics_t, error_t
         class(sink_t), intent(inout) :: self
         type(event_t), intent(in) :: events(:)
         type(run_stats_t), intent(in) :: stats
         type(element_metrics_t), intent(in) :: metrics(:)
         type(error_t), allocatable, intent(out) :: err
      end subroutine close_i
   end interface

   !> A sink that stores nothing (sweeps, tests that only want metrics).
   type, extends(sink_t) :: null_sink_t
   contains
      procedure :: open => null_open
      procedure :: write_sample => null_sample
      procedure :: close => null_close
      procedure :: stores_samples => null_stores_samples
      procedure :: needs_meta => null_needs_meta
   end type null_sink_t

contains

   !> A run that settles until periodic (&run settle_tol) starts its metrics at t,
   !> known only when it has settled. Default: nothing (a sink that keeps figures of
   !> its own over the metrics' window, as a sweep's speed range, takes it).
   subroutine sink_metrics_from(self, t)
      class(sink_t), intent(inout) :: self
      real(wp), intent(in) :: t
      associate (u1 => self, u2 => t)
      end associate
   end subroutine sink_metrics_from

   !> Default abort: nothing to clean up.
   subroutine sink_abort(self)
      class(sink_t), intent(inout) :: self
      associate (unused => self)
      end associate
   end subroutine sink_abort

   !> Whether the sink looks at the samples (asked once, at the start of a run).
   !> A sink that answers .false. is not given any: write_sample is never
   !> called, and the observer does not build them (D-34). Default: .true.
   pure logical function sink_stores_samples(self) result(stores)
      class(sink_t), intent(in) :: self
      associate (unused => self)
      end associate
      stores = .true.
   end function sink_stores_samples

   !> Whether the sink reads only the time and the node speeds (omega) of a
   !> sample (asked once, at the start of a run, of a sink that stores samples).
   !> The observer then fills only those (and the displacements it folds) when
   !> the integrator has just left them in the model's workspace; the other
   !> fields of the samples it is given are stale (D-34). Default: .false.
   pure logical function sink_speeds_only(self) result(only)
      class(sink_t), intent(in) :: self
      associate (unused => self)
      end associate
      only = .false.
   end function sink_speeds_only

   !> Default: events are not stored.
   subroutine sink_write_event(self, row, ev, err)
      class(sink_t), intent(inout) :: self
      integer, intent(in) :: row        !< row number (1, 2, ... in time order)
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => self, u2 => row, u3 => ev)
      end associate
   end subroutine sink_write_event

   !> Default: events are not stored.
   subroutine sink_update_event(self, row, ev, err)
      class(sink_t), intent(inout) :: self
      integer, intent(in) :: row        !< a row already given to write_event
      type(event_t), intent(in) :: ev   !< that row with its final peak_force and duration
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => self, u2 => row, u3 => ev)
      end associate
   end subroutine sink_update_event

   !> Whether `open` reads its run_meta_t. Default: yes. A sink that ignores it is
   !> opened with an empty one, so that start-up does not gather the model's names,
   !> parameters and input files for nothing (D-90).
   pure logical function sink_needs_meta(self) result(needs)
      class(sink_t), intent(in) :: self
      associate (unused => self)
      end associate
      needs = .true.
   end function sink_needs_meta

   !> The null sink ignores the run's description.
   pure logical function null_needs_meta(self) result(needs)
      class(null_sink_t), intent(in) :: self
      associate (unused => self)
      end associate
      needs = .false.
   end function null_needs_meta

   subroutine null_open(self, meta, err)
      class(null_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => self, u2 => meta)
      end associate
   end subroutine null_open

   subroutine null_sample(self, s, err)
      class(null_sink_t), intent(inout) :: self
      type(sample_t), intent(in) :: s
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => self, u2 => s)
      end associate
   end subroutine null_sample

   !> The null sink takes no samples.
   pure logical function null_stores_samples(self) result(stores)
      class(null_sink_t), intent(in) :: self
      associate (unused => self)
      end associate
      stores = .false.
   end function null_stores_samples

   subroutine null_close(self, events, stats, metrics, err)
      class(null_sink_t), intent(inout) :: self
      type(event_t), intent(in) :: events(:)
      type(run_stats_t), intent(in) :: stats
      type(element_metrics_t), intent(in) :: metrics(:)
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => self, u2 => events, u3 => stats, u4 => metrics)
      end associate
   end subroutine null_close
end module trainsim_sink
