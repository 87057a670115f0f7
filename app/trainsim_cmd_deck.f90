!> The commands that read a deck (run, sweep, modes): their options, then the command.
module trainsim_cmd_deck
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_interrupt, only: install_interrupt_handlers
   use trainsim_element, only: lin_state_t, lin_contact_closed, lin_zone_initial, lin_zone_single, lin_zone_stiffest
   use trainsim_cli, only: cmd, deck_path, nargs, sets, strict, arg, quit, add_set, add_preload
   use trainsim_cmd_help, only: command_usage
   use trainsim_cmd_run, only: do_run
   use trainsim_cmd_sweep, only: sweep_opt, sweep_option, do_sweep
   use trainsim_cmd_modes, only: do_modes
   implicit none
   private

   public :: deck_command

contains

   !> trainsim run|sweep|modes DECK [options]: read the options, then run the command.
   subroutine deck_command()
      character(len=:), allocatable :: out_path
      type(lin_state_t) :: modes_state   ! trainsim modes: --closed, --zone, --stiffest
      logical :: no_output
      integer :: i

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
   end subroutine deck_command
end module trainsim_cmd_deck
