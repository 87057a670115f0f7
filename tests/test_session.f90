!> A run its caller advances (trainsim_session, the base of the FMU): the
!> states at the communication points equal a run's samples at the same
!> times, bit for bit, with every integrator; a saved and restored session
!> continues bit for bit; communication points off the integrator's grid and
!> across events give the run's trajectory to the integrator's tolerance;
!> speed and voltage inputs equal runs with those steps in the deck; a
!> positioning sequence's progress is saved and restored with a point.
program test_session
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, err_input
   use trainsim_strings, only: string_t, str
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_session, only: session_t, session_state_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, load_model_text, run_model
   implicit none

   call suite_begin('sessions: a run advanced by its caller')
   call test_session_equals_run('rk4')
   call test_session_equals_run('cvode-bdf')
   call test_session_equals_run('arkode-dp')
   call test_save_and_restore('rk4')
   call test_save_and_restore('cvode-bdf')
   call test_deferred_start('rk4')
   call test_deferred_start('cvode-bdf')
   call test_off_grid_points()
   call test_input_torque('rk4')
   call test_input_torque('cvode-bdf')
   call test_refusals()
   call test_input_speed()
   call test_input_voltage()
   call test_sequence_restored()
   call test_step_checked()
   call suite_end()

contains

   !> The GHM rig (Table 5.5: contact lost and regained every tooth) over 4 ms.
   subroutine rig(integrator, model)
      character(len=*), intent(in) :: integrator
      type(model_t), intent(out) :: model
      call load_model('inputs/gregory_harris_munro.nml', model)
      model%run%integrator = integrator
      model%run%t_end = 2.0e-2_wp
      model%run%output_interval = 4.0e-4_wp   ! 50 dt of 8e-6 s
   end subroutine rig

   !> Advancing to the run's output times gives the run's samples (the same
   !> loop, the same calls): bit for bit.
   subroutine test_session_equals_run(integrator)
      character(len=*), intent(in) :: integrator
      type(model_t) :: m
      type(run_result_t) :: r
      type(session_t), target :: s
      type(error_t), allocatable :: err
      integer :: k, n, worst
      logical :: same
      call test_begin('session_equals_run_'//integrator)
      call rig(integrator, m)
      call s%start(m, err, inputs=[string_t('n4'), string_t('n2')])   ! inputs at 0 change nothing
      call check('the session starts', .not. allocated(err))
      call run_model(m, r)
      n = size(r%series_t)
      same = .true.
      worst = 0
      do k = 2, n
         call s%advance(r%series_t(k), err)
         if (allocated(err)) exit
         call s%kinematics()
         if (any(s%model%theta /= r%series_theta(:, k)) .or. any(s%model%omega /= r%series_omega(:, k))) then
            same = .false.
            if (worst == 0) worst = k
         end if
      end do
      call check('advanced through the '//str(n - 1)//' output times without error', .not. allocated(err))
      call check('the state at every output time equals the run''s sample, bit for bit (first differing: '// &
                 str(worst)//')', same)
      call check('the run had contact events to locate ('//str(size(r%events))//')', size(r%events) > 10)
      call s%finish()
   end subroutine test_session_equals_run

   !> Save at t1, go on to t2; restore t1, go on to t2 again: the same state
   !> and modes, bit for bit; and the saved point is the state at t1.
   subroutine test_save_and_restore(integrator)
      character(len=*), intent(in) :: integrator
      type(model_t) :: m
      type(session_t), target :: s
      type(session_state_t) :: p
      type(error_t), allocatable :: err
      real(wp), allocatable :: y1(:), y2(:)
      real(wp) :: t1, t2
      call test_begin('save_and_restore_'//integrator)
      call rig(integrator, m)
      t1 = 6.0e-3_wp
      t2 = 1.52e-2_wp
      call s%start(m, err)
      if (.not. allocated(err)) call s%advance(t1, err)
      y1 = s%y
      if (.not. allocated(err)) call s%save(p, err)
      if (.not. allocated(err)) call s%advance(t2, err)
      y2 = s%y
      if (.not. allocated(err)) call s%restore(p, err)
      call check('saved, advanced and restored without error', .not. allocated(err))
      call check('the restored point is the saved one (t and y)', s%t == t1 .and. all(s%y == y1))
      if (.not. allocated(err)) call s%advance(t2, err)
      call check('advanced again to t2 without error', .not. allocated(err))
      call check('the second pass from t1 to t2 ends in the same state, bit for bit', all(s%y == y2))
      if (.not. allocated(err)) call s%restore(p, err)
      if (.not. allocated(err)) call s%advance(t2, err)
      call check('and a third pass too', all(s%y == y2))
      call s%finish()
      ! the same run without a save: a fixed-step integrator's grid goes on from
      ! t_start (bit for bit); an adaptive one was restarted at t1 (as at a
      ! breakpoint of the inputs): within 10 rtol of the state's scale
      call s%start(m, err)
      if (.not. allocated(err)) call s%advance(t2, err)
      if (integrator == 'rk4') then
         call check('a save leaves a fixed-step run bit for bit as without it', all(s%y == y2))
      else
         call check('a save changes an adaptive run within 10 rtol', &
                    maxval(abs(s%y - y2)) <= 10.0_wp*m%run%rtol*maxval(abs(y2)))
      end if
      call s%finish()
   end subroutine test_save_and_restore

   !> `save` and `restore` with `defer` (D-186: the period map's next call is
   !> `set_state`, which starts the integrator): the run goes on as without it, bit
   !> for bit, whether the next call is `set_state` or `advance`.
   subroutine test_deferred_start(integrator)
      character(len=*), intent(in) :: integrator
      type(model_t) :: m
      type(session_t), target :: s
      type(session_state_t) :: p
      type(error_t), allocatable :: err
      real(wp), allocatable :: y2(:), y3(:), ys(:), ya(:), yb(:)
      real(wp) :: t1, t2
      call test_begin('deferred_start_'//integrator)
      call rig(integrator, m)
      t1 = 6.0e-3_wp
      t2 = 1.52e-2_wp
      call s%start(m, err)
      if (.not. allocated(err)) call s%advance(t1, err)
      ys = 1.001_wp*s%y                ! (a state of the caller's own at t1)
      if (.not. allocated(err)) call s%save(p, err)
      if (.not. allocated(err)) call s%advance(t2, err)
      y2 = s%y
      if (.not. allocated(err)) call s%restore(p, err)
      if (.not. allocated(err)) call s%set_state(ys, err)
      if (.not. allocated(err)) call s%advance(t2, err)
      ya = s%y
      call s%finish()
      call check('saved, restored, a state set and advanced without error', .not. allocated(err))
      call s%start(m, err)
      if (.not. allocated(err)) call s%advance(t1, err)
      if (.not. allocated(err)) call s%save(p, err, defer=.true.)
      if (.not. allocated(err)) call s%advance(t2, err)
      call check('deferred: the run goes on after its save as without the deferral, bit for bit', &
                 .not. allocated(err) .and. all(s%y == y2))
      if (.not. allocated(err)) call s%restore(p, err, defer=.true.)
      if (.not. allocated(err)) call s%advance(t2, err)
      call check('   and after a deferred restore straight to advance', .not. allocated(err) .and. all(s%y == y2))
      if (.not. allocated(err)) call s%restore(p, err, defer=.true.)
      if (.not. allocated(err)) call s%set_state(ys, err)
      if (.not. allocated(err)) call s%advance(t2, err)
      yb = s%y
      call check('   and after a deferred restore and a state set (the period map''s use)', &
                 .not. allocated(err) .and. all(yb == ya))
      if (.not. allocated(err)) call s%restore(p, err, defer=.true.)
      if (.not. allocated(err)) call s%save(p, err)
      if (.not. allocated(err)) call s%advance(t2, err)
      y3 = s%y
      call check('   and saved again while idle, then advanced', .not. allocated(err) .and. all(y3 == y2))
      call s%finish()
   end subroutine test_deferred_start

   !> Communication points off the dt grid, 0.37 dt to 90 dt apart, across the
   !> contact events (cvode-bdf at rtol 1e-9): the session ends at t_end in the
   !> run's final state to the integrator's tolerance (speeds within 1e-8 of
   !> the speed scale: 10 rtol, the local tolerance grown over 35 contact events).
   subroutine test_off_grid_points()
      type(model_t) :: m
      type(run_result_t) :: r
      type(session_t), target :: s
      type(error_t), allocatable :: err
      real(wp) :: t, h(3), scale, dev
      integer :: j, n
      call test_begin('off_grid_points')
      call rig('cvode-bdf', m)
      m%run%rtol = 1.0e-9_wp
      m%run%output_interval = m%run%dt
      call run_model(m, r)
      n = size(r%series_t)
      scale = maxval(abs(r%series_omega))
      h = [0.37_wp, 7.3_wp, 90.1_wp]*m%run%dt
      do j = 1, size(h)
         call s%start(m, err)
         t = m%run%t_start
         do while (.not. allocated(err))
            t = min(t + h(j), m%run%t_end)
            call s%advance(t, err)
            if (t >= m%run%t_end) exit
         end do
         call s%kinematics()
         dev = maxval(abs(s%model%omega - r%series_omega(:, n)))
         call check('points '//ftoa(h(j)/m%run%dt)//' dt apart: advanced to t_end without error', .not. allocated(err))
         call check('   final speeds equal the run''s within 1e-8 of the speed scale (dev '//ftoa(dev/scale)//')', &
                    dev <= 1.0e-8_wp*scale)
         write (*, '(a, es10.3, a, i0, a)') '       final speed deviation ', dev/scale, ' of the speed scale (', size(r%events), ' events in the run)'
         call s%finish()
      end do
   end subroutine test_off_grid_points

   !> An input torque set between communication points acts as a load step at
   !> that time: the session equals a run of the deck with that step load (rk4:
   !> within 1e-12 of the speed scale: the run's step that ends on the load
   !> step takes its last stage 1e-9 h early, at the left limit, the session's
   !> on time; measured 3.6e-15; cvode-bdf: both restart at the step, within
   !> 10 rtol). Bad inputs are refused.
   subroutine test_input_torque(integrator)
      character(len=*), intent(in) :: integrator
      type(model_t) :: m, mstep
      type(run_result_t) :: r
      type(session_t), target :: s
      type(session_state_t) :: p
      type(error_t), allocatable :: err
      character(len=:), allocatable :: text
      real(wp) :: scale
      integer :: k, n
      logical :: same
      call test_begin('input_torque_'//integrator)
      call rig(integrator, m)
      text = deck_text('inputs/gregory_harris_munro.nml')// &
             "&load node = 'n4', kind = 'step', value0 = 0.0, value1 = -100.0, t_step = 0.008 /"//new_line('a')
      call load_model_text(text, mstep)
      mstep%run%integrator = integrator
      mstep%run%t_end = m%run%t_end
      mstep%run%output_interval = m%run%output_interval
      call run_model(mstep, r)
      n = size(r%series_t)
      scale = maxval(abs(r%series_omega))
      call s%start(m, err, inputs=[string_t('n4')])
      same = .true.
      do k = 2, n
         if (abs(r%series_t(k - 1) - 0.008_wp) < 1.0e-12_wp) call s%set_torque('n4', -100.0_wp, err)
         if (allocated(err)) exit
         call s%advance(r%series_t(k), err)
         if (allocated(err)) exit
         call s%kinematics()
         if (integrator == 'rk4') then
            same = same .and. maxval(abs(s%model%omega - r%series_omega(:, k))) <= 1.0e-12_wp*scale
         else
            same = same .and. maxval(abs(s%model%omega - r%series_omega(:, k))) <= 10.0_wp*m%run%rtol*scale
         end if
      end do
      call check('set the input at t = 0.008 s and advanced to t_end without error', .not. allocated(err))
      if (integrator == 'rk4') then
         call check('every output time equals the run with a step load within 1e-12 of the speed scale', same)
      else
         call check('every output time equals the run with a step load within 10 rtol', same)
      end if
      ! a saved point keeps the input; restoring an earlier point takes it back
      call s%finish()
      call s%start(m, err, inputs=[string_t('n4')])
      call s%advance(0.004_wp, err)
      call s%save(p, err)
      call s%set_torque('n4', -5000.0_wp, err)
      call s%advance(0.012_wp, err)
      call s%restore(p, err)
      call s%advance(0.008_wp, err)
      call s%set_torque('n4', -100.0_wp, err)
      call s%advance(0.012_wp, err)
      k = nint(0.012_wp/m%run%output_interval) + 1
      call s%kinematics()
      if (integrator == 'rk4') then
         call check('restored before a large input: the input is gone (equals the step-load run within 1e-12)', &
                    maxval(abs(s%model%omega - r%series_omega(:, k))) <= 1.0e-12_wp*scale)
      end if
      call s%set_torque('n3', 1.0_wp, err)
      call check('a torque on a node that is not an input is refused', allocated(err))
      if (allocated(err)) call check('   naming the node', index(err%message, "'n3'") > 0 .and. err%code == err_input)
      call s%finish()
      call s%start(m, err, inputs=[string_t('nx')])
      call check('an input on a node that does not exist is refused', allocated(err))
      call s%start(m, err, inputs=[string_t('n1')])
      call check('an input torque on a node with a prescribed speed is refused', allocated(err))
      if (allocated(err)) call check('   saying why', index(err%message, 'prescribed') > 0)
   end subroutine test_input_torque

   !> A prescribed speed as an input (n1, the rig's driven inertia): held at the
   !> deck's 95.2286 rad/s, set to 100 rad/s at t = 0.008 s, equals the run whose
   !> deck has that speed step (rk4: within 1e-12 of the speed and angle scales, as
   !> the torque step: the run's step ending on the speed step takes its last stage
   !> 1e-9 dt early, and its angle is the step's integral w0 ts + w1 (t - ts), the
   !> session's theta(ts) + w1 (t - ts)). Inputs a node cannot take are refused.
   subroutine test_input_speed()
      type(model_t) :: m, mstep
      type(run_result_t) :: r
      type(session_t), target :: s
      type(error_t), allocatable :: err
      character(len=:), allocatable :: text
      real(wp) :: scale, ascale, dw, dth
      integer :: k, n
      call test_begin('input_speed')
      call rig('rk4', m)
      text = deck_text('inputs/gregory_harris_munro.nml')
      k = index(text, "quantity = 'speed', kind = 'constant', value = 95.2286 /")
      call check('the rig prescribes n1''s speed (95.2286 rad/s)', k > 0)
      if (k == 0) return
      text = text(:k - 1)//"quantity = 'speed', kind = 'step', value0 = 95.2286, value1 = 100.0, t_step = 0.008 /"// &
             text(k + len("quantity = 'speed', kind = 'constant', value = 95.2286 /"):)
      call load_model_text(text, mstep)
      mstep%run%t_end = m%run%t_end
      mstep%run%output_interval = m%run%output_interval
      call run_model(mstep, r)
      n = size(r%series_t)
      scale = maxval(abs(r%series_omega))
      ascale = maxval(abs(r%series_theta))
      call s%start(m, err, inputs=[string_t('n1.speed')])
      dw = 0.0_wp
      dth = 0.0_wp
      do k = 2, n
         call s%advance(r%series_t(k), err)
         ! (set at the sample: the run's sample at the step time has the right limit, 100)
         if (abs(r%series_t(k) - 0.008_wp) < 1.0e-12_wp) call s%set_input('n1.speed', 100.0_wp, err)
         if (allocated(err)) exit
         call s%kinematics()
         dw = max(dw, maxval(abs(s%model%omega - r%series_omega(:, k))))
         dth = max(dth, maxval(abs(s%model%theta - r%series_theta(:, k))))
      end do
      call check('set n1.speed at t = 0.008 s and advanced to t_end without error', .not. allocated(err))
      call check('every output time equals the run with the speed step within 1e-12 of the speed scale ('// &
                 ftoa(dw/scale)//') and the angle scale ('//ftoa(dth/ascale)//')', &
                 dw <= 1.0e-12_wp*scale .and. dth <= 1.0e-12_wp*ascale)
      write (*, '(a, es10.3, a, es10.3, a)') '       speed step: ', dw/scale, ' of the speed scale, ', dth/ascale, &
         ' of the angle scale'
      call check('n1 turns at the input speed', s%model%omega(1) == 100.0_wp)
      call s%finish()
      call s%start(m, err, inputs=[string_t('n4.speed')])
      call check('a speed input where the deck prescribes no motion is refused', allocated(err))
      if (allocated(err)) call check('   saying why', index(err%message, 'prescribes no motion') > 0 .and. &
                                     index(err%message, "'n4'") > 0)
      call s%start(m, err, inputs=[string_t('n1.voltage')])
      call check('a voltage input on an inertia is refused', allocated(err))
      if (allocated(err)) call check('   saying why', index(err%message, 'dc_motor') > 0)
   end subroutine test_input_speed

   !> A DC motor's supply voltage as an input: held at the deck's 24 V, set to
   !> 12 V at t = 0.02 s, equals the run whose deck has that voltage step (rk4:
   !> within 1e-12 of the speed scale, the reason as for the torque step).
   subroutine test_input_voltage()
      type(model_t) :: m, mstep
      type(run_result_t) :: r
      type(session_t), target :: s
      type(error_t), allocatable :: err
      real(wp) :: scale, dw
      integer :: k, n
      call test_begin('input_voltage')
      call load_model_text(motor_deck("kind = 'constant', value = 24.0"), m)
      call load_model_text(motor_deck("kind = 'step', value0 = 24.0, value1 = 12.0, t_step = 0.02"), mstep)
      call run_model(mstep, r)
      n = size(r%series_t)
      scale = maxval(abs(r%series_omega))
      call s%start(m, err, inputs=[string_t('motor.voltage')])
      dw = 0.0_wp
      do k = 2, n
         if (abs(r%series_t(k - 1) - 0.02_wp) < 1.0e-12_wp) call s%set_input('motor.voltage', 12.0_wp, err)
         if (allocated(err)) exit
         call s%advance(r%series_t(k), err)
         if (allocated(err)) exit
         call s%kinematics()
         dw = max(dw, maxval(abs(s%model%omega - r%series_omega(:, k))))
      end do
      call check('set motor.voltage at t = 0.02 s and advanced to t_end without error', .not. allocated(err))
      call check('every output time equals the run with the voltage step within 1e-12 of the speed scale ('// &
                 ftoa(dw/scale)//')', dw <= 1.0e-12_wp*scale)
      write (*, '(a, es10.3, a)') '       voltage step: ', dw/scale, ' of the speed scale'
      call s%finish()
      call run_model(m, r)
      call check('the step slowed the motor (its speed at the end below the 24 V run''s)', &
                 s%model%omega(1) < r%series_omega(1, n) - 1.0e-3_wp*scale)
   end subroutine test_input_voltage

   !> inputs/dc_motor_geared_load.nml over 40 ms with the voltage `law`.
   function motor_deck(law) result(text)
      character(len=*), intent(in) :: law
      character(len=:), allocatable :: text
      character(len=*), parameter :: nl = new_line('a')
      text = "&run t_end = 0.04, dt = 5.0e-6, integrator = 'rk4', output_interval = 1.0e-3 /"//nl// &
             "&node id = 'motor', type = 'dc_motor', inertia = 2.0e-3, damping = 1.0e-4, torque_constant = 0.5, "// &
             "back_emf_constant = 0.0565, inductance = 2.0e-3, resistance = 0.5 /"//nl// &
             "&node id = 'gear', type = 'inertia', inertia = 0.05 /"//nl// &
             "&node id = 'load', type = 'inertia', inertia = 2.0, damping = 0.5 /"//nl// &
             "&element id = 'mesh', type = 'spur_gear', left = 'motor', right = 'gear', teeth_driver = 20, "// &
             "teeth_driven = 60, diametral_pitch = 8.0, pressure_angle = 20.0, face_width = 0.75, backlash = 0.004 /"//nl// &
             "&element id = 'shaft', type = 'shaft', left = 'gear', right = 'load', stiffness = 2.0e4, damping = 2.0 /"//nl// &
             "&load node = 'motor', quantity = 'voltage', "//law//" /"//nl
   end function motor_deck

   !> A positioning sequence (targets 5, 10, 2 rad from 0.2, 2.0, 4.0 s, as
   !> test_controller's): saved at 1.99 s (target 1 reached), advanced to 3.99 s (target
   !> 2 reached), restored and advanced again: the same state bit for bit (the
   !> sequence's progress is part of the point; before, the restored run held at
   !> target 1 as if target 2 had been reached). Two sessions of one model advanced
   !> in turn do not share a sequence.
   subroutine test_sequence_restored()
      type(model_t) :: m
      type(session_t), target :: s, s2
      type(session_state_t) :: p
      type(error_t), allocatable :: err
      real(wp), allocatable :: y1(:), y2(:)
      character(len=*), parameter :: nl = new_line('a')
      call test_begin('sequence_restored')
      call load_model_text("&run t_end = 4.0, dt = 1.0e-5, integrator = 'rk4', output_interval = 0.01, "// &
                           "units = 'si' /"//nl// &
                           "&node id = 'm', type = 'dc_motor', inertia = 0.01, torque_constant = 0.05, "// &
                           "back_emf_constant = 0.05, inductance = 1.0e-3, resistance = 1.0 /"//nl// &
                           "&node id = 'load', type = 'inertia', inertia = 0.01 /"//nl// &
                           "&element id = 's', type = 'shaft', left = 'm', right = 'load', stiffness = 1.0e3, "// &
                           "damping = 0.5 /"//nl// &
                           "&controller id = 'pos', motor = 'm', sensor = 'load', measure = 'angle', kp = 40.0, "// &
                           "kd = 8.0, filter_time = 1.0e-3, v_min = -24.0, v_max = 24.0, current_limit = 30.0, "// &
                           "sequence = .true., kind = 'table', times = 0.2, 2.0, 4.0, values = 5.0, 10.0, 2.0, "// &
                           "tolerance = 1.0e-3, speed_tolerance = 1.0e-2 /", m)
      call s%start(m, err)
      if (.not. allocated(err)) call s%advance(1.99_wp, err)
      call s%kinematics()
      call check('at 1.99 s the load is held near target 1 (5 rad within 1e-2: it '// &
                 'arrived within 1e-3 and drifts at 0 V)', abs(s%model%theta(2) - 5.0_wp) <= 1.0e-2_wp)
      if (.not. allocated(err)) call s%save(p, err)
      if (.not. allocated(err)) call s%advance(3.99_wp, err)
      y2 = s%y
      call s%kinematics()
      call check('at 3.99 s near target 2 (10 rad within 1e-2)', abs(s%model%theta(2) - 10.0_wp) <= 1.0e-2_wp)
      if (.not. allocated(err)) call s%restore(p, err)
      if (.not. allocated(err)) call s%advance(3.99_wp, err)
      call check('saved at 1.99 s, advanced to 3.99 s, restored and advanced again without error', .not. allocated(err))
      call check('the second pass ends in the first''s state at 3.99 s, bit for bit', all(s%y == y2))
      call s%finish()
      call s%start(m, err)
      if (.not. allocated(err)) call s2%start(m, err)
      if (.not. allocated(err)) call s%advance(3.99_wp, err)
      y1 = s%y
      if (.not. allocated(err)) call s2%advance(3.99_wp, err)
      call check('two sessions of one model advanced in turn end alike, bit for bit (no shared sequence)', &
                 .not. allocated(err) .and. all(s2%y == y1) .and. all(y1 == y2))
      call s%restore(p, err)
      call check('a point saved by an earlier start is refused', allocated(err))
      call s%finish()
      call s2%finish()
   end subroutine test_sequence_restored

   !> The text of a deck file.
   function deck_text(path) result(text)
      character(len=*), intent(in) :: path
      character(len=:), allocatable :: text
      integer :: u, sz
      open (newunit=u, file=path, access='stream', form='unformatted', action='read')
      inquire (unit=u, size=sz)
      allocate (character(len=sz) :: text)
      read (u) text
      close (u)
   end function deck_text

   !> Going back in time or past t_end is refused with err_input.
   subroutine test_refusals()
      type(model_t) :: m
      type(session_t), target :: s
      type(error_t), allocatable :: err
      call test_begin('refusals')
      call rig('rk4', m)
      call s%start(m, err)
      call s%advance(2.0e-3_wp, err)
      call s%advance(1.0e-3_wp, err)
      call check('advancing backwards is refused (err_input)', allocated(err))
      if (allocated(err)) call check('   with a message naming the times', err%code == err_input .and. &
                                     index(err%message, 'cannot advance') > 0)
      call s%advance(1.0_wp, err)
      call check('advancing past t_end is refused', allocated(err))
      call s%advance(2.0e-2_wp, err)
      call check("t_end itself is reached", .not. allocated(err) .and. abs(s%t - 2.0e-2_wp) < 1.0e-12_wp)
      call s%finish()
   end subroutine test_refusals

   function ftoa(x) result(s)
      real(wp), intent(in) :: x
      character(len=:), allocatable :: s
      character(len=24) :: b
      write (b, '(es10.3)') x
      s = trim(adjustl(b))
   end function ftoa

   !> `step_checked` (D-163): the caller vouches for the fixed-step check, so a start
   !> with a dt 1000 times the RK4 limit (refused without it) goes ahead; the period
   !> map passes it at a branch's later mesh frequencies only.
   subroutine test_step_checked()
      type(model_t) :: m
      type(session_t), target :: s
      type(error_t), allocatable :: err
      call test_begin('step_checked')
      call rig('rk4', m)
      m%run%dt = 2.0_wp   ! (the rig's RK4 limit as it starts is 1.09e-3 s: the check refuses 1000 times it)
      m%run%output_interval = 2.0_wp
      m%run%t_end = 4.0_wp
      call s%start(m, err)
      call check('a dt 1000 times the RK4 limit is refused at the start', allocated(err))
      if (allocated(err)) call check('   as bad input', err%code == err_input)
      if (allocated(err)) deallocate (err)
      call s%start(m, err, step_checked=.true.)
      call check('with step_checked the session starts (the check is the caller''s)', .not. allocated(err))
      call s%finish()
   end subroutine test_step_checked

end program test_session
