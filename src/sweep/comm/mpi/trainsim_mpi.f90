!> The only MPI module (mpi_f08): the few messages of a sweep's dynamic load
!> balancing. Rank 0 hands out run indices and receives each run's record; the
!> other ranks ask for work, run it and send the record back. Built when CMake
!> finds MPI; otherwise comm/serial/trainsim_mpi.f90 has the same interface.
module trainsim_mpi
   use, intrinsic :: iso_fortran_env, only: real64
   use, intrinsic :: iso_c_binding, only: c_char, c_int, c_null_char
   use mpi_f08
   implicit none
   private

   interface
      function c_setenv(name, value, overwrite) bind(C, name='setenv') result(rc)
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: name(*), value(*)
         integer(c_int), value :: overwrite
         integer(c_int) :: rc
      end function c_setenv
   end interface

   public :: comm_available, comm_init, comm_finalize, comm_rank, comm_size
   public :: comm_send_record, comm_poll_record, comm_stop_polling, comm_send_index, comm_recv_index
   public :: comm_bcast_int, comm_bcast_reals, comm_sum_reals, comm_min_int

   !> True in the MPI build.
   logical, parameter :: comm_available = .true.

   integer, parameter :: tag_record = 11, tag_message = 12, tag_index = 13

   !> Whether comm_init called MPI_Init (then comm_finalize calls MPI_Finalize).
   logical, save :: started_here = .false.
   !> Whether MPI is in use (else one rank, no MPI calls).
   logical, save :: use_mpi = .false.

   !> Rank 0's receive of the next record, posted in advance (MPI_Irecv from any
   !> source), so that a poll is one MPI_Test: no probe, no unexpected-message copy.
   real(real64), allocatable, asynchronous, save :: pending_buf(:)
   type(MPI_Request), save :: pending_req
   logical, save :: posted = .false.

contains

   !> Start MPI. A program that no MPI launcher started (no OMPI_COMM_WORLD_SIZE,
   !> PMIX_RANK, PMI_RANK or PMI_SIZE in its environment) is one rank without MPI: Open
   !> MPI's singleton MPI_Init starts a runtime server of its own, about 0.4 s.
   subroutine comm_init(err)
      character(len=:), allocatable, intent(out) :: err   !< set if MPI cannot be used
      logical :: flag
      err = ''
      call MPI_Initialized(flag)
      if (.not. flag) then
         if (.not. launched()) return
         call prefer_shared_memory()
         call MPI_Init()
         started_here = .true.
      end if
      use_mpi = .true.
   end subroutine comm_init

   !> Open MPI, all ranks on one machine, no pml chosen by the user: choose `ob1` (shared
   !> memory through the `vader` transport), as Open MPI would after probing the others.
   !> Its probing of UCX and the OFI/PSM transports took 0.2 s of MPI_Init's 0.23 s on
   !> this machine (0.03 s with ob1). Every rank sees the same environment, so all choose
   !> alike; across machines (local size < size) Open MPI chooses, as before.
   subroutine prefer_shared_memory()
      character(len=32) :: size_all, size_local
      integer :: s1, s2, s3, rc
      call get_environment_variable('OMPI_COMM_WORLD_SIZE', size_all, status=s1)
      call get_environment_variable('OMPI_COMM_WORLD_LOCAL_SIZE', size_local, status=s2)
      call get_environment_variable('OMPI_MCA_pml', status=s3)
      if (s1 /= 0 .or. s2 /= 0 .or. s3 /= 1) return      ! (status 1: not set)
      if (trim(size_all) /= trim(size_local)) return
      rc = c_setenv('OMPI_MCA_pml'//c_null_char, 'ob1'//c_null_char, 0_c_int)
   end subroutine prefer_shared_memory

   !> Whether an MPI launcher (mpirun, mpiexec, srun) started this process.
   logical function launched()
      character(len=*), parameter :: names(4) = [character(len=20) :: 'OMPI_COMM_WORLD_SIZE', 'PMIX_RANK', &
                                                 'PMI_RANK', 'PMI_SIZE']
      integer :: i, stat
      launched = .false.
      do i = 1, size(names)
         call get_environment_variable(trim(names(i)), status=stat)
         if (stat == 0) launched = .true.
      end do
   end function launched

   subroutine comm_finalize()
      logical :: flag
      call comm_stop_polling()
      use_mpi = .false.
      if (.not. started_here) return
      call MPI_Finalized(flag)
      if (.not. flag) call MPI_Finalize()
      started_here = .false.
   end subroutine comm_finalize

   integer function comm_rank() result(r)
      r = 0
      if (use_mpi) call MPI_Comm_rank(MPI_COMM_WORLD, r)
   end function comm_rank

   integer function comm_size() result(n)
      n = 1
      if (use_mpi) call MPI_Comm_size(MPI_COMM_WORLD, n)
   end function comm_size

   !> Worker -> rank 0: a run's record (numbers) and its message.
   subroutine comm_send_record(buf, message)
      real(real64), intent(in) :: buf(:)
      character(len=*), intent(in) :: message
      call MPI_Send(buf, size(buf), MPI_DOUBLE_PRECISION, 0, tag_record, MPI_COMM_WORLD)
      call MPI_Send(message, len(message), MPI_CHARACTER, 0, tag_message, MPI_COMM_WORLD)
   end subroutine comm_send_record

   !> Rank 0: receive one waiting record if there is one (never blocks for long: the
   !> message follows its record at once). The first call posts the receive.
   subroutine comm_poll_record(buf, found, source, message)
      real(real64), intent(out) :: buf(:)
      logical, intent(out) :: found
      integer, intent(out) :: source
      character(len=:), allocatable, intent(out) :: message
      type(MPI_Status) :: st
      integer :: n
      source = -1
      if (.not. posted) call post_record(size(buf))
      call MPI_Test(pending_req, found, st)
      if (.not. found) return
      posted = .false.
      source = st%MPI_SOURCE
      buf = pending_buf
      call MPI_Probe(source, tag_message, MPI_COMM_WORLD, st)
      call MPI_Get_count(st, MPI_CHARACTER, n)
      allocate (character(len=n) :: message)
      call MPI_Recv(message, n, MPI_CHARACTER, source, tag_message, MPI_COMM_WORLD, st)
      call post_record(size(buf))
   end subroutine comm_poll_record

   subroutine post_record(n)
      integer, intent(in) :: n
      if (allocated(pending_buf)) then
         if (size(pending_buf) /= n) deallocate (pending_buf)
      end if
      if (.not. allocated(pending_buf)) allocate (pending_buf(n))
      call MPI_Irecv(pending_buf, n, MPI_DOUBLE_PRECISION, MPI_ANY_SOURCE, tag_record, MPI_COMM_WORLD, &
                     pending_req)
      posted = .true.
   end subroutine post_record

   !> Rank 0, when every worker has been told to stop: withdraw the posted receive.
   subroutine comm_stop_polling()
      if (.not. posted) return
      call MPI_Cancel(pending_req)
      call MPI_Wait(pending_req, MPI_STATUS_IGNORE)
      posted = .false.
   end subroutine comm_stop_polling

   !> Rank 0 -> worker: the next run index (0: no more work).
   subroutine comm_send_index(dest, irun)
      integer, intent(in) :: dest, irun
      call MPI_Send(irun, 1, MPI_INTEGER, dest, tag_index, MPI_COMM_WORLD)
   end subroutine comm_send_index

   !> Worker: wait for the next run index from rank 0.
   subroutine comm_recv_index(irun)
      integer, intent(out) :: irun
      call MPI_Recv(irun, 1, MPI_INTEGER, 0, tag_index, MPI_COMM_WORLD, MPI_STATUS_IGNORE)
   end subroutine comm_recv_index

   !> Rank 0's value of v on every rank.
   subroutine comm_bcast_int(v)
      integer, intent(inout) :: v
      if (use_mpi) call MPI_Bcast(v, 1, MPI_INTEGER, 0, MPI_COMM_WORLD)
   end subroutine comm_bcast_int

   !> Rank 0's values of v on every rank (v has the same size everywhere).
   subroutine comm_bcast_reals(v)
      real(real64), intent(inout) :: v(:, :)
      if (use_mpi) call MPI_Bcast(v, size(v), MPI_DOUBLE_PRECISION, 0, MPI_COMM_WORLD)
   end subroutine comm_bcast_reals

   !> Every rank's v summed, on every rank.
   subroutine comm_sum_reals(v)
      real(real64), intent(inout) :: v(:)
      if (use_mpi) call MPI_Allreduce(MPI_IN_PLACE, v, size(v), MPI_DOUBLE_PRECISION, MPI_SUM, MPI_COMM_WORLD)
   end subroutine comm_sum_reals

   !> The smallest of every rank's v, on every rank.
   subroutine comm_min_int(v)
      integer, intent(inout) :: v
      if (use_mpi) call MPI_Allreduce(MPI_IN_PLACE, v, 1, MPI_INTEGER, MPI_MIN, MPI_COMM_WORLD)
   end subroutine comm_min_int
end module trainsim_mpi
