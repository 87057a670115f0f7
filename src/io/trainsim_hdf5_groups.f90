!> The describing parts of a run file (docs/output-format.md): root attributes,
!> /deck_files, /nodes and /elements with their series, ids, types and parameters,
!> /metrics and /run_stats, and the units of every column. Written by the run sink
!> (trainsim_hdf5) through the generic HDF5 layer (trainsim_h5, trainsim_h5_dsets).
module trainsim_hdf5_groups
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_io
   use trainsim_strings, only: string_t, str
   use trainsim_version, only: git_revision
   use trainsim_sink, only: run_meta_t, run_stats_t, element_metrics_t, param_list_t
   use trainsim_orders, only: n_orders
   use trainsim_h5, only: hid_t, h5_real, h5_int, make_group, close_group, list_text, put_str_attr, &
      put_names_attr, put_list_attr, put_index_attr, put_real_attr, put_int_attr, put_i8_attr
   use trainsim_h5_dsets, only: make_series, put_column_r, put_column_i
   implicit none
   private

   public :: run_units_t, set_units, state_units, write_root_attributes, write_deck_files
   public :: make_node_group, make_element_group, write_metrics, write_stats
   public :: label_columns, units_of, same_units, to_list, count_of, opt_text

   !> Dataset names under /elements (element ids must not clash with them).
   character(len=*), parameter :: element_sets(6) = [character(len=12) :: &
      'torque_left', 'torque_right', 'displacement', 'force', 'contact', 'pairs']
   !> Dataset names under /nodes.
   character(len=*), parameter :: node_sets(2) = [character(len=5) :: 'theta', 'omega']

   !> Units of a run (length, force, torque, energy) and of each element's
   !> displacement and force columns (for the `units` attributes).
   type :: run_units_t
      character(len=:), allocatable :: len, force, torque, energy
      type(string_t), allocatable :: el_disp(:), el_force(:)
   end type run_units_t

contains

   !> Units of the run's unit system and of each of its `n_el` elements' displacement and force.
   subroutine set_units(u, meta, n_el)
      type(run_units_t), intent(out) :: u
      type(run_meta_t), intent(in) :: meta
      integer, intent(in) :: n_el
      integer :: i
      character(len=:), allocatable :: d
      if (opt_text(meta%units) == 'si') then
         u%len = 'm'; u%force = 'N'; u%torque = 'N*m'; u%energy = 'J'
      else
         u%len = 'in'; u%force = 'lbf'; u%torque = 'lbf*in'; u%energy = 'lbf*in'
      end if
      u%el_disp = same_units(n_el, '')
      u%el_force = same_units(n_el, '')
      do i = 1, n_el
         d = list_text(meta%element_disp_units, i)
         if (len(d) == 0) d = 'rad'
         u%el_disp(i)%s = d
         ! an element whose displacement is an angle has a torque for its force (shaft, coupling)
         if (d == 'rad') then
            u%el_force(i)%s = u%torque
         else
            u%el_force(i)%s = u%force
         end if
      end do
   end subroutine set_units

   !> Unit of each of `n` states from its name (node.angle, node.speed, motor.current, energy.*).
   function state_units(u, names, n) result(units)
      type(run_units_t), intent(in) :: u
      type(string_t), allocatable, intent(in) :: names(:)
      integer, intent(in) :: n
      type(string_t), allocatable :: units(:)
      character(len=:), allocatable :: nm
      integer :: i
      allocate (units(n))
      do i = 1, n
         nm = list_text(names, i)
         if (ends_with(nm, '.angle')) then
            units(i)%s = 'rad'
         else if (ends_with(nm, '.speed')) then
            units(i)%s = 'rad/s'
         else if (ends_with(nm, '.current')) then
            units(i)%s = 'A'
         else if (index(nm, 'energy.') == 1) then
            units(i)%s = u%energy
         else
            units(i)%s = '1'
         end if
      end do
   end function state_units

   !> Root attributes: what the run was (title, deck, units, version, integrator), and
   !> `kv_absent` when its gear meshes have no static reference (why; D-138).
   subroutine write_root_attributes(file, meta, err)
      integer(hid_t), intent(in) :: file
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      call put_str_attr(file, 'title', opt_text(meta%title), err)
      if (.not. allocated(err)) call put_str_attr(file, 'deck_file', opt_text(meta%deck_file), err)
      if (.not. allocated(err)) then   ! the deck text may be long: no copy
         if (allocated(meta%deck_text)) then
            call put_str_attr(file, 'deck', meta%deck_text, err)
         else
            call put_str_attr(file, 'deck', '', err)
         end if
      end if
      if (.not. allocated(err)) call put_str_attr(file, 'overrides', opt_text(meta%overrides), err)
      if (.not. allocated(err)) call put_str_attr(file, 'units', opt_text(meta%units), err)
      if (.not. allocated(err)) call put_str_attr(file, 'trainsim_version', opt_text(meta%version), err)
      if (.not. allocated(err)) call put_str_attr(file, 'git_revision', git_revision(), err)
      if (.not. allocated(err)) call put_str_attr(file, 'integrator', opt_text(meta%integrator), err)
      if (.not. allocated(err)) call put_str_attr(file, 'created', iso_now(), err)
      if (len(opt_text(meta%kv_absent)) > 0 .and. .not. allocated(err)) &   ! (only then: D-138)
         call put_str_attr(file, 'kv_absent', meta%kv_absent, err)
      if (.not. allocated(err)) call write_deck_files(file, meta%input_keys, meta%input_files, &
                                                      meta%input_texts, err)
   end subroutine write_root_attributes

   !> /deck_files: the files the deck read (table_file), beside the deck text, so the
   !> file holds every input of the run. Attributes `paths` (as the deck wrote them),
   !> `files` (as opened) and `texts` (their contents), one entry per file.
   !> (Also the sweep file's.)
   subroutine write_deck_files(loc, keys, files, texts, err)
      integer(hid_t), intent(in) :: loc
      type(string_t), allocatable, intent(in) :: keys(:), files(:), texts(:)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: n
      n = 0
      if (allocated(files)) n = size(files)
      if (n == 0) return
      call make_group(loc, 'deck_files', grp, err)
      if (allocated(err)) return
      call put_names_attr(grp, 'paths', keys, n, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'files', files, n, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'texts', texts, n, err)
      call close_group(grp, err)
   end subroutine write_deck_files

   !> /nodes: angle and speed series (`rows` a chunk), ids, types, parameters.
   subroutine make_node_group(file, meta, n, rows, level, d_theta, d_omega, err)
      integer(hid_t), intent(in) :: file
      type(run_meta_t), intent(in) :: meta
      integer, intent(in) :: n, rows
      integer, intent(in) :: level   !< zlib level, 0: none
      integer(hid_t), intent(out) :: d_theta, d_omega
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: i
      d_theta = -1; d_omega = -1
      call make_group(file, 'nodes', grp, err)
      if (allocated(err)) return
      call make_series(grp, 'theta', 2, n, rows, h5_real, level, d_theta, err)
      if (.not. allocated(err)) call make_series(grp, 'omega', 2, n, rows, h5_real, level, d_omega, err)
      if (.not. allocated(err)) call label_columns(d_theta, meta%node_ids, same_units(n, 'rad'), 'rad', err)
      if (.not. allocated(err)) call label_columns(d_omega, meta%node_ids, same_units(n, 'rad/s'), 'rad/s', err)
      if (.not. allocated(err)) call put_names_attr(grp, 'ids', meta%node_ids, n, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'types', meta%node_types, n, err)
      if (.not. allocated(err) .and. allocated(meta%node_params)) then
         if (size(meta%node_params) /= n) then
            call fatal_error(err, 'run description has '//str(size(meta%node_params))// &
                             ' node parameter lists for '//str(n)//' nodes', err_io)
         else
            do i = 1, n
               call put_param_group(grp, member_name(meta%node_ids, i), node_sets, meta%node_params(i), 'node', err)
               if (allocated(err)) exit
            end do
         end if
      end if
      call close_group(grp, err)
   end subroutine make_node_group

   !> /elements: torque, displacement, force, contact and zone series (`d`, in the
   !> order of element_sets), ids, types, node indices, displacement units, parameters.
   subroutine make_element_group(file, meta, u, n, rows, level, d, err)
      integer(hid_t), intent(in) :: file
      type(run_meta_t), intent(in) :: meta
      type(run_units_t), intent(in) :: u
      integer, intent(in) :: n, rows
      integer, intent(in) :: level   !< zlib level, 0: none
      integer(hid_t), intent(out) :: d(6)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: i
      d = -1
      call make_group(file, 'elements', grp, err)
      if (allocated(err)) return
      do i = 1, 6
         call make_series(grp, trim(element_sets(i)), 2, n, rows, merge(h5_int, h5_real, i >= 5), level, d(i), err)
         if (allocated(err)) exit
      end do
      if (.not. allocated(err)) call label_columns(d(1), meta%element_ids, same_units(n, u%torque), u%torque, err)
      if (.not. allocated(err)) call label_columns(d(2), meta%element_ids, same_units(n, u%torque), u%torque, err)
      if (.not. allocated(err)) call label_columns(d(3), meta%element_ids, u%el_disp, u%len, err)
      if (.not. allocated(err)) call label_columns(d(4), meta%element_ids, u%el_force, u%force, err)
      if (.not. allocated(err)) call label_columns(d(5), meta%element_ids, same_units(n, '1'), '1', err)
      if (.not. allocated(err)) call label_columns(d(6), meta%element_ids, same_units(n, '1'), '1', err)
      if (.not. allocated(err)) call put_names_attr(grp, 'ids', meta%element_ids, n, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'types', meta%element_types, n, err)
      if (.not. allocated(err)) call put_index_attr(grp, 'left', meta%element_left, n, err)
      if (.not. allocated(err)) call put_index_attr(grp, 'right', meta%element_right, n, err)
      if (.not. allocated(err)) call put_names_attr(grp, 'displacement_units', meta%element_disp_units, n, err)
      if (.not. allocated(err)) then
         if (allocated(meta%element_params)) then
            if (size(meta%element_params) /= n) then
               call fatal_error(err, 'run description has '//str(size(meta%element_params))// &
                                ' element parameter lists for '//str(n)//' elements', err_io)
            end if
         end if
      end if
      if (.not. allocated(err)) then
         do i = 1, n
            if (allocated(meta%element_params)) then
               call put_param_group(grp, member_name(meta%element_ids, i), element_sets, &
                                    meta%element_params(i), 'element', err)
            else
               call put_param_group(grp, member_name(meta%element_ids, i), element_sets, &
                                    param_list_t(), 'element', err)
            end if
            if (allocated(err)) exit
         end do
      end if
      call close_group(grp, err)
   end subroutine make_element_group

   !> /metrics: one 1-D dataset per figure, one entry per element (the order of
   !> /elements/ids), over t >= t_start + settle_time.
   subroutine write_metrics(file, u, m, err)
      integer(hid_t), intent(in) :: file
      type(run_units_t), intent(in) :: u
      type(element_metrics_t), intent(in) :: m(:)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      real(wp) :: r(size(m))
      integer :: k(size(m)), n
      type(string_t), allocatable :: vel(:), tq(:), cnt(:), sec(:)
      n = size(m)
      allocate (vel, source=per_second(u%el_disp))   ! not `vel = ...`: gfortran 12 false -Wmaybe-uninitialized
      tq = same_units(n, u%torque)
      cnt = same_units(n, '1')
      sec = same_units(n, 's')
      call make_group(file, 'metrics', grp, err)
      if (allocated(err)) return
      r = m%torque_min; call put_column_r(grp, 'torque_min', r, err, tq)
      r = m%torque_max; if (.not. allocated(err)) call put_column_r(grp, 'torque_max', r, err, tq)
      r = m%force_min; if (.not. allocated(err)) call put_column_r(grp, 'force_min', r, err, u%el_force)
      r = m%force_max; if (.not. allocated(err)) call put_column_r(grp, 'force_max', r, err, u%el_force)
      r = m%disp_min; if (.not. allocated(err)) call put_column_r(grp, 'displacement_min', r, err, u%el_disp)
      r = m%disp_max; if (.not. allocated(err)) call put_column_r(grp, 'displacement_max', r, err, u%el_disp)
      r = m%p2p_range; if (.not. allocated(err)) call put_column_r(grp, 'p2p_range', r, err, u%el_disp)
      r = m%p2p_mean; if (.not. allocated(err)) call put_column_r(grp, 'p2p_mean', r, err, u%el_disp)
      k = m%p2p_swings; if (.not. allocated(err)) call put_column_i(grp, 'p2p_swings', k, err, cnt)
      k = m%impacts; if (.not. allocated(err)) call put_column_i(grp, 'impacts', k, err, cnt)
      k = m%separations; if (.not. allocated(err)) call put_column_i(grp, 'separations', k, err, cnt)
      k = m%zone_changes; if (.not. allocated(err)) call put_column_i(grp, 'zone_changes', k, err, cnt)
      r = m%max_approach_velocity; if (.not. allocated(err)) call put_column_r(grp, 'max_approach_velocity', r, err, vel)
      r = m%max_peak_force; if (.not. allocated(err)) call put_column_r(grp, 'max_peak_force', r, err, u%el_force)
      r = m%time_out_of_contact; if (.not. allocated(err)) call put_column_r(grp, 'time_out_of_contact', r, err, sec)
      r = m%load_sharing; if (.not. allocated(err)) call put_column_r(grp, 'load_sharing', r, err, cnt)
      r = m%kv; if (.not. allocated(err)) call put_column_r(grp, 'kv', r, err, cnt)
      r = m%static_force; if (.not. allocated(err)) call put_column_r(grp, 'static_force', r, err, u%el_force)
      r = m%static_te_mean; if (.not. allocated(err)) call put_column_r(grp, 'static_te_mean', r, err, u%el_disp)
      r = m%static_te_p2p; if (.not. allocated(err)) call put_column_r(grp, 'static_te_p2p', r, err, u%el_disp)
      r = m%force_mean; if (.not. allocated(err)) call put_column_r(grp, 'force_mean', r, err, u%el_force)
      do n = 1, n_orders   ! (n is free here)
         r = m%te_order(n); if (.not. allocated(err)) call put_column_r(grp, 'te_order_'//str(n), r, err, u%el_disp)
      end do
      do n = 1, n_orders
         r = m%force_order(n); if (.not. allocated(err)) call put_column_r(grp, 'force_order_'//str(n), r, err, u%el_force)
      end do
      r = m%rattle_impacts; if (.not. allocated(err)) call put_column_r(grp, 'rattle_impacts', r, err, cnt)
      r = m%rattle_open; if (.not. allocated(err)) call put_column_r(grp, 'rattle_open', r, err, cnt)
      r = m%rattle_criterion; if (.not. allocated(err)) call put_column_r(grp, 'rattle_criterion', r, err, cnt)
      r = m%rattle_energy; if (.not. allocated(err)) &
         call put_column_r(grp, 'rattle_energy', r, err, same_units(size(m), u%energy))
      r = m%rattle_power; if (.not. allocated(err)) &
         call put_column_r(grp, 'rattle_power', r, err, same_units(size(m), u%energy//'/s'))
      call close_group(grp, err)
   end subroutine write_metrics

   !> /run_stats: counters (64-bit), timings and the completion flag as attributes.
   subroutine write_stats(file, stats, err)
      integer(hid_t), intent(in) :: file
      type(run_stats_t), intent(in) :: stats
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: completed

      call make_group(file, 'run_stats', grp, err)
      if (allocated(err)) return
      completed = merge(1, 0, stats%completed)
      call put_i8_attr(grp, 'steps', stats%steps, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'rhs_evals', stats%rhs_evals, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'jac_evals', stats%jac_evals, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'root_returns', stats%root_returns, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'error_test_fails', stats%error_test_fails, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'conv_fails', stats%conv_fails, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'events', stats%events, err)
      if (.not. allocated(err)) call put_i8_attr(grp, 'rejected', stats%rejected, err)
      if (.not. allocated(err)) call put_real_attr(grp, 'wall_time', stats%wall_time, err)
      if (.not. allocated(err)) call put_real_attr(grp, 't_final', stats%t_final, err)
      if (.not. allocated(err)) call put_int_attr(grp, 'completed', completed, err)
      if (.not. allocated(err)) call put_real_attr(grp, 't_metrics', stats%t_metrics, err)
      if (stats%settle_status /= 0) then   ! settling until periodic (&run settle_tol)
         if (.not. allocated(err)) call put_int_attr(grp, 'settled', merge(1, 0, stats%settle_status == 1 .or. &
                                                                           stats%settle_status == 3), err)
         if (.not. allocated(err)) call put_int_attr(grp, 'settle_tol_given', merge(1, 0, stats%settle_status <= 2), err)
         if (.not. allocated(err)) call put_int_attr(grp, 'settle_periods', stats%settle_periods, err)
         if (.not. allocated(err)) call put_int_attr(grp, 'settle_k', stats%settle_k, err)
      end if
      call close_group(grp, err)
   end subroutine write_stats

   !> Subgroup `<parent>/<name>` holding one scalar real attribute per parameter.
   subroutine put_param_group(parent, name, reserved, params, what, err)
      integer(hid_t), intent(in) :: parent
      character(len=*), intent(in) :: name, what
      character(len=*), intent(in) :: reserved(:)
      type(param_list_t), intent(in) :: params
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: grp
      integer :: j, n
      if (any(reserved == name)) then
         call fatal_error(err, what//" id '"//name//"' clashes with the dataset of that name", err_io)
         return
      end if
      if (index(name, '/') > 0 .or. name == '.' .or. name == '..') then
         call fatal_error(err, what//" id '"//name//"' cannot be used as an HDF5 group name", err_io)
         return
      end if
      n = 0
      if (allocated(params%values)) n = size(params%values)
      if (n > 0) then
         if (.not. allocated(params%names)) then
            call fatal_error(err, what//" '"//name//"': parameter names are missing", err_io)
            return
         end if
         if (size(params%names) /= n) then
            call fatal_error(err, what//" '"//name//"': "//str(size(params%names))// &
                             ' parameter names for '//str(n)//' values', err_io)
            return
         end if
      end if
      call make_group(parent, name, grp, err)
      if (allocated(err)) return
      do j = 1, n
         if (len(list_text(params%names, j)) == 0) then
            call fatal_error(err, what//" '"//name//"': parameter "//str(j)//' has no name', err_io)
            exit
         end if
         call put_real_attr(grp, list_text(params%names, j), params%values(j), err)
         if (allocated(err)) then
            err%message = what//" '"//name//"': "//err%message//' (duplicate name?)'
            exit
         end if
      end do
      call close_group(grp, err)
   end subroutine put_param_group

   !> `column_names` and `column_units` of a 2-D series (one per column) and its `units`:
   !> the columns' common unit, `mixed: see column_units`, or `empty_unit` with no columns.
   subroutine label_columns(dset, names, units, empty_unit, err)
      integer(hid_t), intent(in) :: dset
      type(string_t), allocatable, intent(in) :: names(:)
      type(string_t), intent(in) :: units(:)
      character(len=*), intent(in) :: empty_unit
      type(error_t), allocatable, intent(out) :: err
      integer :: i
      logical :: same
      call put_names_attr(dset, 'column_names', names, size(units), err)
      if (allocated(err)) return
      call put_list_attr(dset, 'column_units', units, err)
      if (allocated(err)) return
      same = .true.
      do i = 2, size(units)
         if (units(i)%s /= units(1)%s) same = .false.
      end do
      if (size(units) == 0) then
         call put_str_attr(dset, 'units', empty_unit, err)
      else if (same) then
         call put_str_attr(dset, 'units', units(1)%s, err)
      else
         call put_str_attr(dset, 'units', 'mixed: see column_units', err)
      end if
   end subroutine label_columns

   ! ------------------------------------------------------------ small utilities

   !> The units of a list that may be unallocated (none).
   pure function units_of(list) result(units)
      type(string_t), allocatable, intent(in) :: list(:)
      type(string_t), allocatable :: units(:)
      if (allocated(list)) then
         units = list
      else
         allocate (units(0))
      end if
   end function units_of

   !> `n` copies of one unit.
   pure function same_units(n, unit) result(list)
      integer, intent(in) :: n
      character(len=*), intent(in) :: unit
      type(string_t) :: list(n)
      integer :: i
      do i = 1, n
         list(i)%s = unit
      end do
   end function same_units

   !> Each unit per second (speeds of displacements).
   pure function per_second(units) result(list)
      type(string_t), intent(in) :: units(:)
      type(string_t) :: list(size(units))
      integer :: i
      do i = 1, size(units)
         list(i)%s = units(i)%s//'/s'
      end do
   end function per_second

   !> A character array as a list (trailing blanks dropped).
   pure function to_list(names) result(list)
      character(len=*), intent(in) :: names(:)
      type(string_t), allocatable :: list(:)
      integer :: i
      allocate (list(size(names)))
      do i = 1, size(names)
         list(i)%s = trim(names(i))
      end do
   end function to_list

   pure logical function ends_with(text, tail)
      character(len=*), intent(in) :: text, tail
      ends_with = .false.
      if (len(text) >= len(tail)) ends_with = text(len(text) - len(tail) + 1:) == tail
   end function ends_with

   !> Number of entries of an optional list.
   pure integer function count_of(list)
      type(string_t), allocatable, intent(in) :: list(:)
      count_of = 0
      if (allocated(list)) count_of = size(list)
   end function count_of

   !> Group name for member `i`: its id, or '_<i>' when the id is empty.
   pure function member_name(list, i) result(name)
      type(string_t), allocatable, intent(in) :: list(:)
      integer, intent(in) :: i
      character(len=:), allocatable :: name
      name = list_text(list, i)
      if (len(name) == 0) name = '_'//str(i)
   end function member_name

   !> An optional deferred-length text ('' when unallocated).
   pure function opt_text(text) result(out)
      character(len=:), allocatable, intent(in) :: text
      character(len=:), allocatable :: out
      out = ''
      if (allocated(text)) out = text
   end function opt_text

   !> Local date and time as ISO 8601, e.g. 2024-05-01T13:45:07+02:00.
   function iso_now() result(stamp)
      character(len=:), allocatable :: stamp
      character(len=8) :: d
      character(len=10) :: t
      character(len=5) :: z
      call date_and_time(date=d, time=t, zone=z)
      stamp = d(1:4)//'-'//d(5:6)//'-'//d(7:8)//'T'//t(1:2)//':'//t(3:4)//':'//t(5:6)
      if (len_trim(z) == 5) stamp = stamp//z(1:3)//':'//z(4:5)
   end function iso_now
end module trainsim_hdf5_groups
