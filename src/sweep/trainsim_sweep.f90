!> `trainsim sweep`: the runs of a deck's &sweep groups, serially or on MPI ranks with
!> dynamic load balancing, recorded in one HDF5 sweep file as each run completes.
!>
!> Load balancing (docs/sweeps.md): rank 0 hands out run indices one at a time, on
!> request, the longest estimated run first (steps = (t_end - t_start)/dt, so that the
!> last runs handed out are short and the ranks finish together). Each worker sends the
!> record of its finished run, which is also its request for the next index. Rank 0
!> computes runs too; while it does, its sink looks for a worker's record (one MPI_Test
!> of a receive posted in advance) every millisecond of wall time, so no worker waits
!> for rank 0's run to end. Rank 0 alone writes the sweep file.
!>
!> A run is `simulate` on a model prepared from the deck with the run's parameter values
!> (trainsim_prepare); no history is written. A run that fails (blow-up, solver failure)
!> is recorded with its message and the sweep goes on.
module trainsim_sweep
   use, intrinsic :: iso_c_binding, only: c_int, c_char, c_long_long, c_null_char
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_input, err_io, err_interrupted
   use trainsim_interrupt, only: signal_caught, interrupt_signal, signal_name
   use trainsim_strings, only: string_t, str, to_lower, join
   use trainsim_version, only: version_full
   use trainsim_deck, only: deck_t, deck_group_t, read_deck
   use trainsim_model, only: model_t
   use trainsim_overrides, only: override_t, split_sweep_groups
   use trainsim_prepare, only: prepare_model
   use trainsim_sweep_spec, only: sweep_spec_t, read_sweep_spec
   use trainsim_sweep_file, only: sweep_file_t, sweep_layout_t, sweep_record_t, element_metric_names, &
      node_metric_names, status_pending, status_ok, status_failed, record_size, status_names
   use trainsim_sink, only: sink_t, run_meta_t, sample_t, event_t, run_stats_t, element_metrics_t
   use trainsim_observer, only: run_result_t, make_meta
   use trainsim_simulate, only: simulate
   use trainsim_continuation, only: chain_state_t, save_end_state, start_from, nominal_speeds
   use trainsim_mpi, only: comm_init, comm_finalize, comm_rank, comm_size, comm_send_record, &
      comm_poll_record, comm_stop_polling, comm_send_index, comm_recv_index, comm_bcast_int, comm_bcast_reals, &
      comm_sum_reals, comm_min_int
   implicit none
   private

   public :: sweep_options_t, sweep_summary_t, run_sweep, finish_sweep, default_sweep_path

   !> What `trainsim sweep` was asked to do.
   type :: sweep_options_t
      character(len=:), allocatable :: deck_path
      character(len=:), allocatable :: out_path        !< '' : default_sweep_path(deck_path)
      type(override_t), allocatable :: sets(:)         !< --set, applied before each run's values
      logical :: resume = .false.                      !< the sweep file must exist already
      logical :: strict = .false.                      !< --strict: a plausibility warning fails the run's build
      integer :: progress_unit = -1                    !< progress lines (rank 0); -1: none
      real(wp) :: progress_interval = 5.0_wp           !< s between lines when not a terminal; 0: every run
   end type sweep_options_t

   !> What the sweep did (on rank 0; other ranks know only exit_code and root).
   type :: sweep_summary_t
      logical :: root = .true.
      integer :: exit_code = 0          !< 0 all ok, 1 some run failed, 2 input or file error,
                                        !< 128 + signal: interrupted (SIGINT, SIGTERM)
      integer :: n_runs = 0, n_before = 0, n_now = 0, n_ok = 0, n_failed = 0
      real(wp) :: elapsed = 0.0_wp
      character(len=:), allocatable :: path
   end type sweep_summary_t

   !> Rank 0's bookkeeping.
   type :: master_t
      type(sweep_file_t) :: file
      integer, allocatable :: pending(:)
      integer :: next = 1, stopped = 0, n_ranks = 1, ne = 0, nn = 0
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
      function c_usleep(us) bind(C, name='usleep') result(rc)
         import :: c_int
         integer(c_int), value :: us
         integer(c_int) :: rc
      end function c_usleep
      function c_isatty(fd) bind(C, name='isatty') result(rc)
         import :: c_int
         integer(c_int), value :: fd
         integer(c_int) :: rc
      end function c_isatty
      subroutine c_digest(s, n, out) bind(C, name='trainsim_digest')
         import :: c_char, c_long_long
         character(kind=c_char), intent(in) :: s(*)
         integer(c_long_long), value :: n
         character(kind=c_char), intent(out) :: out(*)
      end subroutine c_digest
   end interface

contains

   !> Default sweep file: the deck's base name with `_sweep.h5`, in the current directory.
   function default_sweep_path(deck_path) result(p)
      character(len=*), intent(in) :: deck_path
      character(len=:), allocatable :: p
      integer :: i
      p = deck_path(index(deck_path, '/', back=.true.) + 1:)
      i = index(p, '.', back=.true.)
      if (i > 1) p = p(1:i - 1)
      p = p//'_sweep.h5'
   end function default_sweep_path

   !> Run the sweep of `opt%deck_path`. Every rank calls it; MPI is started here and
   !> stopped by `finish_sweep`, which the caller calls after it has said what happened:
   !> an mpirun that is stopping the job (Ctrl-C in a terminal) never completes
   !> MPI_Finalize, and kills the ranks one second after its SIGTERM (D-63).
   !> `err` is set on every rank for an input error, on rank 0 for a file error.
   subroutine run_sweep(opt, summary, err)
      type(sweep_options_t), intent(in) :: opt
      type(sweep_summary_t), intent(out) :: summary
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: why
      call comm_init(why)
      if (len(why) > 0) then
         call fatal_error(err, 'error: '//why, err_input)
         summary%exit_code = 2
         return
      end if
      summary%root = comm_rank() == 0
      call sweep_body(opt, summary, err)
      call comm_bcast_int(summary%exit_code)
   end subroutine run_sweep

   !> Stop MPI if `run_sweep` started it (else nothing): after the sweep's outcome is
   !> printed, before the program exits.
   subroutine finish_sweep()
      call comm_finalize()
   end subroutine finish_sweep

   subroutine sweep_body(opt, summary, err)
      type(sweep_options_t), intent(in) :: opt
      type(sweep_summary_t), intent(inout) :: summary
      type(error_t), allocatable, intent(out) :: err
      type(deck_t) :: deck
      type(sweep_spec_t) :: spec
      type(sweep_layout_t) :: lay
      type(master_t), target :: m
      real(wp), allocatable :: cost(:), done(:, :)
      integer :: i, bad, stop_now

      call setup(opt, deck, spec, lay, err)
      if (allocated(err)) then
         summary%exit_code = 2
         return
      end if
      ! every run must build (input errors before any file is touched); each rank
      ! builds its share, rank 0 reports the first run that does not build
      call validate_runs(opt, deck, spec, comm_rank(), comm_size(), cost, i, err)
      bad = i
      call comm_sum_reals(cost)
      call comm_min_int(bad)
      stop_now = merge(0, 1, signal_caught /= 0)
      call comm_min_int(stop_now)            ! a signal on any rank stops every rank
      if (stop_now == 0) then
         call fatal_error(err, 'sweep interrupted while its runs were checked, before the first run: '// &
                          'nothing recorded', err_interrupted)
         summary%exit_code = 128 + max(interrupt_signal(), 0)
         if (interrupt_signal() == 0) summary%exit_code = 130
         return
      end if
      if (bad <= spec%n_runs) then
         if (summary%root .and. i /= bad) then
            call validate_runs(opt, deck, spec, bad - 1, spec%n_runs, cost, i, err)   ! run `bad` alone
         end if
         if (.not. allocated(err)) call fatal_error(err, 'error: a run of the sweep does not build', err_input)
         summary%exit_code = 2
         return
      end if
      ! continuation: the end states of runs made before (resumed sweeps), on every rank
      if (any(spec%prev > 0)) then
         allocate (done(1 + 3*size(lay%node_ids), lay%n_runs))
      else
         allocate (done(0, 0))
      end if
      done = 0.0_wp
      if (.not. summary%root) then
         if (size(done) > 0) call comm_bcast_reals(done)
         call worker(opt, deck, spec, lay, done)
         return
      end if

      summary%path = opt%out_path
      if (len(summary%path) == 0) summary%path = default_sweep_path(opt%deck_path)
      m%n_ranks = comm_size()
      m%ne = size(lay%element_ids); m%nn = size(lay%node_ids); m%n_runs = lay%n_runs
      call open_file(m, opt, summary%path, lay, err)
      if (.not. allocated(err)) then
         if (m%file%n_invalid > 0 .and. opt%progress_unit >= 0) then
            write (opt%progress_unit, '(a)') 'sweep: '//str(m%file%n_invalid)//' run(s) of '//summary%path// &
               ' had an invalid status ('//str(m%file%invalid_value)//'; valid: '//status_list()//'): made again'
         end if
         m%pending = longest_first(pack([(i, i=1, lay%n_runs)], m%file%status == status_pending), cost)
         call setup_chains(m, spec, done, err)
      end if
      if (size(done) > 0) then
         call comm_bcast_reals(done)
         if (.not. allocated(err)) call break_resumed_chains(m)
      end if
      if (allocated(err)) then
         summary%exit_code = 2
         call m%file%close()
         call drain(m)
         return
      end if
      m%n_before = lay%n_runs - size(m%pending)
      m%unit = opt%progress_unit
      m%interval = opt%progress_interval
      if (m%unit >= 0) m%tty = c_isatty(2_c_int) == 1 .and. m%unit == 0
      call system_clock(m%c0, m%rate)
      m%last_line = m%c0
      if (m%unit >= 0) then
         if (m%n_before > 0) then
            write (m%unit, '(a)') 'sweep: resuming '//summary%path//': '//str(m%n_before)//' of '// &
               str(lay%n_runs)//' runs already done, '//str(size(m%pending))//' to run on '//str(m%n_ranks)// &
               ' rank(s)'
         else
            write (m%unit, '(a)') 'sweep: '//str(lay%n_runs)//' runs on '//str(m%n_ranks)//' rank(s) -> '// &
               summary%path
         end if
         flush (m%unit)
      end if

      call master_loop(m, opt, deck, spec, lay, done)
      if (.not. allocated(m%err)) call m%file%commit(m%err)
      call m%file%close()
      if (allocated(m%err)) then
         call move_alloc(m%err, err)
         summary%exit_code = 2
         return
      end if
      if (m%interrupted) then
         if (m%unit >= 0 .and. m%tty) write (m%unit, '(a)') ''
         i = count(m%file%status /= status_pending)
         call fatal_error(err, 'sweep interrupted by '//signal_name(interrupt_signal())//': '//str(i)//' of '// &
                          str(lay%n_runs)//' run(s) recorded in '//summary%path//' ('//str(m%n_now)// &
                          ' made now); the same command resumes the sweep', err_interrupted)
         summary%exit_code = 128 + interrupt_signal()
         return
      end if
      call m%progress(final=.true.)
      summary%n_runs = lay%n_runs
      summary%n_before = m%n_before
      summary%n_now = m%n_now
      summary%n_ok = count(m%file%status == status_ok)
      summary%n_failed = count(m%file%status == status_failed)
      summary%elapsed = elapsed(m)
      summary%exit_code = merge(1, 0, summary%n_failed > 0)
   end subroutine sweep_body

   !> Deck, sweep spec and file layout (the same on every rank).
   subroutine setup(opt, deck, spec, lay, err)
      type(sweep_options_t), intent(in) :: opt
      type(deck_t), intent(out) :: deck
      type(sweep_spec_t), intent(out) :: spec
      type(sweep_layout_t), intent(out) :: lay
      type(error_t), allocatable, intent(out) :: err
      type(deck_group_t), allocatable :: groups(:)
      type(model_t) :: model
      type(run_meta_t) :: meta
      type(string_t), allocatable :: sets(:)
      integer :: i, j, k

      call read_deck(opt%deck_path, deck, err); if (allocated(err)) return
      call split_sweep_groups(deck, groups)
      call read_sweep_spec(groups, spec, err); if (allocated(err)) return
      ! a --set of a swept parameter would be overridden in every run
      do i = 1, size(opt%sets)
         do j = 1, size(spec%names)
            if (to_lower(opt%sets(i)%target//'.'//opt%sets(i)%key) == to_lower(spec%names(j)%s)) then
               call fatal_error(err, opt%sets(i)%origin//': error: '//spec%names(j)%s//' is swept by '// &
                                spec%where(j)%s, err_input)
               return
            end if
         end do
      end do
      call prepare_model(deck, run_overrides(opt, spec, 1, err), model, err); if (allocated(err)) return
      if (opt%progress_unit >= 0 .and. .not. opt%strict) then   ! the plausibility warnings of run 1
         do i = 1, size(model%warnings)
            write (opt%progress_unit, '(a)') 'trainsim: '//model%warnings(i)%s
         end do
      end if
      lay%version = version_full()
      lay%deck_file = opt%deck_path
      lay%deck_text = deck%text
      meta = make_meta(model)   ! the table files the deck reads (the same for every run)
      call move_alloc(meta%input_keys, lay%input_keys)
      call move_alloc(meta%input_files, lay%input_files)
      call move_alloc(meta%input_texts, lay%input_texts)
      lay%title = model%title
      lay%units = model%units%name
      allocate (sets(size(opt%sets)))
      do i = 1, size(opt%sets)
         sets(i)%s = opt%sets(i)%origin
      end do
      lay%overrides = join(sets, ' ')
      lay%fingerprint = fingerprint(deck, lay)
      lay%param_names = spec%names
      lay%param_values = spec%values
      lay%n_runs = spec%n_runs
      lay%branch = spec%branch
      allocate (lay%element_ids(size(model%elements)), lay%element_types(size(model%elements)))
      do k = 1, size(model%elements)
         lay%element_ids(k)%s = model%elements(k)%e%id
         lay%element_types(k)%s = model%elements(k)%e%type_name
      end do
      allocate (lay%node_ids(size(model%nodes)))
      do k = 1, size(model%nodes)
         lay%node_ids(k)%s = model%nodes(k)%n%id
      end do
   end subroutine setup

   !> --strict: the first plausibility warning of a model as an error (exit 2).
   subroutine strict_error(warnings, err)
      type(string_t), intent(in) :: warnings(:)
      type(error_t), allocatable, intent(inout) :: err
      integer :: p
      if (allocated(err) .or. size(warnings) == 0) return
      p = index(warnings(1)%s, ': warning: ')
      call fatal_error(err, warnings(1)%s(1:p - 1)//': error: '//warnings(1)%s(p + 11:)// &
                       ' (a warning, made an error by --strict)', err_input)
   end subroutine strict_error

   !> What decides the sweep's results, one item a line: the parsed deck (groups, keys,
   !> values: a comment or a blank does not change it), each table file's contents,
   !> the --set overrides and the trainsim version. Items are compared by line when
   !> an existing file is continued (trainsim_sweep_file, "holds another sweep").
   function fingerprint(deck, lay) result(fp)
      type(deck_t), intent(in) :: deck
      type(sweep_layout_t), intent(in) :: lay
      character(len=:), allocatable :: fp
      integer :: k
      fp = 'deck '//digest(canonical_deck(deck))
      if (allocated(lay%input_files)) then
         do k = 1, size(lay%input_files)
            fp = fp//new_line('a')//'file '//digest(lay%input_texts(k)%s)//' '//lay%input_files(k)%s
         end do
      end if
      fp = fp//new_line('a')//'overrides '//lay%overrides//new_line('a')//'version '//lay%version
   end function fingerprint

   !> The deck as parsed: "&group key=v1,v2 ... /" a line, strings quoted.
   function canonical_deck(deck) result(t)
      type(deck_t), intent(in) :: deck
      character(len=:), allocatable :: t
      integer :: g, e, v
      t = ''
      if (.not. allocated(deck%groups)) return
      do g = 1, size(deck%groups)
         associate (grp => deck%groups(g))
            t = t//'&'//grp%name
            if (allocated(grp%entries)) then
               do e = 1, size(grp%entries)
                  t = t//' '//grp%entries(e)%key//'='
                  do v = 1, size(grp%entries(e)%values)
                     if (v > 1) t = t//','
                     if (grp%entries(e)%quoted(v)) then
                        t = t//"'"//grp%entries(e)%values(v)%s//"'"
                     else
                        t = t//grp%entries(e)%values(v)%s
                     end if
                  end do
               end do
            end if
            t = t//' /'//new_line('a')
         end associate
      end do
   end function canonical_deck

   !> 16 hex digits (FNV-1a 64) of `text`.
   function digest(text) result(d)
      character(len=*), intent(in) :: text
      character(len=16) :: d
      character(kind=c_char) :: out(17)
      integer :: i
      call c_digest(text, int(len(text), c_long_long), out)
      do i = 1, 16
         d(i:i) = out(i)
      end do
   end function digest

   !> "0 pending, 1 ok, 2 failed".
   function status_list() result(s)
      character(len=:), allocatable :: s
      integer :: k
      s = ''
      do k = lbound(status_names, 1), ubound(status_names, 1)
         if (len(s) > 0) s = s//', '
         s = s//str(k)//' '//trim(status_names(k))
      end do
   end function status_list

   !> The overrides of run irun: --set first, then the run's sweep values.
   function run_overrides(opt, spec, irun, err) result(ovs)
      type(sweep_options_t), intent(in) :: opt
      type(sweep_spec_t), intent(in) :: spec
      integer, intent(in) :: irun
      type(error_t), allocatable, intent(out) :: err
      type(override_t), allocatable :: ovs(:)
      type(override_t), allocatable :: runs(:)
      integer :: n
      allocate (runs, source=spec%overrides(irun, err))   ! not `runs = ...`: gfortran 12 false -Wuninitialized
      n = size(opt%sets)
      allocate (ovs(n + size(runs)))
      ovs(1:n) = opt%sets
      ovs(n + 1:) = runs
   end function run_overrides

   !> Build the models of runs first+1, first+1+stride, ... (an input error stops the
   !> sweep before any file is touched): `bad` is the first that does not build (`err`
   !> says why; n_runs + 1 if none), `cost` each run's estimated cost (its steps for a
   !> fixed step, else its simulated time; 0 for the runs of other strides).
   subroutine validate_runs(opt, deck, spec, first, stride, cost, bad, err)
      type(sweep_options_t), intent(in) :: opt
      type(deck_t), intent(in) :: deck
      type(sweep_spec_t), intent(in) :: spec
      integer, intent(in) :: first, stride
      real(wp), allocatable, intent(out) :: cost(:)
      integer, intent(out) :: bad
      type(error_t), allocatable, intent(out) :: err
      type(model_t) :: model
      type(override_t), allocatable :: ovs(:)
      integer :: i
      allocate (cost(spec%n_runs))
      cost = 0.0_wp
      bad = spec%n_runs + 1
      do i = first + 1, spec%n_runs, stride
         if (signal_caught /= 0) return       ! (the caller stops every rank)
         if (allocated(ovs)) deallocate (ovs)
         allocate (ovs, source=run_overrides(opt, spec, i, err))   ! not `ovs = ...`: gfortran 12 false -Wuninitialized
         if (.not. allocated(err)) call prepare_model(deck, ovs, model, err)
         if (.not. allocated(err) .and. opt%strict) call strict_error(model%warnings, err)
         if (allocated(err)) then
            bad = i
            return
         end if
         cost(i) = model%run%t_end - model%run%t_start
         if (model%run%dt > 0.0_wp) cost(i) = cost(i)/model%run%dt
      end do
   end subroutine validate_runs

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

   subroutine open_file(m, opt, path, lay, err)
      type(master_t), intent(inout) :: m
      type(sweep_options_t), intent(in) :: opt
      character(len=*), intent(in) :: path
      type(sweep_layout_t), intent(in) :: lay
      type(error_t), allocatable, intent(out) :: err
      call m%file%open(path, lay, opt%resume, err)
   end subroutine open_file

   ! ------------------------------------------------------------------------------------------
   ! Rank 0
   ! ------------------------------------------------------------------------------------------

   subroutine master_loop(m, opt, deck, spec, lay, done)
      type(master_t), intent(inout), target :: m
      type(sweep_options_t), intent(in) :: opt
      type(deck_t), intent(in) :: deck
      type(sweep_spec_t), intent(in) :: spec
      type(sweep_layout_t), intent(in) :: lay
      real(wp), intent(in) :: done(:, :)
      type(sweep_record_t) :: rec
      type(chain_state_t) :: st
      integer :: irun, last
      integer(c_int) :: rc
      last = 0
      do
         if (m%n_ranks > 1) call m%service()
         irun = 0
         if (.not. allocated(m%err)) irun = m%take(last)
         if (irun > 0) then
            call run_one(opt, deck, spec, lay, done, irun, 0, rec, st, m)
            if (rec%status == status_pending) then
               m%interrupted = .true.         ! stopped by a signal: not recorded, made again on resume
            else
               call m%record(rec)
            end if
            last = irun
         else
            if (m%stopped == m%n_ranks - 1) exit
            rc = c_usleep(250_c_int)      ! nothing of its own to run: wait for the workers
         end if
      end do
      call comm_stop_polling()
   end subroutine master_loop

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
      integer :: src, irun
      call system_clock(self%last_service)
      allocate (buf(record_size(self%ne, self%nn)), rec%el(size(element_metric_names), self%ne), &
                rec%node(size(node_metric_names), self%nn))
      do
         call comm_poll_record(buf, found, src, rec%message)
         if (.not. found) exit
         call rec%unpack(buf)
         if (rec%irun > 0 .and. rec%status == status_pending) then
            self%interrupted = .true.         ! the worker's run was stopped by a signal
         else if (rec%irun > 0) then
            call self%record(rec)
         end if
         irun = 0
         if (.not. allocated(self%err)) irun = self%take(rec%irun)
         call comm_send_index(src, irun)
         if (irun == 0) self%stopped = self%stopped + 1
      end do
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

   ! ------------------------------------------------------------------------------------------
   ! Workers (ranks > 0)
   ! ------------------------------------------------------------------------------------------

   subroutine worker(opt, deck, spec, lay, done)
      type(sweep_options_t), intent(in) :: opt
      type(deck_t), intent(in) :: deck
      type(sweep_spec_t), intent(in) :: spec
      type(sweep_layout_t), intent(in) :: lay
      real(wp), intent(in) :: done(:, :)
      type(sweep_record_t) :: rec
      type(chain_state_t) :: st
      real(wp), allocatable :: buf(:)
      integer :: irun
      allocate (buf(record_size(size(lay%element_ids), size(lay%node_ids))))
      allocate (rec%el(size(element_metric_names), size(lay%element_ids)), &
                rec%node(size(node_metric_names), size(lay%node_ids)))
      rec%el = 0.0_wp; rec%node = 0.0_wp
      rec%irun = 0
      rec%message = ''
      call rec%pack(buf)
      call comm_send_record(buf, '')          ! "ready"
      do
         call comm_recv_index(irun)
         if (irun == 0) exit
         call run_one(opt, deck, spec, lay, done, irun, comm_rank(), rec, st)
         call rec%pack(buf)
         call comm_send_record(buf, rec%message)
      end do
   end subroutine worker

   ! ------------------------------------------------------------------------------------------
   ! One run
   ! ------------------------------------------------------------------------------------------

   !> Run irun and fill its record. `m` (rank 0 of an MPI sweep) is serviced meanwhile.
   !> `st` is this rank's last end state: a continuation run starts from it (its
   !> predecessor was made here, trainsim_continuation) and leaves its own in it; or,
   !> when its predecessor was made before a resume, from that run's column of `done`.
   subroutine run_one(opt, deck, spec, lay, done, irun, rank, rec, st, m)
      type(sweep_options_t), intent(in) :: opt
      type(deck_t), intent(in) :: deck
      type(sweep_spec_t), intent(in) :: spec
      type(sweep_layout_t), intent(in) :: lay
      real(wp), intent(in) :: done(:, :)
      integer, intent(in) :: irun, rank
      type(sweep_record_t), intent(inout) :: rec
      type(chain_state_t), intent(inout) :: st
      type(master_t), intent(inout), target, optional :: m
      type(model_t) :: model, before
      type(sweep_sink_t) :: sink
      type(run_result_t) :: res
      type(error_t), allocatable :: err
      type(override_t), allocatable :: ovs(:)
      integer(i8) :: c0, c1, rate
      integer :: k, ne, nn
      real(wp) :: nan

      call system_clock(c0, rate)
      ne = size(lay%element_ids); nn = size(lay%node_ids)
      nan = transfer(int(z'7FF8000000000000', kind=8), nan)
      if (allocated(rec%el)) deallocate (rec%el)
      if (allocated(rec%node)) deallocate (rec%node)
      allocate (rec%el(size(element_metric_names), ne), rec%node(size(node_metric_names), nn))
      rec%el = nan; rec%node = nan; rec%run_values = nan
      rec%irun = irun
      rec%rank = rank
      ovs = run_overrides(opt, spec, irun, err)
      if (.not. allocated(err)) call prepare_model(deck, ovs, model, err)
      if (.not. allocated(err) .and. spec%prev(irun) > 0) then
         if (st%irun /= spec%prev(irun) .and. size(done) > 0) then
            if (done(1, spec%prev(irun)) > 0.0_wp) then
               st%irun = spec%prev(irun)
               st%theta = done(2:1 + nn, st%irun)
               st%omega = done(2 + nn:1 + 2*nn, st%irun)
               st%omega0 = done(2 + 2*nn:1 + 3*nn, st%irun)
            end if
         end if
         if (st%irun == spec%prev(irun)) then
            ! the nominal speeds of the run before, from the deck and its values
            ovs = run_overrides(opt, spec, spec%prev(irun), err)
            if (.not. allocated(err)) call prepare_model(deck, ovs, before, err)
            if (.not. allocated(err)) call start_from(model, st, nominal_speeds(before))
         else
            call fatal_error(err, 'internal error: continuation run '//str(irun)//' given to a rank without the '// &
                             'end state of run '//str(spec%prev(irun)), err_input)
         end if
      end if
      st%irun = 0
      if (.not. allocated(err)) then
         model%run%output = ''
         sink%t_metrics = model%run%t_start + model%run%settle_time
         if (model%run%settle_tol > 0.0_wp) sink%t_metrics = huge(1.0_wp)   ! until settled (metrics_from)
         if (present(m)) then
            if (m%n_ranks > 1) then
               sink%master => m
               sink%poll_ticks = max(1_i8, rate/1000_i8)
            end if
         end if
         call simulate(model, sink, res, err)
      end if
      if (allocated(err)) then
         rec%status = status_failed
         if (err%code == err_interrupted) rec%status = status_pending   ! not made: made again on resume
         rec%message = err%message
      else
         rec%status = status_ok
         rec%message = ''
         do k = 1, ne
            associate (e => res%el(k))
               rec%el(:, k) = [e%force_min, e%force_max, e%torque_min, e%torque_max, e%disp_min, e%disp_max, &
                               real(e%impacts, wp), real(e%separations, wp), real(e%zone_changes, wp), &
                               e%max_approach_velocity, e%max_peak_force, e%time_out_of_contact, e%p2p_range, &
                               e%p2p_mean, real(e%p2p_swings, wp)]
            end associate
         end do
         if (allocated(sink%wmin)) then
            rec%node(1, :) = sink%wmin
            rec%node(2, :) = sink%wmax
         end if
         call save_end_state(model, res%t_final, res%y_final, irun, st)
         rec%node(3, :) = st%theta
         rec%node(4, :) = st%omega
         rec%node(5, :) = st%omega0
         rec%run_values(1) = real(res%stats%steps, wp)
         rec%run_values(2) = real(res%stats%rhs_evals, wp)
         rec%run_values(3) = real(res%stats%events, wp)
         rec%run_values(4) = 0.0_wp
         if (res%energy_scale > 0.0_wp) rec%run_values(4) = res%energy_residual_max/res%energy_scale
         select case (res%stats%settle_status)
         case (1, 3); rec%run_values(5) = 1.0_wp
         case (2, 4); rec%run_values(5) = 0.0_wp
         case default; rec%run_values(5) = -1.0_wp
         end select
         rec%run_values(6) = real(res%stats%settle_periods, wp)
         rec%run_values(7) = real(res%stats%settle_k, wp)
      end if
      call system_clock(c1)
      rec%wall = real(c1 - c0, wp)/real(rate, wp)
   end subroutine run_one

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
end module trainsim_sweep
