!> Pseudo-arclength continuation of periodic orbits in a deck parameter lambda
!> (issue 27 item 3; docs/periodic.md "Continuation"; D-108).
!>
!> Unknowns z = (x, lambda): the reduced state x at the forcing phase t0 and the
!> parameter. G(x, lambda) = P(x; lambda) - x, P the period map at lambda (the
!> deck rebuilt by the problem's `model_at`, its forcing period taken as shooting
!> takes it). In the scaled variables (x/s, lambda/l) the Jacobian is
!> A = [S^-1 (M - I) S, S^-1 dP/dlambda l], M by central differences
!> (monodromy_fd), dP/dlambda by a central difference of the period map.
!> The tangent t solves [A; t_prev'] t = (0, 1), normalised; the predictor is
!> z + ds t, the corrector chord Newton on [G; t'(z - z_pred)] with the bordered
!> matrix of the last point. Step control: halve on failure (down to ds_min: the
!> branch stops with the reason), grow by 1.5 after at most 3 corrector steps
!> (up to ds_max).
!>
!> Bifurcations between two accepted points: a fold where the lambda-component
!> of the tangent changes sign (a multiplier through +1), a period-doubling where
!> det(M + I) does (a real multiplier through -1), a Neimark-Sacker point where
!> the number of complex multipliers outside the unit circle changes. Each is
!> located by the Illinois secant on its test function along the arclength from
!> the earlier point, to lam_tol in lambda (a fold: to a tangent lambda-component
!> below 1e-9, which puts lambda within ~1e-18/curvature of the turn).
module trainsim_arclength
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_period_map, only: period_map_t, forcing_period
   use trainsim_shooting, only: shoot_options_t, shoot_result_t, shoot, shoot_converged, monodromy_fd
   use trainsim_floquet, only: floquet_multipliers, stability_of
   use trainsim_monodromy, only: monodromy_stats_t
   use trainsim_monodromy_map, only: monodromy_map_stats, flow_signature, monodromy_choice, mono_auto, &
                                     monodromy_variational
   implicit none
   private

   public :: branch_problem_t, point_hook_i, branch_options_t, branch_point_t, branch_t, continue_branch
   public :: branch_done, branch_no_start, branch_step_min, branch_budget, branch_failed, branch_fold

   !> branch_t%status, and a failed point's status (branch_point_t%status): why it stopped
   !> (or, with restarts, why a stretch of the branch ended): 1 no periodic orbit near the
   !> start, 2 the corrector failed at the smallest step (not at a fold), 3 the point
   !> budget spent, 4 an error, 5 the corrector failed at the smallest step at a fold (a
   !> multiplier near +1: a fold it could not turn).
   integer, parameter :: branch_done = 0, branch_no_start = 1, branch_step_min = 2, branch_budget = 3, &
                         branch_failed = 4, branch_fold = 5

   !> The deck at a parameter value: extend and give `model_at`.
   type, abstract :: branch_problem_t
   contains
      procedure(model_at_i), deferred :: model_at
   end type branch_problem_t

   abstract interface
      subroutine model_at_i(self, lam, model, err)
         import :: branch_problem_t, wp, model_t, error_t
         class(branch_problem_t), intent(in) :: self
         real(wp), intent(in) :: lam
         type(model_t), intent(out) :: model
         type(error_t), allocatable, intent(out) :: err
      end subroutine model_at_i
   end interface

   type :: branch_options_t
      real(wp) :: lam_min = -huge(1.0_wp), lam_max = huge(1.0_wp)   !< the branch stops when it leaves these
      integer :: direction = 1          !< +1: start towards larger lambda
      real(wp) :: ds = 0.005_wp         !< the first step (scaled arclength: lambda/|lambda_0|, x/s)
      real(wp) :: ds_min = 1.0e-6_wp, ds_max = 0.05_wp
      integer :: max_points = 400
      integer :: max_corrector = 8
      real(wp) :: tol = 1.0e-10_wp      !< ||G/s||_inf of a point
      real(wp) :: lam_tol = 1.0e-7_wp   !< bifurcation location, relative to |lambda_0|
      real(wp) :: fd_lam = 1.0e-6_wp    !< dP/dlambda: central difference, step of |lambda_0|
      integer :: k = 1                  !< forcing periods per orbit
      type(shoot_options_t) :: shoot   !< the first orbit
      !> the monodromy: mono_auto (saltation where the deck allows it), mono_saltation, mono_fd
      integer :: monodromy = mono_auto
      !> the non-smooth corrector: a change of the contact sequence (grazing) located,
      !> stored as a point of kind 'grazing' and crossed with full Newton (D-109 ns27)
      logical :: nonsmooth = .true.
      !> restarts: where the corrector fails at the smallest step (or no orbit is found at a
      !> restart), a failed point is stored with its reason and the orbit is shot again
      !> restart_step |lambda_0| further on in lambda (from the last orbit's state, through a
      !> transient: where a brute-force sweep would jump), up to `restarts` times
      integer :: restarts = 0
      real(wp) :: restart_step = 0.01_wp
   end type branch_options_t

   type :: branch_point_t
      real(wp) :: lam = 0.0_wp, period = 0.0_wp, t0 = 0.0_wp
      real(wp), allocatable :: x(:), tangent(:)   !< tangent: scaled (x/s, lambda/l), unit
      complex(wp), allocatable :: mu(:)
      character(len=:), allocatable :: stability   !< stable / marginal / unstable
      character(len=:), allocatable :: kind        !< '' (a regular point), fold, period-doubling, neimark-sacker
      real(wp) :: residual = 0.0_wp, ds = 0.0_wp
      integer :: corrector = 0, maps = 0           !< corrector steps; period maps up to this point
      !> for an exact resume: the scaled unknowns z, the vector that bordered the Jacobian
      !> when the tangent was computed, the step after this point, the phase of t0
      real(wp), allocatable :: z(:), border(:)
      real(wp) :: ds_next = 0.0_wp, phase = 0.0_wp
      integer :: segment = 1                       !< 1 + the restarts before it
      integer :: status = branch_done              !< a failed point (restarts): its reason, lam where
      character(len=:), allocatable :: message     !< it failed, no orbit
   end type branch_point_t

   type :: branch_t
      type(branch_point_t), allocatable :: pts(:)
      integer :: status = branch_failed
      character(len=:), allocatable :: message
      integer :: maps = 0, rejected = 0
      integer :: passes = 0               !< variational passes (saltation monodromy or signature)
      real(wp), allocatable :: scale(:)   !< s
      real(wp) :: lam_scale = 1.0_wp      !< l
      real(wp) :: phase = 0.0_wp          !< (t0 - t_start)/T, kept at every lambda
   end type branch_t

   abstract interface
      !> Called with i > 0 after point i is stored, and with i = 0 when the branch
      !> ends (br%status, br%message set): a branch file written as it grows, so
      !> that a killed run can be resumed.
      subroutine point_hook_i(br, i, err)
         import :: branch_t, error_t
         type(branch_t), intent(in) :: br
         integer, intent(in) :: i
         type(error_t), allocatable, intent(out) :: err
      end subroutine point_hook_i
   end interface

   !> The evaluation context: the period map set up at lambda `lam`.
   type :: ctx_t
      class(branch_problem_t), allocatable :: prob
      type(period_map_t) :: pm
      real(wp) :: lam = huge(1.0_wp)
      real(wp) :: phase = 0.0_wp
      integer :: k = 1, n = 0, maps = 0
      real(wp), allocatable :: s(:)
      real(wp) :: ls = 1.0_wp, fd = 1.0e-6_wp
      real(wp) :: t_start = 0.0_wp   !< the deck's t_start (t0 = t_start + phase T)
      logical :: salt = .false.      !< the monodromy by saltation matrices (else differences)
      logical :: sig = .true.        !< take each point's contact-sequence signature
      integer :: passes = 0          !< variational (or signature) passes
   end type ctx_t

   !> an accepted point's data for the next step
   type :: node_t
      real(wp), allocatable :: z(:), px(:), a(:, :), t(:), m(:, :)
      complex(wp), allocatable :: mu(:)
      integer :: corrector = 0
      real(wp) :: residual = 0.0_wp
      type(monodromy_stats_t) :: st   !< the flow's events over the orbit: its contact sequence's signature
   end type node_t

   interface
      subroutine dgesv(n, nrhs, a, lda, ipiv, b, ldb, info)
         import :: wp
         integer, intent(in) :: n, nrhs, lda, ldb
         real(wp), intent(inout) :: a(lda, *), b(ldb, *)
         integer, intent(out) :: ipiv(*), info
      end subroutine dgesv
   end interface

contains

   !> Continue the periodic orbit of `prob` from lam0 (shot there from the deck's
   !> start), or from the last point of `resume` (a branch stored earlier: its
   !> scale, phase and points). br%status / br%message say why it stopped; err:
   !> the deck could not be built, or the monodromy failed, at an accepted point.
   subroutine continue_branch(prob, lam0, opt, br, err, resume, hook)
      class(branch_problem_t), intent(in) :: prob
      real(wp), intent(in) :: lam0
      type(branch_options_t), intent(in) :: opt
      type(branch_t), intent(out) :: br
      type(error_t), allocatable, intent(out) :: err
      type(branch_t), intent(in), optional :: resume
      procedure(point_hook_i), optional :: hook
      type(ctx_t) :: c
      integer :: stored, restarts
      type(node_t) :: cur
      real(wp), allocatable :: t_prev(:)
      real(wp) :: ds, lam
      character(len=:), allocatable :: why
      allocate (c%prob, source=prob)
      c%sig = opt%nonsmooth
      c%k = opt%k
      c%fd = opt%fd_lam
      allocate (br%pts(0))
      restarts = 0
      if (present(resume)) then
         call start_resumed(c, resume, opt, br, cur, t_prev, ds, err)
         restarts = br%pts(size(br%pts))%segment - 1
      else
         lam = lam0
         call start_shot(c, lam, opt, br, cur, t_prev, ds, err)
         do while (br%status == branch_no_start .and. restarts < opt%restarts .and. .not. allocated(err))
            call failed_point(br, lam, branch_no_start, br%message)
            restarts = restarts + 1
            lam = lam + opt%restart_step*abs(lam0)*sign(1, opt%direction)
            if (lam > opt%lam_max .or. lam < opt%lam_min) lam = huge(1.0_wp)
            if (lam == huge(1.0_wp)) exit
            call start_shot(c, lam, opt, br, cur, t_prev, ds, err)
         end do
      end if
      stored = 0
      if (present(resume)) stored = size(br%pts)
      if (allocated(err)) return
      if (br%status == branch_no_start) then
         if (lam < huge(1.0_wp)) call failed_point(br, lam, branch_no_start, br%message)
         call report_points()
         if (.not. allocated(err) .and. present(hook)) call hook(br, 0, err)
         return
      end if
      call evaluate(c, cur%z, cur%px, why, err)
      if (.not. allocated(err) .and. len(why) > 0) call fatal_error(err, 'the start point: '//why, err_input)
      if (.not. allocated(err)) call linearise(c, cur, t_prev, err)
      if (allocated(err)) return
      if (present(resume)) then
         c%maps = br%maps   ! (the resumed point's linearisation is counted once, as uninterrupted)
      else
         call store(br, c, cur, 0.0_wp, '', t_prev, restarts + 1)
         br%pts(size(br%pts))%ds_next = ds
      end if
      call follow(c, br, cur, ds, opt, stored, restarts, err, hook)
   contains
      subroutine report_points()
         if (.not. present(hook)) return
         do while (stored < size(br%pts))
            stored = stored + 1
            call hook(br, stored, err)
            if (allocated(err)) return
         end do
      end subroutine report_points
   end subroutine continue_branch

   !> The continuation loop from the accepted point cur (stored) with the step ds:
   !> predictor, corrector (chord, then full Newton: the non-smooth corrector),
   !> grazing crossed, bifurcations detected, step control, until the branch leaves
   !> [lam_min, lam_max] or stops. stored: the points already given to `hook`.
   subroutine follow(c, br, cur, ds, opt, stored, restarts, err, hook)
      type(ctx_t), intent(inout) :: c
      type(branch_t), intent(inout) :: br
      type(node_t), intent(inout) :: cur
      real(wp), intent(inout) :: ds
      type(branch_options_t), intent(in) :: opt
      integer, intent(inout) :: stored, restarts   !< restarts: made so far (opt%restarts)
      type(error_t), allocatable, intent(out) :: err
      procedure(point_hook_i), optional :: hook
      type(node_t) :: nxt
      real(wp) :: lam
      character(len=:), allocatable :: why
      logical :: crossed, rephased
      integer :: before
      rephased = .false.
      do
         call report_points()
         if (allocated(err)) return
         if (size(br%pts) >= opt%max_points) then
            br%status = branch_budget
            br%message = 'the budget of '//str(opt%max_points)//' points was spent at lambda = '// &
                         str(cur%z(c%n + 1)*c%ls, 10)
            exit
         end if
         call correct(c, cur, cur%z + ds*cur%t, opt, nxt, why)
         if (len(why) > 0 .and. opt%nonsmooth) call correct(c, cur, cur%z + ds*cur%t, opt, nxt, why, full=.true.)
         crossed = .false.
         if (len(why) == 0) then
            call linearise(c, nxt, cur%t, err)
            if (allocated(err)) then
               why = err%message
               deallocate (err)
            end if
         end if
         if (opt%nonsmooth .and. .not. rephased) then
            ! a memory contact reaching t0 (odd events) or a failed step: move t0 first
            if (len(why) > 0 .or. modulo(nxt%st%events, 2) /= 0) then
               call rephase_point(c, br, cur, rephased, err)
               if (allocated(err)) return
               if (rephased) cycle
            end if
         end if
         if (len(why) == 0) then
            if (opt%nonsmooth .and. .not. same_sequence(cur%st, nxt%st)) then
               call cross_grazing(c, br, cur, nxt, ds, opt)
               crossed = .true.
            else if (dot_product(nxt%t, cur%t) < 0.9_wp .and. ds > opt%ds_min) then
               why = 'the tangent turned by more than 25 degrees in one step'
            end if
         end if
         if (len(why) > 0) then
            br%rejected = br%rejected + 1
            if (ds <= opt%ds_min) then
               br%status = branch_step_min
               if (at_fold(cur, c%n)) br%status = branch_fold
               br%message = 'the step reached its minimum '//str(opt%ds_min, 3)//' at lambda = '// &
                            str(cur%z(c%n + 1)*c%ls, 10)//trim(merge(' (a fold: a multiplier near +1)', ' (not at a fold)               ', &
                            br%status == branch_fold))//' and the corrector still failed: '//why
               if (restarts >= opt%restarts) then
                  call failed_point(br, cur%z(c%n + 1)*c%ls, br%status, br%message)
                  exit
               end if
               call restart(c, opt, br, cur, ds, restarts, err)
               if (allocated(err)) return
               if (br%status /= branch_failed) exit
               cycle
            end if
            ds = max(0.5_wp*ds, opt%ds_min)
            cycle
         end if
         before = size(br%pts)
         if (.not. crossed) call detect(c, br, cur, nxt, ds, opt)
         if (closed_loop(br, before, c)) then
            br%status = branch_done
            br%message = 'the branch closed on itself: the fold at lambda = '// &
                         str(br%pts(size(br%pts))%lam, 10)//' was met before'
            exit
         end if
         call store(br, c, nxt, ds, '', cur%t, restarts + 1)
         cur = nxt
         rephased = .false.
         if (nxt%corrector <= 3) ds = min(1.5_wp*ds, opt%ds_max)
         br%pts(size(br%pts))%ds_next = ds
         lam = cur%z(c%n + 1)*c%ls
         if (lam > opt%lam_max .or. lam < opt%lam_min) then
            br%status = branch_done
            br%message = ''
            exit
         end if
      end do
      br%maps = c%maps
      br%passes = c%passes
      call c%pm%finish()
      call report_points()
      if (.not. allocated(err) .and. present(hook)) call hook(br, 0, err)
   contains
      subroutine report_points()
         if (.not. present(hook)) return
         do while (stored < size(br%pts))
            stored = stored + 1
            call hook(br, stored, err)
            if (allocated(err)) return
         end do
      end subroutine report_points
   end subroutine follow

   !> A fold at p: a real multiplier within 0.05 of +1, or the tangent nearly normal
   !> to lambda (|t_lambda| < 0.05).
   logical function at_fold(p, n)
      type(node_t), intent(in) :: p
      integer, intent(in) :: n
      at_fold = abs(p%t(n + 1)) < 0.05_wp .or. &
                any(abs(aimag(p%mu)) <= 1.0e-8_wp*abs(p%mu) .and. abs(real(p%mu, wp) - 1.0_wp) < 0.05_wp)
   end function at_fold

   !> A stretch of the branch ended (br%status, br%message: why, at cur): store that as a
   !> failed point and shoot the orbit again restart_step further on in lambda (in the
   !> direction of the sweep, opt%direction, as a brute-force sweep goes on), from cur's state through the shooting's transient;
   !> again further on while no orbit is found, up to the restarts left. On return
   !> br%status is branch_failed (going on from the new cur) or why it stopped.
   subroutine restart(c, opt, br, cur, ds, restarts, err)
      type(ctx_t), intent(inout) :: c
      type(branch_options_t), intent(in) :: opt
      type(branch_t), intent(inout) :: br
      type(node_t), intent(inout) :: cur
      real(wp) :: t_prev(c%n + 1)
      real(wp), intent(inout) :: ds
      integer, intent(inout) :: restarts
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: lam, dir
      real(wp), allocatable :: x(:)
      character(len=:), allocatable :: why
      dir = real(sign(1, opt%direction), wp)
      lam = cur%z(c%n + 1)*c%ls
      x = cur%z(1:c%n)*c%s
      call failed_point(br, lam, br%status, br%message)
      do while (restarts < opt%restarts .and. size(br%pts) < opt%max_points)
         restarts = restarts + 1
         lam = lam + dir*opt%restart_step*c%ls
         if (lam > opt%lam_max .or. lam < opt%lam_min) then
            br%status = branch_done
            br%message = ''
            return
         end if
         call reshoot(c, lam, opt, x, cur, why, err)
         if (allocated(err)) return
         if (len(why) == 0) then
            t_prev = 0.0_wp
            t_prev(c%n + 1) = dir
            call linearise(c, cur, t_prev, err)
            if (allocated(err)) return
            ds = opt%ds
            call store(br, c, cur, 0.0_wp, '', t_prev, restarts + 1)
            br%pts(size(br%pts))%ds_next = ds
            br%status = branch_failed
            return
         end if
         br%status = branch_no_start
         br%message = 'no periodic orbit at the restart lambda = '//str(lam)//': '//why
         call failed_point(br, lam, br%status, br%message)
      end do
      if (size(br%pts) >= opt%max_points) then
         br%status = branch_budget
         br%message = 'the budget of '//str(opt%max_points)//' points was spent at lambda = '//str(lam, 10)
      end if
   end subroutine restart

   !> The orbit at lam shot from x (through the shooting's transient), as the node cur
   !> (scaled by the branch's scale; t0's phase as shooting left it). why: no orbit.
   subroutine reshoot(c, lam, opt, x, cur, why, err)
      type(ctx_t), intent(inout) :: c
      real(wp), intent(in) :: lam, x(:)
      type(branch_options_t), intent(in) :: opt
      type(node_t), intent(out) :: cur
      character(len=:), allocatable, intent(out) :: why
      type(error_t), allocatable, intent(out) :: err
      type(shoot_result_t) :: res
      why = ''
      call at(c, lam, err)
      if (allocated(err)) return
      call monodromy_choice(opt%monodromy, c%pm%model, c%salt, err)
      if (allocated(err)) return
      if (c%salt) then
         call shoot(c%pm, opt%shoot, res, err, monodromy=monodromy_variational, x_start=x)
      else
         call shoot(c%pm, opt%shoot, res, err, x_start=x)
      end if
      c%maps = c%maps + res%maps
      if (allocated(err)) then
         why = err%message
         deallocate (err)
      else if (res%status /= shoot_converged) then
         why = res%message
      end if
      c%lam = huge(1.0_wp)   ! (shooting may have moved t0: set the map up again at the new phase)
      if (len(why) > 0) return
      c%phase = (c%pm%t0 - c%t_start)/c%pm%period
      cur%z = [res%x/c%s, lam/c%ls]
      call evaluate(c, cur%z, cur%px, why, err)
   end subroutine reshoot

   !> A failed point: lambda where a stretch ended, its reason and message, no orbit.
   subroutine failed_point(br, lam, status, message)
      type(branch_t), intent(inout) :: br
      real(wp), intent(in) :: lam
      integer, intent(in) :: status
      character(len=*), intent(in) :: message
      type(branch_point_t) :: bp
      bp%lam = lam
      bp%status = status
      bp%message = message
      bp%stability = ''
      bp%kind = ''
      bp%maps = br%maps
      if (size(br%pts) > 0) then
         bp%segment = br%pts(size(br%pts))%segment
         bp%phase = br%pts(size(br%pts))%phase
      end if
      allocate (bp%x(0), bp%tangent(0), bp%mu(0), bp%z(0), bp%border(0))
      br%pts = [br%pts, bp]
   end subroutine failed_point

   !> The first point: the orbit shot at lam0; t0 there (moved by shooting to an
   !> instant with no memory contact in progress) kept as a phase of the period.
   subroutine start_shot(c, lam0, opt, br, cur, t_prev, ds, err)
      type(ctx_t), intent(inout) :: c
      real(wp), intent(in) :: lam0
      type(branch_options_t), intent(in) :: opt
      type(branch_t), intent(inout) :: br
      type(node_t), intent(out) :: cur
      real(wp), allocatable, intent(out) :: t_prev(:)
      real(wp), intent(out) :: ds
      type(error_t), allocatable, intent(out) :: err
      type(shoot_result_t) :: res
      c%ls = max(abs(lam0), tiny(1.0_wp))
      if (size(br%pts) > 0) c%ls = max(abs(br%pts(1)%lam), tiny(1.0_wp))
      c%lam = huge(1.0_wp)
      call at(c, lam0, err)
      if (allocated(err)) return
      call monodromy_choice(opt%monodromy, c%pm%model, c%salt, err)
      if (allocated(err)) return
      if (c%salt) then
         call shoot(c%pm, opt%shoot, res, err, monodromy=monodromy_variational)
      else
         call shoot(c%pm, opt%shoot, res, err)
      end if
      c%maps = c%maps + res%maps
      br%maps = c%maps
      if (allocated(err)) then
         br%status = branch_no_start
         br%message = 'no periodic orbit at the start lambda = '//str(lam0)//': '//err%message
         deallocate (err)
         return
      end if
      if (res%status /= shoot_converged) then
         br%status = branch_no_start
         br%message = 'no periodic orbit at the start lambda = '//str(lam0)//': '//res%message
         return
      end if
      br%status = branch_failed
      c%n = c%pm%n
      c%phase = (c%pm%t0 - c%t_start)/c%pm%period
      c%s = res%scale
      br%scale = c%s
      br%lam_scale = c%ls
      br%phase = c%phase
      cur%z = [res%x/c%s, lam0/c%ls]
      allocate (t_prev(c%n + 1))
      t_prev = 0.0_wp
      t_prev(c%n + 1) = real(sign(1, opt%direction), wp)
      ds = opt%ds
   end subroutine start_shot

   !> The first point of a resumed branch: its last stored point.
   subroutine start_resumed(c, resume, opt, br, cur, t_prev, ds, err)
      type(ctx_t), intent(inout) :: c
      type(branch_t), intent(in) :: resume
      type(branch_options_t), intent(in) :: opt
      type(branch_t), intent(inout) :: br
      type(node_t), intent(out) :: cur
      real(wp), allocatable, intent(out) :: t_prev(:)
      real(wp), intent(out) :: ds
      type(error_t), allocatable, intent(out) :: err
      integer :: last
      last = size(resume%pts)
      do while (last > 0)
         if (resume%pts(last)%status == branch_done .and. len(resume%pts(last)%kind) == 0) exit
         last = last - 1
      end do
      if (last == 0) then
         call fatal_error(err, 'the branch to resume has no point', err_input)
         return
      end if
      br = resume
      br%pts = resume%pts(1:last)
      br%status = branch_failed
      c%phase = br%pts(last)%phase
      br%phase = c%phase
      c%s = br%scale
      c%ls = br%lam_scale
      br%maps = br%pts(last)%maps
      c%maps = br%maps
      call at(c, br%pts(last)%lam, err)
      if (allocated(err)) return
      if (abs(c%pm%t0 - br%pts(last)%t0) > 1.0e-12_wp*c%pm%period) then
         c%phase = (br%pts(last)%t0 - c%t_start)/c%pm%period   ! t0 moved along the branch (rephase_point)
         br%phase = c%phase
         c%lam = huge(1.0_wp)
         call at(c, br%pts(last)%lam, err)
         if (allocated(err)) return
      end if
      call monodromy_choice(opt%monodromy, c%pm%model, c%salt, err)
      if (allocated(err)) return
      c%n = c%pm%n
      if (size(c%s) /= c%n .or. size(br%pts(last)%tangent) /= c%n + 1) then
         call fatal_error(err, 'the branch to resume has '//str(size(c%s))//' states, the deck '//str(c%n), err_input)
         return
      end if
      associate (p => br%pts(last))
         cur%z = [p%x/c%s, p%lam/c%ls]
         if (allocated(p%z)) then
            if (size(p%z) == c%n + 1) cur%z = p%z
         end if
         t_prev = p%tangent
         if (allocated(p%border)) then
            if (size(p%border) == c%n + 1) t_prev = p%border
         end if
         ds = min(max(p%ds_next, opt%ds_min), opt%ds_max)
         if (.not. p%ds_next > 0.0_wp) ds = opt%ds
      end associate
   end subroutine start_resumed

   !> The period map set up at lambda (the deck rebuilt there; t0 = t_start + phase T).
   subroutine at(c, lam, err)
      type(ctx_t), intent(inout) :: c
      real(wp), intent(in) :: lam
      type(error_t), allocatable, intent(out) :: err
      type(model_t) :: m
      real(wp) :: period
      if (lam == c%lam) return
      c%lam = huge(1.0_wp)
      call c%prob%model_at(lam, m, err)
      if (allocated(err)) return
      call forcing_period(m, period, err)
      if (allocated(err)) return
      c%t_start = m%run%t_start
      m%run%t_start = m%run%t_start + c%phase*period
      call c%pm%setup(m, period, c%k, err)
      if (allocated(err)) return
      c%lam = lam
   end subroutine at

   !> px = P(x; lambda) for the scaled z = (x/s, lambda/l). why: the integration failed.
   subroutine evaluate(c, z, px, why, err)
      type(ctx_t), intent(inout) :: c
      real(wp), intent(in) :: z(:)
      real(wp), allocatable, intent(out) :: px(:)
      character(len=:), allocatable, intent(out) :: why
      type(error_t), allocatable, intent(out) :: err
      type(error_t), allocatable :: e
      why = ''
      allocate (px(c%n))
      call at(c, z(c%n + 1)*c%ls, err)
      if (allocated(err)) return
      call c%pm%map(z(1:c%n)*c%s, px, e)
      c%maps = c%maps + 1
      if (allocated(e)) why = 'the period map failed: '//e%message
   end subroutine evaluate

   !> The point's monodromy, multipliers, scaled Jacobian A and tangent (oriented along t_prev).
   subroutine linearise(c, p, t_prev, err)
      type(ctx_t), intent(inout) :: c
      type(node_t), intent(inout) :: p
      real(wp), intent(in) :: t_prev(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: x(c%n), lam, h, pp(c%n), pq(c%n)
      real(wp), allocatable :: b(:, :), rhs(:)
      character(len=:), allocatable :: why
      integer :: i, n, info
      integer :: ipiv(c%n + 1)
      n = c%n
      x = p%z(1:n)*c%s
      lam = p%z(n + 1)*c%ls
      h = c%fd*c%ls
      call map_at(lam + h, pp)
      if (allocated(err)) return
      call map_at(lam - h, pq)
      if (allocated(err)) return
      call at(c, lam, err)
      if (allocated(err)) return
      if (allocated(p%m)) deallocate (p%m)
      if (allocated(p%a)) deallocate (p%a)
      allocate (p%m(n, n), p%a(n, n + 1))
      if (c%salt) then
         call monodromy_map_stats(c%pm, x, p%m, p%st, err)
         c%passes = c%passes + 1
      else
         call monodromy_fd(c%pm, x, p%px, p%m, err)
         c%maps = c%maps + 2*n
         if (.not. allocated(err) .and. c%sig) then
            call flow_signature(c%pm, x, p%st, err)
            c%passes = c%passes + 1
         end if
      end if
      if (allocated(err)) return
      call floquet_multipliers(p%m, p%mu, err)
      if (allocated(err)) return
      do i = 1, n
         p%a(i, 1:n) = p%m(i, :)*c%s/c%s(i)
         p%a(i, i) = p%a(i, i) - 1.0_wp
         p%a(i, n + 1) = (pp(i) - pq(i))/(2.0_wp*h)*c%ls/c%s(i)
      end do
      b = bordered(p%a, t_prev)
      allocate (rhs(n + 1))
      rhs = 0.0_wp
      rhs(n + 1) = 1.0_wp
      call dgesv(n + 1, 1, b, n + 1, ipiv, rhs, n + 1, info)
      if (info /= 0) then
         call fatal_error(err, 'the bordered Jacobian is singular at lambda = '//str(lam)//' (a branch point)', &
                          err_input)
         return
      end if
      p%t = rhs/norm2(rhs)
      if (dot_product(p%t, t_prev) < 0.0_wp) p%t = -p%t
   contains
      subroutine map_at(l, y)
         real(wp), intent(in) :: l
         real(wp), intent(out) :: y(:)
         type(error_t), allocatable :: e
         call at(c, l, err)
         if (allocated(err)) return
         call c%pm%map(x, y, e)
         c%maps = c%maps + 1
         if (allocated(e)) then
            why = e%message
            call fatal_error(err, 'dP/dlambda: the period map failed at lambda = '//str(l)//': '//why, err_input)
         end if
      end subroutine map_at
   end subroutine linearise

   !> [A; t'] of A (n x n+1) and t (n+1).
   function bordered(a, t) result(b)
      real(wp), intent(in) :: a(:, :), t(:)
      real(wp) :: b(size(t), size(t))
      b(1:size(a, 1), :) = a
      b(size(t), :) = t
   end function bordered

   !> The corrector from z_pred on [G(z)/s; t'(z - z_pred)] = 0, t = p's tangent:
   !> chord Newton with the bordered matrix [A; t'] of the point `p`, or with
   !> `full` Newton with the Jacobian A(z) of each iterate (the one-sided Jacobian
   !> of its own contact sequence: the non-smooth corrector, D-109 ns27). why = ''
   !> if it converged.
   subroutine correct(c, p, z_pred, opt, q, why, full)
      type(ctx_t), intent(inout) :: c
      type(node_t), intent(in) :: p
      real(wp), intent(in) :: z_pred(:)
      type(branch_options_t), intent(in) :: opt
      type(node_t), intent(out) :: q
      character(len=:), allocatable, intent(out) :: why
      logical, intent(in), optional :: full
      type(error_t), allocatable :: err
      real(wp), allocatable :: b(:, :), rhs(:), px(:)
      real(wp) :: r, r_old, lam
      integer :: it, n, info, grown
      integer, allocatable :: ipiv(:)
      logical :: newton
      newton = .false.
      if (present(full)) newton = full
      n = c%n
      q%z = z_pred
      r_old = huge(1.0_wp)
      grown = 0
      allocate (ipiv(n + 1))
      do it = 0, opt%max_corrector
         lam = q%z(n + 1)*c%ls
         call evaluate(c, q%z, px, why, err)
         if (allocated(err)) why = err%message
         if (len(why) > 0) return
         r = maxval(abs(px/c%s - q%z(1:n)))
         q%px = px
         q%residual = r
         q%corrector = it
         if (r <= opt%tol) return
         if (.not. r < r_old) grown = grown + 1
         if (grown > merge(1, 0, newton)) then
            why = 'the corrector diverged at lambda = '//str(lam, 10)//' (residual '//str(r, 3)//' after '// &
                  str(r_old, 3)//')'
            return
         end if
         if (it == opt%max_corrector) exit
         r_old = r
         if (newton) then
            call linearise(c, q, p%t, err)
            if (allocated(err)) then
               why = err%message
               return
            end if
            b = bordered(q%a, p%t)
         else
            b = bordered(p%a, p%t)
         end if
         rhs = [q%z(1:n) - px/c%s, -dot_product(p%t, q%z - z_pred)]
         call dgesv(n + 1, 1, b, n + 1, ipiv, rhs, n + 1, info)
         if (info /= 0) then
            why = 'the bordered Jacobian is singular'
            return
         end if
         q%z = q%z + rhs
      end do
      why = 'the corrector spent its '//str(opt%max_corrector)//' steps at lambda = '//str(lam, 10)// &
            ' (residual '//str(r, 3)//', tolerance '//str(opt%tol, 3)//')'
   end subroutine correct

   !> Move the forcing phase t0 of the accepted point cur to the middle of the
   !> longest stretch of its orbit with every memory contact open (as shooting
   !> does, D-99): along a branch the contacts drift in phase, and one that spans
   !> t0 makes the map wrong (its impact's damping is not in the state). cur's x
   !> becomes its state at the new t0, its Jacobian and tangent (oriented by the
   !> old one's lambda-component) are taken again. moved: whether t0 moved.
   subroutine rephase_point(c, br, cur, moved, err)
      type(ctx_t), intent(inout) :: c
      type(branch_t), intent(inout) :: br
      type(node_t), intent(inout) :: cur
      logical, intent(out) :: moved
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: x(c%n), t_dir(c%n + 1), t0_old
      character(len=:), allocatable :: why
      moved = .false.
      call at(c, cur%z(c%n + 1)*c%ls, err)
      if (allocated(err)) return
      x = cur%z(1:c%n)*c%s
      t0_old = c%pm%t0
      call c%pm%rephase(x, err)
      if (allocated(err)) return
      c%maps = c%maps + 2
      if (c%pm%t0 == t0_old) return
      moved = .true.
      c%phase = (c%pm%t0 - c%t_start)/c%pm%period
      br%phase = c%phase
      cur%z(1:c%n) = x/c%s
      t_dir = 0.0_wp
      t_dir(c%n + 1) = sign(1.0_wp, cur%t(c%n + 1))
      call evaluate(c, cur%z, cur%px, why, err)
      if (.not. allocated(err) .and. len(why) > 0) call fatal_error(err, 'moving t0: '//why, err_input)
      if (.not. allocated(err)) call linearise(c, cur, t_dir, err)
   end subroutine rephase_point

   !> Whether a fold stored after index `before` repeats an earlier fold (lambda
   !> to 1e-7 of |lambda_0|, the state to 1e-6 of its scale, or where t0 moved in
   !> between the multipliers' moduli to 1e-4): a closed branch, which the
   !> continuation would go round again.
   logical function closed_loop(br, before, c) result(closed)
      type(branch_t), intent(in) :: br
      integer, intent(in) :: before
      type(ctx_t), intent(in) :: c
      integer :: i, j
      closed = .false.
      do i = before + 1, size(br%pts)
         if (br%pts(i)%kind /= 'fold') cycle
         do j = 1, before
            if (br%pts(j)%kind /= 'fold') cycle
            if (abs(br%pts(i)%lam - br%pts(j)%lam) > 1.0e-7_wp*c%ls) cycle
            if (abs(br%pts(i)%t0 - br%pts(j)%t0) <= 1.0e-9_wp*br%pts(i)%period) then
               if (maxval(abs(br%pts(i)%x - br%pts(j)%x)/c%s) > 1.0e-6_wp) cycle
            else if (maxval(abs(abs(br%pts(i)%mu) - abs(br%pts(j)%mu))) > 1.0e-4_wp) then
               cycle   ! (t0 moved in between: the state is another section's; the multipliers are not)
            end if
            closed = .true.
         end do
      end do
   end function closed_loop

   !> Whether two points' flows met the same contact sequence: as many events,
   !> events where f jumps, and impacts over the orbit.
   logical function same_sequence(a, b)
      type(monodromy_stats_t), intent(in) :: a, b
      same_sequence = a%events == b%events .and. a%jumps == b%jumps .and. a%impacts == b%impacts
   end function same_sequence

   !> A contact-sequence change between the accepted p and q (q = p + ds along p's
   !> tangent, corrected, its sequence another): the grazing orbit located by
   !> bisection on the arclength from p (each trial corrected by full Newton on p's
   !> hyperplane; a trial that fails counts as past the change) to lam_tol, the
   !> last point of p's sequence stored as kind 'grazing' (after the bifurcations
   !> between p and it), and q's tangent oriented along the secant from it: the
   !> multipliers and the tangent jump there (the map's derivative is
   !> discontinuous), and the branch goes on in q's sequence (D-109 ns27).
   subroutine cross_grazing(c, br, p, q, ds, opt)
      type(ctx_t), intent(inout) :: c
      type(branch_t), intent(inout) :: br
      type(node_t), intent(in) :: p
      type(node_t), intent(inout) :: q
      real(wp), intent(in) :: ds
      type(branch_options_t), intent(in) :: opt
      type(node_t) :: a, r
      type(error_t), allocatable :: err
      character(len=:), allocatable :: why
      real(wp) :: sa, sb, sm
      integer :: it
      sa = 0.0_wp
      sb = ds
      a = p
      do it = 1, 60
         if (abs(sb - sa)*abs(p%t(c%n + 1)) <= opt%lam_tol .and. abs(sb - sa) <= 1.0e3_wp*opt%lam_tol) exit
         sm = 0.5_wp*(sa + sb)
         call correct(c, p, p%z + sm*p%t, opt, r, why, full=.true.)
         if (len(why) == 0) call linearise(c, r, p%t, err)
         if (allocated(err)) deallocate (err)
         if (len(why) == 0 .and. same_sequence(r%st, p%st)) then
            sa = sm
            a = r
         else
            sb = sm
         end if
      end do
      if (sa > 0.0_wp) then
         call detect(c, br, p, a, sa, opt)
         call store(br, c, a, sa, 'grazing', a%t, br%pts(size(br%pts))%segment)
      else
         call store(br, c, p, 0.0_wp, 'grazing', p%t, br%pts(size(br%pts))%segment)
      end if
      if (dot_product(q%t, q%z - a%z) < 0.0_wp) q%t = -q%t
   end subroutine cross_grazing

   !> Append the point p (with its kind: '' or a bifurcation) to the branch.
   subroutine store(br, c, p, ds, kind, border, segment)
      type(branch_t), intent(inout) :: br
      type(ctx_t), intent(inout) :: c
      type(node_t), intent(in) :: p
      real(wp), intent(in) :: ds, border(:)
      character(len=*), intent(in) :: kind
      integer, intent(in) :: segment
      type(branch_point_t) :: bp
      type(error_t), allocatable :: err
      bp%lam = p%z(c%n + 1)*c%ls
      call at(c, bp%lam, err)   ! (the map at the point's own lambda: its period and t0)
      bp%period = c%pm%period
      bp%t0 = c%pm%t0
      bp%x = p%z(1:c%n)*c%s
      bp%tangent = p%t
      bp%mu = p%mu
      bp%stability = stability_of(p%mu)
      bp%kind = kind
      bp%residual = p%residual
      bp%ds = ds
      bp%corrector = p%corrector
      bp%maps = c%maps
      bp%z = p%z
      bp%border = border
      bp%phase = c%phase
      bp%segment = segment
      bp%message = ''
      br%pts = [br%pts, bp]
      br%maps = c%maps
   end subroutine store

   !> The bifurcations between the accepted points p and q (q = p + ds along p's
   !> tangent, corrected), each located and stored before q.
   subroutine detect(c, br, p, q, ds, opt)
      type(ctx_t), intent(inout) :: c
      type(branch_t), intent(inout) :: br
      type(node_t), intent(in) :: p, q
      real(wp), intent(in) :: ds
      type(branch_options_t), intent(in) :: opt
      integer :: j
      character(len=*), parameter :: kinds(3) = [character(len=15) :: 'fold', 'period-doubling', 'neimark-sacker']
      do j = 1, 3
         if (test_fn(j, p, c%n) * test_fn(j, q, c%n) < 0.0_wp) call locate(c, br, p, q, ds, opt, j, trim(kinds(j)))
      end do
   end subroutine detect

   !> Test function j at a point: 1 fold (the tangent's lambda-component), 2
   !> period-doubling (det(M + I) = prod(1 + mu)), 3 Neimark-Sacker (|mu| - 1 of
   !> the complex pair nearest the unit circle; +-1 with none).
   real(wp) function test_fn(j, p, n) result(f)
      integer, intent(in) :: j, n
      type(node_t), intent(in) :: p
      integer :: i
      select case (j)
      case (1)
         f = p%t(n + 1)
      case (2)
         f = real(product(1.0_wp + p%mu), wp)
      case default
         f = huge(1.0_wp)
         do i = 1, size(p%mu)
            if (abs(aimag(p%mu(i))) > 1.0e-8_wp*abs(p%mu(i))) then
               if (abs(abs(p%mu(i)) - 1.0_wp) < abs(f)) f = abs(p%mu(i)) - 1.0_wp
            end if
         end do
         if (f == huge(1.0_wp)) f = -1.0_wp
      end select
   end function test_fn

   !> Locate the zero of test function j between p (sigma = 0) and q (sigma = ds)
   !> by the Illinois secant on sigma, each trial point corrected from p along p's
   !> tangent (the arclength condition t_p'(z - z_p) = sigma); stored with its kind.
   !> A trial that fails to converge ends the search at the best bracket.
   subroutine locate(c, br, p, q, ds, opt, j, kind)
      type(ctx_t), intent(inout) :: c
      type(branch_t), intent(inout) :: br
      type(node_t), intent(in) :: p, q
      real(wp), intent(in) :: ds
      type(branch_options_t), intent(in) :: opt
      integer, intent(in) :: j
      character(len=*), intent(in) :: kind
      type(node_t) :: r, best
      type(error_t), allocatable :: err
      real(wp) :: sa, sb, fa, fb, sm, fm, la, lb
      character(len=:), allocatable :: why
      integer :: it, side
      sa = 0.0_wp
      sb = ds
      fa = test_fn(j, p, c%n)
      fb = test_fn(j, q, c%n)
      la = p%z(c%n + 1)
      lb = q%z(c%n + 1)
      best = q
      side = 0
      do it = 1, 40
         sm = sb - fb*(sb - sa)/(fb - fa)
         call correct(c, p, p%z + sm*p%t, opt, r, why)
         if (len(why) == 0) call linearise(c, r, p%t, err)
         if (allocated(err) .or. len(why) > 0) exit
         fm = test_fn(j, r, c%n)
         best = r
         if (fm*fb < 0.0_wp) then
            sa = sb
            fa = fb
            la = lb
            side = 0
         else
            if (side == 1) fa = 0.5_wp*fa
            side = 1
         end if
         sb = sm
         fb = fm
         lb = r%z(c%n + 1)
         if (j == 1 .and. abs(fm) < 1.0e-9_wp) exit
         if (j /= 1 .and. abs(la - lb) < opt%lam_tol) exit
      end do
      call store(br, c, best, sm, kind, p%t, br%pts(size(br%pts))%segment)
   end subroutine locate
end module trainsim_arclength
