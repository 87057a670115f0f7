!> The O(n) RK4 step bound (`rk4_dt_bound`, D-64) against the dense
!> analysis it replaces above dense_state_limit states:
!> - its stiffness bound sqrt(mu_K) is >= the highest undamped circular
!>   frequency of LAPACK's dsygv (`compute_modes`) on every bundled deck, the
!>   runaway reproducer and chains of 10 .. 300 nodes, as the run starts and in
!>   the stiffest state, and within a factor 1.25 of it (measured: equal to 6
!>   digits on the bundled decks, within 0.6 % on the chains);
!> - its step is <= the dense limit (dgeev, `rk4_dt_limit(dense=.true.)`: the
!>   advice is safe) and >= 0.65 of it (measured 0.954 .. 0.9995 without a
!>   motor; 0.72 .. 0.87 with one, whose current takes the direction-free radius);
!> - on a uniform shaft chain, against the closed form
!>   omega_max = 2 sqrt(k/J) sin((n - 1) pi / (2 n)), the bound is within
!>   Gershgorin's 2 sqrt(k/J);
!> - a chain above the threshold runs at the advised step without growth
!>   (RK4 inside its region: |R(h lambda)| <= 1 for every mode, so the energy
!>   of an undamped linear train cannot grow), and the same chain at 1.1 x
!>   the dense limit blows up (|R| = 1.9 per step on its top mode): the test can fail;
!> - nodes joined by a rigid_gear or rigid_join move as one body in the dense
!>   advice (D-86): its step is 2 sqrt 2 / omega of the merged train's
!>   closed-form frequency, and a run at 0.99 x that limit is stable, at 1.05 x not;
!> - the bounds of several states at once (`rk4_dt_bounds`, start-up's, D-139) are
!>   each state's bound alone, bit for bit (fails if a state takes another's bound).
program test_dt_bound
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_element, only: lin_state_t, lin_start, lin_stiffest
   use trainsim_modes, only: modes_t, compute_modes, rk4_dt_limit, rk4_dt_bound, dense_state_limit, with_loads
   use trainsim_dt_bound, only: rk4_dt_bounds
   use trainsim_simulate, only: simulate
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, load_model_text, nl
   implicit none

   !> The bound's documented tightness (D-64).
   real(wp), parameter :: omega_factor = 1.25_wp, dt_factor = 0.65_wp
   character(len=48), parameter :: decks(9) = [character(len=48) :: &
                                  'inputs/branched_train.nml', 'inputs/dc_motor_geared_load.nml', &
                                  'inputs/gregory_harris_munro.nml', 'inputs/helical_pair.nml', &
                                  'inputs/loads_table_ramp.nml', 'inputs/start_stop_two_clearances.nml', &
                                  'inputs/two_clearance.nml', 'tests/decks/runaway_at_safe_dt.nml', &
                                  'tests/decks/si_helical_pair.nml']

   call suite_begin('O(n) RK4 step bound against the dense analysis')
   call test_bound_is_above_dense_on_bundled_decks()
   call test_uniform_chain_bound_against_closed_form()
   call test_backlash_chain_bound_against_dense()
   call test_chain_runs_at_the_advised_step()
   call test_rigid_connections_merge_in_the_advice()
   call test_rigid_train_runs_at_the_merged_limit()
   call test_bounds_at_once_as_one_by_one()
   call suite_end()

contains

   !> `rk4_dt_bounds` (the states of start-up at once, a state's bound reused when its
   !> element blocks equal the last one's: D-139) gives each state exactly what
   !> `rk4_dt_bound` gives it alone, on trains whose states differ (clearances, gear
   !> zones, impact damping) and on one whose states are the same matrix.
   subroutine test_bounds_at_once_as_one_by_one()
      character(len=48), parameter :: cases(3) = [character(len=48) :: 'inputs/two_clearance.nml', &
                                                   'inputs/start_stop_two_clearances.nml', 'inputs/helical_pair.nml']
      type(model_t) :: m
      type(lin_state_t) :: st(5)
      real(wp), allocatable :: y(:)
      real(wp) :: dt(5), bd(5), om(5), f(5), dt1, bd1, om1, f1
      integer :: i, k
      logical :: same, differ
      call test_begin('bounds_at_once_as_one_by_one')
      st = [lin_start, lin_stiffest, lin_stiffest, lin_start, lin_stiffest]
      st(2)%impact_scale = 0.0_wp
      st(3)%load_torque = -1.0_wp
      do i = 1, size(cases) + 2   ! then a backlash chain, then a shaft chain (one matrix in every state)
         if (i <= size(cases)) then
            call load_model(trim(cases(min(i, size(cases)))), m)
         else
            call load_model_text(chain_deck(30, i == size(cases) + 1, 5.0e-3_wp, 5.0e-3_wp), m)
         end if
         call m%initial_state(y)
         call m%init_modes(m%run%t_start, y, tables=.false.)
         do k = 1, size(st)
            st(k) = with_loads(m, st(k))
         end do
         call rk4_dt_bounds(m, st, y, dt, bd, om, f)
         same = .true.
         do k = 1, size(st)
            call rk4_dt_bound(m, st(k), y, dt1, bd1, omega_k=om1, freq_hz=f1)
            same = same .and. dt(k) == dt1 .and. bd(k) == bd1 .and. om(k) == om1 .and. f(k) == f1
         end do
         differ = dt(1) /= dt(5) .or. bd(1) /= bd(5)
         call check('case '//str(i)//': every state as alone, bit for bit', same)
         if (i <= size(cases) + 1) then
            call check('case '//str(i)//': the start and the stiffest state differ', differ)
         else
            call check('shaft chain: one bound in every state', .not. differ .and. all(dt == dt(1)))
         end if
         st = [lin_start, lin_stiffest, lin_stiffest, lin_start, lin_stiffest]
         st(2)%impact_scale = 0.0_wp
         st(3)%load_torque = -1.0_wp
      end do
   end subroutine test_bounds_at_once_as_one_by_one

   !> Every bundled deck, as it starts and in its stiffest state.
   subroutine test_bound_is_above_dense_on_bundled_decks()
      type(model_t) :: m
      integer :: i
      call test_begin('bound_is_above_dense_on_bundled_decks')
      do i = 1, size(decks)
         call load_model(trim(decks(i)), m)
         call compare(m, lin_start, trim(decks(i))//' as it starts')
         call compare(m, lin_stiffest, trim(decks(i))//' stiffest')
      end do
   end subroutine test_bound_is_above_dense_on_bundled_decks

   !> n unit inertias on shafts k = 1e4, free at both ends: omega_j =
   !> 2 sqrt(k/J) sin(j pi / (2 n)), j = 0 .. n - 1.
   subroutine test_uniform_chain_bound_against_closed_form()
      integer, parameter :: sizes(4) = [10, 50, 150, 300]
      type(model_t) :: m
      real(wp) :: om_exact, dt, bound, om_k
      real(wp), allocatable :: y(:)
      integer :: i
      call test_begin('uniform_chain_bound_against_closed_form')
      do i = 1, size(sizes)
         call load_model_text(chain_deck(sizes(i), .false., 5.0e-3_wp, 5.0e-3_wp), m)
         om_exact = 200.0_wp*sin(real(sizes(i) - 1, wp)*acos(-1.0_wp)/(2.0_wp*sizes(i)))
         call m%initial_state(y)
         call m%init_modes(m%run%t_start, y)
         call rk4_dt_bound(m, with_loads(m, lin_start), y, dt, bound, omega_k=om_k)
         call check('chain of '//str(sizes(i))//': bound >= closed-form omega_max', om_k >= om_exact*(1.0_wp - 1.0e-12_wp))
         call check('chain of '//str(sizes(i))//': bound <= Gershgorin 2 sqrt(k/J)', om_k <= 200.0_wp*(1.0_wp + 1.0e-12_wp))
         ! undamped: the step is RK4's imaginary-axis radius (less the 0.37 % slope
         ! margin) over the bound (8 power steps from Gershgorin: 0.57 % above
         ! omega_max at 10 nodes, where the top of the spectrum is least crowded)
         call check('chain of '//str(sizes(i))//': dt within 2 % of 2 sqrt 2 / omega_max', &
                    dt <= sqrt(8.0_wp)/om_exact .and. dt >= 0.98_wp*sqrt(8.0_wp)/om_exact)
         if (sizes(i) <= 150) call compare(m, lin_start, 'shaft chain of '//str(sizes(i)))
      end do
   end subroutine test_uniform_chain_bound_against_closed_form

   !> Backlash chains (every 10th element a spur gear) in their stiffest state:
   !> two-pair mesh stiffness and the impact damping swept by the dense analysis.
   subroutine test_backlash_chain_bound_against_dense()
      integer, parameter :: sizes(2) = [20, 60]
      type(model_t) :: m
      integer :: i
      call test_begin('backlash_chain_bound_against_dense')
      do i = 1, size(sizes)
         call load_model_text(chain_deck(sizes(i), .true., 5.0e-3_wp, 5.0e-3_wp), m)
         call compare(m, lin_start, 'backlash chain of '//str(sizes(i))//' as it starts')
         call compare(m, lin_stiffest, 'backlash chain of '//str(sizes(i))//' stiffest')
      end do
   end subroutine test_backlash_chain_bound_against_dense

   !> A 100-node shaft chain (200 states: the bound gives the advice) at the
   !> advised step for 4000 steps, and at 1.1 x the dense limit.
   subroutine test_chain_runs_at_the_advised_step()
      type(model_t) :: m
      type(run_result_t) :: res
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      real(wp) :: dt_advice, dt_dense, om, e_end
      call test_begin('chain_runs_at_the_advised_step')
      call load_model_text(chain_deck(100, .false., 1.0_wp, 1.0e-3_wp), m)
      call check('200 states: above dense_state_limit', m%n_states > dense_state_limit)
      call rk4_dt_limit(m, lin_stiffest, dt_advice, om, err)
      call check('advice: no error', .not. allocated(err))
      call rk4_dt_limit(m, lin_stiffest, dt_dense, om, err, dense=.true.)
      call check('dense: no error', .not. allocated(err))
      call check('advice <= dense limit', dt_advice <= dt_dense)
      ! energy_check = 0: at its stability limit RK4 is stable but damps the top
      ! modes (|R| < 1), which the ledger counts as an error (0.39 of the scale here)
      call load_model_text(chain_deck(100, .false., 4000.0_wp*dt_advice, dt_advice, ', energy_check = 0'), m)
      call simulate(m, none, res, err)
      if (allocated(err)) write (*, '(4x,a)') err%message
      call check('at the advice: no blow-up', .not. allocated(err))
      ! E0 = J w^2 / 2 = 0.5 J; RK4 inside its region cannot add energy to an undamped linear train
      e_end = m%stored_energy(res%t_final, res%y_final)
      write (*, '(4x,a,es12.5,a)') 'stored energy after 4000 steps at the advice: ', e_end, ' J (0.5 at the start)'
      call check('at the advice: the stored energy does not grow', e_end <= 0.5_wp*(1.0_wp + 1.0e-9_wp))
      call load_model_text(chain_deck(100, .false., 4000.0_wp*1.1_wp*dt_dense, 1.1_wp*dt_dense, &
                           ', energy_check = 0'), m)
      call simulate(m, none, res, err)
      if (.not. allocated(err)) e_end = m%stored_energy(res%t_final, res%y_final)
      call check('at 1.1 x the dense limit: the run blows up', allocated(err) .or. e_end > 1.0_wp)
   end subroutine test_chain_runs_at_the_advised_step

   !> The bound against dsygv (undamped frequencies) and dgeev (the damped limit) in `state`.
   subroutine compare(m, state, what)
      type(model_t), intent(inout) :: m
      type(lin_state_t), intent(in) :: state
      character(len=*), intent(in) :: what
      type(modes_t) :: md
      type(error_t), allocatable :: err
      real(wp), allocatable :: y(:)
      real(wp) :: dt_b, bound, om_k, dt_d, om
      call compute_modes(m, md, err, state=state)
      call check(what//': dsygv', .not. allocated(err))
      call rk4_dt_limit(m, state, dt_d, om, err, dense=.true.)
      call check(what//': dgeev', .not. allocated(err))
      call m%initial_state(y)
      call m%init_modes(m%run%t_start, y)
      call rk4_dt_bound(m, with_loads(m, state), y, dt_b, bound, omega_k=om_k)
      write (*, '(4x,a,a,es12.5,a,es12.5,a,es12.5,a,es12.5)') what, ': omega bound/dsygv ', om_k, ' / ', &
         md%omega_max, ', dt bound/dgeev ', dt_b, ' / ', dt_d
      call check(what//': omega bound >= omega_max', om_k >= md%omega_max*(1.0_wp - 1.0e-9_wp))
      call check(what//': omega bound within the factor', om_k <= omega_factor*md%omega_max .or. md%omega_max == 0.0_wp)
      call check(what//': dt bound <= dense limit (safe)', dt_b <= dt_d*(1.0_wp + 1.0e-12_wp))
      call check(what//': dt bound >= the factor of the dense limit', dt_b >= dt_factor*dt_d)
   end subroutine compare

   !> The chain of bench/bench_startup.f90: unit inertias, shafts k = 1e4, with
   !> `backlash` a spur gear (half backlash 1e-3) as every 10th element; node 1 at 1 rad/s.
   function chain_deck(n, backlash, t_end, dt, extra) result(text)
      integer, intent(in) :: n
      logical, intent(in) :: backlash
      real(wp), intent(in) :: t_end, dt
      character(len=*), intent(in), optional :: extra   !< more &run keys
      character(len=:), allocatable :: text
      character(len=64) :: run
      integer :: i
      write (run, '(a,es23.16,a,es23.16)') 't_end = ', t_end, ', dt = ', dt
      text = "&run "//trim(run)//", integrator = 'rk4', output_interval = 0"
      if (present(extra)) text = text//extra
      text = text//' /'
      do i = 1, n
         text = text//nl//"&node id = 'n"//str(i)//"', type = 'inertia', inertia = 1.0 /"
      end do
      do i = 1, n - 1
         if (backlash .and. mod(i, 10) == 0) then
            text = text//nl//"&element id = 'e"//str(i)//"', type = 'spur_gear', stiffness = 1.0e4, "// &
                   'rb_driver = 1.0, rb_driven = 1.0, teeth = 32, contact_ratio = 1.6, approach_angle = 0.1, '// &
                   'half_backlash = 1.0e-3 /'
         else
            text = text//nl//"&element id = 'e"//str(i)//"', type = 'shaft', stiffness = 1.0e4 /"
         end if
      end do
      text = text//nl//"&initial node = 'n1', speed = 1.0 /"
   end function chain_deck

   !> A disk J1 on a rigid_gear (r1 wl = r2 wr) or rigid_join with J2, a shaft k
   !> from J2 to a disk J3 (or to ground): J1 rides on J2 as J_eq = J2 + J1 (r2/r1)^2,
   !> omega^2 = k (1/J_eq + 1/J3) (k/J_eq on ground), undamped: RK4's limit is
   !> 2 sqrt 2/omega (the imaginary-axis radius), and `trainsim modes` (dsygv in
   !> the merged coordinates) has the same top frequency. Unmerged, J2 alone
   !> would set it (omega^2 = k (1/J2 + 1/J3): a step 1.8 (gear) / 1.7 (join) x shorter).
   subroutine test_rigid_connections_merge_in_the_advice()
      real(wp), parameter :: j1 = 0.3_wp, j2 = 0.2_wp, j3 = 0.5_wp, r1 = 0.02_wp, r2 = 0.05_wp
      call test_begin('rigid_connections_merge_in_the_advice')
      call rigid_case("type = 'rigid_gear', rb_driver = 0.02, rb_driven = 0.05", "'c'", j2 + j1*(r2/r1)**2, &
                      1.0_wp/j3, 'rigid_gear, free disk')
      call rigid_case("type = 'rigid_gear', rb_driver = 0.02, rb_driven = 0.05", "'ground'", j2 + j1*(r2/r1)**2, &
                      0.0_wp, 'rigid_gear, shaft to ground')
      call rigid_case("type = 'rigid_join'", "'c'", j2 + j1, 1.0_wp/j3, 'rigid_join, free disk')
   end subroutine test_rigid_connections_merge_in_the_advice

   subroutine rigid_case(link, far, j_eq, inv_j3, name)
      character(len=*), intent(in) :: link, far, name
      real(wp), intent(in) :: j_eq, inv_j3
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      real(wp) :: dt, om, om_exact
      character(len=40) :: far_type
      far_type = "type = 'fixed'"
      if (far == "'c'") far_type = "type = 'inertia', inertia = 0.5"
      call load_model_text("&run t_end = 0.1, dt = 1.0e-5 /"//nl// &
                           "&node id = 'a', type = 'inertia', inertia = 0.3 /"//nl// &
                           "&node id = 'b', type = 'inertia', inertia = 0.2 /"//nl// &
                           "&node id = "//far//", "//trim(far_type)//" /"//nl// &
                           "&element left = 'a', right = 'b', "//link//" /"//nl// &
                           "&element type = 'shaft', left = 'b', right = "//far//", stiffness = 4.0e4 /"//nl// &
                           "&load node = 'a', value = 1.0 /", m)
      om_exact = sqrt(4.0e4_wp*(1.0_wp/j_eq + inv_j3))   ! the shaft's k
      call rk4_dt_limit(m, lin_stiffest, dt, om, err, dense=.true.)
      call check(name//': no error', .not. allocated(err))
      if (allocated(err)) return
      call check(name//': |lambda| = the merged closed form', om, om_exact, rel_tol=1.0e-9_wp)
      call check(name//': RK4 limit = 2 sqrt 2 / omega', dt, sqrt(8.0_wp)/om_exact, rel_tol=1.0e-9_wp)
      call compute_modes(m, md, err)
      if (allocated(err)) return
      call check(name//': modes agrees (top frequency)', md%omega_max, om_exact, rel_tol=1.0e-9_wp)
   end subroutine rigid_case
   !> The merged limit is RK4's own: the rigid gear's train (shaft to ground, one
   !> mode, undamped) runs 4000 steps at 0.99 x the merged limit (3.1 x the unmerged
   !> one) without its energy growing, and at 1.05 x it blows up
   !> (|R| > 1 on its one mode) or is refused.
   subroutine test_rigid_train_runs_at_the_merged_limit()
      type(model_t) :: m
      type(run_result_t) :: res
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      real(wp) :: dt_lim, om, e0, e_end
      call test_begin('rigid_train_runs_at_the_merged_limit')
      call load_model_text(rigid_train(1.0e-5_wp, 1.0e-5_wp), m)
      call rk4_dt_limit(m, lin_stiffest, dt_lim, om, err)
      call check('limit: no error', .not. allocated(err))
      if (allocated(err)) return
      call load_model_text(rigid_train(4000.0_wp*0.99_wp*dt_lim, 0.99_wp*dt_lim), m)
      call simulate(m, none, res, err)
      if (allocated(err)) write (*, '(4x,a)') err%message
      call check('at 0.99 x the merged limit: runs (not refused, no blow-up)', .not. allocated(err))
      if (allocated(err)) return
      e0 = 0.5_wp*4.0e4_wp*0.01_wp**2
      e_end = m%stored_energy(res%t_final, res%y_final)
      write (*, '(4x,a,es12.5,a,es12.5,a)') 'stored energy after 4000 steps: ', e_end, ' J (', e0, ' at the start)'
      call check('at 0.99 x the merged limit: the stored energy does not grow', e_end <= e0*(1.0_wp + 1.0e-9_wp))
      call load_model_text(rigid_train(4000.0_wp*1.05_wp*dt_lim, 1.05_wp*dt_lim), m)
      call simulate(m, none, res, err)
      if (.not. allocated(err)) e_end = m%stored_energy(res%t_final, res%y_final)
      call check('at 1.05 x the merged limit: refused or blows up', allocated(err) .or. e_end > 10.0_wp*e0)
   end subroutine test_rigid_train_runs_at_the_merged_limit

   !> J1 = 0.3 on a rigid gear (r2/r1 = 2.5) with J2 = 0.2, a shaft k = 4e4 to
   !> ground, J2 turned by 0.01 rad at the start (E0 = k 0.01^2/2).
   function rigid_train(t_end, dt) result(text)
      real(wp), intent(in) :: t_end, dt
      character(len=:), allocatable :: text
      character(len=24) :: a, b
      write (a, '(es22.15)') t_end
      write (b, '(es22.15)') dt
      text = "&run t_end = "//trim(a)//", dt = "//trim(b)//", output_interval = "//trim(a)// &
             ", energy_check = 0 /"//nl// &
             "&node id = 'a', type = 'inertia', inertia = 0.3 /"//nl// &
             "&node id = 'b', type = 'inertia', inertia = 0.2 /"//nl// &
             "&node id = 'ground', type = 'fixed' /"//nl// &
             "&element left = 'a', right = 'b', type = 'rigid_gear', rb_driver = 0.02, rb_driven = 0.05 /"//nl// &
             "&element type = 'shaft', left = 'b', right = 'ground', stiffness = 4.0e4 /"//nl// &
             "&initial node = 'b', angle = 0.01 /"
   end function rigid_train

end program test_dt_bound
