!> trainsim runup: a speed ramp through a range of mesh frequencies with the mesh's TE
!> and force tracked in mesh orders, into a file plot_sweep.py draws as a sweep (D-109).
!> The range comes from the deck's &runup group, or the options (which win).
module trainsim_cmd_runup
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_kinds, only: wp, two_pi
   use trainsim_quasi_static, only: mesh_period_angle
   use trainsim_error, only: error_t, err_input
   use trainsim_strings, only: str, string_t, to_lower
   use trainsim_version, only: version_full
   use trainsim_deck, only: deck_t, deck_group_t, read_deck
   use trainsim_model, only: model_t
   use trainsim_overrides, only: split_sweep_groups, describe_overrides
   use trainsim_prepare, only: prepare_model_in_place
   use trainsim_sweep, only: default_sweep_path
   use trainsim_simulate, only: simulate
   use trainsim_observer, only: run_result_t
   use trainsim_runup, only: runup_spec_t, runup_sink_t, prepare_runup, runup_mesh, ramp_static_reference
   use trainsim_rattle, only: rattle_mesh
   use trainsim_runup_file, only: runup_file_info_t, write_runup_file
   use trainsim_interrupt, only: install_interrupt_handlers
   use trainsim_cli, only: nargs, arg, quit, fail, add_set, real_value, text_value, deck_path, sets
   implicit none
   private

   public :: do_runup

   !> What names each value in a message: the &runup key's place or the option.
   type :: places_t
      character(len=:), allocatable :: mesh, from, to, rate
   end type places_t

contains

   !> trainsim runup DECK [--from F1] [--to F2] [--rate R] [--mesh ID] [--settle N] [--cycles M]
   !> [--set ...] [-o FILE]
   subroutine do_runup()
      type(model_t) :: model
      type(runup_spec_t) :: spec, opt
      type(places_t) :: at
      type(runup_sink_t) :: sink
      type(run_result_t) :: res
      type(runup_file_info_t) :: info
      type(error_t), allocatable :: err
      type(string_t), allocatable :: torque_at(:)
      character(len=:), allocatable :: out
      logical :: given(6)
      character(len=256) :: text(4)   ! the options' values as given
      real(wp) :: t_a, x
      integer :: i, ie
      deck_path = ''
      out = ''
      allocate (sets(0))
      given = .false.
      opt%mesh = ''
      text = ''
      i = 2
      do while (i <= nargs)
         select case (arg(i))
         case ('-h', '--help')
            call runup_usage(output_unit)
            call quit(0)
         case ('-o', '--output')
            out = text_value(i)
            i = i + 1
         case ('--from')
            opt%f_from = real_value(i); given(1) = .true.; text(1) = arg(i + 1); i = i + 1
         case ('--to')
            opt%f_to = real_value(i); given(2) = .true.; text(2) = arg(i + 1); i = i + 1
         case ('--rate')
            opt%rate = real_value(i); given(3) = .true.; text(3) = arg(i + 1); i = i + 1
         case ('--mesh')
            opt%mesh = text_value(i); given(4) = .true.; i = i + 1
         case ('--settle')
            opt%settle_cycles = real_value(i); given(5) = .true.; i = i + 1
            if (.not. (opt%settle_cycles >= 0.0_wp .and. opt%settle_cycles <= 1.0e9_wp)) &
               call refuse('option --settle needs the mesh cycles held before the ramp (>= 0), got '//arg(i))
         case ('--cycles')
            x = real_value(i); given(6) = .true.; i = i + 1
            if (.not. (x >= 1.0_wp .and. x <= 1.0e6_wp .and. x == aint(x))) &
               call refuse('option --cycles needs a whole number of mesh cycles per block from 1 to 1000000, got '//arg(i))
            opt%block_cycles = nint(x)
         case ('--set')
            call add_set(i)
            i = i + 1
         case default
            if (index(arg(i), '-') == 1 .or. len(deck_path) > 0) &
               call refuse("unexpected argument '"//arg(i)//"' (try trainsim runup --help)")
            deck_path = arg(i)
         end select
         i = i + 1
      end do
      if (len(deck_path) == 0) call refuse('runup needs a deck file (try trainsim runup --help)')
      if (len(out) == 0) out = default_path(deck_path)
      call install_interrupt_handlers()

      call load_runup_deck(deck_path, model, spec, at, torque_at)
      if (len(at%from) == 0 .and. .not. all(given(1:3))) call refuse(deck_path//': error: a run-up needs its '// &
         'range: give --from, --to and --rate, or a &runup group (from, to, rate)')
      if (given(1)) then; spec%f_from = opt%f_from; at%from = 'option --from '//trim(text(1)); end if
      if (given(2)) then; spec%f_to = opt%f_to; at%to = 'option --to '//trim(text(2)); end if
      if (given(3)) then; spec%rate = opt%rate; at%rate = 'option --rate '//trim(text(3)); end if
      if (given(4)) then; spec%mesh = opt%mesh; at%mesh = 'option --mesh '//opt%mesh; end if
      if (given(5)) spec%settle_cycles = opt%settle_cycles
      if (given(6)) spec%block_cycles = opt%block_cycles
      call runup_mesh(model, spec%mesh, at%mesh, ie, err)
      if (allocated(err)) call fail_at(err)
      call prepare_runup(model, ie, spec, at%from, at%to, at%rate, t_a, err, torque_at)
      if (allocated(err)) call fail_at(err)

      sink%el = ie
      sink%drv = model%elements(ie)%e%left
      sink%teeth = two_pi/mesh_period_angle(model, ie)
      sink%t_track = t_a
      sink%t_grid = model%run%t_start
      sink%dout = model%run%output_interval
      if (.not. sink%dout > 0.0_wp) sink%dout = model%run%dt
      sink%block_cycles = spec%block_cycles
      sink%rc = rattle_mesh(model, ie)
      write (output_unit, '(a)') 'trainsim '//version_full()//': run-up of '//deck_path//" (mesh '"// &
         model%elements(ie)%e%id//"'): "//str(spec%f_from)//' to '//str(spec%f_to)//' teeth/s at '// &
         str(spec%rate)//' teeth/s^2 after '//str(spec%settle_cycles)//' cycles at '//str(spec%f_from)// &
         '; t_end = '//str(model%run%t_end)//' s'
      flush (output_unit)
      call simulate(model, sink, res, err)
      if (allocated(err)) call fail(err)
      call ramp_static_reference(model, sink)   ! Kv of each block at its own load (D-135)

      info%title = model%title
      info%deck_file = deck_path
      info%units = model%units%name
      info%overrides = describe_overrides(sets)
      info%version = version_full()
      info%mesh_id = model%elements(ie)%e%id
      info%mesh_type = model%elements(ie)%e%type_name
      allocate (info%node_ids(size(model%nodes)), info%node_types(size(model%nodes)))
      do i = 1, size(model%nodes)
         info%node_ids(i)%s = model%nodes(i)%n%id
         info%node_types(i)%s = model%nodes(i)%n%type_name
      end do
      call write_runup_file(out, info, spec, sink%blocks, err)
      if (allocated(err)) call fail(err)
      write (output_unit, '(a)') 'run-up: '//str(sink%blocks%n)//' blocks of '//str(spec%block_cycles)// &
         ' mesh cycles, '//str(real(res%stats%steps, wp), 12)//' steps, '//str(res%stats%wall_time, 3)//' s; results in '//out
      call quit(0)
   contains
      !> An error about an option names the option (not the deck); others as `fail`.
      subroutine fail_at(e)
         type(error_t), intent(in) :: e
         if (index(e%message, 'option ') /= 1) call fail(e)
         write (error_unit, '(a)') 'trainsim: runup: '//e%message
         call quit(2)
      end subroutine fail_at

      subroutine refuse(text)
         character(len=*), intent(in) :: text
         write (error_unit, '(a)') 'trainsim: runup: error: '//text
         call quit(2)
      end subroutine refuse
   end subroutine do_runup

   !> The deck with its &runup group (at most one) read into spec and taken out, its
   !> &sweep groups ignored, the --set overrides applied, the model built. torque_at: per
   !> node, where the deck drives it by a torque (its first such &load group; '' none).
   subroutine load_runup_deck(path, model, spec, at, torque_at)
      character(len=*), intent(in) :: path
      type(model_t), intent(out) :: model
      type(runup_spec_t), intent(out) :: spec
      type(places_t), intent(out) :: at
      type(string_t), allocatable, intent(out) :: torque_at(:)
      type(deck_t) :: deck
      type(deck_group_t), allocatable :: sweeps(:)
      type(error_t), allocatable :: err
      logical, allocatable :: is_runup(:)
      integer :: i, k
      at%mesh = path; at%from = ''; at%to = 'option --to'; at%rate = 'option --rate'
      spec%mesh = ''
      call read_deck(path, deck, err)
      if (allocated(err)) call fail(err)
      allocate (is_runup(size(deck%groups)))
      do i = 1, size(deck%groups)
         is_runup(i) = deck%groups(i)%name == 'runup'
      end do
      if (count(is_runup) > 1) then
         k = findloc(is_runup, .true., dim=1, back=.true.)
         call fail(error_t(deck%groups(k)%where()//': error: a deck has at most one &runup group', err_input))
      end if
      if (any(is_runup)) then
         k = findloc(is_runup, .true., dim=1)
         call read_runup_group(deck%groups(k), spec, at)
         deck%groups = pack(deck%groups, .not. is_runup)
      end if
      call split_sweep_groups(deck, sweeps)
      if (size(sweeps) > 0) write (error_unit, '(a)') 'trainsim: note: '//path//' has '//str(size(sweeps))// &
         ' &sweep group(s); runup ignores them (trainsim sweep runs the sweep)'
      call prepare_model_in_place(deck, sets, model, err)
      if (allocated(err)) call fail(err)
      do i = 1, size(model%warnings)
         write (error_unit, '(a)') 'trainsim: '//model%warnings(i)%s
      end do
      call torque_loads(deck, model, torque_at)
   end subroutine load_runup_deck

   !> Per node of the model, where a &load group of the deck drives it by a torque (quantity
   !> 'torque', the default): its `quantity` key, given or not; '' for none.
   subroutine torque_loads(deck, model, at)
      type(deck_t), intent(inout) :: deck   !< (its groups' keys marked as read)
      type(model_t), intent(in) :: model
      type(string_t), allocatable, intent(out) :: at(:)
      type(error_t), allocatable :: err
      character(len=:), allocatable :: node, quantity
      integer :: i, n
      allocate (at(size(model%nodes)))
      do n = 1, size(at)
         at(n)%s = ''
      end do
      do i = 1, size(deck%groups)
         if (deck%groups(i)%name /= 'load') cycle
         call deck%groups(i)%get_string('node', node, err, default='')
         if (.not. allocated(err)) call deck%groups(i)%get_string('quantity', quantity, err, default='torque')
         if (allocated(err)) cycle
         if (to_lower(quantity) /= 'torque') cycle
         do n = 1, size(at)
            if (model%nodes(n)%n%id /= node .or. len(at(n)%s) > 0) cycle
            at(n)%s = deck%groups(i)%where('quantity')
            if (.not. deck%groups(i)%has('quantity')) at(n)%s = at(n)%s//", key 'quantity' (not given: 'torque')"
         end do
      end do
   end subroutine torque_loads

   !> &runup mesh = 'ID', from = F1, to = F2, rate = R, settle_cycles = N, block_cycles = M /
   subroutine read_runup_group(g, spec, at)
      type(deck_group_t), intent(inout) :: g
      type(runup_spec_t), intent(inout) :: spec
      type(places_t), intent(inout) :: at
      type(error_t), allocatable :: err
      call g%get_string('mesh', spec%mesh, err, default='')
      if (.not. allocated(err)) call g%get_real('from', spec%f_from, err)
      if (.not. allocated(err)) call g%get_real('to', spec%f_to, err)
      if (.not. allocated(err)) call g%get_real('rate', spec%rate, err)
      if (.not. allocated(err)) call g%get_real('settle_cycles', spec%settle_cycles, err, default=100.0_wp)
      if (.not. allocated(err)) call g%get_int('block_cycles', spec%block_cycles, err, default=20)
      if (.not. allocated(err)) call g%check_unused(err)
      if (allocated(err)) call fail(err)
      at%mesh = g%where('mesh'); at%from = g%where('from'); at%to = g%where('to'); at%rate = g%where('rate')
      if (.not. (spec%settle_cycles >= 0.0_wp)) &
         call fail(error_t(g%where('settle_cycles')//': error: settle_cycles must be >= 0, got '// &
                           str(spec%settle_cycles), err_input))
      if (spec%block_cycles < 1) &
         call fail(error_t(g%where('block_cycles')//': error: block_cycles must be >= 1, got '// &
                           str(spec%block_cycles), err_input))
   end subroutine read_runup_group

   !> trainsim runup --help.
   subroutine runup_usage(unit)
      integer, intent(in) :: unit
      write (unit, '(a)') 'usage: trainsim runup DECK [--from F1 --to F2 --rate R] [--mesh ID] [--settle N] [--cycles M]', &
         '                      [--set TARGET.KEY=VALUE ...] [-o FILE]', '', &
         'A run-up: the gear mesh''s driver held at F1 teeth/s for N mesh cycles, then its prescribed', &
         'speeds on a linear ramp to F2 at R teeth/s^2; its transmission error and mesh force tracked at', &
         'mesh orders 0..4 over blocks of M whole mesh cycles, one point per block against the block''s', &
         'mesh frequency, into a file in the sweep file''s layout (default DECK_runup.h5): plot_sweep.py', &
         'draws it, beside a sweep (docs/sweeps.md, "Run-up"). The deck''s &runup group gives the same', &
         'keys (mesh, from, to, rate, settle_cycles, block_cycles); the options win.', '', &
         '  --from F1, --to F2 the range, teeth/s (> 0; F2 < F1: a run-down)', &
         '  --rate R           |df/dt|, teeth/s^2 (> 0)', &
         '  --mesh ID          the gear mesh (default: the first)', &
         '  --settle N         mesh cycles at F1 before the ramp (default 100)', &
         '  --cycles M         mesh cycles per block (default 20)', &
         '  -o FILE            the run-up file', &
         '  -h, --help         this text', '', &
         'exit status: 0 success, 1 the run failed (numerics), 2 bad input or file'
   end subroutine runup_usage

   !> Default run-up file: the deck's base name with `_runup.h5` (as a sweep's, `_sweep.h5`).
   function default_path(path) result(p)
      character(len=*), intent(in) :: path
      character(len=:), allocatable :: p
      p = default_sweep_path(path)
      p = p(1:len(p) - len('_sweep.h5'))//'_runup.h5'
   end function default_path
end module trainsim_cmd_runup
