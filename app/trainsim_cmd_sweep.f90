!> trainsim sweep: its own options (--resume, --progress) and the sweep itself.
module trainsim_cmd_sweep
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, err_interrupted
   use trainsim_strings, only: str
   use trainsim_deck, only: parse_real
   use trainsim_sweep, only: sweep_options_t, sweep_summary_t, run_sweep
   use trainsim_cli, only: cmd, nargs, sets, arg, quit, fail
   implicit none
   private

   public :: sweep_opt, sweep_option, do_sweep

   type(sweep_options_t) :: sweep_opt         ! trainsim sweep: --resume, --progress

contains

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
end module trainsim_cmd_sweep
