!> The branch file of `trainsim continue` (docs/periodic.md "The branch file"; D-119):
!> a periodic-orbit branch in the sweep file's HDF5 layout, one slot per point.
!>
!> As in a sweep file (trainsim_sweep_file) every dataset is made at the start with
!> one slot per point (the point budget: contiguous, allocated at once, fill NaN / -1 /
!> status 0), the same root attributes (format 'trainsim-branch', trainsim_version,
!> deck_file, title, units, overrides, fingerprint) and groups: /parameters (the one
!> continued key, its value per point), /runs (status 0 pending, 1 ok, 2 failed, the
!> reason and message of a failed point, period, t0, kind, stability, ...), /elements
!> (every element metric of the orbit's run, per point) and /branch (state, scaled
!> unknowns, tangent, multipliers, the scales; the branch's end status and message; with
!> element memory, the map's memory at t0 and which of it is held, D-154).
!> A point is written into its slot, the file flushed, then its status written and
!> flushed again: after a `kill -9` the file opens and every point with a non-zero
!> status is complete. `open` takes the writer lock (FILE.lock) and makes a new file
!> under FILE.<pid>.part, renamed when its layout is complete.
!>
!> Fortran (n, n_points) arrays appear in h5py as (n_points, n).
module trainsim_branch_file
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_io, err_input
   use trainsim_strings, only: string_t, str
   use trainsim_fs, only: pk_regular, path_kind, path_refusal, io_reason, os_text, fs_rename, fs_remove, &
      process_id, lock_file, unlock_file, remove_stale_parts
   use trainsim_h5, only: hid_t, h5_real, h5_int, h5_text, h5_init, create_file_excl, open_file_rdwr, flush_file, &
      close_file, new_group, end_group, close_dset, close_type, make_string_type, put_str_attr, get_str_attr
   use trainsim_h5_dsets, only: put_column_s, read_i1
   use trainsim_h5_slots, only: new_slots, open_dset, open_dsets, put_slot_r, put_slot_i, put_slot_text, get_slot_r, &
                                get_slot_text
   use trainsim_sweep_layout, only: sweep_layout_t, element_metric_names, status_pending, status_ok, status_failed, &
      status_meaning
   use trainsim_sweep_file, only: clean_slot_messages, finish_message_move, put_file_head
   use trainsim_arclength, only: branch_t, branch_point_t, branch_done
   implicit none
   private

   public :: branch_file_t, branch_format_version, reason_meaning

   character(len=*), parameter :: branch_format_version = '3'   ! (2: 34 element metrics, D-134; 3: memory, D-154)
   !> /runs: reals and integers per point (status and message apart)
   character(len=*), parameter :: run_r(7) = [character(len=18) :: 'period', 't0', 'phase', 'max_abs_multiplier', &
                                               'ds', 'ds_next', 'residual']
   character(len=*), parameter :: run_i(7) = [character(len=9) :: 'reason', 'kind', 'stable', 'stability', &
                                               'segment', 'corrector', 'maps']
   !> /branch: vectors per point (n states, or n + 1 for the scaled unknowns)
   character(len=*), parameter :: vec(7) = [character(len=15) :: 'state', 'z', 'tangent', 'border', &
                                            'multipliers_re', 'multipliers_im', 'multipliers_abs']
   character(len=*), parameter :: kinds(0:4) = [character(len=15) :: '', 'fold', 'period-doubling', 'neimark-sacker', &
                                                 'grazing']
   character(len=*), parameter :: stabilities(0:2) = [character(len=8) :: 'stable', 'marginal', 'unstable']

   type :: branch_file_t
      character(len=:), allocatable :: path, lock_path
      integer :: lock_fd = -1
      integer(hid_t) :: file = -1, d_status = -1, d_message = -1, t_message = -1, d_lam = -1
      integer(hid_t) :: d_r(size(run_r)) = -1, d_i(size(run_i)) = -1, d_v(size(vec)) = -1
      integer(hid_t) :: d_el(size(element_metric_names)) = -1
      integer(hid_t) :: d_scale = -1, d_lam_scale = -1, d_end = -1, d_end_message = -1
      integer(hid_t) :: d_mem = -1, d_kept = -1   !< /branch/memory, memory_held (nm > 0 only)
      integer :: n = 0, ne = 0, n_slots = 0
      integer :: nm = 0, nk = 0   !< the map's memory values and the elements holding them (D-150)
      integer :: period_count = 1   !< forcing periods per orbit (root attribute period_count; 1 if absent)
   contains
      procedure :: open => bf_open
      procedure :: write_point => bf_write_point
      procedure :: write_end => bf_write_end
      procedure :: read => bf_read
      procedure :: close => bf_close
   end type branch_file_t

contains

   !> "0 ok, 1 no periodic orbit near the start, ...": the meaning of /runs/reason and /branch/status.
   function reason_meaning() result(s)
      character(len=:), allocatable :: s
      s = '0 a point (or the branch left its range), 1 no periodic orbit near the start, 2 the corrector '// &
          'failed at the smallest step (not at a fold), 3 the point budget spent, 4 an error, 5 the corrector '// &
          'failed at the smallest step at a fold (a fold test heading for its sign change: a fold it could '// &
          'not turn), 6 a stale point: t0 in a contact that strikes within the period, not an orbit of '// &
          'the train (a failed point only; D-188); -1 running'
   end function reason_meaning

   !> Open the branch file `path` (lay: the deck, its fingerprint with the options that
   !> decide the branch, the element ids; lay%n_runs: the point budget; n: the states;
   !> key: the parameter): with `resume` it must exist and hold this branch, else it is
   !> made anew (an old one replaced). period_count: the forcing periods per orbit,
   !> written in a new file (default 1); a resumed file's is read into self%period_count
   !> (a doubled branch is resumed without --period-count, D-122). memory: the map's memory
   !> values and the elements holding them (period_map_t's mem and kept; default none).
   !> On error nothing is held.
   subroutine bf_open(self, path, lay, n, key, resume, err, period_count, memory)
      class(branch_file_t), intent(inout) :: self
      character(len=*), intent(in) :: path, key
      type(sweep_layout_t), intent(in) :: lay
      integer, intent(in) :: n
      logical, intent(in) :: resume
      type(error_t), allocatable, intent(out) :: err
      integer, intent(in), optional :: period_count, memory(2)
      character(len=:), allocatable :: why, s
      integer :: info, h
      logical :: ok
      self%path = path
      self%period_count = 1
      if (present(period_count)) self%period_count = period_count
      self%n = n
      if (present(memory)) then
         self%nm = memory(1)
         self%nk = memory(2)
      end if
      self%ne = size(lay%element_ids)
      self%n_slots = lay%n_runs
      why = path_refusal(path, ': a branch is recorded and resumed in a file')
      if (len(why) > 0) then
         call fatal_error(err, "cannot write branch file '"//path//"': "//why, err_io)
         return
      end if
      self%lock_path = path//'.lock'
      self%lock_fd = lock_file(self%lock_path, info)
      if (self%lock_fd < 0) then
         call fatal_error(err, "branch file '"//path//"': another trainsim is writing it, or its lock file '"// &
                          self%lock_path//"' cannot be made ("//os_text(max(info, 0))//')', err_io)
         return
      end if
      info = remove_stale_parts(path)
      call h5_init(err)
      if (allocated(err)) return
      if (resume) then
         if (path_kind(path) /= pk_regular) then
            call fatal_error(err, "nothing to resume: branch file '"//path//"' does not exist", err_io)
         else
            call open_file_rdwr(path, self%file, h)
            if (h < 0) call fatal_error(err, "cannot open branch file '"//path//"' (not an HDF5 file, or damaged)", &
                                        err_io)
         end if
         if (.not. allocated(err)) then
            call get_str_attr(self%file, 'format', s, ok)
            why = ''
            if (.not. ok .or. s /= 'trainsim-branch') then
               why = 'it is not a trainsim branch file'
            else
               call get_str_attr(self%file, 'format_version', s, ok)
               if (.not. ok) s = '?'
               if (s /= branch_format_version) then
                  why = 'its layout is version '//s//', this trainsim writes '//branch_format_version
               else
                  call get_str_attr(self%file, 'fingerprint', s, ok)
                  if (s /= lay%fingerprint) why = 'its deck, --set, --param or options differ'
               end if
               call get_str_attr(self%file, 'period_count', s, ok)
               self%period_count = 1
               if (ok) read (s, *, iostat=info) self%period_count
               if (len(why) == 0 .and. ok .and. (info /= 0 .or. self%period_count < 1)) &
                  why = "its period_count '"//s//"' is not a count"
            end if
            if (len(why) > 0) call fatal_error(err, "branch file '"//path//"' holds another branch ("//why// &
                                               '): delete it, or run without --resume', err_input)
         end if
      else
         call create(self, path, lay, key, err)
      end if
      if (.not. allocated(err)) call open_sets(self, resume, err)
      if (allocated(err)) call self%close()
   end subroutine bf_open

   !> A new file with every dataset (as FILE.<pid>.part, renamed when complete).
   subroutine create(self, path, lay, key, err)
      type(branch_file_t), intent(inout) :: self
      character(len=*), intent(in) :: path, key
      type(sweep_layout_t), intent(in) :: lay
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: part
      type(string_t) :: one(1)
      integer(hid_t) :: f, g, d
      integer :: h, hs, k, np
      logical :: ok
      part = path//'.'//str(process_id())//'.part'
      call fs_remove(part)
      call create_file_excl(part, f, h)
      if (h < 0) then
         call fatal_error(err, "cannot create branch file '"//part//"'"//io_reason(part), err_io)
         return
      end if
      np = self%n_slots
      call put_file_head(f, 'trainsim-branch', branch_format_version, lay, np, err)
      if (.not. allocated(err)) call put_str_attr(f, 'period_count', str(self%period_count), err)
      hs = 0
      call new_group(f, 'parameters', g, h); hs = min(hs, h)
      one(1)%s = key
      if (.not. allocated(err)) call put_column_s(g, 'names', one, err)
      call new_slots(g, 'values', [1, np], h5_real, d, hs); call close_dset(d)
      call end_group(g)
      call new_group(f, 'runs', g, h); hs = min(hs, h)
      call new_slots(g, 'status', [np], h5_int, d, hs, ifill=status_pending)
      if (.not. allocated(err) .and. hs == 0) call put_str_attr(d, 'meaning', status_meaning(), err)
      call close_dset(d)
      call new_slots(g, 'message', [np], h5_text, d, hs); call close_dset(d)
      do k = 1, size(run_r)
         call new_slots(g, trim(run_r(k)), [np], h5_real, d, hs); call close_dset(d)
      end do
      do k = 1, size(run_i)
         call new_slots(g, trim(run_i(k)), [np], h5_int, d, hs, ifill=-1)
         if (k == 1 .and. .not. allocated(err) .and. hs == 0) call put_str_attr(d, 'meaning', reason_meaning(), err)
         if (k == 2 .and. .not. allocated(err) .and. hs == 0) &
            call put_str_attr(d, 'meaning', '0 regular, 1 fold, 2 period-doubling, 3 neimark-sacker, 4 grazing', err)
         if (k == 4 .and. .not. allocated(err) .and. hs == 0) &
            call put_str_attr(d, 'meaning', '0 stable, 1 marginal, 2 unstable', err)
         call close_dset(d)
      end do
      call end_group(g)
      call new_group(f, 'elements', g, h); hs = min(hs, h)
      if (self%ne > 0 .and. .not. allocated(err)) then
         call put_column_s(g, 'ids', lay%element_ids, err)
         if (.not. allocated(err)) call put_column_s(g, 'types', lay%element_types, err)
         do k = 1, size(element_metric_names)
            call new_slots(g, trim(element_metric_names(k)), [self%ne, np], h5_real, d, hs); call close_dset(d)
         end do
      end if
      call end_group(g)
      call new_group(f, 'branch', g, h); hs = min(hs, h)
      do k = 1, size(vec)
         call new_slots(g, trim(vec(k)), [vec_size(self, k), np], h5_real, d, hs); call close_dset(d)
      end do
      if (self%nm > 0) then   ! (the map's memory at t0, D-150, and which elements hold it: 1/0)
         call new_slots(g, 'memory', [self%nm, np], h5_real, d, hs); call close_dset(d)
         call new_slots(g, 'memory_held', [self%nk, np], h5_int, d, hs, ifill=-1); call close_dset(d)
      end if
      call new_slots(g, 'scale', [self%n, 1], h5_real, d, hs); call close_dset(d)
      call new_slots(g, 'lam_scale', [1], h5_real, d, hs); call close_dset(d)
      call new_slots(g, 'status', [1], h5_int, d, hs, ifill=-1)
      if (.not. allocated(err) .and. hs == 0) call put_str_attr(d, 'meaning', reason_meaning(), err)
      call close_dset(d)
      call new_slots(g, 'message', [1], h5_text, d, hs); call close_dset(d)
      call end_group(g)
      call close_file(f, ok)
      if (allocated(err) .or. hs < 0 .or. .not. ok) then
         call fs_remove(part)
         if (.not. allocated(err)) call fatal_error(err, "cannot write branch file '"//path//"'"//io_reason(path), &
                                                    err_io)
         return
      end if
      if (.not. fs_rename(part, path)) then
         call fs_remove(part)
         call fatal_error(err, "cannot rename '"//part//"' to '"//path//"'"//io_reason(path), err_io)
         return
      end if
      call open_file_rdwr(path, self%file, h)
      if (h < 0) call fatal_error(err, "cannot open branch file '"//path//"'", err_io)
   end subroutine create

   integer function vec_size(self, k)
      type(branch_file_t), intent(in) :: self
      integer, intent(in) :: k
      vec_size = self%n
      if (k >= 2 .and. k <= 4) vec_size = self%n + 1
   end function vec_size

   !> Open every dataset of the open file; resumed, the messages of uncommitted points cleaned.
   subroutine open_sets(self, resume, err)
      type(branch_file_t), intent(inout) :: self
      logical, intent(in) :: resume
      type(error_t), allocatable, intent(out) :: err
      integer :: hs
      integer, allocatable :: st(:)
      hs = 0
      call finish_message_move(self%file, 'runs')
      call open_dset(self%file, 'runs/status', self%d_status, hs)
      call open_dset(self%file, 'runs/message', self%d_message, hs)
      call open_dset(self%file, 'parameters/values', self%d_lam, hs)
      call open_dsets(self%file, 'runs', run_r, self%d_r, hs)
      call open_dsets(self%file, 'runs', run_i, self%d_i, hs)
      if (self%ne > 0) then
         call open_dsets(self%file, 'elements', element_metric_names, self%d_el, hs)
      end if
      call open_dsets(self%file, 'branch', vec, self%d_v, hs)
      if (self%nm > 0) then
         call open_dset(self%file, 'branch/memory', self%d_mem, hs)
         call open_dset(self%file, 'branch/memory_held', self%d_kept, hs)
      end if
      call open_dset(self%file, 'branch/scale', self%d_scale, hs)
      call open_dset(self%file, 'branch/lam_scale', self%d_lam_scale, hs)
      call open_dset(self%file, 'branch/status', self%d_end, hs)
      call open_dset(self%file, 'branch/message', self%d_end_message, hs)
      call make_string_type(self%t_message, err)
      if (allocated(err)) return
      allocate (st(self%n_slots))
      if (hs == 0) call read_i1(self%d_status, st, hs)
      if (hs < 0) then
         call fatal_error(err, "cannot read branch file '"//self%path//"' (damaged: a dataset is missing or "// &
                          'unreadable, or the deck has other elements): delete it', err_io)
         return
      end if
      ! (a file just created holds no message: every slot pending, its text the fill
      ! value; reading each slot's text back cost ~430 M instructions, D-186)
      if (resume) call clean_slot_messages(self%file, 'runs', self%d_message, self%t_message, st /= status_pending, &
                                           self%path, err)
   end subroutine open_sets

   !> Point i of br (its element metrics el(metric, element), NaN for a failed point) into
   !> its slot; flush; its status; flush.
   subroutine bf_write_point(self, br, i, el, err)
      class(branch_file_t), intent(inout) :: self
      type(branch_t), intent(in) :: br
      integer, intent(in) :: i
      real(wp), intent(in) :: el(:, :)
      type(error_t), allocatable, intent(out) :: err
      integer :: h, hs, k, ints(size(run_i))
      real(wp) :: v(self%n + 1)
      hs = 0
      if (i > self%n_slots) then
         call fatal_error(err, "branch file '"//self%path//"': point "//str(i)//' beyond its '//str(self%n_slots)// &
                          ' slots', err_io)
         return
      end if
      associate (p => br%pts(i))
         call put_slot_r(self%d_lam, i, [p%lam], h); hs = min(hs, h)
         if (len(p%message) > 0) then   ! ('' is the fill value)
            call put_slot_text(self%d_message, self%t_message, i, p%message, h); hs = min(hs, h)
         end if
         if (p%status /= branch_done) then
            call put_slot_i(self%d_i(1), i, [p%status], h); hs = min(hs, h)
            call put_slot_i(self%d_i(5), i, [p%segment], h); hs = min(hs, h)
            call put_slot_i(self%d_i(7), i, [p%maps], h); hs = min(hs, h)
         else
            call put_slot_r(self%d_scale, 1, br%scale, h); hs = min(hs, h)
            call put_slot_r(self%d_lam_scale, 1, [br%lam_scale], h); hs = min(hs, h)
            call put_slot_r(self%d_r(1), i, [p%period], h); hs = min(hs, h)
            call put_slot_r(self%d_r(2), i, [p%t0], h); hs = min(hs, h)
            call put_slot_r(self%d_r(3), i, [p%phase], h); hs = min(hs, h)
            call put_slot_r(self%d_r(4), i, [maxval(abs(p%mu))], h); hs = min(hs, h)
            call put_slot_r(self%d_r(5), i, [p%ds], h); hs = min(hs, h)
            call put_slot_r(self%d_r(6), i, [p%ds_next], h); hs = min(hs, h)
            call put_slot_r(self%d_r(7), i, [p%residual], h); hs = min(hs, h)
            ints = [0, code(p%kind, kinds), merge(1, 0, p%stability == 'stable'), code(p%stability, stabilities), &
                    p%segment, p%corrector, p%maps]
            do k = 1, size(run_i)
               call put_slot_i(self%d_i(k), i, [ints(k)], h); hs = min(hs, h)
            end do
            call put_slot_r(self%d_v(1), i, p%x, h); hs = min(hs, h)
            call put_slot_r(self%d_v(2), i, p%z, h); hs = min(hs, h)
            call put_slot_r(self%d_v(3), i, p%tangent, h); hs = min(hs, h)
            call put_slot_r(self%d_v(4), i, p%border, h); hs = min(hs, h)
            v(1:self%n) = real(p%mu, wp)
            call put_slot_r(self%d_v(5), i, v(1:self%n), h); hs = min(hs, h)
            v(1:self%n) = aimag(p%mu)
            call put_slot_r(self%d_v(6), i, v(1:self%n), h); hs = min(hs, h)
            v(1:self%n) = abs(p%mu)
            call put_slot_r(self%d_v(7), i, v(1:self%n), h); hs = min(hs, h)
            if (self%nm > 0) call put_memory(self, i, p, hs)
            if (self%ne > 0) then
               do k = 1, size(element_metric_names)
                  v(1:self%ne) = el(k, :)
                  call put_slot_r(self%d_el(k), i, v(1:self%ne), h); hs = min(hs, h)
               end do
            end if
         end if
         if (hs == 0) call flush_file(self%file, h); hs = min(hs, h)
         if (hs == 0) call put_slot_i(self%d_status, i, [merge(status_ok, status_failed, p%status == branch_done)], h)
         hs = min(hs, h)
      end associate
      if (hs == 0) call flush_file(self%file, hs)
      if (hs < 0) call fatal_error(err, "cannot write point "//str(i)//" to branch file '"//self%path//"'"// &
                                   io_reason(self%path), err_io)
   end subroutine bf_write_point

   !> Point p's memory and which of it is held (its map's, D-150) into slot i.
   subroutine put_memory(self, i, p, hs)
      type(branch_file_t), intent(in) :: self
      integer, intent(in) :: i
      type(branch_point_t), intent(in) :: p
      integer, intent(inout) :: hs
      integer :: h
      if (.not. allocated(p%mem) .or. .not. allocated(p%kept)) return
      if (size(p%mem) /= self%nm .or. size(p%kept) /= self%nk) then
         hs = -1
         return
      end if
      call put_slot_r(self%d_mem, i, p%mem, h); hs = min(hs, h)
      call put_slot_i(self%d_kept, i, merge(1, 0, p%kept), h); hs = min(hs, h)
   end subroutine put_memory

   integer function code(word, words)
      character(len=*), intent(in) :: word, words(0:)
      do code = ubound(words, 1), 1, -1
         if (word == trim(words(code))) return
      end do
   end function code

   !> The branch's end: its status and message; flush.
   subroutine bf_write_end(self, br, err)
      class(branch_file_t), intent(inout) :: self
      type(branch_t), intent(in) :: br
      type(error_t), allocatable, intent(out) :: err
      integer :: h, hs
      character(len=:), allocatable :: m
      m = ''
      if (allocated(br%message)) m = br%message
      hs = 0
      call put_slot_text(self%d_end_message, self%t_message, 1, m, h); hs = min(hs, h)
      call flush_file(self%file, h); hs = min(hs, h)
      call put_slot_i(self%d_end, 1, [br%status], h); hs = min(hs, h)
      call flush_file(self%file, h); hs = min(hs, h)
      if (hs < 0) call fatal_error(err, "cannot write the end of branch file '"//self%path//"'", err_io)
   end subroutine bf_write_end

   !> The committed points (status ok or failed, from the first on), with the branch's
   !> scales: what `continue_branch(..., resume=br)` goes on from.
   subroutine bf_read(self, br, err)
      class(branch_file_t), intent(inout) :: self
      type(branch_t), intent(out) :: br
      type(error_t), allocatable, intent(out) :: err
      integer, allocatable :: st(:)
      type(branch_point_t) :: p, fresh
      real(wp) :: r(size(run_r)), ri(size(run_i)), one(1), v(self%n + 1), w(self%n), held(self%nk), mem(self%nm)
      integer :: i, k, h, hs
      logical :: ok
      allocate (st(self%n_slots), br%pts(0), br%scale(self%n))
      hs = 0
      call read_i1(self%d_status, st, h); hs = min(hs, h)
      call get_slot_r(self%d_scale, 1, br%scale, h); hs = min(hs, h)
      call get_slot_r(self%d_lam_scale, 1, one, h); hs = min(hs, h)
      br%lam_scale = one(1)
      do i = 1, self%n_slots
         if (st(i) == status_pending .or. hs < 0) exit
         p = fresh   ! (a failed point after a regular one: nothing allocated)
         call get_slot_r(self%d_lam, i, one, h); hs = min(hs, h)
         p%lam = one(1)
         do k = 1, size(run_r)
            call get_slot_r(self%d_r(k), i, r(k:k), h); hs = min(hs, h)
         end do
         do k = 1, size(run_i)
            call get_slot_r(self%d_i(k), i, ri(k:k), h); hs = min(hs, h)
         end do
         call get_slot_text(self%d_message, self%t_message, i, p%message, ok)
         if (.not. ok) hs = -1
         p%status = nint(ri(1))
         p%segment = nint(ri(5))
         p%maps = nint(ri(7))
         if (st(i) == status_ok) then
            p%period = r(1); p%t0 = r(2); p%phase = r(3); p%ds = r(5); p%ds_next = r(6); p%residual = r(7)
            p%kind = trim(kinds(nint(ri(2))))
            p%stability = trim(stabilities(nint(ri(4))))
            p%corrector = nint(ri(6))
            call get_slot_r(self%d_v(1), i, w, h); hs = min(hs, h)
            p%x = w
            call get_slot_r(self%d_v(2), i, v, h); hs = min(hs, h)
            p%z = v
            call get_slot_r(self%d_v(3), i, v, h); hs = min(hs, h)
            p%tangent = v
            call get_slot_r(self%d_v(4), i, v, h); hs = min(hs, h)
            p%border = v
            call get_slot_r(self%d_v(5), i, w, h); hs = min(hs, h)
            call get_slot_r(self%d_v(6), i, v(1:self%n), h); hs = min(hs, h)
            p%mu = cmplx(w, v(1:self%n), kind=wp)
            if (self%nm > 0) then
               call get_slot_r(self%d_mem, i, mem, h); hs = min(hs, h)
               call get_slot_r(self%d_kept, i, held, h); hs = min(hs, h)
               p%mem = mem
               p%kept = held > 0.5_wp
            end if
            br%phase = p%phase
         else
            p%kind = ''
            p%stability = ''
            allocate (p%x(0), p%z(0), p%tangent(0), p%border(0), p%mu(0))
         end if
         br%pts = [br%pts, p]
         br%maps = p%maps
      end do
      if (hs < 0) then
         call fatal_error(err, "cannot read the points of branch file '"//self%path//"' (damaged)", err_io)
      else if (size(br%pts) == 0) then
         call fatal_error(err, "the branch file '"//self%path//"' holds no point to resume from", err_input)
      end if
   end subroutine bf_read

   !> Close the file and release the lock. Safe to call at any time.
   subroutine bf_close(self)
      class(branch_file_t), intent(inout) :: self
      integer :: k
      logical :: ok
      if (self%file >= 0) then
         call close_dset(self%d_status); call close_dset(self%d_message); call close_dset(self%d_lam)
         call close_type(self%t_message)
         do k = 1, size(self%d_r)
            call close_dset(self%d_r(k)); call close_dset(self%d_i(k)); call close_dset(self%d_v(k))
         end do
         do k = 1, size(self%d_el)
            call close_dset(self%d_el(k))
         end do
         call close_dset(self%d_scale); call close_dset(self%d_lam_scale)
         call close_dset(self%d_mem); call close_dset(self%d_kept)
         call close_dset(self%d_end); call close_dset(self%d_end_message)
         call close_file(self%file, ok)
         self%file = -1
      end if
      if (self%lock_fd >= 0) call unlock_file(self%lock_fd, self%lock_path)
      self%lock_fd = -1
   end subroutine bf_close
end module trainsim_branch_file
