!> trainsim gear DECK [--mesh ID]: a spur or helical gear's mesh excitation (issue 26)
!> from the deck: the mesh stiffness k c(u), the loaded and the unloaded
!> static transmission error over a tooth period, or over the hunting period
!> when per-tooth data, run-out or a fault repeat later; as a table, and as a
!> figure drawn by scripts/trainsim_mesh_plot.py.
module trainsim_cmd_mesh
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_deck, only: deck_t, read_deck
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_excited_mesh, only: excited_mesh_t
   use trainsim_cli, only: nargs, arg, quit, fail, text_value, real_value
   use trainsim_cmd_scripts, only: find_script, env_text, quoted
   implicit none
   private

   public :: do_gear_mesh

   !> Most rows written (a hunting period of 1e4 x 1e4 teeth would be 1e8 x points).
   integer, parameter :: max_rows = 2000000

contains

   subroutine do_gear_mesh()
      character(len=:), allocatable :: deck_file, mesh_id, out, plot, script, python
      type(deck_t) :: deck
      type(model_t) :: model
      type(error_t), allocatable :: err
      integer :: k, i, found, points, u, ios, stat, cstat
      deck_file = arg(2)
      mesh_id = ''
      out = ''
      plot = ''
      points = 64
      k = 3
      do while (k <= nargs)
         select case (arg(k))
         case ('--mesh'); mesh_id = text_value(k); k = k + 1
         case ('--points'); points = nint(real_value(k)); k = k + 1
         case ('-o', '--output'); out = text_value(k); k = k + 1
         case ('--plot'); plot = text_value(k); k = k + 1
         case default
            write (error_unit, '(a)') "trainsim: gear: error: unknown option '"//arg(k)//"' after a deck; valid: "// &
               '--mesh ID, --points N (per tooth, default 64), -o TABLE, --plot OUT.png|svg|pdf'
            call quit(2)
         end select
         k = k + 1
      end do
      if (points < 4 .or. points > 100000) then
         write (error_unit, '(a)') 'trainsim: gear: error: --points must be in [4, 100000], got '//str(points)
         call quit(2)
      end if
      if (len(plot) > 0 .and. len(out) == 0) out = plot(:index(plot, '.', back=.true.) - 1)//'.txt'
      call read_deck(deck_file, deck, err)
      if (allocated(err)) call fail(err)
      call build_model(deck, model, err)
      if (allocated(err)) call fail(err)
      found = 0
      do i = 1, size(model%elements)
         select type (e => model%elements(i)%e)
         class is (excited_mesh_t)
            if (len(mesh_id) == 0 .or. e%id == mesh_id) then
               found = i
               exit
            end if
         end select
      end do
      if (found == 0) then
         if (len(mesh_id) == 0) then
            write (error_unit, '(a)') 'trainsim: gear: error: '//deck_file//' has no spur_gear or helical_gear'
         else
            write (error_unit, '(a)') "trainsim: gear: error: '"//mesh_id//"' is not a spur_gear or helical_gear of "//deck_file
         end if
         call quit(2)
      end if
      select type (e => model%elements(found)%e)
      class is (excited_mesh_t)
         if (len(out) == 0) then
            call write_table(e, points, output_unit, .true.)
         else
            open (newunit=u, file=out, status='replace', action='write', iostat=ios)
            if (ios /= 0) then
               write (error_unit, '(a)') "trainsim: gear: error: cannot write '"//out//"'"
               call quit(2)
            end if
            call write_table(e, points, u, .true.)
            close (u)
            call write_table(e, points, output_unit, .false.)
            write (output_unit, '(a)') 'table written to '//out
         end if
      end select
      if (len(plot) == 0) call quit(0)
      script = find_script('trainsim_mesh_plot.py')
      if (len(script) == 0) then
         write (error_unit, '(a)') 'trainsim: gear: error: cannot find trainsim_mesh_plot.py'
         call quit(2)
      end if
      python = env_text('TRAINSIM_PYTHON')
      if (len(python) == 0) python = '/usr/bin/python3'
      flush (output_unit)
      call execute_command_line(quoted(python)//' '//quoted(script)//' '//quoted(out)//' -o '//quoted(plot), &
                                exitstat=stat, cmdstat=cstat)
      if (cstat /= 0) then
         write (error_unit, '(a)') 'trainsim: gear: error: cannot run '//python//' '//script
         call quit(2)
      end if
      call quit(stat)
   end subroutine do_gear_mesh

   !> The summary ('#' lines) and, if rows, the table: u, pairs, k c(u), c(u),
   !> loaded TE, unloaded TE, at `points` roll positions a tooth over the period.
   subroutine write_table(e, points, unit, rows)
      class(excited_mesh_t), intent(in) :: e
      integer, intent(in) :: points, unit
      logical, intent(in) :: rows
      real(wp) :: period, u, c, te, tu, cmin, cmax, csum, emin, emax, umin, umax
      integer :: j, n, pairs
      period = e%ex%hunting_period()
      n = int(min(real(max_rows, wp), period*points))
      cmin = huge(1.0_wp); cmax = -cmin; csum = 0.0_wp
      emin = huge(1.0_wp); emax = -emin; umin = emin; umax = -emin
      do j = 0, n - 1
         u = period*(j + 0.5_wp)/n
         call e%mesh_at_roll(u, c, te, tu, pairs)
         cmin = min(cmin, c); cmax = max(cmax, c); csum = csum + c
         emin = min(emin, te); emax = max(emax, te); umin = min(umin, tu); umax = max(umax, tu)
      end do
      write (unit, '(a)') '# mesh '//e%id//': stiffness_model = '//e%stiffness_name()
      write (unit, '(a, es15.7)') '# stiffness k (force/length)          ', e%cl%law%k
      write (unit, '(a, 3es15.7)') '# k c(u): mean, min, max             ', e%cl%law%k*csum/n, e%cl%law%k*cmin, &
         e%cl%law%k*cmax
      write (unit, '(a, f15.1)') '# period (mesh cycles, teeth)         ', period
      write (unit, '(a, 3es15.7)') '# loaded static TE: min, max, p-p    ', emin, emax, emax - emin
      write (unit, '(a, 3es15.7)') '# unloaded static TE: min, max, p-p  ', umin, umax, umax - umin
      if (.not. rows) return
      write (unit, '(a)') '# u (teeth), pairs, k c(u), c(u), TE loaded, TE unloaded'
      do j = 0, n - 1
         u = period*real(j, wp)/n
         call e%mesh_at_roll(u, c, te, tu, pairs)
         write (unit, '(es24.16, i6, 4es24.16)') u, pairs, e%cl%law%k*c, c, te, tu
      end do
   end subroutine write_table
end module trainsim_cmd_mesh
