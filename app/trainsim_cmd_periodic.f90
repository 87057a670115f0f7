!> trainsim periodic: the periodic steady state of a deck under periodic forcing by
!> shooting (src/periodic, docs/periodic.md), its Floquet multipliers, stability,
!> grazing check and the run's metrics over the orbit.
module trainsim_cmd_periodic
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_hdf5, only: hdf5_sink_t
   use trainsim_report, only: print_summary
   use trainsim_period_map, only: period_map_t, forcing_period
   use trainsim_shooting, only: shoot_options_t, shoot_result_t, shoot, shoot_converged
   use trainsim_floquet, only: floquet_multipliers, stability_of, neutral_tol
   use trainsim_orbit, only: orbit_run, orbit_grazing, graze_tol
   use trainsim_periodic_file, only: write_periodic_group, write_orbit_p2p
   use trainsim_cli, only: nargs, arg, quit, fail, load, add_set, real_value, text_value, deck_path, sets
   use trainsim_cmd_help, only: command_usage
   use trainsim_monodromy_map, only: monodromy_variational, monodromy_choice, monodromy_name, monodromy_code, &
                                     mono_auto
   implicit none
   private

   public :: do_periodic

contains

   !> trainsim periodic DECK [--period-count K] [--period T] [--segments M] [--transient N] [--tol TOL]
   !> [--set ...] [-o FILE]
   subroutine do_periodic()
      type(model_t) :: model
      type(period_map_t) :: pm
      type(shoot_options_t) :: opt
      type(shoot_result_t) :: res
      type(error_t), allocatable :: err
      complex(wp), allocatable :: mu(:)
      character(len=:), allocatable :: out
      real(wp) :: period
      integer :: k, i, mono
      logical :: salt
      deck_path = ''
      mono = mono_auto
      out = ''
      allocate (sets(0))
      k = 1
      period = 0.0_wp
      i = 2
      do while (i <= nargs)
         select case (arg(i))
         case ('-h', '--help')
            call command_usage('periodic', output_unit)
            call quit(0)
         case ('-o', '--output')
            out = text_value(i)
            i = i + 1
         case ('--period-count')
            k = count_value(i, 1, 1000)
            i = i + 1
         case ('--segments')
            opt%segments = count_value(i, 1, 64)
            i = i + 1
         case ('--transient')
            opt%transient = count_value(i, 0, 100000)
            i = i + 1
         case ('--period')
            period = real_value(i)
            i = i + 1
            if (.not. period > 0.0_wp) call refuse('option --period needs a period > 0 s, got '//arg(i))
         case ('--tol')
            opt%tol = real_value(i)
            i = i + 1
            if (.not. (opt%tol > 0.0_wp .and. opt%tol < 1.0_wp)) &
               call refuse('option --tol needs a tolerance between 0 and 1, got '//arg(i))
         case ('--monodromy')
            mono = monodromy_code(text_value(i))
            i = i + 1
            if (mono < 0) call refuse("option --monodromy needs auto, saltation or fd, got '"//arg(i)//"'")
         case ('--set')
            call add_set(i)
            i = i + 1
         case default
            if (index(arg(i), '-') == 1 .or. len(deck_path) > 0) &
               call refuse("unexpected argument '"//arg(i)//"' (try trainsim periodic --help)")
            deck_path = arg(i)
         end select
         i = i + 1
      end do
      if (len(deck_path) == 0) call refuse('no deck given (usage: trainsim periodic DECK [options])')
      call load(deck_path, model)
      if (.not. period > 0.0_wp) call forcing_period(model, period, err)
      if (allocated(err)) call fail(err)
      write (output_unit, '(a)') 'trainsim periodic: '//deck_path//'  ('//model%title//')'
      write (output_unit, '(a)') 'forcing period T = '//str(period, 10)//' s, orbit of '//str(k)// &
         ' period(s), from t_start = '//str(model%run%t_start)//' s after a transient of at least '// &
         str(opt%transient*k)//' period(s); integrator '//model%run%integrator//', dt = '//str(model%run%dt)//' s'
      call pm%setup(model, period, k, err)
      if (allocated(err)) call fail(err)
      call monodromy_choice(mono, model, salt, err)
      if (allocated(err)) call refuse(err%message)
      if (opt%segments > 1) salt = .false.   ! (multiple shooting: differences per segment)
      if (salt) then
         call shoot(pm, opt, res, err, monodromy=monodromy_variational)
      else
         call shoot(pm, opt, res, err)
      end if
      if (allocated(err)) then
         err%message = 'the periodic orbit could not be computed: '//err%message
         call fail(err)
      end if
      call print_convergence(res, opt, salt)
      if (pm%t0 /= model%run%t_start) write (output_unit, '(a)') 'the forcing phase moved to t0 = '//str(pm%t0, 10)// &
         ' s, where no contact with a memory of its impact is in progress (D-99)'
      if (res%status /= shoot_converged) then
         write (error_unit, '(a)') 'trainsim: error: no periodic orbit found: '//res%message
         call quit(1)
      end if
      call floquet_multipliers(res%m, mu, err)
      if (allocated(err)) call fail(err)
      call print_state(model, pm, res)
      call print_multipliers(mu)
      call orbit_metrics(model, pm, res, mu, out)
      call pm%finish()
   end subroutine do_periodic

   subroutine refuse(msg)
      character(len=*), intent(in) :: msg
      write (error_unit, '(a)') 'trainsim: periodic: error: '//msg
      call quit(2)
   end subroutine refuse

   !> The integer value of option arg(k) within [lo, hi] (exit 2 otherwise).
   integer function count_value(k, lo, hi) result(n)
      integer, intent(in) :: k, lo, hi
      real(wp) :: x
      x = real_value(k)
      if (.not. (x >= real(lo, wp) .and. x <= real(hi, wp) .and. x == aint(x))) &
         call refuse('option '//arg(k)//' needs a whole number from '//str(lo)//' to '//str(hi)//", got '"// &
                     arg(k + 1)//"'")
      n = nint(x)
   end function count_value

   subroutine print_convergence(res, opt, salt)
      type(shoot_result_t), intent(in) :: res
      type(shoot_options_t), intent(in) :: opt
      logical, intent(in) :: salt
      integer :: j
      if (res%segments > 1) write (output_unit, '(a)') 'multiple shooting over '//str(res%segments)//' segments'
      write (output_unit, '(a)') 'Newton on P(x) - x (monodromy by '//monodromy_name(salt)//') after '//str(res%transient)// &
         ' periods of transient (start '//str(res%attempts)//' of at most '//str(opt%retries + 1)// &
         '), residual of the state scale:'
      do j = 1, size(res%history)
         write (output_unit, '(4x,a,i3,a,es10.3)') 'step', j - 1, ':  ', res%history(j)
      end do
      if (res%status == shoot_converged) then
         write (output_unit, '(a)') 'converged to '//str(res%residual, 3)//' <= '//str(opt%tol, 3)//' in '// &
            str(res%newton)//' Newton steps, '//str(res%maps)//' period maps'
      else
         write (output_unit, '(a)') 'not converged after '//str(res%newton)//' Newton steps, '//str(res%maps)// &
            ' period maps'
      end if
   end subroutine print_convergence

   subroutine print_state(model, pm, res)
      type(model_t), intent(in) :: model
      type(period_map_t), intent(in) :: pm
      type(shoot_result_t), intent(in) :: res
      integer :: i, j
      write (output_unit, '(a)') 'the orbit at t0 (angles relative to the rigid rotation W (t - t0)):'
      do i = 1, pm%n
         j = findloc(pm%ang, i, 1)
         if (j > 0) then
            write (output_unit, '(4x,a,es22.14,a)') model%state_label(i)//': ', res%x(i), &
               '   (W = '//str(pm%w(j))//' rad/s)'
         else
            write (output_unit, '(4x,a,es22.14)') model%state_label(i)//': ', res%x(i)
         end if
      end do
      do i = 1, size(pm%memory)   ! (D-150: the memory a contact closed at t0 goes on with)
         if (.not. pm%kept(i)) cycle
         write (output_unit, '(4x,a,3es15.7)') "memory of '"//model%elements(pm%memory(i))%e%id// &
            "' (its contact never opens; yang_sun D, e, V_i): ", pm%mem(3*i - 2:3*i)
      end do
   end subroutine print_state

   subroutine print_multipliers(mu)
      complex(wp), intent(in) :: mu(:)
      integer :: j
      write (output_unit, '(a)') 'Floquet multipliers (largest |mu| first):'
      do j = 1, size(mu)
         write (output_unit, '(4x,es16.8,sp,es16.8,ss,a,es14.6)') real(mu(j)), aimag(mu(j)), ' i   |mu| =', abs(mu(j))
      end do
      if (size(mu) == 0) return
      select case (stability_of(mu))
      case ('stable')
         write (output_unit, '(a)') 'stable: the largest |mu| is '//str(abs(mu(1)), 8)//' < 1'
      case ('marginal')
         write (output_unit, '(a)') 'marginal: the largest |mu| is '//str(abs(mu(1)), 10)//', within '// &
            str(neutral_tol, 2)//' of 1 (an undamped mode: neither decays nor grows to the accuracy of M)'
      case default
         write (output_unit, '(a)') 'UNSTABLE: the largest |mu| is '//str(abs(mu(1)), 8)//' > 1'
      end select
   end subroutine print_multipliers

   !> The orbit's run (into FILE with -o), its metrics, the grazing check, /periodic.
   subroutine orbit_metrics(model, pm, res, mu, out)
      type(model_t), intent(in) :: model
      type(period_map_t), intent(in) :: pm
      type(shoot_result_t), intent(in) :: res
      complex(wp), intent(in) :: mu(:)
      character(len=*), intent(in) :: out
      type(run_result_t) :: run
      type(hdf5_sink_t) :: h5
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      type(model_t) :: m
      real(wp), allocatable :: gap(:)
      integer :: worst, stale
      m = model
      if (len(out) > 0) then
         m%run%output = out
         h5%path = out
         h5%compression = m%run%compression
         call orbit_run(m, pm, res%x, h5, run, err, stale)
      else
         call orbit_run(m, pm, res%x, none, run, err, stale)
      end if
      if (allocated(err)) call fail(err)
      if (stale > 0) write (output_unit, '(a)') "WARNING: t0 lies in a contact of '"//m%elements(stale)%e%id// &
         "' that came from an impact (no t0 has every striking clearance open): the map restarts it with the "// &
         "contact law's start, not its impact's damping; this is not an orbit of the train (D-144)"
      write (output_unit, '(a)') 'the orbit''s run over '//str(pm%k)//' period(s) from t0:'
      call print_summary(m, run, output_unit)
      call orbit_grazing(m, run, gap, worst)
      if (worst > 0) then
         write (output_unit, '(a)') 'grazing check: the closest extreme of a clearance''s displacement to a '// &
            "contact face is '"//m%elements(worst)%e%id//"'s, "//str(gap(worst), 4)//' of its half clearance'
         if (gap(worst) <= graze_tol) write (output_unit, '(a)') 'GRAZING: within '//str(graze_tol, 2)// &
            ' of the half clearance (a contact that just touches or just fails to open)'
      else
         write (output_unit, '(a)') 'grazing check: no clearance in the train'
      end if
      if (len(out) == 0) return
      call write_orbit_p2p(out, run%el%p2p_range, err)
      if (allocated(err)) call fail(err)
      if (worst == 0) then
         call write_periodic_group(out, m, pm, res, mu, huge(1.0_wp), 0, err)
      else
         call write_periodic_group(out, m, pm, res, mu, gap(worst), worst, err)
      end if
      if (allocated(err)) call fail(err)
      write (output_unit, '(a)') 'orbit written to '//out//' (its run, and the group /periodic)'
   end subroutine orbit_metrics
end module trainsim_cmd_periodic
