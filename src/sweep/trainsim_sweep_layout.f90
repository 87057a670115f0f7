!> What a sweep file holds, apart from the file itself (trainsim_sweep_file): the run
!> statuses, the names of the per-run figures and metrics, the description of a sweep
!> (`sweep_layout_t`, the same on every rank), one finished run as sent to rank 0
!> (`sweep_record_t`, packed into a real buffer for MPI), and what differs between
!> the fingerprints of two sweeps ("holds another sweep (...)").
module trainsim_sweep_layout
   use trainsim_kinds, only: wp
   use trainsim_strings, only: string_t, str
   use trainsim_observer, only: run_result_t
   implicit none
   private

   public :: sweep_layout_t, sweep_record_t, element_metric_names, element_metric_is_int, node_metric_names
   public :: run_value_names, n_run_values
   public :: status_pending, status_ok, status_failed, record_size, format_version, status_names
   public :: status_meaning, fingerprint_difference, element_record

   !> Run statuses: the value stored in /runs/status is the index into status_names
   !> (a new status is one more name here and one parameter); any other value in a
   !> file is invalid (the run is made again).
   integer, parameter :: status_pending = 0, status_ok = 1, status_failed = 2
   character(len=*), parameter :: status_names(0:2) = [character(len=7) :: 'pending', 'ok', 'failed']
   !> Layout version (2: variable-length UTF-8 strings, nodes/start_speed; 3: elements/load_sharing;
   !> 4: elements/kv, static_force, static_te_mean, static_te_p2p, force_mean, te_order_1..4, force_order_1..4,
   !> rattle_impacts, rattle_open; 5: elements/rattle_criterion, rattle_energy, rattle_power).
   character(len=*), parameter :: format_version = '5'

   !> Per-element metrics (element_metrics_t), in record order; the integer counts are
   !> stored as integer datasets.
   character(len=*), parameter :: element_metric_names(34) = [character(len=21) :: &
      'force_min', 'force_max', 'torque_min', 'torque_max', 'disp_min', 'disp_max', 'impacts', 'separations', &
      'zone_changes', 'max_approach_velocity', 'max_peak_force', 'time_out_of_contact', 'p2p_range', &
      'p2p_mean', 'p2p_swings', 'load_sharing', 'kv', 'static_force', 'static_te_mean', 'static_te_p2p', &
      'force_mean', 'te_order_1', 'te_order_2', 'te_order_3', 'te_order_4', 'force_order_1', 'force_order_2', &
      'force_order_3', 'force_order_4', 'rattle_impacts', 'rattle_open', 'rattle_criterion', 'rattle_energy', &
      'rattle_power']
   logical, parameter :: element_metric_is_int(34) = [.false., .false., .false., .false., .false., .false., &
      .true., .true., .true., .false., .false., .false., .false., .false., .true., .false., .false., .false., .false., &
      .false., .false., .false., .false., .false., .false., .false., .false., .false., .false., .false., .false., &
      .false., .false., .false.]
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

   !> A run's element metrics in the sweep file's order (element_metric_names, element).
   function element_record(res) result(el)
      type(run_result_t), intent(in) :: res
      real(wp) :: el(size(element_metric_names), size(res%el))
      integer :: k
      do k = 1, size(res%el)
         associate (e => res%el(k))
            el(:, k) = [e%force_min, e%force_max, e%torque_min, e%torque_max, e%disp_min, e%disp_max, &
                        real(e%impacts, wp), real(e%separations, wp), real(e%zone_changes, wp), &
                        e%max_approach_velocity, e%max_peak_force, e%time_out_of_contact, e%p2p_range, &
                        e%p2p_mean, real(e%p2p_swings, wp), e%load_sharing, e%kv, e%static_force, &
                        e%static_te_mean, e%static_te_p2p, e%force_mean, e%te_order, e%force_order, &
                        e%rattle_impacts, e%rattle_open, e%rattle_criterion, e%rattle_energy, e%rattle_power]
         end associate
      end do
   end function element_record
end module trainsim_sweep_layout
