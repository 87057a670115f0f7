!> trainsim run: one run of a deck, its RK4 step advice, its history file and summary.
module trainsim_cmd_run
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, err_interrupted
   use trainsim_interrupt, only: interrupt_signal, signal_name
   use trainsim_strings, only: str
   use trainsim_version, only: version_full
   use trainsim_model, only: model_t
   use trainsim_modes, only: rk4_dt_limit, dense_state_limit
   use trainsim_element, only: lin_start, lin_stiffest
   use trainsim_simulate, only: simulate, check_fixed_step
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_hdf5, only: hdf5_sink_t
   use trainsim_report, only: print_summary, print_parameters
   use trainsim_progress, only: progress_t
   use trainsim_cli, only: quit, fail, load
   use trainsim_cmd_modes, only: mode_name
   implicit none
   private

   public :: do_run

contains

   subroutine do_run(path, out, no_output)
      character(len=*), intent(in) :: path, out
      logical, intent(in) :: no_output   !< -o - or --no-output: no history file
      type(model_t) :: model
      type(error_t), allocatable :: err
      type(run_result_t) :: res
      type(hdf5_sink_t) :: h5
      type(null_sink_t) :: none
      type(progress_t) :: progress
      real(wp) :: dt_safe, dt_quick, om, f, z, stiffest(3)
      logical :: warned
      integer :: sig

      call load(path, model)
      if (len(out) > 0) model%run%output = out
      if (no_output) model%run%output = ''
      write (output_unit, '(a)') 'trainsim '//version_full()//': '//path//'  ('//model%title//')'
      call print_parameters(model, output_unit)
      flush (output_unit)   ! kept even if the run is interrupted or crashes
      ! a step the run would refuse is refused before any warning about it (D-55)
      call check_fixed_step(model, err, start_bound=dt_quick, stiffest=stiffest)
      if (allocated(err)) call fail(err)
      if (model%run%integrator(1:3) == 'rk4') then
         ! RK4 step advice from the damped linearised train (D-25): first as it starts;
         ! above the dense limit that is the check's own O(n) bound (D-107): asked again
         ! only for the text of a warning
         warned = .false.
         if (model%n_states > dense_state_limit .and. .not. model%nport .and. model%run%dt <= dt_quick) then
            dt_safe = dt_quick
         else
            call rk4_dt_limit(model, lin_start, dt_safe, om, err, freq_hz=f, damping_ratio=z)
         end if
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
            if (model%n_states > dense_state_limit .and. .not. model%nport .and. stiffest(1) > 0.0_wp) then
               ! what rk4_dt_limit gives there: the check's own O(n) bound (D-139)
               dt_safe = stiffest(1)
               om = stiffest(2)
               f = stiffest(3)
               z = 0.0_wp
            else
               call rk4_dt_limit(model, lin_stiffest, dt_safe, om, err, freq_hz=f, damping_ratio=z)
            end if
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
         call simulate(model, h5, res, err, keep_interrupted=.true., progress=progress, step_checked=.true., &
                       tables_built=.true.)
      else
         call simulate(model, none, res, err, progress=progress, step_checked=.true., &
                       tables_built=.true.)
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
      ! the run is the process's last work: it ends here, without taking the model
      ! apart piece by piece on the way out (53 M instructions at 20 000 nodes, D-139),
      ! silent as the program's own end (no note of IEEE flags)
      call quit(0, silent=.true.)
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
end module trainsim_cmd_run
