!> The commands run by Python scripts: trainsim diagram (the deck read and built here,
!> drawn by scripts/trainsim_diagram.py), trainsim export and trainsim plot.
module trainsim_cmd_scripts
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use, intrinsic :: iso_c_binding, only: c_char, c_long, c_size_t, c_null_char
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_deck, only: deck_t, deck_group_t, read_deck
   use trainsim_model, only: model_t
   use trainsim_overrides, only: split_sweep_groups
   use trainsim_prepare, only: prepare_model
   use trainsim_describe, only: write_description
   use trainsim_fs, only: process_id
   use trainsim_cli, only: cmd, nargs, sets, arg, quit, fail, add_set, text_value
   use trainsim_cmd_help, only: command_usage
   implicit none
   private

   public :: do_diagram, do_script
   public :: find_script, exe_dir, env_text, quoted   ! (trainsim_cmd_fmu)

   interface
      !> POSIX readlink(2) (ssize_t is a C long on the 64-bit Linux targets).
      function c_readlink(path, buf, n) bind(C, name='readlink') result(r)
         import :: c_char, c_long, c_size_t
         character(kind=c_char), intent(in) :: path(*)
         character(kind=c_char), intent(out) :: buf(*)
         integer(c_size_t), value :: n
         integer(c_long) :: r
      end function c_readlink
   end interface

contains

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
         path = path//'/trainsim-diagram-'//str(process_id())//'.json'
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
      if (st /= 0 .or. n == 0) then
         v = ''
         return
      end if
      allocate (character(len=n) :: v)   ! (not after v = '': a set variable ended in a runtime error)
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
end module trainsim_cmd_scripts
