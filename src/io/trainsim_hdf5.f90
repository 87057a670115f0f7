!> HDF5 output sink: one file per run, layout documented in docs/output-format.md.
!>
!> The file is written under a temporary name of its own in the same directory,
!> `<path>.<pid>.<n>.part`, and renamed to `<path>` only when `close` succeeds, so a
!> file under the final name is always complete, and runs writing to the same path at
!> the same time never share a temporary file (the last to finish wins, whole).
!> `<path>` is only ever replaced if it is a regular file: a directory, a symbolic
!> link, a device (/dev/null, /dev/full), a pipe or a socket is refused at `open`.
!> Samples are buffered in blocks of `block_rows` and appended to extendible, chunked
!> (optionally deflate-compressed) datasets. Event rows are streamed the same way
!> (sink_t%write_event) into /events (trainsim_hdf5_events); the describing groups
!> are trainsim_hdf5_groups'. Every HDF5 call goes through the generic layer
!> (trainsim_h5, trainsim_h5_dsets) and is checked; failures are returned as `error_t`
!> values (code `err_io`, message naming the output path); the library never prints.
!> After any error the sink cleans up after itself (ids closed, its `.part` removed) and
!> must be opened again before further use; `abort` is always safe to call.
module trainsim_hdf5
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_io, err_internal
   use trainsim_strings, only: string_t, str
   use trainsim_sink, only: sink_t, run_meta_t, sample_t, event_t, run_stats_t, element_metrics_t
   use trainsim_fs, only: pk_regular, path_kind, path_refusal, os_reason, fs_rename, fs_remove, fs_truncate, &
      process_id
   use trainsim_h5, only: hid_t, hsize_t, h5_real, h5_init, hdf5_library_stuck, deflate_available, &
      create_run_file, close_file, close_dset, put_str_attr, put_names_attr, put_fixed_names_attr
   use trainsim_h5_dsets, only: make_series, append_r1, append_r2, append_i2, make_time_scale
   use trainsim_hdf5_groups, only: run_units_t, set_units, state_units, write_root_attributes, make_node_group, &
      make_element_group, write_metrics, write_stats, label_columns, units_of, same_units, to_list, count_of, &
      opt_text
   use trainsim_hdf5_events, only: event_table_t
   implicit none
   private

   public :: hdf5_sink_t, hdf5_library_stuck

   !> Names of the five energy columns (rows of /energy in Fortran order).
   character(len=*), parameter :: energy_names(5) = [character(len=10) :: &
      'kinetic', 'potential', 'dissipated', 'input', 'balance']
   !> What the refusal of a device, pipe or socket as the output file suggests.
   character(len=*), parameter :: no_output_hint = '; use --no-output to write no file'

   !> Temporary names made by this process (part of each name, so two sinks of one
   !> process never collide either).
   integer, save :: n_temp_names = 0

   !> Indices into hdf5_sink_t%dset (ds_tl..ds_pairs in the order of /elements' series).
   integer, parameter :: ds_time = 1, ds_states = 2, ds_theta = 3, ds_omega = 4, &
      ds_energy = 5, ds_tl = 6, ds_tr = 7, ds_disp = 8, ds_force = 9, ds_contact = 10, &
      ds_pairs = 11, ds_inputs = 12, n_ds = 12

   !> Writes one run to an HDF5 file (see docs/output-format.md for the layout).
   type, extends(sink_t) :: hdf5_sink_t
      !> Final file name, set by the caller before `open`; written under `temp_path()`.
      character(len=:), allocatable :: path
      !> Samples buffered in memory before each write (also the chunk length in time).
      integer :: block_rows = 256
      !> zlib level of the series (0: none, the default). Measured on the 4-node
      !> rig, one sample per step: 0.97 us of CPU and 300 B per sample (the raw
      !> size) without compression, 5.7 us and 197 B at level 1 (docs/benchmarks.md).
      integer :: compression = 0
      !> Event rows buffered in memory before each write (also the chunk length of /events).
      integer :: event_block_rows = 256
      character(len=:), allocatable, private :: part
      logical, private :: is_open = .false.       ! between a successful open and close
      logical, private :: part_made = .false.     ! the .part file may exist
      integer(hid_t), private :: file_id = -1
      integer(hid_t), private :: dset(n_ds) = -1
      integer, private :: n_states = 0, n_nodes = 0, n_el = 0, n_in = 0, rows = 0
      type(run_units_t), private :: u
      integer, private :: n_buf = 0                ! samples in the block buffers
      integer(hsize_t), private :: n_written = 0   ! samples already in the file
      real(wp), allocatable, private :: b_time(:), b_states(:, :), b_theta(:, :), &
         b_omega(:, :), b_energy(:, :), b_tl(:, :), b_tr(:, :), b_disp(:, :), b_force(:, :), b_inputs(:, :)
      integer, allocatable, private :: b_contact(:, :), b_pairs(:, :)
      type(event_table_t), private :: events
   contains
      procedure :: open => h5_open
      procedure :: write_sample => h5_write_sample
      procedure :: close => h5_close
      procedure :: abort => h5_abort
      procedure :: write_event => h5_write_event
      procedure :: update_event => h5_update_event
      procedure :: temp_path => h5_temp_path
   end type hdf5_sink_t

contains

   ! ------------------------------------------------------------------ sink API

   !> Create `path//'.part'` with all datasets and the run description.
   subroutine h5_open(self, meta, err)
      class(hdf5_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: shown

      shown = ''
      if (allocated(self%path)) shown = self%path
      if (self%is_open) then
         call fatal_error(err, "cannot write output file '"//shown// &
                          "': the HDF5 sink is already open", err_internal)
         return
      end if
      call self%abort()   ! reset any state left from an earlier run
      if (len(shown) == 0) then
         call fatal_error(err, "cannot write output file '': no output path set", err_io)
         return
      end if
      if (self%block_rows < 1 .or. self%event_block_rows < 1) then
         call fatal_error(err, "cannot write output file '"//shown// &
                          "': block_rows and event_block_rows must be positive, got "//str(self%block_rows)// &
                          ' and '//str(self%event_block_rows), err_internal)
         return
      end if
      call open_impl(self, meta, err)
      if (allocated(err)) then
         call self%abort()
         err%message = "cannot write output file '"//shown//"': "//err%message
      end if
   end subroutine h5_open

   !> Buffer one sample; append a block to the file when the buffer is full.
   subroutine h5_write_sample(self, s, err)
      class(hdf5_sink_t), intent(inout) :: self
      type(sample_t), intent(in) :: s
      type(error_t), allocatable, intent(out) :: err
      integer :: k

      if (.not. self%is_open) then
         call fatal_error(err, 'HDF5 sink: write_sample called while not open', err_internal)
         return
      end if
      if (bad_size_r(s%y, self%n_states) .or. bad_size_r(s%theta, self%n_nodes) .or. &
          bad_size_r(s%omega, self%n_nodes) .or. bad_size_r(s%torque_left, self%n_el) .or. &
          bad_size_r(s%torque_right, self%n_el) .or. bad_size_r(s%displacement, self%n_el) .or. &
          bad_size_r(s%force, self%n_el) .or. bad_size_i(s%contact, self%n_el) .or. &
          bad_size_i(s%pairs, self%n_el) .or. bad_size_r(s%inputs, self%n_in)) then
         call fatal_error(err, "HDF5 sink '"//self%path//"': sample arrays do not match the run "// &
                          "description ("//str(self%n_states)//' states, '//str(self%n_nodes)// &
                          ' nodes, '//str(self%n_el)//' elements)', err_internal)
         call self%abort()
         return
      end if

      k = self%n_buf + 1
      self%b_time(k) = s%t
      self%b_energy(:, k) = s%energy
      if (self%n_states > 0) self%b_states(:, k) = s%y
      if (self%n_nodes > 0) then
         self%b_theta(:, k) = s%theta
         self%b_omega(:, k) = s%omega
      end if
      if (self%n_el > 0) then
         self%b_tl(:, k) = s%torque_left
         self%b_tr(:, k) = s%torque_right
         self%b_disp(:, k) = s%displacement
         self%b_force(:, k) = s%force
         self%b_contact(:, k) = s%contact
         self%b_pairs(:, k) = s%pairs
      end if
      if (self%n_in > 0) self%b_inputs(:, k) = s%inputs
      self%n_buf = k

      if (self%n_buf == self%rows) then
         call flush_block(self, err)
         if (allocated(err)) then
            err%message = "cannot write output file '"//self%path//"': "//err%message
            call self%abort()
         end if
      end if
   end subroutine h5_write_sample

   !> Flush, write the event table and run statistics, close and publish the file.
   subroutine h5_close(self, events, stats, metrics, err)
      class(hdf5_sink_t), intent(inout) :: self
      type(event_t), intent(in) :: events(:)
      type(run_stats_t), intent(in) :: stats
      type(element_metrics_t), intent(in) :: metrics(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr, i
      logical :: ok

      if (.not. self%is_open) then
         call fatal_error(err, 'HDF5 sink: close called while not open', err_internal)
         return
      end if
      if (size(metrics) /= self%n_el) then
         call fatal_error(err, 'HDF5 sink: close got metrics for '//str(size(metrics))//' elements, the run has '// &
                          str(self%n_el), err_internal)
         call self%abort()
         return
      end if
      call flush_block(self, err)
      do i = 1, size(events)   ! rows given only now, after the streamed ones
         if (allocated(err)) exit
         call h5_write_event(self, self%events%rows() + 1, events(i), err)
      end do
      if (.not. self%is_open) return   ! write_event failed and aborted
      if (.not. allocated(err)) call self%events%finish(err)
      if (.not. allocated(err)) call write_metrics(self%file_id, self%u, metrics, err)
      if (.not. allocated(err)) call write_stats(self%file_id, stats, err)
      ! a run stopped by a signal is kept with what it computed, marked as such
      if (.not. allocated(err)) then
         if (stats%completed) then
            call put_str_attr(self%file_id, 'status', 'complete', err)
         else
            call put_str_attr(self%file_id, 'status', 'interrupted', err)
         end if
      end if
      if (.not. allocated(err)) then
         do i = 1, n_ds
            call close_dset(self%dset(i), hdferr)
            if (hdferr < 0) then
               call fatal_error(err, 'H5Dclose failed', err_io)
               exit
            end if
         end do
      end if
      if (.not. allocated(err)) then
         call close_file(self%file_id, ok)   ! (a failure marks HDF5 stuck: see h5_abort)
         if (.not. ok) call fatal_error(err, 'H5Fclose failed (disk full?)', err_io)
      end if
      if (allocated(err)) then
         err%message = "cannot write output file '"//self%path//"': "//err%message
         call self%abort()
         return
      end if

      self%is_open = .false.
      call free_buffers(self)
      call self%events%abort()   ! (a finished table: only its buffer is left)
      ! rename(2) would replace a directory's entry or a symbolic link itself: check again
      if (path_kind(self%path) > pk_regular) then
         self%part_made = .false.
         call fatal_error(err, "cannot write output file '"//self%path//"': "// &
                          path_refusal(self%path, no_output_hint)// &
                          "; the complete output was left in '"//self%part//"'", err_io)
         return
      end if
      if (.not. fs_rename(self%part, self%path)) then
         ! The data are complete: keep them under the .part name rather than lose them.
         self%part_made = .false.
         call fatal_error(err, "cannot write output file '"//self%path//"': rename from '"// &
                          self%part//"' failed (the complete output was left there)", err_io)
         return
      end if
      self%part_made = .false.
   end subroutine h5_close

   !> Close whatever is open and delete the `.part` file. Safe to call at any time.
   subroutine h5_abort(self)
      class(hdf5_sink_t), intent(inout) :: self
      integer :: i
      logical :: ok

      do i = 1, n_ds
         call close_dset(self%dset(i))
      end do
      call self%events%abort()
      ! The file was created with H5F_CLOSE_STRONG: this also closes any other object.
      if (self%file_id >= 0) then
         ! The file is discarded: free its space first, so that HDF5 can flush its
         ! metadata on a full disk. A failed H5Fclose leaves a half-closed file that
         ! HDF5 1.10 cannot close again (it crashes, also in its exit handler).
         if (self%part_made .and. allocated(self%part)) call fs_truncate(self%part)
         call close_file(self%file_id, ok)
      end if
      self%file_id = -1
      if (self%part_made .and. allocated(self%part)) call fs_remove(self%part)
      self%part_made = .false.
      self%is_open = .false.
      self%n_buf = 0
      self%n_written = 0
      call free_buffers(self)
   end subroutine h5_abort

   !> Name of the temporary file of the current (or last) run, '' before the first open.
   function h5_temp_path(self) result(path)
      class(hdf5_sink_t), intent(in) :: self
      character(len=:), allocatable :: path
      path = ''
      if (allocated(self%part)) path = self%part
   end function h5_temp_path

   !> Buffer event row `row` (rows come in order); write a block when the buffer is full.
   subroutine h5_write_event(self, row, ev, err)
      class(hdf5_sink_t), intent(inout) :: self
      integer, intent(in) :: row
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      if (.not. self%is_open) then
         call fatal_error(err, 'HDF5 sink: write_event called while not open', err_internal)
         return
      end if
      call self%events%write(row, ev, err)
      if (allocated(err)) call event_failed(self, err)
   end subroutine h5_write_event

   !> Row `row` again with its final peak force and duration.
   subroutine h5_update_event(self, row, ev, err)
      class(hdf5_sink_t), intent(inout) :: self
      integer, intent(in) :: row
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      if (.not. self%is_open) then
         call fatal_error(err, 'HDF5 sink: update_event called while not open', err_internal)
         return
      end if
      call self%events%update(row, ev, err)
      if (allocated(err)) call event_failed(self, err)
   end subroutine h5_update_event

   !> An event row the table refused (err_internal) or could not write: say which
   !> file, and abort.
   subroutine event_failed(self, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(error_t), intent(inout) :: err
      if (err%code == err_internal) then
         err%message = "HDF5 sink '"//self%path//"': "//err%message
      else
         err%message = "cannot write output file '"//self%path//"': "//err%message
      end if
      call self%abort()
   end subroutine event_failed

   ! ------------------------------------------------------------- open helpers

   !> Create the temporary file `<path>.<pid>.<n>.part`, a name no other run uses: the
   !> pid is unique among running processes, n among the sinks of this process, and the
   !> file is created only if absent (so not even a stale file is overwritten).
   subroutine make_temp_file(self, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      character(len=512) :: msg
      character(len=40) :: tag
      integer :: unit, ios, attempt
      logical :: exists
      ! a stale file of a crashed run whose pid is reused is skipped, not overwritten
      do attempt = 1, 100
         n_temp_names = n_temp_names + 1
         write (tag, '(i0,".",i0)') process_id(), n_temp_names
         self%part = self%path//'.'//trim(tag)//'.part'
         msg = ''
         open (newunit=unit, file=self%part, status='new', action='write', iostat=ios, iomsg=msg)
         if (ios == 0) then
            close (unit)
            self%part_made = .true.
            return
         end if
         inquire (file=self%part, exist=exists)
         if (.not. exists) exit
      end do
      ! the operating system's reason (no such directory, permission denied, ...)
      call fatal_error(err, os_reason(msg), err_io)
   end subroutine make_temp_file

   !> Body of open: errors carry only the reason, h5_open adds the path and cleans up.
   subroutine open_impl(self, meta, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      integer :: unit, ios
      character(len=512) :: msg
      character(len=:), allocatable :: why
      integer :: level   ! zlib level of the series, 0: none

      self%n_states = count_of(meta%state_names)
      self%n_nodes = count_of(meta%node_ids)
      self%n_el = count_of(meta%element_ids)
      self%n_in = count_of(meta%input_series_names)
      call set_units(self%u, meta, self%n_el)
      self%rows = self%block_rows
      self%n_buf = 0
      self%n_written = 0

      call h5_init(err)
      if (allocated(err)) return
      ! The final name must be a regular file that can be replaced, or absent:
      ! say so now rather than after the whole run.
      why = path_refusal(self%path, no_output_hint)
      if (len(why) > 0) then
         call fatal_error(err, why, err_io)
         return
      end if
      if (path_kind(self%path) == pk_regular) then
         open (newunit=unit, file=self%path, status='old', action='write', position='append', iostat=ios, iomsg=msg)
         if (ios /= 0) then
            call fatal_error(err, os_reason(msg), err_io)
            return
         end if
         close (unit)
      end if

      ! the run's own temporary file, created empty by make_temp_file: ours alone,
      ! so truncating it is safe
      call make_temp_file(self, err)
      if (allocated(err)) return
      call create_run_file(self%part, self%file_id, err)
      if (allocated(err)) return
      self%is_open = .true.
      level = 0
      if (deflate_available()) level = self%compression

      call write_root_attributes(self%file_id, meta, err)
      if (allocated(err)) return
      call make_root_series(self, meta, level, err)
      if (allocated(err)) return
      call make_node_group(self%file_id, meta, self%n_nodes, self%rows, level, self%dset(ds_theta), &
                           self%dset(ds_omega), err)
      if (allocated(err)) return
      call make_element_group(self%file_id, meta, self%u, self%n_el, self%rows, level, self%dset(ds_tl:ds_pairs), err)
      if (allocated(err)) return
      ! /time is the dimension scale of the time axis of every series
      call make_time_scale(self%dset(ds_time), 'time', self%dset(ds_states:n_ds), err)
      if (allocated(err)) return
      call self%events%open(self%file_id, self%event_block_rows, self%u, err)
      if (allocated(err)) return
      call alloc_buffers(self)
   end subroutine open_impl

   !> The series at the root: /time, /states, /energy, /inputs (the input series as
   !> the run saw them: loads, prescribed speeds, voltages).
   subroutine make_root_series(self, meta, level, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      integer, intent(in) :: level
      type(error_t), allocatable, intent(out) :: err
      associate (f => self%file_id, r => self%rows, d => self%dset)
         call make_series(f, 'time', 1, 0, r, h5_real, level, d(ds_time), err)
         if (.not. allocated(err)) call put_str_attr(d(ds_time), 'units', 's', err)
         if (.not. allocated(err)) call make_series(f, 'states', 2, self%n_states, r, h5_real, level, d(ds_states), err)
         if (.not. allocated(err)) call put_names_attr(d(ds_states), 'names', meta%state_names, self%n_states, err)
         if (.not. allocated(err)) call label_columns(d(ds_states), meta%state_names, &
                                                      state_units(self%u, meta%state_names, self%n_states), '1', err)
         if (.not. allocated(err)) call make_series(f, 'energy', 2, 5, r, h5_real, level, d(ds_energy), err)
         if (.not. allocated(err)) call put_fixed_names_attr(d(ds_energy), 'names', energy_names, err)
         if (.not. allocated(err)) call label_columns(d(ds_energy), to_list(energy_names), &
                                                      same_units(5, self%u%energy), self%u%energy, err)
         if (.not. allocated(err)) call make_series(f, 'inputs', 2, self%n_in, r, h5_real, level, d(ds_inputs), err)
         if (.not. allocated(err)) call put_names_attr(d(ds_inputs), 'names', meta%input_series_names, self%n_in, err)
         if (.not. allocated(err)) call label_columns(d(ds_inputs), meta%input_series_names, &
                                                      units_of(meta%input_series_units), '1', err)
      end associate
   end subroutine make_root_series

   ! -------------------------------------------------------------- the samples

   !> Block buffers, allocated once per run.
   subroutine alloc_buffers(self)
      type(hdf5_sink_t), intent(inout) :: self
      integer :: r
      r = self%rows
      call free_buffers(self)
      allocate (self%b_time(r), self%b_energy(5, r))
      allocate (self%b_states(self%n_states, r), self%b_inputs(self%n_in, r))
      allocate (self%b_theta(self%n_nodes, r), self%b_omega(self%n_nodes, r))
      allocate (self%b_tl(self%n_el, r), self%b_tr(self%n_el, r), self%b_disp(self%n_el, r), &
                self%b_force(self%n_el, r), self%b_contact(self%n_el, r), self%b_pairs(self%n_el, r))
   end subroutine alloc_buffers

   subroutine free_buffers(self)
      type(hdf5_sink_t), intent(inout) :: self
      if (allocated(self%b_time)) deallocate (self%b_time)
      if (allocated(self%b_energy)) deallocate (self%b_energy)
      if (allocated(self%b_states)) deallocate (self%b_states)
      if (allocated(self%b_inputs)) deallocate (self%b_inputs)
      if (allocated(self%b_theta)) deallocate (self%b_theta)
      if (allocated(self%b_omega)) deallocate (self%b_omega)
      if (allocated(self%b_tl)) deallocate (self%b_tl)
      if (allocated(self%b_tr)) deallocate (self%b_tr)
      if (allocated(self%b_disp)) deallocate (self%b_disp)
      if (allocated(self%b_force)) deallocate (self%b_force)
      if (allocated(self%b_contact)) deallocate (self%b_contact)
      if (allocated(self%b_pairs)) deallocate (self%b_pairs)
   end subroutine free_buffers

   !> Write the buffered samples: extend every series and write one hyperslab each.
   subroutine flush_block(self, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer :: nb
      nb = self%n_buf
      if (nb == 0) return
      associate (d => self%dset, n0 => self%n_written)
         call append_r1(d(ds_time), self%b_time(1:nb), n0, '/time', err)
         if (.not. allocated(err)) call append_r2(d(ds_states), self%b_states(:, 1:nb), n0, '/states', err)
         if (.not. allocated(err)) call append_r2(d(ds_energy), self%b_energy(:, 1:nb), n0, '/energy', err)
         if (.not. allocated(err)) call append_r2(d(ds_theta), self%b_theta(:, 1:nb), n0, '/nodes/theta', err)
         if (.not. allocated(err)) call append_r2(d(ds_omega), self%b_omega(:, 1:nb), n0, '/nodes/omega', err)
         if (.not. allocated(err)) call append_r2(d(ds_tl), self%b_tl(:, 1:nb), n0, '/elements/torque_left', err)
         if (.not. allocated(err)) call append_r2(d(ds_tr), self%b_tr(:, 1:nb), n0, '/elements/torque_right', err)
         if (.not. allocated(err)) call append_r2(d(ds_disp), self%b_disp(:, 1:nb), n0, '/elements/displacement', err)
         if (.not. allocated(err)) call append_r2(d(ds_force), self%b_force(:, 1:nb), n0, '/elements/force', err)
         if (.not. allocated(err)) call append_i2(d(ds_contact), self%b_contact(:, 1:nb), n0, '/elements/contact', err)
         if (.not. allocated(err)) call append_i2(d(ds_pairs), self%b_pairs(:, 1:nb), n0, '/elements/pairs', err)
         if (.not. allocated(err)) call append_r2(d(ds_inputs), self%b_inputs(:, 1:nb), n0, '/inputs', err)
      end associate
      if (allocated(err)) return
      self%n_written = self%n_written + int(nb, hsize_t)
      self%n_buf = 0
   end subroutine flush_block

   !> True when an optional sample array does not have `n` entries.
   pure logical function bad_size_r(a, n)
      real(wp), allocatable, intent(in) :: a(:)
      integer, intent(in) :: n
      if (allocated(a)) then
         bad_size_r = size(a) /= n
      else
         bad_size_r = n > 0
      end if
   end function bad_size_r

   pure logical function bad_size_i(a, n)
      integer, allocatable, intent(in) :: a(:)
      integer, intent(in) :: n
      if (allocated(a)) then
         bad_size_i = size(a) /= n
      else
         bad_size_i = n > 0
      end if
   end function bad_size_i
end module trainsim_hdf5
