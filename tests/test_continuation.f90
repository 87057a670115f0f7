!> Pseudo-arclength continuation of periodic orbits (issue 27 item 3;
!> docs/periodic.md "Continuation"): a harmonically forced one-degree-of-freedom
!> oscillator with a dead zone (J = 1, k = 100, k2 = 100, c = 0.4, torque
!> 300 + 8 sin(W t), half clearance b = 3.6: the mean angle 3 sits 0.6 below the
!> upper face; the lower face, 6.6 below, is never reached), whose contact orbit
!> hardens into an S-shaped frequency response. The continuation in W from
!> 9.6 rad/s turns at two folds (11.113, 10.608 rad/s). The reference: the
!> entry into and exit from contact at the face solve four matching conditions
!> of the exact linear segments; that curve is followed in (phase of entry,
!> entry speed, exit time, exit speed, W) and where W turns, W is maximised or
!> minimised by golden section as a function of the curve's locally monotone
!> component (to 1e-11 of it). Checked: both folds to 1e-8 rad/s (measured
!> 1.4e-11, 4.1e-11 at dt = 2e-4 s), a real multiplier > 1 at every point between them and
!> stable points outside (the branch stopped by a budget of 8 points and
!> resumed from its last), a corrector that cannot converge and a start with no orbit stop
!> the branch with their status and reason.
program test_continuation
   use trainsim_test_branch, only: sine_problem_t, sine_retuned_t, retunes_done
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_arclength, only: branch_options_t, branch_t, continue_branch, branch_done, &
                                 branch_step_min, branch_no_start, branch_budget, branch_fold
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check, check_close
   use trainsim_test_support, only: load_model_text, nl
   use trainsim_test_oscillator, only: oscillator_t
   implicit none

   real(wp), parameter :: pi = 3.14159265358979323846264338327950_wp
   interface
      subroutine dgesv(n, nrhs, a, lda, ipiv, b, ldb, info)
         import :: wp
         integer, intent(in) :: n, nrhs, lda, ldb
         real(wp), intent(inout) :: a(lda, *), b(ldb, *)
         integer, intent(out) :: ipiv(*), info
      end subroutine dgesv
   end interface
   ! J th'' + c th' + k th + k2 dz_b(th) = t0 + a sin(W t)
   real(wp), parameter :: jj = 1.0_wp, c1 = 0.4_wp, k1 = 100.0_wp, k2 = 100.0_wp, tq0 = 300.0_wp, amp = 8.0_wp, &
                          b = 3.6_wp, w_start = 9.6_wp, w_end = 11.5_wp
   type(oscillator_t), parameter :: osc = oscillator_t(jj, c1, amp)

   type(sine_problem_t) :: prob
   type(branch_t) :: full
   real(wp) :: w_fold(2)

   call suite_begin('pseudo-arclength continuation of periodic orbits: the dead-zone oscillator''s folds')
   call oscillator(prob%base)
   call reference_folds(w_fold)
   call test_folds_against_closed_form()
   call test_stability_along_the_branch()
   call test_retuned_model_gives_the_same_branch()
   call test_failures_stop_with_a_reason()
   call test_reasons_and_restarts()
   call test_slow_damped_mode_is_no_fold()
   call suite_end()

contains

   subroutine oscillator(model)
      type(model_t), intent(out) :: model
      call load_model_text('&run t_end = 1.0, dt = 2e-4, integrator = ''rk4'', output_interval = 2e-4 /'//nl// &
                           "&node id='g', type='fixed' /"//nl//"&node id='m', type='inertia', inertia="//str(jj)//' /'// &
                           nl//"&element type='shaft', left='m', right='g', stiffness="//str(k1)//', damping='// &
                           str(c1)//' /'//nl//"&element type='clearance_coupling', left='m', right='g', clearance="// &
                           str(2.0_wp*b)//', stiffness='//str(k2)//', contact_damping=0 /'//nl// &
                           "&load node='m', kind='sine', offset="//str(tq0)//', amplitude='//str(amp)// &
                           ', frequency=1.75 /', model)
   end subroutine oscillator

   function options() result(opt)
      type(branch_options_t) :: opt
      opt%lam_min = 9.0_wp
      opt%lam_max = w_end
      opt%ds = 0.005_wp
      opt%ds_max = 0.05_wp
   end function options

   !> The folds of the continuation from 11 rad/s against the closed form.
   subroutine test_folds_against_closed_form()
      integer :: i, nf
      real(wp) :: lf(2)
      call test_begin('folds_against_closed_form')
      call resumed_branch(full)
      call check('the continuation ran ('//msg(full)//')', full%status == branch_done)
      write (*, '(a,i0,a,i0,a,i0,a)') '    ', size(full%pts), ' points, ', full%maps, ' period maps, ', &
         full%rejected, ' steps rejected'
      nf = 0
      do i = 1, size(full%pts)
         if (full%pts(i)%kind == 'fold') then
            nf = nf + 1
            if (nf <= 2) lf(nf) = full%pts(i)%lam
         end if
      end do
      call check('two folds found (got '//str(nf)//')', nf == 2)
      if (nf /= 2) return
      write (*, '(a,2es24.15)') '    folds by continuation: ', lf
      write (*, '(a,2es24.15)') '    folds, closed form:    ', w_fold
      call check_close('the jump-down fold (largest W of the upper branch)', lf(1), w_fold(1), abs_tol=1.0e-8_wp)
      call check_close('the jump-up fold (smallest W of the middle branch)', lf(2), w_fold(2), abs_tol=1.0e-8_wp)
      call check('the continuation ended beyond ' // str(w_end), full%pts(size(full%pts))%lam > w_end)
   end subroutine test_folds_against_closed_form

   !> The branch with the model retuned to each lambda (D-131: the continuation keeps the
   !> first model and changes only the forcing frequency in it) against the closed
   !> form: both folds to 1e-8 rad/s as the branch built afresh at every lambda; the
   !> reuse taken at every lambda after the first (retunes counted), and the same
   !> points as that branch (`full`, resumed bit for bit, D-119): lambda to 1e-9 (the
   !> same models, so the same maps; 1e-9 leaves room for the corrector's 1e-10).
   subroutine test_retuned_model_gives_the_same_branch()
      type(sine_retuned_t) :: rprob
      type(branch_t) :: br
      type(error_t), allocatable :: err
      integer :: i, nf
      real(wp) :: lf(2)
      call test_begin('retuned_model_gives_the_same_branch')
      rprob%base = prob%base
      retunes_done = 0
      call continue_branch(rprob, w_start, options(), br, err)
      call check('the continuation ran ('//msg(br)//')', .not. allocated(err) .and. br%status == branch_done)
      call check('the model was retuned (not built) at the later lambdas: '//str(retunes_done), &
                 retunes_done > size(br%pts))
      nf = 0
      do i = 1, size(br%pts)
         if (br%pts(i)%kind /= 'fold') cycle
         nf = nf + 1
         if (nf <= 2) lf(nf) = br%pts(i)%lam
      end do
      call check('two folds found (got '//str(nf)//')', nf == 2)
      if (nf /= 2) return
      call check_close('the jump-down fold, retuned model', lf(1), w_fold(1), abs_tol=1.0e-8_wp)
      call check_close('the jump-up fold, retuned model', lf(2), w_fold(2), abs_tol=1.0e-8_wp)
      call check('the branch built at every lambda (folds_against_closed_form): as many points', &
                 size(full%pts) == size(br%pts))
      if (size(full%pts) == size(br%pts)) call check('... at the same lambda (1e-9)', &
                                                     all(abs(full%pts%lam - br%pts%lam) <= 1.0e-9_wp*w_start))
   end subroutine test_retuned_model_gives_the_same_branch

   !> Stable up to the first fold, a real multiplier > 1 between them, stable after.
   subroutine test_stability_along_the_branch()
      integer :: i, seg, n_mid
      logical :: ok_out, ok_mid
      call test_begin('stability_along_the_branch')
      seg = 1
      ok_out = .true.
      ok_mid = .true.
      n_mid = 0
      do i = 1, size(full%pts)
         associate (p => full%pts(i))
            if (p%kind == 'fold') then
               seg = seg + 1
               cycle
            end if
            if (seg == 2) then
               n_mid = n_mid + 1
               ok_mid = ok_mid .and. abs(aimag(p%mu(1))) == 0.0_wp .and. real(p%mu(1)) > 1.0_wp .and. &
                        p%stability == 'unstable'
            else
               ok_out = ok_out .and. p%stability == 'stable'
            end if
         end associate
      end do
      call check('points on the middle branch: '//str(n_mid), n_mid >= 3)
      call check('the middle branch has a real multiplier > 1 at every point', ok_mid)
      call check('the outer branches are stable at every point', ok_out)
   end subroutine test_stability_along_the_branch

   !> The branch from w_start to w_end, stopped by a budget of 8 points and resumed
   !> from its last point (the folds are then checked against the closed form).
   subroutine resumed_branch(rest)
      type(branch_t), intent(out) :: rest
      type(branch_options_t) :: opt
      type(branch_t) :: part
      type(error_t), allocatable :: err
      integer :: j
      opt = options()
      opt%max_points = 8
      call continue_branch(prob, w_start, opt, part, err)
      call check('stopped by its budget ('//msg(part)//')', .not. allocated(err) .and. part%status == branch_budget)
      call check('the reason names the budget', index(part%message, 'budget of 8 points') > 0)
      call continue_branch(prob, w_start, options(), rest, err, resume=part)
      call check('the resumed branch ran without an error', .not. allocated(err))
      call check('it keeps the first 8 points', size(rest%pts) > 8)
      if (size(rest%pts) > 8) call check('the first 8 as they were', all([(rest%pts(j)%lam == part%pts(j)%lam, j=1, 8)]))
   end subroutine resumed_branch

   !> A chord corrector (the smooth one: no full-Newton retry) allowed one step cannot
   !> reach 1e-10 from a predictor: the step halves to its minimum and the branch
   !> stops with branch_step_min and why; a
   !> start with no Newton budget stops with branch_no_start and why.
   subroutine test_failures_stop_with_a_reason()
      type(branch_options_t) :: opt
      type(branch_t) :: br
      type(error_t), allocatable :: err
      call test_begin('failures_stop_with_a_reason')
      opt = options()
      opt%max_corrector = 1
      opt%nonsmooth = .false.
      opt%ds_min = 0.00125_wp
      call continue_branch(prob, w_start, opt, br, err)
      call check('no error, a status ('//msg(br)//')', .not. allocated(err) .and. br%status == branch_step_min)
      call check('the reason: the corrector''s budget', index(br%message, 'corrector spent its 1 steps') > 0)
      call check('the start point is kept, then the failure as a point with its reason', size(br%pts) == 2)
      if (size(br%pts) == 2) call check('the failed point: status step_min, the message', &
                                        br%pts(2)%status == branch_step_min .and. br%pts(2)%message == br%message)
      opt = options()
      opt%shoot%max_newton = 1
      opt%shoot%retries = 0
      opt%shoot%transient = 1
      call continue_branch(prob, w_start, opt, br, err)
      call check('no start orbit: a status ('//msg(br)//')', .not. allocated(err) .and. br%status == branch_no_start)
      call check('the reason: the shooting''s', index(br%message, 'no periodic orbit at the start') > 0)
   end subroutine test_failures_stop_with_a_reason

   !> Each reason a branch stops for, constructed, and with restarts the branch going on
   !> past a failure. A chord corrector of 4 steps (no full-Newton retry) at a smallest step
   !> of 0.04 turns the jump-down fold (located, 11.1132) and fails 16 points further down the
   !> middle branch, 0.043 rad/s below it, its tangent turning away from the fold: reason 2,
   !> not at a fold (before D-174 "a fold it could not turn", a real multiplier being within
   !> 0.05 of +1 there). A chord corrector of 8 steps at a fixed step of 0.08 turns the
   !> jump-down fold and fails 0.0127 rad/s short of the jump-up one (10.6077), t_lambda
   !> falling towards it: reason 5. With one restart (the first corrector) the orbit is shot
   !> again 1 % further up in W, beyond the jump-down fold,
   !> and the branch goes on along the lower (non-contact) branch to
   !> w_end (status done, one failed point, its reason kept); a start with no orbit,
   !> given 2 restarts, is tried at three frequencies and stops with three failed points.
   subroutine test_reasons_and_restarts()
      type(branch_options_t) :: opt
      type(branch_t) :: br
      type(error_t), allocatable :: err
      integer :: i, nf
      call test_begin('reasons_and_restarts')
      call fold_failures(prob)
      opt = options()
      opt%nonsmooth = .false.     ! (the chord corrector alone: no full-Newton retry)
      opt%max_corrector = 4
      opt%ds_min = 0.04_wp
      opt%restarts = 1
      opt%restart_step = 0.01_wp
      call continue_branch(prob, w_start, opt, br, err)
      nf = count(br%pts%status /= branch_done)
      write (*, '(a,i0,a,i0,a,f10.5)') '    with a restart: ', size(br%pts), ' points, ', nf, ' failed, last at ', &
         br%pts(size(br%pts))%lam
      call check('with a restart the branch reaches its end ('//msg(br)//')', .not. allocated(err) .and. &
                 br%status == branch_done .and. br%pts(size(br%pts))%lam > w_end)
      call check('one failed point, reason 2, then segment 2', nf == 1)
      do i = 1, size(br%pts)
         if (br%pts(i)%status == branch_done) cycle
         call check('the failed point keeps its reason', br%pts(i)%status == branch_step_min .and. &
                    index(br%pts(i)%message, 'not at a fold') > 0)
         if (i < size(br%pts)) call check('the next point is a new segment, beyond the fold, stable', &
                                          br%pts(i + 1)%segment == 2 .and. br%pts(i + 1)%lam > w_fold(1) .and. &
                                          br%pts(i + 1)%stability == 'stable')
      end do
      opt = options()
      opt%shoot%max_newton = 1
      opt%shoot%retries = 0
      opt%shoot%transient = 1
      opt%restarts = 2
      call continue_branch(prob, w_start, opt, br, err)
      call check('no orbit at three starts: status no_start, three failed points ('//msg(br)//')', &
                 .not. allocated(err) .and. br%status == branch_no_start .and. size(br%pts) == 3)
      if (size(br%pts) == 3) call check('... at w, w + 1 %, w + 2 %', all(abs(br%pts%lam - w_start*[1.0_wp, 1.01_wp, &
                                        1.02_wp]) < 1.0e-12_wp) .and. all(br%pts%status == branch_no_start))
   end subroutine test_reasons_and_restarts

   !> A damped train's slow mode is no fold (D-174): the oscillator with a second inertia
   !> held by a weak shaft (k = 1e-4, c = 1: an overdamped mode at s = -1e-4, a real
   !> multiplier exp(-1e-4 T) = 0.99993 at every point, which before D-174 made any failure a
   !> "fold"). A chord corrector of one step fails at the first step (as in
   !> `failures_stop_with_a_reason`): reason 2, not at a fold; the two failures of
   !> `reasons_and_restarts` (`fold_failures`) keep their reasons 2 and 5.
   subroutine test_slow_damped_mode_is_no_fold()
      type(sine_problem_t) :: dprob
      type(branch_options_t) :: opt
      type(branch_t) :: br
      type(error_t), allocatable :: err
      call test_begin('slow_damped_mode_is_no_fold')
      call load_model_text('&run t_end = 1.0, dt = 2e-4, integrator = ''rk4'', output_interval = 2e-4 /'//nl// &
                           "&node id='g', type='fixed' /"//nl//"&node id='m', type='inertia', inertia="//str(jj)//' /'// &
                           nl//"&node id='r', type='inertia', inertia=1 /"//nl// &
                           "&element type='shaft', left='m', right='g', stiffness="//str(k1)//', damping='// &
                           str(c1)//' /'//nl//"&element type='clearance_coupling', left='m', right='g', clearance="// &
                           str(2.0_wp*b)//', stiffness='//str(k2)//', contact_damping=0 /'//nl// &
                           "&element type='shaft', left='r', right='g', stiffness=1e-4, damping=1 /"//nl// &
                           "&load node='m', kind='sine', offset="//str(tq0)//', amplitude='//str(amp)// &
                           ', frequency=1.75 /', dprob%base)
      opt = options()
      opt%max_corrector = 1
      opt%nonsmooth = .false.
      opt%ds_min = 0.00125_wp
      call continue_branch(dprob, w_start, opt, br, err)
      write (*, '(a)') '    '//msg(br)
      call check('no error, stopped at the smallest step', .not. allocated(err) .and. br%status /= branch_done)
      if (size(br%pts) > 0) call check('the slow mode''s multiplier sits near +1 (0.9999)', &
                                       any(abs(br%pts(1)%mu - exp(-1.0e-4_wp*2.0_wp*pi/w_start)) < 1.0e-6_wp))
      call check('... and is no fold: reason 2 ('//msg(br)//')', br%status == branch_step_min .and. &
                 index(br%message, 'not ') > 0)
      call fold_failures(dprob)
   end subroutine test_slow_damped_mode_is_no_fold

   !> The chord corrector of 4 steps at a smallest step of 0.04 past the jump-down fold:
   !> reason 2 (the fold located before it); of 8 steps at a step of 0.08 short of the jump-up
   !> fold: reason 5, within 0.05 rad/s of it.
   subroutine fold_failures(pr)
      type(sine_problem_t), intent(in) :: pr
      type(branch_options_t) :: opt
      type(branch_t) :: br
      type(error_t), allocatable :: err
      integer :: i, nf
      opt = options()
      opt%nonsmooth = .false.
      opt%max_corrector = 4
      opt%ds_min = 0.04_wp
      call continue_branch(pr, w_start, opt, br, err)
      write (*, '(a)') '    '//msg(br)
      nf = count([(br%pts(i)%kind == 'fold', i=1, size(br%pts))])
      call check('past the jump-down fold, which it turned: reason 2 ('//msg(br)//')', .not. allocated(err) .and. &
                 br%status == branch_step_min .and. index(br%message, 'not at a fold') > 0 .and. nf == 1)
      if (size(br%pts) > 0) call check('... below the jump-down fold (within 0.05 rad/s)', &
                                       br%pts(size(br%pts))%lam < w_fold(1) .and. &
                                       abs(br%pts(size(br%pts))%lam - w_fold(1)) < 0.05_wp)
      opt%max_corrector = 8
      opt%ds_min = 0.08_wp
      opt%ds_max = 0.08_wp
      opt%ds = 0.08_wp
      call continue_branch(pr, w_start, opt, br, err)
      write (*, '(a)') '    '//msg(br)
      nf = count([(br%pts(i)%kind == 'fold', i=1, size(br%pts))])
      call check('short of the jump-up fold: reason 5 ('//msg(br)//')', .not. allocated(err) .and. &
                 br%status == branch_fold .and. nf == 1)
      if (size(br%pts) > 0) call check('... above the jump-up fold (within 0.05 rad/s)', &
                                       br%pts(size(br%pts))%lam > w_fold(2) .and. &
                                       abs(br%pts(size(br%pts))%lam - w_fold(2)) < 0.05_wp)
   end subroutine fold_failures

   function msg(br) result(s)
      type(branch_t), intent(in) :: br
      character(len=:), allocatable :: s
      s = 'status '//str(br%status)
      if (allocated(br%message)) s = s//': '//br%message
   end function msg

   ! ---- the closed form ------------------------------------------------------

   !> The matching conditions of the contact orbit, v = (phi, va, tb, vb, W): the
   !> entry at ta = phi/W with speed va, contact (k + k2, torque t0 + k2 b) to the
   !> exit (tb, b, vb), free (k) from there to (ta + T, b, va).
   function matching(v) result(g)
      real(wp), intent(in) :: v(5)
      real(wp) :: g(4), ta, w
      w = v(5)
      ta = v(1)/w
      g(1:2) = osc%flow(k1 + k2, tq0 + k2*b, w, ta, [b, v(2)], v(3)) - [b, v(4)]
      g(3:4) = osc%flow(k1, tq0, w, v(3), [b, v(4)], ta + 2.0_wp*pi/w) - [b, v(2)]
      g = g/[b, 10.0_wp*b, b, 10.0_wp*b]
   end function matching

   !> d matching / dv (5 columns), central differences.
   function matching_jac(v) result(a)
      real(wp), intent(in) :: v(5)
      real(wp) :: a(4, 5), vp(5), vm(5), h
      integer :: j
      do j = 1, 5
         h = 1.0e-6_wp*max(abs(v(j)), 1.0e-2_wp)
         vp = v
         vm = v
         vp(j) = v(j) + h
         vm(j) = v(j) - h
         a(:, j) = (matching(vp) - matching(vm))/(vp(j) - vm(j))
      end do
   end function matching_jac

   !> Newton on the matching conditions with v(jfix) held (the other four free).
   subroutine solve_matching(v, jfix, ok)
      real(wp), intent(inout) :: v(5)
      integer, intent(in) :: jfix
      logical, intent(out) :: ok
      real(wp) :: g(4), a(4, 5), jac(4, 4)
      integer :: it, ipiv(4), info
      integer :: free(4)
      free = pack([1, 2, 3, 4, 5], [1, 2, 3, 4, 5] /= jfix)
      ok = .false.
      do it = 1, 40
         g = matching(v)
         if (maxval(abs(g)) < 1.0e-14_wp) exit
         a = matching_jac(v)
         jac = a(:, free)
         g = -g
         call dgesv(4, 1, jac, 4, ipiv, g, 4, info)
         if (info /= 0) return
         v(free) = v(free) + g
      end do
      ok = maxval(abs(matching(v))) < 1.0e-12_wp
   end subroutine solve_matching

   !> The unit tangent of the solution curve at v (the null vector of the 4 x 5
   !> Jacobian), oriented along t_old.
   function curve_tangent(v, t_old) result(t)
      real(wp), intent(in) :: v(5), t_old(5)
      real(wp) :: t(5), bb(5, 5)
      integer :: ipiv(5), info
      bb(1:4, :) = matching_jac(v)
      bb(5, :) = t_old
      t = [0.0_wp, 0.0_wp, 0.0_wp, 0.0_wp, 1.0_wp]
      call dgesv(5, 1, bb, 5, ipiv, t, 5, info)
      t = t/norm2(t)
      if (dot_product(t, t_old) < 0.0_wp) t = -t
   end function curve_tangent

   !> The folds of the closed form. Start: at W = w_start the entry and exit of the
   !> linear steady state (no contact) at th = b, Newton with W held. Then along the
   !> solution curve in steps of 0.02 (predictor on the tangent, Newton with the
   !> component of the largest tangent entry held); where the tangent's W entry
   !> changes sign, W is extremal along the curve: golden section on W as a
   !> function of that held component (the rest solved), to 1e-11 of it.
   subroutine reference_folds(wf)
      real(wp), intent(out) :: wf(2)
      real(wp) :: v(5), vo(5), t(5), to(5), p, q, rr, psi, s, w, d, e
      logical :: ok
      integer :: i, found, jf
      w = w_start
      d = k1 - jj*w**2
      e = c1*w
      p = amp*d/(d**2 + e**2)
      q = -amp*e/(d**2 + e**2)
      rr = hypot(p, q)
      psi = atan2(q, p)
      s = asin((b - tq0/k1)/rr)   ! th = t0/k + rr sin(W t + psi): enters at W t + psi = s
      v(1) = modulo(s - psi, 2.0_wp*pi)
      v(2:5) = [rr*w*cos(s), (v(1) + pi - 2.0_wp*s)/w, -rr*w*cos(s), w]
      call solve_matching(v, 5, ok)
      call check('the closed form''s orbit at W = '//str(w_start), ok)
      t = curve_tangent(v, [0.0_wp, 0.0_wp, 0.0_wp, 0.0_wp, 1.0_wp])
      found = 0
      do i = 1, 20000
         vo = v
         to = t
         jf = maxloc(abs(t), 1)
         v = vo + 0.02_wp*t
         call solve_matching(v, jf, ok)
         if (.not. ok) exit
         t = curve_tangent(v, to)
         if (t(5)*to(5) < 0.0_wp) then
            found = found + 1
            jf = maxloc(abs(t(1:4)), 1)
            wf(found) = golden(vo, v, jf, sign(1.0_wp, to(5)))
            if (found == 2) exit
         end if
      end do
      call check('the closed form has two folds', found == 2)
   end subroutine reference_folds

   !> The extreme of W along the curve between va and vb (sgn +1: maximum, -1:
   !> minimum), W a function of component jf (the others solved): golden section.
   real(wp) function golden(va, vb, jf, sgn) result(wext)
      real(wp), intent(in) :: va(5), vb(5), sgn
      integer, intent(in) :: jf
      real(wp), parameter :: gr = 0.6180339887498949_wp
      real(wp) :: lo, hi, x1, x2, f1, f2, u(5)
      logical :: all_ok
      lo = min(va(jf), vb(jf))
      hi = max(va(jf), vb(jf))
      u = 0.5_wp*(va + vb)
      all_ok = .true.
      x1 = hi - gr*(hi - lo)
      x2 = lo + gr*(hi - lo)
      f1 = w_at(u, jf, x1, all_ok)
      f2 = w_at(u, jf, x2, all_ok)
      do while (hi - lo > 1.0e-11_wp*max(1.0_wp, abs(hi)))
         if (sgn*f1 > sgn*f2) then
            hi = x2
            x2 = x1
            f2 = f1
            x1 = hi - gr*(hi - lo)
            f1 = w_at(u, jf, x1, all_ok)
         else
            lo = x1
            x1 = x2
            f1 = f2
            x2 = lo + gr*(hi - lo)
            f2 = w_at(u, jf, x2, all_ok)
         end if
      end do
      wext = merge(f1, f2, sgn*f1 > sgn*f2)
      call check('the golden section''s orbits converged', all_ok)
   end function golden

   !> W with component jf of the curve's point held at xj (u: the guess, then the point).
   real(wp) function w_at(u, jf, xj, all_ok)
      real(wp), intent(inout) :: u(5)
      integer, intent(in) :: jf
      real(wp), intent(in) :: xj
      logical, intent(inout) :: all_ok
      logical :: ok
      u(jf) = xj
      call solve_matching(u, jf, ok)
      all_ok = all_ok .and. ok
      w_at = u(5)
   end function w_at
end program test_continuation
