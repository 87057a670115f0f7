!> What the SUNDIALS integrators share: the SUNDIALS context and vectors, the
!> callbacks (right-hand side, Jacobian, guards as root functions, error
!> messages; in trainsim_sundials_callbacks), the set-up sequence, the
!> advance/restart cycle and the failure diagnosis (submodule
!> trainsim_sundials_failure). The backends (trainsim_int_cvode, trainsim_int_arkode) extend
!> `sundials_integrator_t` and differ only in the SUNDIALS calls they make:
!> each deferred `sun_*` procedure below is one call of the package.
!>
!> Every guard of every element is a root function with direction -1 (a mode
!> stays valid while its guards are >= 0: only downward crossings are
!> events). The integrator advances in ONE_STEP mode: `advance` returns every
!> internal step, and an output time inside a step interpolated on the step's
!> dense output (GetDky). A root ends the step at the root: the output times
!> before it are interpolated and returned first, then the root as adv_event
!> (D-49); the driver updates the modes and calls `restart`, which
!> re-initialises the integrator at the event point: a mode change makes the
!> right-hand side non-smooth there, so no history (multistep history, or the
!> RK step-size history and interpolant) is carried across it. The same
!> happens at the breakpoints of the inputs, which are stop times.
!> See docs/integrators.md.
module trainsim_sundials
   use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_char, c_null_ptr, c_null_char, &
                                          c_loc, c_funloc, c_f_pointer, c_associated
   use fsundials_context_mod, only: FSUNContext_Create, FSUNContext_Free
   use fsundials_nvector_mod, only: N_Vector, FN_VDestroy
   use fnvector_serial_mod, only: FN_VMake_Serial
   use trainsim_kinds, only: wp, i8, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input, err_numeric, err_internal
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_modes, only: rk4_dt_limit, limiting_part, rk4_dt_quick
   use trainsim_element, only: lin_stiffest, lin_state_t
   use trainsim_integrator, only: integrator_t, adv_step, adv_reached, adv_event
   use trainsim_sundials_callbacks, only: cv_user_t, cv_rhs, cv_jac, cv_roots, cv_error_handler, cv_ewt, &
                                          cvode_max_step, cvode_abstol, cvode_weights, angle_resolution
   implicit none
   private

   public :: sundials_integrator_t, cv_user_t
   public :: cv_rhs, cv_jac, cv_roots, cv_error_handler, cv_ewt
   public :: cvode_max_step, cvode_abstol, angle_resolution
   public :: st_success, st_tstop, st_root, st_too_much_work, st_too_much_acc, st_err_failure, &
             st_conv_failure, st_lin_failure, st_rhs_failure, st_root_failure, st_too_close, st_bad_input, st_other

   !> Internal steps allowed per call (per output interval), at least.
   integer(i8), parameter :: mxstep_min = 1000000_i8
   !> Most steps a run may be forced into by the automatic max_step (or, for an
   !> explicit method, by its stability limit): beyond this the highest mode is
   !> out of proportion to the run, and the run would crawl for hours.
   real(wp), parameter :: implied_step_budget = 1.0e8_wp
   !> Highest mode (Hz) a lumped torsional model can mean: a torsional wave in
   !> steel (sqrt(G/rho) = 3200 m/s) has its first mode at 10 MHz in a part
   !> 0.16 mm long. A mode above this is an input slip, and would force the
   !> automatic max_step (a tenth of its period) below 1e-8 s.
   real(wp), parameter :: plausible_mode_hz = 1.0e7_wp

   !> Package-neutral outcome of a SUNDIALS call (each backend's `status` maps
   !> its CV_* or ARK_* return flags onto these).
   integer, parameter :: st_success = 0, st_tstop = 1, st_root = 2
   integer, parameter :: st_too_much_work = -1, st_too_much_acc = -2, st_err_failure = -3, &
                         st_conv_failure = -4, st_lin_failure = -5, st_rhs_failure = -6, &
                         st_root_failure = -7, st_too_close = -8, st_bad_input = -9, st_other = -99

   type, abstract, extends(integrator_t) :: sundials_integrator_t
      !> the integrator's name, the package ('CVODE', 'ARKODE') and the prefix
      !> of its functions ('CVode', 'ERKStep'), for messages
      character(len=:), allocatable :: name, solver, prefix
      type(cv_user_t) :: ud
      type(c_ptr) :: ctx = c_null_ptr, mem = c_null_ptr
      type(N_Vector), pointer :: nv_y => null(), nv_atol => null()
      real(c_double), allocatable :: yv(:), atol(:), ydky(:)
      type(N_Vector), pointer :: nv_dky => null()
      real(wp) :: t_int = 0.0_wp          !< where the last internal step ended (yv holds the state there)
      real(wp) :: tiny_t = 0.0_wp         !< times closer than this are one instant
      integer(i8) :: steps_to_goal = 0    !< internal steps since the last goal was reached
      integer(c_int), allocatable :: rootdir(:), rootsfound(:)
      logical :: root_pending = .false.   !< rootsfound holds the roots of the last return
      !> the last internal step ended at a root (t_int, yv) not yet returned: the
      !> output times before it inside the step are returned first (D-49)
      logical :: root_ahead = .false.
      logical :: root_info_ok = .false.   !< rootsfound holds the roots of that root
      real(wp) :: hmax = 0.0_wp, omega_max = 0.0_wp, t_goal = 0.0_wp
      real(wp) :: t_init = 0.0_wp          !< where the integration starts
      integer(i8) :: mxstep = mxstep_min
      integer :: n = 0, ng = 0
   contains
      procedure :: start => sun_start
      procedure :: advance => sun_advance
      procedure :: restart => sun_restart
      procedure :: finish => sun_finish
      procedure :: fired => sun_fired
      procedure :: may_miss_events => sun_may_miss_events
      procedure :: flush_counters => sun_accumulate
      procedure, private :: setup_failed => sun_setup_failed
      procedure, private :: failed => sun_failed
      ! the package's calls
      procedure(create_i), deferred :: sun_create
      procedure(flag_i), deferred :: sun_init
      procedure(flag_i), deferred :: sun_set_err_handler
      procedure(flag_i), deferred :: sun_set_user_data
      procedure(flag_i), deferred :: sun_tolerances
      procedure(flag_i), deferred :: sun_setup_solver
      procedure(flag_real_i), deferred :: sun_set_max_step
      procedure(flag_i), deferred :: sun_set_max_num_steps
      procedure(flag_i), deferred :: sun_root_init
      procedure(flag_real_i), deferred :: sun_set_stop_time
      procedure(evolve_i), deferred :: sun_evolve
      procedure(flag_i), deferred :: sun_root_info
      procedure(flag_real_i), deferred :: sun_reinit
      procedure(flag_real_i), deferred :: sun_get_y_at
      procedure(counters_i), deferred :: sun_counters
      procedure(local_errors_i), deferred :: sun_local_errors
      procedure(where_i), deferred :: sun_where
      procedure(free_i), deferred :: sun_free
      procedure(status_i), deferred :: status
      procedure :: advice_too_much_work => sun_no_advice
      procedure :: advice_error_failure => sun_no_advice
      procedure :: describe_conv_failure => sun_describe_conv_failure
      procedure :: explicit_limit => sun_explicit_limit
   end type sundials_integrator_t

   abstract interface
      !> Create the integrator memory (self%mem).
      subroutine create_i(self, t)
         import :: sundials_integrator_t, wp
         class(sundials_integrator_t), intent(inout), target :: self
         real(wp), intent(in) :: t
      end subroutine create_i
      !> One SUNDIALS call; its raw return flag.
      integer(c_int) function flag_i(self) result(flag)
         import :: sundials_integrator_t, c_int
         class(sundials_integrator_t), intent(inout), target :: self
      end function flag_i
      !> One SUNDIALS call with a time or step argument; its raw flag.
      integer(c_int) function flag_real_i(self, x) result(flag)
         import :: sundials_integrator_t, c_int, wp
         class(sundials_integrator_t), intent(inout), target :: self
         real(wp), intent(in) :: x
      end function flag_real_i
      !> One internal step towards t_to (ONE_STEP mode); the time reached in tr; raw flag.
      integer(c_int) function evolve_i(self, t_to, tr) result(flag)
         import :: sundials_integrator_t, c_int, c_double, wp
         class(sundials_integrator_t), intent(inout), target :: self
         real(wp), intent(in) :: t_to
         real(c_double), intent(out) :: tr
      end function evolve_i
      !> Counters since the last (re-)initialisation.
      subroutine counters_i(self, nst, nfe, nje, netf, ncf, nsf)
         import :: sundials_integrator_t, i8
         class(sundials_integrator_t), intent(inout) :: self
         integer(i8), intent(out) :: nst, nfe, nje, netf, ncf, nsf
      end subroutine counters_i
      !> Estimated local errors and error weights of the last step attempt.
      subroutine local_errors_i(self, nv_ele, nv_ewt)
         import :: sundials_integrator_t, N_Vector
         class(sundials_integrator_t), intent(inout) :: self
         type(N_Vector), intent(inout) :: nv_ele, nv_ewt
      end subroutine local_errors_i
      !> The integrator's current time and its last step size.
      subroutine where_i(self, tcur, hlast)
         import :: sundials_integrator_t, c_double
         class(sundials_integrator_t), intent(inout) :: self
         real(c_double), intent(inout) :: tcur(1), hlast(1)
      end subroutine where_i
      !> Free the integrator memory and the package's own solver objects.
      subroutine free_i(self)
         import :: sundials_integrator_t
         class(sundials_integrator_t), intent(inout) :: self
      end subroutine free_i
      !> The package-neutral outcome (st_*) of a return flag.
      pure integer function status_i(self, flag) result(st)
         import :: sundials_integrator_t, c_int
         class(sundials_integrator_t), intent(in) :: self
         integer(c_int), intent(in) :: flag
      end function status_i
   end interface


   interface
      !> The failure diagnosis (submodule trainsim_sundials_failure).
      module subroutine sun_failed(self, model, flag, st, t, err)
         class(sundials_integrator_t), intent(inout), target :: self
         type(model_t), intent(in) :: model
         integer(c_int), intent(in) :: flag
         integer, intent(in) :: st
         real(wp), intent(in) :: t
         type(error_t), allocatable, intent(out) :: err
      end subroutine sun_failed
   end interface

contains

   ! --------------------------------------------------------------- callbacks

   ! ------------------------------------------------------------ set-up helpers

   !> An explicit method's step is held below explicit_limit/|lambda| for the
   !> largest |lambda| of the damped train in its stiffest state (every
   !> clearance closed, every contact law's damping at its largest, D-55; an
   !> overdamped contact or node limits it as much as a stiff one): a run that
   !> would take more than implied_step_budget such steps is refused before the
   !> first step, naming the node or element that limits it.
   subroutine explicit_stiffness_check(self, model, t, err)
      class(sundials_integrator_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: t
      type(error_t), allocatable, intent(out) :: err
      type(model_t) :: tmp
      type(error_t), allocatable :: lim_err
      real(wp) :: om, dt_rk4, om_damped, h_part
      character(len=:), allocatable :: part, what
      type(lin_state_t) :: st
      om = self%omega_max
      what = 'the highest mode ('//str(self%omega_max/two_pi, 4)//' Hz, every clearance closed)'
      st = lin_stiffest
      st%load_torque = -1.0_wp     ! the impact damping, not a gentle closure under load (as check_fixed_step)
      tmp = model
      call rk4_dt_quick(tmp, st, dt_rk4, om_damped)   ! O(n): |lambda| <= om_damped
      if (.not. (model%run%t_end - t)*max(om, om_damped)/self%explicit_limit() > implied_step_budget) return
      tmp = model
      call rk4_dt_limit(tmp, st, dt_rk4, om_damped, lim_err)
      if (.not. allocated(lim_err) .and. om_damped > om) then
         om = om_damped
         what = 'the damped train with every clearance closed (|lambda| = '//str(om_damped, 4)//' 1/s)'
      end if
      if (.not. om > 0.0_wp) return
      if (.not. (model%run%t_end - t)*om/self%explicit_limit() > implied_step_budget) return
      tmp = model
      call limiting_part(tmp, st, part, h_part)
      call fatal_error(err, "integrator '"//self%name//"' is explicit: its step is held below "// &
                       str(self%explicit_limit()/om, 4)//' s by '//what//', set by '//part// &
                       ', so the run of '//str(model%run%t_end - t)//' s would take more than '// &
                       str(implied_step_budget)//" steps: this train is stiff; use integrator = 'cvode-bdf' "// &
                       '(implicit: its step has no stability limit)', err_numeric)
   end subroutine explicit_stiffness_check

   ! ------------------------------------------------------ the shared cycle

   !> Create and set up the SUNDIALS objects for a run from (t, y).
   subroutine sun_start(self, model, t, y, err)
      class(sundials_integrator_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t, y(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: dout

      self%name = model%run%integrator
      self%t_init = t
      self%n = model%n_y
      self%ng = model%n_guards
      if (self%n == 0) then
         call fatal_error(err, "integrator '"//self%name//"' needs at least one integrated state; "// &
                          "every node of this train is fixed or has a prescribed speed: use integrator = 'rk4'", err_input)
         return
      end if
      call cvode_max_step(model, self%hmax, self%omega_max)
      dout = model%run%output_interval
      if (.not. dout > 0.0_wp) dout = model%run%dt
      if (self%explicit_limit() > 0.0_wp) then
         call explicit_stiffness_check(self, model, t, err)
         if (allocated(err)) return
      end if
      if (self%hmax > 0.0_wp) then
         if ((model%run%t_end - t)/self%hmax > 1.0e12_wp) then
            call fatal_error(err, 'max_step = '//str(self%hmax)//' s would need more than 1e12 steps over the run of '// &
                             str(model%run%t_end - t)//' s: raise max_step (0 chooses it from the highest frequency)', &
                             err_input)
            return
         end if
         if (model%run%max_step <= 0.0_wp .and. self%omega_max/two_pi > plausible_mode_hz) then
            call fatal_error(err, "integrator '"//self%name//"': the highest mode with every clearance closed is at "// &
                             str(self%omega_max/two_pi, 4)//' Hz, above the '//str(plausible_mode_hz)// &
                             ' Hz a lumped torsional model can mean (a steel part 0.16 mm long): check the '// &
                             'stiffnesses, radii and inertias of the deck for a unit slip, or set max_step explicitly', &
                             err_input)
            return
         end if
         if (model%run%max_step <= 0.0_wp .and. (model%run%t_end - t)/self%hmax > implied_step_budget) then
            call fatal_error(err, "integrator '"//self%name//"': the highest mode with every clearance closed ("// &
                             str(self%omega_max/two_pi, 4)//' Hz) sets the automatic max_step to '//str(self%hmax, 4)// &
                             ' s, so the run of '//str(model%run%t_end - t)//' s would take more than '// &
                             str(implied_step_budget)//' steps. A mode that fast is out of proportion to the train: '// &
                             'check the stiffnesses and inertias of the deck, or set max_step explicitly', err_numeric)
            return
         end if
         ! steps allowed per call (one output interval): generous, but bounded
         self%mxstep = max(mxstep_min, int(min(10.0_wp*dout/self%hmax, 1.0e9_wp), i8))
      end if

      allocate (self%yv(self%n), self%atol(self%n), self%ydky(self%n), self%rootdir(max(self%ng, 1)), &
                self%rootsfound(max(self%ng, 1)))
      self%yv = y
      self%ydky = y
      self%t_int = t
      self%tiny_t = 1.0e-9_wp*model%run%dt
      call cvode_abstol(model, self%atol)
      allocate (self%ud%rel(self%n), self%ud%fixed(self%n))
      call cvode_weights(model, self%atol, self%ud%rel, self%ud%fixed)
      self%rootdir = -1_c_int
      self%rootsfound = 0
      self%ud%model => model
      self%ud%ng = self%ng

      if (FSUNContext_Create(c_null_ptr, self%ctx) /= 0) then
         call fatal_error(err, 'could not create the SUNDIALS context (out of memory?)', err_internal)
         return
      end if
      self%nv_y => FN_VMake_Serial(int(self%n, c_long), self%yv, self%ctx)
      self%nv_atol => FN_VMake_Serial(int(self%n, c_long), self%atol, self%ctx)
      self%nv_dky => FN_VMake_Serial(int(self%n, c_long), self%ydky, self%ctx)
      if (.not. (associated(self%nv_y) .and. associated(self%nv_atol) .and. associated(self%nv_dky))) then
         call self%setup_failed('N_VMake_Serial', err); return
      end if
      call self%sun_create(t)
      if (.not. c_associated(self%mem)) then
         call self%setup_failed(self%prefix//'Create', err); return
      end if
      if (self%status(self%sun_set_err_handler()) /= st_success) then
         call self%setup_failed(self%prefix//'SetErrHandlerFn', err); return
      end if
      if (self%status(self%sun_init()) /= st_success) then
         call self%setup_failed(self%prefix//'Init', err); return
      end if
      if (self%status(self%sun_set_user_data()) /= st_success) then
         call self%setup_failed(self%prefix//'SetUserData', err); return
      end if
      if (self%status(self%sun_tolerances()) /= st_success) then
         call self%setup_failed(self%prefix//'SVtolerances', err); return
      end if
      if (self%status(self%sun_setup_solver()) /= st_success) then
         call self%setup_failed('the solver set-up of '//self%solver, err); return
      end if
      if (self%hmax > 0.0_wp) then
         if (self%status(self%sun_set_max_step(self%hmax)) /= st_success) then
            call self%setup_failed(self%prefix//'SetMaxStep', err); return
         end if
      end if
      if (self%status(self%sun_set_max_num_steps()) /= st_success) then
         call self%setup_failed(self%prefix//'SetMaxNumSteps', err); return
      end if
      if (self%ng > 0) then
         if (self%status(self%sun_root_init()) /= st_success) then
            call self%setup_failed(self%prefix//'RootInit', err); return
         end if
      end if
      if (self%status(self%sun_set_stop_time(self%t_stop)) /= st_success) then
         call self%setup_failed(self%prefix//'SetStopTime', err); return
      end if
   end subroutine sun_start

   !> One internal step (ONE_STEP mode: the driver and the observer see every
   !> step, so extremes are taken at every internal step), or the goal: a step
   !> that passes t_goal is reported at t_goal, interpolated by the integrator's
   !> own dense output, and its end on the next call. A step that ends at a
   !> root (the package stops the step there) is treated alike (D-49): output
   !> times before the root are interpolated on the step and returned first,
   !> then the root, as adv_event; never a root beyond t_goal.
   subroutine sun_advance(self, model, t_goal, t, y, status, err)
      class(sundials_integrator_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t_goal
      real(wp), intent(inout) :: t, y(:)
      integer, intent(out) :: status
      type(error_t), allocatable, intent(out) :: err
      integer(c_int) :: flag
      integer :: st
      real(c_double) :: tret
      self%t_goal = t_goal
      status = adv_reached
      self%root_pending = .false.
      if (self%t_int <= t + self%tiny_t) then
         ! take one internal step
         flag = self%sun_evolve(t_goal, tret)
         st = self%status(flag)
         if (flag >= 0) self%steps_to_goal = self%steps_to_goal + 1
         if (flag < 0 .or. self%steps_to_goal > self%mxstep) then
            if (flag >= 0) st = st_too_much_work
            call self%failed(model, flag, st, t, err)
            return
         end if
         self%t_int = tret
         if (st == st_root) then
            ! yv is the state at the root, where the integrator will restart;
            ! the step's dense output still covers the times before it
            self%stats%root_returns = self%stats%root_returns + 1
            self%rootsfound = 0
            self%root_info_ok = self%status(self%sun_root_info()) == st_success
            self%root_ahead = .true.
         end if
      end if
      if (self%root_ahead .and. self%t_int <= t_goal + self%tiny_t) then
         t = self%t_int                      ! the root, at or before the goal
         y = self%yv
         self%root_ahead = .false.
         self%root_pending = self%root_info_ok
         status = adv_event
         return
      end if
      if (self%t_int < t_goal - self%tiny_t) then
         t = self%t_int                      ! an internal step short of the goal
         y = self%yv
         status = adv_step
      else if (self%t_int > t_goal + self%tiny_t) then
         if (self%status(self%sun_get_y_at(t_goal)) /= st_success) then
            call fatal_error(err, 'internal: '//self%prefix//'GetDky failed at t = '//str(t_goal)//' s', err_internal)
            return
         end if
         t = t_goal                          ! the goal, inside the last step (before its root, if any)
         y = self%ydky
      else
         t = self%t_int                      ! the step ended on the goal (a stop time)
         y = self%yv
      end if
      if (status == adv_reached) self%steps_to_goal = 0
   end subroutine sun_advance

   !> The guards that fired at an event: those below zero and, right after a
   !> root return, those the root finder reported (located within its
   !> tolerance, so possibly just above zero).
   subroutine sun_fired(self, g, fired)
      class(sundials_integrator_t), intent(inout) :: self
      real(wp), intent(in) :: g(:)
      logical, intent(out) :: fired(:)
      fired = g < 0.0_wp
      if (self%root_pending) fired = fired .or. self%rootsfound(1:size(g)) /= 0
      self%root_pending = .false.
   end subroutine sun_fired

   !> SUNDIALS's root finder checks sign changes between step ends only.
   pure logical function sun_may_miss_events(self) result(may)
      class(sundials_integrator_t), intent(in) :: self
      associate (unused => self)
      end associate
      may = .true.
   end function sun_may_miss_events

   !> Re-initialise at (t, y) (no history across a mode change or breakpoint).
   subroutine sun_restart(self, model, t, y, err)
      class(sundials_integrator_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t, y(:)
      type(error_t), allocatable, intent(out) :: err
      call self%flush_counters()
      self%yv = y
      self%t_int = t
      self%steps_to_goal = 0
      self%root_pending = .false.
      self%root_ahead = .false.
      if (self%status(self%sun_reinit(t)) /= st_success) then
         call fatal_error(err, 'internal: '//self%prefix//'ReInit failed at t = '//str(t)//' s: '// &
                          self%ud%msg(1:self%ud%msg_len), err_internal)
         return
      end if
      if (self%status(self%sun_set_stop_time(self%t_stop)) /= st_success) then
         call fatal_error(err, 'internal: '//self%prefix//'SetStopTime('//str(self%t_stop)//') failed at t = '// &
                          str(t)//' s', err_internal)
      end if
      associate (unused => model)
      end associate
   end subroutine sun_restart

   !> Add the integrator's counters (zeroed by every re-initialisation) to self%stats.
   subroutine sun_accumulate(self)
      class(sundials_integrator_t), intent(inout) :: self
      integer(i8) :: nst, nfe, nje, netf, ncf, nsf
      if (.not. c_associated(self%mem)) return
      call self%sun_counters(nst, nfe, nje, netf, ncf, nsf)
      self%stats%steps = self%stats%steps + nst
      self%stats%rhs_evals = self%stats%rhs_evals + nfe
      self%stats%jac_evals = self%stats%jac_evals + nje
      self%stats%error_test_fails = self%stats%error_test_fails + netf
      self%stats%conv_fails = self%stats%conv_fails + ncf
      self%stats%rejected = self%stats%rejected + netf + nsf
   end subroutine sun_accumulate

   !> Free the SUNDIALS objects (in reverse order of creation).
   subroutine sun_finish(self)
      class(sundials_integrator_t), intent(inout) :: self
      integer(c_int) :: ie
      call self%sun_free()
      if (associated(self%nv_dky)) call FN_VDestroy(self%nv_dky)
      if (associated(self%nv_atol)) call FN_VDestroy(self%nv_atol)
      if (associated(self%nv_y)) call FN_VDestroy(self%nv_y)
      nullify (self%nv_dky, self%nv_atol, self%nv_y)
      if (c_associated(self%ctx)) ie = FSUNContext_Free(self%ctx)
      self%ctx = c_null_ptr
   end subroutine sun_finish

   !> A SUNDIALS object could not be made or set up.
   subroutine sun_setup_failed(self, what, err)
      class(sundials_integrator_t), intent(inout) :: self
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: detail
      detail = ''
      if (self%ud%msg_len > 0) detail = ': '//self%ud%msg(1:self%ud%msg_len)
      call fatal_error(err, "internal: setting up integrator '"//self%name//"' failed in "//what//detail, err_internal)
   end subroutine sun_setup_failed

   !> Extra advice of a backend for a failure (default: none).
   function sun_no_advice(self) result(text)
      class(sundials_integrator_t), intent(in) :: self
      character(len=:), allocatable :: text
      associate (unused => self)
      end associate
      text = ''
   end function sun_no_advice

   !> |h lambda| on the imaginary axis inside which an explicit method is
   !> stable (0: implicit, no such limit).
   pure real(wp) function sun_explicit_limit(self) result(r)
      class(sundials_integrator_t), intent(in) :: self
      associate (unused => self)
      end associate
      r = 0.0_wp
   end function sun_explicit_limit

   !> What a convergence failure of the nonlinear iteration means (Newton's by default).
   subroutine sun_describe_conv_failure(self, rk4_hint, what, advice)
      class(sundials_integrator_t), intent(in) :: self
      character(len=*), intent(in) :: rk4_hint
      character(len=:), allocatable, intent(out) :: what, advice
      associate (unused => self)
      end associate
      what = 'the Newton iteration did not converge'
      advice = 'lower max_step, loosen rtol/atol, or '//rk4_hint
   end subroutine sun_describe_conv_failure

end module trainsim_sundials
