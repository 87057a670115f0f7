!> The run-up file (D-109): a run-up's tracked blocks in the sweep file's layout, one
!> block a "run", so that scripts/plot_sweep.py draws a run-up on the same axes as a
!> sweep (docs/output-format.md, "Run-up files"):
!>
!>   attributes  format = 'trainsim-runup', format_version, kind = 'runup', title,
!>               deck_file, units, overrides, mesh, from, to, rate, settle_cycles, block_cycles
!>   /parameters/names    ['MESH.mesh_frequency']; /parameters/values (block, 1): the
!>                        block's mesh frequency (teeth/s)
!>   /runs/status (1), branch (1 a run-up, 2 a run-down), settled (-1: not asked),
!>   /runs/t_start, t_end  the block's time span (s)
!>   /elements/ids, types  the mesh; /elements/NAME (block, 1): te_order_0..4 (order 0 the
!>                        mean), force_order_1..4, force_mean, disp_min, disp_max, p2p_range,
!>                        force_min, force_max, static_force (at the block's midpoint), kv,
!>                        impacts, rattle_impacts, rattle_criterion, rattle_energy, rattle_power
!>                        (format_version 2; 1: no static_force, rattle_criterion, _energy, _power,
!>                        and kv against the load as the run starts)
!>   /nodes/ids, types
module trainsim_runup_file
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_io
   use trainsim_strings, only: string_t, str
   use trainsim_h5, only: hid_t, h5_init, create_run_file, close_file, make_group, close_group, put_str_attr
   use trainsim_h5_dsets, only: put_column_s, put_column_r, put_column_i
   use trainsim_h5_slots, only: put_matrix
   use trainsim_orders, only: n_orders
   use trainsim_runup, only: runup_spec_t, runup_blocks_t
   implicit none
   private

   public :: runup_file_info_t, write_runup_file

   !> What the file says of the run besides the blocks.
   type :: runup_file_info_t
      character(len=:), allocatable :: title, deck_file, units, overrides, version
      character(len=:), allocatable :: mesh_id, mesh_type
      type(string_t), allocatable :: node_ids(:), node_types(:)
   end type runup_file_info_t

contains

   subroutine write_runup_file(path, info, spec, b, err)
      character(len=*), intent(in) :: path
      type(runup_file_info_t), intent(in) :: info
      type(runup_spec_t), intent(in) :: spec
      type(runup_blocks_t), intent(in) :: b
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: f, g
      type(string_t) :: one(1)
      type(string_t), allocatable :: none(:)
      integer :: k, hs
      logical :: ok
      call h5_init(err)
      if (allocated(err)) return
      call create_run_file(path, f, err)
      if (allocated(err)) then
         err%message = "cannot create run-up file '"//path//"'"
         return
      end if
      allocate (none(0))
      call put_str_attr(f, 'format', 'trainsim-runup', err)
      if (.not. allocated(err)) call put_str_attr(f, 'format_version', '2', err)
      if (.not. allocated(err)) call put_str_attr(f, 'kind', 'runup', err)
      if (.not. allocated(err)) call put_str_attr(f, 'trainsim_version', info%version, err)
      if (.not. allocated(err)) call put_str_attr(f, 'title', info%title, err)
      if (.not. allocated(err)) call put_str_attr(f, 'deck_file', info%deck_file, err)
      if (.not. allocated(err)) call put_str_attr(f, 'units', info%units, err)
      if (.not. allocated(err)) call put_str_attr(f, 'overrides', info%overrides, err)
      if (.not. allocated(err)) call put_str_attr(f, 'mesh', info%mesh_id, err)
      if (.not. allocated(err)) call put_str_attr(f, 'from', str(spec%f_from), err)
      if (.not. allocated(err)) call put_str_attr(f, 'to', str(spec%f_to), err)
      if (.not. allocated(err)) call put_str_attr(f, 'rate', str(spec%rate), err)
      if (.not. allocated(err)) call put_str_attr(f, 'settle_cycles', str(spec%settle_cycles), err)
      if (.not. allocated(err)) call put_str_attr(f, 'block_cycles', str(spec%block_cycles), err)
      hs = 0
      if (.not. allocated(err)) then
         call make_group(f, 'parameters', g, err)
         one(1)%s = info%mesh_id//'.mesh_frequency'
         if (.not. allocated(err)) call put_column_s(g, 'names', one, err)
         if (.not. allocated(err)) call put_matrix(g, 'values', reshape(b%f, [1, b%n]), hs)
         call close_group(g, err)
      end if
      if (.not. allocated(err) .and. hs >= 0) then
         call make_group(f, 'runs', g, err)
         if (.not. allocated(err)) call put_column_i(g, 'status', [(1, k=1, b%n)], err, none)
         if (.not. allocated(err)) call put_column_i(g, 'branch', [(merge(1, 2, spec%f_to > spec%f_from), k=1, b%n)], &
                                                     err, none)
         if (.not. allocated(err)) call put_column_i(g, 'settled', [(-1, k=1, b%n)], err, none)
         if (.not. allocated(err)) call put_column_r(g, 't_start', b%t0, err, none)
         if (.not. allocated(err)) call put_column_r(g, 't_end', b%t1, err, none)
         call close_group(g, err)
      end if
      if (.not. allocated(err) .and. hs >= 0) then
         call make_group(f, 'elements', g, err)
         one(1)%s = info%mesh_id
         if (.not. allocated(err)) call put_column_s(g, 'ids', one, err)
         one(1)%s = info%mesh_type
         if (.not. allocated(err)) call put_column_s(g, 'types', one, err)
         if (.not. allocated(err)) then
            call col('te_order_0', b%te(1, :))
            do k = 1, n_orders
               call col('te_order_'//str(k), b%te(k + 1, :))
               call col('force_order_'//str(k), b%force(k + 1, :))
            end do
            call col('force_mean', b%force(1, :))
            call col('disp_min', b%te_min)
            call col('disp_max', b%te_max)
            call col('p2p_range', b%te_max - b%te_min)
            call col('force_min', b%force_min)
            call col('force_max', b%force_max)
            call col('static_force', b%static_force)
            call col('kv', b%kv)
            call col('impacts', real(b%impacts, wp))
            call col('rattle_impacts', real(b%impacts, wp)/real(spec%block_cycles, wp))
            call col('rattle_criterion', b%criterion)
            call col('rattle_energy', b%energy)
            call col('rattle_power', b%power)
         end if
         call close_group(g, err)
      end if
      if (.not. allocated(err) .and. hs >= 0) then
         call make_group(f, 'nodes', g, err)
         if (.not. allocated(err)) call put_column_s(g, 'ids', info%node_ids, err)
         if (.not. allocated(err)) call put_column_s(g, 'types', info%node_types, err)
         call close_group(g, err)
      end if
      call close_file(f, ok)
      if (.not. allocated(err) .and. (hs < 0 .or. .not. ok)) &
         call fatal_error(err, "cannot write run-up file '"//path//"'", err_io)
   contains
      subroutine col(name, v)
         character(len=*), intent(in) :: name
         real(wp), intent(in) :: v(:)
         integer :: h
         if (hs < 0) return
         call put_matrix(g, name, reshape(v, [1, size(v)]), h)
         hs = min(hs, h)
      end subroutine col
   end subroutine write_runup_file
end module trainsim_runup_file
