!> Working precision and the few numeric constants every module shares.
module trainsim_kinds
   use, intrinsic :: iso_fortran_env, only: real64, int64
   implicit none
   private

   public :: wp, i8, pi, two_pi

   !> Working precision for all physics (matches c_double at the SUNDIALS boundary).
   integer, parameter :: wp = real64
   !> 64-bit integer for counters.
   integer, parameter :: i8 = int64
   real(wp), parameter :: pi = 3.141592653589793238462643383279502884_wp
   real(wp), parameter :: two_pi = 2.0_wp*pi
end module trainsim_kinds
