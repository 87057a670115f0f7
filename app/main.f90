!> trainsim: drive-train simulation with clearances (successor to TRAIN, Cook 1989).
program trainsim_main
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use, intrinsic :: iso_c_binding, only: c_int
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, err_numeric, err_interrupted
   use trainsim_interrupt, only: install_interrupt_handlers, interrupt_signal, signal_name
   use trainsim_strings, only: str
   use trainsim_version, only: version_string
   use trainsim_deck, only: deck_t, read_deck
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_modes, only: modes_t, compute_modes, rk4_stability_limit
   use trainsim_simulate, only: simulate
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_hdf5, only: hdf5_sink_t, hdf5_library_stuck
   use trainsim_report, only: print_summary, print_modes, print_parameters
   implicit none

   character(len=:), allocatable :: cmd, deck_path, out_path
   integer :: nargs, i
   logical :: no_output

   interface
      !> POSIX _exit(2): ends the process without exit handlers (see quit).
      subroutine c_exit_now(status) bind(C, name='_exit')
         import :: c_int
         integer(c_int), value :: status
      end subroutine c_exit_now
   end interface

   nargs = command_argument_count()
   if (nargs == 0) then
      call usage(error_unit)
      call quit(2)
   end if
   cmd = arg(1)
   select case (cmd)
   case ('-h', '--help', 'help')
      call usage(output_unit)
      call quit(0)
   case ('-V', '--version', 'version')
      write (output_unit, '(a)') 'trainsim '//version_string
      call quit(0)
   case ('run', 'modes')
   case default
      write (error_unit, '(a)') "trainsim: error: unknown command '"//cmd//"' (try trainsim --help)"
      call quit(2)
   end select

   deck_path = ''
   out_path = ''
   no_output = .false.
   i = 2
   do while (i <= nargs)
      select case (arg(i))
      case ('-o', '--output')
         if (i == nargs .or. cmd /= 'run') then
            write (error_unit, '(a)') 'trainsim: error: option -o needs a file name (and only applies to run)'
            call quit(2)
         end if
         out_path = arg(i + 1)
         if (len(out_path) == 0) then
            write (error_unit, '(a)') "trainsim: error: option -o got an empty file name (use -o - or "// &
               "--no-output to write no history file)"
            call quit(2)
         end if
         no_output = out_path == '-'
         i = i + 1
      case ('--no-output')
         if (cmd /= 'run') then
            write (error_unit, '(a)') 'trainsim: error: option --no-output only applies to run'
            call quit(2)
         end if
         no_output = .true.
      case default
         if (len(deck_path) > 0 .or. index(arg(i), '-') == 1) then
            write (error_unit, '(a)') "trainsim: error: unexpected argument '"//arg(i)//"' (try trainsim --help)"
            call quit(2)
         end if
         deck_path = arg(i)
      end select
      i = i + 1
   end do
   if (len(deck_path) == 0) then
      write (error_unit, '(a)') 'trainsim: error: '//cmd//' needs a deck file (try trainsim --help)'
      call quit(2)
   end if
   if (cmd == 'run') then
      call install_interrupt_handlers()
      call do_run(deck_path, out_path, no_output)
   else
      call do_modes(deck_path)
   end if

contains

   function arg(k) result(a)
      integer, intent(in) :: k
      character(len=:), allocatable :: a
      integer :: n
      call get_command_argument(k, length=n)
      allocate (character(len=n) :: a)
      call get_command_argument(k, a)
   end function arg

   subroutine usage(unit)
      integer, intent(in) :: unit
      write (unit, '(a)') 'trainsim '//version_string//' - drive trains with clearances (successor to TRAIN, Cook 1989)', &
         '', &
         'usage:', &
         '  trainsim run DECK [-o FILE]   integrate the train in DECK; write the HDF5 history', &
         '                                (to FILE, else to the deck''s &run output)', &
         '  trainsim run DECK --no-output   (or -o -) integrate and print the summary, write no file', &
         '  trainsim modes DECK           natural frequencies and mode shapes of the linearised train', &
         '  trainsim --help | --version', &
         '', &
         'exit status: 0 success, 1 the run failed (numerics), 2 bad input or file,', &
         '             130 / 143 interrupted by SIGINT / SIGTERM (no history written)', &
         'deck format: docs/deck.md'
   end subroutine usage

   !> End the program with exit status `code`, output flushed. When HDF5 holds a file
   !> it could not close (a full disk), its exit handler would crash: end without it.
   subroutine quit(code)
      integer, intent(in) :: code
      flush (output_unit)
      flush (error_unit)
      if (hdf5_library_stuck()) call c_exit_now(int(code, c_int))
      if (code == 0) stop
      stop code, quiet=.true.
   end subroutine quit

   subroutine fail(err)
      type(error_t), intent(in) :: err
      integer :: sig
      if (err%code == err_interrupted) then
         sig = interrupt_signal()
         write (error_unit, '(a)') 'trainsim: '//err%message//' by '//signal_name(sig)//'; no history written'
         call quit(128 + sig)
      end if
      write (error_unit, '(a)') 'trainsim: '//err%message
      if (err%code == err_numeric) call quit(1)
      call quit(2)
   end subroutine fail

   subroutine load(path, model)
      character(len=*), intent(in) :: path
      type(model_t), intent(out) :: model
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      call read_deck(path, deck, err)
      if (allocated(err)) call fail(err)
      call build_model(deck, model, err)
      if (allocated(err)) call fail(err)
   end subroutine load

   subroutine do_modes(path)
      character(len=*), intent(in) :: path
      type(model_t) :: model
      type(modes_t) :: modes
      type(error_t), allocatable :: err
      call load(path, model)
      call compute_modes(model, modes, err)
      if (allocated(err)) call fail(err)
      call print_modes(model, modes, output_unit)
      if (modes%omega_max > 0.0_wp) write (output_unit, '(a,es11.4,a)') &
         'RK4 stability limit of the highest mode: dt < ', rk4_stability_limit/modes%omega_max, ' s'
   end subroutine do_modes

   subroutine do_run(path, out, no_output)
      character(len=*), intent(in) :: path, out
      logical, intent(in) :: no_output   !< -o - or --no-output: no history file
      type(model_t) :: model
      type(modes_t) :: modes
      type(error_t), allocatable :: err
      type(run_result_t) :: res
      type(hdf5_sink_t) :: h5
      type(null_sink_t) :: none
      real(wp) :: dt_safe
      logical :: warned

      call load(path, model)
      if (len(out) > 0) model%run%output = out
      if (no_output) model%run%output = ''
      write (output_unit, '(a)') 'trainsim '//version_string//': '//path//'  ('//model%title//')'
      call print_parameters(model, output_unit)
      flush (output_unit)   ! kept even if the run is interrupted or crashes
      if (model%run%integrator(1:3) == 'rk4') then
         warned = .false.
         call compute_modes(model, modes, err)
         if (.not. allocated(err)) then
            if (modes%omega_max > 0.0_wp) then
               dt_safe = rk4_stability_limit/modes%omega_max
               if (model%run%dt > dt_safe) then
                  write (error_unit, '(a)') 'trainsim: warning: dt = '// &
                     str(model%run%dt)//' s exceeds the RK4 stability limit of the highest linearised mode ('// &
                     str(modes%freq_hz(modes%n), 5)//' Hz): dt < '//str(dt_safe, 4)//' s would be safe; the run goes '// &
                     'on and is only trustworthy if that mode is not excited'
                  warned = .true.
               end if
            end if
         end if
         if (allocated(err)) deallocate (err)
         ! a clearance open at the start hides its contact mode from the check above
         if (.not. warned) then
            call compute_modes(model, modes, err, closed=.true.)
            if (.not. allocated(err)) then
               if (modes%omega_max > 0.0_wp) then
                  dt_safe = rk4_stability_limit/modes%omega_max
                  if (model%run%dt > dt_safe) write (error_unit, '(a)') 'trainsim: warning: dt = '// &
                     str(model%run%dt)//' s exceeds the RK4 stability limit of the highest mode with every '// &
                     'clearance closed ('//str(modes%freq_hz(modes%n), 5)//' Hz): once contacts close, dt < '// &
                     str(dt_safe, 4)//' s would be safe'
               end if
            end if
            if (allocated(err)) deallocate (err)
         end if
      end if
      if (len(model%run%output) > 0) then
         h5%path = model%run%output
         call simulate(model, h5, res, err)
      else
         call simulate(model, none, res, err)
      end if
      if (allocated(err)) call fail(err)
      call print_summary(model, res, output_unit)
      if (len(model%run%output) > 0) write (output_unit, '(a)') 'history written to '//model%run%output
      flush (output_unit)
   end subroutine do_run
end program trainsim_main
