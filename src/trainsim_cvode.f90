!> SUNDIALS CVODE (BDF/Newton or Adams/fixed-point) with root-finding on the
!> element guards. All SUNDIALS calls live in this module.
!>
!> 'cvode-bdf'  : variable-order BDF, Newton iteration, dense direct linear
!>                solver; the Jacobian is CVODE's internal difference quotient.
!> 'cvode-adams': variable-order Adams-Moulton, fixed-point iteration.
!>
!> Every guard of every element is a CVODE root function with direction -1
!> (a mode stays valid while its guards are >= 0: only downward crossings are
!> events). At a root return the modes are updated by `model%apply_events`
!> (the code the RK4 path uses), the events go to the observer, and CVODE is
!> re-initialised at the event point: a mode change makes the right-hand side
!> non-smooth there, so the multistep history must not be carried across it.
!> Breakpoints of the time functions (tables, steps, ramps, duty cycles) are
!> CVODE stop times followed by a re-initialisation for the same reason.
!>
!> Output: CVODE advances with CV_NORMAL to each output time (t_start +
!> k output_interval, or each dt if output_interval = 0) and interpolates;
!> the observer sees every output time and every root return.
!> See docs/integrators.md.
module trainsim_cvode
   use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_char, c_null_ptr, c_null_char, &
                                          c_loc, c_funloc, c_f_pointer, c_associated
   use fsundials_context_mod, only: FSUNContext_Create, FSUNContext_Free
   use fsundials_nvector_mod, only: N_Vector, FN_VGetArrayPointer, FN_VDestroy
   use fsundials_matrix_mod, only: SUNMatrix, FSUNMatDestroy
   use fsundials_linearsolver_mod, only: SUNLinearSolver, FSUNLinSolFree
   use fsundials_nonlinearsolver_mod, only: SUNNonlinearSolver, FSUNNonlinSolFree
   use fnvector_serial_mod, only: FN_VMake_Serial
   use fsunmatrix_dense_mod, only: FSUNDenseMatrix, FSUNDenseMatrix_Data
   use fsunlinsol_dense_mod, only: FSUNLinSol_Dense
   use fsunnonlinsol_fixedpoint_mod, only: FSUNNonlinSol_FixedPoint
   use fcvode_mod, only: FCVodeCreate, FCVodeInit, FCVodeReInit, FCVodeFree, FCVode, &
                         FCVodeSVtolerances, FCVodeSetUserData, FCVodeSetLinearSolver, FCVodeSetNonlinearSolver, &
                         FCVodeSetMaxStep, FCVodeSetMaxNumSteps, FCVodeSetStopTime, FCVodeSetErrHandlerFn, &
                         FCVodeSetMaxHnilWarns, FCVodeSetNoInactiveRootWarn, FCVodeSetJacFn, &
                         FCVodeRootInit, FCVodeSetRootDirection, FCVodeGetRootInfo, &
                         FCVodeGetNumSteps, FCVodeGetNumRhsEvals, FCVodeGetNumLinRhsEvals, FCVodeGetNumJacEvals, &
                         FCVodeGetNumErrTestFails, FCVodeGetNumNonlinSolvConvFails, FCVodeGetNumStepSolveFails, &
                         FCVodeGetCurrentTime, FCVodeGetLastStep, &
                         FCVodeGetEstLocalErrors, FCVodeGetErrWeights, &
                         CV_BDF, CV_ADAMS, CV_NORMAL, CV_SUCCESS, CV_ROOT_RETURN, CV_TSTOP_RETURN, &
                         CV_TOO_MUCH_WORK, CV_TOO_MUCH_ACC, CV_ERR_FAILURE, CV_CONV_FAILURE, &
                         CV_LINIT_FAIL, CV_LSETUP_FAIL, CV_LSOLVE_FAIL, CV_RHSFUNC_FAIL, CV_FIRST_RHSFUNC_ERR, &
                         CV_REPTD_RHSFUNC_ERR, CV_UNREC_RHSFUNC_ERR, CV_RTFUNC_FAIL, CV_NLS_FAIL, CV_TOO_CLOSE, &
                         CV_MEM_NULL, CV_ILL_INPUT, CV_BAD_T
   use trainsim_kinds, only: wp, i8, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input, err_numeric, err_internal
   use trainsim_strings, only: str, string_t
   use trainsim_model, only: model_t
   use trainsim_modes, only: modes_t, compute_modes, rk4_stability_limit
   use trainsim_sink, only: sink_t, run_stats_t, event_t
   use trainsim_observer, only: observer_t
   implicit none
   private

   public :: integrate_cvode, cvode_max_step, cvode_abstol

   !> Fraction of the period of the highest linearised mode (clearances closed)
   !> used as the default maximum step.
   real(wp), parameter :: max_step_fraction = 0.1_wp
   !> Floor of the absolute tolerance of the energy-accounting states, per unit of 1 + E0.
   real(wp), parameter :: energy_atol_factor = 1.0e-6_wp
   !> Internal steps allowed per call (per output interval), at least.
   integer(i8), parameter :: mxstep_min = 1000000_i8
   !> Passes of the mode update at one event point (cascading guards).
   integer, parameter :: max_event_passes = 4

   !> What the callbacks see (user data): the caller's model and a few
   !> diagnostics written without allocation.
   type :: cv_user_t
      type(model_t), pointer :: model => null()
      integer :: ng = 0
      integer :: bad_state = 0            !< first state whose derivative was NaN
      real(wp) :: bad_t = 0.0_wp          !< time of that evaluation
      integer :: msg_len = 0
      character(len=512) :: msg = ''      !< last message CVODE reported
   end type cv_user_t

contains

   ! --------------------------------------------------------------- callbacks

   !> dy/dt for CVODE: model%rhs on the CVODE vectors. 1 (recoverable) on NaN.
   integer(c_int) function cv_rhs(tn, sunvec_y, sunvec_f, user_data) result(ierr) bind(C)
      real(c_double), value :: tn
      type(N_Vector) :: sunvec_y, sunvec_f
      type(c_ptr), value :: user_data
      type(cv_user_t), pointer :: ud
      real(c_double), pointer :: yv(:), fv(:)
      integer :: i
      call c_f_pointer(user_data, ud)
      yv => FN_VGetArrayPointer(sunvec_y)
      fv => FN_VGetArrayPointer(sunvec_f)
      call ud%model%rhs(tn, yv, fv)
      ierr = 0
      do i = 1, size(fv)
         if (fv(i) /= fv(i)) then
            if (ud%bad_state == 0) then
               ud%bad_state = i
               ud%bad_t = tn
            end if
            ierr = 1
            return
         end if
      end do
   end function cv_rhs

   !> Dense Jacobian for CVODE BDF's Newton iteration: model%jacobian written
   !> straight into the SUNDIALS matrix (column-major, no copy, no allocation).
   integer(c_int) function cv_jac(tn, sunvec_y, sunvec_f, sunmat_j, user_data, tmp1, tmp2, tmp3) &
      result(ierr) bind(C)
      real(c_double), value :: tn
      type(N_Vector) :: sunvec_y, sunvec_f, tmp1, tmp2, tmp3
      type(SUNMatrix) :: sunmat_j
      type(c_ptr), value :: user_data
      type(cv_user_t), pointer :: ud
      real(c_double), pointer :: yv(:), jflat(:), jac(:, :)
      integer :: n
      call c_f_pointer(user_data, ud)
      yv => FN_VGetArrayPointer(sunvec_y)
      jflat => FSUNDenseMatrix_Data(sunmat_j)
      n = size(yv)
      call c_f_pointer(c_loc(jflat(1)), jac, [n, n])
      call ud%model%jacobian(tn, yv, jac)
      ierr = 0
      associate (u1 => sunvec_f, u2 => tmp1, u3 => tmp2, u4 => tmp3)   ! unused by this Jacobian
      end associate
   end function cv_jac

   !> The guards as CVODE root functions.
   integer(c_int) function cv_roots(tn, sunvec_y, gout, user_data) result(ierr) bind(C)
      real(c_double), value :: tn
      type(N_Vector) :: sunvec_y
      real(c_double) :: gout(*)
      type(c_ptr), value :: user_data
      type(cv_user_t), pointer :: ud
      real(c_double), pointer :: yv(:)
      call c_f_pointer(user_data, ud)
      yv => FN_VGetArrayPointer(sunvec_y)
      call ud%model%guards(tn, yv, gout(1:ud%ng))
      ierr = 0
   end function cv_roots

   !> CVODE's error and warning messages: kept (the last one) for our own
   !> message instead of being printed to stderr.
   subroutine cv_error_handler(error_code, module, function, msg, user_data) bind(C)
      integer(c_int), value :: error_code
      type(c_ptr), value :: module, function, msg, user_data
      type(cv_user_t), pointer :: ud
      character(kind=c_char), pointer :: text(:)
      integer :: i
      if (error_code > 0) return    ! warnings (e.g. t + h = t) are not kept
      associate (u1 => module, u2 => function)
      end associate
      if (.not. (c_associated(user_data) .and. c_associated(msg))) return
      call c_f_pointer(user_data, ud)
      call c_f_pointer(msg, text, [len(ud%msg)])
      ud%msg_len = 0
      do i = 1, len(ud%msg)
         if (text(i) == c_null_char) exit
         ud%msg(i:i) = text(i)
         ud%msg_len = i
      end do
   end subroutine cv_error_handler

   ! ------------------------------------------------------------ set-up helpers

   !> Maximum step CVODE may take: run%max_step if > 0, else a tenth of the
   !> period of the highest linearised mode with every clearance closed
   !> (0: no bound, when the train has no elastic mode).
   subroutine cvode_max_step(model, hmax, omega_max)
      type(model_t), intent(in) :: model
      real(wp), intent(out) :: hmax, omega_max
      type(model_t) :: tmp
      type(modes_t) :: modes
      type(error_t), allocatable :: err
      omega_max = 0.0_wp
      tmp = model
      call compute_modes(tmp, modes, err, closed=.true.)
      if (.not. allocated(err)) omega_max = modes%omega_max
      if (model%run%max_step > 0.0_wp) then
         hmax = model%run%max_step
      else if (omega_max > 0.0_wp) then
         hmax = max_step_fraction*two_pi/omega_max
      else
         hmax = 0.0_wp
      end if
   end subroutine cvode_max_step

   !> Absolute tolerance of each state: node angles atol_angle, speeds
   !> atol_speed, a motor's current (third state) atol_current; the two
   !> energy-accounting states max(rtol, 1e-6)*(1 + |E0|) (loose: they are
   !> diagnostics, and must not set the step at tight rtol). E0 is the stored
   !> energy at t_start (set by model%init_modes).
   subroutine cvode_abstol(model, atol)
      type(model_t), intent(in) :: model
      real(wp), intent(out) :: atol(:)
      integer :: i, o, ns
      atol = model%run%atol_speed
      do i = 1, size(model%nodes)
         if (model%speed_of(i) /= 0) cycle
         ns = model%nodes(i)%n%nstates()
         o = model%nodes(i)%n%offset
         if (ns >= 1) atol(o + 1) = model%run%atol_angle
         if (ns >= 2) atol(o + 2) = model%run%atol_speed
         if (ns >= 3) atol(o + 3:o + ns) = model%run%atol_current
      end do
      if (model%run%track_energy) atol(model%n_states + 1:model%n_states + 2) = &
         max(model%run%rtol, energy_atol_factor)*(1.0_wp + abs(model%energy0))
   end subroutine cvode_abstol

   !> "state 2 of node 'gear1' (gear1.speed)" for state index s.
   function state_label(model, s) result(label)
      type(model_t), intent(in) :: model
      integer, intent(in) :: s
      character(len=:), allocatable :: label
      type(string_t), allocatable :: names(:)
      integer :: i, o, ns
      label = 'state '//str(s)
      if (model%run%track_energy) then
         if (s == model%n_states + 1) label = 'state '//str(s)//' (energy.dissipated, the dissipated-energy integral)'
         if (s == model%n_states + 2) label = 'state '//str(s)//' (energy.input, the work-input integral)'
      end if
      do i = 1, size(model%nodes)
         if (model%speed_of(i) /= 0) cycle
         ns = model%nodes(i)%n%nstates()
         o = model%nodes(i)%n%offset
         if (s > o .and. s <= o + ns) then
            allocate (names(ns))
            call model%nodes(i)%n%state_names(names)
            label = 'state '//str(s - o)//" of node '"//model%nodes(i)%n%id//"'"
            if (allocated(names(s - o)%s)) label = label//' ('//names(s - o)%s//')'
            return
         end if
      end do
   end function state_label

   ! ------------------------------------------------------------ the integrator

   !> Integrate from (t, y) to t_end with CVODE, reporting to the observer.
   subroutine integrate_cvode(model, obs, sink, t, y, stats, err)
      type(model_t), intent(inout), target :: model
      type(observer_t), intent(inout) :: obs
      class(sink_t), intent(inout) :: sink
      real(wp), intent(inout) :: t, y(:)
      type(run_stats_t), intent(inout) :: stats
      type(error_t), allocatable, intent(out) :: err

      type(cv_user_t), target :: ud
      type(c_ptr) :: ctx, mem
      type(N_Vector), pointer :: nv_y, nv_atol
      type(SUNMatrix), pointer :: amat
      type(SUNLinearSolver), pointer :: ls
      type(SUNNonlinearSolver), pointer :: nls
      real(c_double), allocatable, target :: yv(:), atol(:)
      integer(c_int), allocatable, target :: rootdir(:), rootsfound(:)
      real(wp), allocatable :: g(:), bp(:)
      logical, allocatable :: fired(:)
      type(event_t) :: ev(64)
      real(c_double) :: tret(1)
      real(wp) :: t0, t_end, dout, tout, hmax, omega_max, tstop, tol_out
      integer(i8) :: k, mxstep
      integer(c_int) :: ierr, flag, method
      integer :: n, ng, ibp
      logical :: adams

      ctx = c_null_ptr; mem = c_null_ptr
      nullify (nv_y, nv_atol, amat, ls, nls)
      n = model%n_y; ng = model%n_guards
      adams = model%run%integrator == 'cvode-adams'
      t0 = model%run%t_start
      t_end = model%run%t_end
      if (n == 0) then
         call fatal_error(err, "integrator '"//model%run%integrator//"' needs at least one integrated state; "// &
                          "every node of this train is fixed or has a prescribed speed: use integrator = 'rk4'", err_input)
         return
      end if

      ! ---- settings derived from the model
      call cvode_max_step(model, hmax, omega_max)
      if (model%run%output_interval > 0.0_wp) then
         dout = model%run%output_interval
      else
         dout = model%run%dt
      end if
      if (hmax > 0.0_wp .and. (t_end - t0)/hmax > 1.0e12_wp) then
         call fatal_error(err, 'max_step = '//str(hmax)//' s would need more than 1e12 steps over the run of '// &
                          str(t_end - t0)//' s: raise max_step (0 chooses it from the highest frequency)', err_input)
         return
      end if
      mxstep = mxstep_min
      if (hmax > 0.0_wp) mxstep = max(mxstep, min(10_i8*ceiling(dout/hmax, i8), 1000000000_i8))
      tol_out = 1.0e-9_wp*model%run%dt    ! the observer's output-time tolerance
      call model%breakpoints(t, t_end, bp)
      ibp = 1

      allocate (yv(n), atol(n), rootdir(max(ng, 1)), rootsfound(max(ng, 1)), g(ng), fired(ng))
      yv = y
      call cvode_abstol(model, atol)
      rootdir = -1_c_int
      ud%model => model
      ud%ng = ng

      ! ---- SUNDIALS objects
      ierr = FSUNContext_Create(c_null_ptr, ctx)
      if (ierr /= 0) then
         call fatal_error(err, 'could not create the SUNDIALS context (out of memory?)', err_internal)
         return
      end if
      nv_y => FN_VMake_Serial(int(n, c_long), yv, ctx)
      nv_atol => FN_VMake_Serial(int(n, c_long), atol, ctx)
      if (.not. (associated(nv_y) .and. associated(nv_atol))) then
         call setup_failed('N_VMake_Serial'); return
      end if
      method = CV_BDF
      if (adams) method = CV_ADAMS
      mem = FCVodeCreate(method, ctx)
      if (.not. c_associated(mem)) then
         call setup_failed('CVodeCreate'); return
      end if
      ierr = FCVodeSetErrHandlerFn(mem, c_funloc(cv_error_handler), c_loc(ud))
      if (ierr /= CV_SUCCESS) then
         call setup_failed('CVodeSetErrHandlerFn'); return
      end if
      ierr = FCVodeInit(mem, c_funloc(cv_rhs), t, nv_y)
      if (ierr /= CV_SUCCESS) then
         call setup_failed('CVodeInit'); return
      end if
      ierr = FCVodeSetUserData(mem, c_loc(ud))
      if (ierr == CV_SUCCESS) ierr = FCVodeSVtolerances(mem, model%run%rtol, nv_atol)
      if (ierr /= CV_SUCCESS) then
         call setup_failed('CVodeSVtolerances'); return
      end if
      if (adams) then
         nls => FSUNNonlinSol_FixedPoint(nv_y, 0_c_int, ctx)
         if (.not. associated(nls)) then
            call setup_failed('SUNNonlinSol_FixedPoint'); return
         end if
         ierr = FCVodeSetNonlinearSolver(mem, nls)
         if (ierr /= CV_SUCCESS) then
            call setup_failed('CVodeSetNonlinearSolver'); return
         end if
      else
         amat => FSUNDenseMatrix(int(n, c_long), int(n, c_long), ctx)
         if (.not. associated(amat)) then
            call setup_failed('SUNDenseMatrix'); return
         end if
         ls => FSUNLinSol_Dense(nv_y, amat, ctx)
         if (.not. associated(ls)) then
            call setup_failed('SUNLinSol_Dense'); return
         end if
         ierr = FCVodeSetLinearSolver(mem, ls, amat)
         if (ierr /= CV_SUCCESS) then
            call setup_failed('CVodeSetLinearSolver'); return
         end if
         if (model%run%analytic_jacobian) then
            ierr = FCVodeSetJacFn(mem, c_funloc(cv_jac))
            if (ierr /= CV_SUCCESS) then
               call setup_failed('CVodeSetJacFn'); return
            end if
         end if
      end if
      if (hmax > 0.0_wp) then
         ierr = FCVodeSetMaxStep(mem, hmax)
         if (ierr /= CV_SUCCESS) then
            call setup_failed('CVodeSetMaxStep'); return
         end if
      end if
      ierr = FCVodeSetMaxNumSteps(mem, int(mxstep, c_long))
      if (ierr == CV_SUCCESS) ierr = FCVodeSetMaxHnilWarns(mem, -1_c_int)
      if (ierr /= CV_SUCCESS) then
         call setup_failed('CVodeSetMaxNumSteps'); return
      end if
      if (ng > 0) then
         ierr = FCVodeRootInit(mem, int(ng, c_int), c_funloc(cv_roots))
         if (ierr == CV_SUCCESS) ierr = FCVodeSetRootDirection(mem, rootdir)
         if (ierr == CV_SUCCESS) ierr = FCVodeSetNoInactiveRootWarn(mem)
         if (ierr /= CV_SUCCESS) then
            call setup_failed('CVodeRootInit'); return
         end if
      end if
      call set_stop_time()
      if (allocated(err)) then
         call cleanup(); return
      end if

      ! ---- a guard already negative at t_start: handle it before the first step
      if (ng > 0) then
         call model%guards(t, yv, g)
         if (any(g < 0.0_wp)) then
            rootsfound = 0
            call handle_events(.false.)
            if (allocated(err)) then
               call cleanup(); return
            end if
         end if
      end if

      ! ---- main loop: to each output time, stopping at roots and breakpoints
      k = 1
      do while (t < t_end)
         tout = t0 + real(k, wp)*dout
         if (tout >= t_end - 1.0e-6_wp*dout) tout = t_end
         if (tout - t <= tol_out) then
            ! already there: an event fell on this output time (the observer has it)
            if (tout < t_end) then
               k = k + 1
               cycle
            end if
            ! ... or within rounding of t_end, too close for CVODE to start a step
            t = t_end
            call obs%step(model, t, yv, sink, err)
            if (allocated(err)) then
               call cleanup(); return
            end if
            exit
         end if
         flag = FCVode(mem, tout, nv_y, tret, CV_NORMAL)
         if (flag < 0) then
            call failed(flag)
            call cleanup(); return
         end if
         t = tret(1)
         call check_finite()
         if (allocated(err)) then
            call cleanup(); return
         end if
         call obs%step(model, t, yv, sink, err)
         if (allocated(err)) then
            call cleanup(); return
         end if
         if (flag == CV_ROOT_RETURN) then
            stats%root_returns = stats%root_returns + 1
            rootsfound = 0
            ierr = FCVodeGetRootInfo(mem, rootsfound)
            call handle_events(.true.)
         else if (flag == CV_TSTOP_RETURN .and. t < t_end) then
            ! a breakpoint of a time function: restart the multistep history there
            rootsfound = 0
            call handle_events(.false.)
         else if (ng > 0) then
            ! safety net: a guard below zero that CVODE did not report
            call model%guards(t, yv, g)
            if (any(g < 0.0_wp)) then
               rootsfound = 0
               call handle_events(.false.)
            end if
         end if
         if (allocated(err)) then
            call cleanup(); return
         end if
         if (t >= tout - tol_out) k = k + 1
      end do
      t = t_end
      y = yv
      call accumulate()
      call cleanup()

   contains

      !> Stop time: the next breakpoint of a time function, else t_end.
      subroutine set_stop_time()
         integer(c_int) :: ie
         do while (ibp <= size(bp))
            if (bp(ibp) > t) exit
            ibp = ibp + 1
         end do
         tstop = t_end
         if (ibp <= size(bp)) tstop = bp(ibp)
         ie = FCVodeSetStopTime(mem, tstop)
         if (ie /= CV_SUCCESS) call fatal_error(err, 'internal: CVodeSetStopTime('//str(tstop)//') failed at t = '// &
                                                str(t)//' s', err_internal)
      end subroutine set_stop_time

      !> Update the modes at (t, yv) for the guards that fired (CVODE's roots
      !> and any guard below zero), report the events, then re-initialise CVODE.
      subroutine handle_events(roots)
         logical, intent(in) :: roots
         integer :: pass, nev
         integer(c_int) :: ie
         if (ng > 0) then
            call model%guards(t, yv, g)
            fired = g < 0.0_wp
            if (roots) fired = fired .or. rootsfound(1:ng) /= 0
            do pass = 1, max_event_passes
               if (.not. any(fired)) exit
               nev = 0
               call model%apply_events(t, yv, fired, ev, nev)
               call obs%record_events(model, t, yv, ev, nev, sink, err)
               if (allocated(err)) return
               call model%guards(t, yv, g)
               fired = g < 0.0_wp
            end do
         end if
         call accumulate()
         ie = FCVodeReInit(mem, t, nv_y)
         if (ie /= CV_SUCCESS) then
            call fatal_error(err, 'internal: CVodeReInit failed at t = '//str(t)//' s: '//ud%msg(1:ud%msg_len), &
                             err_internal)
            return
         end if
         call set_stop_time()
      end subroutine handle_events

      !> Add CVODE's counters (zeroed by every re-initialisation) to stats.
      subroutine accumulate()
         integer(c_long) :: v(1)
         integer(c_int) :: ie
         integer(i8) :: netf, nsf
         if (.not. c_associated(mem)) return
         v = 0; ie = FCVodeGetNumSteps(mem, v); stats%steps = stats%steps + v(1)
         v = 0; ie = FCVodeGetNumRhsEvals(mem, v); stats%rhs_evals = stats%rhs_evals + v(1)
         if (.not. adams) then
            v = 0; ie = FCVodeGetNumLinRhsEvals(mem, v); stats%rhs_evals = stats%rhs_evals + v(1)
            v = 0; ie = FCVodeGetNumJacEvals(mem, v); stats%jac_evals = stats%jac_evals + v(1)
         end if
         v = 0; ie = FCVodeGetNumErrTestFails(mem, v); netf = v(1)
         stats%error_test_fails = stats%error_test_fails + netf
         v = 0; ie = FCVodeGetNumNonlinSolvConvFails(mem, v); stats%conv_fails = stats%conv_fails + v(1)
         v = 0; ie = FCVodeGetNumStepSolveFails(mem, v); nsf = v(1)
         stats%rejected = stats%rejected + netf + nsf
      end subroutine accumulate

      !> NaN or runaway state at an output or event point.
      subroutine check_finite()
         integer :: i
         do i = 1, n
            if (yv(i) /= yv(i) .or. abs(yv(i)) > 1.0e100_wp) then
               call fatal_error(err, "integrator '"//model%run%integrator//"': the solution blew up at t = "// &
                                str(t)//' s ('//state_label(model, i)//' is '// &
                                trim(merge('NaN    ', 'runaway', yv(i) /= yv(i)))//'); tighten rtol and the '// &
                                'absolute tolerances, or set a smaller max_step', err_numeric)
               return
            end if
         end do
      end subroutine check_finite

      !> A SUNDIALS object could not be made.
      subroutine setup_failed(what)
         character(len=*), intent(in) :: what
         character(len=:), allocatable :: detail
         detail = ''
         if (ud%msg_len > 0) detail = ': '//ud%msg(1:ud%msg_len)
         call fatal_error(err, "internal: setting up integrator '"//model%run%integrator//"' failed in "// &
                          what//detail, err_internal)
         call cleanup()
      end subroutine setup_failed

      !> FCVode returned flag < 0: an error naming the time, the state with the
      !> largest weighted local error, what CVODE said, and what to try.
      subroutine failed(flag)
         integer(c_int), intent(in) :: flag
         real(c_double), allocatable, target :: ele(:), ewt(:)
         type(N_Vector), pointer :: nv_ele, nv_ewt
         real(c_double) :: tcur(1), hlast(1)
         integer(c_int) :: ie
         integer :: worst
         real(wp) :: wmax
         character(len=:), allocatable :: what, advice, loc_text, detail, rk4_hint, h_text
         call accumulate()
         tcur = t; hlast = 0.0_wp
         ie = FCVodeGetCurrentTime(mem, tcur)
         ie = FCVodeGetLastStep(mem, hlast)
         stats%t_final = tcur(1)
         ! the state that limits the step: largest |local error| * weight
         allocate (ele(n), ewt(n))
         ele = 0.0_wp; ewt = 0.0_wp
         nv_ele => FN_VMake_Serial(int(n, c_long), ele, ctx)
         nv_ewt => FN_VMake_Serial(int(n, c_long), ewt, ctx)
         worst = 0
         if (associated(nv_ele) .and. associated(nv_ewt)) then
            ie = FCVodeGetEstLocalErrors(mem, nv_ele)
            ie = FCVodeGetErrWeights(mem, nv_ewt)
            wmax = maxval(abs(ele*ewt))
            if (flag == CV_TOO_MUCH_ACC) then
               ! what limits the accuracy is |y| against its tolerance, not a local error
               worst = maxloc(abs(yv)*ewt, 1)
               loc_text = 'the tightest tolerance relative to its value is on '//state_label(model, worst)
            else if (wmax > 0.0_wp .and. wmax == wmax) then
               worst = maxloc(abs(ele*ewt), 1)
               loc_text = 'the largest weighted local error estimate is in '//state_label(model, worst)// &
                       ' (|error|/tolerance = '//str(wmax)//')'
            else
               ! no error estimate yet: name the state whose tolerance is tightest for its size
               worst = maxloc(abs(yv)*ewt, 1)
               loc_text = 'no step was completed; the tightest tolerance relative to its value is on '// &
                       state_label(model, worst)
            end if
         else
            loc_text = 'the local error estimates are not available'
         end if
         if (associated(nv_ele)) call FN_VDestroy(nv_ele)
         if (associated(nv_ewt)) call FN_VDestroy(nv_ewt)
         if (ud%bad_state > 0 .and. (flag == CV_RHSFUNC_FAIL .or. flag == CV_FIRST_RHSFUNC_ERR .or. &
                                     flag == CV_REPTD_RHSFUNC_ERR .or. flag == CV_UNREC_RHSFUNC_ERR)) then
            loc_text = 'the right-hand side first gave NaN at t = '//str(ud%bad_t)//' s in the derivative of '// &
                    state_label(model, ud%bad_state)
         end if
         if (omega_max > 0.0_wp) then
            rk4_hint = "try integrator = 'rk4' with dt below "//str(rk4_stability_limit/omega_max)// &
                       ' s (the RK4 stability limit of the highest mode with the clearances closed)'
         else
            rk4_hint = "try integrator = 'rk4' with a small dt"
         end if
         h_text = ''
         if (hlast(1) > 0.0_wp) h_text = ' (last step size '//str(hlast(1))//' s)'
         select case (flag)
         case (CV_TOO_MUCH_WORK)
            what = 'more than '//str(real(mxstep, wp))//' internal steps were taken without reaching the next output time '// &
                   str(tout)//' s'
            advice = 'the step size collapsed (a stiff contact, chattering, or a discontinuity no guard '// &
                     'announces): '
            if (adams) advice = advice//"the train may be stiff for the Adams method: use integrator = 'cvode-bdf'; "
            advice = advice//'loosen rtol/atol'
            if (model%run%max_step > 0.0_wp) advice = advice//', raise max_step (now '//str(model%run%max_step)//' s)'
            advice = advice//", shorten output_interval, or "//rk4_hint
         case (CV_TOO_MUCH_ACC)
            what = 'the tolerances ask for more accuracy than double precision can give (rtol = '// &
                   str(model%run%rtol)//')'
            advice = 'loosen the tolerances: rtol >= 1e-13 and absolute tolerances that are not tiny against '// &
                     'the states'' values'
         case (CV_ERR_FAILURE)
            what = 'the local error test failed repeatedly or with the smallest step'
            advice = 'the model probably has a discontinuity inside a mode, or the tolerances are too tight: '// &
                     'loosen rtol/atol, lower max_step, or '//rk4_hint
         case (CV_CONV_FAILURE, CV_NLS_FAIL)
            if (adams) then
               what = 'the fixed-point (functional) iteration of the Adams method did not converge'
               advice = "the system is stiff for Adams: use integrator = 'cvode-bdf', or lower max_step"
            else
               what = 'the Newton iteration did not converge'
               advice = 'lower max_step, loosen rtol/atol, or '//rk4_hint
            end if
         case (CV_LINIT_FAIL, CV_LSETUP_FAIL, CV_LSOLVE_FAIL)
            what = 'the dense linear solver failed (singular iteration matrix)'
            advice = "lower max_step, or use integrator = 'cvode-adams' or 'rk4'"
         case (CV_RHSFUNC_FAIL, CV_FIRST_RHSFUNC_ERR, CV_REPTD_RHSFUNC_ERR, CV_UNREC_RHSFUNC_ERR)
            what = 'the right-hand side could not be evaluated (NaN derivatives)'
            advice = 'check the deck for non-physical parameters; tighten the tolerances or lower max_step'
         case (CV_RTFUNC_FAIL)
            what = 'the guard (root) functions failed'
            advice = 'check the clearance elements of the deck'
         case (CV_TOO_CLOSE)
            what = 'the next output time is too close to the current time'
            advice = 'use a larger output_interval (or dt when output_interval = 0)'
         case (CV_ILL_INPUT, CV_BAD_T, CV_MEM_NULL)
            what = 'CVODE rejected its input'
            advice = 'check rtol, the absolute tolerances and max_step of the &run group'
         case default
            what = 'CVODE returned flag '//str(int(flag))
            advice = 'loosen rtol/atol, lower max_step, or '//rk4_hint
         end select
         detail = ''
         if (ud%msg_len > 0) detail = ' [CVODE: '//ud%msg(1:ud%msg_len)//']'
         call fatal_error(err, "integrator '"//model%run%integrator//"' failed at t = "//str(tcur(1))// &
                          ' s'//h_text//': '//what//'; '//loc_text//'. Advice: '//advice//'.'//detail, err_numeric)
      end subroutine failed

      !> Free the SUNDIALS objects (in reverse order of creation).
      subroutine cleanup()
         integer(c_int) :: ie
         if (c_associated(mem)) call FCVodeFree(mem)
         mem = c_null_ptr
         if (associated(nls)) ie = FSUNNonlinSolFree(nls)
         if (associated(ls)) ie = FSUNLinSolFree(ls)
         if (associated(amat)) call FSUNMatDestroy(amat)
         if (associated(nv_atol)) call FN_VDestroy(nv_atol)
         if (associated(nv_y)) call FN_VDestroy(nv_y)
         nullify (nls, ls, amat, nv_atol, nv_y)
         if (c_associated(ctx)) ie = FSUNContext_Free(ctx)
         ctx = c_null_ptr
      end subroutine cleanup
   end subroutine integrate_cvode
end module trainsim_cvode
