!> &sweep groups -> the runs: grid order (first axis slowest), zip, linear and log
!> spacing with exact end points, and each run's overrides naming its group and value.
program test_sweep_spec
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_deck, only: deck_t, deck_group_t, parse_deck
   use trainsim_overrides, only: override_t, split_sweep_groups
   use trainsim_sweep_spec, only: sweep_spec_t, read_sweep_spec
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   implicit none

   call suite_begin('sweep specification')
   call test_grid_first_axis_slowest_and_zip_in_step()
   call test_linear_and_log_spacing_end_exactly()
   call test_continuation_orders_branches_and_chains_runs()
   call suite_end()

contains

   subroutine spec_of(text, spec, err)
      character(len=*), intent(in) :: text
      type(sweep_spec_t), intent(out) :: spec
      type(error_t), allocatable, intent(out) :: err
      type(deck_t) :: deck
      type(deck_group_t), allocatable :: groups(:)
      call parse_deck(text, 's.nml', deck, err)
      if (allocated(err)) error stop 'test setup: '//err%message
      call split_sweep_groups(deck, groups)
      call check('the &sweep groups are taken out of the deck', deck%count_groups('sweep') == 0)
      call read_sweep_spec(groups, spec, err)
   end subroutine spec_of

   subroutine test_grid_first_axis_slowest_and_zip_in_step()
      type(sweep_spec_t) :: spec
      type(error_t), allocatable :: err
      type(override_t), allocatable :: ovs(:)
      character(len=1), parameter :: nl = new_line('a')
      call test_begin('grid_first_axis_slowest_and_zip_in_step')
      call spec_of("&run t_end = 1, dt = 0.1 /"//nl// &
                   "&sweep parameter = 'g.mesh_frequency', values = 100, 200 /"//nl// &
                   "&sweep parameter = 'g.half_backlash', values = 1e-3, 2e-3, 3e-3 /"//nl// &
                   "&sweep parameter = 'run.t_end', values = 0.1, 0.2, 0.3, mode = 'zip' /", spec, err)
      call check('reads', .not. allocated(err))
      call check('2 x 3 grid = 6 runs (the zipped group adds no axis)', spec%n_runs == 6)
      call check('run 1 = (100, 1e-3, 0.1)', all(spec%values(:, 1) == [100.0_wp, 1.0e-3_wp, 0.1_wp]))
      call check('run 2: the last axis moves first', all(spec%values(:, 2) == [100.0_wp, 2.0e-3_wp, 0.2_wp]))
      call check('run 4: then the first', all(spec%values(:, 4) == [200.0_wp, 1.0e-3_wp, 0.1_wp]))
      call check('run 6', all(spec%values(:, 6) == [200.0_wp, 3.0e-3_wp, 0.3_wp]))
      allocate (ovs, source=spec%overrides(5, err))   ! not `ovs = ...`: gfortran 12 false -Wuninitialized
      call check('run 5 overrides: three, naming group, run and value', size(ovs) == 3 .and. &
                 ovs(2)%origin == "s.nml:3: &sweep #2 (run 5: g.half_backlash = 0.002)")
      call check('... the value as a deck token that reads back exactly', ovs(2)%values(1)%s == '0.002')
      call check('... mesh_frequency is derived', ovs(1)%derived .and. .not. ovs(2)%derived)
   end subroutine test_grid_first_axis_slowest_and_zip_in_step

   subroutine test_linear_and_log_spacing_end_exactly()
      type(sweep_spec_t) :: spec
      type(error_t), allocatable :: err
      character(len=1), parameter :: nl = new_line('a')
      call test_begin('linear_and_log_spacing_end_exactly')
      call spec_of("&sweep parameter = 'g.mesh_frequency', from = 385, to = 645, count = 27 /", spec, err)
      call check('Table 5.5''s 27 speeds: 385, 395, ..., 645 teeth/s', spec%n_runs == 27 .and. &
                 spec%values(1, 1) == 385.0_wp .and. spec%values(1, 27) == 645.0_wp)
      call check('... 10 teeth/s apart', maxval(abs(spec%values(1, 2:) - spec%values(1, :26) - 10.0_wp)) < 1.0e-12_wp)
      call spec_of("&sweep parameter = 'g.stiffness', from = 1e4, to = 1e6, count = 3, scale = 'log' /"//nl, spec, err)
      call check('log: 1e4, 1e5, 1e6', spec%values(1, 1) == 1.0e4_wp .and. spec%values(1, 3) == 1.0e6_wp .and. &
                 abs(spec%values(1, 2) - 1.0e5_wp) < 1.0e-9_wp)
      call spec_of("&sweep parameter = 'g.stiffness', values = 1, 2 /"//nl// &
                   "&sweep parameter = 'g.stiffness', values = 3 /", spec, err)
      call check('a parameter swept twice is an error', allocated(err))
   end subroutine test_linear_and_log_spacing_end_exactly

   subroutine test_continuation_orders_branches_and_chains_runs()
      type(sweep_spec_t) :: spec
      type(error_t), allocatable :: err
      character(len=1), parameter :: nl = new_line('a')
      call test_begin('continuation_orders_branches_and_chains_runs')
      ! values given out of order, a zipped group riding along, a constant
      call spec_of("&sweep parameter = 'g.mesh_frequency', values = 300, 100, 200, continuation = 'both' /"//nl// &
                   "&sweep parameter = 'run.t_end', values = 0.3, 0.1, 0.2, mode = 'zip' /"//nl// &
                   "&sweep parameter = 'g.settle_cycles', values = 10 /", spec, err)
      call check('reads', .not. allocated(err))
      call check('both: up then down, 2 x 3 runs', spec%n_runs == 6)
      call check('up 100, 200, 300 then down 300, 200, 100', &
                 all(spec%values(1, :) == [100.0_wp, 200.0_wp, 300.0_wp, 300.0_wp, 200.0_wp, 100.0_wp]))
      call check('the zipped group goes with its value', &
                 all(spec%values(2, :) == [0.1_wp, 0.2_wp, 0.3_wp, 0.3_wp, 0.2_wp, 0.1_wp]))
      call check('branches 1 1 1 2 2 2', all(spec%branch == [1, 1, 1, 2, 2, 2]))
      call check('each branch starts afresh, then from the run before', all(spec%prev == [0, 1, 2, 0, 4, 5]))
      call spec_of("&sweep parameter = 'g.mesh_frequency', values = 1, 2, continuation = 'down' /", spec, err)
      call check('down: descending, one branch', all(spec%values(1, :) == [2.0_wp, 1.0_wp]) .and. &
                 all(spec%branch == 2) .and. all(spec%prev == [0, 1]))
      call spec_of("&sweep parameter = 'g.mesh_frequency', values = 1, 2, continuation = 'up' /"//nl// &
                   "&sweep parameter = 'g.half_backlash', values = 1e-3, 2e-3 /", spec, err)
      call check('a second axis with several values is an error', allocated(err))
      call spec_of("&sweep parameter = 'g.mesh_frequency', values = 1, 2, continuation = 'sideways' /", spec, err)
      call check('an unknown continuation is an error', allocated(err))
      call spec_of("&sweep parameter = 'g.mesh_frequency', values = 1, 2 /", spec, err)
      call check('without continuation: no branch, no chain', all(spec%branch == 0) .and. all(spec%prev == 0))
   end subroutine test_continuation_orders_branches_and_chains_runs
end program test_sweep_spec
