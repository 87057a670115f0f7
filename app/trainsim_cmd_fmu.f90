!> trainsim fmu DECK -o TRAIN.fmu [--input NODE ...] [--fmi 3|2]: the train of DECK as
!> an FMI 3.0 (or 2.0) co-simulation FMU (docs/fmu.md). The deck is read and built here (bad input
!> is refused as for `trainsim run`), its variables listed in a JSON file, and
!> scripts/trainsim_fmu.py writes modelDescription.xml and packs the deck, its table
!> files and the binary (build/fmu or <prefix>/lib/.../trainsim/fmu) into the FMU.
module trainsim_cmd_fmu
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str, string_t
   use trainsim_deck, only: deck_t, deck_group_t, read_deck, parse_real
   use trainsim_model, only: model_t
   use trainsim_overrides, only: split_sweep_groups
   use trainsim_prepare, only: prepare_model
   use trainsim_fs, only: process_id
   use trainsim_version, only: version_full
   use trainsim_cli, only: nargs, sets, arg, quit, fail, text_value
   use trainsim_cmd_help, only: command_usage
   use trainsim_cmd_scripts, only: find_script, exe_dir, env_text, quoted
   use trainsim_session_inputs, only: input_of, check_input, input_start_value
   implicit none
   private

   public :: do_fmu

   !> &run keys that are not FMU parameters: the experiment's own times, the output
   !> (an FMU has no history file) and the settling (a run's metrics).
   !> quoted keys that are not FMU parameters: the train's topology, units, names and files
   character(len=*), parameter :: not_text_parameters(*) = [character(len=16) :: 'id', 'type', 'node', 'left', &
      'right', 'carrier', 'units', 'title', 'output', 'initial_state', 'continuation', 'parameter']
   character(len=*), parameter :: kind_name(3) = [character(len=7) :: 'torque', 'speed', 'voltage']
   character(len=*), parameter :: not_parameters(*) = [character(len=16) :: 't_start', 't_end', &
      'output_interval', 'settle_time', 'settle_tol', 'settle_cycles', 'measure_cycles']

contains

   subroutine do_fmu()
      character(len=:), allocatable :: deck_file, out, path, script, python, line, fmi
      type(string_t), allocatable :: inputs(:)
      type(deck_t) :: deck
      type(deck_group_t), allocatable :: sweeps(:)
      type(model_t) :: model
      type(error_t), allocatable :: err
      integer :: k, u, ios, stat, cstat, i
      deck_file = ''
      out = ''
      fmi = '3'
      allocate (sets(0), inputs(0))
      k = 2
      do while (k <= nargs)
         select case (arg(k))
         case ('-h', '--help')
            call command_usage('fmu', output_unit)
            call quit(0)
         case ('-o', '--output'); out = text_value(k); k = k + 1
         case ('--input'); call append(inputs, text_value(k)); k = k + 1
         case ('--fmi')
            fmi = text_value(k)
            k = k + 1
            if (fmi /= '2' .and. fmi /= '3') then
               write (error_unit, '(a)') "trainsim: fmu: error: --fmi '"//fmi//"': the FMI version is 3 or 2"
               call quit(2)
            end if
         case default
            if (index(arg(k), '-') == 1 .or. len(deck_file) > 0) then
               write (error_unit, '(a)') "trainsim: fmu: error: unexpected argument '"//arg(k)//"' (try trainsim fmu --help)"
               call quit(2)
            end if
            deck_file = arg(k)
         end select
         k = k + 1
      end do
      if (len(deck_file) == 0 .or. len(out) < 5) then
         write (error_unit, '(a)') 'trainsim: fmu: error: needs a deck and -o TRAIN.fmu (try trainsim fmu --help)'
         call quit(2)
      end if
      if (out(len(out) - 3:) /= '.fmu') then
         write (error_unit, '(a)') "trainsim: fmu: error: output '"//out//"' must end in .fmu"
         call quit(2)
      end if
      script = find_script('trainsim_fmu.py')
      if (len(script) == 0) then
         write (error_unit, '(a)') 'trainsim: fmu: error: cannot find trainsim_fmu.py (looked in $TRAINSIM_SCRIPTS, '// &
            '<prefix>/share/trainsim/scripts and <build>/../scripts beside the executable)'
         call quit(2)
      end if
      call read_deck(deck_file, deck, err)
      if (allocated(err)) call fail(err)
      call deck_inputs(deck, inputs)
      call split_sweep_groups(deck, sweeps)   ! an FMU of a sweep deck is of its own values
      call prepare_model(deck, sets, model, err)
      if (allocated(err)) call fail(err)
      do i = 1, size(inputs)
         call check_fmu_input(model, inputs(i)%s)
      end do

      path = env_text('TMPDIR')
      if (len(path) == 0) path = '/tmp'
      path = path//'/trainsim-fmu-'//str(process_id())//'.json'
      open (newunit=u, file=path, status='replace', action='write', iostat=ios)
      if (ios /= 0) then
         write (error_unit, '(a)') "trainsim: fmu: error: cannot write '"//path//"'"
         call quit(2)
      end if
      call write_variables(u, deck, model, deck_file, inputs)
      close (u)
      python = env_text('TRAINSIM_PYTHON')
      if (len(python) == 0) python = '/usr/bin/python3'
      line = quoted(python)//' '//quoted(script)//' '//quoted(path)//' -o '//quoted(out)//' --exe-dir '//quoted(exe_dir())//' --fmi '//fmi
      flush (output_unit)
      call execute_command_line(line, exitstat=stat, cmdstat=cstat)
      open (newunit=u, file=path, status='old', iostat=ios)
      if (ios == 0) close (u, status='delete')
      if (cstat /= 0) then
         write (error_unit, '(a)') 'trainsim: fmu: error: cannot run '//python//' '//script
         call quit(2)
      end if
      call quit(stat)
   end subroutine do_fmu

   !> The input nodes the deck names in its &fmu group (`inputs = 'n4', 'n2'`), after
   !> those of --input; any other key of &fmu, or a second &fmu, is refused (exit 2).
   subroutine deck_inputs(deck, inputs)
      type(deck_t), intent(in) :: deck
      type(string_t), allocatable, intent(inout) :: inputs(:)
      integer :: i, j, k, n
      n = 0
      do i = 1, size(deck%groups)
         associate (g => deck%groups(i))
            if (g%name /= 'fmu') cycle
            n = n + 1
            if (n > 1) then
               write (error_unit, '(a)') g%file//':'//str(g%line)//": error: &fmu: a deck has one &fmu group"
               call quit(2)
            end if
            do j = 1, g%nentries()
               if (g%key_of(j) /= 'inputs') then
                  write (error_unit, '(a)') g%file//':'//str(g%entries(j)%line)//": error: &fmu: unknown key '"// &
                     g%key_of(j)//"'; the keys of &fmu are: inputs"
                  call quit(2)
               end if
               do k = 1, g%nvalues(j)
                  if (.not. listed(inputs, g%value_of(j, k))) call append(inputs, g%value_of(j, k))
               end do
            end do
         end associate
      end do
   end subroutine deck_inputs

   !> list with s appended (a new element, the old ones moved).
   subroutine append(list, s)
      type(string_t), allocatable, intent(inout) :: list(:)
      character(len=*), intent(in) :: s
      type(string_t), allocatable :: more(:)
      integer :: i
      allocate (more(size(list) + 1))
      do i = 1, size(list)
         call move_alloc(list(i)%s, more(i)%s)
      end do
      more(size(more))%s = s
      call move_alloc(more, list)
   end subroutine append

   logical function listed(list, s)
      type(string_t), intent(in) :: list(:)
      character(len=*), intent(in) :: s
      integer :: i
      listed = .false.
      do i = 1, size(list)
         if (list(i)%s == s) listed = .true.
      end do
   end function listed

   !> An input (NODE or NODE.tau, NODE.speed, NODE.voltage) the session can take
   !> (trainsim_session_inputs: a torque on a node that moves, a speed where the deck
   !> prescribes a motion, a voltage on a DC motor without a controller); else exit 2.
   subroutine check_fmu_input(model, name)
      type(model_t), intent(in) :: model
      character(len=*), intent(in) :: name
      character(len=:), allocatable :: node
      type(error_t), allocatable :: err
      integer :: kind
      call input_of(name, node, kind)
      call check_input(model, model%node_index(node), node, kind, err)
      if (allocated(err)) then
         write (error_unit, '(a)') "trainsim: fmu: error: --input or &fmu inputs '"//name//"': "//err%message
         call quit(2)
      end if
   end subroutine check_fmu_input

   !> The FMU's variables as JSON for trainsim_fmu.py: the nodes (outputs), the input
   !> nodes, the parameters (every number the deck writes in a &node, &element, &load or
   !> &run group, by its path as `--set` takes it), the table files the deck reads.
   subroutine write_variables(u, deck, model, deck_file, inputs)
      integer, intent(in) :: u
      type(deck_t), intent(in) :: deck
      type(model_t), intent(in) :: model
      character(len=*), intent(in) :: deck_file
      type(string_t), intent(in) :: inputs(:)
      integer :: i, j, n_load, kind, n
      character(len=:), allocatable :: sep, group, key, node, text
      real(wp) :: v
      integer :: st
      write (u, '(a)') '{"version": '//js(version_full())//', "deck_file": '//js(deck_file)//', "title": '// &
         js(model%title)//', "torque_unit": '//js(model%units%torque)//','
      write (u, '(a)', advance='no') ' "nodes": ['
      do i = 1, size(model%nodes)
         write (u, '(a)', advance='no') merge(', ', '  ', i > 1)//js(model%nodes(i)%n%id)
      end do
      write (u, '(a)') '],'
      write (u, '(a)', advance='no') ' "elements": ['
      do i = 1, size(model%elements)
         associate (e => model%elements(i)%e)
            if (e%displacement_unit() == 'rad') then
               write (u, '(a)', advance='no') merge(', ', '  ', i > 1)//'{"id": '//js(e%id)//', "disp_unit": "rad", '// &
                  '"force_unit": '//js(model%units%torque)//'}'
            else
               write (u, '(a)', advance='no') merge(', ', '  ', i > 1)//'{"id": '//js(e%id)//', "disp_unit": '// &
                  js(model%units%length)//', "force_unit": '//js(model%units%force)//'}'
            end if
         end associate
      end do
      write (u, '(a)') '],'
      write (u, '(a)', advance='no') ' "inputs": ['
      do i = 1, size(inputs)
         call input_of(inputs(i)%s, node, kind)
         write (u, '(a, es24.16e3, a)', advance='no') merge(', ', '  ', i > 1)//'{"node": '//js(node)// &
            ', "kind": '//js(trim(kind_name(kind)))//', "start": ', &
            input_start_value(model, model%node_index(node), kind, model%run%t_start), '}'
      end do
      write (u, '(a)') '],'
      write (u, '(a)') ' "parameters": ['
      sep = '  '
      n_load = 0
      do i = 1, size(deck%groups)
         associate (g => deck%groups(i))
            group = ''
            select case (g%name)
            case ('node', 'element')
               do j = 1, g%nentries()
                  if (g%key_of(j) == 'id') group = g%value_of(j, 1)
               end do
            case ('load')
               n_load = n_load + 1
               group = 'load#'//str(n_load)
            case ('run')
               group = 'run'
            end select
            if (len(group) == 0) cycle
            do j = 1, g%nentries()
               key = g%key_of(j)
               if (g%nvalues(j) /= 1) cycle
               if (group == 'run' .and. any(not_parameters == key)) cycle
               text = g%value_of(j, 1)
               if (g%quoted(j, 1)) then
                  if (any(not_text_parameters == key) .or. index(key, '_file') > 0 .or. index(text, "'") > 0) cycle
                  write (u, '(a)') sep//'{"path": '//js(group//'.'//key)//', "type": "string", "value": '//js(text)//'}'
               else if (is_int32(text, n)) then
                  write (u, '(a)') sep//'{"path": '//js(group//'.'//key)//', "type": "integer", "value": '// &
                     str(n)//'}'
               else
                  call parse_real(text, v, st)
                  if (st /= 0) cycle
                  write (u, '(a, es24.16e3, a)') sep//'{"path": '//js(group//'.'//key)//', "type": "real", "value": ', &
                     v, '}'
               end if
               sep = ', '
            end do
         end associate
      end do
      write (u, '(a)') ' ],'
      write (u, '(a)', advance='no') ' "table_files": ['
      sep = ''
      do i = 1, size(deck%groups)
         do j = 1, deck%groups(i)%nentries()
            if (deck%groups(i)%key_of(j) /= 'table_file') cycle
            write (u, '(a)', advance='no') sep//js(deck%groups(i)%value_of(j, 1))
            sep = ', '
         end do
      end do
      write (u, '(a)') ']}'
   end subroutine write_variables

   !> Whether text is an integer literal (an optional sign, digits) within Int32's range.
   logical function is_int32(text, n)
      character(len=*), intent(in) :: text
      integer, intent(out) :: n
      integer :: a, ios
      integer(kind=8) :: n8
      n = 0
      a = 1
      if (len(text) > 0) then
         if (text(1:1) == '+' .or. text(1:1) == '-') a = 2
      end if
      is_int32 = len(text) >= a .and. len(text) - a < 10
      if (is_int32) is_int32 = verify(text(a:), '0123456789') == 0
      if (.not. is_int32) return
      n = 0
      read (text, *, iostat=ios) n8
      is_int32 = ios == 0 .and. abs(n8) <= 2147483647_8
      if (is_int32) n = int(n8)
   end function is_int32

   !> A JSON string.
   function js(s) result(q)
      character(len=*), intent(in) :: s
      character(len=:), allocatable :: q
      integer :: k
      q = '"'
      do k = 1, len(s)
         select case (s(k:k))
         case ('"', '\')
            q = q//'\'//s(k:k)
         case default
            if (iachar(s(k:k)) < 32) then
               q = q//' '
            else
               q = q//s(k:k)
            end if
         end select
      end do
      q = q//'"'
   end function js

end module trainsim_cmd_fmu
