!> CVODE backends of the SUNDIALS integrator (trainsim_sundials):
!> 'cvode-bdf'   : variable-order BDF, Newton iteration, dense direct linear
!>                 solver; analytic Jacobian (model%jacobian) by default.
!> 'cvode-adams' : variable-order Adams-Moulton, fixed-point iteration.
!> Only the CVODE calls are here; the cycle, callbacks and messages are shared.
module trainsim_int_cvode
   use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_loc, c_funloc, c_associated, c_null_ptr
   use fsundials_nvector_mod, only: N_Vector
   use fsundials_matrix_mod, only: SUNMatrix, FSUNMatDestroy
   use fsundials_linearsolver_mod, only: SUNLinearSolver, FSUNLinSolFree
   use fsundials_nonlinearsolver_mod, only: SUNNonlinearSolver, FSUNNonlinSolFree
   use fsunmatrix_dense_mod, only: FSUNDenseMatrix
   use fsunlinsol_dense_mod, only: FSUNLinSol_Dense
   use fsunnonlinsol_fixedpoint_mod, only: FSUNNonlinSol_FixedPoint
   use fcvode_mod, only: FCVodeCreate, FCVodeInit, FCVodeReInit, FCVodeFree, FCVode, &
                         FCVodeWFtolerances, FCVodeSetUserData, FCVodeSetLinearSolver, FCVodeSetNonlinearSolver, &
                         FCVodeSetMaxStep, FCVodeSetMaxNumSteps, FCVodeSetStopTime, FCVodeSetErrHandlerFn, &
                         FCVodeSetMaxHnilWarns, FCVodeSetNoInactiveRootWarn, FCVodeSetJacFn, &
                         FCVodeRootInit, FCVodeSetRootDirection, FCVodeGetRootInfo, &
                         FCVodeGetNumSteps, FCVodeGetNumRhsEvals, FCVodeGetNumLinRhsEvals, FCVodeGetNumJacEvals, &
                         FCVodeGetNumErrTestFails, FCVodeGetNumNonlinSolvConvFails, FCVodeGetNumStepSolveFails, &
                         FCVodeGetCurrentTime, FCVodeGetLastStep, FCVodeGetDky, FCVodeGetEstLocalErrors, FCVodeGetErrWeights, &
                         CV_BDF, CV_ADAMS, CV_ONE_STEP, CV_SUCCESS, CV_ROOT_RETURN, CV_TSTOP_RETURN, &
                         CV_TOO_MUCH_WORK, CV_TOO_MUCH_ACC, CV_ERR_FAILURE, CV_CONV_FAILURE, &
                         CV_LINIT_FAIL, CV_LSETUP_FAIL, CV_LSOLVE_FAIL, CV_RHSFUNC_FAIL, CV_FIRST_RHSFUNC_ERR, &
                         CV_REPTD_RHSFUNC_ERR, CV_UNREC_RHSFUNC_ERR, CV_RTFUNC_FAIL, CV_NLS_FAIL, CV_TOO_CLOSE, &
                         CV_MEM_NULL, CV_ILL_INPUT, CV_BAD_T
   use trainsim_kinds, only: wp, i8
   use trainsim_integrator, only: integrator_t
   use trainsim_sundials, only: sundials_integrator_t, cv_rhs, cv_jac, cv_roots, cv_error_handler, cv_ewt, &
                                st_success, st_tstop, st_root, st_too_much_work, st_too_much_acc, st_err_failure, &
                                st_conv_failure, st_lin_failure, st_rhs_failure, st_root_failure, st_too_close, &
                                st_bad_input, st_other
   implicit none
   private

   public :: cvode_t, new_cvode_bdf, new_cvode_adams

   type, extends(sundials_integrator_t) :: cvode_t
      logical :: adams = .false.
      type(SUNMatrix), pointer :: amat => null()
      type(SUNLinearSolver), pointer :: ls => null()
      type(SUNNonlinearSolver), pointer :: nls => null()
   contains
      procedure :: sun_create => cv_create
      procedure :: sun_init => cv_init
      procedure :: sun_set_err_handler => cv_set_err_handler
      procedure :: sun_set_user_data => cv_set_user_data
      procedure :: sun_tolerances => cv_tolerances
      procedure :: sun_setup_solver => cv_setup_solver
      procedure :: sun_set_max_step => cv_set_max_step
      procedure :: sun_set_max_num_steps => cv_set_max_num_steps
      procedure :: sun_root_init => cv_root_init
      procedure :: sun_set_stop_time => cv_set_stop_time
      procedure :: sun_evolve => cv_evolve
      procedure :: sun_root_info => cv_root_info
      procedure :: sun_reinit => cv_reinit
      procedure :: sun_get_y_at => cv_get_y_at
      procedure :: sun_counters => cv_counters
      procedure :: sun_local_errors => cv_local_errors
      procedure :: sun_where => cv_where
      procedure :: sun_free => cv_free
      procedure :: status => cv_status
      procedure :: advice_too_much_work => cv_advice_too_much_work
      procedure :: describe_conv_failure => cv_describe_conv_failure
   end type cvode_t

contains

   !> Factory (registry row 'cvode-bdf').
   subroutine new_cvode_bdf(integ)
      class(integrator_t), allocatable, intent(out) :: integ
      allocate (integ, source=cvode_t(solver='CVODE', prefix='CVode', adams=.false.))
   end subroutine new_cvode_bdf

   !> Factory (registry row 'cvode-adams').
   subroutine new_cvode_adams(integ)
      class(integrator_t), allocatable, intent(out) :: integ
      allocate (integ, source=cvode_t(solver='CVODE', prefix='CVode', adams=.true.))
   end subroutine new_cvode_adams

   subroutine cv_create(self, t)
      class(cvode_t), intent(inout), target :: self
      real(wp), intent(in) :: t
      integer(c_int) :: method
      method = CV_BDF
      if (self%adams) method = CV_ADAMS
      self%mem = FCVodeCreate(method, self%ctx)
      associate (unused => t)
      end associate
   end subroutine cv_create

   integer(c_int) function cv_init(self) result(f)
      class(cvode_t), intent(inout), target :: self
      f = FCVodeInit(self%mem, c_funloc(cv_rhs), self%t_init, self%nv_y)
   end function cv_init

   integer(c_int) function cv_set_err_handler(self) result(f)
      class(cvode_t), intent(inout), target :: self
      f = FCVodeSetErrHandlerFn(self%mem, c_funloc(cv_error_handler), c_loc(self%ud))
   end function cv_set_err_handler

   integer(c_int) function cv_set_user_data(self) result(f)
      class(cvode_t), intent(inout), target :: self
      f = FCVodeSetUserData(self%mem, c_loc(self%ud))
   end function cv_set_user_data

   integer(c_int) function cv_tolerances(self) result(f)
      class(cvode_t), intent(inout), target :: self
      f = FCVodeWFtolerances(self%mem, c_funloc(cv_ewt))
   end function cv_tolerances

   !> Fixed-point iteration (Adams), or Newton with the dense solver and the
   !> analytic Jacobian unless the deck asks for difference quotients (BDF).
   integer(c_int) function cv_setup_solver(self) result(f)
      class(cvode_t), intent(inout), target :: self
      f = -1
      if (self%adams) then
         self%nls => FSUNNonlinSol_FixedPoint(self%nv_y, 0_c_int, self%ctx)
         if (.not. associated(self%nls)) return
         f = FCVodeSetNonlinearSolver(self%mem, self%nls)
         return
      end if
      self%amat => FSUNDenseMatrix(int(self%n, c_long), int(self%n, c_long), self%ctx)
      if (.not. associated(self%amat)) return
      self%ls => FSUNLinSol_Dense(self%nv_y, self%amat, self%ctx)
      if (.not. associated(self%ls)) return
      f = FCVodeSetLinearSolver(self%mem, self%ls, self%amat)
      if (f /= CV_SUCCESS) return
      if (self%ud%model%run%analytic_jacobian) f = FCVodeSetJacFn(self%mem, c_funloc(cv_jac))
   end function cv_setup_solver

   integer(c_int) function cv_set_max_step(self, x) result(f)
      class(cvode_t), intent(inout), target :: self
      real(wp), intent(in) :: x
      f = FCVodeSetMaxStep(self%mem, x)
   end function cv_set_max_step

   !> Steps allowed per call; no "t + h = t" warnings.
   integer(c_int) function cv_set_max_num_steps(self) result(f)
      class(cvode_t), intent(inout), target :: self
      f = FCVodeSetMaxNumSteps(self%mem, int(self%mxstep, c_long))
      if (f == CV_SUCCESS) f = FCVodeSetMaxHnilWarns(self%mem, -1_c_int)
   end function cv_set_max_num_steps

   !> The guards as root functions, direction -1, no inactive-root warning.
   integer(c_int) function cv_root_init(self) result(f)
      class(cvode_t), intent(inout), target :: self
      f = FCVodeRootInit(self%mem, int(self%ng, c_int), c_funloc(cv_roots))
      if (f == CV_SUCCESS) f = FCVodeSetRootDirection(self%mem, self%rootdir)
      if (f == CV_SUCCESS) f = FCVodeSetNoInactiveRootWarn(self%mem)
   end function cv_root_init

   integer(c_int) function cv_set_stop_time(self, x) result(f)
      class(cvode_t), intent(inout), target :: self
      real(wp), intent(in) :: x
      f = FCVodeSetStopTime(self%mem, x)
   end function cv_set_stop_time

   integer(c_int) function cv_evolve(self, t_to, tr) result(f)
      class(cvode_t), intent(inout), target :: self
      real(wp), intent(in) :: t_to
      real(c_double), intent(out) :: tr
      real(c_double) :: tr1(1)
      f = FCVode(self%mem, t_to, self%nv_y, tr1, CV_ONE_STEP)
      tr = tr1(1)
   end function cv_evolve

   integer(c_int) function cv_root_info(self) result(f)
      class(cvode_t), intent(inout), target :: self
      f = FCVodeGetRootInfo(self%mem, self%rootsfound)
   end function cv_root_info

   integer(c_int) function cv_reinit(self, x) result(f)
      class(cvode_t), intent(inout), target :: self
      real(wp), intent(in) :: x
      f = FCVodeReInit(self%mem, x, self%nv_y)
   end function cv_reinit

   !> The interpolated state at x (inside the last step) into self%ydky.
   integer(c_int) function cv_get_y_at(self, x) result(f)
      class(cvode_t), intent(inout), target :: self
      real(wp), intent(in) :: x
      f = FCVodeGetDky(self%mem, x, 0_c_int, self%nv_dky)
   end function cv_get_y_at

   !> Counters since the last (re-)initialisation; BDF's RHS count includes the
   !> difference-quotient Jacobian's evaluations.
   subroutine cv_counters(self, nst, nfe, nje, netf, ncf, nsf)
      class(cvode_t), intent(inout) :: self
      integer(i8), intent(out) :: nst, nfe, nje, netf, ncf, nsf
      integer(c_long) :: v(1)
      integer(c_int) :: ie
      nje = 0
      v = 0; ie = FCVodeGetNumSteps(self%mem, v); nst = v(1)
      v = 0; ie = FCVodeGetNumRhsEvals(self%mem, v); nfe = v(1)
      if (.not. self%adams) then
         v = 0; ie = FCVodeGetNumLinRhsEvals(self%mem, v); nfe = nfe + v(1)
         v = 0; ie = FCVodeGetNumJacEvals(self%mem, v); nje = v(1)
      end if
      v = 0; ie = FCVodeGetNumErrTestFails(self%mem, v); netf = v(1)
      v = 0; ie = FCVodeGetNumNonlinSolvConvFails(self%mem, v); ncf = v(1)
      v = 0; ie = FCVodeGetNumStepSolveFails(self%mem, v); nsf = v(1)
   end subroutine cv_counters

   subroutine cv_local_errors(self, nv_ele, nv_ewt)
      class(cvode_t), intent(inout) :: self
      type(N_Vector), intent(inout) :: nv_ele, nv_ewt
      integer(c_int) :: ie
      ie = FCVodeGetEstLocalErrors(self%mem, nv_ele)
      ie = FCVodeGetErrWeights(self%mem, nv_ewt)
   end subroutine cv_local_errors

   subroutine cv_where(self, tcur, hlast)
      class(cvode_t), intent(inout) :: self
      real(c_double), intent(inout) :: tcur(1), hlast(1)
      integer(c_int) :: ie
      ie = FCVodeGetCurrentTime(self%mem, tcur)
      ie = FCVodeGetLastStep(self%mem, hlast)
   end subroutine cv_where

   subroutine cv_free(self)
      class(cvode_t), intent(inout) :: self
      integer(c_int) :: ie
      if (c_associated(self%mem)) call FCVodeFree(self%mem)
      self%mem = c_null_ptr
      if (associated(self%nls)) ie = FSUNNonlinSolFree(self%nls)
      if (associated(self%ls)) ie = FSUNLinSolFree(self%ls)
      if (associated(self%amat)) call FSUNMatDestroy(self%amat)
      nullify (self%nls, self%ls, self%amat)
   end subroutine cv_free

   pure integer function cv_status(self, flag) result(st)
      class(cvode_t), intent(in) :: self
      integer(c_int), intent(in) :: flag
      associate (unused => self)
      end associate
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
   end function cv_status

   function cv_advice_too_much_work(self) result(text)
      class(cvode_t), intent(in) :: self
      character(len=:), allocatable :: text
      text = ''
      if (self%adams) text = "the train may be stiff for the Adams method: use integrator = 'cvode-bdf'; "
   end function cv_advice_too_much_work

   subroutine cv_describe_conv_failure(self, rk4_hint, what, advice)
      class(cvode_t), intent(in) :: self
      character(len=*), intent(in) :: rk4_hint
      character(len=:), allocatable, intent(out) :: what, advice
      if (self%adams) then
         what = 'the fixed-point (functional) iteration of the Adams method did not converge'
         advice = "the system is stiff for Adams: use integrator = 'cvode-bdf', or lower max_step"
      else
         what = 'the Newton iteration did not converge'
         advice = 'lower max_step, loosen rtol/atol, or '//rk4_hint
      end if
   end subroutine cv_describe_conv_failure
end module trainsim_int_cvode
