!> What every command of the program shares: the command line (the command, its
!> arguments, the deck, the --set overrides, --strict), how the program ends (`quit`
!> with an exit status, `fail` with an error's message), reading the option values of
!> the calculators, and loading a deck into a model. Only the program prints and
!> chooses exit codes (errors are values in the library).
module trainsim_cli
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use, intrinsic :: iso_c_binding, only: c_int
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, err_numeric, err_interrupted, err_input
   use trainsim_interrupt, only: interrupt_signal, signal_name
   use trainsim_strings, only: str
   use trainsim_deck, only: deck_t, deck_group_t, read_deck, parse_real
   use trainsim_model, only: model_t
   use trainsim_hdf5, only: hdf5_library_stuck
   use trainsim_overrides, only: override_t, parse_set_argument, split_sweep_groups
   use trainsim_prepare, only: prepare_model_in_place
   use trainsim_preload, only: preload_info_t
   use trainsim_sweep, only: finish_sweep
   implicit none
   private

   public :: cmd, deck_path, nargs, sets, strict
   public :: arg, quit, fail, add_set, add_preload, load, real_value, text_value

   !> The command (run, sweep, modes, gear, ...), the number of arguments, the deck
   !> (allocated once a deck command reads its arguments: `fail` then names it).
   character(len=:), allocatable :: cmd, deck_path
   integer :: nargs = 0
   type(override_t), allocatable :: sets(:)   ! --set TARGET.KEY=VALUE, in order
   logical :: strict = .false.                ! --strict: plausibility warnings are errors
   !> The groups of the deck `load` read, kept until the process ends: each command loads
   !> once and quits after its print-out (D-140), and freeing them, ~16 allocations a
   !> node or element, cost 5 % of a shaft chain's start-up (D-151).
   type(deck_group_t), allocatable :: loaded_groups(:)

   interface
      !> POSIX _exit(2): ends the process without exit handlers (see quit).
      subroutine c_exit_now(status) bind(C, name='_exit')
         import :: c_int
         integer(c_int), value :: status
      end subroutine c_exit_now
   end interface

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

   !> End the program with exit status `code`, output flushed. When HDF5 holds a file
   !> it could not close (a full disk), its exit handler would crash: end without it.
   !> `silent`: as the program's own end, without gfortran's note of the IEEE flags
   !> raised, which a `stop` prints (for a command ending early, D-139).
   subroutine quit(code, silent)
      integer, intent(in) :: code
      logical, intent(in), optional :: silent
      flush (output_unit)
      flush (error_unit)
      call finish_sweep()     ! after the outcome is out (a stopping mpirun never completes it)
      if (hdf5_library_stuck()) call c_exit_now(int(code, c_int))
      if (present(silent)) then
         if (silent) stop code, quiet=.true.
      end if
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
      do i = 1, size(deck%groups)
         if (deck%groups(i)%named('runup')) write (error_unit, '(a)') 'trainsim: note: '//path// &
            ' has a &runup group; '//cmd//' ignores it (trainsim runup runs the run-up)'
      end do
      call split_sweep_groups(deck, sweeps)   ! (and drops the &runup group)
      if (size(sweeps) > 0) write (error_unit, '(a)') 'trainsim: note: '//path//' has '//str(size(sweeps))// &
         ' &sweep group(s); '//cmd//' ignores them and uses the deck''s own values (trainsim sweep runs the sweep)'
      call prepare_model_in_place(deck, sets, model, err, preload)
      if (allocated(err)) call fail(err)
      if (allocated(loaded_groups)) deallocate (loaded_groups)
      call move_alloc(deck%groups, loaded_groups)   ! not freed: kept until the process ends
      do i = 1, size(model%warnings)
         write (error_unit, '(a)') 'trainsim: '//model%warnings(i)%s
      end do
      if (strict .and. size(model%warnings) > 0) then
         write (error_unit, '(a)') 'trainsim: error: '//str(size(model%warnings))//' plausibility warning(s) '// &
            'above, and --strict makes them errors'
         call quit(2)
      end if
   end subroutine load

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
end module trainsim_cli
