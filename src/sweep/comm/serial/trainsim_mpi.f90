!> Serial stand-in for the MPI module (built when CMake finds no MPI): one rank,
!> no messages. Same interface as comm/mpi/trainsim_mpi.f90.
module trainsim_mpi
   use, intrinsic :: iso_fortran_env, only: real64
   implicit none
   private

   public :: comm_available, comm_init, comm_finalize, comm_rank, comm_size
   public :: comm_send_record, comm_poll_record, comm_stop_polling, comm_send_index, comm_recv_index
   public :: comm_bcast_int, comm_bcast_reals, comm_sum_reals, comm_min_int

   logical, parameter :: comm_available = .false.

contains

   !> Refuse to run as one of several copies started by mpirun: each would write the
   !> same file as "rank 0".
   subroutine comm_init(err)
      character(len=:), allocatable, intent(out) :: err   !< set if MPI cannot be used
      character(len=32) :: v
      integer :: n, stat
      err = ''
      call get_environment_variable('OMPI_COMM_WORLD_SIZE', v, status=stat)
      if (stat /= 0) call get_environment_variable('PMI_SIZE', v, status=stat)
      if (stat /= 0) return
      read (v, *, iostat=stat) n
      if (stat == 0 .and. n > 1) err = 'this trainsim was built without MPI, and mpirun started '// &
         trim(v)//' copies of it; run the sweep without mpirun, or rebuild with MPI'
   end subroutine comm_init

   subroutine comm_finalize()
   end subroutine comm_finalize

   integer function comm_rank() result(r)
      r = 0
   end function comm_rank

   integer function comm_size() result(n)
      n = 1
   end function comm_size

   subroutine comm_send_record(buf, message)
      real(real64), intent(in) :: buf(:)
      character(len=*), intent(in) :: message
      error stop 'trainsim_mpi (serial): comm_send_record with one rank'
   end subroutine comm_send_record

   subroutine comm_poll_record(buf, found, source, message)
      real(real64), intent(out) :: buf(:)
      logical, intent(out) :: found
      integer, intent(out) :: source
      character(len=:), allocatable, intent(out) :: message
      buf = 0.0_real64
      found = .false.
      source = -1
      message = ''
   end subroutine comm_poll_record

   subroutine comm_stop_polling()
   end subroutine comm_stop_polling

   subroutine comm_send_index(dest, irun)
      integer, intent(in) :: dest, irun
      error stop 'trainsim_mpi (serial): comm_send_index with one rank'
   end subroutine comm_send_index

   subroutine comm_recv_index(irun)
      integer, intent(out) :: irun
      irun = 0
      error stop 'trainsim_mpi (serial): comm_recv_index with one rank'
   end subroutine comm_recv_index

   subroutine comm_bcast_int(v)
      integer, intent(inout) :: v
   end subroutine comm_bcast_int

   subroutine comm_bcast_reals(v)
      real(real64), intent(inout) :: v(:, :)
   end subroutine comm_bcast_reals

   !> Every rank's v summed, on every rank.
   subroutine comm_sum_reals(v)
      real(real64), intent(inout) :: v(:)
   end subroutine comm_sum_reals

   !> The smallest of every rank's v, on every rank.
   subroutine comm_min_int(v)
      integer, intent(inout) :: v
   end subroutine comm_min_int
end module trainsim_mpi
