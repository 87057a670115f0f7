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
!> UTF-8, as in run files (the generic HDF5 layer, trainsim_h5): h5py reads attributes as str
!> and string datasets with `.asstr()`. An empty message is the fill value (no heap
!> object); a failed run's message is written to the global heap with its slot, before
!> the flush that precedes its status.
!>
!> Fortran (n, n_runs) arrays appear in h5py as (n_runs, n).
module trainsim_sweep_file
   use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_io, err_input
   use trainsim_strings, only: string_t, str
   use trainsim_fs, only: pk_regular, path_kind, path_refusal, io_reason, os_text, fs_rename, fs_remove, &
      fs_truncate, process_id, lock_file, unlock_file, remove_stale_parts, trim_memory
   use trainsim_h5, only: hid_t, h5_real, h5_int, h5_text, h5_init, create_file_excl, open_file_rdwr, flush_file, &
      close_file, new_group, open_group, end_group, close_dset, close_type, link_exists, link_move, link_delete, &
      garbage_collect, make_string_type, put_str_attr, get_str_attr, attr_exists
   use trainsim_h5_dsets, only: put_column_s, read_i1
   use trainsim_h5_slots, only: new_slots, open_dset, open_dsets, put_slot_r, put_slot_i, put_slot_text, get_slot_r, &
      get_slot_text, put_matrix, get_matrix
   use trainsim_hdf5_groups, only: write_deck_files
   use trainsim_sweep_layout, only: sweep_layout_t, sweep_record_t, element_metric_names, element_metric_is_int, &
      node_metric_names, run_value_names, n_run_values, status_pending, status_ok, status_failed, record_size, &
      format_version, status_names, status_meaning, fingerprint_difference
   implicit none
   private

   public :: sweep_file_t, clean_slot_messages, finish_message_move, put_file_head
   !> (the layout, re-exported: what a sweep file holds)
   public :: sweep_layout_t, sweep_record_t, element_metric_names, node_metric_names
   public :: status_pending, status_ok, status_failed, record_size, format_version, status_names

   !> What the refusal of a device, pipe or socket as the sweep file says.
   character(len=*), parameter :: no_file_hint = ': a sweep records and resumes its runs in a file'

   type :: sweep_file_t
      character(len=:), allocatable :: path
      character(len=:), allocatable :: lock_path
      integer :: lock_fd = -1
      integer :: n_invalid = 0               !< runs whose status in the file was invalid (made again)
      integer :: invalid_value = 0           !< the first such status
      integer(hid_t) :: file = -1
      integer(hid_t) :: d_status = -1, d_wall = -1, d_rank = -1, d_message = -1, t_message = -1
      integer(hid_t) :: d_run(n_run_values) = -1
      integer(hid_t) :: d_el(size(element_metric_names)) = -1, d_node(5) = -1
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

contains

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
      integer :: info

      self%path = path
      why = path_refusal(path, no_file_hint)
      if (len(why) > 0) then
         call fatal_error(err, "cannot write sweep file '"//path//"': "//why, err_io)
         return
      end if
      self%lock_path = path//'.lock'
      self%lock_fd = lock_file(self%lock_path, info)
      if (self%lock_fd == -1) then
         why = 'another trainsim sweep is writing it'
         if (info > 0) why = why//' (process '//str(info)//')'
         call fatal_error(err, "sweep file '"//path//"': "//why//": wait until it ends (the same command "// &
                          "then completes the sweep), or write this sweep to another file with -o", err_io)
         return
      else if (self%lock_fd < 0) then
         call fatal_error(err, "cannot write sweep file '"//path//"': cannot create its lock file '"// &
                          self%lock_path//"': "//os_text(info), err_io)
         return
      end if
      ! a sweep killed while creating FILE left its FILE.<pid>.part: under the lock, stale
      info = remove_stale_parts(path)
      why = path_refusal(path, no_file_hint)     ! (again: the path may have changed before the lock was ours)
      if (len(why) > 0) then
         call fatal_error(err, "cannot write sweep file '"//path//"': "//why, err_io)
      else if (path_kind(path) == pk_regular) then
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
      integer(hid_t) :: f
      integer :: h, hs
      logical :: ok
      character(len=:), allocatable :: part

      ! under the lock a temporary of this pid is a crashed process's (pids are reused)
      part = path//'.'//str(process_id())//'.part'
      call fs_remove(part)
      call h5_init(err)
      if (allocated(err)) return
      call create_file_excl(part, f, h)
      if (h < 0) then
         call fatal_error(err, "cannot create sweep file '"//part//"'"//io_reason(part), err_io)
         return
      end if
      call put_file_head(f, 'trainsim-sweep', format_version, lay, lay%n_runs, err)
      if (.not. allocated(err)) call write_deck_files(f, lay%input_keys, lay%input_files, lay%input_texts, err)
      hs = 0
      call make_groups(self, f, lay, err, hs)
      call close_ids(self)
      if (allocated(err) .or. hs < 0) then
         ! free the space first, so that HDF5 can close the file on a full disk
         call fs_truncate(part)
         call close_file(f, ok)
         call fs_remove(part)
         ! (the string helpers' own message names a run file's group: not repeated)
         call fatal_error(err, "cannot write sweep file '"//path//"'"//io_reason(path), err_io)
         return
      end if
      call close_file(f, ok)
      if (.not. ok) then
         call fs_remove(part)
         call fatal_error(err, "cannot write sweep file '"//path//"'"//io_reason(path), err_io)
         return
      end if
      if (.not. fs_rename(part, path)) then
         call fs_remove(part)
         call fatal_error(err, "cannot rename '"//part//"' to '"//path//"'"//io_reason(path), err_io)
         return
      end if
      call self%open_existing(path, lay, err)
   end subroutine file_create

   !> The groups of a new sweep file: /parameters, /runs, /elements and /nodes with a
   !> slot per run in every dataset (hs = min(hs, the HDF5 statuses)).
   subroutine make_groups(self, f, lay, err, hs)
      type(sweep_file_t), intent(inout) :: self
      integer(hid_t), intent(in) :: f
      type(sweep_layout_t), intent(in) :: lay
      type(error_t), allocatable, intent(inout) :: err
      integer, intent(inout) :: hs
      integer(hid_t) :: g, d_branch
      integer :: h, k, ne, nn
      ne = size(lay%element_ids); nn = size(lay%node_ids)
      call new_group(f, 'parameters', g, h); hs = min(hs, h)
      if (size(lay%param_names) > 0) then
         if (.not. allocated(err)) call put_column_s(g, 'names', lay%param_names, err)
         call put_matrix(g, 'values', lay%param_values, h); hs = min(hs, h)
      end if
      call end_group(g)
      if (.not. allocated(err) .and. hs == 0) then
         call new_group(f, 'runs', g, h); hs = min(hs, h)
         call new_slots(g, 'status', [lay%n_runs], h5_int, self%d_status, hs, ifill=status_pending)
         call put_str_attr(self%d_status, 'meaning', status_meaning(), err)
         call new_slots(g, 'rank', [lay%n_runs], h5_int, self%d_rank, hs, ifill=-1)
         call new_slots(g, 'wall_time', [lay%n_runs], h5_real, self%d_wall, hs)
         do k = 1, size(run_value_names)
            call new_slots(g, trim(run_value_names(k)), [lay%n_runs], h5_real, self%d_run(k), hs)
         end do
         if (.not. allocated(err)) call new_slots(g, 'message', [lay%n_runs], h5_text, self%d_message, hs)
         call new_slots(g, 'branch', [lay%n_runs], h5_int, d_branch, hs, ifill=0)
         if (allocated(lay%branch) .and. hs == 0) then
            do k = 1, lay%n_runs
               call put_slot_i(d_branch, k, [lay%branch(k)], h); hs = min(hs, h)
            end do
         end if
         call close_dset(d_branch)
         call end_group(g)
      end if
      if (.not. allocated(err) .and. hs == 0) then
         call new_group(f, 'elements', g, h); hs = min(hs, h)
         if (ne > 0) then
            call put_column_s(g, 'ids', lay%element_ids, err)
            if (.not. allocated(err)) call put_column_s(g, 'types', lay%element_types, err)
            do k = 1, size(element_metric_names)
               if (element_metric_is_int(k)) then
                  call new_slots(g, trim(element_metric_names(k)), [ne, lay%n_runs], h5_int, self%d_el(k), hs, ifill=-1)
               else
                  call new_slots(g, trim(element_metric_names(k)), [ne, lay%n_runs], h5_real, self%d_el(k), hs)
               end if
            end do
         end if
         call end_group(g)
      end if
      if (.not. allocated(err) .and. hs == 0) then
         call new_group(f, 'nodes', g, h); hs = min(hs, h)
         if (.not. allocated(err)) call put_column_s(g, 'ids', lay%node_ids, err)
         do k = 1, size(node_metric_names)
            call new_slots(g, trim(node_metric_names(k)), [nn, lay%n_runs], h5_real, self%d_node(k), hs)
         end do
         call end_group(g)
      end if
   end subroutine make_groups

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
      call h5_init(err)
      if (allocated(err)) return
      call open_file_rdwr(path, self%file, h)
      if (h < 0) then
         call fatal_error(err, "cannot open sweep file '"//path//"' for writing (not an HDF5 file, damaged, "// &
                          'or open in another program)', err_io)
         return
      end if
      why = ''
      call get_str_attr(self%file, 'format', s, ok)
      if (.not. ok .or. s /= 'trainsim-sweep') then
         ! (format_version 1 had fixed-length strings, which do not read as variable-length)
         if (attr_exists(self%file, 'format')) then
            why = 'it is a sweep file of an older layout, not format_version '//format_version
         else
            why = 'it is not a trainsim sweep file'
         end if
      else
         call get_str_attr(self%file, 'format_version', s, ok)
         if (s /= format_version) why = 'its layout is version '//s//', this trainsim writes '//format_version
      end if
      if (len(why) == 0) then
         call get_str_attr(self%file, 'trainsim_version', s, ok)
         if (len(why) == 0 .and. s /= lay%version) why = 'it was written by trainsim '//s//', this is '//lay%version
         call get_str_attr(self%file, 'overrides', s, ok)
         if (len(why) == 0 .and. s /= lay%overrides) why = 'its --set options differ ("'//s//'")'
         call get_str_attr(self%file, 'fingerprint', s, ok)
         if (len(why) == 0) then
            if (.not. ok) then
               why = 'it has no fingerprint of its inputs: written by an older trainsim'
            else if (s /= lay%fingerprint) then
               why = fingerprint_difference(s, lay%fingerprint, lay%deck_file)
            end if
         end if
         call get_str_attr(self%file, 'n_runs', s, ok)
         if (len(why) == 0 .and. s /= str(lay%n_runs)) why = 'it has '//s//' runs, this sweep '//str(lay%n_runs)
         if (len(why) == 0 .and. size(lay%param_names) > 0) then
            allocate (pv(size(lay%param_names), lay%n_runs))
            call get_matrix(self%file, 'parameters/values', pv, ok)
            if (.not. ok) then
               why = 'its parameter table does not match'
            else if (any(pv /= lay%param_values)) then
               why = 'its parameter values differ'
            end if
         end if
      end if
      if (len(why) > 0) then
         call close_file(self%file, ok)
         call fatal_error(err, "sweep file '"//path//"' holds another sweep ("//why// &
                          '): delete it, or write this sweep to another file with -o', err_input)
         return
      end if
      self%ne = size(lay%element_ids); self%nn = size(lay%node_ids); self%n_runs = lay%n_runs
      hs = 0
      call finish_message_move(self%file, 'runs')
      call open_dset(self%file, 'runs/status', self%d_status, hs)
      call open_dset(self%file, 'runs/rank', self%d_rank, hs)
      call open_dset(self%file, 'runs/wall_time', self%d_wall, hs)
      call open_dset(self%file, 'runs/message', self%d_message, hs)
      call make_string_type(self%t_message, err)
      if (allocated(err)) return
      call open_dsets(self%file, 'runs', run_value_names, self%d_run, hs)
      if (self%ne > 0) then
         call open_dsets(self%file, 'elements', element_metric_names, self%d_el, hs)
      end if
      call open_dsets(self%file, 'nodes', node_metric_names, self%d_node, hs)
      allocate (self%status(self%n_runs))
      h = 0
      if (hs == 0) call read_i1(self%d_status, self%status, h)
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
      call garbage_collect()
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
      call clean_slot_messages(self%file, 'runs', self%d_message, self%t_message, self%status /= status_pending, &
                               self%path, err)
   end subroutine clean_messages

   !> A rebuild of GROUP/message (clean_slot_messages) killed between its delete and its move: complete it.
   subroutine finish_message_move(file, group)
      integer(hid_t), intent(in) :: file
      character(len=*), intent(in) :: group
      integer :: h
      logical :: ok
      call link_exists(file, group//'/message', ok, h)
      if (h >= 0 .and. .not. ok) then
         call link_exists(file, group//'/message.new', ok, h)
         if (h >= 0 .and. ok) call link_move(file, group//'/message.new', group//'/message', h)
      end if
   end subroutine finish_message_move

   !> clean_messages for the text slots `d` (GROUP/message of `file`, string type `stype`)
   !> of any slot file: the slots not `committed` must hold no message.
   subroutine clean_slot_messages(file, group, d, stype, committed, path, err)
      integer(hid_t), intent(in) :: file, stype
      character(len=*), intent(in) :: group, path
      integer(hid_t), intent(inout) :: d
      logical, intent(in) :: committed(:)
      type(error_t), allocatable, intent(out) :: err
      type(string_t), allocatable :: msgs(:)
      character(len=:), allocatable :: m
      integer(hid_t) :: g, dn
      integer :: h, hs, k, n
      logical :: ok, stale
      stale = .false.
      n = size(committed)
      do k = 1, n         ! (nothing kept per run: memory stays flat in the runs)
         call get_slot_text(d, stype, k, m, ok)
         if (.not. committed(k)) then
            if (.not. ok .or. len(m) > 0) stale = .true.
         else if (.not. ok) then
            call fatal_error(err, "cannot read the message of run "//str(k)//" of '"//path// &
                             "' (damaged): delete it, or write to another file with -o", err_io)
            return
         end if
      end do
      if (.not. stale) return
      allocate (msgs(n))
      do k = 1, n
         msgs(k)%s = ''
         if (.not. committed(k)) cycle
         call get_slot_text(d, stype, k, m, ok)
         msgs(k)%s = m
      end do
      hs = 0
      call open_group(file, group, g, h); hs = min(hs, h)
      if (hs == 0) then
         call new_slots(g, 'message.new', [n], h5_text, dn, hs)
         if (hs == 0) then
            call close_dset(d)
            d = dn
            do k = 1, n
               if (len(msgs(k)%s) == 0) cycle
               call put_slot_text(d, stype, k, msgs(k)%s, h); hs = min(hs, h)
            end do
            call flush_file(file, h); hs = min(hs, h)
         end if
         if (hs == 0) call link_delete(g, 'message', h); hs = min(hs, h)
         if (hs == 0) call link_move(g, 'message.new', 'message', h); hs = min(hs, h)
         if (hs == 0) call flush_file(file, h); hs = min(hs, h)
         call end_group(g)
      end if
      if (hs < 0) call fatal_error(err, "cannot rewrite the run messages of '"//path//"'"//io_reason(path), err_io)
   end subroutine clean_slot_messages

   !> Record a finished run: its slot, flush, then its status, flush.
   subroutine file_write_run(self, rec, err)
      class(sweep_file_t), intent(inout) :: self
      type(sweep_record_t), intent(in) :: rec
      type(error_t), allocatable, intent(out) :: err
      integer :: h, k, hs
      integer(i8) :: c, rate
      real(wp) :: col(max(self%ne, 1))

      hs = 0
      call put_slot_i(self%d_rank, rec%irun, [rec%rank], h); hs = min(hs, h)
      call put_slot_r(self%d_wall, rec%irun, [rec%wall], h); hs = min(hs, h)
      do k = 1, size(run_value_names)
         call put_slot_r(self%d_run(k), rec%irun, [rec%run_values(k)], h); hs = min(hs, h)
      end do
      ! ('' is the fill value; a slot an uncommitted attempt left was cleared by clean_messages)
      if (len(rec%message) > 0) then
         call put_slot_text(self%d_message, self%t_message, rec%irun, rec%message, h); hs = min(hs, h)
      end if
      if (self%ne > 0) then
         do k = 1, size(element_metric_names)
            if (element_metric_is_int(k)) then
               call put_slot_i(self%d_el(k), rec%irun, to_int(rec%el(k, :)), h)
            else
               col(1:self%ne) = rec%el(k, :)
               call put_slot_r(self%d_el(k), rec%irun, col(1:self%ne), h)
            end if
            hs = min(hs, h)
         end do
      end if
      do k = 1, size(node_metric_names)
         call put_slot_r(self%d_node(k), rec%irun, [rec%node(k, :)], h); hs = min(hs, h)
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
      call flush_file(self%file, h)
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
         call put_slot_i(self%d_status, j, [self%status(j)], h); hs = min(hs, h)
      end do
      call flush_file(self%file, h); hs = min(hs, h)
      ! HDF5 keeps the conversion buffers of each variable-length write in its free
      ! lists (about 0.7 kB a message): give them back, so memory stays flat
      call garbage_collect()
      call trim_memory()
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
      integer :: h, hs, i
      hs = 0
      do i = 1, 3            ! end_angle, end_speed, start_speed
         call get_slot_r(self%d_node(2 + i), irun, v((i - 1)*self%nn + 1:i*self%nn), h)
         hs = min(hs, h)
      end do
      if (hs < 0) call fatal_error(err, "cannot read the end state of run "//str(irun)//" from sweep file '"// &
                                   self%path//"'", err_io)
   end subroutine file_read_end_state

   !> Commit the last batch (an error here is reported by `commit` called before), close
   !> and release the lock. Safe to call at any time.
   subroutine file_close(self)
      class(sweep_file_t), intent(inout) :: self
      type(error_t), allocatable :: err
      logical :: ok
      if (self%file >= 0) then
         call self%commit(err)
         call close_ids(self)
         ! (a file HDF5 cannot close, on a full disk, marks HDF5 stuck: its exit handler would crash)
         call close_file(self%file, ok)
      end if
      if (self%lock_fd >= 0) call unlock_file(self%lock_fd, self%lock_path)
      self%lock_fd = -1
   end subroutine file_close

   subroutine close_ids(self)
      type(sweep_file_t), intent(inout) :: self
      integer :: k
      call close_dset(self%d_status)
      call close_dset(self%d_rank)
      call close_dset(self%d_wall)
      call close_dset(self%d_message)
      call close_type(self%t_message)
      do k = 1, size(self%d_run)
         call close_dset(self%d_run(k))
      end do
      do k = 1, size(self%d_el)
         call close_dset(self%d_el(k))
      end do
      do k = 1, size(self%d_node)
         call close_dset(self%d_node(k))
      end do
   end subroutine close_ids

   !> A count carried as a real; -1 for NaN (a failed run).
   elemental integer function to_int(x)
      real(wp), intent(in) :: x
      to_int = -1
      if (ieee_is_nan(x)) return        ! (an ordered compare of NaN traps in Debug)
      if (abs(x) < 2.0e9_wp) to_int = nint(x)
   end function to_int

   !> The attributes a sweep file and a branch file share (format and its version, the
   !> trainsim version, the deck's file, title, units, overrides and fingerprint, n_runs
   !> slots) and the deck's text.
   subroutine put_file_head(f, format, version, lay, n_runs, err)
      integer(hid_t), intent(in) :: f
      character(len=*), intent(in) :: format, version
      type(sweep_layout_t), intent(in) :: lay
      integer, intent(in) :: n_runs
      type(error_t), allocatable, intent(out) :: err
      type(string_t), allocatable :: text(:)
      call put_str_attr(f, 'format', format, err)
      if (.not. allocated(err)) call put_str_attr(f, 'format_version', version, err)
      if (.not. allocated(err)) call put_str_attr(f, 'trainsim_version', lay%version, err)
      if (.not. allocated(err)) call put_str_attr(f, 'deck_file', lay%deck_file, err)
      if (.not. allocated(err)) call put_str_attr(f, 'title', lay%title, err)
      if (.not. allocated(err)) call put_str_attr(f, 'units', lay%units, err)
      if (.not. allocated(err)) call put_str_attr(f, 'overrides', lay%overrides, err)
      if (.not. allocated(err)) call put_str_attr(f, 'n_runs', str(n_runs), err)
      if (.not. allocated(err)) call put_str_attr(f, 'fingerprint', lay%fingerprint, err)
      allocate (text(1))
      text(1)%s = lay%deck_text       ! (an array constructor of string_t here trips gfortran 12)
      if (.not. allocated(err)) call put_column_s(f, 'deck_text', text, err)
   end subroutine put_file_head
end module trainsim_sweep_file
