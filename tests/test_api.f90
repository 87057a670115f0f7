!> The public API (module `trainsim`): decks from text and files, parameters set by
!> their deck path (replaced, added, by id, default id or `run`) and checked by the
!> plug-ins when the model is built, runs in memory and into an HDF5 file, metrics and
!> the event table, and every misuse returned as an error value.
program test_api
   use trainsim, only: simulation_t, error_t, wp, event_t, element_metrics_t, run_stats_t, string_t, &
                       err_input, err_io, ev_name, ev_contact_front, ev_contact_rear
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   implicit none

   character(len=1), parameter :: nl = new_line('a')

   call suite_begin('public API (module trainsim)')
   call test_text_deck_runs_and_reports_metrics()
   call test_set_replaces_a_value_by_element_id()
   call test_set_adds_a_missing_key_and_reaches_run_group()
   call test_set_by_default_id()
   call test_bad_values_are_reported_by_the_plugin_with_the_key()
   call test_bad_paths_are_errors()
   call test_results_before_a_run_are_errors()
   call test_file_deck_events_and_hdf5_output()
   call suite_end()

contains

   !> Two disks on a shaft with a clearance coupling to a third: contacts happen.
   function two_disk_deck() result(text)
      character(len=:), allocatable :: text
      text = "&run title = 'api', t_end = 0.05, dt = 1.0e-5 /"//nl// &
             "&node id = 'a', type = 'inertia', inertia = 0.5 /"//nl// &
             "&node id = 'b', type = 'inertia', inertia = 2.0, damping = 1.0 /"//nl// &
             "&node type = 'inertia', inertia = 1.0 /"//nl// &
             "&element id = 'shaft1', type = 'shaft', stiffness = 5.0e4 /"//nl// &
             "&element type = 'clearance_coupling', clearance = 0.002, stiffness = 1.0e5, contact_damping = 3.0 /"//nl// &
             "&load node = 'a', value = 100.0 /"
   end function two_disk_deck

   subroutine test_text_deck_runs_and_reports_metrics()
      type(simulation_t) :: sim
      type(error_t), allocatable :: err
      type(string_t), allocatable :: ids(:)
      type(run_stats_t) :: st
      real(wp) :: tmax
      call test_begin('text_deck_runs_and_reports_metrics')
      call sim%read_text(two_disk_deck(), err)
      call check('the text deck parses', .not. allocated(err))
      call sim%run(err)
      call check('it runs (built on the way)', .not. allocated(err))
      call sim%element_ids(ids)
      call check('two elements, the second with the default id e2', size(ids) == 2)
      if (size(ids) == 2) call check('ids shaft1, e2', ids(1)%s == 'shaft1' .and. ids(2)%s == 'e2')
      call sim%metric('shaft1', 'torque_max', tmax, err)
      call check('the shaft carries torque (100 lbf in drive)', .not. allocated(err) .and. tmax > 0.0_wp)
      call sim%stats(st, err)
      call check('the run completed to t_end', .not. allocated(err) .and. st%completed)
      call sim%metric('shaft1', 'no_such_metric', tmax, err)
      call check('an unknown metric is an error that lists the valid ones', allocated(err))
      if (allocated(err)) call check('  ... naming p2p_mean', index(err%message, 'p2p_mean') > 0)
   end subroutine test_text_deck_runs_and_reports_metrics

   subroutine test_set_replaces_a_value_by_element_id()
      type(simulation_t) :: sim
      type(error_t), allocatable :: err
      real(wp) :: t_soft, t_stiff
      call test_begin('set_replaces_a_value_by_element_id')
      call sim%read_text(two_disk_deck(), err)
      call sim%run(err)
      call sim%metric('shaft1', 'torque_max', t_soft, err)
      call sim%set('shaft1.stiffness', 5.0e6_wp, err)
      call check('set shaft1.stiffness', .not. allocated(err))
      call sim%run(err)
      call check('the changed deck runs', .not. allocated(err))
      call sim%metric('shaft1', 'disp_max', t_stiff, err)
      call sim%set('shaft1.stiffness', '5.0e4', err)
      call sim%run(err)
      call sim%metric('shaft1', 'disp_max', t_soft, err)
      ! wind-up ~ torque/k: 100x stiffer, 100x less; asserted with a wide margin (10x)
      call check('shaft wind-up at least 10x smaller with a 100x stiffer shaft', &
                 t_soft > 0.0_wp .and. t_stiff < t_soft/10.0_wp)
   end subroutine test_set_replaces_a_value_by_element_id

   subroutine test_set_adds_a_missing_key_and_reaches_run_group()
      type(simulation_t) :: sim
      type(error_t), allocatable :: err
      type(run_stats_t) :: st
      type(element_metrics_t) :: m0, m1
      call test_begin('set_adds_a_missing_key_and_reaches_run_group')
      call sim%read_text(two_disk_deck(), err)
      call sim%set('run.t_end', 0.01_wp, err)
      call check('set run.t_end', .not. allocated(err))
      call sim%run(err)
      call sim%stats(st, err)
      call check_close_t('the run ends at the new t_end', st%t_final, 0.01_wp)
      call sim%element_metrics('shaft1', m0, err)
      ! damping is not in the deck's shaft1 group: it is added
      call sim%set('shaft1.damping', 50.0_wp, err)
      call check('set shaft1.damping (a key the group did not have)', .not. allocated(err))
      call sim%run(err)
      call check('runs with the added key', .not. allocated(err))
      call sim%element_metrics('shaft1', m1, err)
      call check('the damped shaft swings less', m1%disp_max < m0%disp_max)
      call sim%set_string('run.integrator', 'cvode-bdf', err)
      call sim%run(err)
      call check('set_string run.integrator = cvode-bdf runs', .not. allocated(err))
      call sim%stats(st, err)
      call check('  ... with CVODE (it counts Jacobian evaluations or error-test failures)', &
                 st%jac_evals + st%error_test_fails > 0)
   end subroutine test_set_adds_a_missing_key_and_reaches_run_group

   subroutine check_close_t(what, a, b)
      character(len=*), intent(in) :: what
      real(wp), intent(in) :: a, b
      call check(what, abs(a - b) <= 1.0e-12_wp*abs(b))
   end subroutine check_close_t

   subroutine test_set_by_default_id()
      type(simulation_t) :: sim
      type(error_t), allocatable :: err
      real(wp) :: n_wide, n_none
      call test_begin('set_by_default_id')
      call sim%read_text(two_disk_deck(), err)
      call sim%run(err)
      call sim%metric('e2', 'impacts', n_wide, err)
      call sim%set('e2.clearance', 10.0_wp, err)     ! wider than the shaft ever winds
      call check('set e2.clearance (the builder''s id of the unnamed second element)', .not. allocated(err))
      call sim%set('n3.inertia', 1.5_wp, err)
      call check('set n3.inertia (unnamed third node)', .not. allocated(err))
      call sim%run(err)
      call sim%metric('e2', 'impacts', n_none, err)
      call check('no impact once the clearance is wider than any wind-up', n_none == 0.0_wp)
      ! node b gains ~0.05 rad on the free node in 0.05 s (40 rad/s^2): the 0.002 rad gap closes
      call check('  ... whereas the deck''s 0.002 rad clearance does close', n_wide > 0.0_wp)
   end subroutine test_set_by_default_id

   subroutine test_bad_values_are_reported_by_the_plugin_with_the_key()
      type(simulation_t) :: sim
      type(error_t), allocatable :: err
      call test_begin('bad_values_are_reported_by_the_plugin_with_the_key')
      call sim%read_text(two_disk_deck(), err, name='two.nml')
      call sim%set('shaft1.stiffness', -1.0_wp, err)
      call check('set accepts any value (checked at build)', .not. allocated(err))
      call sim%build(err)
      call check('build rejects a negative stiffness', allocated(err))
      if (allocated(err)) then
         call check('  ... as an input error naming the set call (as --set names its argument) and the key', &
                    err%code == err_input .and. index(err%message, "set 'shaft1.stiffness'") > 0 .and. &
                    index(err%message, 'stiffness') > 0)
      end if
      call sim%set('shaft1.stiffnes', 1.0_wp, err)
      call sim%set('shaft1.stiffness', 1.0_wp, err)
      call sim%build(err)
      call check('a misspelt key is reported as unknown by the plug-in', allocated(err))
      if (allocated(err)) call check('  ... by name', index(err%message, 'stiffnes') > 0)
      call sim%read_text(two_disk_deck(), err)
      call sim%set('shaft1.stiffness', "'stiff'", err)
      call sim%build(err)
      call check('a string where a number belongs is an error at build', allocated(err))
      call sim%set('shaft1.stiffness', '1.0 /', err)
      call check('a value that would close the group is rejected at set', allocated(err))
   end subroutine test_bad_values_are_reported_by_the_plugin_with_the_key

   subroutine test_bad_paths_are_errors()
      type(simulation_t) :: sim
      type(error_t), allocatable :: err
      call test_begin('bad_paths_are_errors')
      call sim%set('shaft1.stiffness', 1.0_wp, err)
      call check('set before any deck is read: error', allocated(err))
      call sim%read_text(two_disk_deck(), err)
      call sim%set('nosuch.stiffness', 1.0_wp, err)
      call check('unknown group id: error naming it', allocated(err))
      if (allocated(err)) call check('  ... naming it', index(err%message, 'nosuch') > 0)
      call sim%set('stiffness', 1.0_wp, err)
      call check('path without a dot: error', allocated(err))
      call sim%set('shaft1.', 1.0_wp, err)
      call check('path without a key: error', allocated(err))
      call sim%set('shaft1.stiff ness', 1.0_wp, err)
      call check('key that is not a deck key: error', allocated(err))
   end subroutine test_bad_paths_are_errors

   subroutine test_results_before_a_run_are_errors()
      type(simulation_t) :: sim
      type(error_t), allocatable :: err
      type(event_t), allocatable :: ev(:)
      real(wp) :: x
      call test_begin('results_before_a_run_are_errors')
      call sim%build(err)
      call check('build without a deck: error', allocated(err))
      call sim%read_text(two_disk_deck(), err)
      call sim%run(err)
      call sim%set('shaft1.stiffness', 6.0e4_wp, err)
      call sim%metric('shaft1', 'torque_max', x, err)
      call check('metrics of a run made before the deck changed: error', allocated(err))
      call sim%events(ev, err)
      call check('events likewise (and an empty table)', allocated(err) .and. size(ev) == 0)
      call sim%run(err)
      call sim%metric('no_such_element', 'torque_max', x, err)
      call check('an unknown element id: error', allocated(err))
   end subroutine test_results_before_a_run_are_errors

   subroutine test_file_deck_events_and_hdf5_output()
      type(simulation_t) :: sim
      type(error_t), allocatable :: err
      type(event_t), allocatable :: ev(:)
      type(element_metrics_t) :: m
      character(len=*), parameter :: h5 = 'test_api_ghm.h5'
      logical :: there
      integer :: u, ios, i, n_impacts
      call test_begin('file_deck_events_and_hdf5_output')
      call sim%read_file('no/such/deck.nml', err)
      call check('a missing deck file is an I/O error', allocated(err))
      if (allocated(err)) call check('  ... with code err_io', err%code == err_io)
      call sim%read_file('inputs/gregory_harris_munro.nml', err)
      call check('the bundled GHM deck reads', .not. allocated(err))
      call sim%run(err, output=h5)
      call check('runs with an HDF5 history', .not. allocated(err))
      inquire (file=h5, exist=there)
      call check('the history file exists', there)
      call sim%events(ev, err)
      call sim%element_metrics('mesh', m, err)
      n_impacts = 0
      do i = 1, size(ev)
         if (ev(i)%kind == ev_contact_front .or. ev(i)%kind == ev_contact_rear) n_impacts = n_impacts + 1
      end do
      call check('the event table has the impacts the metrics count', size(ev) > 0 .and. n_impacts == m%impacts)
      if (size(ev) > 0) call check('its rows name their element', sim%event_element_id(ev(1)) == 'mesh' .and. &
                                   len(ev_name(ev(1)%kind)) > 0)
      open (newunit=u, file=h5, status='old', iostat=ios)
      if (ios == 0) close (u, status='delete')
   end subroutine test_file_deck_events_and_hdf5_output
end program test_api
