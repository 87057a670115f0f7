!> HDF5 output sink: one file per run, layout documented in docs/output-format.md.
!>
!> The file is written under a temporary name of its own in the same directory,
!> `<path>.<pid>.<n>.part`, and renamed to `<path>` only when `close` succeeds, so a
!> file under the final name is always complete, and runs writing to the same path at
!> the same time never share a temporary file (the last to finish wins, whole).
!> `<path>` is only ever replaced if it is a regular file: a directory, a symbolic
!> link, a device (/dev/null, /dev/full), a pipe or a socket is refused at `open`.
!> Samples are buffered
!> in blocks of `block_rows` and appended to extendible, chunked (optionally deflate-compressed)
!> datasets. Event rows are streamed the same way (sink_t%write_event): buffered in
!> blocks of `event_block_rows`, appended to the chunked columns of /events; a row
!> already written is rewritten in place (one-row hyperslabs of peak_force and
!> duration) when its contact ends. Every HDF5 call is checked; failures are returned as `error_t` values
!> (code `err_io`, message naming the output path). HDF5's automatic error printing is
!> switched off (process-wide) when a sink is opened, so the library never prints.
!> After any error the sink cleans up after itself (ids closed, its `.part` removed) and
!> must be opened again before further use; `abort` is always safe to call.
module trainsim_hdf5
   use, intrinsic :: iso_c_binding, only: c_int, c_long, c_char, c_null_char, c_ptr, c_loc
   use hdf5, only: hid_t, hsize_t, size_t, h5open_f, h5eset_auto_f, &
      h5fcreate_f, h5fclose_f, H5F_ACC_TRUNC_F, H5F_CLOSE_STRONG_F, H5F_LIBVER_V18_F, &
      h5pcreate_f, h5pclose_f, h5pset_fclose_degree_f, h5pset_libver_bounds_f, &
      h5pset_chunk_f, h5pset_deflate_f, h5pset_cache_f, H5P_FILE_ACCESS_F, H5P_DATASET_CREATE_F, &
      h5zfilter_avail_f, H5Z_FILTER_DEFLATE_F, &
      h5screate_simple_f, h5screate_f, h5sclose_f, h5sselect_hyperslab_f, &
      H5S_SCALAR_F, H5S_UNLIMITED_F, H5S_SELECT_SET_F, &
      h5dcreate_f, h5dclose_f, h5dset_extent_f, h5dget_space_f, h5dwrite_f, h5dread_f, &
      h5gcreate_f, h5gclose_f, h5acreate_f, h5awrite_f, h5aclose_f, &
      h5tcopy_f, h5tset_size_f, h5tset_strpad_f, h5tset_cset_f, h5tclose_f, &
      H5T_STRING, H5T_STR_NULLTERM_F, H5T_CSET_UTF8_F, H5T_NATIVE_DOUBLE, H5T_NATIVE_INTEGER, &
      h5kind_to_type, H5_INTEGER_KIND
   use h5ds, only: h5dsset_scale_f, h5dsattach_scale_f
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_io, err_internal
   use trainsim_strings, only: string_t, str
   use trainsim_version, only: git_revision
   use trainsim_sink, only: sink_t, run_meta_t, sample_t, event_t, run_stats_t, element_metrics_t, &
      param_list_t, ev_name
   implicit none
   private

   public :: hdf5_sink_t, hdf5_library_stuck, mark_hdf5_stuck
   !> String helpers shared with the sweep file (src/sweep/trainsim_sweep_file.f90).
   public :: make_string_type, vlen_pointers, put_str_attr, put_column_s, write_deck_files

   !> Deflate level of the sample datasets (1 fast .. 9 small).
   !> Names of the five energy columns (rows of /energy in Fortran order).
   character(len=*), parameter :: energy_names(5) = [character(len=10) :: &
      'kinetic', 'potential', 'dissipated', 'input', 'balance']
   !> Dataset names under /elements (element ids must not clash with them).
   character(len=*), parameter :: element_sets(6) = [character(len=12) :: &
      'torque_left', 'torque_right', 'displacement', 'force', 'contact', 'pairs']
   !> Dataset names under /nodes.
   character(len=*), parameter :: node_sets(2) = [character(len=5) :: 'theta', 'omega']

   !> h5open_f has been called by this module.
   logical :: hdf5_ready = .false.
   !> Temporary names made by this process (part of each name, so two sinks of one
   !> process never collide either).
   integer, save :: n_temp_names = 0
   !> HDF5 failed to close a file even after its space was freed: the library's own
   !> clean-up at exit would then crash (HDF5 1.10 closes the half-closed file again).
   logical, save :: hdf5_stuck = .false.

   !> Kinds of path returned by trainsim_path_kind (src/io/trainsim_fs.c).
   integer, parameter :: pk_absent = 0, pk_regular = 1, pk_directory = 2, pk_symlink = 3, pk_other = 4

   !> Indices into hdf5_sink_t%dset.
   integer, parameter :: ds_time = 1, ds_states = 2, ds_theta = 3, ds_omega = 4, &
      ds_energy = 5, ds_tl = 6, ds_tr = 7, ds_disp = 8, ds_force = 9, ds_contact = 10, &
      ds_pairs = 11, ds_inputs = 12, n_ds = 12

   !> Columns of /events, in the order they are created (docs/output-format.md).
   integer, parameter :: n_evc = 15
   character(len=*), parameter :: ev_columns(n_evc) = [character(len=17) :: 'time', 'element', 'kind', &
      'kind_name', 'approach_velocity', 'restitution', 'damping', 'peak_force', 'duration', 'theta_left', &
      'omega_left', 'theta_right', 'omega_right', 'displacement', 'force']
   integer, parameter :: evc_time = 1, evc_element = 2, evc_kind = 3, evc_kind_name = 4, evc_velocity = 5, &
      evc_restitution = 6, evc_damping = 7, evc_peak = 8, evc_duration = 9, evc_theta_left = 10, &
      evc_omega_left = 11, evc_theta_right = 12, evc_omega_right = 13, evc_disp = 14, evc_force = 15

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
      !> Units of the run (length, force, torque, energy) and of each element's
      !> displacement and force columns (for the `units` attributes).
      character(len=:), allocatable, private :: u_len, u_force, u_torque, u_energy
      type(string_t), allocatable, private :: el_disp_units(:), el_force_units(:)
      integer, private :: n_buf = 0                ! samples in the block buffers
      integer(hsize_t), private :: n_written = 0   ! samples already in the file
      real(wp), allocatable, private :: b_time(:), b_states(:, :), b_theta(:, :), &
         b_omega(:, :), b_energy(:, :), b_tl(:, :), b_tr(:, :), b_disp(:, :), b_force(:, :), b_inputs(:, :)
      integer, allocatable, private :: b_contact(:, :), b_pairs(:, :)
      integer(hid_t), private :: ev_grp = -1, ev_dset(n_evc) = -1
      type(event_t), allocatable, private :: ev_buf(:)
      integer, private :: ev_n_buf = 0, ev_written = 0   ! event rows buffered, in the file
      !> Element of the first event row, and whether later rows' displacement or
      !> force units differ from its (then the columns list a unit per row).
      integer, private :: ev_el1 = 0
      logical, private :: ev_disp_mixed = .false., ev_force_mixed = .false.
   contains
      procedure :: open => h5_open
      procedure :: write_sample => h5_write_sample
      procedure :: close => h5_close
      procedure :: abort => h5_abort
      procedure :: write_event => h5_write_event
      procedure :: update_event => h5_update_event
      procedure :: temp_path => h5_temp_path
   end type hdf5_sink_t

   interface
      !> C stdio rename(3).
      function c_rename(old, new) bind(C, name='rename') result(rc)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: old(*), new(*)
         integer(c_int) :: rc
      end function c_rename
      !> C stdio remove(3).
      function c_remove(path) bind(C, name='remove') result(rc)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: rc
      end function c_remove
      !> POSIX truncate(2) (off_t is a C long on the 64-bit Linux trainsim targets).
      function c_truncate(path, length) bind(C, name='truncate') result(rc)
         import :: c_int, c_long, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_long), value :: length
         integer(c_int) :: rc
      end function c_truncate
      !> POSIX getpid(2).
      function c_getpid() bind(C, name='getpid') result(pid)
         import :: c_int
         integer(c_int) :: pid
      end function c_getpid
      !> Kind of a path, not following a final symbolic link (pk_*; src/io/trainsim_fs.c).
      function c_path_kind(path) bind(C, name='trainsim_path_kind') result(kind)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: kind
      end function c_path_kind
   end interface

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
      integer(c_int) :: rc

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
         call h5_write_event(self, self%ev_written + self%ev_n_buf + 1, events(i), err)
      end do
      if (.not. self%is_open) return   ! write_event failed and aborted
      if (.not. allocated(err)) call finish_events(self, err)
      if (.not. allocated(err)) call write_metrics(self, metrics, err)
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
            call h5dclose_f(self%dset(i), hdferr)
            if (hdferr < 0) then
               call fatal_error(err, 'H5Dclose failed', err_io)
               exit
            end if
            self%dset(i) = -1
         end do
      end if
      if (.not. allocated(err)) then
         call h5fclose_f(self%file_id, hdferr)
         if (hdferr < 0) then
            call fatal_error(err, 'H5Fclose failed (disk full?)', err_io)
            hdf5_stuck = .true.   ! HDF5 cannot close this file again (see h5_abort)
         end if
         self%file_id = -1
      end if
      if (allocated(err)) then
         err%message = "cannot write output file '"//self%path//"': "//err%message
         call self%abort()
         return
      end if

      self%is_open = .false.
      call free_buffers(self)
      ! rename(2) would replace a directory's entry or a symbolic link itself: check again
      if (c_path_kind(self%path//c_null_char) > pk_regular) then
         self%part_made = .false.
         call fatal_error(err, "cannot write output file '"//self%path//"': "//kind_reason(self%path)// &
                          "; the complete output was left in '"//self%part//"'", err_io)
         return
      end if
      rc = c_rename(self%part//c_null_char, self%path//c_null_char)
      if (rc /= 0) then
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
      integer :: hdferr, i
      integer(c_int) :: rc

      do i = 1, n_ds
         if (self%dset(i) >= 0) call h5dclose_f(self%dset(i), hdferr)
         self%dset(i) = -1
      end do
      do i = 1, n_evc
         if (self%ev_dset(i) >= 0) call h5dclose_f(self%ev_dset(i), hdferr)
         self%ev_dset(i) = -1
      end do
      if (self%ev_grp >= 0) call h5gclose_f(self%ev_grp, hdferr)
      self%ev_grp = -1
      self%ev_n_buf = 0
      self%ev_written = 0
      ! The file was created with H5F_CLOSE_STRONG: this also closes any other object.
      if (self%file_id >= 0) then
         ! The file is discarded: free its space first, so that HDF5 can flush its
         ! metadata on a full disk. A failed H5Fclose leaves a half-closed file that
         ! HDF5 1.10 cannot close again (it crashes, also in its exit handler).
         if (self%part_made .and. allocated(self%part)) rc = c_truncate(self%part//c_null_char, 0_c_long)
         call h5fclose_f(self%file_id, hdferr)
         if (hdferr < 0) hdf5_stuck = .true.
      end if
      self%file_id = -1
      if (self%part_made .and. allocated(self%part)) rc = c_remove(self%part//c_null_char)
      self%part_made = .false.
      self%is_open = .false.
      self%n_buf = 0
      self%n_written = 0
      call free_buffers(self)
   end subroutine h5_abort

   !> True if HDF5 holds a file it could not close: the program must then end without
   !> the library's exit handler (after flushing its own output), or it crashes there.
   !> Record that HDF5 failed to close a file of another module (the sweep file).
   subroutine mark_hdf5_stuck()
      hdf5_stuck = .true.
   end subroutine mark_hdf5_stuck

   logical function hdf5_library_stuck()
      hdf5_library_stuck = hdf5_stuck
   end function hdf5_library_stuck

   !> Name of the temporary file of the current (or last) run, '' before the first open.
   function h5_temp_path(self) result(path)
      class(hdf5_sink_t), intent(in) :: self
      character(len=:), allocatable :: path
      path = ''
      if (allocated(self%part)) path = self%part
   end function h5_temp_path

   ! ------------------------------------------------------------- open helpers

   !> Why `path` cannot be the output file ('' if it can: absent or a regular file).
   function kind_reason(path) result(reason)
      character(len=*), intent(in) :: path
      character(len=:), allocatable :: reason
      select case (c_path_kind(path//c_null_char))
      case (pk_directory)
         reason = 'it is a directory'
      case (pk_symlink)
         reason = 'it is a symbolic link (trainsim replaces only regular files; give the path of the link''s '// &
                  'target, or remove the link)'
      case (pk_other)
         reason = 'it is not a regular file (a device, pipe or socket); use --no-output to write no file'
      case default
         reason = ''
      end select
   end function kind_reason

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
         write (tag, '(i0,".",i0)') c_getpid(), n_temp_names
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
      integer :: hdferr, unit, ios
      character(len=512) :: msg
      logical :: deflate_ok, exists
      integer :: level   ! zlib level of the series, 0: none

      self%n_states = count_of(meta%state_names)
      self%n_nodes = count_of(meta%node_ids)
      self%n_el = count_of(meta%element_ids)
      self%n_in = count_of(meta%input_series_names)
      call set_units(self, meta)
      self%rows = self%block_rows
      self%n_buf = 0
      self%n_written = 0

      if (.not. hdf5_ready) then
         ! Once per process: every h5open_f call makes new copies of ~55 datatypes.
         call h5open_f(hdferr)
         if (hdferr < 0) then
            call fatal_error(err, 'cannot initialise the HDF5 library', err_io)
            return
         end if
         hdf5_ready = .true.
      end if
      call h5eset_auto_f(0, hdferr)   ! errors are returned as values, never printed

      ! The final name must be a regular file that can be replaced, or absent:
      ! say so now rather than after the whole run.
      if (len(kind_reason(self%path)) > 0) then
         call fatal_error(err, kind_reason(self%path), err_io)
         return
      end if
      exists = c_path_kind(self%path//c_null_char) == pk_regular
      if (exists) then
         open (newunit=unit, file=self%path, status='old', action='write', position='append', iostat=ios, iomsg=msg)
         if (ios /= 0) then
            call fatal_error(err, os_reason(msg), err_io)
            return
         end if
         close (unit)
      end if

      call create_temp_file(self, err)
      if (allocated(err)) return
      call h5zfilter_avail_f(H5Z_FILTER_DEFLATE_F, deflate_ok, hdferr)
      if (hdferr < 0) deflate_ok = .false.
      level = 0
      if (deflate_ok) level = self%compression

      call write_root_attributes(self, meta, err)
      if (allocated(err)) return
      ! Time series datasets.
      call make_series(self%file_id, 'time', 1, 0, self%rows, H5T_NATIVE_DOUBLE, level, &
                       self%dset(ds_time), err)
      if (allocated(err)) return
      call put_str_attr(self%dset(ds_time), 'units', 's', err)
      if (allocated(err)) return
      call make_series(self%file_id, 'states', 2, self%n_states, self%rows, H5T_NATIVE_DOUBLE, level, &
                       self%dset(ds_states), err)
      if (allocated(err)) return
      call put_names_attr(self%dset(ds_states), 'names', meta%state_names, self%n_states, err)
      if (allocated(err)) return
      call label_columns(self%dset(ds_states), meta%state_names, state_units(self, meta%state_names), '1', err)
      if (allocated(err)) return
      call make_series(self%file_id, 'energy', 2, 5, self%rows, H5T_NATIVE_DOUBLE, level, &
                       self%dset(ds_energy), err)
      if (allocated(err)) return
      call put_fixed_names_attr(self%dset(ds_energy), 'names', energy_names, err)
      if (allocated(err)) return
      call label_columns(self%dset(ds_energy), to_list(energy_names), same_units(5, self%u_energy), &
                         self%u_energy, err)
      if (allocated(err)) return

      ! the input series as the run saw them (loads, prescribed speeds, voltages)
      call make_series(self%file_id, 'inputs', 2, self%n_in, self%rows, H5T_NATIVE_DOUBLE, level, &
                       self%dset(ds_inputs), err)
      if (allocated(err)) return
      call put_names_attr(self%dset(ds_inputs), 'names', meta%input_series_names, self%n_in, err)
      if (allocated(err)) return
      call label_columns(self%dset(ds_inputs), meta%input_series_names, units_of(meta%input_series_units), '1', err)
      if (allocated(err)) return

      call make_node_group(self, meta, level, err)
      if (allocated(err)) return
      call make_element_group(self, meta, level, err)
      if (allocated(err)) return
      call attach_time_scale(self, err)
      if (allocated(err)) return
      call make_event_columns(self, err)
      if (allocated(err)) return
      call alloc_buffers(self)
   end subroutine open_impl

   !> Units of the run's unit system and of each element's displacement and force.
   subroutine set_units(self, meta)
      type(hdf5_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      integer :: i
      character(len=:), allocatable :: d
      if (opt_text(meta%units) == 'si') then
         self%u_len = 'm'; self%u_force = 'N'; self%u_torque = 'N*m'; self%u_energy = 'J'
      else
         self%u_len = 'in'; self%u_force = 'lbf'; self%u_torque = 'lbf*in'; self%u_energy = 'lbf*in'
      end if
      self%el_disp_units = same_units(self%n_el, '')
      self%el_force_units = same_units(self%n_el, '')
      do i = 1, self%n_el
         d = member_text(meta%element_disp_units, i)
         if (len(d) == 0) d = 'rad'
         self%el_disp_units(i)%s = d
         ! an element whose displacement is an angle has a torque for its force (shaft, coupling)
         if (d == 'rad') then
            self%el_force_units(i)%s = self%u_torque
         else
            self%el_force_units(i)%s = self%u_force
         end if
      end do
   end subroutine set_units

   !> Unit of each state from its name (node.angle, node.speed, motor.current, energy.*).
   function state_units(self, names) result(u)
      type(hdf5_sink_t), intent(in) :: self
      type(string_t), allocatable, intent(in) :: names(:)
      type(string_t), allocatable :: u(:)
      character(len=:), allocatable :: nm
      integer :: i
      allocate (u(self%n_states))
      do i = 1, self%n_states
         nm = member_text(names, i)
         if (ends_with(nm, '.angle')) then
            u(i)%s = 'rad'
         else if (ends_with(nm, '.speed')) then
            u(i)%s = 'rad/s'
         else if (ends_with(nm, '.current')) then
            u(i)%s = 'A'
         else if (index(nm, 'energy.') == 1) then
            u(i)%s = self%u_energy
         else
            u(i)%s = '1'
         end if
      end do
   end function state_units

   !> /time is the dimension scale of the time axis of every series.
   subroutine attach_time_scale(self, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr, i
      call h5dsset_scale_f(self%dset(ds_time), hdferr, 'time')
      if (hdferr < 0) then
         call fatal_error(err, 'cannot make /time a dimension scale', err_io)
         return
      end if
      do i = 1, n_ds
         if (i == ds_time) cycle
         ! idx 1: the first C dimension (the rows, h5py's axis 0); the Fortran
         ! wrapper of HDF5 1.10 passes idx - 1 unchanged (tests/check_h5_layout.py checks it)
         call h5dsattach_scale_f(self%dset(i), self%dset(ds_time), 1, hdferr)
         if (hdferr < 0) then
            call fatal_error(err, 'cannot attach the /time dimension scale', err_io)
            return
         end if
      end do
   end subroutine attach_time_scale

   !> The run's own temporary file, created through a file-access list that closes
   !> it strongly and keeps the 1.8 format.
   subroutine create_temp_file(self, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      integer(hid_t) :: fapl
      call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, hdferr)
      if (hdferr < 0) then
         call fatal_error(err, 'H5Pcreate (file access) failed', err_io)
         return
      end if
      call h5pset_fclose_degree_f(fapl, H5F_CLOSE_STRONG_F, hdferr)
      ! 1.8 format: large attributes (the deck text) go to dense storage;
      ! files stay readable by HDF5 1.8 and later.
      if (hdferr >= 0) call h5pset_libver_bounds_f(fapl, H5F_LIBVER_V18_F, H5F_LIBVER_V18_F, hdferr)
      ! No raw-data chunk cache: every block is written as whole chunks, and a
      ! rewritten event row is one read-modify-write of its chunk. (HDF5's
      ! default, 1 MiB per dataset, made a run's memory grow with its length
      ! until every one of the 26 datasets had filled its cache.)
      if (hdferr >= 0) call h5pset_cache_f(fapl, 0, 0_size_t, 0_size_t, 0.75, hdferr)
      if (hdferr >= 0) then
         ! created empty by make_temp_file: ours alone, so truncating it is safe
         call make_temp_file(self, err)
         if (allocated(err)) then
            call close_plist(fapl)
            return
         end if
         call h5fcreate_f(self%part, H5F_ACC_TRUNC_F, self%file_id, hdferr, access_prp=fapl)
         if (hdferr < 0) self%file_id = -1
      end if
      call close_plist(fapl)
      if (hdferr < 0) then
         call fatal_error(err, 'H5Fcreate failed for '''//self%part//'''', err_io)
         return
      end if
      self%is_open = .true.

   end subroutine create_temp_file

   !> Root attributes: what the run was (title, deck, units, version, integrator).
   subroutine write_root_attributes(self, meta, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      ! Root attributes.
      call put_str_attr(self%file_id, 'title', opt_text(meta%title), err)
      if (.not. allocated(err)) call put_str_attr(self%file_id, 'deck_file', opt_text(meta%deck_file), err)
      if (.not. allocated(err)) then   ! the deck text may be long: no copy
         if (allocated(meta%deck_text)) then
            call put_str_attr(self%file_id, 'deck', meta%deck_text, err)
         else
            call put_str_attr(self%file_id, 'deck', '', err)
         end if
      end if
      if (.not. allocated(err)) call put_str_attr(self%file_id, 'overrides', opt_text(meta%overrides), err)
      if (.not. allocated(err)) call put_str_attr(self%file_id, 'units', opt_text(meta%units), err)
      if (.not. allocated(err)) call put_str_attr(self%file_id, 'trainsim_version', opt_text(meta%version), err)
      if (.not. allocated(err)) call put_str_attr(self%file_id, 'git_revision', git_revision(), err)
      if (.not. allocated(err)) call put_str_attr(self%file_id, 'integrator', opt_text(meta%integrator), err)
      if (.not. allocated(err)) call put_str_attr(self%file_id, 'created', iso_now(), err)
      if (.not. allocated(err)) call write_deck_files(self%file_id, meta%input_keys, meta%input_files, &
                                                      meta%input_texts, err)
   end subroutine write_root_attributes

   !> /deck_files: the files the deck read (table_file), beside the deck text, so the
   !> file holds every input of the run. Attributes `paths` (as the deck wrote them),
   !> `files` (as opened) and `texts` (their contents), one entry per file.
   !> (Also the sweep file's.)
   subroutine write_deck_files(loc, keys, files, texts, err)
      integer(hid_t), intent(in) :: loc
      type(string_t), allocatable, intent(in) :: keys(:), files(:), texts(:)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: n, hdferr
      n = 0
      if (allocated(files)) n = size(files)
      if (n == 0) return
      call make_group(loc, 'deck_files', grp, err)
      if (allocated(err)) return
      call put_names_attr(grp, 'paths', keys, n, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'files', files, n, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'texts', texts, n, err)
      call h5gclose_f(grp, hdferr)
   end subroutine write_deck_files

   !> /nodes: angle and speed series, ids, types, parameters.
   subroutine make_node_group(self, meta, level, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      integer, intent(in) :: level   !< zlib level, 0: none
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: i
      call make_group(self%file_id, 'nodes', grp, err)
      if (allocated(err)) return
      call make_series(grp, 'theta', 2, self%n_nodes, self%rows, H5T_NATIVE_DOUBLE, level, &
                       self%dset(ds_theta), err)
      if (.not. allocated(err)) call make_series(grp, 'omega', 2, self%n_nodes, self%rows, &
                                                 H5T_NATIVE_DOUBLE, level, self%dset(ds_omega), err)
      if (.not. allocated(err)) call label_columns(self%dset(ds_theta), meta%node_ids, same_units(self%n_nodes, 'rad'), &
                                                   'rad', err)
      if (.not. allocated(err)) call label_columns(self%dset(ds_omega), meta%node_ids, &
                                                   same_units(self%n_nodes, 'rad/s'), 'rad/s', err)
      if (.not. allocated(err)) call put_names_attr(grp, 'ids', meta%node_ids, self%n_nodes, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'types', meta%node_types, self%n_nodes, err)
      if (.not. allocated(err) .and. allocated(meta%node_params)) then
         if (size(meta%node_params) /= self%n_nodes) then
            call fatal_error(err, 'run description has '//str(size(meta%node_params))// &
                             ' node parameter lists for '//str(self%n_nodes)//' nodes', err_io)
         else
            do i = 1, self%n_nodes
               call put_param_group(grp, member_name(meta%node_ids, i), node_sets, &
                                    meta%node_params(i), 'node', err)
               if (allocated(err)) exit
            end do
         end if
      end if
      call close_group(grp, err)
   end subroutine make_node_group

   !> /elements: torque, displacement, force, contact and zone series, ids,
   !> types, node indices, displacement units, parameters.
   subroutine make_element_group(self, meta, level, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      integer, intent(in) :: level   !< zlib level, 0: none
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: i
      call make_group(self%file_id, 'elements', grp, err)
      if (allocated(err)) return
      call make_series(grp, 'torque_left', 2, self%n_el, self%rows, H5T_NATIVE_DOUBLE, level, &
                       self%dset(ds_tl), err)
      if (.not. allocated(err)) call make_series(grp, 'torque_right', 2, self%n_el, self%rows, &
                                                 H5T_NATIVE_DOUBLE, level, self%dset(ds_tr), err)
      if (.not. allocated(err)) call make_series(grp, 'displacement', 2, self%n_el, self%rows, &
                                                 H5T_NATIVE_DOUBLE, level, self%dset(ds_disp), err)
      if (.not. allocated(err)) call make_series(grp, 'force', 2, self%n_el, self%rows, &
                                                 H5T_NATIVE_DOUBLE, level, self%dset(ds_force), err)
      if (.not. allocated(err)) call make_series(grp, 'contact', 2, self%n_el, self%rows, &
                                                 H5T_NATIVE_INTEGER, level, self%dset(ds_contact), err)
      if (.not. allocated(err)) call make_series(grp, 'pairs', 2, self%n_el, self%rows, &
                                                 H5T_NATIVE_INTEGER, level, self%dset(ds_pairs), err)
      if (.not. allocated(err)) call label_columns(self%dset(ds_tl), meta%element_ids, &
                                                   same_units(self%n_el, self%u_torque), self%u_torque, err)
      if (.not. allocated(err)) call label_columns(self%dset(ds_tr), meta%element_ids, &
                                                   same_units(self%n_el, self%u_torque), self%u_torque, err)
      if (.not. allocated(err)) call label_columns(self%dset(ds_disp), meta%element_ids, self%el_disp_units, &
                                                   self%u_len, err)
      if (.not. allocated(err)) call label_columns(self%dset(ds_force), meta%element_ids, self%el_force_units, &
                                                   self%u_force, err)
      if (.not. allocated(err)) call label_columns(self%dset(ds_contact), meta%element_ids, same_units(self%n_el, '1'), &
                                                   '1', err)
      if (.not. allocated(err)) call label_columns(self%dset(ds_pairs), meta%element_ids, same_units(self%n_el, '1'), &
                                                   '1', err)
      if (.not. allocated(err)) call put_names_attr(grp, 'ids', meta%element_ids, self%n_el, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'types', meta%element_types, self%n_el, err)
      if (.not. allocated(err)) call put_index_attr(grp, 'left', meta%element_left, self%n_el, err)
      if (.not. allocated(err)) call put_index_attr(grp, 'right', meta%element_right, self%n_el, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'displacement_units', &
                                                    meta%element_disp_units, self%n_el, err)
      if (.not. allocated(err)) then
         if (allocated(meta%element_params)) then
            if (size(meta%element_params) /= self%n_el) then
               call fatal_error(err, 'run description has '//str(size(meta%element_params))// &
                                ' element parameter lists for '//str(self%n_el)//' elements', err_io)
            end if
         end if
      end if
      if (.not. allocated(err)) then
         do i = 1, self%n_el
            if (allocated(meta%element_params)) then
               call put_param_group(grp, member_name(meta%element_ids, i), element_sets, &
                                    meta%element_params(i), 'element', err)
            else
               call put_param_group(grp, member_name(meta%element_ids, i), element_sets, &
                                    param_list_t(), 'element', err)
            end if
            if (allocated(err)) exit
         end do
      end if
      call close_group(grp, err)
   end subroutine make_element_group

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
      allocate (self%ev_buf(self%event_block_rows))
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
      if (allocated(self%ev_buf)) deallocate (self%ev_buf)
   end subroutine free_buffers

   !> Write the buffered samples: extend every series and write one hyperslab each.
   subroutine flush_block(self, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer :: nb
      nb = self%n_buf
      if (nb == 0) return
      call append_r1(self%dset(ds_time), self%b_time(1:nb), self%n_written, '/time', err)
      if (.not. allocated(err)) call append_r2(self%dset(ds_states), self%b_states(:, 1:nb), &
                                               self%n_written, '/states', err)
      if (.not. allocated(err)) call append_r2(self%dset(ds_energy), self%b_energy(:, 1:nb), &
                                               self%n_written, '/energy', err)
      if (.not. allocated(err)) call append_r2(self%dset(ds_theta), self%b_theta(:, 1:nb), &
                                               self%n_written, '/nodes/theta', err)
      if (.not. allocated(err)) call append_r2(self%dset(ds_omega), self%b_omega(:, 1:nb), &
                                               self%n_written, '/nodes/omega', err)
      if (.not. allocated(err)) call append_r2(self%dset(ds_tl), self%b_tl(:, 1:nb), &
                                               self%n_written, '/elements/torque_left', err)
      if (.not. allocated(err)) call append_r2(self%dset(ds_tr), self%b_tr(:, 1:nb), &
                                               self%n_written, '/elements/torque_right', err)
      if (.not. allocated(err)) call append_r2(self%dset(ds_disp), self%b_disp(:, 1:nb), &
                                               self%n_written, '/elements/displacement', err)
      if (.not. allocated(err)) call append_r2(self%dset(ds_force), self%b_force(:, 1:nb), &
                                               self%n_written, '/elements/force', err)
      if (.not. allocated(err)) call append_i2(self%dset(ds_contact), self%b_contact(:, 1:nb), &
                                               self%n_written, '/elements/contact', err)
      if (.not. allocated(err)) call append_i2(self%dset(ds_pairs), self%b_pairs(:, 1:nb), &
                                               self%n_written, '/elements/pairs', err)
      if (.not. allocated(err)) call append_r2(self%dset(ds_inputs), self%b_inputs(:, 1:nb), &
                                               self%n_written, '/inputs', err)
      if (allocated(err)) return
      self%n_written = self%n_written + int(nb, hsize_t)
      self%n_buf = 0
   end subroutine flush_block

   ! ------------------------------------------------------------ close helpers

   !> /events: one 1-D dataset per column (zero length when there are no events).
   !> /metrics: one 1-D dataset per figure, one entry per element (the order of
   !> /elements/ids), over t >= t_start + settle_time.
   subroutine write_metrics(self, m, err)
      type(hdf5_sink_t), intent(in) :: self
      type(element_metrics_t), intent(in) :: m(:)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      real(wp) :: r(size(m))
      integer :: k(size(m))
      type(string_t), allocatable :: vel(:), tq(:), cnt(:), sec(:)
      allocate (vel, source=per_second(self%el_disp_units))   ! not `vel = ...`: gfortran 12 false -Wmaybe-uninitialized
      tq = same_units(self%n_el, self%u_torque)
      cnt = same_units(self%n_el, '1')
      sec = same_units(self%n_el, 's')
      call make_group(self%file_id, 'metrics', grp, err)
      if (allocated(err)) return
      r = m%torque_min; call put_column_r(grp, 'torque_min', r, err, tq)
      r = m%torque_max; if (.not. allocated(err)) call put_column_r(grp, 'torque_max', r, err, tq)
      r = m%force_min; if (.not. allocated(err)) call put_column_r(grp, 'force_min', r, err, self%el_force_units)
      r = m%force_max; if (.not. allocated(err)) call put_column_r(grp, 'force_max', r, err, self%el_force_units)
      r = m%disp_min; if (.not. allocated(err)) call put_column_r(grp, 'displacement_min', r, err, self%el_disp_units)
      r = m%disp_max; if (.not. allocated(err)) call put_column_r(grp, 'displacement_max', r, err, self%el_disp_units)
      r = m%p2p_range; if (.not. allocated(err)) call put_column_r(grp, 'p2p_range', r, err, self%el_disp_units)
      r = m%p2p_mean; if (.not. allocated(err)) call put_column_r(grp, 'p2p_mean', r, err, self%el_disp_units)
      k = m%p2p_swings; if (.not. allocated(err)) call put_column_i(grp, 'p2p_swings', k, err, cnt)
      k = m%impacts; if (.not. allocated(err)) call put_column_i(grp, 'impacts', k, err, cnt)
      k = m%separations; if (.not. allocated(err)) call put_column_i(grp, 'separations', k, err, cnt)
      k = m%zone_changes; if (.not. allocated(err)) call put_column_i(grp, 'zone_changes', k, err, cnt)
      r = m%max_approach_velocity; if (.not. allocated(err)) call put_column_r(grp, 'max_approach_velocity', r, err, vel)
      r = m%max_peak_force; if (.not. allocated(err)) call put_column_r(grp, 'max_peak_force', r, err, self%el_force_units)
      r = m%time_out_of_contact; if (.not. allocated(err)) call put_column_r(grp, 'time_out_of_contact', r, err, sec)
      call close_group(grp, err)
   end subroutine write_metrics

   !> /events: the group and its columns, extendible and chunked (rows come in blocks).
   subroutine make_event_columns(self, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: stype, dtype
      integer :: k, hdferr
      self%ev_n_buf = 0; self%ev_written = 0; self%ev_el1 = 0
      self%ev_disp_mixed = .false.; self%ev_force_mixed = .false.
      call make_group(self%file_id, 'events', self%ev_grp, err)
      if (allocated(err)) return
      call make_string_type(stype, err)
      if (allocated(err)) return
      do k = 1, n_evc
         select case (k)
         case (evc_element, evc_kind); dtype = H5T_NATIVE_INTEGER
         case (evc_kind_name); dtype = stype
         case default; dtype = H5T_NATIVE_DOUBLE
         end select
         call make_series(self%ev_grp, trim(ev_columns(k)), 1, 0, self%event_block_rows, dtype, 0, &
                          self%ev_dset(k), err)
         if (allocated(err)) exit
      end do
      call h5tclose_f(stype, hdferr)
   end subroutine make_event_columns

   !> Buffer event row `row` (rows come in order); write a block when the buffer is full.
   subroutine h5_write_event(self, row, ev, err)
      class(hdf5_sink_t), intent(inout) :: self
      integer, intent(in) :: row
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: d1, f1, d, f
      if (.not. self%is_open) then
         call fatal_error(err, 'HDF5 sink: write_event called while not open', err_internal)
         return
      end if
      if (row /= self%ev_written + self%ev_n_buf + 1) then
         call fatal_error(err, "HDF5 sink '"//self%path//"': event row "//str(row)//' out of order (expected '// &
                          str(self%ev_written + self%ev_n_buf + 1)//')', err_internal)
         call self%abort()
         return
      end if
      if (row == 1) then
         self%ev_el1 = ev%element
      else
         call row_units(self, self%ev_el1, d1, f1)
         call row_units(self, ev%element, d, f)
         if (d /= d1) self%ev_disp_mixed = .true.
         if (f /= f1) self%ev_force_mixed = .true.
      end if
      self%ev_n_buf = self%ev_n_buf + 1
      self%ev_buf(self%ev_n_buf) = ev
      if (self%ev_n_buf == size(self%ev_buf)) then
         call flush_events(self, err)
         if (allocated(err)) then
            err%message = "cannot write output file '"//self%path//"': "//err%message
            call self%abort()
         end if
      end if
   end subroutine h5_write_event

   !> Row `row` again with its final peak force and duration: in the buffer if it
   !> is still there, else rewritten in the file (one row of those two columns).
   subroutine h5_update_event(self, row, ev, err)
      class(hdf5_sink_t), intent(inout) :: self
      integer, intent(in) :: row
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      if (.not. self%is_open) then
         call fatal_error(err, 'HDF5 sink: update_event called while not open', err_internal)
         return
      end if
      if (row < 1 .or. row > self%ev_written + self%ev_n_buf) then
         call fatal_error(err, "HDF5 sink '"//self%path//"': update of event row "//str(row)// &
                          ' not written yet', err_internal)
         call self%abort()
         return
      end if
      if (row > self%ev_written) then
         self%ev_buf(row - self%ev_written)%peak_force = ev%peak_force
         self%ev_buf(row - self%ev_written)%duration = ev%duration
         return
      end if
      call write_r_at(self%ev_dset(evc_peak), ev%peak_force, row, '/events/peak_force', err)
      if (.not. allocated(err)) call write_r_at(self%ev_dset(evc_duration), ev%duration, row, '/events/duration', err)
      if (allocated(err)) then
         err%message = "cannot write output file '"//self%path//"': "//err%message
         call self%abort()
      end if
   end subroutine h5_update_event

   !> Append the buffered event rows to every column.
   subroutine flush_events(self, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer :: nb, i, k
      real(wp), allocatable :: r(:)
      integer, allocatable :: iv(:)
      type(string_t), allocatable :: names(:)
      integer(hsize_t) :: row0
      nb = self%ev_n_buf
      if (nb == 0) return
      row0 = int(self%ev_written, hsize_t)
      allocate (r(nb), iv(nb), names(nb))
      do k = 1, n_evc
         associate (b => self%ev_buf(1:nb), what => '/events/'//trim(ev_columns(k)))
            select case (k)
            case (evc_element, evc_kind)
               if (k == evc_element) iv = b%element
               if (k == evc_kind) iv = b%kind
               call append_i1(self%ev_dset(k), iv, row0, what, err)
            case (evc_kind_name)
               do i = 1, nb
                  names(i)%s = ev_name(b(i)%kind)
               end do
               call append_s1(self%ev_dset(k), names, row0, what, err)
            case default
               select case (k)
               case (evc_time); r = b%t
               case (evc_velocity); r = b%approach_velocity
               case (evc_restitution); r = b%restitution
               case (evc_damping); r = b%damping
               case (evc_peak); r = b%peak_force
               case (evc_duration); r = b%duration
               case (evc_theta_left); r = b%theta_left
               case (evc_omega_left); r = b%omega_left
               case (evc_theta_right); r = b%theta_right
               case (evc_omega_right); r = b%omega_right
               case (evc_disp); r = b%displacement
               case (evc_force); r = b%force
               end select
               call append_r1(self%ev_dset(k), r, row0, what, err)
            end select
         end associate
         if (allocated(err)) return
      end do
      self%ev_written = self%ev_written + nb
      self%ev_n_buf = 0
   end subroutine flush_events

   !> Last block of events, the columns' units, close /events. Each row takes
   !> its element's displacement and force units; a column whose rows differ
   !> lists them per row (`entry_units`, read back from /events/element).
   subroutine finish_events(self, err)
      type(hdf5_sink_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer :: n, i, k, hdferr
      integer, allocatable :: el(:)
      character(len=:), allocatable :: d, f
      type(string_t), allocatable :: disp(:), force(:), vel(:), damp(:), u(:)
      call flush_events(self, err)
      if (allocated(err)) return
      n = self%ev_written
      if (self%ev_disp_mixed .or. self%ev_force_mixed) then
         allocate (el(n))
         call h5dread_f(self%ev_dset(evc_element), H5T_NATIVE_INTEGER, el, [int(n, hsize_t)], hdferr)
         if (hdferr < 0) then
            call fatal_error(err, 'cannot read back /events/element', err_io)
            return
         end if
      else
         allocate (el(min(n, 1)))
         if (n > 0) el = self%ev_el1
      end if
      ! per-row units (one entry when they are all the same; none without rows)
      allocate (disp(size(el)), force(size(el)), vel(size(el)), damp(size(el)))
      do i = 1, size(el)
         call row_units(self, el(i), d, f)
         disp(i)%s = d; force(i)%s = f
         vel(i)%s = d//'/s'
         ! D of eq. (3.12) (force per displacement^2 per speed); a linear law's c is force*s/displacement
         damp(i)%s = f//'*s/'//d//'^2 (yang_sun D) or '//f//'*s/'//d//' (linear c)'
      end do
      do k = 1, n_evc
         select case (k)
         case (evc_time, evc_duration); u = same_units(min(n, 1), 's')
         case (evc_theta_left, evc_theta_right); u = same_units(min(n, 1), 'rad')
         case (evc_omega_left, evc_omega_right); u = same_units(min(n, 1), 'rad/s')
         case (evc_velocity); u = vel
         case (evc_damping); u = damp
         case (evc_peak, evc_force); u = force
         case (evc_disp); u = disp
         case default; u = same_units(min(n, 1), '1')
         end select
         if (k == evc_kind_name) then
            call put_str_attr(self%ev_dset(k), 'units', '1', err)
         else
            call put_entry_units(self%ev_dset(k), u, err)
         end if
         if (allocated(err)) return
         call h5dclose_f(self%ev_dset(k), hdferr)
         self%ev_dset(k) = -1
         if (hdferr < 0) then
            call fatal_error(err, 'cannot write events/'//trim(ev_columns(k)), err_io)
            return
         end if
      end do
      call close_group(self%ev_grp, err)
      self%ev_grp = -1
   end subroutine finish_events

   !> Displacement and force units of an event row of element `el` ('1' out of range).
   subroutine row_units(self, el, d, f)
      type(hdf5_sink_t), intent(in) :: self
      integer, intent(in) :: el
      character(len=:), allocatable, intent(out) :: d, f
      if (el >= 1 .and. el <= self%n_el) then
         d = self%el_disp_units(el)%s
         f = self%el_force_units(el)%s
      else
         d = '1'; f = '1'
      end if
   end subroutine row_units

   !> /run_stats: counters (64-bit), timings and the completion flag as attributes.
   subroutine write_stats(file_id, stats, err)
      integer(hid_t), intent(in) :: file_id
      type(run_stats_t), intent(in) :: stats
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: completed

      call make_group(file_id, 'run_stats', grp, err)
      if (allocated(err)) return
      completed = merge(1, 0, stats%completed)
      call put_i8_attr(grp, 'steps', stats%steps, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'rhs_evals', stats%rhs_evals, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'jac_evals', stats%jac_evals, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'root_returns', stats%root_returns, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'error_test_fails', stats%error_test_fails, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'conv_fails', stats%conv_fails, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'events', stats%events, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'rejected', stats%rejected, err)
      if (.not. allocated(err)) call put_real_attr(grp, 'wall_time', stats%wall_time, err)
      if (.not. allocated(err)) call put_real_attr(grp, 't_final', stats%t_final, err)
      if (.not. allocated(err)) call put_int_attr(grp, 'completed', completed, err)
      if (.not. allocated(err)) call put_real_attr(grp, 't_metrics', stats%t_metrics, err)
      if (stats%settle_status /= 0) then   ! settling until periodic (&run settle_tol)
         if (.not. allocated(err)) call put_int_attr(grp, 'settled', merge(1, 0, stats%settle_status == 1 .or. &
                                                                           stats%settle_status == 3), err)
         if (.not. allocated(err)) call put_int_attr(grp, 'settle_tol_given', merge(1, 0, stats%settle_status <= 2), err)
         if (.not. allocated(err)) call put_int_attr(grp, 'settle_periods', stats%settle_periods, err)
         if (.not. allocated(err)) call put_int_attr(grp, 'settle_k', stats%settle_k, err)
      end if
      call close_group(grp, err)
   end subroutine write_stats

   ! ------------------------------------------------------- low-level writers

   !> Extendible chunked dataset: (n) when rank == 1, else (nvar x n) in Fortran order.
   !> A zero-sized variable dimension is made unlimited too (chunk sizes must be > 0).
   subroutine make_series(loc, name, rank, nvar, rows, dtype, level, dset, err)
      integer(hid_t), intent(in) :: loc, dtype
      character(len=*), intent(in) :: name
      integer, intent(in) :: rank, nvar, rows
      integer, intent(in) :: level   !< zlib level, 0: none
      integer(hid_t), intent(out) :: dset
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: space, dcpl
      integer(hsize_t) :: dims(2), maxdims(2), chunk(2)
      integer :: hdferr, hdferr2

      dset = -1
      if (rank == 1) then
         dims(1) = 0; maxdims(1) = H5S_UNLIMITED_F; chunk(1) = int(rows, hsize_t)
      else
         dims = [int(nvar, hsize_t), 0_hsize_t]
         maxdims = [int(nvar, hsize_t), H5S_UNLIMITED_F]
         if (nvar == 0) maxdims(1) = H5S_UNLIMITED_F
         chunk = [int(max(nvar, 1), hsize_t), int(rows, hsize_t)]
      end if

      call h5screate_simple_f(rank, dims(1:rank), space, hdferr, maxdims(1:rank))
      if (hdferr < 0) then
         call fatal_error(err, 'H5Screate failed for dataset '//name, err_io)
         return
      end if
      call h5pcreate_f(H5P_DATASET_CREATE_F, dcpl, hdferr)
      if (hdferr >= 0) then
         call h5pset_chunk_f(dcpl, rank, chunk(1:rank), hdferr)
         if (hdferr >= 0 .and. level > 0) call h5pset_deflate_f(dcpl, level, hdferr)
         if (hdferr >= 0) then
            call h5dcreate_f(loc, name, dtype, space, dset, hdferr, dcpl_id=dcpl)
            if (hdferr < 0) dset = -1
         end if
         call h5pclose_f(dcpl, hdferr2)
      end if
      call h5sclose_f(space, hdferr2)
      if (hdferr < 0) call fatal_error(err, 'cannot create dataset '//name, err_io)
   end subroutine make_series

   !> Extend `dset` to row0+nb rows and select the new rows; also a memory space.
   subroutine begin_append(dset, rank, nvar, row0, nb, fspace, mspace, what, err)
      integer(hid_t), intent(in) :: dset
      integer, intent(in) :: rank, nvar, nb
      integer(hsize_t), intent(in) :: row0
      integer(hid_t), intent(out) :: fspace, mspace
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hsize_t) :: dims(2), start(2), cnt(2)
      integer :: hdferr, hdferr2

      fspace = -1
      mspace = -1
      if (rank == 1) then
         dims(1) = row0 + int(nb, hsize_t); start(1) = row0; cnt(1) = int(nb, hsize_t)
      else
         dims = [int(nvar, hsize_t), row0 + int(nb, hsize_t)]
         start = [0_hsize_t, row0]
         cnt = [int(nvar, hsize_t), int(nb, hsize_t)]
      end if
      call h5dset_extent_f(dset, dims(1:rank), hdferr)
      if (hdferr < 0) then
         call fatal_error(err, 'H5Dset_extent failed for '//what, err_io)
         return
      end if
      call h5dget_space_f(dset, fspace, hdferr)
      if (hdferr < 0) then
         fspace = -1
         call fatal_error(err, 'H5Dget_space failed for '//what, err_io)
         return
      end if
      call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, start(1:rank), cnt(1:rank), hdferr)
      if (hdferr >= 0) then
         call h5screate_simple_f(rank, cnt(1:rank), mspace, hdferr)
         if (hdferr < 0) mspace = -1
      end if
      if (hdferr < 0) then
         call h5sclose_f(fspace, hdferr2)
         fspace = -1
         call fatal_error(err, 'cannot select rows of '//what, err_io)
      end if
   end subroutine begin_append

   !> Close the two spaces of an append and turn a failed write into an error.
   subroutine end_append(fspace, mspace, write_err, what, err)
      integer(hid_t), intent(in) :: fspace, mspace
      integer, intent(in) :: write_err
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call h5sclose_f(mspace, hdferr)
      call h5sclose_f(fspace, hdferr)
      if (write_err < 0) call fatal_error(err, 'H5Dwrite failed for '//what//' (disk full?)', err_io)
   end subroutine end_append

   !> A 2-d dataset with no columns (e.g. no elements): only its row count grows.
   subroutine extend_empty(dset, n_rows, what, err)
      integer(hid_t), intent(in) :: dset
      integer(hsize_t), intent(in) :: n_rows
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call h5dset_extent_f(dset, [0_hsize_t, n_rows], hdferr)
      if (hdferr < 0) call fatal_error(err, 'H5Dset_extent failed for '//what, err_io)
   end subroutine extend_empty

   subroutine append_r1(dset, buf, row0, what, err)
      integer(hid_t), intent(in) :: dset
      real(wp), contiguous, intent(in) :: buf(:)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fspace, mspace
      integer :: hdferr
      call begin_append(dset, 1, 0, row0, size(buf), fspace, mspace, what, err)
      if (allocated(err)) return
      call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, buf, [int(size(buf), hsize_t)], hdferr, &
                      mem_space_id=mspace, file_space_id=fspace)
      call end_append(fspace, mspace, hdferr, what, err)
   end subroutine append_r1

   subroutine append_r2(dset, buf, row0, what, err)
      integer(hid_t), intent(in) :: dset
      real(wp), contiguous, intent(in) :: buf(:, :)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fspace, mspace
      integer :: hdferr
      if (size(buf, 1) == 0) then   ! nothing to store, but keep the row count right
         call extend_empty(dset, row0 + int(size(buf, 2), hsize_t), what, err)
         return
      end if
      call begin_append(dset, 2, size(buf, 1), row0, size(buf, 2), fspace, mspace, what, err)
      if (allocated(err)) return
      call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, buf, int(shape(buf), hsize_t), hdferr, &
                      mem_space_id=mspace, file_space_id=fspace)
      call end_append(fspace, mspace, hdferr, what, err)
   end subroutine append_r2

   subroutine append_i2(dset, buf, row0, what, err)
      integer(hid_t), intent(in) :: dset
      integer, contiguous, intent(in) :: buf(:, :)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fspace, mspace
      integer :: hdferr
      if (size(buf, 1) == 0) then   ! nothing to store, but keep the row count right
         call extend_empty(dset, row0 + int(size(buf, 2), hsize_t), what, err)
         return
      end if
      call begin_append(dset, 2, size(buf, 1), row0, size(buf, 2), fspace, mspace, what, err)
      if (allocated(err)) return
      call h5dwrite_f(dset, H5T_NATIVE_INTEGER, buf, int(shape(buf), hsize_t), hdferr, &
                      mem_space_id=mspace, file_space_id=fspace)
      call end_append(fspace, mspace, hdferr, what, err)
   end subroutine append_i2

   subroutine append_i1(dset, buf, row0, what, err)
      integer(hid_t), intent(in) :: dset
      integer, contiguous, intent(in) :: buf(:)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fspace, mspace
      integer :: hdferr
      call begin_append(dset, 1, 0, row0, size(buf), fspace, mspace, what, err)
      if (allocated(err)) return
      call h5dwrite_f(dset, H5T_NATIVE_INTEGER, buf, [int(size(buf), hsize_t)], hdferr, &
                      mem_space_id=mspace, file_space_id=fspace)
      call end_append(fspace, mspace, hdferr, what, err)
   end subroutine append_i1

   !> Append variable-length UTF-8 strings.
   subroutine append_s1(dset, texts, row0, what, err)
      integer(hid_t), intent(in) :: dset
      type(string_t), intent(in) :: texts(:)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fspace, mspace, stype
      integer :: hdferr, hdferr2
      character(kind=c_char), allocatable, target :: pool(:)
      type(c_ptr), allocatable, target :: ptrs(:)
      call make_string_type(stype, err)
      if (allocated(err)) return
      call begin_append(dset, 1, 0, row0, size(texts), fspace, mspace, what, err)
      if (.not. allocated(err)) then
         call vlen_pointers(texts, pool, ptrs)
         call h5dwrite_f(dset, stype, c_loc(ptrs), hdferr, mem_space_id=mspace, file_space_id=fspace)
         call end_append(fspace, mspace, hdferr, what, err)
      end if
      call h5tclose_f(stype, hdferr2)
   end subroutine append_s1

   !> Rewrite entry `row` (1-based) of a 1-D float64 dataset.
   subroutine write_r_at(dset, value, row, what, err)
      integer(hid_t), intent(in) :: dset
      real(wp), intent(in) :: value
      integer, intent(in) :: row
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fspace, mspace
      integer :: hdferr, hdferr2
      real(wp) :: v(1)
      v(1) = value
      call h5dget_space_f(dset, fspace, hdferr)
      if (hdferr < 0) then
         call fatal_error(err, 'H5Dget_space failed for '//what, err_io)
         return
      end if
      call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, [int(row - 1, hsize_t)], [1_hsize_t], hdferr)
      if (hdferr >= 0) then
         call h5screate_simple_f(1, [1_hsize_t], mspace, hdferr)
         if (hdferr >= 0) then
            call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, v, [1_hsize_t], hdferr, mem_space_id=mspace, file_space_id=fspace)
            call h5sclose_f(mspace, hdferr2)
         end if
      end if
      call h5sclose_f(fspace, hdferr2)
      if (hdferr < 0) call fatal_error(err, 'cannot rewrite a row of '//what//' (disk full?)', err_io)
   end subroutine write_r_at

   !> Fixed-size 1-D dataset (contiguous; may have zero length).
   subroutine make_column(loc, name, dtype, n, dset, err)
      integer(hid_t), intent(in) :: loc, dtype
      character(len=*), intent(in) :: name
      integer, intent(in) :: n
      integer(hid_t), intent(out) :: dset
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: space
      integer :: hdferr, hdferr2
      dset = -1
      call h5screate_simple_f(1, [int(n, hsize_t)], space, hdferr)
      if (hdferr < 0) then
         call fatal_error(err, 'H5Screate failed for events/'//name, err_io)
         return
      end if
      call h5dcreate_f(loc, name, dtype, space, dset, hdferr)
      if (hdferr < 0) then
         dset = -1
         call fatal_error(err, 'cannot create dataset events/'//name, err_io)
      end if
      call h5sclose_f(space, hdferr2)
   end subroutine make_column

   !> Close a column dataset, reporting a failed write or close.
   subroutine finish_column(dset, write_err, name, err)
      integer(hid_t), intent(in) :: dset
      integer, intent(in) :: write_err
      character(len=*), intent(in) :: name
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call h5dclose_f(dset, hdferr)
      if (write_err < 0 .or. hdferr < 0) call fatal_error(err, 'cannot write events/'//name, err_io)
   end subroutine finish_column

   !> Column of variable-length UTF-8 strings (units '1').
   subroutine put_column_s(loc, name, texts, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      type(string_t), intent(in) :: texts(:)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: dset, stype
      integer :: hdferr, hdferr2
      character(kind=c_char), allocatable, target :: pool(:)
      type(c_ptr), allocatable, target :: ptrs(:)
      call make_string_type(stype, err)
      if (allocated(err)) return
      call make_column(loc, name, stype, size(texts), dset, err)
      if (.not. allocated(err)) then
         hdferr = 0
         if (size(texts) > 0) then
            call vlen_pointers(texts, pool, ptrs)
            call h5dwrite_f(dset, stype, c_loc(ptrs), hdferr)
         end if
         if (hdferr >= 0) call put_str_attr(dset, 'units', '1', err)
         if (allocated(err)) hdferr = -1
         call finish_column(dset, hdferr, name, err)
      end if
      call h5tclose_f(stype, hdferr2)
   end subroutine put_column_s

   !> 1-D column with its `units` (the common unit of `entry_units`, or `mixed`) and,
   !> when the entries differ, one unit per entry in `entry_units`.
   subroutine put_column_r(loc, name, values, err, entry_units)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      real(wp), contiguous, intent(in) :: values(:)
      type(error_t), allocatable, intent(out) :: err
      type(string_t), intent(in) :: entry_units(:)
      integer(hid_t) :: dset
      integer :: hdferr
      call make_column(loc, name, H5T_NATIVE_DOUBLE, size(values), dset, err)
      if (allocated(err)) return
      hdferr = 0
      if (size(values) > 0) call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, values, [int(size(values), hsize_t)], hdferr)
      if (hdferr >= 0) call put_entry_units(dset, entry_units, err)
      if (allocated(err)) hdferr = -1
      call finish_column(dset, hdferr, name, err)
   end subroutine put_column_r

   subroutine put_column_i(loc, name, values, err, entry_units)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer, contiguous, intent(in) :: values(:)
      type(error_t), allocatable, intent(out) :: err
      type(string_t), intent(in) :: entry_units(:)
      integer(hid_t) :: dset
      integer :: hdferr
      call make_column(loc, name, H5T_NATIVE_INTEGER, size(values), dset, err)
      if (allocated(err)) return
      hdferr = 0
      if (size(values) > 0) call h5dwrite_f(dset, H5T_NATIVE_INTEGER, values, [int(size(values), hsize_t)], hdferr)
      if (hdferr >= 0) call put_entry_units(dset, entry_units, err)
      if (allocated(err)) hdferr = -1
      call finish_column(dset, hdferr, name, err)
   end subroutine put_column_i

   !> `units` = the entries' common unit ('mixed: see entry_units' when they differ,
   !> with `entry_units` then listing them; '1' for an empty column).
   subroutine put_entry_units(dset, units, err)
      integer(hid_t), intent(in) :: dset
      type(string_t), intent(in) :: units(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: i
      logical :: same
      same = .true.
      do i = 2, size(units)
         if (units(i)%s /= units(1)%s) same = .false.
      end do
      if (size(units) == 0) then
         call put_str_attr(dset, 'units', '1', err)
      else if (same) then
         call put_str_attr(dset, 'units', units(1)%s, err)
      else
         call put_str_attr(dset, 'units', 'mixed: see entry_units', err)
         if (.not. allocated(err)) call put_list_attr(dset, 'entry_units', units, err)
      end if
   end subroutine put_entry_units

   !> `column_names` and `column_units` of a 2-D series (one per column) and its `units`:
   !> the columns' common unit, `mixed: see column_units`, or `empty_unit` with no columns.
   subroutine label_columns(dset, names, units, empty_unit, err)
      integer(hid_t), intent(in) :: dset
      type(string_t), allocatable, intent(in) :: names(:)
      type(string_t), intent(in) :: units(:)
      character(len=*), intent(in) :: empty_unit
      type(error_t), allocatable, intent(out) :: err
      integer :: i
      logical :: same
      call put_names_attr(dset, 'column_names', names, size(units), err)
      if (allocated(err)) return
      call put_list_attr(dset, 'column_units', units, err)
      if (allocated(err)) return
      same = .true.
      do i = 2, size(units)
         if (units(i)%s /= units(1)%s) same = .false.
      end do
      if (size(units) == 0) then
         call put_str_attr(dset, 'units', empty_unit, err)
      else if (same) then
         call put_str_attr(dset, 'units', units(1)%s, err)
      else
         call put_str_attr(dset, 'units', 'mixed: see column_units', err)
      end if
   end subroutine label_columns

   !> The units of a list that may be unallocated (none).
   pure function units_of(list) result(units)
      type(string_t), allocatable, intent(in) :: list(:)
      type(string_t), allocatable :: units(:)
      if (allocated(list)) then
         units = list
      else
         allocate (units(0))
      end if
   end function units_of

   !> `n` copies of one unit.
   pure function same_units(n, unit) result(list)
      integer, intent(in) :: n
      character(len=*), intent(in) :: unit
      type(string_t) :: list(n)
      integer :: i
      do i = 1, n
         list(i)%s = unit
      end do
   end function same_units

   !> Each unit per second (speeds of displacements).
   pure function per_second(units) result(list)
      type(string_t), intent(in) :: units(:)
      type(string_t) :: list(size(units))
      integer :: i
      do i = 1, size(units)
         list(i)%s = units(i)%s//'/s'
      end do
   end function per_second

   !> A character array as a list (trailing blanks dropped).
   pure function to_list(names) result(list)
      character(len=*), intent(in) :: names(:)
      type(string_t), allocatable :: list(:)
      integer :: i
      allocate (list(size(names)))
      do i = 1, size(names)
         list(i)%s = trim(names(i))
      end do
   end function to_list

   pure logical function ends_with(text, tail)
      character(len=*), intent(in) :: text, tail
      ends_with = .false.
      if (len(text) >= len(tail)) ends_with = text(len(text) - len(tail) + 1:) == tail
   end function ends_with

   !> One buffer holding every text NUL-terminated, and a pointer to each (the
   !> memory layout of an array of variable-length C strings).
   subroutine vlen_pointers(texts, pool, ptrs)
      type(string_t), intent(in) :: texts(:)
      character(kind=c_char), allocatable, target, intent(out) :: pool(:)
      type(c_ptr), allocatable, intent(out) :: ptrs(:)
      integer :: i, j, k, total
      total = 0
      do i = 1, size(texts)
         total = total + text_len(texts(i)) + 1
      end do
      allocate (pool(max(total, 1)), ptrs(size(texts)))
      k = 1
      do i = 1, size(texts)
         ptrs(i) = c_loc(pool(k))
         do j = 1, text_len(texts(i))
            pool(k) = texts(i)%s(j:j)
            k = k + 1
         end do
         pool(k) = c_null_char
         k = k + 1
      end do
   end subroutine vlen_pointers

   pure integer function text_len(t)
      type(string_t), intent(in) :: t
      text_len = 0
      if (allocated(t%s)) text_len = len(t%s)
   end function text_len

   !> Variable-length, UTF-8 C string type (h5py reads it as str). The deck reader
   !> accepts only UTF-8 text without NUL, so titles, ids and the deck are valid.
   subroutine make_string_type(stype, err)
      integer(hid_t), intent(out) :: stype
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr, hdferr2
      call h5tcopy_f(H5T_STRING, stype, hdferr)
      if (hdferr < 0) then
         stype = -1
         call fatal_error(err, 'H5Tcopy failed for a string type', err_io)
         return
      end if
      ! the Fortran H5T_STRING is already a variable-length C string (setting its
      ! size to H5T_VARIABLE again through h5tset_size_f breaks the VL writes)
      call h5tset_strpad_f(stype, H5T_STR_NULLTERM_F, hdferr)
      if (hdferr >= 0) call h5tset_cset_f(stype, H5T_CSET_UTF8_F, hdferr)
      if (hdferr < 0) then
         call h5tclose_f(stype, hdferr2)
         stype = -1
         call fatal_error(err, 'cannot set up a variable-length string type', err_io)
      end if
   end subroutine make_string_type

   !> Create attribute `name` of type `dtype` with `n` elements (scalar if n < 0).
   subroutine make_attr(loc, name, dtype, n, attr, err)
      integer(hid_t), intent(in) :: loc, dtype
      character(len=*), intent(in) :: name
      integer, intent(in) :: n
      integer(hid_t), intent(out) :: attr
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: space
      integer :: hdferr, hdferr2
      attr = -1
      if (n < 0) then
         call h5screate_f(H5S_SCALAR_F, space, hdferr)
      else
         call h5screate_simple_f(1, [int(n, hsize_t)], space, hdferr)
      end if
      if (hdferr < 0) then
         call fatal_error(err, 'H5Screate failed for attribute '//name, err_io)
         return
      end if
      call h5acreate_f(loc, name, dtype, space, attr, hdferr)
      if (hdferr < 0) then
         attr = -1
         call fatal_error(err, "cannot create attribute '"//name//"'", err_io)
      end if
      call h5sclose_f(space, hdferr2)
   end subroutine make_attr

   !> Close an attribute, reporting a failed write or close.
   subroutine finish_attr(attr, write_err, name, err)
      integer(hid_t), intent(in) :: attr
      integer, intent(in) :: write_err
      character(len=*), intent(in) :: name
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call h5aclose_f(attr, hdferr)
      if (write_err < 0 .or. hdferr < 0) call fatal_error(err, "cannot write attribute '"//name//"'", err_io)
   end subroutine finish_attr

   !> Scalar string attribute (variable length, UTF-8; '' allowed).
   subroutine put_str_attr(loc, name, value, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name, value
      type(error_t), allocatable, intent(out) :: err
      type(string_t) :: one(1)
      one(1)%s = value
      call write_str_attr(loc, name, one, .true., err)
   end subroutine put_str_attr

   !> 1-D string attribute from a list of `n` names (unallocated list: `n` empty strings).
   subroutine put_names_attr(loc, name, list, n, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      type(string_t), allocatable, intent(in) :: list(:)
      integer, intent(in) :: n
      type(error_t), allocatable, intent(out) :: err
      type(string_t) :: texts(n)
      integer :: i
      if (allocated(list)) then
         if (size(list) /= n) then
            call fatal_error(err, 'run description: '//name//' has '//str(size(list))// &
                             ' entries, expected '//str(n), err_io)
            return
         end if
      end if
      do i = 1, n
         texts(i)%s = member_text(list, i)
      end do
      call write_str_attr(loc, name, texts, .false., err)
   end subroutine put_names_attr

   !> 1-D string attribute from a list.
   subroutine put_list_attr(loc, name, texts, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      type(string_t), intent(in) :: texts(:)
      type(error_t), allocatable, intent(out) :: err
      call write_str_attr(loc, name, texts, .false., err)
   end subroutine put_list_attr

   !> 1-D string attribute from a character array (trailing blanks dropped).
   subroutine put_fixed_names_attr(loc, name, names, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      character(len=*), contiguous, intent(in) :: names(:)
      type(error_t), allocatable, intent(out) :: err
      call write_str_attr(loc, name, to_list(names), .false., err)
   end subroutine put_fixed_names_attr

   !> A variable-length string attribute: scalar (one text) or 1-D.
   subroutine write_str_attr(loc, name, texts, scalar, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      type(string_t), intent(in) :: texts(:)
      logical, intent(in) :: scalar
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: stype, attr
      integer :: hdferr, hdferr2
      character(kind=c_char), allocatable, target :: pool(:)
      type(c_ptr), allocatable, target :: ptrs(:)
      call make_string_type(stype, err)
      if (allocated(err)) return
      call make_attr(loc, name, stype, merge(-1, size(texts), scalar), attr, err)
      if (.not. allocated(err)) then
         hdferr = 0
         if (size(texts) > 0) then
            call vlen_pointers(texts, pool, ptrs)
            call h5awrite_f(attr, stype, c_loc(ptrs), hdferr)
         end if
         call finish_attr(attr, hdferr, name, err)
      end if
      call h5tclose_f(stype, hdferr2)
   end subroutine write_str_attr

   !> 1-D integer attribute of `n` node indices (the list must be allocated when n > 0).
   subroutine put_index_attr(loc, name, list, n, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer, allocatable, intent(in) :: list(:)
      integer, intent(in) :: n
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: attr
      integer :: hdferr
      integer :: buf(n)
      if (n > 0) then
         if (.not. allocated(list)) then
            call fatal_error(err, 'run description: element '//name//' nodes are missing', err_io)
            return
         end if
         if (size(list) /= n) then
            call fatal_error(err, 'run description: element '//name//' has '//str(size(list))// &
                             ' entries, expected '//str(n), err_io)
            return
         end if
         buf = list
      end if
      call make_attr(loc, name, H5T_NATIVE_INTEGER, n, attr, err)
      if (allocated(err)) return
      hdferr = 0
      if (n > 0) call h5awrite_f(attr, H5T_NATIVE_INTEGER, buf, [int(n, hsize_t)], hdferr)
      call finish_attr(attr, hdferr, name, err)
   end subroutine put_index_attr

   subroutine put_real_attr(loc, name, value, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      real(wp), intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: attr
      integer :: hdferr
      call make_attr(loc, name, H5T_NATIVE_DOUBLE, -1, attr, err)
      if (allocated(err)) return
      call h5awrite_f(attr, H5T_NATIVE_DOUBLE, value, [1_hsize_t], hdferr)
      call finish_attr(attr, hdferr, name, err)
   end subroutine put_real_attr

   subroutine put_int_attr(loc, name, value, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer, intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: attr
      integer :: hdferr
      call make_attr(loc, name, H5T_NATIVE_INTEGER, -1, attr, err)
      if (allocated(err)) return
      call h5awrite_f(attr, H5T_NATIVE_INTEGER, value, [1_hsize_t], hdferr)
      call finish_attr(attr, hdferr, name, err)
   end subroutine put_int_attr

   subroutine put_i8_attr(loc, name, value, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer(i8), intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: attr, itype
      integer :: hdferr
      itype = h5kind_to_type(i8, H5_INTEGER_KIND)
      call make_attr(loc, name, itype, -1, attr, err)
      if (allocated(err)) return
      call h5awrite_f(attr, itype, value, [1_hsize_t], hdferr)
      call finish_attr(attr, hdferr, name, err)
   end subroutine put_i8_attr

   !> Subgroup `<parent>/<name>` holding one scalar real attribute per parameter.
   subroutine put_param_group(parent, name, reserved, params, what, err)
      integer(hid_t), intent(in) :: parent
      character(len=*), intent(in) :: name, what
      character(len=*), intent(in) :: reserved(:)
      type(param_list_t), intent(in) :: params
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: j, n
      if (any(reserved == name)) then
         call fatal_error(err, what//" id '"//name//"' clashes with the dataset of that name", err_io)
         return
      end if
      if (index(name, '/') > 0 .or. name == '.' .or. name == '..') then
         call fatal_error(err, what//" id '"//name//"' cannot be used as an HDF5 group name", err_io)
         return
      end if
      n = 0
      if (allocated(params%values)) n = size(params%values)
      if (n > 0) then
         if (.not. allocated(params%names)) then
            call fatal_error(err, what//" '"//name//"': parameter names are missing", err_io)
            return
         end if
         if (size(params%names) /= n) then
            call fatal_error(err, what//" '"//name//"': "//str(size(params%names))// &
                             ' parameter names for '//str(n)//' values', err_io)
            return
         end if
      end if
      call make_group(parent, name, grp, err)
      if (allocated(err)) return
      do j = 1, n
         if (len(member_text(params%names, j)) == 0) then
            call fatal_error(err, what//" '"//name//"': parameter "//str(j)//' has no name', err_io)
            exit
         end if
         call put_real_attr(grp, member_text(params%names, j), params%values(j), err)
         if (allocated(err)) then
            err%message = what//" '"//name//"': "//err%message//' (duplicate name?)'
            exit
         end if
      end do
      call close_group(grp, err)
   end subroutine put_param_group

   subroutine make_group(loc, name, grp, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer(hid_t), intent(out) :: grp
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call h5gcreate_f(loc, name, grp, hdferr)
      if (hdferr < 0) then
         grp = -1
         call fatal_error(err, "cannot create group '"//name//"'", err_io)
      end if
   end subroutine make_group

   !> Close a group; keeps an earlier error, or reports a failed close.
   subroutine close_group(grp, err)
      integer(hid_t), intent(in) :: grp
      type(error_t), allocatable, intent(inout) :: err
      integer :: hdferr
      if (grp < 0) return
      call h5gclose_f(grp, hdferr)
      if (hdferr < 0 .and. .not. allocated(err)) call fatal_error(err, 'H5Gclose failed', err_io)
   end subroutine close_group

   subroutine close_plist(plist)
      integer(hid_t), intent(in) :: plist
      integer :: hdferr
      call h5pclose_f(plist, hdferr)
   end subroutine close_plist

   ! ------------------------------------------------------------ small utilities

   !> Number of entries of an optional list.
   pure integer function count_of(list)
      type(string_t), allocatable, intent(in) :: list(:)
      count_of = 0
      if (allocated(list)) count_of = size(list)
   end function count_of

   !> Entry `i` of an optional list ('' when absent).
   pure function member_text(list, i) result(text)
      type(string_t), allocatable, intent(in) :: list(:)
      integer, intent(in) :: i
      character(len=:), allocatable :: text
      text = ''
      if (.not. allocated(list)) return
      if (i > size(list)) return
      if (allocated(list(i)%s)) text = list(i)%s
   end function member_text

   !> Group name for member `i`: its id, or '_<i>' when the id is empty.
   pure function member_name(list, i) result(name)
      type(string_t), allocatable, intent(in) :: list(:)
      integer, intent(in) :: i
      character(len=:), allocatable :: name
      name = member_text(list, i)
      if (len(name) == 0) name = '_'//str(i)
   end function member_name

   !> An optional deferred-length text ('' when unallocated).
   pure function opt_text(text) result(out)
      character(len=:), allocatable, intent(in) :: text
      character(len=:), allocatable :: out
      out = ''
      if (allocated(text)) out = text
   end function opt_text

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

   !> The operating-system part of a gfortran OPEN message ("Cannot open file 'x': reason").
   pure function os_reason(msg) result(reason)
      character(len=*), intent(in) :: msg
      character(len=:), allocatable :: reason
      integer :: k
      k = index(msg, ': ', back=.true.)
      if (k > 0) then
         reason = trim(msg(k + 2:))
      else
         reason = trim(msg)
      end if
      if (len(reason) == 0) reason = 'cannot create file'
   end function os_reason

   !> Local date and time as ISO 8601, e.g. 2024-05-01T13:45:07+02:00.
   function iso_now() result(stamp)
      character(len=:), allocatable :: stamp
      character(len=8) :: d
      character(len=10) :: t
      character(len=5) :: z
      call date_and_time(date=d, time=t, zone=z)
      stamp = d(1:4)//'-'//d(5:6)//'-'//d(7:8)//'T'//t(1:2)//':'//t(3:4)//':'//t(5:6)
      if (len_trim(z) == 5) stamp = stamp//z(1:3)//':'//z(4:5)
   end function iso_now
end module trainsim_hdf5
