!> `trainsim sweep`: the runs of a deck's &sweep groups, serially or on MPI ranks with
!> dynamic load balancing, recorded in one HDF5 sweep file as each run completes.
!>
!> Load balancing (docs/sweeps.md): rank 0 hands out run indices one at a time, on
!> request, the longest estimated run first (steps = (t_end - t_start)/dt, so that the
!> last runs handed out are short and the ranks finish together). Each worker sends the
!> record of its finished run, which is also its request for the next index. Rank 0
!> answers every worker's first request before it takes a run of its own and takes
!> one right after the last, then computes runs too; while it does, its sink looks for a worker's record (one MPI_Test
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
   use trainsim_deck, only: deck_t, deck_group_t, read_deck, canonical_deck
   use trainsim_model, only: model_t
   use trainsim_overrides, only: override_t, split_sweep_groups
   use trainsim_prepare, only: prepare_model
   use trainsim_sweep_spec, only: sweep_spec_t, read_sweep_spec
   use trainsim_sweep_file, only: sweep_layout_t, sweep_record_t, element_metric_names, &
      node_metric_names, status_pending, status_ok, status_failed, record_size, status_names
   use trainsim_sweep_layout, only: element_record
   use trainsim_sink, only: run_meta_t
   use trainsim_observer, only: run_result_t, make_meta
   use trainsim_simulate, only: simulate
   use trainsim_continuation, only: chain_state_t, save_end_state, start_from, nominal_speeds
   use trainsim_sweep_master, only: master_t, sweep_sink_t, longest_first, setup_chains, break_resumed_chains, &
      drain, elapsed, c_usleep
   use trainsim_mpi, only: comm_init, comm_finalize, comm_rank, comm_size, comm_send_record, &
      comm_poll_record, comm_stop_polling, comm_send_index, comm_recv_index, comm_bcast_int, comm_bcast_reals, &
      comm_sum_reals, comm_min_int
   implicit none
   private

   public :: sweep_options_t, sweep_summary_t, run_sweep, finish_sweep, default_sweep_path
   public :: fingerprint

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

   interface
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
         if (m%n_ready < m%n_ranks - 1) then
            ! every worker's "ready" is answered before rank 0 takes a run of its own, and
            ! rank 0 takes one right after the last (D-110)
            rc = c_usleep(250_c_int)
            cycle
         end if
         irun = 0
         if (.not. allocated(m%err)) irun = m%take(last)
         m%own_tried = .true.                 ! (the workers' waiting requests answered next: D-137)
         if (irun > 0) then
            m%own_taken = .true.
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
      integer :: ne, nn
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
         rec%el = element_record(res)
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
end module trainsim_sweep
