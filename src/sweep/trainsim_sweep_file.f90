!> The sweep file: one HDF5 file per sweep, written by rank 0 only (docs/sweeps.md).
!>
!> Every dataset is created at the start with one slot per run (contiguous, space
!> allocated at once, fill values NaN / -1 / status 0), so recording a finished run
!> writes raw data into its slot and touches no HDF5 metadata. Runs are committed in
!> batches: their slots are written as they finish; at most every `commit_interval`
!> seconds (and before a progress line, and at the end) the file is flushed, then the
!> batch's statuses are written and the file flushed again: after a `kill -9` at any
!> moment the file opens, and a run with a non-zero status is complete. The runs of a
!> batch not yet committed are made again by the next `trainsim sweep` (their results
!> are the same bits). `--resume` runs only the runs whose status is still 0.
!>
!> One writer at a time: `open` takes an flock on `FILE.lock` before it looks at FILE
!> (a second `trainsim sweep` on the same FILE is refused; the kernel drops the lock of a
!> killed process, so a lock file left by `kill -9` is never stale). A new file is made
!> under a temporary name of its own, `FILE.<pid>.part` (created exclusively), and
!> renamed to FILE when its layout is complete. A commit writes statuses only after the
!> flush of their runs succeeded, so a full disk never commits a run whose data are not
!> on disk. The file's `fingerprint` attribute names everything that decides results
!> (the parsed deck, the contents of its table files, the --set overrides, the trainsim
!> version): a file whose fingerprint differs holds another sweep and is refused.
!>
!> Strings (attributes, ids, names, the deck text, run messages) are variable-length
!> UTF-8, as in run files (the helpers of trainsim_hdf5): h5py reads attributes as str
!> and string datasets with `.asstr()`. An empty message is the fill value (no heap
!> object); a failed run's message is written to the global heap with its slot, before
!> the flush that precedes its status.
!>
!> Fortran (n, n_runs) arrays appear in h5py as (n_runs, n).
module trainsim_sweep_file
   use, intrinsic :: iso_c_binding, only: c_char, c_int, c_null_char, c_ptr, c_loc, c_f_pointer, c_size_t, &
      c_associated, c_long, c_long_long, c_null_ptr
   use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_io, err_input
   use trainsim_strings, only: string_t, str
   use trainsim_hdf5, only: make_string_type, vlen_pointers, put_str_attr, put_column_s, write_deck_files, &
      mark_hdf5_stuck
   use hdf5, only: hid_t, hsize_t, size_t, h5open_f, h5fcreate_f, h5fopen_f, h5fclose_f, h5fflush_f, &
      h5gcreate_f, h5gclose_f, h5screate_simple_f, h5sclose_f, h5sselect_hyperslab_f, &
      h5dcreate_f, h5dopen_f, h5dclose_f, h5dwrite_f, h5dread_f, h5dget_space_f, &
      h5sget_simple_extent_dims_f, h5pcreate_f, h5pclose_f, h5pset_alloc_time_f, h5pset_fill_value_f, &
      h5pset_obj_track_times_f, h5tclose_f, h5aexists_f, h5aopen_f, h5aclose_f, h5aread_f, h5eset_auto_f, &
      H5F_ACC_EXCL_F, H5F_ACC_RDWR_F, H5F_SCOPE_GLOBAL_F, H5S_SELECT_SET_F, &
      H5P_DATASET_CREATE_F, H5D_ALLOC_TIME_EARLY_F, H5T_NATIVE_DOUBLE, H5T_NATIVE_INTEGER, &
      h5gopen_f, h5lexists_f, h5lmove_f, h5ldelete_f, h5garbage_collect_f
   implicit none
   private

   public :: sweep_file_t, sweep_layout_t, sweep_record_t, element_metric_names, node_metric_names
   public :: status_pending, status_ok, status_failed, record_size, format_version, status_names
   public :: path_refusal

   !> Run statuses: the value stored in /runs/status is the index into status_names
   !> (a new status is one more name here and one parameter); any other value in a
   !> file is invalid (the run is made again).
   integer, parameter :: status_pending = 0, status_ok = 1, status_failed = 2
   character(len=*), parameter :: status_names(0:2) = [character(len=7) :: 'pending', 'ok', 'failed']
   !> Layout version (2: variable-length UTF-8 strings, nodes/start_speed).
   character(len=*), parameter :: format_version = '2'

   !> Per-element metrics (element_metrics_t), in record order; the integer counts are
   !> stored as integer datasets.
   character(len=*), parameter :: element_metric_names(15) = [character(len=21) :: &
      'force_min', 'force_max', 'torque_min', 'torque_max', 'disp_min', 'disp_max', 'impacts', 'separations', &
      'zone_changes', 'max_approach_velocity', 'max_peak_force', 'time_out_of_contact', 'p2p_range', &
      'p2p_mean', 'p2p_swings']
   logical, parameter :: element_metric_is_int(15) = [.false., .false., .false., .false., .false., .false., &
      .true., .true., .true., .false., .false., .false., .false., .false., .true.]
   !> Per-node metrics: the speed range after settle_time, the angle and speed at the
   !> end of the run, and the run's initial speed (what the next run of a continuation
   !> branch starts from, trainsim_continuation, also when a killed sweep is resumed).
   character(len=*), parameter :: node_metric_names(5) = [character(len=11) :: 'speed_min', 'speed_max', &
                                                          'end_angle', 'end_speed', 'start_speed']
   !> Per-run figures besides the metrics; the last three say whether the run settled
   !> (&run settle_tol, D-44): settled 1 yes, 0 not within the budget (its metrics are of
   !> a transient), -1 not asked; settle_periods, settle_k as in a run file's /run_stats.
   integer, parameter :: n_run_values = 7
   character(len=*), parameter :: run_value_names(n_run_values) = [character(len=15) :: 'steps', 'rhs_evals', &
                                                                   'events', 'energy_residual', 'settled', &
                                                                   'settle_periods', 'settle_k']
   integer, parameter :: n_head = 4   ! irun, status, rank, wall time

   !> What the file describes (the same on every rank: built from the deck).
   type :: sweep_layout_t
      character(len=:), allocatable :: version, deck_file, deck_text, title, units, overrides
      !> what decides results, one item a line ("deck <digest>", "file <digest> <path>",
      !> "overrides <text>", "version <text>"): see trainsim_sweep%fingerprint
      character(len=:), allocatable :: fingerprint
      !> the files the deck reads (table_file), as in a run file's /deck_files
      type(string_t), allocatable :: input_keys(:), input_files(:), input_texts(:)
      type(string_t), allocatable :: param_names(:)
      real(wp), allocatable :: param_values(:, :)    !< (parameter, run)
      type(string_t), allocatable :: element_ids(:), element_types(:), node_ids(:)
      integer :: n_runs = 0
      integer, allocatable :: branch(:)             !< per run: 0 fixed start, 1 up, 2 down (continuation)
   end type sweep_layout_t

   !> One finished run, as sent to rank 0 and written to its slot.
   type :: sweep_record_t
      integer :: irun = 0, status = status_pending, rank = 0
      real(wp) :: wall = 0.0_wp
      real(wp) :: run_values(n_run_values) = 0.0_wp
      real(wp), allocatable :: el(:, :)      !< (element metric, element)
      real(wp), allocatable :: node(:, :)    !< (node metric, node)
      character(len=:), allocatable :: message
   contains
      procedure :: pack => record_pack
      procedure :: unpack => record_unpack
   end type sweep_record_t

   type :: sweep_file_t
      character(len=:), allocatable :: path
      character(len=:), allocatable :: lock_path
      integer(c_int) :: lock_fd = -1
      integer :: n_invalid = 0               !< runs whose status in the file was invalid (made again)
      integer :: invalid_value = 0           !< the first such status
      integer(hid_t) :: file = -1
      integer(hid_t) :: d_status = -1, d_wall = -1, d_rank = -1, d_message = -1, t_message = -1
      integer(hid_t) :: d_run(n_run_values) = -1
      integer(hid_t) :: d_el(15) = -1, d_node(5) = -1
      integer :: ne = 0, nn = 0, n_runs = 0
      integer, allocatable :: status(:)      !< as in the file once committed
      integer, allocatable :: batch(:)       !< runs written but not committed
      integer :: n_batch = 0
      real(wp) :: commit_interval = 0.5_wp   !< s between commits (0: every run)
      integer(i8) :: last_commit = 0
   contains
      procedure :: open => file_open
      procedure :: create => file_create
      procedure :: open_existing => file_open_existing
      procedure :: write_run => file_write_run
      procedure :: commit => file_commit
      procedure :: read_end_state => file_read_end_state
      procedure :: close => file_close
   end type sweep_file_t

   !> Kinds of path returned by trainsim_path_kind (src/io/trainsim_fs.c).
   integer, parameter :: pk_absent = 0, pk_regular = 1, pk_directory = 2, pk_symlink = 3, pk_other = 4

   interface
      function c_path_kind(path) bind(C, name='trainsim_path_kind') result(kind)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: kind
      end function c_path_kind
      function c_lock(path, info) bind(C, name='trainsim_lock') result(fd)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int), intent(out) :: info
         integer(c_int) :: fd
      end function c_lock
      subroutine c_unlock(fd, path) bind(C, name='trainsim_unlock')
         import :: c_int, c_char
         integer(c_int), value :: fd
         character(kind=c_char), intent(in) :: path(*)
      end subroutine c_unlock
      subroutine c_strerror(e, buf, n) bind(C, name='trainsim_strerror')
         import :: c_int, c_char
         integer(c_int), value :: e, n
         character(kind=c_char), intent(out) :: buf(*)
      end subroutine c_strerror
      function c_errno() bind(C, name='trainsim_errno') result(e)
         import :: c_int
         integer(c_int) :: e
      end function c_errno
      function c_free_bytes(path) bind(C, name='trainsim_free_bytes') result(n)
         import :: c_char, c_long_long
         character(kind=c_char), intent(in) :: path(*)
         integer(c_long_long) :: n
      end function c_free_bytes
      function c_remove_stale_parts(path) bind(C, name='trainsim_remove_stale_parts') result(n)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: n
      end function c_remove_stale_parts
      subroutine c_trim_memory() bind(C, name='trainsim_trim_memory')
      end subroutine c_trim_memory
      function c_getpid() bind(C, name='getpid') result(pid)
         import :: c_int
         integer(c_int) :: pid
      end function c_getpid
      function c_remove(path) bind(C, name='remove') result(rc)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: rc
      end function c_remove
      function c_truncate(path, length) bind(C, name='truncate') result(rc)
         import :: c_int, c_long, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_long), value :: length
         integer(c_int) :: rc
      end function c_truncate
      function c_rename(old, new) bind(C, name='rename') result(rc)
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: old(*), new(*)
         integer(c_int) :: rc
      end function c_rename
      pure function c_strlen(p) bind(C, name='strlen') result(n)
         import :: c_ptr, c_size_t
         type(c_ptr), value :: p
         integer(c_size_t) :: n
      end function c_strlen
      !> Frees what HDF5 allocated for a variable-length read.
      function c_h5free_memory(p) bind(C, name='H5free_memory') result(rc)
         import :: c_ptr, c_int
         type(c_ptr), value :: p
         integer(c_int) :: rc
      end function c_h5free_memory
   end interface

contains

   !> Length of a packed record.
   pure integer function record_size(ne, nn) result(n)
      integer, intent(in) :: ne, nn
      n = n_head + size(run_value_names) + size(element_metric_names)*ne + size(node_metric_names)*nn
   end function record_size

   subroutine record_pack(self, buf)
      class(sweep_record_t), intent(in) :: self
      real(wp), intent(out) :: buf(:)
      integer :: k, ne, nn
      ne = size(self%el, 2); nn = size(self%node, 2)
      buf(1:n_head) = [real(self%irun, wp), real(self%status, wp), real(self%rank, wp), self%wall]
      k = n_head
      buf(k + 1:k + n_run_values) = self%run_values; k = k + n_run_values
      buf(k + 1:k + size(self%el)) = reshape(self%el, [size(self%el)]); k = k + size(self%el)
      buf(k + 1:k + size(self%node)) = reshape(self%node, [size(self%node)])
   end subroutine record_pack

   !> Fill from a packed buffer; el and node must be allocated to their shapes.
   subroutine record_unpack(self, buf)
      class(sweep_record_t), intent(inout) :: self
      real(wp), intent(in) :: buf(:)
      integer :: k
      self%irun = nint(buf(1)); self%status = nint(buf(2)); self%rank = nint(buf(3)); self%wall = buf(4)
      k = n_head
      self%run_values = buf(k + 1:k + n_run_values); k = k + n_run_values
      self%el = reshape(buf(k + 1:k + size(self%el)), shape(self%el)); k = k + size(self%el)
      self%node = reshape(buf(k + 1:k + size(self%node)), shape(self%node))
   end subroutine record_unpack

   ! ------------------------------------------------------------------------------------------

   !> Why `path` cannot be a sweep file ('' if it can: absent or a regular file).
   function path_refusal(path) result(reason)
      character(len=*), intent(in) :: path
      character(len=:), allocatable :: reason
      select case (c_path_kind(path//c_null_char))
      case (pk_directory)
         reason = 'it is a directory'
      case (pk_symlink)
         reason = 'it is a symbolic link (trainsim writes only regular files; give the path of the link''s '// &
                  'target, or remove the link)'
      case (pk_other)
         reason = 'it is not a regular file (a device, pipe or socket): a sweep records and resumes its runs '// &
                  'in a file'
      case default
         reason = ''
      end select
   end function path_refusal

   !> Open the sweep file `path` for this sweep: refuse a path that is not a regular file,
   !> take the writer lock, then continue the file if it exists (it must hold this sweep)
   !> or create it (unless `resume`: then it must exist). On error nothing is held.
   subroutine file_open(self, path, lay, resume, err)
      class(sweep_file_t), intent(inout) :: self
      character(len=*), intent(in) :: path
      type(sweep_layout_t), intent(in) :: lay
      logical, intent(in) :: resume
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: why
      integer(c_int) :: info

      self%path = path
      why = path_refusal(path)
      if (len(why) > 0) then
         call fatal_error(err, "cannot write sweep file '"//path//"': "//why, err_io)
         return
      end if
      self%lock_path = path//'.lock'
      self%lock_fd = c_lock(self%lock_path//c_null_char, info)
      if (self%lock_fd == -1) then
         why = 'another trainsim sweep is writing it'
         if (info > 0) why = why//' (process '//str(int(info))//')'
         call fatal_error(err, "sweep file '"//path//"': "//why//": wait until it ends (the same command "// &
                          "then completes the sweep), or write this sweep to another file with -o", err_io)
         return
      else if (self%lock_fd < 0) then
         call fatal_error(err, "cannot write sweep file '"//path//"': cannot create its lock file '"// &
                          self%lock_path//"': "//os_text(info), err_io)
         return
      end if
      ! a sweep killed while creating FILE left its FILE.<pid>.part: under the lock, stale
      info = c_remove_stale_parts(path//c_null_char)
      why = path_refusal(path)     ! (again: the path may have changed before the lock was ours)
      if (len(why) > 0) then
         call fatal_error(err, "cannot write sweep file '"//path//"': "//why, err_io)
      else if (c_path_kind(path//c_null_char) == pk_regular) then
         call self%open_existing(path, lay, err)
      else if (resume) then
         call fatal_error(err, "nothing to resume: sweep file '"//path//"' does not exist", err_io)
      else
         call self%create(path, lay, err)
      end if
      if (allocated(err)) call self%close()
   end subroutine file_open

   !> Create a new sweep file at `path` (written as `path.<pid>.part`, renamed when
   !> complete), then open it for the runs. The caller holds the lock.
   subroutine file_create(self, path, lay, err)
      class(sweep_file_t), intent(inout) :: self
      character(len=*), intent(in) :: path
      type(sweep_layout_t), intent(in) :: lay
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: f, g, d_branch
      integer :: h, hs, k
      integer(c_int) :: rc
      character(len=:), allocatable :: part
      type(string_t), allocatable :: text(:)

      ! under the lock a temporary of this pid is a crashed process's (pids are reused)
      part = path//'.'//str(int(c_getpid()))//'.part'
      rc = c_remove(part//c_null_char)
      call h5open_f(h)
      call h5eset_auto_f(0, h)
      call h5fcreate_f(part, H5F_ACC_EXCL_F, f, h)
      if (h < 0) then
         call fatal_error(err, "cannot create sweep file '"//part//"'"//io_reason(part), err_io)
         return
      end if
      hs = 0
      call put_str_attr(f, 'format', 'trainsim-sweep', err)
      if (.not. allocated(err)) call put_str_attr(f, 'format_version', format_version, err)
      if (.not. allocated(err)) call put_str_attr(f, 'trainsim_version', lay%version, err)
      if (.not. allocated(err)) call put_str_attr(f, 'deck_file', lay%deck_file, err)
      if (.not. allocated(err)) call put_str_attr(f, 'title', lay%title, err)
      if (.not. allocated(err)) call put_str_attr(f, 'units', lay%units, err)
      if (.not. allocated(err)) call put_str_attr(f, 'overrides', lay%overrides, err)
      if (.not. allocated(err)) call put_str_attr(f, 'n_runs', str(lay%n_runs), err)
      if (.not. allocated(err)) call put_str_attr(f, 'fingerprint', lay%fingerprint, err)
      allocate (text(1))
      text(1)%s = lay%deck_text       ! (an array constructor of string_t here trips gfortran 12)
      if (.not. allocated(err)) call put_column_s(f, 'deck_text', text, err)
      if (.not. allocated(err)) call write_deck_files(f, lay%input_keys, lay%input_files, lay%input_texts, err)
      call h5gcreate_f(f, 'parameters', g, h); hs = min(hs, h)
      if (size(lay%param_names) > 0) then
         if (.not. allocated(err)) call put_column_s(g, 'names', lay%param_names, err)
         call put_reals(g, 'values', lay%param_values, h); hs = min(hs, h)
      end if
      call h5gclose_f(g, h)
      if (.not. allocated(err) .and. hs == 0) then
         call h5gcreate_f(f, 'runs', g, h); hs = min(hs, h)
         call new_dset(g, 'status', [lay%n_runs], H5T_NATIVE_INTEGER, self%d_status, hs, ifill=status_pending)
         call put_str_attr(self%d_status, 'meaning', status_meaning(), err)
         call new_dset(g, 'rank', [lay%n_runs], H5T_NATIVE_INTEGER, self%d_rank, hs, ifill=-1)
         call new_dset(g, 'wall_time', [lay%n_runs], H5T_NATIVE_DOUBLE, self%d_wall, hs)
         do k = 1, size(run_value_names)
            call new_dset(g, trim(run_value_names(k)), [lay%n_runs], H5T_NATIVE_DOUBLE, self%d_run(k), hs)
         end do
         if (.not. allocated(err)) call make_string_type(self%t_message, err)
         if (.not. allocated(err)) call new_dset(g, 'message', [lay%n_runs], self%t_message, self%d_message, hs)
         call new_dset(g, 'branch', [lay%n_runs], H5T_NATIVE_INTEGER, d_branch, hs, ifill=0)
         if (allocated(lay%branch) .and. hs == 0) then
            do k = 1, lay%n_runs
               call put_slot_int(d_branch, k, [lay%branch(k)], h); hs = min(hs, h)
            end do
         end if
         if (d_branch >= 0) call h5dclose_f(d_branch, h)
         call h5gclose_f(g, h)
      end if
      if (.not. allocated(err) .and. hs == 0) then
         call h5gcreate_f(f, 'elements', g, h); hs = min(hs, h)
         if (size(lay%element_ids) > 0) then
            call put_column_s(g, 'ids', lay%element_ids, err)
            if (.not. allocated(err)) call put_column_s(g, 'types', lay%element_types, err)
            do k = 1, size(element_metric_names)
               if (element_metric_is_int(k)) then
                  call new_dset(g, trim(element_metric_names(k)), [size(lay%element_ids), lay%n_runs], &
                                H5T_NATIVE_INTEGER, self%d_el(k), hs, ifill=-1)
               else
                  call new_dset(g, trim(element_metric_names(k)), [size(lay%element_ids), lay%n_runs], &
                                H5T_NATIVE_DOUBLE, self%d_el(k), hs)
               end if
            end do
         end if
         call h5gclose_f(g, h)
      end if
      if (.not. allocated(err) .and. hs == 0) then
         call h5gcreate_f(f, 'nodes', g, h); hs = min(hs, h)
         if (.not. allocated(err)) call put_column_s(g, 'ids', lay%node_ids, err)
         do k = 1, size(node_metric_names)
            call new_dset(g, trim(node_metric_names(k)), [size(lay%node_ids), lay%n_runs], H5T_NATIVE_DOUBLE, &
                          self%d_node(k), hs)
         end do
         call h5gclose_f(g, h)
      end if
      call close_ids(self)
      if (allocated(err) .or. hs < 0) then
         ! free the space first, so that HDF5 can close the file on a full disk
         rc = c_truncate(part//c_null_char, 0_c_long)
         call h5fclose_f(f, h)
         if (h < 0) call mark_hdf5_stuck()
         rc = c_remove(part//c_null_char)
         ! (the string helpers' own message names a run file's group: not repeated)
         call fatal_error(err, "cannot write sweep file '"//path//"'"//io_reason(path), err_io)
         return
      end if
      call h5fclose_f(f, h)
      if (h < 0) then
         call mark_hdf5_stuck()
         rc = c_remove(part//c_null_char)
         call fatal_error(err, "cannot write sweep file '"//path//"'"//io_reason(path), err_io)
         return
      end if
      if (c_rename(part//c_null_char, path//c_null_char) /= 0) then
         rc = c_remove(part//c_null_char)
         call fatal_error(err, "cannot rename '"//part//"' to '"//path//"'"//io_reason(path), err_io)
         return
      end if
      call self%open_existing(path, lay, err)
   end subroutine file_create

   !> "0 pending, 1 ok, 2 failed": the meaning of /runs/status.
   function status_meaning() result(s)
      character(len=:), allocatable :: s
      integer :: k
      s = ''
      do k = lbound(status_names, 1), ubound(status_names, 1)
         if (k > lbound(status_names, 1)) s = s//', '
         s = s//str(k)//' '//trim(status_names(k))
      end do
   end function status_meaning

   !> ": <the operating system's reason>" after a failed write to `path` ('' if unknown):
   !> errno if it names a full disk, else "no space left" if the file system has none.
   function io_reason(path) result(r)
      character(len=*), intent(in) :: path
      character(len=:), allocatable :: r
      integer(c_int) :: e
      integer(c_long_long) :: free
      character(len=:), allocatable :: dir
      integer :: i
      integer(c_int), parameter :: enospc = 28, edquot = 122
      e = c_errno()
      r = ''
      if (e == enospc .or. e == edquot) then
         r = ': '//os_text(e)
         return
      end if
      i = index(path, '/', back=.true.)
      dir = '.'
      if (i > 0) dir = path(1:max(i - 1, 1))
      free = c_free_bytes(dir//c_null_char)
      if (free >= 0 .and. free < 65536_c_long_long) r = ': '//os_text(enospc)//' ('//str(int(free))//' bytes free)'
   end function io_reason

   function os_text(e) result(t)
      integer(c_int), intent(in) :: e
      character(len=:), allocatable :: t
      character(kind=c_char) :: buf(256)
      integer :: i
      call c_strerror(e, buf, 256_c_int)
      t = ''
      do i = 1, 255
         if (buf(i) == c_null_char) exit
         t = t//buf(i)
      end do
   end function os_text

   !> Open an existing sweep file for the remaining runs; it must hold the same sweep
   !> (version, fingerprint of its inputs, overrides, runs). A run whose status is not
   !> one of status_names is made again (n_invalid counts them).
   subroutine file_open_existing(self, path, lay, err)
      class(sweep_file_t), intent(inout) :: self
      character(len=*), intent(in) :: path
      type(sweep_layout_t), intent(in) :: lay
      type(error_t), allocatable, intent(out) :: err
      integer :: h, hs, k
      character(len=:), allocatable :: s, why
      real(wp), allocatable :: pv(:, :)
      logical :: ok

      self%path = path
      call h5open_f(h)
      call h5eset_auto_f(0, h)
      call h5fopen_f(path, H5F_ACC_RDWR_F, self%file, h)
      if (h < 0) then
         self%file = -1
         call fatal_error(err, "cannot open sweep file '"//path//"' for writing (not an HDF5 file, damaged, "// &
                          'or open in another program)', err_io)
         return
      end if
      why = ''
      call get_attr(self%file, 'format', s, ok)
      if (.not. ok .or. s /= 'trainsim-sweep') then
         ! (format_version 1 had fixed-length strings, which do not read as variable-length)
         if (h5_attr_exists(self%file, 'format')) then
            why = 'it is a sweep file of an older layout, not format_version '//format_version
         else
            why = 'it is not a trainsim sweep file'
         end if
      else
         call get_attr(self%file, 'format_version', s, ok)
         if (s /= format_version) why = 'its layout is version '//s//', this trainsim writes '//format_version
      end if
      if (len(why) == 0) then
         call get_attr(self%file, 'trainsim_version', s, ok)
         if (len(why) == 0 .and. s /= lay%version) why = 'it was written by trainsim '//s//', this is '//lay%version
         call get_attr(self%file, 'overrides', s, ok)
         if (len(why) == 0 .and. s /= lay%overrides) why = 'its --set options differ ("'//s//'")'
         call get_attr(self%file, 'fingerprint', s, ok)
         if (len(why) == 0) then
            if (.not. ok) then
               why = 'it has no fingerprint of its inputs: written by an older trainsim'
            else if (s /= lay%fingerprint) then
               why = fingerprint_difference(s, lay%fingerprint, lay%deck_file)
            end if
         end if
         call get_attr(self%file, 'n_runs', s, ok)
         if (len(why) == 0 .and. s /= str(lay%n_runs)) why = 'it has '//s//' runs, this sweep '//str(lay%n_runs)
         if (len(why) == 0 .and. size(lay%param_names) > 0) then
            allocate (pv(size(lay%param_names), lay%n_runs))
            call get_reals(self%file, 'parameters/values', pv, ok)
            if (.not. ok) then
               why = 'its parameter table does not match'
            else if (any(pv /= lay%param_values)) then
               why = 'its parameter values differ'
            end if
         end if
      end if
      if (len(why) > 0) then
         call h5fclose_f(self%file, h)
         self%file = -1
         call fatal_error(err, "sweep file '"//path//"' holds another sweep ("//why// &
                          '): delete it, or write this sweep to another file with -o', err_input)
         return
      end if
      self%ne = size(lay%element_ids); self%nn = size(lay%node_ids); self%n_runs = lay%n_runs
      hs = 0
      ! a rebuild of /runs/message (below) killed between its delete and its move
      call h5lexists_f(self%file, 'runs/message', ok, h)
      if (h >= 0 .and. .not. ok) then
         call h5lexists_f(self%file, 'runs/message.new', ok, h)
         if (h >= 0 .and. ok) call h5lmove_f(self%file, 'runs/message.new', self%file, 'runs/message', h)
      end if
      call h5dopen_f(self%file, 'runs/status', self%d_status, h); hs = min(hs, h)
      call h5dopen_f(self%file, 'runs/rank', self%d_rank, h); hs = min(hs, h)
      call h5dopen_f(self%file, 'runs/wall_time', self%d_wall, h); hs = min(hs, h)
      call h5dopen_f(self%file, 'runs/message', self%d_message, h); hs = min(hs, h)
      call make_string_type(self%t_message, err)
      if (allocated(err)) return
      do k = 1, size(run_value_names)
         call h5dopen_f(self%file, 'runs/'//trim(run_value_names(k)), self%d_run(k), h); hs = min(hs, h)
      end do
      if (self%ne > 0) then
         do k = 1, size(element_metric_names)
            call h5dopen_f(self%file, 'elements/'//trim(element_metric_names(k)), self%d_el(k), h); hs = min(hs, h)
         end do
      end if
      do k = 1, size(node_metric_names)
         call h5dopen_f(self%file, 'nodes/'//trim(node_metric_names(k)), self%d_node(k), h); hs = min(hs, h)
      end do
      allocate (self%status(self%n_runs))
      if (hs == 0) call h5dread_f(self%d_status, H5T_NATIVE_INTEGER, self%status, [int(self%n_runs, hsize_t)], h)
      if (hs < 0 .or. h < 0) then
         call fatal_error(err, "cannot read the runs of sweep file '"//path//"' (damaged: a dataset is missing "// &
                          'or unreadable): delete it, or write this sweep to another file with -o', err_io)
         return
      end if
      self%n_invalid = 0
      do k = 1, self%n_runs
         if (self%status(k) < lbound(status_names, 1) .or. self%status(k) > ubound(status_names, 1)) then
            if (self%n_invalid == 0) self%invalid_value = self%status(k)
            self%n_invalid = self%n_invalid + 1
            self%status(k) = status_pending
         end if
      end do
      call clean_messages(self, err)
      ! the fill and read buffers of the creation and of this open (sized by the number
      ! of runs) stay in HDF5's free lists unless given back
      call h5garbage_collect_f(h)
   end subroutine file_open_existing

   !> A run's message (a variable-length string, a global-heap object) reaches the disk
   !> at the commit's flush, its slot earlier: the slot of a run written but not
   !> committed (a kill, a full disk) may refer to a heap object never written, or to
   !> one that a later heap reuses, and HDF5 reads the old value of a slot it overwrites.
   !> So if any run not made holds a message (or an unreadable one), /runs/message is
   !> made again with the messages of the committed runs only (created as
   !> message.new, then moved over the old one; open_existing completes a move that
   !> was killed half-way).
   subroutine clean_messages(self, err)
      type(sweep_file_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      type(string_t), allocatable :: msgs(:)
      character(len=:), allocatable :: m
      integer(hid_t) :: g, d
      integer :: h, hs, k
      logical :: ok, stale
      stale = .false.
      do k = 1, self%n_runs         ! (nothing kept per run: memory stays flat in the runs)
         call get_message(self, k, m, ok)
         if (self%status(k) == status_pending) then
            if (.not. ok .or. len(m) > 0) stale = .true.
         else if (.not. ok) then
            call fatal_error(err, "cannot read the message of run "//str(k)//" of sweep file '"//self%path// &
                             "' (damaged): delete it, or write this sweep to another file with -o", err_io)
            return
         end if
      end do
      if (.not. stale) return
      allocate (msgs(self%n_runs))
      do k = 1, self%n_runs
         msgs(k)%s = ''
         if (self%status(k) == status_pending) cycle
         call get_message(self, k, m, ok)
         msgs(k)%s = m
      end do
      hs = 0
      call h5gopen_f(self%file, 'runs', g, h); hs = min(hs, h)
      if (hs == 0) then
         call new_dset(g, 'message.new', [self%n_runs], self%t_message, d, hs)
         if (hs == 0) then
            call h5dclose_f(self%d_message, h)
            self%d_message = d
            do k = 1, self%n_runs
               if (len(msgs(k)%s) == 0) cycle
               call put_message(self, k, msgs(k)%s, h); hs = min(hs, h)
            end do
            call h5fflush_f(self%file, H5F_SCOPE_GLOBAL_F, h); hs = min(hs, h)
         end if
         if (hs == 0) call h5ldelete_f(g, 'message', h); hs = min(hs, h)
         if (hs == 0) call h5lmove_f(g, 'message.new', g, 'message', h); hs = min(hs, h)
         if (hs == 0) call h5fflush_f(self%file, H5F_SCOPE_GLOBAL_F, h); hs = min(hs, h)
         call h5gclose_f(g, h)
      end if
      if (hs < 0) call fatal_error(err, "cannot rewrite the run messages of sweep file '"//self%path//"'"// &
                                   io_reason(self%path), err_io)
   end subroutine clean_messages

   !> The message of run irun ('' for none); ok = .false. if it cannot be read.
   subroutine get_message(self, irun, message, ok)
      type(sweep_file_t), intent(in) :: self
      integer, intent(in) :: irun
      character(len=:), allocatable, intent(out) :: message
      logical, intent(out) :: ok
      integer(hid_t) :: fs, ms
      integer(hsize_t) :: dims(2), maxd(2)
      integer :: rank, h
      type(c_ptr), target :: p(1)
      type(c_ptr) :: buf
      message = ''
      p(1) = c_null_ptr
      buf = c_loc(p)
      call select_slot(self%d_message, irun, 1, fs, ms, rank, dims, maxd)
      call h5dread_f(self%d_message, self%t_message, buf, h, mem_space_id=ms, file_space_id=fs)
      ok = h >= 0
      if (ok) message = c_text(p(1))
      call h5sclose_f(ms, rank); call h5sclose_f(fs, rank)
   end subroutine get_message

   !> What differs between two fingerprints (lines "deck DIGEST", "file DIGEST PATH",
   !> "overrides TEXT", "version TEXT"), for "holds another sweep (...)".
   function fingerprint_difference(old, new, deck_file) result(why)
      character(len=*), intent(in) :: old, new, deck_file
      character(len=:), allocatable :: why
      type(string_t), allocatable :: a(:), b(:)
      integer :: i, j
      call split_lines(old, a)
      call split_lines(new, b)
      why = ''
      do i = 1, size(b)
         j = find_key(a, line_key(b(i)%s))
         if (j > 0) then
            if (a(j)%s == b(i)%s) cycle
         end if
         select case (word(b(i)%s, 1))
         case ('deck')
            why = 'its deck differs from '//deck_file//' in a group, key or value'
         case ('file')
            if (j > 0) then
               why = "the table file '"//file_path(b(i)%s)//"' had other contents when it was made"
            else
               why = "it did not read the table file '"//file_path(b(i)%s)//"'"
            end if
         case default
            why = 'its '//word(b(i)%s, 1)//' differs'
         end select
         return
      end do
      do i = 1, size(a)
         if (find_key(b, line_key(a(i)%s)) > 0) cycle
         if (word(a(i)%s, 1) == 'file') then
            why = "it read a table file '"//file_path(a(i)%s)//"' that this deck does not"
         else
            why = 'its '//word(a(i)%s, 1)//' differs'
         end if
         return
      end do
   end function fingerprint_difference

   !> "deck", "file PATH", "overrides", "version": what a fingerprint line is about.
   function line_key(line) result(key)
      character(len=*), intent(in) :: line
      character(len=:), allocatable :: key
      key = word(line, 1)
      if (key == 'file') key = key//' '//file_path(line)
   end function line_key

   !> PATH of a line "file DIGEST PATH" (a path may hold blanks).
   function file_path(line) result(path)
      character(len=*), intent(in) :: line
      character(len=:), allocatable :: path
      path = ''
      if (len(line) > 22) path = line(23:)
   end function file_path

   integer function find_key(lines, key) result(j)
      type(string_t), intent(in) :: lines(:)
      character(len=*), intent(in) :: key
      do j = 1, size(lines)
         if (line_key(lines(j)%s) == key) return
      end do
      j = 0
   end function find_key

   !> Word k (blank-separated) of `line`, '' if it has fewer.
   function word(line, k) result(w)
      character(len=*), intent(in) :: line
      integer, intent(in) :: k
      character(len=:), allocatable :: w
      integer :: i, n, start
      n = 0
      w = ''
      i = 1
      do while (i <= len(line))
         if (line(i:i) == ' ') then
            i = i + 1
            cycle
         end if
         start = i
         do while (i <= len(line))
            if (line(i:i) == ' ') exit
            i = i + 1
         end do
         n = n + 1
         if (n == k) then
            w = line(start:i - 1)
            return
         end if
      end do
   end function word

   subroutine split_lines(text, lines)
      character(len=*), intent(in) :: text
      type(string_t), allocatable, intent(out) :: lines(:)
      integer :: i, j, n
      n = 0
      if (len(text) > 0) n = count([(text(i:i) == new_line('a'), i=1, len(text))]) + 1
      allocate (lines(n))
      j = 1
      do i = 1, n
         if (i < n) then
            lines(i)%s = text(j:j - 1 + index(text(j:), new_line('a')) - 1)
            j = j + len(lines(i)%s) + 1
         else
            lines(i)%s = text(j:)
         end if
      end do
   end subroutine split_lines

   !> Record a finished run: its slot, flush, then its status, flush.
   subroutine file_write_run(self, rec, err)
      class(sweep_file_t), intent(inout) :: self
      type(sweep_record_t), intent(in) :: rec
      type(error_t), allocatable, intent(out) :: err
      integer :: h, k, hs
      integer(i8) :: c, rate
      real(wp) :: col(max(self%ne, 1))

      hs = 0
      call put_slot_int(self%d_rank, rec%irun, [rec%rank], h); hs = min(hs, h)
      call put_slot(self%d_wall, rec%irun, [rec%wall], h); hs = min(hs, h)
      do k = 1, size(run_value_names)
         call put_slot(self%d_run(k), rec%irun, [rec%run_values(k)], h); hs = min(hs, h)
      end do
      ! ('' is the fill value; a slot an uncommitted attempt left was cleared by clean_messages)
      if (len(rec%message) > 0) then
         call put_message(self, rec%irun, rec%message, h); hs = min(hs, h)
      end if
      if (self%ne > 0) then
         do k = 1, size(element_metric_names)
            if (element_metric_is_int(k)) then
               call put_slot_int(self%d_el(k), rec%irun, to_int(rec%el(k, :)), h)
            else
               col(1:self%ne) = rec%el(k, :)
               call put_slot(self%d_el(k), rec%irun, col(1:self%ne), h)
            end if
            hs = min(hs, h)
         end do
      end if
      do k = 1, size(node_metric_names)
         call put_slot(self%d_node(k), rec%irun, [rec%node(k, :)], h); hs = min(hs, h)
      end do
      if (hs < 0) then
         call fatal_error(err, "cannot write run "//str(rec%irun)//" to sweep file '"//self%path//"'", err_io)
         return
      end if
      self%status(rec%irun) = rec%status
      if (.not. allocated(self%batch)) allocate (self%batch(self%n_runs))
      self%n_batch = self%n_batch + 1
      self%batch(self%n_batch) = rec%irun
      call system_clock(c, rate)
      if (real(c - self%last_commit, wp) >= self%commit_interval*real(rate, wp)) call self%commit(err)
   end subroutine file_write_run

   !> Commit the runs written since the last commit: flush; only if that succeeded,
   !> their statuses; flush. A failed commit commits nothing (the runs are made again
   !> by the next command) and the batch is dropped.
   subroutine file_commit(self, err)
      class(sweep_file_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer :: h, hs, i, j, n
      call system_clock(self%last_commit)
      if (self%n_batch == 0 .or. self%file < 0) return
      n = self%n_batch
      self%n_batch = 0
      call h5fflush_f(self%file, H5F_SCOPE_GLOBAL_F, h)
      if (h < 0) then
         do i = 1, n
            self%status(self%batch(i)) = status_pending
         end do
         call fatal_error(err, "cannot record runs in sweep file '"//self%path//"'"//io_reason(self%path), err_io)
         return
      end if
      hs = 0
      do i = 1, n
         j = self%batch(i)
         call put_slot_int(self%d_status, j, [self%status(j)], h); hs = min(hs, h)
      end do
      call h5fflush_f(self%file, H5F_SCOPE_GLOBAL_F, h); hs = min(hs, h)
      ! HDF5 keeps the conversion buffers of each variable-length write in its free
      ! lists (about 0.7 kB a message): give them back, so memory stays flat
      call h5garbage_collect_f(h)
      call c_trim_memory()
      if (hs < 0) call fatal_error(err, "cannot record runs in sweep file '"//self%path//"'"// &
                                   io_reason(self%path), err_io)
   end subroutine file_commit

   !> Where run irun ended, for the run after it in a continuation branch: its nodes'
   !> end_angle, end_speed and start_speed, one after the other in `v`.
   subroutine file_read_end_state(self, irun, v, err)
      class(sweep_file_t), intent(in) :: self
      integer, intent(in) :: irun
      real(wp), intent(out) :: v(:)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fs, ms
      integer(hsize_t) :: dims(2), maxd(2)
      integer :: h, hs, k, rank, i
      real(wp) :: col(self%nn)
      hs = 0
      do i = 1, 3
         k = 2 + i            ! end_angle, end_speed, start_speed
         call select_slot(self%d_node(k), irun, self%nn, fs, ms, rank, dims, maxd)
         call h5dread_f(self%d_node(k), H5T_NATIVE_DOUBLE, col, [int(self%nn, hsize_t)], h, &
                        mem_space_id=ms, file_space_id=fs)
         hs = min(hs, h)
         call h5sclose_f(ms, rank); call h5sclose_f(fs, rank)
         v((i - 1)*self%nn + 1:i*self%nn) = col
      end do
      if (hs < 0) call fatal_error(err, "cannot read the end state of run "//str(irun)//" from sweep file '"// &
                                   self%path//"'", err_io)
   end subroutine file_read_end_state

   !> Commit the last batch (an error here is reported by `commit` called before), close
   !> and release the lock. Safe to call at any time.
   subroutine file_close(self)
      class(sweep_file_t), intent(inout) :: self
      type(error_t), allocatable :: err
      integer :: h
      if (self%file >= 0) then
         call self%commit(err)
         call close_ids(self)
         call h5fclose_f(self%file, h)
         ! a file HDF5 cannot close (a full disk) would crash its exit handler
         if (h < 0) call mark_hdf5_stuck()
         self%file = -1
      end if
      if (self%lock_fd >= 0) call c_unlock(self%lock_fd, self%lock_path//c_null_char)
      self%lock_fd = -1
   end subroutine file_close

   subroutine close_ids(self)
      type(sweep_file_t), intent(inout) :: self
      integer :: h, k
      if (self%d_status >= 0) call h5dclose_f(self%d_status, h)
      if (self%d_rank >= 0) call h5dclose_f(self%d_rank, h)
      if (self%d_wall >= 0) call h5dclose_f(self%d_wall, h)
      if (self%d_message >= 0) call h5dclose_f(self%d_message, h)
      if (self%t_message >= 0) call h5tclose_f(self%t_message, h)
      do k = 1, size(self%d_run)
         if (self%d_run(k) >= 0) call h5dclose_f(self%d_run(k), h)
      end do
      do k = 1, size(self%d_el)
         if (self%d_el(k) >= 0) call h5dclose_f(self%d_el(k), h)
      end do
      do k = 1, size(self%d_node)
         if (self%d_node(k) >= 0) call h5dclose_f(self%d_node(k), h)
      end do
      self%d_status = -1; self%d_rank = -1; self%d_wall = -1; self%d_message = -1; self%t_message = -1
      self%d_run = -1; self%d_el = -1; self%d_node = -1
   end subroutine close_ids

   !> A count carried as a real; -1 for NaN (a failed run).
   elemental integer function to_int(x)
      real(wp), intent(in) :: x
      to_int = -1
      if (ieee_is_nan(x)) return        ! (an ordered compare of NaN traps in Debug)
      if (abs(x) < 2.0e9_wp) to_int = nint(x)
   end function to_int

   ! ------------------------------------------------------------------------------------------
   ! HDF5 helpers
   ! ------------------------------------------------------------------------------------------

   !> A dataset with one slot per run: contiguous, allocated now, filled with NaN
   !> (reals) or `ifill` (integers); no time stamps (metadata stays fixed).
   subroutine new_dset(loc, name, dims, t, d, hs, ifill)
      integer(hid_t), intent(in) :: loc, t
      character(len=*), intent(in) :: name
      integer, intent(in) :: dims(:)
      integer(hid_t), intent(out) :: d
      integer, intent(inout) :: hs     !< min(hs, status of the creation)
      integer, intent(in), optional :: ifill
      integer(hid_t) :: sp, pl
      integer :: h
      real(wp) :: nan
      call h5screate_simple_f(size(dims), int(dims, hsize_t), sp, h)
      call h5pcreate_f(H5P_DATASET_CREATE_F, pl, h)
      call h5pset_alloc_time_f(pl, H5D_ALLOC_TIME_EARLY_F, h)
      call h5pset_obj_track_times_f(pl, .false., h)
      if (t == H5T_NATIVE_DOUBLE) then
         nan = transfer(int(z'7FF8000000000000', kind=8), nan)
         call h5pset_fill_value_f(pl, H5T_NATIVE_DOUBLE, nan, h)
      else if (present(ifill)) then
         call h5pset_fill_value_f(pl, H5T_NATIVE_INTEGER, ifill, h)
      end if
      d = -1
      if (hs == 0) then
         call h5dcreate_f(loc, name, t, sp, d, h, dcpl_id=pl)
         hs = min(hs, h)
         if (h < 0) d = -1
         call h5garbage_collect_f(h)   ! its fill buffer (sized by the runs) back to the system
      end if
      call h5pclose_f(pl, h)
      call h5sclose_f(sp, h)
   end subroutine new_dset

   !> Write the values of one run (a column (:, irun), or element irun of a 1-D dataset).
   subroutine put_slot(d, irun, v, h)
      integer(hid_t), intent(in) :: d
      integer, intent(in) :: irun
      real(wp), intent(in) :: v(:)
      integer, intent(out) :: h
      integer(hid_t) :: fs, ms
      integer(hsize_t) :: dims(2), maxd(2)
      integer :: rank
      call select_slot(d, irun, size(v), fs, ms, rank, dims, maxd)
      call h5dwrite_f(d, H5T_NATIVE_DOUBLE, v, [int(size(v), hsize_t)], h, mem_space_id=ms, file_space_id=fs)
      call h5sclose_f(ms, rank); call h5sclose_f(fs, rank)
   end subroutine put_slot

   subroutine put_slot_int(d, irun, v, h)
      integer(hid_t), intent(in) :: d
      integer, intent(in) :: irun
      integer, intent(in) :: v(:)
      integer, intent(out) :: h
      integer(hid_t) :: fs, ms
      integer(hsize_t) :: dims(2), maxd(2)
      integer :: rank
      call select_slot(d, irun, size(v), fs, ms, rank, dims, maxd)
      call h5dwrite_f(d, H5T_NATIVE_INTEGER, v, [int(size(v), hsize_t)], h, mem_space_id=ms, file_space_id=fs)
      call h5sclose_f(ms, rank); call h5sclose_f(fs, rank)
   end subroutine put_slot_int

   !> The message of run irun (variable length; '' is the fill value, never written).
   subroutine put_message(self, irun, message, h)
      type(sweep_file_t), intent(in) :: self
      integer, intent(in) :: irun
      character(len=*), intent(in) :: message
      integer, intent(out) :: h
      integer(hid_t) :: fs, ms
      integer(hsize_t) :: dims(2), maxd(2)
      integer :: rank
      type(string_t) :: one(1)
      character(kind=c_char), allocatable, target :: pool(:)
      type(c_ptr), allocatable, target :: ptrs(:)
      one(1)%s = message
      call vlen_pointers(one, pool, ptrs)
      call select_slot(self%d_message, irun, 1, fs, ms, rank, dims, maxd)
      call h5dwrite_f(self%d_message, self%t_message, c_loc(ptrs), h, mem_space_id=ms, file_space_id=fs)
      call h5sclose_f(ms, rank); call h5sclose_f(fs, rank)
   end subroutine put_message

   !> File and memory spaces for the slot of run irun (n values).
   subroutine select_slot(d, irun, n, fs, ms, rank, dims, maxd)
      integer(hid_t), intent(in) :: d
      integer, intent(in) :: irun, n
      integer(hid_t), intent(out) :: fs, ms
      integer, intent(out) :: rank
      integer(hsize_t), intent(out) :: dims(2), maxd(2)
      integer :: h
      call h5dget_space_f(d, fs, h)
      call h5sget_simple_extent_dims_f(fs, dims, maxd, rank)
      if (rank == 1) then
         call h5sselect_hyperslab_f(fs, H5S_SELECT_SET_F, [int(irun - 1, hsize_t)], [1_hsize_t], h)
      else
         call h5sselect_hyperslab_f(fs, H5S_SELECT_SET_F, [0_hsize_t, int(irun - 1, hsize_t)], &
                                    [int(n, hsize_t), 1_hsize_t], h)
      end if
      call h5screate_simple_f(1, [int(n, hsize_t)], ms, h)
   end subroutine select_slot

   logical function h5_attr_exists(loc, name)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer :: h
      call h5aexists_f(loc, name, h5_attr_exists, h)
      if (h < 0) h5_attr_exists = .false.
   end function h5_attr_exists

   !> A scalar variable-length string attribute ('' and ok = .false. if absent).
   subroutine get_attr(loc, name, value, ok)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      character(len=:), allocatable, intent(out) :: value
      logical, intent(out) :: ok
      integer(hid_t) :: t, a
      type(c_ptr), target :: p(1)
      type(c_ptr) :: buf
      type(error_t), allocatable :: err
      integer :: h
      value = ''
      call h5aopen_f(loc, name, a, h)
      ok = h >= 0
      if (.not. ok) return
      call make_string_type(t, err)
      ok = .not. allocated(err)
      if (ok) then
         buf = c_loc(p)
         call h5aread_f(a, t, buf, h)
         ok = h >= 0
         if (ok) value = c_text(p(1))
         call h5tclose_f(t, h)
      end if
      call h5aclose_f(a, h)
   end subroutine get_attr

   !> The text of a C string that HDF5 allocated for a variable-length read; frees it.
   function c_text(p) result(text)
      type(c_ptr), intent(in) :: p
      character(len=:), allocatable :: text
      character(kind=c_char), pointer :: chars(:)
      integer :: i, n, rc
      text = ''
      if (.not. c_associated(p)) return
      n = int(c_strlen(p))
      call c_f_pointer(p, chars, [n])
      deallocate (text)
      allocate (character(len=n) :: text)
      do i = 1, n
         text(i:i) = chars(i)
      end do
      rc = c_h5free_memory(p)
   end function c_text

   subroutine put_reals(loc, name, v, hs)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      real(wp), intent(in) :: v(:, :)
      integer, intent(out) :: hs
      integer(hid_t) :: sp, d
      integer :: h
      call h5screate_simple_f(2, int(shape(v), hsize_t), sp, h)
      call h5dcreate_f(loc, name, H5T_NATIVE_DOUBLE, sp, d, hs)
      if (hs == 0) then
         call h5dwrite_f(d, H5T_NATIVE_DOUBLE, v, int(shape(v), hsize_t), hs)
         call h5dclose_f(d, h)
      end if
      call h5sclose_f(sp, h)
   end subroutine put_reals

   subroutine get_reals(loc, name, v, ok)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      real(wp), intent(inout) :: v(:, :)
      logical, intent(out) :: ok
      integer(hid_t) :: d, sp
      integer(hsize_t) :: dims(2), maxd(2)
      integer :: h, rank
      call h5dopen_f(loc, name, d, h)
      ok = h >= 0
      if (.not. ok) return
      call h5dget_space_f(d, sp, h)
      call h5sget_simple_extent_dims_f(sp, dims, maxd, rank)
      ok = rank == 2 .and. all(dims == int(shape(v), hsize_t))
      if (ok) then
         call h5dread_f(d, H5T_NATIVE_DOUBLE, v, dims, h)
         ok = h >= 0
      end if
      call h5sclose_f(sp, h); call h5dclose_f(d, h)
   end subroutine get_reals
end module trainsim_sweep_file
