!> The failure diagnosis of the SUNDIALS integrators (submodule of trainsim_sundials):
!> a negative return flag becomes an error naming the time, the state with the
!> largest weighted local error, what SUNDIALS said, and what to try.
submodule(trainsim_sundials) trainsim_sundials_failure
   implicit none

contains

   !> The integrator returned flag < 0 (status st): an error naming the time,
   !> the state with the largest weighted local error, what SUNDIALS said,
   !> and what to try.
   module subroutine sun_failed(self, model, flag, st, t, err)
      class(sundials_integrator_t), intent(inout), target :: self
      type(model_t), intent(in) :: model
      integer(c_int), intent(in) :: flag
      integer, intent(in) :: st
      real(wp), intent(in) :: t
      type(error_t), allocatable, intent(out) :: err
      real(c_double), allocatable, target :: ele(:), ewt(:)
      type(N_Vector), pointer :: nv_ele, nv_ewt
      real(c_double) :: tcur(1), hlast(1)
      integer :: worst
      real(wp) :: wmax
      character(len=:), allocatable :: what, advice, loc_text, detail, rk4_hint, h_text
      type(model_t) :: tmp
      type(error_t), allocatable :: lim_err
      real(wp) :: dt_safe, omega
      call self%flush_counters()
      tcur = t; hlast = 0.0_wp
      call self%sun_where(tcur, hlast)
      ! the state that limits the step: largest |local error| * weight
      allocate (ele(self%n), ewt(self%n))
      ele = 0.0_wp; ewt = 0.0_wp
      nv_ele => FN_VMake_Serial(int(self%n, c_long), ele, self%ctx)
      nv_ewt => FN_VMake_Serial(int(self%n, c_long), ewt, self%ctx)
      worst = 0
      if (associated(nv_ele) .and. associated(nv_ewt)) then
         call self%sun_local_errors(nv_ele, nv_ewt)
         wmax = maxval(abs(ele*ewt))
         if (st == st_too_much_acc) then
            ! what limits the accuracy is |y| against its tolerance, not a local error
            worst = maxloc(abs(self%yv)*ewt, 1)
            loc_text = 'the tightest tolerance relative to its value is on '//model%state_label(worst)
         else if (wmax > 0.0_wp .and. wmax == wmax) then
            worst = maxloc(abs(ele*ewt), 1)
            loc_text = 'the largest weighted local error estimate is in '//model%state_label(worst)// &
                       ' (|error|/tolerance = '//str(wmax)//')'
         else
            ! no error estimate yet: name the state whose tolerance is tightest for its size
            worst = maxloc(abs(self%yv)*ewt, 1)
            loc_text = 'no step was completed; the tightest tolerance relative to its value is on '// &
                       model%state_label(worst)
         end if
      else
         loc_text = 'the local error estimates are not available'
      end if
      if (associated(nv_ele)) call FN_VDestroy(nv_ele)
      if (associated(nv_ewt)) call FN_VDestroy(nv_ewt)
      if (self%ud%bad_state > 0 .and. st == st_rhs_failure) then
         loc_text = 'the right-hand side first gave NaN at t = '//str(self%ud%bad_t)//' s in the derivative of '// &
                    model%state_label(self%ud%bad_state)
      end if
      rk4_hint = "try integrator = 'rk4' with a small dt"
      tmp = model
      call rk4_dt_limit(tmp, lin_stiffest, dt_safe, omega, lim_err)
      if (.not. allocated(lim_err) .and. omega > 0.0_wp) then
         rk4_hint = "try integrator = 'rk4' with dt below "//str(dt_safe, 4)// &
                    ' s (the RK4 stability limit of the stiffest state the run can reach)'
      end if
      h_text = ''
      if (hlast(1) > 0.0_wp) h_text = ' (last step size '//str(hlast(1))//' s)'
      select case (st)
      case (st_too_much_work)
         what = 'more than '//str(real(self%mxstep, wp))//' internal steps were taken without reaching the next output time '// &
                str(self%t_goal)//' s'
         advice = 'the step size collapsed (a stiff contact, chattering, or a discontinuity no guard '// &
                  'announces): '
         advice = advice//self%advice_too_much_work()
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
         advice = advice//self%advice_error_failure()
      case (st_conv_failure)
         call self%describe_conv_failure(rk4_hint, what, advice)
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
         what = self%solver//' rejected its input'
         advice = 'check rtol, the absolute tolerances and max_step of the &run group'
      case default
         what = self%solver//' returned flag '//str(int(flag))
         advice = 'loosen rtol/atol, lower max_step, or '//rk4_hint
      end select
      detail = ''
      if (self%ud%msg_len > 0) detail = ' ['//self%solver//': '//self%ud%msg(1:self%ud%msg_len)//']'
      call fatal_error(err, "integrator '"//model%run%integrator//"' failed at t = "//str(tcur(1))// &
                       ' s'//h_text//': '//what//'; '//loc_text//'. Advice: '//advice//'.'//detail, err_numeric)
   end subroutine sun_failed
end submodule trainsim_sundials_failure
