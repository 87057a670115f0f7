!> SIGINT and SIGTERM as a flag: the handler only records the signal, the run loop
!> polls the flag (`signal_caught`, read as a plain variable) once per step and
!> stops with an error value, so the
!> program unwinds normally (`trainsim run`: the history so far kept, marked
!> interrupted, D-46; stdout flushed) and exits with 128 + the signal number.
!>
!> A second signal while the first is still pending restores the default action and
!> re-raises it, so a run stuck where no one polls can still be stopped.
module trainsim_interrupt
   use, intrinsic :: iso_c_binding, only: c_int, c_funptr, c_funloc, c_null_funptr
   implicit none
   private

   public :: install_interrupt_handlers, interrupt_signal, signal_name, signal_caught
   public :: sigint, sigterm

   integer(c_int), parameter :: sigint = 2    !< POSIX signal numbers
   integer(c_int), parameter :: sigterm = 15

   !> Signal received, 0 if none (written only by the handler; an int is what C's
   !> sig_atomic_t is on every platform trainsim builds on). Read-only outside:
   !> the run loop polls it as a variable (a load per step, no call).
   integer(c_int), volatile, protected, save :: signal_caught = 0

   interface
      !> C signal(3); glibc gives BSD semantics (the handler stays installed).
      function c_signal(signum, handler) bind(C, name='signal') result(previous)
         import :: c_int, c_funptr
         integer(c_int), value :: signum
         type(c_funptr), value :: handler
         type(c_funptr) :: previous
      end function c_signal
      !> C raise(3).
      function c_raise(signum) bind(C, name='raise') result(rc)
         import :: c_int
         integer(c_int), value :: signum
         integer(c_int) :: rc
      end function c_raise
   end interface

contains

   !> Catch SIGINT and SIGTERM from now on (for `trainsim run`).
   subroutine install_interrupt_handlers()
      type(c_funptr) :: previous
      signal_caught = 0
      previous = c_signal(sigint, c_funloc(on_signal))
      previous = c_signal(sigterm, c_funloc(on_signal))
   end subroutine install_interrupt_handlers

   !> The signal that asked the program to stop (sigint or sigterm), 0 if none.
   integer function interrupt_signal()
      interrupt_signal = int(signal_caught)
   end function interrupt_signal

   !> "SIGINT", "SIGTERM" or "signal N".
   function signal_name(signum) result(name)
      integer, intent(in) :: signum
      character(len=:), allocatable :: name
      character(len=12) :: buf
      select case (signum)
      case (sigint)
         name = 'SIGINT'
      case (sigterm)
         name = 'SIGTERM'
      case default
         write (buf, '(i0)') signum
         name = 'signal '//trim(buf)
      end select
   end function signal_name

   !> The handler: async-signal-safe (an assignment; signal and raise are safe).
   subroutine on_signal(signum) bind(C)
      integer(c_int), value :: signum
      type(c_funptr) :: previous
      integer(c_int) :: rc
      if (signal_caught /= 0) then
         previous = c_signal(signum, c_null_funptr)   ! SIG_DFL
         rc = c_raise(signum)
         return
      end if
      signal_caught = signum
   end subroutine on_signal
end module trainsim_interrupt
