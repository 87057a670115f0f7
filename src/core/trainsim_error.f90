!> Errors as values: library code returns an allocated error_t and never stops.
module trainsim_error
   implicit none
   private

   public :: error_t, fatal_error, prefix_error
   public :: err_input, err_io, err_numeric, err_internal, err_interrupted

   integer, parameter :: err_input = 1    !< malformed or non-physical input
   integer, parameter :: err_io = 2       !< missing, unreadable or unwritable file
   integer, parameter :: err_numeric = 3  !< NaN, solver failure, unstable step
   integer, parameter :: err_internal = 4 !< cannot happen
   integer, parameter :: err_interrupted = 5 !< stopped by SIGINT/SIGTERM (trainsim_interrupt)

   !> An error: a human-readable message and a category code.
   type :: error_t
      character(len=:), allocatable :: message
      integer :: code = err_input
   end type error_t

contains

   !> Allocate `err` with `message` (and optional category `code`).
   pure subroutine fatal_error(err, message, code)
      type(error_t), allocatable, intent(out) :: err
      character(len=*), intent(in) :: message
      integer, intent(in), optional :: code
      allocate (err)
      err%message = message
      if (present(code)) err%code = code
   end subroutine fatal_error

   !> Put context (e.g. "deck.nml:12: ") in front of an existing message.
   pure subroutine prefix_error(err, prefix)
      type(error_t), intent(inout) :: err
      character(len=*), intent(in) :: prefix
      err%message = prefix//err%message
   end subroutine prefix_error
end module trainsim_error
