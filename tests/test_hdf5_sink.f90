!> Tests of the HDF5 output sink: write a small run, read it back with the HDF5 Fortran
!> API, and check the error paths (bad directory, abort, misuse).
program test_hdf5_sink
   use, intrinsic :: iso_c_binding, only: c_int, c_ptr, c_char, c_size_t, c_loc, c_f_pointer, c_associated
   use hdf5, only: hid_t, hsize_t, size_t, h5open_f, h5fopen_f, h5fclose_f, H5F_ACC_RDONLY_F, &
      h5dopen_f, h5dclose_f, h5dread_f, h5dget_space_f, h5dget_type_f, h5dget_create_plist_f, &
      h5sget_simple_extent_ndims_f, h5sget_simple_extent_dims_f, h5sclose_f, H5S_UNLIMITED_F, &
      h5aopen_by_name_f, h5aread_f, h5aclose_f, h5aget_type_f, h5aget_space_f, &
      h5tget_size_f, h5tclose_f, h5tis_variable_str_f, h5tget_cset_f, H5T_CSET_UTF8_F, h5pget_nfilters_f, h5pclose_f, h5eset_auto_f, &
      h5fget_obj_count_f, H5F_OBJ_ALL_F, &
      H5T_NATIVE_DOUBLE, H5T_NATIVE_INTEGER, h5kind_to_type, H5_INTEGER_KIND
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, err_io, err_internal
   use trainsim_strings, only: string_t, str
   use trainsim_sink, only: run_meta_t, sample_t, event_t, run_stats_t, param_list_t, element_metrics_t, &
      ev_contact_front, ev_contact_rear, ev_separation, ev_zone, ev_name
   use trainsim_hdf5, only: hdf5_sink_t
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_simulate, only: simulate
   use trainsim_test_support, only: load_model
   use trainsim_testing, only: check, check_close, suite_begin, suite_end, test_begin
   implicit none

   interface
      function c_getpid() bind(C, name='getpid') result(pid)
         import :: c_int
         integer(c_int) :: pid
      end function c_getpid
      function c_strlen(p) bind(C, name='strlen') result(n)
         import :: c_ptr, c_size_t
         type(c_ptr), value :: p
         integer(c_size_t) :: n
      end function c_strlen
   end interface

   integer, parameter :: n_samples = 600   ! crosses the 256-row block boundary twice
   integer, parameter :: deck_len = 100000 ! larger than HDF5's 64 KiB compact attribute limit
   character(len=:), allocatable :: tmp, main_file, empty_file
   integer :: hdferr
   integer(size_t) :: baseline_objects   ! see open_objects

   call suite_begin('hdf5_sink')
   call h5open_f(hdferr)
   call h5eset_auto_f(0, hdferr)
   tmp = temp_prefix()
   main_file = tmp//'_run.h5'
   empty_file = tmp//'_empty.h5'

   call test_bad_directory()   ! first: the sink initialises HDF5 and opens nothing else
   baseline_objects = open_objects()
   call test_write_full_run()
   call test_read_back()
   call test_no_elements()
   call test_streamed_events()
   call test_run_file_events_equal_the_table()
   call test_abort()
   call test_misuse()
   call test_python_layout()
   call test_no_leaks()

   call remove_file(main_file)
   call remove_file(empty_file)
   call suite_end()

contains

   ! ------------------------------------------------------------------ fixtures

   !> /tmp/trainsim_h5test_<pid> (or under $TMPDIR).
   function temp_prefix() result(prefix)
      character(len=:), allocatable :: prefix
      character(len=512) :: dir
      integer :: n, stat
      call get_environment_variable('TMPDIR', dir, n, stat)
      if (stat /= 0 .or. n == 0) dir = '/tmp'
      prefix = trim(dir)//'/trainsim_h5test_'//str(int(c_getpid()))
   end function temp_prefix

   !> A list of names (trailing blanks dropped).
   subroutine set_names(list, texts)
      type(string_t), allocatable, intent(out) :: list(:)
      character(len=*), intent(in) :: texts(:)
      integer :: i
      allocate (list(size(texts)))
      do i = 1, size(texts)
         list(i)%s = trim(texts(i))
      end do
   end subroutine set_names

   subroutine set_params(params, names, values)
      type(param_list_t), intent(out) :: params
      character(len=*), intent(in) :: names(:)
      real(wp), intent(in) :: values(:)
      call set_names(params%names, names)
      params%values = values
   end subroutine set_params

   !> 3 states, 2 nodes (motor, load), 1 gear element 'g1' with parameters.
   function small_meta() result(meta)
      type(run_meta_t) :: meta
      integer :: i
      meta%title = 'HDF5 sink test'
      meta%deck_file = 'decks/test.nml'
      allocate (character(len=deck_len) :: meta%deck_text)
      do i = 1, deck_len
         meta%deck_text(i:i) = achar(iachar('a') + mod(i - 1, 26))
      end do
      meta%deck_text(deck_len:deck_len) = '!'
      meta%units = 'SI'
      meta%version = '0.1.0'
      meta%integrator = 'cvode-bdf'
      call set_names(meta%state_names, [character(len=11) :: 'theta_load', 'omega_motor', 'omega_load'])
      call set_names(meta%node_ids, [character(len=5) :: 'motor', 'load'])
      call set_names(meta%node_types, [character(len=10) :: 'prescribed', 'inertia'])
      call set_names(meta%element_ids, ['g1'])
      call set_names(meta%element_types, ['gear_pair'])
      meta%element_left = [1]
      meta%element_right = [2]
      call set_names(meta%element_disp_units, ['in'])
      allocate (meta%element_params(1), meta%node_params(2))
      call set_params(meta%element_params(1), [character(len=8) :: 'ratio', 'k_mesh', 'backlash'], &
                      [2.5_wp, 1.0e8_wp, 1.0e-4_wp])
      call set_params(meta%node_params(1), ['speed'], [157.0_wp])
      call set_params(meta%node_params(2), ['inertia'], [0.02_wp])
   end function small_meta

   !> Sample number k (1-based) with values that identify k and the column.
   subroutine fill_sample(smp, k)
      type(sample_t), intent(inout) :: smp
      integer, intent(in) :: k
      real(wp) :: x
      x = real(k, wp)
      smp%t = 1.0e-3_wp*(x - 1.0_wp)
      smp%y = [x, 2.0_wp*x, 3.0_wp*x]
      smp%theta = [0.1_wp*x, 0.2_wp*x]
      smp%omega = [-x, -2.0_wp*x]
      smp%torque_left = [10.0_wp*x]
      smp%torque_right = [-10.0_wp*x]
      smp%displacement = [1.0e-6_wp*x]
      smp%force = [100.0_wp + x]
      smp%contact = [mod(k, 3) - 1]
      smp%pairs = [1 + mod(k, 2)]
      smp%energy = [x, x + 0.1_wp, x + 0.2_wp, x + 0.3_wp, x + 0.4_wp]
   end subroutine fill_sample

   subroutine alloc_sample(smp, n_states, n_nodes, n_el)
      type(sample_t), intent(inout) :: smp
      integer, intent(in) :: n_states, n_nodes, n_el
      allocate (smp%y(n_states), smp%theta(n_nodes), smp%omega(n_nodes))
      allocate (smp%torque_left(n_el), smp%torque_right(n_el), smp%displacement(n_el), &
                smp%force(n_el), smp%contact(n_el), smp%pairs(n_el))
   end subroutine alloc_sample

   logical function exists(path)
      character(len=*), intent(in) :: path
      inquire (file=path, exist=exists)
   end function exists

   subroutine remove_file(path)
      character(len=*), intent(in) :: path
      integer :: unit, ios
      if (.not. exists(path)) return
      open (newunit=unit, file=path, status='old', iostat=ios)
      if (ios == 0) close (unit, status='delete')
   end subroutine remove_file

   subroutine write_text_file(path, text)
      character(len=*), intent(in) :: path, text
      integer :: unit
      open (newunit=unit, file=path, status='replace', action='write')
      write (unit, '(a)') text
      close (unit)
   end subroutine write_text_file

   subroutine check_no_error(what, err)
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(in) :: err
      if (allocated(err)) then
         call check(what//' succeeds ('//err%message//')', .false.)
      else
         call check(what//' succeeds', .true.)
      end if
   end subroutine check_no_error

   ! --------------------------------------------------------------------- tests

   subroutine test_write_full_run()
      type(element_metrics_t) :: metrics(1)   ! one per element of the test meta
      type(hdf5_sink_t) :: sink
      type(run_meta_t) :: meta
      type(sample_t) :: smp
      type(event_t) :: events(3)
      type(run_stats_t) :: stats
      type(error_t), allocatable :: err
      integer :: k

      call test_begin('write 600 samples, 3 events, publish')
      call write_text_file(main_file, 'an older file that must be replaced')
      meta = small_meta()
      sink%path = main_file
      sink%compression = 1   ! this file checks that compression works (the default is none)
      call sink%open(meta, err)
      call check_no_error('open', err)
      if (allocated(err)) return
      call check('.part exists while writing', exists(sink%temp_path()))
      call alloc_sample(smp, 3, 2, 1)
      do k = 1, n_samples
         call fill_sample(smp, k)
         call sink%write_sample(smp, err)
         if (allocated(err)) exit
      end do
      call check_no_error('write_sample x600', err)
      if (allocated(err)) return

      events(1) = event_t(t=0.01_wp, element=1, kind=ev_contact_front, approach_velocity=0.5_wp, &
                          restitution=0.7_wp, damping=12.0_wp, peak_force=345.0_wp, duration=2.0e-4_wp)
      events(2) = event_t(t=0.02_wp, element=1, kind=ev_separation, approach_velocity=0.0_wp, &
                          restitution=0.0_wp, damping=0.0_wp, peak_force=0.0_wp, duration=-1.0_wp)
      events(3) = event_t(t=0.03_wp, element=1, kind=ev_zone)
      stats%steps = 12345678901_i8     ! does not fit in 32 bits
      stats%rhs_evals = 2_i8
      stats%jac_evals = 3_i8
      stats%root_returns = 4_i8
      stats%error_test_fails = 5_i8
      stats%conv_fails = 6_i8
      stats%events = 3_i8
      stats%rejected = 7_i8
      stats%wall_time = 1.25_wp
      stats%t_final = 0.599_wp
      stats%completed = .true.
      call sink%close(events, stats, metrics, err)
      call check_no_error('close', err)
      call check('final file exists', exists(main_file))
      call check('.part is gone after close', .not. exists(sink%temp_path()))
   end subroutine test_write_full_run

   subroutine test_read_back()
      integer(hid_t) :: fid
      integer :: hdferr
      integer(hsize_t), allocatable :: dims(:), maxdims(:)
      real(wp), allocatable :: r1(:), r2(:, :)
      integer, allocatable :: i1(:), i2(:, :)
      character(len=:), allocatable :: txt
      type(string_t), allocatable :: names(:)
      integer(i8) :: big
      integer :: k_
      character(len=*), parameter :: event_columns(9) = [character(len=17) :: 'time', 'element', &
         'kind', 'kind_name', 'approach_velocity', 'restitution', 'damping', 'peak_force', 'duration']

      call test_begin('read back with the HDF5 Fortran API')
      call h5fopen_f(main_file, H5F_ACC_RDONLY_F, fid, hdferr)
      call check('file opens read-only as HDF5', hdferr >= 0)
      if (hdferr < 0) return

      ! dimensions (Fortran order: variables first, time last) and extendibility
      call dset_dims(fid, '/time', dims, maxdims)
      call check('/time is 1-D with 600 rows', same(dims, [600]))
      call check('/time is extendible', size(maxdims) == 1 .and. all(maxdims == H5S_UNLIMITED_F))
      call dset_dims(fid, '/states', dims, maxdims)
      call check('/states is 3 x 600', same(dims, [3, 600]))
      call check('/states extendible in time only', same(maxdims(1:1), [3]) .and. maxdims(2) == H5S_UNLIMITED_F)
      call dset_dims(fid, '/nodes/theta', dims, maxdims)
      call check('/nodes/theta is 2 x 600', same(dims, [2, 600]))
      call dset_dims(fid, '/nodes/omega', dims, maxdims)
      call check('/nodes/omega is 2 x 600', same(dims, [2, 600]))
      call dset_dims(fid, '/elements/displacement', dims, maxdims)
      call check('/elements/displacement is 1 x 600', same(dims, [1, 600]))
      call dset_dims(fid, '/elements/contact', dims, maxdims)
      call check('/elements/contact is 1 x 600', same(dims, [1, 600]))
      call dset_dims(fid, '/energy', dims, maxdims)
      call check('/energy is 5 x 600', same(dims, [5, 600]))
      call check('/states is compressed (level 1 asked for)', n_filters(fid, '/states') >= 1)

      ! values on both sides of the block boundaries (256, 512) and the last, partial block
      call read_r1(fid, '/time', r1)
      if (size(r1) == n_samples) then
         call check_close('time(1)', r1(1), 0.0_wp, abs_tol=0.0_wp)
         call check_close('time(257)', r1(257), 0.256_wp, rel_tol=1.0e-15_wp)
         call check_close('time(600)', r1(600), 0.599_wp, rel_tol=1.0e-15_wp)
      end if
      call read_r2(fid, '/states', r2)
      if (all(shape(r2) == [3, n_samples])) then
         call check_close('states(2,300)', r2(2, 300), 600.0_wp, abs_tol=0.0_wp)
         call check_close('states(3,600)', r2(3, 600), 1800.0_wp, abs_tol=0.0_wp)
         call check_close('max |states(1,:) - (1..600)|', maxval(abs(r2(1, :) - [(real(k_, wp), k_=1, n_samples)])), &
                          0.0_wp, abs_tol=0.0_wp)
      end if
      call read_r2(fid, '/nodes/omega', r2)
      if (all(shape(r2) == [2, n_samples])) call check_close('omega(2,513)', r2(2, 513), -1026.0_wp, abs_tol=0.0_wp)
      call read_r2(fid, '/elements/displacement', r2)
      if (all(shape(r2) == [1, n_samples])) call check_close('displacement(1,512)', r2(1, 512), 512.0e-6_wp, rel_tol=1.0e-15_wp)
      call read_r2(fid, '/elements/torque_right', r2)
      if (all(shape(r2) == [1, n_samples])) call check_close('torque_right(1,256)', r2(1, 256), -2560.0_wp, abs_tol=0.0_wp)
      call read_r2(fid, '/elements/force', r2)
      if (all(shape(r2) == [1, n_samples])) call check_close('force(1,600)', r2(1, 600), 700.0_wp, abs_tol=0.0_wp)
      call read_r2(fid, '/energy', r2)
      if (all(shape(r2) == [5, n_samples])) call check_close('energy(4,599)', r2(4, 599), 599.3_wp, rel_tol=1.0e-15_wp)
      call read_i2(fid, '/elements/contact', i2)
      if (all(shape(i2) == [1, n_samples])) call check('contact(1,:) = mod(k,3)-1', &
                                                       all(i2(1, :) == [(mod(k_, 3) - 1, k_=1, n_samples)]))
      call read_i2(fid, '/elements/pairs', i2)
      if (all(shape(i2) == [1, n_samples])) call check('pairs(1,257) = 2', i2(1, 257) == 2)

      ! attributes
      call read_str_attr(fid, '/', 'title', txt)
      call check('title', txt == 'HDF5 sink test')
      call read_str_attr(fid, '/', 'units', txt)
      call check('units', txt == 'SI')
      call read_str_attr(fid, '/', 'integrator', txt)
      call check('integrator', txt == 'cvode-bdf')
      call read_str_attr(fid, '/', 'trainsim_version', txt)
      call check('trainsim_version', txt == '0.1.0')
      call read_str_attr(fid, '/', 'deck_file', txt)
      call check('deck_file', txt == 'decks/test.nml')
      call read_str_attr(fid, '/', 'deck', txt)
      call check('deck text has all '//str(deck_len)//' characters', len(txt) == deck_len)
      if (len(txt) == deck_len) call check('deck text intact', txt(1:3) == 'abc' .and. txt(deck_len:) == '!')
      call read_str_attr(fid, '/', 'created', txt)
      call check('created is an ISO date-time', len(txt) >= 19)
      if (len(txt) >= 19) call check('created has the ISO shape', txt(5:5) == '-' .and. txt(11:11) == 'T')
      call read_str_list(fid, '/states', 'names', names)
      call check('/states@names', same_names(names, [character(len=11) :: 'theta_load', 'omega_motor', 'omega_load']))
      call read_str_list(fid, '/energy', 'names', names)
      call check('/energy@names', same_names(names, [character(len=10) :: &
                                                     'kinetic', 'potential', 'dissipated', 'input', 'balance']))
      call read_str_list(fid, '/nodes', 'ids', names)
      call check('/nodes@ids', same_names(names, [character(len=5) :: 'motor', 'load']))
      call read_str_list(fid, '/nodes', 'types', names)
      call check('/nodes@types', same_names(names, [character(len=10) :: 'prescribed', 'inertia']))
      call read_str_list(fid, '/elements', 'ids', names)
      call check('/elements@ids', same_names(names, ['g1']))
      call read_str_list(fid, '/elements', 'types', names)
      call check('/elements@types', same_names(names, ['gear_pair']))
      call read_str_list(fid, '/elements', 'displacement_units', names)
      call check('/elements@displacement_units', same_names(names, ['in']))
      call read_int_attr(fid, '/elements', 'left', i1)
      call check('/elements@left = [1]', same(int(i1, hsize_t), [1]))
      call read_int_attr(fid, '/elements', 'right', i1)
      call check('/elements@right = [2]', same(int(i1, hsize_t), [2]))
      call check_close('/elements/g1@ratio', read_real_attr(fid, '/elements/g1', 'ratio'), 2.5_wp, abs_tol=0.0_wp)
      call check_close('/elements/g1@k_mesh', read_real_attr(fid, '/elements/g1', 'k_mesh'), 1.0e8_wp, abs_tol=0.0_wp)
      call check_close('/nodes/load@inertia', read_real_attr(fid, '/nodes/load', 'inertia'), 0.02_wp, abs_tol=0.0_wp)
      call check_close('/nodes/motor@speed', read_real_attr(fid, '/nodes/motor', 'speed'), 157.0_wp, abs_tol=0.0_wp)

      ! event table
      call dset_dims(fid, '/events/time', dims, maxdims)
      call check('/events/time has 3 rows', same(dims, [3]))
      call read_r1(fid, '/events/time', r1)
      if (size(r1) == 3) call check_close('events time(3)', r1(3), 0.03_wp, abs_tol=0.0_wp)
      call read_r1(fid, '/events/peak_force', r1)
      if (size(r1) == 3) call check_close('events peak_force(1)', r1(1), 345.0_wp, abs_tol=0.0_wp)
      call read_r1(fid, '/events/duration', r1)
      if (size(r1) == 3) call check_close('events duration(2)', r1(2), -1.0_wp, abs_tol=0.0_wp)
      call read_r1(fid, '/events/restitution', r1)
      if (size(r1) == 3) call check_close('events restitution(1)', r1(1), 0.7_wp, abs_tol=0.0_wp)
      call read_i1(fid, '/events/kind', i1)
      call check('events kind = [1,3,4]', same(int(i1, hsize_t), [ev_contact_front, ev_separation, ev_zone]))
      call read_i1(fid, '/events/element', i1)
      call check('events element = [1,1,1]', same(int(i1, hsize_t), [1, 1, 1]))
      call read_str_dset(fid, '/events/kind_name', names)
      call check('events kind_name', same_names(names, [character(len=13) :: 'contact_front', 'separation', 'zone']))
      do k_ = 1, size(event_columns)
         call check('/events/'//trim(event_columns(k_))//' exists', has_dset(fid, '/events/'//trim(event_columns(k_))))
      end do

      ! run statistics
      big = read_i8_attr(fid, '/run_stats', 'steps')
      call check('run_stats@steps keeps 64 bits', big == 12345678901_i8)
      call check('run_stats@rejected', read_i8_attr(fid, '/run_stats', 'rejected') == 7_i8)
      call check('run_stats@completed = 1', read_int_scalar(fid, '/run_stats', 'completed') == 1)
      call check_close('run_stats@wall_time', read_real_attr(fid, '/run_stats', 'wall_time'), 1.25_wp, abs_tol=0.0_wp)

      call h5fclose_f(fid, hdferr)
      call check('close after reading', hdferr >= 0)
   end subroutine test_read_back

   !> No elements, empty strings, a tiny block and no events must all work.
   subroutine test_no_elements()
      type(element_metrics_t) :: metrics(0)   ! no elements
      type(hdf5_sink_t) :: sink
      type(run_meta_t) :: meta
      type(sample_t) :: smp
      type(event_t) :: events(0)
      type(run_stats_t) :: stats
      type(error_t), allocatable :: err
      integer(hid_t) :: fid
      integer(hsize_t), allocatable :: dims(:), maxdims(:)
      type(string_t), allocatable :: names(:)
      character(len=:), allocatable :: txt
      real(wp), allocatable :: r1(:)
      integer :: k, hdferr

      call test_begin('no elements, empty strings, no events, block_rows = 7')
      meta%title = ''
      call set_names(meta%state_names, [' ', 'x'])
      call set_names(meta%node_ids, ['n1'])
      allocate (meta%element_ids(0))
      ! deck_file, units, ... left unallocated on purpose
      sink%path = empty_file
      sink%block_rows = 7
      call sink%open(meta, err)
      call check_no_error('open', err)
      if (allocated(err)) return
      call alloc_sample(smp, 2, 1, 0)
      do k = 1, 10
         smp%t = real(k, wp)
         smp%y = [real(k, wp), 0.0_wp]
         smp%theta = [0.0_wp]
         smp%omega = [1.0_wp]
         call sink%write_sample(smp, err)
         if (allocated(err)) exit
      end do
      call check_no_error('write_sample x10', err)
      if (allocated(err)) return
      call sink%close(events, stats, metrics, err)
      call check_no_error('close', err)
      if (allocated(err)) return

      call h5fopen_f(empty_file, H5F_ACC_RDONLY_F, fid, hdferr)
      call check('file opens', hdferr >= 0)
      if (hdferr < 0) return
      call dset_dims(fid, '/time', dims, maxdims)
      call check('/time has 10 rows', same(dims, [10]))
      call read_r1(fid, '/time', r1)
      if (size(r1) == 10) call check_close('time(10)', r1(10), 10.0_wp, abs_tol=0.0_wp)
      call dset_dims(fid, '/elements/force', dims, maxdims)
      call check('/elements/force is 0 x 10', same(dims, [0, 10]))
      call dset_dims(fid, '/elements/pairs', dims, maxdims)
      call check('/elements/pairs is 0 x 10', same(dims, [0, 10]))
      call dset_dims(fid, '/events/kind_name', dims, maxdims)
      call check('/events/kind_name has 0 rows', same(dims, [0]))
      call dset_dims(fid, '/events/time', dims, maxdims)
      call check('/events/time has 0 rows', same(dims, [0]))
      call read_str_attr(fid, '/', 'title', txt)
      call check('empty title', txt == '')
      call read_str_attr(fid, '/', 'units', txt)
      call check('unset units written as empty', txt == '')
      call read_str_list(fid, '/states', 'names', names)
      call check('state names with an empty one', same_names(names, [character(len=1) :: '', 'x']))
      call read_str_list(fid, '/elements', 'ids', names)
      call check('no element ids', allocated(names) .and. size(names) == 0)
      call check('run_stats@completed = 0', read_int_scalar(fid, '/run_stats', 'completed') == 0)
      call h5fclose_f(fid, hdferr)
   end subroutine test_no_elements

   !> Event rows streamed as a run makes them (write_event, update_event), in
   !> blocks of 4: a contact of g1 open from row 2 to row 10, across two block
   !> boundaries (its row rewritten in the file), one of b1 closed in the next
   !> block (rewritten), one closed while still buffered, one still open at the
   !> end; two elements with different units. Read back: every column equals
   !> the table the rows describe, to the bit, and the per-row units are listed.
   subroutine test_streamed_events()
      integer, parameter :: n = 12
      type(element_metrics_t) :: metrics(2)
      type(hdf5_sink_t) :: sink
      type(run_meta_t) :: meta
      type(sample_t) :: smp
      type(event_t) :: ex(n), no_rows(0)
      type(run_stats_t) :: stats
      type(error_t), allocatable :: err
      integer(hid_t) :: fid
      integer :: k, hdferr, row
      integer, parameter :: el(n) = [1, 1, 1, 2, 2, 2, 2, 2, 2, 1, 2, 1]
      integer, parameter :: kinds(n) = [ev_zone, ev_contact_front, ev_zone, ev_contact_front, ev_separation, &
                                        ev_zone, ev_zone, ev_zone, ev_contact_rear, ev_separation, ev_separation, &
                                        ev_contact_front]
      real(wp), allocatable :: r1(:)
      integer, allocatable :: i1(:)
      type(string_t), allocatable :: names(:), units(:)
      character(len=:), allocatable :: path, txt
      logical :: same_all

      call test_begin('events streamed in blocks of 4, open contacts rewritten in place')
      path = tmp//'_events.h5'
      meta = small_meta()
      call set_names(meta%element_ids, [character(len=2) :: 'g1', 'b1'])
      call set_names(meta%element_types, [character(len=9) :: 'gear_pair', 'backlash'])
      meta%element_left = [1, 1]
      meta%element_right = [2, 2]
      call set_names(meta%element_disp_units, [character(len=3) :: 'in', 'rad'])
      deallocate (meta%element_params)
      allocate (meta%element_params(2))
      call set_params(meta%element_params(1), ['ratio'], [2.5_wp])
      call set_params(meta%element_params(2), ['gap'], [0.01_wp])
      sink%path = path
      sink%event_block_rows = 4
      call sink%open(meta, err)
      call check_no_error('open', err)
      if (allocated(err)) return
      call alloc_sample(smp, 3, 2, 2)
      smp%t = 0.0_wp; smp%y(:) = 1.0_wp; smp%theta(:) = 0.0_wp; smp%omega(:) = 0.0_wp
      smp%torque_left(:) = 0.0_wp; smp%torque_right(:) = 0.0_wp; smp%displacement(:) = 0.0_wp
      smp%force(:) = 0.0_wp; smp%contact(:) = 0; smp%pairs(:) = 0; smp%energy = 0.0_wp
      call sink%write_sample(smp, err)
      do k = 1, n
         ex(k) = event_t(t=1.0e-3_wp*k, element=el(k), kind=kinds(k), approach_velocity=k + 0.5_wp, &
                         restitution=0.01_wp*k, damping=1.0e5_wp + k, peak_force=10.0_wp*k, duration=-1.0_wp, &
                         theta_left=0.1_wp*k, omega_left=-0.2_wp*k, theta_right=0.3_wp*k, omega_right=-0.4_wp*k, &
                         displacement=1.0e-6_wp*k, force=100.0_wp + k)
      end do
      ! as the observer does: a row goes out when it happens; a contact's row
      ! again (final peak force and duration) when it ends
      do k = 1, n
         if (.not. allocated(err)) call sink%write_event(k, ex(k), err)
         row = 0
         select case (k)
         case (5)    ! b1 separates: row 4, flushed with the block of rows 1-4
            row = 4; ex(row)%peak_force = 7.5_wp
         case (10)   ! g1 separates: row 2, open across the blocks of rows 1-4 and 5-8
            row = 2; ex(row)%peak_force = 99.0_wp
         case (11)   ! b1 separates: row 9, still in the buffer
            row = 9; ex(row)%peak_force = 3.25_wp
         end select
         if (row > 0) then
            ex(row)%duration = ex(k)%t - ex(row)%t
            if (.not. allocated(err)) call sink%update_event(row, ex(row), err)
         end if
      end do
      ! row 12 still open at the end: its peak force so far, duration -1
      ex(12)%peak_force = 555.0_wp
      if (.not. allocated(err)) call sink%update_event(12, ex(12), err)
      call check_no_error('write_event and update_event', err)
      if (allocated(err)) return
      stats%events = int(n, i8)
      stats%completed = .true.
      call sink%close(no_rows, stats, metrics, err)
      call check_no_error('close', err)
      if (allocated(err)) return

      call h5fopen_f(path, H5F_ACC_RDONLY_F, fid, hdferr)
      call check('file opens', hdferr >= 0)
      if (hdferr < 0) return
      same_all = .true.
      call read_r1(fid, '/events/time', r1); same_all = same_all .and. same_r(r1, ex%t)
      call read_i1(fid, '/events/element', i1); same_all = same_all .and. size(i1) == n .and. all(i1 == ex%element)
      call read_i1(fid, '/events/kind', i1); same_all = same_all .and. size(i1) == n .and. all(i1 == ex%kind)
      call read_str_dset(fid, '/events/kind_name', names)
      same_all = same_all .and. size(names) == n
      if (size(names) == n) then
         do k = 1, n
            same_all = same_all .and. names(k)%s == ev_name(ex(k)%kind)
         end do
      end if
      call read_r1(fid, '/events/approach_velocity', r1); same_all = same_all .and. same_r(r1, ex%approach_velocity)
      call read_r1(fid, '/events/restitution', r1); same_all = same_all .and. same_r(r1, ex%restitution)
      call read_r1(fid, '/events/damping', r1); same_all = same_all .and. same_r(r1, ex%damping)
      call read_r1(fid, '/events/theta_left', r1); same_all = same_all .and. same_r(r1, ex%theta_left)
      call read_r1(fid, '/events/omega_left', r1); same_all = same_all .and. same_r(r1, ex%omega_left)
      call read_r1(fid, '/events/theta_right', r1); same_all = same_all .and. same_r(r1, ex%theta_right)
      call read_r1(fid, '/events/omega_right', r1); same_all = same_all .and. same_r(r1, ex%omega_right)
      call read_r1(fid, '/events/displacement', r1); same_all = same_all .and. same_r(r1, ex%displacement)
      call read_r1(fid, '/events/force', r1); same_all = same_all .and. same_r(r1, ex%force)
      call check('every column but peak_force and duration as written, to the bit', same_all)
      call read_r1(fid, '/events/peak_force', r1)
      call check('peak_force: final values, rewritten in the file (rows 2, 4) and in the buffer (9, 12)', &
                 same_r(r1, ex%peak_force))
      call read_r1(fid, '/events/duration', r1)
      call check('duration: final values, -1 for the contact still open', same_r(r1, ex%duration))
      call read_str_attr(fid, '/events/displacement', 'units', txt)
      call check('displacement units are mixed', txt == 'mixed: see entry_units')
      call read_vlen(fid, '/events/displacement', 'entry_units', .true., units)
      same_all = size(units) == n
      if (same_all) then
         do k = 1, n
            same_all = same_all .and. units(k)%s == trim(merge('in ', 'rad', el(k) == 1))
         end do
      end if
      call check('displacement entry_units: the element of each row', same_all)
      call read_str_attr(fid, '/events/time', 'units', txt)
      call check('time units s', txt == 's')
      call h5fclose_f(fid, hdferr)
      call remove_file(path)
   end subroutine test_streamed_events

   !> A run with ~1300 events (contacts open across many blocks of 64 rows):
   !> /events in the file is the run's in-memory table, column by column, to the
   !> bit. The same run without the in-memory table (the default: what the CLI
   !> and the sweeps do) writes the same file table and the same metrics.
   subroutine test_run_file_events_equal_the_table()
      type(model_t) :: base, m
      type(run_result_t) :: r1, r2
      type(hdf5_sink_t) :: h5
      type(error_t), allocatable :: err
      integer(hid_t) :: fid
      integer :: hdferr, k
      type(string_t), allocatable :: names(:)
      character(len=:), allocatable :: p1, p2
      logical :: same_all, same_files
      call test_begin('a run with a file: /events is the in-memory event table, to the bit')
      p1 = tmp//'_run_events1.h5'; p2 = tmp//'_run_events2.h5'
      call load_model('inputs/dc_motor_geared_load.nml', base)
      m = base
      m%run%keep_events = .true.
      h5%path = p1
      h5%event_block_rows = 64
      call simulate(m, h5, r1, err)
      call check_no_error('run keeping the table', err)
      if (allocated(err)) return
      m = base
      h5%path = p2
      h5%event_block_rows = 256
      call simulate(m, h5, r2, err)
      call check_no_error('run without the table', err)
      if (allocated(err)) return
      call check('more than 1000 events (many blocks)', size(r1%events) > 1000 .and. &
                 r1%stats%events == int(size(r1%events), i8))
      call check('no table in memory by default, the same event count', size(r2%events) == 0 .and. &
                 r2%stats%events == r1%stats%events)
      same_all = size(r1%el) == size(r2%el)
      if (same_all) then
         do k = 1, size(r1%el)
            associate (a => r1%el(k), b => r2%el(k))
               same_all = same_all .and. a%max_peak_force == b%max_peak_force .and. a%impacts == b%impacts .and. &
                          a%p2p_mean == b%p2p_mean .and. a%p2p_swings == b%p2p_swings .and. a%force_max == b%force_max
            end associate
         end do
      end if
      call check('the same metrics either way', same_all)

      same_all = .true.; same_files = .true.
      call column_r(p1, p2, 'time', same_all, same_files, r1%events%t)
      call column_i(p1, p2, 'element', same_all, same_files, r1%events%element)
      call column_i(p1, p2, 'kind', same_all, same_files, r1%events%kind)
      call column_r(p1, p2, 'approach_velocity', same_all, same_files, r1%events%approach_velocity)
      call column_r(p1, p2, 'restitution', same_all, same_files, r1%events%restitution)
      call column_r(p1, p2, 'damping', same_all, same_files, r1%events%damping)
      call column_r(p1, p2, 'peak_force', same_all, same_files, r1%events%peak_force)
      call column_r(p1, p2, 'duration', same_all, same_files, r1%events%duration)
      call column_r(p1, p2, 'theta_left', same_all, same_files, r1%events%theta_left)
      call column_r(p1, p2, 'omega_left', same_all, same_files, r1%events%omega_left)
      call column_r(p1, p2, 'theta_right', same_all, same_files, r1%events%theta_right)
      call column_r(p1, p2, 'omega_right', same_all, same_files, r1%events%omega_right)
      call column_r(p1, p2, 'displacement', same_all, same_files, r1%events%displacement)
      call column_r(p1, p2, 'force', same_all, same_files, r1%events%force)
      call h5fopen_f(p1, H5F_ACC_RDONLY_F, fid, hdferr)
      if (hdferr >= 0) then
         call read_str_dset(fid, '/events/kind_name', names)
         call h5fclose_f(fid, hdferr)
         same_all = same_all .and. size(names) == size(r1%events)
         if (same_all) then
            do k = 1, size(names)
               same_all = same_all .and. names(k)%s == ev_name(r1%events(k)%kind)
            end do
         end if
      end if
      call check('every column of /events equals the table, to the bit', same_all)
      call check('the file without the in-memory table has the same /events', same_files)
      call check('some contacts lasted over a block of 64 rows', any(r1%events%duration > 0.0_wp) .and. &
                 long_contact(r1))
      call remove_file(p1)
      call remove_file(p2)
   end subroutine test_run_file_events_equal_the_table

   !> Column `name` of /events in file p1 against `want`, and in p2 against p1's.
   subroutine column_r(p1, p2, name, same_all, same_files, want)
      character(len=*), intent(in) :: p1, p2, name
      real(wp), intent(in) :: want(:)
      logical, intent(inout) :: same_all, same_files
      real(wp), allocatable :: c(:), other(:)
      integer(hid_t) :: fid
      integer :: hdferr
      call h5fopen_f(p1, H5F_ACC_RDONLY_F, fid, hdferr)
      if (hdferr < 0) then
         same_all = .false.; return
      end if
      call read_r1(fid, '/events/'//name, c)
      call h5fclose_f(fid, hdferr)
      same_all = same_all .and. same_r(c, want)
      call h5fopen_f(p2, H5F_ACC_RDONLY_F, fid, hdferr)
      if (hdferr < 0) then
         same_files = .false.; return
      end if
      call read_r1(fid, '/events/'//name, other)
      call h5fclose_f(fid, hdferr)
      same_files = same_files .and. same_r(other, c)
   end subroutine column_r

   subroutine column_i(p1, p2, name, same_all, same_files, want)
      character(len=*), intent(in) :: p1, p2, name
      integer, intent(in) :: want(:)
      logical, intent(inout) :: same_all, same_files
      integer, allocatable :: ic(:), other(:)
      integer(hid_t) :: fid
      integer :: hdferr
      call h5fopen_f(p1, H5F_ACC_RDONLY_F, fid, hdferr)
      if (hdferr < 0) then
         same_all = .false.; return
      end if
      call read_i1(fid, '/events/'//name, ic)
      call h5fclose_f(fid, hdferr)
      same_all = same_all .and. size(ic) == size(want)
      if (same_all) same_all = all(ic == want)
      call h5fopen_f(p2, H5F_ACC_RDONLY_F, fid, hdferr)
      if (hdferr < 0) then
         same_files = .false.; return
      end if
      call read_i1(fid, '/events/'//name, other)
      call h5fclose_f(fid, hdferr)
      same_files = same_files .and. size(other) == size(ic)
      if (same_files) same_files = all(other == ic)
   end subroutine column_i

   !> A contact whose row was flushed before it ended: more than 64 rows between
   !> a contact and its separation.
   logical function long_contact(r)
      type(run_result_t), intent(in) :: r
      integer :: i, j
      long_contact = .false.
      do i = 1, size(r%events)
         if (r%events(i)%kind /= ev_contact_front .and. r%events(i)%kind /= ev_contact_rear) cycle
         do j = i + 1, size(r%events)
            if (r%events(j)%element == r%events(i)%element .and. r%events(j)%kind == ev_separation) exit
         end do
         if (j - i > 64 .and. j <= size(r%events)) long_contact = .true.
      end do
   end function long_contact

   !> Two float64 columns equal to the bit (and of one length).
   logical function same_r(a, b)
      real(wp), intent(in) :: a(:), b(:)
      same_r = size(a) == size(b)
      if (same_r) same_r = all(a == b)
   end function same_r

   subroutine test_bad_directory()
      type(hdf5_sink_t) :: sink
      type(run_meta_t) :: meta
      type(error_t), allocatable :: err
      character(len=:), allocatable :: path

      call test_begin('open in a missing directory fails cleanly')
      path = tmp//'_no_such_dir/out.h5'
      meta = small_meta()
      sink%path = path
      call sink%open(meta, err)
      call check('open returns an error', allocated(err))
      if (.not. allocated(err)) return
      write (*, '(a)') '    message: '//err%message
      call check('error code is err_io', err%code == err_io)
      call check('message names the path', index(err%message, "'"//path//"'") > 0)
      call check('message starts with "cannot write output file"', index(err%message, 'cannot write output file') == 1)
      call check('no .part file', .not. exists(sink%temp_path()))
      call check('no output file', .not. exists(path))
      call sink%abort()   ! harmless after a failed open
   end subroutine test_bad_directory

   subroutine test_abort()
      type(element_metrics_t) :: metrics(1)   ! one per element of the test meta
      type(hdf5_sink_t) :: sink
      type(run_meta_t) :: meta
      type(sample_t) :: smp
      type(error_t), allocatable :: err
      type(event_t) :: events(0)
      type(run_stats_t) :: stats
      character(len=:), allocatable :: path
      integer :: k

      call test_begin('abort removes the .part file; the sink can be reused')
      path = tmp//'_abort.h5'
      meta = small_meta()
      call sink%abort()   ! before any open: nothing to do
      sink%path = path
      sink%block_rows = 64
      call sink%open(meta, err)
      call check_no_error('open', err)
      if (allocated(err)) return
      call alloc_sample(smp, 3, 2, 1)
      do k = 1, 100          ! one block already on disk
         call fill_sample(smp, k)
         call sink%write_sample(smp, err)
      end do
      call check('.part exists before abort', exists(sink%temp_path()))
      call sink%abort()
      call check('.part removed by abort', .not. exists(sink%temp_path()))
      call check('no output file after abort', .not. exists(path))
      call sink%abort()   ! idempotent

      call sink%open(meta, err)
      call check_no_error('re-open after abort', err)
      if (allocated(err)) return
      call fill_sample(smp, 1)
      call sink%write_sample(smp, err)
      call sink%close(events, stats, metrics, err)
      call check_no_error('close after re-open', err)
      call check('output published after re-open', exists(path))
      call check('no .part after re-open and close', .not. exists(sink%temp_path()))
      call remove_file(path)
   end subroutine test_abort

   subroutine test_misuse()
      type(element_metrics_t) :: metrics(1)   ! one per element of the test meta
      type(hdf5_sink_t) :: sink
      type(run_meta_t) :: meta
      type(sample_t) :: smp
      type(error_t), allocatable :: err
      type(event_t) :: events(0)
      type(run_stats_t) :: stats
      character(len=:), allocatable :: path

      call test_begin('misuse is reported, not fatal')
      path = tmp//'_misuse.h5'
      call alloc_sample(smp, 3, 2, 1)
      call sink%write_sample(smp, err)
      call check('write_sample before open -> err_internal', allocated(err))
      if (allocated(err)) call check('  code', err%code == err_internal)
      call sink%close(events, stats, metrics, err)
      call check('close before open -> err_internal', allocated(err))
      call sink%open(meta, err)
      call check('open without a path -> err_io', allocated(err))
      if (allocated(err)) call check('  code', err%code == err_io)

      meta = small_meta()
      sink%path = path
      call sink%open(meta, err)
      call check_no_error('open', err)
      if (allocated(err)) return
      call sink%open(meta, err)
      call check('second open -> error', allocated(err))
      call fill_sample(smp, 1)
      deallocate (smp%y)
      allocate (smp%y(5), source=0.0_wp)   ! 5 states for a 3-state run
      call sink%write_sample(smp, err)
      call check('wrong state count -> err_internal', allocated(err))
      if (allocated(err)) call check('  code', err%code == err_internal)
      call check('.part removed after the error', .not. exists(sink%temp_path()))
      call check('nothing published', .not. exists(path))
   end subroutine test_misuse

   !> The layout check in Python, when /usr/bin/python3 with h5py is available.
   subroutine test_python_layout()
      character(len=*), parameter :: py = '/usr/bin/python3'
      character(len=:), allocatable :: script
      character(len=512) :: src
      integer :: stat, cstat, n
      logical :: found

      call test_begin('tests/check_h5_layout.py accepts the files')
      script = 'tests/check_h5_layout.py'
      call get_environment_variable('TRAINSIM_SOURCE_DIR', src, n, stat)
      if (stat == 0 .and. n > 0) script = trim(src)//'/'//script
      found = exists(py)
      if (found) found = exists(script)
      if (.not. found) then
         write (*, '(a)') '    skipped: '//py//' or '//script//' not found'
         return
      end if
      call execute_command_line(py//' -c "import h5py" 2>/dev/null', exitstat=stat, cmdstat=cstat)
      if (cstat /= 0 .or. stat /= 0) then
         write (*, '(a)') '    skipped: h5py not importable by '//py
         return
      end if
      call execute_command_line(py//' '//script//' '//main_file, exitstat=stat, cmdstat=cstat)
      call check('layout check of the full run passes', cstat == 0 .and. stat == 0)
      call execute_command_line(py//' '//script//' '//empty_file, exitstat=stat, cmdstat=cstat)
      call check('layout check of the element-less run passes', cstat == 0 .and. stat == 0)
   end subroutine test_python_layout

   !> Open HDF5 objects of all kinds (files, groups, datasets, attributes, datatypes).
   !> h5fget_obj_count_f of HDF5 1.10 subtracts an offset that changes with each h5open_f
   !> call, so only differences between counts taken after the sink's (single) h5open_f
   !> are meaningful.
   integer(size_t) function open_objects() result(n_open)
      integer :: hdferr
      call h5fget_obj_count_f(int(H5F_OBJ_ALL_F, hid_t), H5F_OBJ_ALL_F, n_open, hdferr)
      if (hdferr < 0) n_open = -huge(1_size_t)
   end function open_objects

   !> Every file, group, dataset, attribute and datatype the sink opened has been closed.
   subroutine test_no_leaks()
      integer(size_t) :: n_open
      call test_begin('no HDF5 files, groups, datasets, attributes or datatypes left open')
      n_open = open_objects()
      if (n_open /= baseline_objects) write (*, '(a,i0)') '    objects left open: ', n_open - baseline_objects
      call check('no HDF5 objects left open', n_open == baseline_objects)
   end subroutine test_no_leaks

   ! ----------------------------------------------------------- HDF5 readers

   logical function same(a, b)
      integer(hsize_t), intent(in) :: a(:)
      integer, intent(in) :: b(:)
      same = size(a) == size(b)
      if (same) same = all(a == int(b, hsize_t))
   end function same

   logical function same_names(a, b)
      type(string_t), allocatable, intent(in) :: a(:)
      character(len=*), intent(in) :: b(:)
      integer :: i
      same_names = .false.
      if (.not. allocated(a)) return
      if (size(a) /= size(b)) return
      do i = 1, size(b)
         if (a(i)%s /= trim(b(i)) .or. len(a(i)%s) /= len_trim(b(i))) return
      end do
      same_names = .true.
   end function same_names

   logical function has_dset(fid, name)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: name
      integer(hid_t) :: d
      integer :: hdferr
      call h5dopen_f(fid, name, d, hdferr)
      has_dset = hdferr >= 0
      if (has_dset) call h5dclose_f(d, hdferr)
   end function has_dset

   subroutine dset_dims(fid, name, dims, maxdims)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: name
      integer(hsize_t), allocatable, intent(out) :: dims(:), maxdims(:)
      integer(hid_t) :: d, sp
      integer :: hdferr, rank
      allocate (dims(0), maxdims(0))
      call h5dopen_f(fid, name, d, hdferr)
      call check('open dataset '//name, hdferr >= 0)
      if (hdferr < 0) return
      call h5dget_space_f(d, sp, hdferr)
      call h5sget_simple_extent_ndims_f(sp, rank, hdferr)
      deallocate (dims, maxdims)
      allocate (dims(rank), maxdims(rank))
      call h5sget_simple_extent_dims_f(sp, dims, maxdims, hdferr)
      call h5sclose_f(sp, hdferr)
      call h5dclose_f(d, hdferr)
   end subroutine dset_dims

   integer function n_filters(fid, name) result(nf)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: name
      integer(hid_t) :: d, plist
      integer :: hdferr
      nf = 0
      call h5dopen_f(fid, name, d, hdferr)
      if (hdferr < 0) return
      call h5dget_create_plist_f(d, plist, hdferr)
      call h5pget_nfilters_f(plist, nf, hdferr)
      call h5pclose_f(plist, hdferr)
      call h5dclose_f(d, hdferr)
   end function n_filters

   subroutine read_r1(fid, name, buf)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: name
      real(wp), allocatable, intent(out) :: buf(:)
      integer(hsize_t), allocatable :: dims(:), maxdims(:)
      integer(hid_t) :: d
      integer :: hdferr
      call dset_dims(fid, name, dims, maxdims)
      allocate (buf(0))
      if (size(dims) /= 1) return
      deallocate (buf)
      allocate (buf(dims(1)))
      call h5dopen_f(fid, name, d, hdferr)
      call h5dread_f(d, H5T_NATIVE_DOUBLE, buf, dims, hdferr)
      call check('read '//name, hdferr >= 0)
      call h5dclose_f(d, hdferr)
   end subroutine read_r1

   subroutine read_i1(fid, name, buf)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: name
      integer, allocatable, intent(out) :: buf(:)
      integer(hsize_t), allocatable :: dims(:), maxdims(:)
      integer(hid_t) :: d
      integer :: hdferr
      call dset_dims(fid, name, dims, maxdims)
      allocate (buf(0))
      if (size(dims) /= 1) return
      deallocate (buf)
      allocate (buf(dims(1)))
      call h5dopen_f(fid, name, d, hdferr)
      call h5dread_f(d, H5T_NATIVE_INTEGER, buf, dims, hdferr)
      call check('read '//name, hdferr >= 0)
      call h5dclose_f(d, hdferr)
   end subroutine read_i1

   subroutine read_r2(fid, name, buf)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: name
      real(wp), allocatable, intent(out) :: buf(:, :)
      integer(hsize_t), allocatable :: dims(:), maxdims(:)
      integer(hid_t) :: d
      integer :: hdferr
      call dset_dims(fid, name, dims, maxdims)
      allocate (buf(0, 0))
      if (size(dims) /= 2) return
      deallocate (buf)
      allocate (buf(dims(1), dims(2)))
      call h5dopen_f(fid, name, d, hdferr)
      call h5dread_f(d, H5T_NATIVE_DOUBLE, buf, dims, hdferr)
      call check('read '//name, hdferr >= 0)
      call h5dclose_f(d, hdferr)
   end subroutine read_r2

   subroutine read_i2(fid, name, buf)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: name
      integer, allocatable, intent(out) :: buf(:, :)
      integer(hsize_t), allocatable :: dims(:), maxdims(:)
      integer(hid_t) :: d
      integer :: hdferr
      call dset_dims(fid, name, dims, maxdims)
      allocate (buf(0, 0))
      if (size(dims) /= 2) return
      deallocate (buf)
      allocate (buf(dims(1), dims(2)))
      call h5dopen_f(fid, name, d, hdferr)
      call h5dread_f(d, H5T_NATIVE_INTEGER, buf, dims, hdferr)
      call check('read '//name, hdferr >= 0)
      call h5dclose_f(d, hdferr)
   end subroutine read_i2

   !> Scalar fixed-length string attribute.
   !> Texts behind an array of C string pointers (variable-length strings as read).
   function from_pointers(ptrs) result(list)
      type(c_ptr), intent(in) :: ptrs(:)
      type(string_t), allocatable :: list(:)
      character(kind=c_char), pointer :: chars(:)
      integer :: i, j, n
      allocate (list(size(ptrs)))
      do i = 1, size(ptrs)
         n = 0
         if (c_associated(ptrs(i))) n = int(c_strlen(ptrs(i)))
         if (n == 0) then
            list(i)%s = ''
            cycle
         end if
         call c_f_pointer(ptrs(i), chars, [n])
         allocate (character(len=n) :: list(i)%s)
         do j = 1, n
            list(i)%s(j:j) = chars(j)
         end do
      end do
   end function from_pointers

   !> Scalar variable-length string attribute (the writer's only string form).
   subroutine read_str_attr(fid, obj, name, txt)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: obj, name
      character(len=:), allocatable, intent(out) :: txt
      type(string_t), allocatable :: list(:)
      call read_vlen(fid, obj, name, .true., list)
      txt = '<missing>'
      if (size(list) == 1) txt = list(1)%s
   end subroutine read_str_attr

   !> 1-D variable-length string attribute.
   subroutine read_str_list(fid, obj, name, list)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: obj, name
      type(string_t), allocatable, intent(out) :: list(:)
      call read_vlen(fid, obj, name, .true., list)
   end subroutine read_str_list

   !> 1-D variable-length string dataset.
   subroutine read_str_dset(fid, name, list)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: name
      type(string_t), allocatable, intent(out) :: list(:)
      call read_vlen(fid, name, '', .false., list)
   end subroutine read_str_dset

   !> Variable-length UTF-8 strings of an attribute `obj@name` or a dataset `obj`.
   subroutine read_vlen(fid, obj, name, is_attr, list)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: obj, name
      logical, intent(in) :: is_attr
      type(string_t), allocatable, intent(out) :: list(:)
      integer(hid_t) :: h, t, sp
      integer(hsize_t) :: dims(1), maxdims(1)
      integer :: hdferr, rank, cset
      logical :: vlen
      type(c_ptr), allocatable, target :: ptrs(:)
      type(c_ptr) :: buf
      allocate (list(0))
      if (is_attr) then
         call h5aopen_by_name_f(fid, obj, name, h, hdferr)
         call check('attribute '//obj//'@'//name//' exists', hdferr >= 0)
         if (hdferr < 0) return
         call h5aget_type_f(h, t, hdferr)
         call h5aget_space_f(h, sp, hdferr)
      else
         call h5dopen_f(fid, obj, h, hdferr)
         call check('dataset '//obj//' exists', hdferr >= 0)
         if (hdferr < 0) return
         call h5dget_type_f(h, t, hdferr)
         call h5dget_space_f(h, sp, hdferr)
      end if
      call h5tis_variable_str_f(t, vlen, hdferr)
      call check(obj//'@'//name//' is a variable-length string (h5py reads str)', vlen)
      call h5tget_cset_f(t, cset, hdferr)
      call check(obj//'@'//name//' is marked UTF-8', cset == H5T_CSET_UTF8_F)
      call h5sget_simple_extent_ndims_f(sp, rank, hdferr)
      dims = 1
      if (rank == 1) call h5sget_simple_extent_dims_f(sp, dims, maxdims, hdferr)
      call h5sclose_f(sp, hdferr)
      allocate (ptrs(dims(1)))
      if (vlen .and. dims(1) > 0) then
         buf = c_loc(ptrs)
         if (is_attr) then
            call h5aread_f(h, t, buf, hdferr)
         else
            call h5dread_f(h, t, buf, hdferr)
         end if
         call check('read '//obj//'@'//name, hdferr >= 0)
         if (hdferr >= 0) list = from_pointers(ptrs)
      else if (vlen) then
         deallocate (list)
         allocate (list(0))
      end if
      call h5tclose_f(t, hdferr)
      if (is_attr) then
         call h5aclose_f(h, hdferr)
      else
         call h5dclose_f(h, hdferr)
      end if
   end subroutine read_vlen

   subroutine read_int_attr(fid, obj, name, buf)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: obj, name
      integer, allocatable, intent(out) :: buf(:)
      integer(hid_t) :: a, sp
      integer(hsize_t) :: dims(1), maxdims(1)
      integer :: hdferr
      allocate (buf(0))
      call h5aopen_by_name_f(fid, obj, name, a, hdferr)
      call check('attribute '//obj//'@'//name//' exists', hdferr >= 0)
      if (hdferr < 0) return
      call h5aget_space_f(a, sp, hdferr)
      call h5sget_simple_extent_dims_f(sp, dims, maxdims, hdferr)
      call h5sclose_f(sp, hdferr)
      deallocate (buf)
      allocate (buf(dims(1)))
      call h5aread_f(a, H5T_NATIVE_INTEGER, buf, dims, hdferr)
      call check('read '//obj//'@'//name, hdferr >= 0)
      call h5aclose_f(a, hdferr)
   end subroutine read_int_attr

   real(wp) function read_real_attr(fid, obj, name) result(value)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: obj, name
      integer(hid_t) :: a
      integer :: hdferr
      value = -huge(1.0_wp)
      call h5aopen_by_name_f(fid, obj, name, a, hdferr)
      call check('attribute '//obj//'@'//name//' exists', hdferr >= 0)
      if (hdferr < 0) return
      call h5aread_f(a, H5T_NATIVE_DOUBLE, value, [1_hsize_t], hdferr)
      call h5aclose_f(a, hdferr)
   end function read_real_attr

   integer function read_int_scalar(fid, obj, name) result(value)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: obj, name
      integer(hid_t) :: a
      integer :: hdferr
      value = -huge(1)
      call h5aopen_by_name_f(fid, obj, name, a, hdferr)
      call check('attribute '//obj//'@'//name//' exists', hdferr >= 0)
      if (hdferr < 0) return
      call h5aread_f(a, H5T_NATIVE_INTEGER, value, [1_hsize_t], hdferr)
      call h5aclose_f(a, hdferr)
   end function read_int_scalar

   integer(i8) function read_i8_attr(fid, obj, name) result(value)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: obj, name
      integer(hid_t) :: a
      integer :: hdferr
      value = -huge(1_i8)
      call h5aopen_by_name_f(fid, obj, name, a, hdferr)
      call check('attribute '//obj//'@'//name//' exists', hdferr >= 0)
      if (hdferr < 0) return
      call h5aread_f(a, h5kind_to_type(i8, H5_INTEGER_KIND), value, [1_hsize_t], hdferr)
      call h5aclose_f(a, hdferr)
   end function read_i8_attr
end program test_hdf5_sink
