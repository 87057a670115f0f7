!> A run is a library call on a model object with no global state (the sweeps
!> to come rely on it): repeated and interleaved runs in one process give
!> bit-identical results, copies are independent, and HDF5 histories can be
!> written run after run from one process.
program test_library_runs
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_simulate, only: simulate
   use trainsim_hdf5, only: hdf5_sink_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, run_model
   implicit none

   call suite_begin('runs as library calls (no global state)')
   call test_interleaved_runs_are_bit_identical()
   call test_copies_are_independent()
   call test_many_hdf5_histories_from_one_process()
   call suite_end()

contains

   logical function same(a, b)
      type(run_result_t), intent(in) :: a, b
      integer :: i
      same = size(a%events) == size(b%events) .and. all(a%y_final == b%y_final)
      if (.not. same) return
      do i = 1, size(a%events)
         same = same .and. a%events(i)%t == b%events(i)%t .and. &
                a%events(i)%approach_velocity == b%events(i)%approach_velocity
      end do
      do i = 1, size(a%el)
         same = same .and. a%el(i)%torque_max == b%el(i)%torque_max .and. a%el(i)%p2p_mean == b%el(i)%p2p_mean
      end do
   end function same

   subroutine test_interleaved_runs_are_bit_identical()
      type(model_t) :: ghm, key, m
      type(run_result_t) :: r1, r2, rk, rc
      call test_begin('interleaved_runs_are_bit_identical')
      call load_model('inputs/gregory_harris_munro.nml', ghm)
      call load_model('verification/table5_4/table5_4.nml', key)
      m = ghm; call run_model(m, r1)
      m = key; call run_model(m, rk)
      m = ghm; m%run%integrator = 'cvode-bdf'; call run_model(m, rc)
      m = ghm; call run_model(m, r2)
      call check('GHM run, then other runs and integrators, then GHM again: identical to the bit', same(r1, r2))
      call check('the keyed-joint run in between had its own single impact', rk%el(1)%impacts == 1)
   end subroutine test_interleaved_runs_are_bit_identical

   subroutine test_copies_are_independent()
      type(model_t) :: base, fast
      type(run_result_t) :: r0, r1, rf
      integer :: i
      call test_begin('copies_are_independent')
      call load_model('inputs/gregory_harris_munro.nml', base)
      call run_model(base, r0)
      ! re-parameterise a copy: another mesh frequency (as a sweep would)
      fast = base
      do i = 1, size(fast%nodes)
         fast%nodes(i)%n%omega0 = two_pi*300.0_wp/32.0_wp
      end do
      fast%speeds(1)%value0 = two_pi*300.0_wp/32.0_wp
      call run_model(fast, rf)
      call run_model(base, r1)
      call check('the copy ran at its own speed', abs(rf%y_final(2) - r0%y_final(2)) > 1.0_wp)
      call check('the original is untouched by running the copy', same(r0, r1))
   end subroutine test_copies_are_independent

   subroutine test_many_hdf5_histories_from_one_process()
      type(model_t) :: base, m
      type(run_result_t) :: r
      type(hdf5_sink_t) :: h5
      type(error_t), allocatable :: err
      character(len=64) :: path
      integer :: k, ok, u, ios
      logical :: exists
      call test_begin('many_hdf5_histories_from_one_process')
      call load_model('verification/table5_3/table5_3.nml', base)
      ok = 0
      do k = 1, 20
         m = base
         write (path, '(a,i0,a)') '/tmp/trainsim_library_run_', k, '.h5'
         h5%path = trim(path)
         call simulate(m, h5, r, err)
         if (allocated(err)) exit
         inquire (file=trim(path), exist=exists)
         if (exists .and. r%stats%events == 2) ok = ok + 1
         open (newunit=u, file=trim(path), iostat=ios)
         if (ios == 0) close (u, status='delete')
      end do
      call check('20 runs in one process each wrote a complete history', ok == 20)
   end subroutine test_many_hdf5_histories_from_one_process
end program test_library_runs
