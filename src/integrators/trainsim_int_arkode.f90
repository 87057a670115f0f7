!> ARKODE ERKStep backends of the SUNDIALS integrator (trainsim_sundials):
!> explicit adaptive Runge-Kutta pairs.
!> 'arkode-dp'    : Dormand-Prince 5(4) (ARKODE_DORMAND_PRINCE_7_4_5).
!> 'arkode-verner': Verner 6(5) (ARKODE_VERNER_8_5_6, made a true FSAL pair:
!>                  see set_erk_table).
!> Only the ERKStep calls are here; the cycle, callbacks and messages are shared.
module trainsim_int_arkode
   use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_null_ptr, c_loc, c_funloc, &
                                          c_f_pointer, c_associated
   use fsundials_nvector_mod, only: N_Vector
   use farkode_mod, only: ARK_ONE_STEP, ARK_SUCCESS, ARK_ROOT_RETURN, ARK_TSTOP_RETURN, &
                          ARK_TOO_MUCH_WORK, ARK_TOO_MUCH_ACC, ARK_ERR_FAILURE, ARK_RHSFUNC_FAIL, &
                          ARK_FIRST_RHSFUNC_ERR, ARK_REPTD_RHSFUNC_ERR, ARK_UNREC_RHSFUNC_ERR, ARK_RTFUNC_FAIL, &
                          ARK_TOO_CLOSE, ARK_MEM_NULL, ARK_ILL_INPUT, ARK_BAD_T, &
                          ARKODE_DORMAND_PRINCE_7_4_5, ARKODE_VERNER_8_5_6, &
                          FARKodeButcherTable_LoadERK, FARKodeButcherTable_Create, FARKodeButcherTable_Free
   use farkode_erkstep_mod, only: FERKStepCreate, FERKStepReInit, FERKStepFree, FERKStepEvolve, &
                                  FERKStepWFtolerances, FERKStepSetUserData, FERKStepSetTableNum, FERKStepSetTable, &
                                  FERKStepSetMaxStep, FERKStepSetMaxNumSteps, FERKStepSetMaxHnilWarns, &
                                  FERKStepSetStopTime, FERKStepSetErrHandlerFn, &
                                  FERKStepRootInit, FERKStepSetRootDirection, FERKStepSetNoInactiveRootWarn, &
                                  FERKStepGetRootInfo, FERKStepGetNumSteps, FERKStepGetNumRhsEvals, &
                                  FERKStepGetNumErrTestFails, FERKStepGetCurrentTime, FERKStepGetLastStep, &
                                  FERKStepGetEstLocalErrors, FERKStepGetErrWeights, FERKStepGetDky
   use trainsim_kinds, only: wp, i8
   use trainsim_integrator, only: integrator_t
   use trainsim_sundials, only: sundials_integrator_t, cv_rhs, cv_roots, cv_error_handler, cv_ewt, &
                                st_success, st_tstop, st_root, st_too_much_work, st_too_much_acc, st_err_failure, &
                                st_rhs_failure, st_root_failure, st_too_close, st_bad_input, st_other
   implicit none
   private

   public :: arkode_erk_t, new_arkode_dp, new_arkode_verner

   type, extends(sundials_integrator_t) :: arkode_erk_t
      integer(c_int) :: table = 0     !< ARKODE's id of the Butcher table
   contains
      procedure :: sun_create => ark_create
      procedure :: sun_init => ark_init
      procedure :: sun_set_err_handler => ark_set_err_handler
      procedure :: sun_set_user_data => ark_set_user_data
      procedure :: sun_tolerances => ark_tolerances
      procedure :: sun_setup_solver => ark_setup_solver
      procedure :: sun_set_max_step => ark_set_max_step
      procedure :: sun_set_max_num_steps => ark_set_max_num_steps
      procedure :: sun_root_init => ark_root_init
      procedure :: sun_set_stop_time => ark_set_stop_time
      procedure :: sun_evolve => ark_evolve
      procedure :: sun_root_info => ark_root_info
      procedure :: sun_reinit => ark_reinit
      procedure :: sun_get_y_at => ark_get_y_at
      procedure :: sun_counters => ark_counters
      procedure :: sun_local_errors => ark_local_errors
      procedure :: sun_where => ark_where
      procedure :: sun_free => ark_free
      procedure :: status => ark_status
      procedure :: advice_too_much_work => ark_advice_too_much_work
      procedure :: advice_error_failure => ark_advice_error_failure
      procedure :: explicit_limit => ark_explicit_limit
   end type arkode_erk_t

   !> The layout of SUNDIALS's `struct ARKodeButcherTableMem` (arkode_butcher.h),
   !> to read a table that ARKODE loaded: A is an array of `stages` row pointers.
   type, bind(C) :: butcher_table_c
      integer(c_int) :: q = 0, p = 0, stages = 0
      type(c_ptr) :: a = c_null_ptr, c = c_null_ptr, b = c_null_ptr, d = c_null_ptr
   end type butcher_table_c

contains

   !> Factory (registry row 'arkode-dp').
   subroutine new_arkode_dp(integ)
      class(integrator_t), allocatable, intent(out) :: integ
      allocate (integ, source=arkode_erk_t(solver='ARKODE', prefix='ERKStep', table=ARKODE_DORMAND_PRINCE_7_4_5))
   end subroutine new_arkode_dp

   !> Factory (registry row 'arkode-verner').
   subroutine new_arkode_verner(integ)
      class(integrator_t), allocatable, intent(out) :: integ
      allocate (integ, source=arkode_erk_t(solver='ARKODE', prefix='ERKStep', table=ARKODE_VERNER_8_5_6))
   end subroutine new_arkode_verner

   !> ERKStep takes the problem (f, t, y) at creation.
   subroutine ark_create(self, t)
      class(arkode_erk_t), intent(inout), target :: self
      real(wp), intent(in) :: t
      self%mem = FERKStepCreate(c_funloc(cv_rhs), t, self%nv_y, self%ctx)
   end subroutine ark_create

   !> The Butcher table (the problem was given at creation).
   integer(c_int) function ark_init(self) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      f = set_erk_table(self%mem, self%table)
   end function ark_init

   integer(c_int) function ark_set_err_handler(self) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      f = FERKStepSetErrHandlerFn(self%mem, c_funloc(cv_error_handler), c_loc(self%ud))
   end function ark_set_err_handler

   integer(c_int) function ark_set_user_data(self) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      f = FERKStepSetUserData(self%mem, c_loc(self%ud))
   end function ark_set_user_data

   integer(c_int) function ark_tolerances(self) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      f = FERKStepWFtolerances(self%mem, c_funloc(cv_ewt))
   end function ark_tolerances

   !> An explicit method has no (non)linear solver.
   integer(c_int) function ark_setup_solver(self) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      associate (unused => self)
      end associate
      f = ARK_SUCCESS
   end function ark_setup_solver

   integer(c_int) function ark_set_max_step(self, x) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      real(wp), intent(in) :: x
      f = FERKStepSetMaxStep(self%mem, x)
   end function ark_set_max_step

   integer(c_int) function ark_set_max_num_steps(self) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      f = FERKStepSetMaxNumSteps(self%mem, int(self%mxstep, c_long))
      if (f == ARK_SUCCESS) f = FERKStepSetMaxHnilWarns(self%mem, -1_c_int)
   end function ark_set_max_num_steps

   integer(c_int) function ark_root_init(self) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      f = FERKStepRootInit(self%mem, int(self%ng, c_int), c_funloc(cv_roots))
      if (f == ARK_SUCCESS) f = FERKStepSetRootDirection(self%mem, self%rootdir)
      if (f == ARK_SUCCESS) f = FERKStepSetNoInactiveRootWarn(self%mem)
   end function ark_root_init

   integer(c_int) function ark_set_stop_time(self, x) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      real(wp), intent(in) :: x
      f = FERKStepSetStopTime(self%mem, x)
   end function ark_set_stop_time

   integer(c_int) function ark_evolve(self, t_to, tr) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      real(wp), intent(in) :: t_to
      real(c_double), intent(out) :: tr
      real(c_double) :: tr1(1)
      f = FERKStepEvolve(self%mem, t_to, self%nv_y, tr1, ARK_ONE_STEP)
      tr = tr1(1)
   end function ark_evolve

   integer(c_int) function ark_root_info(self) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      f = FERKStepGetRootInfo(self%mem, self%rootsfound)
   end function ark_root_info

   integer(c_int) function ark_reinit(self, x) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      real(wp), intent(in) :: x
      f = FERKStepReInit(self%mem, c_funloc(cv_rhs), x, self%nv_y)
   end function ark_reinit

   !> The interpolated state at x (inside the last step) into self%ydky.
   integer(c_int) function ark_get_y_at(self, x) result(f)
      class(arkode_erk_t), intent(inout), target :: self
      real(wp), intent(in) :: x
      f = FERKStepGetDky(self%mem, x, 0_c_int, self%nv_dky)
   end function ark_get_y_at

   !> Counters since the last (re-)initialisation (no Jacobian, no nonlinear solver).
   subroutine ark_counters(self, nst, nfe, nje, netf, ncf, nsf)
      class(arkode_erk_t), intent(inout) :: self
      integer(i8), intent(out) :: nst, nfe, nje, netf, ncf, nsf
      integer(c_long) :: v(1)
      integer(c_int) :: ie
      nje = 0; ncf = 0; nsf = 0
      v = 0; ie = FERKStepGetNumSteps(self%mem, v); nst = v(1)
      v = 0; ie = FERKStepGetNumRhsEvals(self%mem, v); nfe = v(1)
      v = 0; ie = FERKStepGetNumErrTestFails(self%mem, v); netf = v(1)
   end subroutine ark_counters

   subroutine ark_local_errors(self, nv_ele, nv_ewt)
      class(arkode_erk_t), intent(inout) :: self
      type(N_Vector), intent(inout) :: nv_ele, nv_ewt
      integer(c_int) :: ie
      ie = FERKStepGetEstLocalErrors(self%mem, nv_ele)
      ie = FERKStepGetErrWeights(self%mem, nv_ewt)
   end subroutine ark_local_errors

   subroutine ark_where(self, tcur, hlast)
      class(arkode_erk_t), intent(inout) :: self
      real(c_double), intent(inout) :: tcur(1), hlast(1)
      integer(c_int) :: ie
      ie = FERKStepGetCurrentTime(self%mem, tcur)
      ie = FERKStepGetLastStep(self%mem, hlast)
   end subroutine ark_where

   subroutine ark_free(self)
      class(arkode_erk_t), intent(inout) :: self
      if (c_associated(self%mem)) call FERKStepFree(self%mem)
      self%mem = c_null_ptr
   end subroutine ark_free

   pure integer function ark_status(self, flag) result(st)
      class(arkode_erk_t), intent(in) :: self
      integer(c_int), intent(in) :: flag
      associate (unused => self)
      end associate
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
   end function ark_status

   !> Imaginary-axis stability limit |h lambda| of the pair: about 3.3 for
   !> Dormand-Prince 5(4) (Hairer-Wanner, Fig. IV.2.1) and 3.5 for Verner 6(5);
   !> 3 bounds both from below, which is all the step estimate needs.
   pure real(wp) function ark_explicit_limit(self) result(r)
      class(arkode_erk_t), intent(in) :: self
      associate (unused => self)
      end associate
      r = 3.0_wp
   end function ark_explicit_limit

   function ark_advice_too_much_work(self) result(text)
      class(arkode_erk_t), intent(in) :: self
      character(len=:), allocatable :: text
      associate (unused => self)
      end associate
      text = "the train may be stiff for an explicit Runge-Kutta method (its step is held "// &
             "at the stability limit of the fastest mode): use integrator = 'cvode-bdf'; "
   end function ark_advice_too_much_work

   function ark_advice_error_failure(self) result(text)
      class(arkode_erk_t), intent(in) :: self
      character(len=:), allocatable :: text
      associate (unused => self)
      end associate
      text = "; if the train is stiff, use integrator = 'cvode-bdf'"
   end function ark_advice_error_failure

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
end module trainsim_int_arkode
