!> Rank 0 of a sweep (docs/sweeps.md): its bookkeeping (`master_t`), which hands out
!> run indices on request, the longest estimated run first and a continuation's run to
!> the rank that made its predecessor, records each finished run in the sweep file and
!> prints the progress lines; and the sink of a sweep run (`sweep_sink_t`: no history,
!> the node speed range), through which rank 0 services the workers during its own runs.
module trainsim_sweep_master
   use, intrinsic :: iso_c_binding, only: c_int
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t
   use trainsim_interrupt, only: signal_caught
   use trainsim_strings, only: str
   use trainsim_sweep_spec, only: sweep_spec_t
   use trainsim_sweep_file, only: sweep_file_t, sweep_record_t, element_metric_names, node_metric_names, &
      status_pending, status_ok, status_failed, record_size
   use trainsim_sink, only: sink_t, run_meta_t, sample_t, event_t, run_stats_t, element_metrics_t
   use trainsim_mpi, only: comm_poll_record, comm_stop_polling, comm_send_index
   implicit none
   private

   public :: master_t, sweep_sink_t, longest_first, setup_chains, break_resumed_chains, drain, elapsed, c_usleep

   !> Rank 0's bookkeeping.
   type :: master_t
      type(sweep_file_t) :: file
      integer, allocatable :: pending(:)
      integer :: next = 1, stopped = 0, n_ranks = 1, ne = 0, nn = 0
      integer :: n_ready = 0                !< workers whose first request ("ready") was answered
      logical :: own_taken = .false.       !< rank 0 has taken a run of its own
      !> rank 0 has looked for a run of its own after every worker's first request;
      !> until then a worker's later requests wait (D-137: every rank makes a run)
      logical :: own_tried = .false.
      !> the workers whose request waits, and the run each reported (0: none)
      integer :: n_held = 0
      integer, allocatable :: held_src(:), held_run(:)
      integer :: n_now = 0, n_failed_now = 0, n_before = 0, n_runs = 0
      integer(i8) :: c0 = 0, rate = 1, last_line = 0
      integer :: last_done = -1             !< runs done at the last progress line
      integer(i8) :: last_service = 0       !< clock at the last look for records
      integer :: unit = -1
      real(wp) :: interval = 5.0_wp
      logical :: tty = .false.
      type(error_t), allocatable :: err    !< a write error met while servicing
      logical :: interrupted = .false.     !< SIGINT/SIGTERM: hand out no more runs
      !> continuation: per run, the run it starts from (0: none) and the run that
      !> starts from it; a successor goes to the rank that made its predecessor
      integer, allocatable :: prev(:), next_of(:)
      logical, allocatable :: taken(:)
      !> continuation, resumed: per run, whether it starts from a run made before this
      !> sweep (its start state is in `done`, on every rank)
      logical, allocatable :: resumed(:)
   contains
      procedure :: take => master_take
      procedure :: service => master_service
      procedure :: record => master_record
      procedure :: break_chain => master_break_chain
      procedure :: progress => master_progress
   end type master_t

   !> The sink of a sweep run: no history; the node speed range after settle_time;
   !> on rank 0 of an MPI sweep, services the workers between samples.
   type, extends(sink_t) :: sweep_sink_t
      real(wp) :: t_metrics = 0.0_wp
      real(wp), allocatable :: wmin(:), wmax(:)
      type(master_t), pointer :: master => null()
      integer(i8) :: poll_ticks = 0
      integer :: n_samples = 0
   contains
      procedure :: open => ssink_open
      procedure :: write_sample => ssink_sample
      procedure :: speeds_only => ssink_speeds_only
      procedure :: metrics_from => ssink_metrics_from
      procedure :: close => ssink_close
   end type sweep_sink_t

   interface
      !> (POSIX usleep: waiting for the workers)
      function c_usleep(us) bind(C, name='usleep') result(rc)
         import :: c_int
         integer(c_int), value :: us
         integer(c_int) :: rc
      end function c_usleep
   end interface

contains

   !> The runs `runs` ordered by decreasing cost (equal costs in their order), so that
   !> the runs handed out last are the short ones (a short tail on N ranks).
   function longest_first(runs, cost) result(order)
      integer, intent(in) :: runs(:)
      real(wp), intent(in) :: cost(:)
      integer :: order(size(runs))
      integer :: i, j, r
      order = runs
      do i = 2, size(order)          ! insertion sort: stable, n is the number of runs
         r = order(i)
         j = i - 1
         do while (j >= 1)
            if (cost(order(j)) >= cost(r)) exit
            order(j + 1) = order(j)
            j = j - 1
         end do
         order(j + 1) = r
      end do
   end function longest_first

   !> The next run to hand out to a rank that has just made run `after` (0: none):
   !> in a continuation sweep the run that continues from `after` if there is one,
   !> else the next run not yet handed out that starts afresh (0: none left).
   integer function master_take(self, after) result(irun)
      class(master_t), intent(inout) :: self
      integer, intent(in) :: after
      integer :: j
      irun = 0
      if (signal_caught /= 0) self%interrupted = .true.
      if (self%interrupted) return
      if (allocated(self%next_of) .and. after > 0) then
         j = self%next_of(after)
         if (j > 0) then
            if (.not. self%taken(j) .and. self%file%status(j) == status_pending) then
               self%taken(j) = .true.
               irun = j
               return
            end if
         end if
      end if
      do while (self%next <= size(self%pending))
         j = self%pending(self%next)
         self%next = self%next + 1
         if (allocated(self%taken)) then
            ! a successor goes with its chain, unless its predecessor was made before
            if (self%taken(j)) cycle
            if (self%prev(j) > 0 .and. .not. self%resumed(j)) cycle
            self%taken(j) = .true.
         end if
         irun = j
         return
      end do
   end function master_take

   !> Continuation chains from the spec. A branch stopped part-way (a killed sweep)
   !> goes on from its last run made: that run's end state (the file's end_angle,
   !> end_speed, start_speed) goes into `done`, which rank 0 then sends to every rank.
   subroutine setup_chains(m, spec, done, err)
      type(master_t), intent(inout) :: m
      type(sweep_spec_t), intent(in) :: spec
      real(wp), intent(inout) :: done(:, :)
      type(error_t), allocatable, intent(out) :: err
      integer :: j, p
      if (.not. any(spec%prev > 0)) return
      m%prev = spec%prev
      allocate (m%next_of(size(spec%prev)), m%taken(size(spec%prev)), m%resumed(size(spec%prev)))
      m%next_of = 0
      m%taken = .false.
      m%resumed = .false.
      do j = 1, size(spec%prev)
         p = spec%prev(j)
         if (p == 0) cycle
         m%next_of(p) = j
         if (m%file%status(j) /= status_pending .or. m%file%status(p) /= status_ok) cycle
         m%resumed(j) = .true.
         call m%file%read_end_state(p, done(2:, p), err)
         if (allocated(err)) return
         done(1, p) = 1.0_wp
      end do
   end subroutine setup_chains

   !> A resumed sweep killed between a failed run's record and the "not made" record of
   !> the run after it: record that run (and the rest of its branch) now.
   subroutine break_resumed_chains(m)
      type(master_t), intent(inout) :: m
      type(sweep_record_t) :: rec
      integer :: j, p
      if (.not. allocated(m%prev)) return
      do j = 1, size(m%prev)
         p = m%prev(j)
         if (p == 0) cycle
         if (m%file%status(j) /= status_pending .or. m%file%status(p) /= status_failed) cycle
         if (m%taken(j)) cycle
         rec%irun = p
         rec%status = status_failed
         rec%rank = -1
         allocate (rec%el(size(element_metric_names), m%ne), rec%node(size(node_metric_names), m%nn))
         rec%el = ieee_value(0.0_wp, ieee_quiet_nan)
         rec%node = rec%el(1, 1)
         rec%run_values = rec%el(1, 1)
         rec%message = ''
         call m%break_chain(rec)
         deallocate (rec%el, rec%node)
      end do
   end subroutine break_resumed_chains

   !> Receive the workers' records, write them, answer each with its next index.
   subroutine master_service(self)
      class(master_t), intent(inout) :: self
      type(sweep_record_t) :: rec
      real(wp), allocatable :: buf(:)
      logical :: found
      integer :: src
      call system_clock(self%last_service)
      allocate (buf(record_size(self%ne, self%nn)), rec%el(size(element_metric_names), self%ne), &
                rec%node(size(node_metric_names), self%nn))
      if (.not. allocated(self%held_src)) allocate (self%held_src(self%n_ranks), self%held_run(self%n_ranks))
      if (self%own_tried) then                ! the requests that waited for rank 0's first run
         do while (self%n_held > 0)
            call answer(self%held_src(self%n_held), self%held_run(self%n_held))
            self%n_held = self%n_held - 1
         end do
      end if
      do
         call comm_poll_record(buf, found, src, rec%message)
         if (.not. found) exit
         call rec%unpack(buf)
         if (rec%irun == 0) self%n_ready = self%n_ready + 1
         if (rec%irun > 0 .and. rec%status == status_pending) then
            self%interrupted = .true.         ! the worker's run was stopped by a signal
         else if (rec%irun > 0) then
            call self%record(rec)
         end if
         if (rec%irun > 0 .and. .not. self%own_tried) then
            ! a fast worker's next request waits until every worker's first one has
            ! been answered and rank 0 has taken its run (else, on 3 ranks or more, it
            ! could take every run before a slow worker's first request: D-137)
            self%n_held = self%n_held + 1
            self%held_src(self%n_held) = src
            self%held_run(self%n_held) = rec%irun
            cycle
         end if
         call answer(src, rec%irun)
         ! the last worker's first request answered: rank 0 takes a run before any more (D-110)
         if (rec%irun == 0 .and. self%n_ready == self%n_ranks - 1 .and. .not. self%own_taken) exit
      end do
   contains
      !> Answer worker src, which reported run `done` (0: its first request), with its next run.
      subroutine answer(src, done)
         integer, intent(in) :: src, done
         integer :: irun
         irun = 0
         if (.not. allocated(self%err)) irun = self%take(done)
         call comm_send_index(src, irun)
         if (irun == 0) self%stopped = self%stopped + 1
      end subroutine answer
   end subroutine master_service

   recursive subroutine master_record(self, rec)
      class(master_t), intent(inout) :: self
      type(sweep_record_t), intent(in) :: rec
      type(error_t), allocatable :: err
      if (allocated(self%err)) return
      call self%file%write_run(rec, err)
      if (allocated(err)) then
         call move_alloc(err, self%err)
         return
      end if
      self%n_now = self%n_now + 1
      if (rec%status == status_failed) self%n_failed_now = self%n_failed_now + 1
      call self%progress(final=.false.)
      ! a failed run breaks its continuation branch: the runs after it fail too
      if (rec%status == status_failed) call self%break_chain(rec)
   end subroutine master_record

   !> Record the run after the failed run `rec` in its continuation branch as not made.
   recursive subroutine master_break_chain(self, rec)
      class(master_t), intent(inout) :: self
      type(sweep_record_t), intent(in) :: rec
      type(sweep_record_t) :: next
      integer :: j
      if (.not. allocated(self%next_of)) return
      j = self%next_of(rec%irun)
      if (j == 0) return
      if (self%taken(j)) return
      self%taken(j) = .true.
      next = rec
      next%irun = j
      next%wall = 0.0_wp
      next%message = 'not made: run '//str(rec%irun)//', the run before it in its continuation branch, failed'
      call self%record(next)
   end subroutine master_break_chain

   !> "sweep: 12/27 runs done (1 failed), 3.2 s, ETA 4.1 s"; in place on a terminal,
   !> else a line every `interval` seconds.
   subroutine master_progress(self, final)
      class(master_t), intent(inout) :: self
      logical, intent(in) :: final
      integer(i8) :: c
      real(wp) :: t, since, eta
      character(len=:), allocatable :: line
      integer :: done, failed
      if (self%unit < 0) return
      call system_clock(c)
      since = real(c - self%last_line, wp)/real(self%rate, wp)
      done = self%n_before + self%n_now
      if (.not. final) then
         if (self%tty .and. since < 0.2_wp) return
         if (.not. self%tty .and. since < self%interval) return
      else if (done == self%last_done .and. .not. self%tty) then
         return
      end if
      self%last_line = c
      self%last_done = done
      ! a line says what the file holds: commit the runs written so far
      if (.not. allocated(self%err)) call self%file%commit(self%err)
      t = elapsed(self)
      failed = count(self%file%status == status_failed)
      line = 'sweep: '//str(done)//'/'//str(self%n_runs)//' runs done'
      if (failed > 0) line = line//' ('//str(failed)//' failed)'
      line = line//', '//fixed1(t)//' s elapsed'
      if (self%n_now > 0 .and. done < self%n_runs) then
         eta = t/real(self%n_now, wp)*real(self%n_runs - done, wp)
         line = line//', ETA '//fixed1(eta)//' s'
      end if
      if (self%tty) then
         if (final) then
            write (self%unit, '(a)') achar(13)//line//'      '
         else
            write (self%unit, '(a)', advance='no') achar(13)//line//'      '
         end if
      else
         write (self%unit, '(a)') line
      end if
      flush (self%unit)
   end subroutine master_progress

   function fixed1(x) result(s)
      real(wp), intent(in) :: x
      character(len=:), allocatable :: s
      character(len=32) :: buf
      write (buf, '(f0.1)') x
      s = trim(buf)
      if (s(1:1) == '.') s = '0'//s
   end function fixed1

   real(wp) function elapsed(m)
      type(master_t), intent(in) :: m
      integer(i8) :: c
      call system_clock(c)
      elapsed = real(c - m%c0, wp)/real(m%rate, wp)
   end function elapsed

   !> After an error on rank 0: tell every worker there is no work.
   subroutine drain(m)
      type(master_t), intent(inout) :: m
      type(sweep_record_t) :: rec
      real(wp), allocatable :: buf(:)
      logical :: found
      integer :: src
      integer(c_int) :: rc
      if (m%n_ranks <= 1) return
      do while (m%n_held > 0)                 ! (requests that waited for rank 0's first run)
         call comm_send_index(m%held_src(m%n_held), 0)
         m%stopped = m%stopped + 1
         m%n_held = m%n_held - 1
      end do
      allocate (buf(record_size(m%ne, m%nn)))
      do while (m%stopped < m%n_ranks - 1)
         call comm_poll_record(buf, found, src, rec%message)
         if (found) then
            call comm_send_index(src, 0)
            m%stopped = m%stopped + 1
         else
            rc = c_usleep(250_c_int)
         end if
      end do
      call comm_stop_polling()
   end subroutine drain

   subroutine ssink_open(self, meta, err)
      class(sweep_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      allocate (self%wmin(size(meta%node_ids)), self%wmax(size(meta%node_ids)))
      self%wmin = huge(1.0_wp)
      self%wmax = -huge(1.0_wp)
   end subroutine ssink_open

   subroutine ssink_sample(self, s, err)
      class(sweep_sink_t), intent(inout) :: self
      type(sample_t), intent(in) :: s
      type(error_t), allocatable, intent(out) :: err
      integer(i8) :: c
      if (s%t >= self%t_metrics) then
         self%wmin = min(self%wmin, s%omega)
         self%wmax = max(self%wmax, s%omega)
      end if
      if (associated(self%master)) then
         ! a clock read at the first sample (a tiny run has few), then every 32 (a
         ! sample is a few steps of a microsecond)
         self%n_samples = self%n_samples + 1
         if (iand(self%n_samples, 31) /= 1) return
         call system_clock(c)
         if (c - self%master%last_service >= self%poll_ticks) call self%master%service()
      end if
   end subroutine ssink_sample

   !> The run has settled at t: the speed range starts there.
   subroutine ssink_metrics_from(self, t)
      class(sweep_sink_t), intent(inout) :: self
      real(wp), intent(in) :: t
      self%t_metrics = t
   end subroutine ssink_metrics_from

   !> A sweep run reads the node speeds of its samples only (their range).
   pure logical function ssink_speeds_only(self) result(only)
      class(sweep_sink_t), intent(in) :: self
      associate (unused => self)
      end associate
      only = .true.
   end function ssink_speeds_only

   subroutine ssink_close(self, events, stats, metrics, err)
      class(sweep_sink_t), intent(inout) :: self
      type(event_t), intent(in) :: events(:)
      type(run_stats_t), intent(in) :: stats
      type(element_metrics_t), intent(in) :: metrics(:)
      type(error_t), allocatable, intent(out) :: err
   end subroutine ssink_close
end module trainsim_sweep_master
