!> trainsim: drive-train simulation with clearances (successor to TRAIN, Cook 1989).
program trainsim_main
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use, intrinsic :: iso_c_binding, only: c_int, c_char, c_long, c_size_t, c_null_char
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, err_numeric, err_interrupted, err_input
   use trainsim_interrupt, only: install_interrupt_handlers, interrupt_signal, signal_name
   use trainsim_strings, only: str
   use trainsim_version, only: version_string, version_full
   use trainsim_deck, only: deck_t, deck_group_t, read_deck, parse_real
   use trainsim_model, only: model_t
   use trainsim_modes, only: modes_t, compute_modes, rk4_dt_limit
   use trainsim_element, only: lin_state_t, lin_start, lin_stiffest, lin_contact_closed, &
                               lin_zone_initial, lin_zone_single, lin_zone_stiffest
   use trainsim_simulate, only: simulate, check_fixed_step
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_hdf5, only: hdf5_sink_t, hdf5_library_stuck
   use trainsim_report, only: print_summary, print_modes, print_parameters
   use trainsim_progress, only: progress_t
   use trainsim_overrides, only: override_t, parse_set_argument, split_sweep_groups
   use trainsim_prepare, only: prepare_model
   use trainsim_preload, only: preload_info_t
   use trainsim_sweep, only: sweep_options_t, sweep_summary_t, run_sweep, finish_sweep
   use trainsim_gear_calc, only: gear_input_t, gear_result_t, gear_calc, gear_report, &
                                 key_input_t, key_result_t, key_calc, key_report, key_max_points
   use trainsim_units, only: units_t, make_units
   use trainsim_contact, only: fit_tight, fit_loose, fit_average
   use trainsim_describe, only: write_description
   implicit none

   character(len=:), allocatable :: cmd, deck_path, out_path
   integer :: nargs, i
   type(lin_state_t) :: modes_state   ! trainsim modes: --closed, --zone, --stiffest
   type(override_t), allocatable :: sets(:)   ! --set TARGET.KEY=VALUE, in order
   type(sweep_options_t) :: sweep_opt         ! trainsim sweep: --resume, --progress
   logical :: no_output
   logical :: strict = .false.                ! --strict: plausibility warnings are errors

   interface
      !> POSIX _exit(2): ends the process without exit handlers (see quit).
      subroutine c_exit_now(status) bind(C, name='_exit')
         import :: c_int
         integer(c_int), value :: status
      end subroutine c_exit_now
      !> POSIX readlink(2) (ssize_t is a C long on the 64-bit Linux targets).
      !> POSIX getpid(2), for a temporary file name of this process.
      function c_getpid() bind(C, name='getpid') result(pid)
         import :: c_int
         integer(c_int) :: pid
      end function c_getpid
      function c_readlink(path, buf, n) bind(C, name='readlink') result(r)
         import :: c_char, c_long, c_size_t
         character(kind=c_char), intent(in) :: path(*)
         character(kind=c_char), intent(out) :: buf(*)
         integer(c_size_t), value :: n
         integer(c_long) :: r
      end function c_readlink
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
      write (output_unit, '(a)') 'trainsim '//version_full()
      call quit(0)
   case ('run', 'modes', 'sweep')
   case ('gear', 'key')
      if (nargs >= 2) then
         select case (arg(2))
         case ('-h', '--help')
            call command_usage(cmd, output_unit)
            call quit(0)
         end select
      end if
      if (cmd == 'gear') call do_gear()
      if (cmd == 'key') call do_key()
   case ('export', 'plot')
      call do_script()
   case ('diagram')
      call do_diagram()
   case default
      write (error_unit, '(a)') "trainsim: error: unknown command '"//cmd//"' (try trainsim --help)"
      call quit(2)
   end select

   deck_path = ''
   out_path = ''
   allocate (sets(0))
   no_output = .false.
   i = 2
   do while (i <= nargs)
      select case (arg(i))
      case ('-h', '--help')
         call command_usage(cmd, output_unit)
         call quit(0)
      case ('-o', '--output')
         if (i == nargs .or. cmd == 'modes') then
            write (error_unit, '(a)') 'trainsim: error: option -o needs a file name (and only applies to run and sweep)'
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
      case ('--set')
         call add_set(i)
         i = i + 1
      case ('--resume', '--progress')
         call sweep_option(i)
      case ('--strict')   ! plausibility warnings are errors (trainsim_plausibility)
         if (cmd /= 'run' .and. cmd /= 'sweep') then
            write (error_unit, '(a)') 'trainsim: error: option --strict only applies to run and sweep'
            call quit(2)
         end if
         strict = .true.
         sweep_opt%strict = .true.
      case ('--preload')   ! = --set run.initial_state=preload (trainsim_preload)
         if (cmd /= 'modes') then
            write (error_unit, '(a)') 'trainsim: error: option --preload only applies to modes '// &
               '(for run and sweep: &run initial_state = ''preload'')'
            call quit(2)
         end if
         call add_preload()
      case ('--closed', '--stiffest', '--zone')
         if (cmd /= 'modes') then
            write (error_unit, '(a)') 'trainsim: error: option '//arg(i)//' only applies to modes (try trainsim --help)'
            call quit(2)
         end if
         if (arg(i) == '--closed') then
            modes_state%contact = lin_contact_closed
         else if (arg(i) == '--stiffest') then
            modes_state%contact = lin_contact_closed
            modes_state%zone = lin_zone_stiffest
         else
            if (i == nargs) then
               write (error_unit, '(a)') 'trainsim: error: option --zone needs single, two-pair or initial'
               call quit(2)
            end if
            select case (arg(i + 1))
            case ('single'); modes_state%zone = lin_zone_single
            case ('two-pair'); modes_state%zone = lin_zone_stiffest
            case ('initial'); modes_state%zone = lin_zone_initial
            case default
               write (error_unit, '(a)') "trainsim: error: unknown --zone '"//arg(i + 1)//"'; valid: single, two-pair, initial"
               call quit(2)
            end select
            i = i + 1
         end if
      case ('--no-output')
         if (cmd /= 'run') then
            write (error_unit, '(a)') 'trainsim: error: option --no-output only applies to run'
            call quit(2)
         end if
         no_output = .true.
      case default
         if (index(arg(i), '-') == 1 .or. len(deck_path) > 0) then
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
   else if (cmd == 'sweep') then
      call install_interrupt_handlers()
      call do_sweep(deck_path, out_path)
   else
      call do_modes(deck_path, modes_state)
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

   !> --set TARGET.KEY=VALUE at argument k (the value is argument k+1).
   subroutine add_set(k)
      integer, intent(in) :: k
      type(override_t) :: ov
      type(error_t), allocatable :: err
      if (k == nargs) then
         write (error_unit, '(a)') 'trainsim: error: option --set needs TARGET.KEY=VALUE (e.g. mesh.half_backlash=2e-4)'
         call quit(2)
      end if
      call parse_set_argument(arg(k + 1), ov, err)
      if (allocated(err)) call fail(err)
      sets = [sets, ov]
   end subroutine add_set

   !> --preload of trainsim modes: the override run.initial_state=preload.
   subroutine add_preload()
      type(override_t) :: ov
      type(error_t), allocatable :: err
      call parse_set_argument('run.initial_state=preload', ov, err)
      if (allocated(err)) call fail(err)
      ov%origin = '--preload'
      sets = [sets, ov]
   end subroutine add_preload

   !> trainsim sweep's own options at argument k (advances k past a value).
   subroutine sweep_option(k)
      integer, intent(inout) :: k
      integer :: ios
      character(len=:), allocatable :: value
      if (cmd /= 'sweep') then
         write (error_unit, '(a)') 'trainsim: error: option '//arg(k)//' only applies to sweep (try trainsim --help)'
         call quit(2)
      end if
      if (arg(k) == '--resume') then
         sweep_opt%resume = .true.
         return
      end if
      ios = 1
      if (k < nargs) then
         value = trim(adjustl(arg(k + 1)))
         call parse_real(value, sweep_opt%progress_interval, ios)   ! no list-directed READ: 1e999 would trap
      end if
      if (ios /= 0 .or. .not. sweep_opt%progress_interval >= 0.0_wp) then
         write (error_unit, '(a)') 'trainsim: error: option --progress needs the seconds between progress lines (>= 0)'
         call quit(2)
      end if
      k = k + 1
   end subroutine sweep_option

   !> trainsim sweep: every run of the deck's &sweep groups into one HDF5 sweep file.
   subroutine do_sweep(path, out)
      character(len=*), intent(in) :: path, out
      type(sweep_summary_t) :: summary
      type(error_t), allocatable :: err
      if (out == '-') then
         write (error_unit, '(a)') 'trainsim: error: -o - (no file) does not apply to sweep: a sweep records '// &
            'and resumes its runs in a file; name one with -o FILE'
         call quit(2)
      end if
      sweep_opt%deck_path = path
      sweep_opt%out_path = out
      sweep_opt%sets = sets
      sweep_opt%progress_unit = error_unit
      call run_sweep(sweep_opt, summary, err)
      ! other ranks exit 0: mpirun's status is rank 0's, and a rank that exits non-zero
      ! first makes mpirun kill rank 0 before it has printed why
      if (.not. summary%root) call quit(0)
      if (allocated(err)) then
         if (err%code == err_interrupted) then    ! the runs made are recorded: say so, not "no history"
            write (error_unit, '(a)') 'trainsim: '//err%message
            call quit(summary%exit_code)
         end if
         call fail(err)
      end if
      write (output_unit, '(a)') 'sweep: '//str(summary%n_now)//' run(s) made, '//str(summary%n_ok)//' of '// &
         str(summary%n_runs)//' ok, '//str(summary%n_failed)//' failed; results in '//summary%path
      call quit(summary%exit_code)
   end subroutine do_sweep

   subroutine usage(unit)
      integer, intent(in) :: unit
      write (unit, '(a)') 'trainsim '//version_string//' - drive trains with clearances (successor to TRAIN, Cook 1989)', &
         '', &
         'usage:', &
         '  trainsim run DECK [-o FILE | --no-output] [--set TARGET.KEY=VALUE ...] [--strict]', &
         '                                integrate the train in DECK; write the HDF5 history', &
         '                                (to FILE, else to the deck''s &run output). --set changes a', &
         '                                deck value (TARGET: node/element id, run, or GROUP#K) or a', &
         '                                derived one (GEAR.mesh_frequency, .settle_cycles, .measure_cycles,', &
         '                                .settle_max_cycles);', &
         '                                --no-output (or -o -): no history file, even if the deck names one;', &
         '                                --strict: the deck''s plausibility warnings (unit slips) are errors', &
         '  trainsim sweep DECK [-o FILE] [--set ...] [--resume] [--progress S] [--strict]', &
         '                                every run of the deck''s &sweep groups (serial, or under', &
         '                                mpirun -np N) into one HDF5 sweep file (default DECK_sweep.h5);', &
         '                                re-running it (or --resume) completes a sweep that was stopped;', &
         '                                progress on stderr every S seconds (default 5; 0: every run)', &
         '  trainsim modes DECK [--closed] [--zone single|two-pair|initial] [--stiffest] [--preload]', &
         '                                natural frequencies and mode shapes of the linearised train,', &
         '                                and its RK4 step limit. Linearised as the run starts, or:', &
         '                                --closed    every clearance closed (contact stiffness counts)', &
         '                                --zone Z    every spur gear in its single-pair or two-pair', &
         '                                            zone (helical: shortest/longest contact lines),', &
         '                                            or the zone it starts in (initial, the default)', &
         '                                --stiffest  = --closed --zone two-pair: the stiffest state a', &
         '                                            run can reach (what `run` checks dt against)', &
         '                                --preload   about the static wind-up under the loads (contacts', &
         '                                            closed on their loaded faces; its angles printed)', &
         '  trainsim gear --teeth N1 [N2] (--diametral-pitch P | --module M) --face-width F [...]', &
         '                                spur gear constants (App. E) and a deck fragment', &
         '  trainsim key --diameter D --key-length L [--fit tight|loose|average|all] [...]', &
         '                                keyed-joint stiffness curve (Ch. IV) and a deck fragment', &
         '  trainsim export FILE.h5 QUANTITY ... | --events | --metrics | --summary json | --spectrum', &
         '                                CSV/JSON of a history (scripts/trainsim_export.py --help)', &
         '  trainsim plot FILE.h5 Y ... [--x X] | --te GEAR | --te-spectrum GEAR | --overview [ID]  -o OUT', &
         '                                figures of a history or a sweep (scripts/trainsim_plot.py --help)', &
         '  trainsim diagram DECK -o OUT.svg|png|pdf [--json FILE] [--set ...]', &
         '                                the train as a block diagram, from the deck alone', &
         '  trainsim --help | --version', &
         '', &
         'exit status: 0 success, 1 the run (or a run of the sweep) failed (numerics), 2 bad input or file,', &
         '             130 / 143 interrupted by SIGINT / SIGTERM (a run keeps its history so far, marked', &
         '             interrupted)', &
         'deck format: man trainsim; docs/deck.md (installed in share/doc/trainsim)'
   end subroutine usage

   !> `trainsim CMD --help`: the usage of one command.
   subroutine command_usage(cmd, unit)
      character(len=*), intent(in) :: cmd
      integer, intent(in) :: unit
      select case (cmd)
      case ('run')
         write (unit, '(a)') 'usage: trainsim run DECK [-o FILE | --no-output] [--set TARGET.KEY=VALUE ...]', '', &
            'Integrate the train in DECK from t_start to t_end of its &run group. Prints the', &
            'element parameters as used, a warning if dt exceeds the RK4 stability limit, and', &
            'a summary (steps, events, energy balance, element extremes, final state).', '', &
            '  -o, --output FILE  write the HDF5 history to FILE (else to &run output, if set);', &
            '                     only a regular file is replaced', &
            '  --no-output, -o -  write no history file, even if the deck names one', &
            '  --set T.KEY=VALUE  change a deck value: T is a node or element id, run, or GROUP#K', &
            '                     (e.g. mesh.half_backlash=2e-4, run.t_end=0.1, load#2.value=-500),', &
            '                     or a derived one (GEAR.mesh_frequency, .settle_cycles, .measure_cycles,', &
            '                     .settle_max_cycles)', &
            '  -h, --help         this text', '', &
            'A run longer than 2 s prints its progress on stderr: one line rewritten in place on a', &
            'terminal, a line every 10 s otherwise (TRAINSIM_PROGRESS_INTERVAL=S: every S seconds).', '', &
            'exit status: 0 success, 1 the run failed (numerics), 2 bad input or file,', &
            '             130 / 143 interrupted by SIGINT / SIGTERM: the history up to the last output', &
            '             time reached is kept, marked interrupted (root attribute status)'
      case ('sweep')
         write (unit, '(a)') 'usage: trainsim sweep DECK [-o FILE] [--set TARGET.KEY=VALUE ...] [--resume] [--progress S]', '', &
            'Every run of the &sweep groups of DECK, serially or under mpirun -np N (rank 0 hands', &
            'out runs on request), into one HDF5 sweep file (default DECK_sweep.h5). Running the', &
            'same command again (or --resume) makes only the runs still missing.', '', &
            '  -o, --output FILE  the sweep file', &
            '  --set T.KEY=VALUE  as for run, applied to every run', &
            '  --resume           complete the sweep in FILE (the default when FILE holds this sweep)', &
            '  --progress S       a progress line on stderr every S seconds (0: every run)', &
            '  -h, --help         this text', '', &
            'exit status: 0 every run ok, 1 some run failed (recorded in the file), 2 bad input or file', &
            '             (or FILE written by another sweep now), 130 / 143 stopped by SIGINT / SIGTERM', &
            '             (the runs made are recorded; the same command resumes)'
      case ('modes')
         write (unit, '(a)') 'usage: trainsim modes DECK [--closed] [--zone single|two-pair|initial] [--stiffest]', '', &
            'Natural frequencies and mode shapes of the linearised train, and its RK4 step limit.', &
            'Linearised as the run starts, or:', '', &
            '  --closed    every clearance closed (contact stiffness counts)', &
            '  --zone Z    every spur gear in its single-pair or two-pair zone (helical: shortest/', &
            '              longest contact lines), or the zone it starts in (initial, the default)', &
            '  --stiffest  = --closed --zone two-pair: the stiffest state a run can reach', &
            '  -h, --help  this text', '', &
            'exit status: 0 success, 2 bad input or file'
      case ('gear')
         write (unit, '(a)') 'usage: trainsim gear --teeth N1 [N2] (--diametral-pitch P | --module M) --face-width F [...]', '', &
            'Spur gear constants from the geometry (App. E, eqs. 3.9 and 3.12): radii, addendum, length of', &
            'action, base pitch, contact ratio, approach angle, gear ratio, pitch-disk inertias, mesh', &
            'stiffness, and a deck fragment in TRAIN''s seven constants. Implausible geometry (a unit slip)', &
            'is an error that names the likely slip.', '', &
            '  --teeth N1 [N2]            teeth of the driver (and the driven gear)', &
            '  --diametral-pitch P        1/in; or --module M in mm', &
            '  --pressure-angle DEG       default 20', &
            '  --face-width F             face width (in; m with --units si)', &
            '  --backlash B               total backlash along the line of action (in; m with --units si)', &
            '  --youngs-modulus E, --density RHO   material (steel by default)', &
            '  --stiffness-per-width KW, --stiffness K   the mesh stiffness instead of eq. 3.9', &
            '  --frequency HZ             the inertias that put each gear at HZ on the mesh', &
            '  --approach-velocity V      Goldsmith''s e and the damping D of eq. 3.12 at V', &
            '  --id ID, --units U         the fragment''s element id (its nodes ID_driver, ID_driven); in-lbf-s or si', &
            '  -h, --help                 this text', '', &
            'exit status: 0 success, 2 bad input'
      case ('diagram')
         write (unit, '(a)') 'usage: trainsim diagram DECK -o OUT.svg|png|pdf [--json FILE] [--set TARGET.KEY=VALUE ...]', '', &
            'The train of DECK as a block diagram: nodes as blocks (kind, inertia), elements as', &
            'connectors (type, ratio, backlash or clearance, stiffness), loads, prescribed speeds and', &
            'motor voltages as arrows; every unconnected part is drawn as its own piece. The deck is', &
            'read and built as `run` does (a bad deck: exit 2, the same message); nothing is run.', &
            'Drawn by scripts/trainsim_diagram.py with matplotlib (no Graphviz needed).', '', &
            '  -o, --output OUT   the drawing; the format follows the extension', &
            '  --json FILE        also write the description the drawing is made from (- for stdout);', &
            '                     without -o only the description is written', &
            '  --set T.KEY=VALUE  as for run', &
            '  -h, --help         this text', '', &
            'exit status: 0 success, 2 bad input or file'
      case ('key')
         write (unit, '(a)') 'usage: trainsim key --diameter D --key-length L [--fit tight|loose|average|all] [...]', '', &
            'The keyed-joint stiffness curve of Ch. IV (eqs. 4.35-4.37): torque, key force, lineal and', &
            'angular stiffness for each fit, and a deck fragment.', '', &
            '  --diameter D               shaft diameter', &
            '  --key-length L             key length', &
            '  --key-width W, --key-height H, --clearance C   key section and play', &
            '  --fit F                    tight, loose, average or all (default)', &
            '  --torque-max T, --points N the range and resolution of the table', &
            '  --id ID, --units U         the fragment''s element id; in-lbf-s (default) or si', &
            '  -h, --help                 this text', '', &
            'exit status: 0 success, 2 bad input'
      end select
   end subroutine command_usage

   !> End the program with exit status `code`, output flushed. When HDF5 holds a file
   !> it could not close (a full disk), its exit handler would crash: end without it.
   subroutine quit(code)
      integer, intent(in) :: code
      flush (output_unit)
      flush (error_unit)
      call finish_sweep()     ! after the outcome is out (a stopping mpirun never completes it)
      if (hdf5_library_stuck()) call c_exit_now(int(code, c_int))
      if (code == 0) stop
      stop code, quiet=.true.
   end subroutine quit

   subroutine fail(err_in)
      type(error_t), intent(in) :: err_in
      type(error_t) :: err
      integer :: sig
      err = err_in
      ! an input refusal names where the bad input is: a deck or table line, a --set
      ! argument; one about the deck as a whole names at least the deck file
      if (allocated(deck_path)) then
         if (err%code == err_input .and. len(deck_path) > 0 .and. .not. located(err%message)) &
            err%message = deck_path//': error: '//err%message
      end if
      if (err%code == err_interrupted) then
         sig = interrupt_signal()
         write (error_unit, '(a)') 'trainsim: '//err%message//' by '//signal_name(sig)//'; no history written'
         call quit(128 + sig)
      end if
      write (error_unit, '(a)') 'trainsim: '//err%message
      if (err%code == err_numeric) call quit(1)
      call quit(2)
   end subroutine fail

   !> True if `msg` starts with a place: "FILE:LINE:", "--set ...", "set '...'", the deck
   !> file, or names a file of its own ("sweep file ...", "cannot ..."), or is not about
   !> the deck ("error: ..." from the MPI start-up).
   logical function located(msg)
      character(len=*), intent(in) :: msg
      integer :: p1, p2
      located = .true.
      if (index(msg, '--set ') == 1 .or. index(msg, "set '") == 1 .or. index(msg, deck_path//':') == 1 .or. &
          index(msg, 'sweep file ') == 1 .or. index(msg, 'cannot ') == 1 .or. index(msg, 'error: ') == 1) return
      p1 = index(msg, ':')
      if (p1 > 1) then
         p2 = index(msg(p1 + 1:), ':')
         if (p2 > 1) then
            if (verify(msg(p1 + 1:p1 + p2 - 1), '-0123456789') == 0 .and. index(msg(1:p1), ' ') == 0) return
         end if
      end if
      located = .false.
   end function located

   subroutine load(path, model, preload)
      character(len=*), intent(in) :: path
      type(model_t), intent(out) :: model
      type(preload_info_t), intent(out), optional :: preload
      type(deck_t) :: deck
      type(deck_group_t), allocatable :: sweeps(:)
      type(error_t), allocatable :: err
      integer :: i
      call read_deck(path, deck, err)
      if (allocated(err)) call fail(err)
      call split_sweep_groups(deck, sweeps)
      if (size(sweeps) > 0) write (error_unit, '(a)') 'trainsim: note: '//path//' has '//str(size(sweeps))// &
         ' &sweep group(s); '//cmd//' ignores them and uses the deck''s own values (trainsim sweep runs the sweep)'
      call prepare_model(deck, sets, model, err, preload)
      if (allocated(err)) call fail(err)
      do i = 1, size(model%warnings)
         write (error_unit, '(a)') 'trainsim: '//model%warnings(i)%s
      end do
      if (strict .and. size(model%warnings) > 0) then
         write (error_unit, '(a)') 'trainsim: error: '//str(size(model%warnings))//' plausibility warning(s) '// &
            'above, and --strict makes them errors'
         call quit(2)
      end if
   end subroutine load

   subroutine do_modes(path, state)
      character(len=*), intent(in) :: path
      type(lin_state_t), intent(in) :: state
      type(model_t) :: model
      type(modes_t) :: modes
      type(error_t), allocatable :: err
      real(wp) :: dt_max, om, f, z
      character(len=:), allocatable :: what
      type(preload_info_t) :: preload
      call load(path, model, preload)
      call compute_modes(model, modes, err, state=state)
      if (allocated(err)) call fail(err)
      what = 'contacts as at the start'
      if (state%contact == lin_contact_closed) what = 'every clearance closed'
      select case (state%zone)
      case (lin_zone_single); what = what//', single-pair zones (helical: shortest contact lines)'
      case (lin_zone_stiffest); what = what//', two-pair zones (helical: longest contact lines)'
      case default; what = what//', mesh zones as at the start'
      end select
      if (model%run%preload) what = what//', about the static preload (trainsim_preload)'
      write (output_unit, '(a)') 'linearised with '//what
      if (model%run%preload) call print_preload(model, preload, output_unit)
      call print_modes(model, modes, output_unit)
      call rk4_dt_limit(model, state, dt_max, om, err, freq_hz=f, damping_ratio=z, dense=.true.)   ! the full analysis (D-64)
      if (allocated(err)) call fail(err)
      if (dt_max < huge(1.0_wp)) then
         write (output_unit, '(a)') 'RK4 stability limit (damped linear system'// &
            trim(merge(', impact damping up to the law''s largest', '                                        ', &
                       state%contact == lin_contact_closed))//'): dt < '//str(dt_max)//' s, set by '//mode_name(f, om, z)
      end if
   end subroutine do_modes

   !> The preloaded initial angles against the deck's, and the equilibrium residuals
   !> (trainsim modes --preload).
   subroutine print_preload(model, p, unit)
      type(model_t), intent(in) :: model
      type(preload_info_t), intent(in) :: p
      integer, intent(in) :: unit
      integer :: i
      if (p%free_train) then
         write (unit, '(a)') 'static preload (reference node '''//model%nodes(p%reference)%n%id// &
            ''', free train, acceleration '//str(p%acceleration, 6)//' rad/s^2):'
      else
         write (unit, '(a)') 'static preload (reference node '''//model%nodes(p%reference)%n%id//''', held or fixed):'
      end if
      write (unit, '(8x,a12,3a18)') 'node', 'deck angle', 'preload angle', 'difference'
      do i = 1, size(model%nodes)
         write (unit, '(8x,a12,3f18.9)') model%nodes(i)%n%id, p%theta_deck(i), model%nodes(i)%n%theta0, &
            p%theta_deck(i) - model%nodes(i)%n%theta0
      end do
      write (unit, '(a)') 'largest net-torque residual: '//str(p%residual, 3)//' at the preload, '// &
         str(p%deck_residual, 5)//' at the deck''s angles (torque scale '//str(p%torque_scale, 5)//'; '// &
         str(p%iterations)//' Newton iterations, '//str(p%passes)//' mode passes)'
   end subroutine print_preload

   !> "the mode at 5690.8 Hz (damping ratio 0.00)" for the eigenvalue that limits the RK4 step.
   function mode_name(f, om, z) result(s)
      real(wp), intent(in) :: f, om, z
      character(len=:), allocatable :: s
      character(len=40) :: a, b
      if (f > 0.0_wp) then
         a = str(f, 5)                             ! f0.1 would not fit above 1e38 Hz
         if (f < 1.0e9_wp) write (a, '(f0.1)') f
         write (b, '(f4.2)') z
         s = 'the mode at '//trim(a)//' Hz, damping ratio '//trim(b)
      else
         s = 'an overdamped mode, |lambda| = '//str(om, 5)//' 1/s'
      end if
   end function mode_name

   subroutine do_run(path, out, no_output)
      character(len=*), intent(in) :: path, out
      logical, intent(in) :: no_output   !< -o - or --no-output: no history file
      type(model_t) :: model
      type(error_t), allocatable :: err
      type(run_result_t) :: res
      type(hdf5_sink_t) :: h5
      type(null_sink_t) :: none
      type(progress_t) :: progress
      real(wp) :: dt_safe, om, f, z
      logical :: warned
      integer :: sig

      call load(path, model)
      if (len(out) > 0) model%run%output = out
      if (no_output) model%run%output = ''
      write (output_unit, '(a)') 'trainsim '//version_full()//': '//path//'  ('//model%title//')'
      call print_parameters(model, output_unit)
      flush (output_unit)   ! kept even if the run is interrupted or crashes
      ! a step the run would refuse is refused before any warning about it (D-55)
      call check_fixed_step(model, err)
      if (allocated(err)) call fail(err)
      if (model%run%integrator(1:3) == 'rk4') then
         ! RK4 step advice from the damped linearised train (D-25): first as it starts
         warned = .false.
         call rk4_dt_limit(model, lin_start, dt_safe, om, err, freq_hz=f, damping_ratio=z)
         if (.not. allocated(err)) then
            if (model%run%dt > dt_safe) then
               write (error_unit, '(a)') 'trainsim: warning: dt = '// &
                  str(model%run%dt)//' s exceeds the RK4 stability limit of the linearised train as it starts ('// &
                  mode_name(f, om, z)//'): dt < '//str(dt_safe, 4)//' s would be safe; the run goes '// &
                  'on and is only trustworthy if that mode is not excited'
               warned = .true.
            end if
         end if
         if (allocated(err)) deallocate (err)
         ! then the stiffest state contacts can reach: every clearance closed, gears
         ! in their stiffest mesh zone, impact damping anywhere up to the law's largest
         if (.not. warned) then
            call rk4_dt_limit(model, lin_stiffest, dt_safe, om, err, freq_hz=f, damping_ratio=z)
            if (.not. allocated(err)) then
               if (model%run%dt > dt_safe) write (error_unit, '(a)') 'trainsim: warning: dt = '// &
                  str(model%run%dt)//' s exceeds the RK4 stability limit of the stiffest state the run can reach '// &
                  '(every clearance closed, gears in their stiffest mesh zone; '//mode_name(f, om, z)// &
                  '): once contacts close, dt < '//str(dt_safe, 4)//' s would be safe'
            end if
            if (allocated(err)) deallocate (err)
         end if
      end if
      if (len(model%run%output) > 0) then
         h5%path = model%run%output
         h5%compression = model%run%compression
         call simulate(model, h5, res, err, keep_interrupted=.true., progress=progress)
      else
         call simulate(model, none, res, err, progress=progress)
      end if
      if (allocated(err)) then
         if (err%code == err_interrupted) then
            ! the history computed so far was kept (simulate's keep_interrupted)
            sig = interrupt_signal()
            if (len(model%run%output) == 0) then
               write (error_unit, '(a)') 'trainsim: '//err%message//' by '//signal_name(sig)//'; '//no_file_reason(no_output)
            else if (res%t_sampled > -huge(1.0_wp)) then
               write (error_unit, '(a)') 'trainsim: '//err%message//' by '//signal_name(sig)//'; the history up to t = '// &
                  str(res%t_sampled)//' s (the last output time reached) was kept in '//model%run%output// &
                  ", marked incomplete (root attribute status = 'interrupted')"
            else   ! stopped before the first sample, or the file could not be closed (err says why)
               write (error_unit, '(a)') 'trainsim: '//err%message//' ('//signal_name(sig)//'); no history written'
            end if
            call quit(128 + sig)
         end if
         call fail(err)
      end if
      call print_summary(model, res, output_unit)
      if (len(model%run%output) > 0) then
         write (output_unit, '(a)') 'history written to '//model%run%output
      else
         write (output_unit, '(a)') 'note: '//no_file_reason(no_output)
      end if
      flush (output_unit)
   end subroutine do_run

   !> Why a run wrote no history file.
   function no_file_reason(no_output) result(text)
      logical, intent(in) :: no_output   !< --no-output or -o - was given
      character(len=:), allocatable :: text
      if (no_output) then
         text = 'no history file was written (--no-output or -o -)'
      else
         text = 'no history file was written: the deck names no output (set output in &run, or give -o FILE)'
      end if
   end function no_file_reason

   ! ------------------------------------------------ trainsim gear / trainsim key

   !> Value of option arg(k) read from arg(k+1) as a real (exit 2 naming the option if it is not one).
   real(wp) function real_value(k) result(x)
      integer, intent(in) :: k
      integer :: ios
      character(len=:), allocatable :: text
      if (k >= nargs) then
         write (error_unit, '(a)') 'trainsim: '//cmd//': error: option '//arg(k)//' needs a number'
         call quit(2)
      end if
      text = trim(adjustl(arg(k + 1)))
      call parse_real(text, x, ios)   ! checked as text first: 1e999 is refused, never converted
      if (ios == 2) then
         write (error_unit, '(a)') 'trainsim: '//cmd//': error: option '//arg(k)//" got '"//arg(k + 1)// &
            "', beyond the range of double precision"
         call quit(2)
      else if (ios /= 0) then
         write (error_unit, '(a)') 'trainsim: '//cmd//': error: option '//arg(k)//" needs a number, got '"// &
            arg(k + 1)//"'"
         call quit(2)
      end if
   end function real_value

   !> Value of option arg(k) as text (exit 2 if it is missing).
   function text_value(k) result(s)
      integer, intent(in) :: k
      character(len=:), allocatable :: s
      if (k >= nargs) then
         write (error_unit, '(a)') 'trainsim: '//cmd//': error: option '//arg(k)//' needs a value'
         call quit(2)
      end if
      s = arg(k + 1)
   end function text_value

   !> --units NAME for the calculators.
   subroutine calc_units(k, units)
      integer, intent(in) :: k
      type(units_t), intent(out) :: units
      type(error_t), allocatable :: err
      call make_units(text_value(k), units, err)
      if (allocated(err)) then
         write (error_unit, '(a)') 'trainsim: '//cmd//': error: --units: '//err%message
         call quit(2)
      end if
   end subroutine calc_units

   !> in-lbf-s, the calculators' default.
   subroutine default_units(units)
      type(units_t), intent(out) :: units
      type(error_t), allocatable :: err
      call make_units('in-lbf-s', units, err)
   end subroutine default_units

   !> trainsim gear: spur gear constants from the geometry (App. E) and a deck fragment.
   subroutine do_gear()
      type(gear_input_t) :: g
      type(gear_result_t) :: r
      type(error_t), allocatable :: err
      integer :: k, j
      call default_units(g%units)
      k = 2
      do while (k <= nargs)
         select case (arg(k))
         case ('--teeth')
            g%teeth1 = real_value(k)
            g%teeth2 = g%teeth1
            k = k + 1
            if (k < nargs) then   ! a second number: the driven gear's teeth
               if (verify(trim(arg(k + 1)), '0123456789.eE+') == 0) then
                  g%teeth2 = real_value(k)
                  k = k + 1
               end if
            end if
         case ('--diametral-pitch'); g%diametral_pitch = real_value(k); k = k + 1
         case ('--module'); g%module_mm = real_value(k); k = k + 1
         case ('--pressure-angle'); g%pressure_angle_deg = real_value(k); k = k + 1
         case ('--face-width'); g%face_width = real_value(k); k = k + 1
         case ('--backlash'); g%backlash = real_value(k); k = k + 1
         case ('--youngs-modulus'); g%youngs_modulus = real_value(k); k = k + 1
         case ('--density'); g%density = real_value(k); k = k + 1
         case ('--stiffness-per-width'); g%stiffness_per_width = real_value(k); k = k + 1
         case ('--stiffness'); g%stiffness = real_value(k); k = k + 1
         case ('--frequency'); g%target_frequency = real_value(k); k = k + 1
         case ('--approach-velocity'); g%approach_velocity = real_value(k); k = k + 1
         case ('--id'); g%id = text_value(k); k = k + 1
         case ('--units'); call calc_units(k, g%units); k = k + 1
         case default
            write (error_unit, '(a)') "trainsim: gear: error: unknown option '"//arg(k)//"'; valid: --teeth N1 [N2], "// &
               '--diametral-pitch P | --module M, --pressure-angle DEG, --face-width F, --backlash B, --units U, '// &
               '--youngs-modulus E, --density RHO, --stiffness-per-width KW, --stiffness K, --frequency HZ, '// &
               '--approach-velocity V, --id ID'
            call quit(2)
         end select
         k = k + 1
      end do
      call gear_calc(g, r, err)
      if (allocated(err)) call fail(err)
      do j = 1, size(r%warnings)
         write (error_unit, '(a)') 'trainsim: '//r%warnings(j)%s
      end do
      call gear_report(g, r, output_unit)
      call quit(0)
   end subroutine do_gear

   !> trainsim key: the keyed joint's stiffness curve (Ch. IV) and a deck fragment.
   subroutine do_key()
      type(key_input_t) :: q
      type(key_result_t) :: r
      type(error_t), allocatable :: err
      integer :: k, j
      real(wp) :: x
      call default_units(q%units)
      k = 2
      do while (k <= nargs)
         select case (arg(k))
         case ('--diameter'); q%diameter = real_value(k); k = k + 1
         case ('--key-length'); q%key_length = real_value(k); k = k + 1
         case ('--key-width'); q%key_width = real_value(k); k = k + 1
         case ('--key-height'); q%key_height = real_value(k); k = k + 1
         case ('--clearance'); q%clearance = real_value(k); k = k + 1
         case ('--torque-max'); q%torque_max = real_value(k); k = k + 1
         case ('--points')   ! checked as a real first: nint of 1e300 would overflow
            x = real_value(k)
            if (.not. (x >= 2.0_wp .and. x <= real(key_max_points, wp) .and. x == aint(x))) then
               write (error_unit, '(a)') 'trainsim: key: error: --points must be a whole number in [2, '// &
                  str(key_max_points)//'] (rows of the curve), got '//arg(k + 1)
               call quit(2)
            end if
            q%points = nint(x)
            k = k + 1
         case ('--id'); q%id = text_value(k); k = k + 1
         case ('--units'); call calc_units(k, q%units); k = k + 1
         case ('--fit')
            select case (text_value(k))
            case ('tight'); q%fit = fit_tight
            case ('loose'); q%fit = fit_loose
            case ('average'); q%fit = fit_average
            case ('all'); q%fit = 0
            case default
               write (error_unit, '(a)') "trainsim: key: error: unknown --fit '"//arg(k + 1)// &
                  "'; valid: tight (eq. 4.35), loose (4.36), average (4.37), all"
               call quit(2)
            end select
            k = k + 1
         case default
            write (error_unit, '(a)') "trainsim: key: error: unknown option '"//arg(k)//"'; valid: --diameter D, "// &
               '--key-length L, --key-width W, --key-height H, --clearance C, --fit tight|loose|average|all, '// &
               '--torque-max T, --points N, --units U, --id ID'
            call quit(2)
         end select
         k = k + 1
      end do
      call key_calc(q, r, err)
      if (allocated(err)) call fail(err)
      do j = 1, size(r%warnings)
         write (error_unit, '(a)') 'trainsim: '//r%warnings(j)%s
      end do
      call key_report(q, r, output_unit)
      call quit(0)
   end subroutine do_key

   ! ------------------------------------------------------------ trainsim diagram

   !> trainsim diagram DECK -o OUT [--json FILE] [--set ...]: the deck read and built by
   !> trainsim itself, its description (trainsim_describe) written as JSON, then drawn by
   !> scripts/trainsim_diagram.py (run as `export` and `plot` run theirs).
   subroutine do_diagram()
      character(len=:), allocatable :: deck_file, out, json, path, script, python, line, ext
      type(deck_t) :: deck
      type(deck_group_t), allocatable :: sweeps(:)
      type(model_t) :: model
      type(error_t), allocatable :: err
      integer :: k, u, ios, stat, cstat
      deck_file = ''
      out = ''
      json = ''
      allocate (sets(0))
      k = 2
      do while (k <= nargs)
         select case (arg(k))
         case ('-h', '--help')
            call command_usage('diagram', output_unit)
            call quit(0)
         case ('-o', '--output'); out = text_value(k); k = k + 1
         case ('--json'); json = text_value(k); k = k + 1
         case ('--set'); call add_set(k); k = k + 1
         case default
            if (index(arg(k), '-') == 1 .or. len(deck_file) > 0) then
               write (error_unit, '(a)') "trainsim: diagram: error: unexpected argument '"//arg(k)// &
                  "' (try trainsim diagram --help)"
               call quit(2)
            end if
            deck_file = arg(k)
         end select
         k = k + 1
      end do
      if (len(deck_file) == 0 .or. (len(out) == 0 .and. len(json) == 0)) then
         write (error_unit, '(a)') 'trainsim: diagram: error: needs a deck and -o OUT.svg|png|pdf (or --json FILE) '// &
            '(try trainsim diagram --help)'
         call quit(2)
      end if
      ext = ''
      if (index(out, '.', back=.true.) > 0) ext = out(index(out, '.', back=.true.):)
      if (len(out) > 0 .and. ext /= '.svg' .and. ext /= '.png' .and. ext /= '.pdf') then
         write (error_unit, '(a)') "trainsim: diagram: error: output '"//out//"' must end in .svg, .png or .pdf"
         call quit(2)
      end if
      script = ''
      if (len(out) > 0) then
         script = find_script('trainsim_diagram.py')
         if (len(script) == 0) then
            write (error_unit, '(a)') 'trainsim: diagram: error: cannot find trainsim_diagram.py (looked in '// &
               '$TRAINSIM_SCRIPTS, <prefix>/share/trainsim/scripts and <build>/../scripts beside the executable)'
            call quit(2)
         end if
      end if

      call read_deck(deck_file, deck, err)
      if (allocated(err)) call fail(err)
      call split_sweep_groups(deck, sweeps)   ! a sweep deck is drawn with its own values
      call prepare_model(deck, sets, model, err)
      if (allocated(err)) call fail(err)

      if (json == '-') then
         call write_description(deck, model, output_unit)
         flush (output_unit)
         if (len(out) == 0) call quit(0)
      end if
      path = json
      if (json == '-' .or. len(json) == 0) then   ! a temporary file for the script
         path = env_text('TMPDIR')
         if (len(path) == 0) path = '/tmp'
         path = path//'/trainsim-diagram-'//str(int(c_getpid()))//'.json'
      end if
      open (newunit=u, file=path, status='replace', action='write', iostat=ios)
      if (ios /= 0) then
         write (error_unit, '(a)') "trainsim: diagram: error: cannot write '"//path//"'"
         call quit(2)
      end if
      call write_description(deck, model, u)
      close (u)
      if (len(out) == 0) call quit(0)

      python = env_text('TRAINSIM_PYTHON')
      if (len(python) == 0) python = '/usr/bin/python3'
      line = quoted(python)//' '//quoted(script)//' '//quoted(path)//' -o '//quoted(out)
      flush (output_unit)
      call execute_command_line(line, exitstat=stat, cmdstat=cstat)
      if (path /= json) then
         open (newunit=u, file=path, status='old', iostat=ios)
         if (ios == 0) close (u, status='delete')
      end if
      if (cstat /= 0) then
         write (error_unit, '(a)') 'trainsim: diagram: error: cannot run '//python//' '//script
         call quit(2)
      end if
      call quit(stat)
   end subroutine do_diagram

   ! ------------------------------------------ trainsim export / trainsim plot

   !> trainsim export|plot ARGS: run scripts/trainsim_<cmd>.py ARGS with Python
   !> (docs/output-format.md, "Export and plots"): $TRAINSIM_PYTHON or /usr/bin/python3.
   !> The exit status is the script's.
   subroutine do_script()
      character(len=:), allocatable :: script, line, python
      integer :: k, stat, cstat
      script = find_script('trainsim_'//cmd//'.py')
      if (len(script) == 0) then
         write (error_unit, '(a)') 'trainsim: '//cmd//': error: cannot find trainsim_'//cmd//'.py (looked in '// &
            '$TRAINSIM_SCRIPTS, <prefix>/share/trainsim/scripts and <build>/../scripts beside the executable)'
         call quit(2)
      end if
      python = env_text('TRAINSIM_PYTHON')
      if (len(python) == 0) python = '/usr/bin/python3'
      line = quoted(python)//' '//quoted(script)
      do k = 2, nargs
         line = line//' '//quoted(arg(k))
      end do
      flush (output_unit)
      call execute_command_line(line, exitstat=stat, cmdstat=cstat)
      if (cstat /= 0) then
         write (error_unit, '(a)') 'trainsim: '//cmd//': error: cannot run '//python//' '//script
         call quit(2)
      end if
      call quit(stat)
   end subroutine do_script

   !> The first existing `name` in $TRAINSIM_SCRIPTS, the installed share directory
   !> (<prefix>/bin/trainsim -> <prefix>/share/trainsim/scripts) or the source tree
   !> (<source>/build/trainsim -> <source>/scripts); '' if none.
   function find_script(name) result(path)
      character(len=*), intent(in) :: name
      character(len=:), allocatable :: path, dir
      character(len=4096) :: candidates(3)
      logical :: there
      integer :: k
      dir = exe_dir()
      candidates(1) = env_text('TRAINSIM_SCRIPTS')//'/'//name
      candidates(2) = dir//'/../share/trainsim/scripts/'//name
      candidates(3) = dir//'/../scripts/'//name
      if (len(env_text('TRAINSIM_SCRIPTS')) == 0) candidates(1) = ''
      path = ''
      do k = 1, size(candidates)
         if (len_trim(candidates(k)) == 0) cycle
         inquire (file=trim(candidates(k)), exist=there)
         if (there) then
            path = trim(candidates(k))
            return
         end if
      end do
   end function find_script

   !> Directory of the running executable (/proc/self/exe), '.' if unknown.
   function exe_dir() result(dir)
      character(len=:), allocatable :: dir
      character(kind=c_char, len=4096) :: buf
      integer(c_long) :: n
      integer :: k
      n = c_readlink('/proc/self/exe'//c_null_char, buf, int(len(buf), c_size_t))
      dir = '.'
      if (n <= 0 .or. n >= len(buf)) return
      k = index(buf(1:n), '/', back=.true.)
      if (k > 1) dir = buf(1:k - 1)
   end function exe_dir

   !> An environment variable's value ('' when unset).
   function env_text(name) result(v)
      character(len=*), intent(in) :: name
      character(len=:), allocatable :: v
      integer :: n, st
      call get_environment_variable(name, length=n, status=st)
      v = ''
      if (st /= 0 .or. n == 0) return
      allocate (character(len=n) :: v)
      call get_environment_variable(name, v)
   end function env_text

   !> `s` as one POSIX shell word: single-quoted, each ' written as '\''.
   function quoted(s) result(q)
      character(len=*), intent(in) :: s
      character(len=:), allocatable :: q
      integer :: k
      q = "'"
      do k = 1, len(s)
         if (s(k:k) == "'") then
            q = q//"'\''"
         else
            q = q//s(k:k)
         end if
      end do
      q = q//"'"
   end function quoted
end program trainsim_main
