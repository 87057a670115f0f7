!> The /events table of a run file (docs/output-format.md): one extendible, chunked
!> 1-D dataset per column. Rows are buffered in blocks and appended; a row already
!> written is rewritten in place (one-row hyperslabs of peak_force and duration) when
!> its contact ends. Part of the run sink (trainsim_hdf5), which reports its errors
!> with the output path and aborts: an error of code err_internal is a misuse (a row
!> out of order), err_io a failed write.
module trainsim_hdf5_events
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_io, err_internal
   use trainsim_strings, only: string_t, str
   use trainsim_sink, only: event_t, ev_name
   use trainsim_h5, only: hid_t, hsize_t, h5_real, h5_int, h5_text, make_group, close_group, end_group, &
      close_dset, put_str_attr
   use trainsim_h5_dsets, only: make_series, append_r1, append_i1, append_s1, write_r_at, read_i1, put_entry_units
   use trainsim_hdf5_groups, only: run_units_t, same_units
   implicit none
   private

   public :: event_table_t

   !> Columns of /events, in the order they are created (docs/output-format.md).
   integer, parameter :: n_evc = 15
   character(len=*), parameter :: ev_columns(n_evc) = [character(len=17) :: 'time', 'element', 'kind', &
      'kind_name', 'approach_velocity', 'restitution', 'damping', 'peak_force', 'duration', 'theta_left', &
      'omega_left', 'theta_right', 'omega_right', 'displacement', 'force']
   integer, parameter :: evc_time = 1, evc_element = 2, evc_kind = 3, evc_kind_name = 4, evc_velocity = 5, &
      evc_restitution = 6, evc_damping = 7, evc_peak = 8, evc_duration = 9, evc_theta_left = 10, &
      evc_omega_left = 11, evc_theta_right = 12, evc_omega_right = 13, evc_disp = 14, evc_force = 15

   !> The /events group of one open run file.
   type :: event_table_t
      integer(hid_t), private :: grp = -1, dset(n_evc) = -1
      type(event_t), allocatable, private :: buf(:)
      integer, private :: n_buf = 0, written = 0   ! rows buffered, in the file
      !> Element of the first row, and whether later rows' displacement or force
      !> units differ from its (then the columns list a unit per row).
      integer, private :: el1 = 0
      logical, private :: disp_mixed = .false., force_mixed = .false.
      type(run_units_t), private :: units
   contains
      procedure :: open => events_open
      procedure :: rows => events_rows
      procedure :: write => events_write
      procedure :: update => events_update
      procedure :: finish => events_finish
      procedure :: abort => events_abort
   end type event_table_t

contains

   !> /events in `file`: the group and its columns, chunked by `block_rows` (rows come in blocks).
   subroutine events_open(self, file, block_rows, units, err)
      class(event_table_t), intent(inout) :: self
      integer(hid_t), intent(in) :: file
      integer, intent(in) :: block_rows
      type(run_units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      integer :: k, kind
      self%n_buf = 0; self%written = 0; self%el1 = 0
      self%disp_mixed = .false.; self%force_mixed = .false.
      self%units = units
      call make_group(file, 'events', self%grp, err)
      if (allocated(err)) return
      do k = 1, n_evc
         select case (k)
         case (evc_element, evc_kind); kind = h5_int
         case (evc_kind_name); kind = h5_text
         case default; kind = h5_real
         end select
         call make_series(self%grp, trim(ev_columns(k)), 1, 0, block_rows, kind, 0, self%dset(k), err)
         if (allocated(err)) return
      end do
      if (allocated(self%buf)) deallocate (self%buf)
      allocate (self%buf(block_rows))
   end subroutine events_open

   !> Rows given so far (in the file and in the buffer).
   pure integer function events_rows(self)
      class(event_table_t), intent(in) :: self
      events_rows = self%written + self%n_buf
   end function events_rows

   !> Buffer row `row` (rows come in order); write a block when the buffer is full.
   subroutine events_write(self, row, ev, err)
      class(event_table_t), intent(inout) :: self
      integer, intent(in) :: row
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: d1, f1, d, f
      if (row /= self%written + self%n_buf + 1) then
         call fatal_error(err, 'event row '//str(row)//' out of order (expected '// &
                          str(self%written + self%n_buf + 1)//')', err_internal)
         return
      end if
      if (row == 1) then
         self%el1 = ev%element
      else
         call row_units(self, self%el1, d1, f1)
         call row_units(self, ev%element, d, f)
         if (d /= d1) self%disp_mixed = .true.
         if (f /= f1) self%force_mixed = .true.
      end if
      self%n_buf = self%n_buf + 1
      self%buf(self%n_buf) = ev
      if (self%n_buf == size(self%buf)) call flush_events(self, err)
   end subroutine events_write

   !> Row `row` again with its final peak force and duration: in the buffer if it
   !> is still there, else rewritten in the file (one row of those two columns).
   subroutine events_update(self, row, ev, err)
      class(event_table_t), intent(inout) :: self
      integer, intent(in) :: row
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      if (row < 1 .or. row > self%written + self%n_buf) then
         call fatal_error(err, 'update of event row '//str(row)//' not written yet', err_internal)
         return
      end if
      if (row > self%written) then
         self%buf(row - self%written)%peak_force = ev%peak_force
         self%buf(row - self%written)%duration = ev%duration
         return
      end if
      call write_r_at(self%dset(evc_peak), ev%peak_force, row, '/events/peak_force', err)
      if (.not. allocated(err)) call write_r_at(self%dset(evc_duration), ev%duration, row, '/events/duration', err)
   end subroutine events_update

   !> Append the buffered rows to every column.
   subroutine flush_events(self, err)
      type(event_table_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer :: nb, i, k
      real(wp), allocatable :: r(:)
      integer, allocatable :: iv(:)
      type(string_t), allocatable :: names(:)
      integer(hsize_t) :: row0
      nb = self%n_buf
      if (nb == 0) return
      row0 = int(self%written, hsize_t)
      allocate (r(nb), iv(nb), names(nb))
      do k = 1, n_evc
         associate (b => self%buf(1:nb), what => '/events/'//trim(ev_columns(k)))
            select case (k)
            case (evc_element, evc_kind)
               if (k == evc_element) iv = b%element
               if (k == evc_kind) iv = b%kind
               call append_i1(self%dset(k), iv, row0, what, err)
            case (evc_kind_name)
               do i = 1, nb
                  names(i)%s = ev_name(b(i)%kind)
               end do
               call append_s1(self%dset(k), names, row0, what, err)
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
               call append_r1(self%dset(k), r, row0, what, err)
            end select
         end associate
         if (allocated(err)) return
      end do
      self%written = self%written + nb
      self%n_buf = 0
   end subroutine flush_events

   !> Last block of events, the columns' units, close /events. Each row takes
   !> its element's displacement and force units; a column whose rows differ
   !> lists them per row (`entry_units`, read back from /events/element).
   subroutine events_finish(self, err)
      class(event_table_t), intent(inout) :: self
      type(error_t), allocatable, intent(out) :: err
      integer :: n, i, k, h
      integer, allocatable :: el(:)
      character(len=:), allocatable :: d, f
      type(string_t), allocatable :: disp(:), force(:), vel(:), damp(:), u(:)
      call flush_events(self, err)
      if (allocated(err)) return
      n = self%written
      if (self%disp_mixed .or. self%force_mixed) then
         allocate (el(n))
         call read_i1(self%dset(evc_element), el, h)
         if (h < 0) then
            call fatal_error(err, 'cannot read back /events/element', err_io)
            return
         end if
      else
         allocate (el(min(n, 1)))
         if (n > 0) el = self%el1
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
            call put_str_attr(self%dset(k), 'units', '1', err)
         else
            call put_entry_units(self%dset(k), u, err)
         end if
         if (allocated(err)) return
         call close_dset(self%dset(k), h)
         if (h < 0) then
            call fatal_error(err, 'cannot write events/'//trim(ev_columns(k)), err_io)
            return
         end if
      end do
      call close_group(self%grp, err)
      self%grp = -1
   end subroutine events_finish

   !> Close whatever is open and forget the rows. Safe to call at any time.
   subroutine events_abort(self)
      class(event_table_t), intent(inout) :: self
      integer :: i
      do i = 1, n_evc
         call close_dset(self%dset(i))
      end do
      call end_group(self%grp)
      self%grp = -1
      self%n_buf = 0
      self%written = 0
      if (allocated(self%buf)) deallocate (self%buf)
   end subroutine events_abort

   !> Displacement and force units of a row of element `el` ('1' out of range).
   subroutine row_units(self, el, d, f)
      type(event_table_t), intent(in) :: self
      integer, intent(in) :: el
      character(len=:), allocatable, intent(out) :: d, f
      if (el >= 1 .and. el <= size(self%units%el_disp)) then
         d = self%units%el_disp(el)%s
         f = self%units%el_force(el)%s
      else
         d = '1'; f = '1'
      end if
   end subroutine row_units
end module trainsim_hdf5_events
