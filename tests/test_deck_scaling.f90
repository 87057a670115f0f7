!> Reading and building a deck takes time linear in its size: a 100 000-node chain
!> (100 000 nodes, 99 999 shafts joined by explicit left/right ids, a load and an
!> initial condition found by id) is read and built within the CTest TIMEOUT of this
!> suite. With a look-up that compares each group with every earlier one, 100 000
!> nodes take hours (1 000 took 4 s), so the TIMEOUT makes this test fail.
!>
!> `test_deck_scaling N [N ...]` reads and builds chains of N nodes and prints the
!> times (for docs/benchmarks; no timing is asserted).
program test_deck_scaling
   use, intrinsic :: iso_fortran_env, only: int64
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_deck, only: deck_t, read_deck
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_id_table, only: id_table_t
   use trainsim_testing, only: suite_begin, test_begin, check, suite_end
   implicit none

   character(len=32) :: argbuf
   integer :: k, n

   if (command_argument_count() > 0) then
      do k = 1, command_argument_count()
         call get_command_argument(k, argbuf)
         read (argbuf, *) n
         call time_chain(n)
      end do
      stop
   end if
   call suite_begin('deck_scaling')
   call test_id_table_answers_like_a_linear_search()
   call test_chain_of_100000_nodes_reads_and_builds()
   call suite_end()

contains

   !> Path of a scratch file in $TMPDIR (or /tmp), unique to this process.
   function scratch_path(stem) result(path)
      character(len=*), intent(in) :: stem
      character(len=:), allocatable :: path
      character(len=512) :: tmpdir
      integer :: stat
      integer(int64) :: clock
      call get_environment_variable('TMPDIR', tmpdir, status=stat)
      if (stat /= 0 .or. len_trim(tmpdir) == 0) tmpdir = '/tmp'
      call system_clock(clock)
      path = trim(tmpdir)//'/'//stem//'_'//str(int(mod(clock, 1000000000_int64)))//'.nml'
   end function scratch_path

   !> Write a chain deck of `n` nodes to `path`.
   subroutine write_chain(path, n, ok)
      character(len=*), intent(in) :: path
      integer, intent(in) :: n
      logical, intent(out) :: ok
      integer :: u, ios, i
      open (newunit=u, file=path, status='replace', action='write', iostat=ios)
      ok = ios == 0
      if (.not. ok) return
      write (u, '(a)') '&run t_end = 1.0e-6, dt = 1.0e-6 /'
      do i = 1, n
         write (u, '(a)') "&node id = 'n"//str(i)//"', type = 'inertia', inertia = 1.0 /"
      end do
      do i = 1, n - 1
         write (u, '(a)') "&element id = 'e"//str(i)//"', type = 'shaft', stiffness = 1.0e3, left = 'n"// &
            str(i)//"', right = 'n"//str(i + 1)//"' /"
      end do
      write (u, '(a)') "&load node = 'n"//str(n)//"', value = 1.0 /"
      write (u, '(a)') "&initial node = 'n"//str(n/2 + 1)//"', speed = 2.0 /"
      close (u)
   end subroutine write_chain

   subroutine read_and_build(path, model, err)
      character(len=*), intent(in) :: path
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      type(deck_t) :: deck
      call read_deck(path, deck, err)
      if (allocated(err)) return
      call build_model(deck, model, err)
   end subroutine read_and_build

   !> Inserting finds duplicates, look-ups find every key and only those, across the
   !> table's growth; trailing blanks do not count (as with Fortran's ==).
   subroutine test_id_table_answers_like_a_linear_search()
      integer, parameter :: n = 5000
      type(id_table_t) :: t
      integer :: i, prev, nbad
      call test_begin('id table: duplicates found, every key found, absent keys give 0')
      nbad = 0
      do i = 1, n
         call t%insert('n'//str(i), i, prev)
         if (prev /= 0) nbad = nbad + 1
      end do
      call check('no false duplicate among '//str(n)//' distinct keys', nbad == 0)
      call check('count', t%count() == n)
      nbad = 0
      do i = 1, n
         if (t%get('n'//str(i)) /= i) nbad = nbad + 1
         if (t%get('m'//str(i)) /= 0) nbad = nbad + 1
      end do
      call check('every key found with its value, no absent key found', nbad == 0)
      call t%insert('n17', 99, prev)
      call check('a duplicate returns the first value', prev == 17)
      call check('and does not replace it', t%get('n17') == 17)
      call check('trailing blanks do not count', t%get('n17   ') == 17)
      call check('the empty key is a key like any other', t%get('') == 0)
      call t%insert('', 7, prev)
      call check('empty key inserted as new', prev == 0)
      call check('empty key stored', t%get('') == 7)
   end subroutine test_id_table_answers_like_a_linear_search

   subroutine test_chain_of_100000_nodes_reads_and_builds()
      integer, parameter :: n = 100000
      type(model_t) :: model
      type(error_t), allocatable :: err
      character(len=:), allocatable :: path
      logical :: ok
      integer :: u, ios
      call test_begin('a chain of 100 000 nodes is read and built (CTest TIMEOUT bounds the time)')
      path = scratch_path('trainsim_chain')
      call write_chain(path, n, ok)
      call check('scratch deck written', ok)
      if (.not. ok) return
      call read_and_build(path, model, err)
      open (newunit=u, file=path, status='old', iostat=ios)
      if (ios == 0) close (u, status='delete')
      call check('no error', .not. allocated(err))
      if (allocated(err)) then
         write (*, '(a)') '    '//err%message
         return
      end if
      call check('all nodes built', size(model%nodes) == n)
      call check('all elements built', size(model%elements) == n - 1)
      ! the look-ups by id found the right nodes, not merely some node
      call check('last shaft joins n99999 and n100000', &
                 model%elements(n - 1)%e%left == n - 1 .and. model%elements(n - 1)%e%right == n)
      call check('load found its node by id', model%loads(1)%node == n)
      call check('initial speed went to n50001', model%nodes(n/2 + 1)%n%omega0, 2.0_wp, abs_tol=0.0_wp)
      call check('other nodes keep speed 0', model%nodes(n/2)%n%omega0, 0.0_wp, abs_tol=0.0_wp)
   end subroutine test_chain_of_100000_nodes_reads_and_builds

   subroutine time_chain(n)
      integer, intent(in) :: n
      type(model_t) :: model
      type(error_t), allocatable :: err
      character(len=:), allocatable :: path
      logical :: ok
      integer :: u, ios
      integer(int64) :: c0, c1, rate
      path = scratch_path('trainsim_chain_time')
      call write_chain(path, n, ok)
      if (.not. ok) error stop 'cannot write the scratch deck'
      call system_clock(c0, rate)
      call read_and_build(path, model, err)
      call system_clock(c1)
      open (newunit=u, file=path, status='old', iostat=ios)
      if (ios == 0) close (u, status='delete')
      if (allocated(err)) then
         write (*, '(a)') err%message
      else
         write (*, '(a,i0,a,f9.3,a)') 'chain of ', n, ' nodes: read and built in ', &
            real(c1 - c0, wp)/real(rate, wp), ' s'
      end if
   end subroutine time_chain
end program test_deck_scaling
