!> SUNDIALS drivers with root-finding on the element guards: CVODE
!> (BDF/Newton or Adams/fixed-point) and ARKODE ERKStep (explicit adaptive
!> Runge-Kutta). All SUNDIALS calls live in this module, behind one driver
!> loop and one event handler; each SUNDIALS call site picks the package with
!> a small wrapper (`sun_evolve`, `sun_reinit`, `sun_counters`, ...).
!>
!> 'cvode-bdf'    : variable-order BDF, Newton iteration, dense direct linear
!>                  solver; analytic Jacobian (model%jacobian) by default.
!> 'cvode-adams'  : variable-order Adams-Moulton, fixed-point iteration.
!> 'arkode-dp'    : ERKStep with the Dormand-Prince 5(4) table
!>                  (ARKODE_DORMAND_PRINCE_7_4_5).
!> 'arkode-verner': ERKStep with the Verner 6(5) table (ARKODE_VERNER_8_5_6).
!>
!> Every guard of every element is a root function with direction -1 (a mode
!> stays valid while its guards are >= 0: only downward crossings are
!> events). At a root return the modes are updated by `model%apply_events`
!> (the code the RK4 path uses), the events go to the observer, and the
!> integrator is re-initialised at the event point: a mode change makes the
!> right-hand side non-smooth there, so no history (multistep history, or the
!> RK step-size history and interpolant) is carried across it. Breakpoints of
!> the time functions (tables, steps, ramps, duty cycles) are stop times
!> followed by a re-initialisation for the same reason.
!>
!> Output: the integrator advances in NORMAL mode to each output time (t_start
!> + k output_interval, or each dt if output_interval = 0) and interpolates;
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
   use farkode_mod, only: ARK_NORMAL, ARK_SUCCESS, ARK_ROOT_RETURN, ARK_TSTOP_RETURN, &
                          ARK_TOO_MUCH_WORK, ARK_TOO_MUCH_ACC, ARK_ERR_FAILURE, ARK_RHSFUNC_FAIL, &
                          ARK_FIRST_RHSFUNC_ERR, ARK_REPTD_RHSFUNC_ERR, ARK_UNREC_RHSFUNC_ERR, ARK_RTFUNC_FAIL, &
                          ARK_TOO_CLOSE, ARK_MEM_NULL, ARK_ILL_INPUT, ARK_BAD_T, &
                          ARKODE_DORMAND_PRINCE_7_4_5, ARKODE_VERNER_8_5_6, &
                          FARKodeButcherTable_LoadERK, FARKodeButcherTable_Create, FARKodeButcherTable_Free
   use farkode_erkstep_mod, only: FERKStepCreate, FERKStepReInit, FERKStepFree, FERKStepEvolve, &
                                  FERKStepSVtolerances, FERKStepSetUserData, FERKStepSetTableNum, FERKStepSetTable, &
                                  FERKStepSetMaxStep, FERKStepSetMaxNumSteps, FERKStepSetMaxHnilWarns, &
                                  FERKStepSetStopTime, FERKStepSetErrHandlerFn, &
                                  FERKStepRootInit, FERKStepSetRootDirection, FERKStepSetNoInactiveRootWarn, &
                                  FERKStepGetRootInfo, FERKStepGetNumSteps, FERKStepGetNumRhsEvals, &
                                  FERKStepGetNumErrTestFails, FERKStepGetCurrentTime, FERKStepGetLastStep, &
                                  FERKStepGetEstLocalErrors, FERKStepGetErrWeights
   use trainsim_kinds, only: wp, i8, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input, err_numeric, err_internal, err_interrupted
   use trainsim_interrupt, only: interrupt_signal
   use trainsim_strings, only: str, string_t
   use trainsim_model, only: model_t
   use trainsim_modes, only: modes_t, compute_modes, rk4_stability_limit
   use trainsim_sink, only: sink_t, run_stats_t, event_t
   use trainsim_observer, only: observer_t
   implicit none
   private

   public :: integrate_sundials, integrate_cvode, cvode_max_step, cvode_abstol

   !> The former name of `integrate_sundials` (same arguments).
   interface integrate_cvode
      module procedure integrate_sundials
   end interface integrate_cvode

   !> Fraction of the period of the highest linearised mode (clearances closed)
   !> used as the default maximum step.
   real(wp), parameter :: max_step_fraction = 0.1_wp
   !> Floor of the absolute tolerance of the energy-accounting states, per unit of 1 + E0.
   real(wp), parameter :: energy_atol_factor = 1.0e-6_wp
   !> Internal steps allowed per call (per output interval), at least.
   integer(i8), parameter :: mxstep_min = 1000000_i8
   !> Passes of the mode update at one event point (cascading guards).
   integer, parameter :: max_event_passes = 4

   !> Package-neutral outcome of a SUNDIALS call (`sun_status` maps CVODE's
   !> CV_* and ARKODE's ARK_* return flags onto these).
   integer, parameter :: st_success = 0, st_tstop = 1, st_root = 2
   integer, parameter :: st_too_much_work = -1, st_too_much_acc = -2, st_err_failure = -3, &
                         st_conv_failure = -4, st_lin_failure = -5, st_rhs_failure = -6, &
                         st_root_failure = -7, st_too_close = -8, st_bad_input = -9, st_other = -99

   !> What the callbacks see (user data): the caller's model and a few
   !> diagnostics written without allocation.
   type :: cv_user_t
      type(model_t), pointer :: model => null()
      integer :: ng = 0
      integer :: bad_state = 0            !< first state whose derivative was NaN
      real(wp) :: bad_t = 0.0_wp          !< time of that evaluation
      integer :: msg_len = 0
      character(len=512) :: msg = ''      !< last message SUNDIALS reported
   end type cv_user_t

   !> The layout of SUNDIALS's `struct ARKodeButcherTableMem` (arkode_butcher.h),
   !> to read a table that ARKODE loaded: A is an array of `stages` row pointers.
   type, bind(C) :: butcher_table_c
      integer(c_int) :: q = 0, p = 0, stages = 0
      type(c_ptr) :: a = c_null_ptr, c = c_null_ptr, b = c_null_ptr, d = c_null_ptr
   end type butcher_table_c

contains

   ! --------------------------------------------------------------- callbacks

   !> dy/dt for CVODE and ERKStep (same signature): model%rhs on the SUNDIALS
   !> vectors. 1 (recoverable) on NaN.
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

   !> The guards as root functions (CVODE and ERKStep alike).
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

   !> CVODE's and ARKODE's error and warning messages: kept (the last one) for
   !> our own message instead of being printed to stderr.
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

   !> Give ERKStep the explicit table `id`, so that f(t_n+1, y_n+1) is right.
   !>
   !> ERKStep (SUNDIALS 6.4) reuses the last stage's derivative as the first
   !> one of the next step whenever the last node is c_s = 1, without checking
   !> that the last row of A is b (llnl/sundials issue 311). That holds for
   !> Dormand-Prince (a true FSAL pair), not for Verner 6(5): its last stage
   !> (c = 1) is not the solution, and the wrong derivative drops the method to
   !> third order (measured: global error x8 per halving of a fixed step). Such
   !> a table gets one more stage, c = 1 with the row b (zero weights), that is
   !> the solution itself: a true FSAL pair with the same solution and error
   !> estimate, and still s new derivatives per step (stage 1 is the FSAL one).
   !> Returns ARK_SUCCESS or the failing flag.
   integer(c_int) function set_erk_table(mem, id) result(ierr)
      type(c_ptr), intent(in) :: mem
      integer(c_int), intent(in) :: id
      type(c_ptr) :: loaded, ext
      type(butcher_table_c), pointer :: bt
      type(c_ptr), pointer :: rows(:)
      real(c_double), pointer :: row(:), cv(:), bv(:), dv(:)
      real(c_double), allocatable, target :: c1(:), a1(:), b1(:), d1(:)
      integer :: s, s1, i
      logical :: fsal
      loaded = FARKodeButcherTable_LoadERK(id)
      if (.not. c_associated(loaded)) then
         ierr = ARK_ILL_INPUT
         return
      end if
      call c_f_pointer(loaded, bt)
      s = bt%stages
      call c_f_pointer(bt%a, rows, [s])
      call c_f_pointer(bt%c, cv, [s])
      call c_f_pointer(bt%b, bv, [s])
      call c_f_pointer(bt%d, dv, [s])
      call c_f_pointer(rows(s), row, [s])
      fsal = abs(cv(s) - 1.0_wp) > 1.0e-10_wp .or. all(abs(row - bv) <= 1.0e-15_wp)
      if (fsal) then
         ! ERKStep's reuse is right (or does not happen): the table as it is
         call FARKodeButcherTable_Free(loaded)
         ierr = FERKStepSetTableNum(mem, id)
         return
      end if
      s1 = s + 1
      allocate (c1(s1), a1(s1*s1), b1(s1), d1(s1))
      a1 = 0.0_c_double
      do i = 1, s
         call c_f_pointer(rows(i), row, [s])
         a1((i - 1)*s1 + 1:(i - 1)*s1 + s) = row          ! row-major, as ARKodeButcherTable_Create reads it
      end do
      a1(s*s1 + 1:s*s1 + s) = bv                          ! the new last stage: y_n+1 itself
      c1 = [cv, 1.0_c_double]
      b1 = [bv, 0.0_c_double]
      d1 = [dv, 0.0_c_double]
      ext = FARKodeButcherTable_Create(int(s1, c_int), bt%q, bt%p, c1, a1, b1, d1)
      call FARKodeButcherTable_Free(loaded)
      if (.not. c_associated(ext)) then
         ierr = ARK_ILL_INPUT
         return
      end if
      ierr = FERKStepSetTable(mem, ext)                   ! ERKStep keeps a copy
      call FARKodeButcherTable_Free(ext)
   end function set_erk_table

   !> The package-neutral outcome (st_*) of a CVODE (erk false) or ARKODE
   !> (erk true) return flag.
   pure integer function sun_status(erk, flag) result(st)
      logical, intent(in) :: erk
      integer(c_int), intent(in) :: flag
      if (erk) then
         select case (flag)
         case (ARK_SUCCESS); st = st_success
         case (ARK_TSTOP_RETURN); st = st_tstop
         case (ARK_ROOT_RETURN); st = st_root
         case (ARK_TOO_MUCH_WORK); st = st_too_much_work
         case (ARK_TOO_MUCH_ACC); st = st_too_much_acc
         case (ARK_ERR_FAILURE); st = st_err_failure
         case (ARK_RHSFUNC_FAIL, ARK_FIRST_RHSFUNC_ERR, ARK_REPTD_RHSFUNC_ERR, ARK_UNREC_RHSFUNC_ERR)
            st = st_rhs_failure
         case (ARK_RTFUNC_FAIL); st = st_root_failure
         case (ARK_TOO_CLOSE); st = st_too_close
         case (ARK_ILL_INPUT, ARK_BAD_T, ARK_MEM_NULL); st = st_bad_input
         case default; st = st_other
         end select
      else
         select case (flag)
         case (CV_SUCCESS); st = st_success
         case (CV_TSTOP_RETURN); st = st_tstop
         case (CV_ROOT_RETURN); st = st_root
         case (CV_TOO_MUCH_WORK); st = st_too_much_work
         case (CV_TOO_MUCH_ACC); st = st_too_much_acc
         case (CV_ERR_FAILURE); st = st_err_failure
         case (CV_CONV_FAILURE, CV_NLS_FAIL); st = st_conv_failure
         case (CV_LINIT_FAIL, CV_LSETUP_FAIL, CV_LSOLVE_FAIL); st = st_lin_failure
         case (CV_RHSFUNC_FAIL, CV_FIRST_RHSFUNC_ERR, CV_REPTD_RHSFUNC_ERR, CV_UNREC_RHSFUNC_ERR)
            st = st_rhs_failure
         case (CV_RTFUNC_FAIL); st = st_root_failure
         case (CV_TOO_CLOSE); st = st_too_close
         case (CV_ILL_INPUT, CV_BAD_T, CV_MEM_NULL); st = st_bad_input
         case default; st = st_other
         end select
      end if
   end function sun_status

   ! ------------------------------------------------------------ the integrator

   !> Integrate from (t, y) to t_end with the SUNDIALS integrator named by
   !> model%run%integrator ('cvode-bdf', 'cvode-adams', 'arkode-dp',
   !> 'arkode-verner'), reporting to the observer.
   subroutine integrate_sundials(model, obs, sink, t, y, stats, err)
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
      real(c_double) :: tret
      real(wp) :: t0, t_end, dout, tout, hmax, omega_max, tstop, tol_out
      integer(i8) :: k, mxstep
      integer(c_int) :: flag, table
      integer :: n, ng, ibp, st
      logical :: adams, erk
      !> the package ('CVODE', 'ARKODE') and the prefix of its functions ('CVode', 'ERKStep'), for messages
      character(len=:), allocatable :: solver, prefix

      ctx = c_null_ptr; mem = c_null_ptr
      nullify (nv_y, nv_atol, amat, ls, nls)
      n = model%n_y; ng = model%n_guards
      adams = .false.; erk = .false.; table = 0
      select case (model%run%integrator)
      case ('cvode-bdf')
      case ('cvode-adams')
         adams = .true.
      case ('arkode-dp')
         erk = .true.; table = ARKODE_DORMAND_PRINCE_7_4_5
      case ('arkode-verner')
         erk = .true.; table = ARKODE_VERNER_8_5_6
      case default
         call fatal_error(err, "internal: integrator '"//model%run%integrator//"' is not a SUNDIALS integrator", &
                          err_internal)
         return
      end select
      solver = merge('ARKODE', 'CVODE ', erk); solver = trim(solver)
      prefix = merge('ERKStep', 'CVode  ', erk); prefix = trim(prefix)
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
      st = FSUNContext_Create(c_null_ptr, ctx)
      if (st /= 0) then
         call fatal_error(err, 'could not create the SUNDIALS context (out of memory?)', err_internal)
         return
      end if
      nv_y => FN_VMake_Serial(int(n, c_long), yv, ctx)
      nv_atol => FN_VMake_Serial(int(n, c_long), atol, ctx)
      if (.not. (associated(nv_y) .and. associated(nv_atol))) then
         call setup_failed('N_VMake_Serial', .false.); return
      end if
      call sun_create()
      if (.not. c_associated(mem)) then
         call setup_failed('Create'); return
      end if
      if (sun_set_err_handler() /= st_success) then
         call setup_failed('SetErrHandlerFn'); return
      end if
      if (sun_init() /= st_success) then
         if (erk) then
            call setup_failed('SetTable')
         else
            call setup_failed('Init')
         end if
         return
      end if
      if (sun_set_user_data() /= st_success) then
         call setup_failed('SetUserData'); return
      end if
      if (sun_tolerances() /= st_success) then
         call setup_failed('SVtolerances'); return
      end if
      if (.not. erk) then
         ! CVODE's iteration: fixed point (Adams) or Newton with the dense solver (BDF)
         if (adams) then
            nls => FSUNNonlinSol_FixedPoint(nv_y, 0_c_int, ctx)
            if (.not. associated(nls)) then
               call setup_failed('SUNNonlinSol_FixedPoint', .false.); return
            end if
            if (FCVodeSetNonlinearSolver(mem, nls) /= CV_SUCCESS) then
               call setup_failed('SetNonlinearSolver'); return
            end if
         else
            amat => FSUNDenseMatrix(int(n, c_long), int(n, c_long), ctx)
            if (.not. associated(amat)) then
               call setup_failed('SUNDenseMatrix', .false.); return
            end if
            ls => FSUNLinSol_Dense(nv_y, amat, ctx)
            if (.not. associated(ls)) then
               call setup_failed('SUNLinSol_Dense', .false.); return
            end if
            if (FCVodeSetLinearSolver(mem, ls, amat) /= CV_SUCCESS) then
               call setup_failed('SetLinearSolver'); return
            end if
            if (model%run%analytic_jacobian) then
               if (FCVodeSetJacFn(mem, c_funloc(cv_jac)) /= CV_SUCCESS) then
                  call setup_failed('SetJacFn'); return
               end if
            end if
         end if
      end if
      if (hmax > 0.0_wp) then
         if (sun_set_max_step(hmax) /= st_success) then
            call setup_failed('SetMaxStep'); return
         end if
      end if
      if (sun_set_max_num_steps(mxstep) /= st_success) then
         call setup_failed('SetMaxNumSteps'); return
      end if
      if (ng > 0) then
         if (sun_root_init() /= st_success) then
            call setup_failed('RootInit'); return
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
            ! ... or within rounding of t_end, too close for SUNDIALS to start a step
            t = t_end
            call obs%step(model, t, yv, sink, err)
            if (allocated(err)) then
               call cleanup(); return
            end if
            exit
         end if
         flag = sun_evolve(tout, tret)
         st = sun_status(erk, flag)
         if (flag < 0) then
            call failed(flag, st)
            call cleanup(); return
         end if
         t = tret
         call check_finite()
         if (allocated(err)) then
            call cleanup(); return
         end if
         call obs%step(model, t, yv, sink, err)
         if (allocated(err)) then
            call cleanup(); return
         end if
         if (st == st_root) then
            stats%root_returns = stats%root_returns + 1
            rootsfound = 0
            call sun_root_info()
            call handle_events(.true.)
         else if (st == st_tstop .and. t < t_end) then
            ! a breakpoint of a time function: restart the integrator there
            rootsfound = 0
            call handle_events(.false.)
         else if (ng > 0) then
            ! safety net: a guard below zero that the root finder did not report
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
         ! interrupt check (SIGINT/SIGTERM; to move into the common driver)
         if (interrupt_signal() /= 0) call fatal_error(err, 'interrupted at t = '//str(t)//' s', err_interrupted)
         if (allocated(err)) call cleanup()
         if (allocated(err)) return
      end do
      t = t_end
      y = yv
      call accumulate()
      call cleanup()

   contains

      ! ---- the SUNDIALS call sites: one wrapper each, CVODE or ERKStep.
      !      The functions return a package-neutral status (st_*).

      !> Create the integrator memory (CVODE: method only; ERKStep: with f, t, y).
      subroutine sun_create()
         integer(c_int) :: method
         if (erk) then
            mem = FERKStepCreate(c_funloc(cv_rhs), t, nv_y, ctx)
         else
            method = CV_BDF
            if (adams) method = CV_ADAMS
            mem = FCVodeCreate(method, ctx)
         end if
      end subroutine sun_create

      !> Keep SUNDIALS's messages (see cv_error_handler) instead of printing them.
      integer function sun_set_err_handler() result(s)
         if (erk) then
            s = sun_status(erk, FERKStepSetErrHandlerFn(mem, c_funloc(cv_error_handler), c_loc(ud)))
         else
            s = sun_status(erk, FCVodeSetErrHandlerFn(mem, c_funloc(cv_error_handler), c_loc(ud)))
         end if
      end function sun_set_err_handler

      !> CVODE: the problem (f, t, y); ERKStep (problem given at creation): the Butcher table.
      integer function sun_init() result(s)
         if (erk) then
            s = sun_status(erk, set_erk_table(mem, table))
         else
            s = sun_status(erk, FCVodeInit(mem, c_funloc(cv_rhs), t, nv_y))
         end if
      end function sun_init

      integer function sun_set_user_data() result(s)
         if (erk) then
            s = sun_status(erk, FERKStepSetUserData(mem, c_loc(ud)))
         else
            s = sun_status(erk, FCVodeSetUserData(mem, c_loc(ud)))
         end if
      end function sun_set_user_data

      !> Scalar rtol, vector atol (cvode_abstol).
      integer function sun_tolerances() result(s)
         if (erk) then
            s = sun_status(erk, FERKStepSVtolerances(mem, model%run%rtol, nv_atol))
         else
            s = sun_status(erk, FCVodeSVtolerances(mem, model%run%rtol, nv_atol))
         end if
      end function sun_tolerances

      integer function sun_set_max_step(h) result(s)
         real(wp), intent(in) :: h
         if (erk) then
            s = sun_status(erk, FERKStepSetMaxStep(mem, h))
         else
            s = sun_status(erk, FCVodeSetMaxStep(mem, h))
         end if
      end function sun_set_max_step

      !> Steps allowed per call; no "t + h = t" warnings.
      integer function sun_set_max_num_steps(mx) result(s)
         integer(i8), intent(in) :: mx
         if (erk) then
            s = sun_status(erk, FERKStepSetMaxNumSteps(mem, int(mx, c_long)))
            if (s == st_success) s = sun_status(erk, FERKStepSetMaxHnilWarns(mem, -1_c_int))
         else
            s = sun_status(erk, FCVodeSetMaxNumSteps(mem, int(mx, c_long)))
            if (s == st_success) s = sun_status(erk, FCVodeSetMaxHnilWarns(mem, -1_c_int))
         end if
      end function sun_set_max_num_steps

      !> The ng guards as root functions, direction -1, no inactive-root warning.
      integer function sun_root_init() result(s)
         if (erk) then
            s = sun_status(erk, FERKStepRootInit(mem, int(ng, c_int), c_funloc(cv_roots)))
            if (s == st_success) s = sun_status(erk, FERKStepSetRootDirection(mem, rootdir))
            if (s == st_success) s = sun_status(erk, FERKStepSetNoInactiveRootWarn(mem))
         else
            s = sun_status(erk, FCVodeRootInit(mem, int(ng, c_int), c_funloc(cv_roots)))
            if (s == st_success) s = sun_status(erk, FCVodeSetRootDirection(mem, rootdir))
            if (s == st_success) s = sun_status(erk, FCVodeSetNoInactiveRootWarn(mem))
         end if
      end function sun_root_init

      integer function sun_set_stop_time(ts) result(s)
         real(wp), intent(in) :: ts
         if (erk) then
            s = sun_status(erk, FERKStepSetStopTime(mem, ts))
         else
            s = sun_status(erk, FCVodeSetStopTime(mem, ts))
         end if
      end function sun_set_stop_time

      !> Advance towards tout (NORMAL mode: interpolated at tout); the raw flag.
      integer(c_int) function sun_evolve(t_to, tr) result(f)
         real(wp), intent(in) :: t_to
         real(c_double), intent(out) :: tr
         real(c_double) :: tr1(1)
         tr1 = t
         if (erk) then
            f = FERKStepEvolve(mem, t_to, nv_y, tr1, ARK_NORMAL)
         else
            f = FCVode(mem, t_to, nv_y, tr1, CV_NORMAL)
         end if
         tr = tr1(1)
      end function sun_evolve

      !> Which guards crossed at a root return, into rootsfound.
      subroutine sun_root_info()
         integer(c_int) :: ie
         if (erk) then
            ie = FERKStepGetRootInfo(mem, rootsfound)
         else
            ie = FCVodeGetRootInfo(mem, rootsfound)
         end if
      end subroutine sun_root_info

      !> Restart at (t, yv): no history carried over (the counters are zeroed).
      integer function sun_reinit() result(s)
         if (erk) then
            s = sun_status(erk, FERKStepReInit(mem, c_funloc(cv_rhs), t, nv_y))
         else
            s = sun_status(erk, FCVodeReInit(mem, t, nv_y))
         end if
      end function sun_reinit

      !> Counters since the last (re-)initialisation: steps, RHS evaluations
      !> (with the difference-quotient Jacobian's for BDF), Jacobians,
      !> error-test failures, nonlinear convergence failures, failed nonlinear
      !> solves. ERKStep has no Jacobian and no nonlinear solver: those are 0.
      subroutine sun_counters(nst, nfe, nje, netf, ncf, nsf)
         integer(i8), intent(out) :: nst, nfe, nje, netf, ncf, nsf
         integer(c_long) :: v(1)
         integer(c_int) :: ie
         nst = 0; nfe = 0; nje = 0; netf = 0; ncf = 0; nsf = 0
         if (erk) then
            v = 0; ie = FERKStepGetNumSteps(mem, v); nst = v(1)
            v = 0; ie = FERKStepGetNumRhsEvals(mem, v); nfe = v(1)
            v = 0; ie = FERKStepGetNumErrTestFails(mem, v); netf = v(1)
         else
            v = 0; ie = FCVodeGetNumSteps(mem, v); nst = v(1)
            v = 0; ie = FCVodeGetNumRhsEvals(mem, v); nfe = v(1)
            if (.not. adams) then
               v = 0; ie = FCVodeGetNumLinRhsEvals(mem, v); nfe = nfe + v(1)
               v = 0; ie = FCVodeGetNumJacEvals(mem, v); nje = v(1)
            end if
            v = 0; ie = FCVodeGetNumErrTestFails(mem, v); netf = v(1)
            v = 0; ie = FCVodeGetNumNonlinSolvConvFails(mem, v); ncf = v(1)
            v = 0; ie = FCVodeGetNumStepSolveFails(mem, v); nsf = v(1)
         end if
      end subroutine sun_counters

      !> Estimated local errors and error weights of the last step attempt.
      subroutine sun_local_errors(nv_ele, nv_ewt)
         type(N_Vector), intent(inout) :: nv_ele, nv_ewt
         integer(c_int) :: ie
         if (erk) then
            ie = FERKStepGetEstLocalErrors(mem, nv_ele)
            ie = FERKStepGetErrWeights(mem, nv_ewt)
         else
            ie = FCVodeGetEstLocalErrors(mem, nv_ele)
            ie = FCVodeGetErrWeights(mem, nv_ewt)
         end if
      end subroutine sun_local_errors

      !> The integrator's current time and its last step size.
      subroutine sun_where(tcur, hlast)
         real(c_double), intent(inout) :: tcur(1), hlast(1)
         integer(c_int) :: ie
         if (erk) then
            ie = FERKStepGetCurrentTime(mem, tcur)
            ie = FERKStepGetLastStep(mem, hlast)
         else
            ie = FCVodeGetCurrentTime(mem, tcur)
            ie = FCVodeGetLastStep(mem, hlast)
         end if
      end subroutine sun_where

      subroutine sun_free()
         if (.not. c_associated(mem)) return
         if (erk) then
            call FERKStepFree(mem)
         else
            call FCVodeFree(mem)
         end if
         mem = c_null_ptr
      end subroutine sun_free

      ! ---- the driver's own steps (package-independent)

      !> Stop time: the next breakpoint of a time function, else t_end.
      subroutine set_stop_time()
         do while (ibp <= size(bp))
            if (bp(ibp) > t) exit
            ibp = ibp + 1
         end do
         tstop = t_end
         if (ibp <= size(bp)) tstop = bp(ibp)
         if (sun_set_stop_time(tstop) /= st_success) then
            call fatal_error(err, 'internal: '//prefix//'SetStopTime('//str(tstop)//') failed at t = '// &
                             str(t)//' s', err_internal)
         end if
      end subroutine set_stop_time

      !> Update the modes at (t, yv) for the guards that fired (the roots
      !> found and any guard below zero), report the events, then re-initialise.
      subroutine handle_events(roots)
         logical, intent(in) :: roots
         integer :: pass, nev
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
         if (sun_reinit() /= st_success) then
            call fatal_error(err, 'internal: '//prefix//'ReInit failed at t = '//str(t)//' s: '// &
                             ud%msg(1:ud%msg_len), err_internal)
            return
         end if
         call set_stop_time()
      end subroutine handle_events

      !> Add the integrator's counters (zeroed by every re-initialisation) to stats.
      subroutine accumulate()
         integer(i8) :: nst, nfe, nje, netf, ncf, nsf
         if (.not. c_associated(mem)) return
         call sun_counters(nst, nfe, nje, netf, ncf, nsf)
         stats%steps = stats%steps + nst
         stats%rhs_evals = stats%rhs_evals + nfe
         stats%jac_evals = stats%jac_evals + nje
         stats%error_test_fails = stats%error_test_fails + netf
         stats%conv_fails = stats%conv_fails + ncf
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

      !> A SUNDIALS object could not be made or set up; `what` is a function of
      !> the integrator (prefixed with CVode / ERKStep) unless own_name is false.
      subroutine setup_failed(what, own_name)
         character(len=*), intent(in) :: what
         logical, intent(in), optional :: own_name
         character(len=:), allocatable :: detail, fname
         fname = prefix//what
         if (present(own_name)) then
            if (.not. own_name) fname = what
         end if
         detail = ''
         if (ud%msg_len > 0) detail = ': '//ud%msg(1:ud%msg_len)
         call fatal_error(err, "internal: setting up integrator '"//model%run%integrator//"' failed in "// &
                          fname//detail, err_internal)
         call cleanup()
      end subroutine setup_failed

      !> The integrator returned flag < 0 (status st): an error naming the time,
      !> the state with the largest weighted local error, what SUNDIALS said,
      !> and what to try.
      subroutine failed(flag, st)
         integer(c_int), intent(in) :: flag
         integer, intent(in) :: st
         real(c_double), allocatable, target :: ele(:), ewt(:)
         type(N_Vector), pointer :: nv_ele, nv_ewt
         real(c_double) :: tcur(1), hlast(1)
         integer :: worst
         real(wp) :: wmax
         character(len=:), allocatable :: what, advice, loc_text, detail, rk4_hint, h_text
         call accumulate()
         tcur = t; hlast = 0.0_wp
         call sun_where(tcur, hlast)
         stats%t_final = tcur(1)
         ! the state that limits the step: largest |local error| * weight
         allocate (ele(n), ewt(n))
         ele = 0.0_wp; ewt = 0.0_wp
         nv_ele => FN_VMake_Serial(int(n, c_long), ele, ctx)
         nv_ewt => FN_VMake_Serial(int(n, c_long), ewt, ctx)
         worst = 0
         if (associated(nv_ele) .and. associated(nv_ewt)) then
            call sun_local_errors(nv_ele, nv_ewt)
            wmax = maxval(abs(ele*ewt))
            if (st == st_too_much_acc) then
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
         if (ud%bad_state > 0 .and. st == st_rhs_failure) then
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
         select case (st)
         case (st_too_much_work)
            what = 'more than '//str(real(mxstep, wp))//' internal steps were taken without reaching the next output time '// &
                   str(tout)//' s'
            advice = 'the step size collapsed (a stiff contact, chattering, or a discontinuity no guard '// &
                     'announces): '
            if (adams) advice = advice//"the train may be stiff for the Adams method: use integrator = 'cvode-bdf'; "
            if (erk) advice = advice//"the train may be stiff for an explicit Runge-Kutta method (its step is held "// &
                              "at the stability limit of the fastest mode): use integrator = 'cvode-bdf'; "
            advice = advice//'loosen rtol/atol'
            if (model%run%max_step > 0.0_wp) advice = advice//', raise max_step (now '//str(model%run%max_step)//' s)'
            advice = advice//", shorten output_interval, or "//rk4_hint
         case (st_too_much_acc)
            what = 'the tolerances ask for more accuracy than double precision can give (rtol = '// &
                   str(model%run%rtol)//')'
            advice = 'loosen the tolerances: rtol >= 1e-13 and absolute tolerances that are not tiny against '// &
                     'the states'' values'
         case (st_err_failure)
            what = 'the local error test failed repeatedly or with the smallest step'
            advice = 'the model probably has a discontinuity inside a mode, or the tolerances are too tight: '// &
                     'loosen rtol/atol, lower max_step, or '//rk4_hint
            if (erk) advice = advice//"; if the train is stiff, use integrator = 'cvode-bdf'"
         case (st_conv_failure)
            if (adams) then
               what = 'the fixed-point (functional) iteration of the Adams method did not converge'
               advice = "the system is stiff for Adams: use integrator = 'cvode-bdf', or lower max_step"
            else
               what = 'the Newton iteration did not converge'
               advice = 'lower max_step, loosen rtol/atol, or '//rk4_hint
            end if
         case (st_lin_failure)
            what = 'the dense linear solver failed (singular iteration matrix)'
            advice = "lower max_step, or use integrator = 'cvode-adams' or 'rk4'"
         case (st_rhs_failure)
            what = 'the right-hand side could not be evaluated (NaN derivatives)'
            advice = 'check the deck for non-physical parameters; tighten the tolerances or lower max_step'
         case (st_root_failure)
            what = 'the guard (root) functions failed'
            advice = 'check the clearance elements of the deck'
         case (st_too_close)
            what = 'the next output time is too close to the current time'
            advice = 'use a larger output_interval (or dt when output_interval = 0)'
         case (st_bad_input)
            what = solver//' rejected its input'
            advice = 'check rtol, the absolute tolerances and max_step of the &run group'
         case default
            what = solver//' returned flag '//str(int(flag))
            advice = 'loosen rtol/atol, lower max_step, or '//rk4_hint
         end select
         detail = ''
         if (ud%msg_len > 0) detail = ' ['//solver//': '//ud%msg(1:ud%msg_len)//']'
         call fatal_error(err, "integrator '"//model%run%integrator//"' failed at t = "//str(tcur(1))// &
                          ' s'//h_text//': '//what//'; '//loc_text//'. Advice: '//advice//'.'//detail, err_numeric)
      end subroutine failed

      !> Free the SUNDIALS objects (in reverse order of creation).
      subroutine cleanup()
         integer(c_int) :: ie
         call sun_free()
         if (associated(nls)) ie = FSUNNonlinSolFree(nls)
         if (associated(ls)) ie = FSUNLinSolFree(ls)
         if (associated(amat)) call FSUNMatDestroy(amat)
         if (associated(nv_atol)) call FN_VDestroy(nv_atol)
         if (associated(nv_y)) call FN_VDestroy(nv_y)
         nullify (nls, ls, amat, nv_atol, nv_y)
         if (c_associated(ctx)) ie = FSUNContext_Free(ctx)
         ctx = c_null_ptr
      end subroutine cleanup
   end subroutine integrate_sundials
end module trainsim_cvode
