!> trainsim: drive-train simulation with clearances (successor to TRAIN, Cook 1989).
!> The command line's dispatch: each command is a module of app/ (trainsim_cmd_*),
!> what they share is trainsim_cli.
program trainsim_main
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_version, only: version_full
   use trainsim_cli, only: cmd, nargs, arg, quit
   use trainsim_cmd_help, only: usage, command_usage
   use trainsim_cmd_deck, only: deck_command
   use trainsim_cmd_calc, only: do_gear, do_key, do_worm, do_planetary
   use trainsim_cmd_mesh, only: do_gear_mesh
   use trainsim_cmd_scripts, only: do_diagram, do_script
   use trainsim_cmd_fmu, only: do_fmu
   use trainsim_cmd_periodic, only: do_periodic
   use trainsim_cmd_continue, only: do_continue
   use trainsim_cmd_runup, only: do_runup
   implicit none

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
      call deck_command()
   case ('gear', 'key', 'worm', 'planetary')
      if (nargs >= 2) then
         select case (arg(2))
         case ('-h', '--help')
            call command_usage(cmd, output_unit)
            call quit(0)
         end select
      end if
      if (cmd == 'gear' .and. nargs >= 2) then
         if (index(arg(2), '-') /= 1) call do_gear_mesh()   ! trainsim gear DECK: its mesh excitation
      end if
      if (cmd == 'gear') call do_gear()
      if (cmd == 'key') call do_key()
      if (cmd == 'worm') call do_worm()
      if (cmd == 'planetary') call do_planetary()
   case ('export', 'plot')
      call do_script()
   case ('diagram')
      call do_diagram()
   case ('fmu')
      call do_fmu()
   case ('periodic')
      call do_periodic()
   case ('continue')
      call do_continue()
   case ('runup')
      call do_runup()
   case default
      write (error_unit, '(a)') "trainsim: error: unknown command '"//cmd//"' (try trainsim --help)"
      call quit(2)
   end select
end program trainsim_main
