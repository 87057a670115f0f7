!> Pseudo-arclength continuation of periodic orbits in a deck parameter lambda (issue 27 item 3;
!> docs/periodic.md "Continuation"; D-108).
!>
!> Unknowns z = (x, lambda): the reduced state x at the forcing phase t0 and the parameter.
!> G(x, lambda) = P(x; lambda) - x, P the period map at lambda (the problem's model retuned or
!> built there, D-131; its forcing period as shooting takes it). In the scaled variables (x/s,
!> lambda/l) A = [S^-1 (M - I) S, S^-1 dP/dlambda l], M by saltation matrices or differences
!> (D-115), dP/dlambda by a central difference of the period map.
!> The tangent t solves [A; t_prev'] t = (0, 1), normalised; the predictor is z + ds t, the
!> corrector chord Newton on [G; t'(z - z_pred)] with the bordered matrix of the last point (then
!> full Newton; each stops early where it cannot converge, D-172). Step control: halve on failure
!> (down to ds_min: the branch stops with the reason), grow by 1.5 after at most 3 corrector
!> steps (up to ds_max).
!>
!> Bifurcations between two accepted points: a fold where the lambda-component of the tangent
!> changes sign (a multiplier through +1), a period-doubling where det(M + I) does (a real
!> multiplier through -1), a Neimark-Sacker point where the number of complex multipliers outside
!> the unit circle changes. Each is located by the Illinois secant on its test function along the
!> arclength from the earlier point, to lam_tol in lambda (a fold: to a tangent lambda-component
!> below 1e-9, which puts lambda within ~1e-18/curvature of the turn).
module trainsim_arclength
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_period_map, only: period_map_t, forcing_period
   use trainsim_shooting, only: shoot_options_t, shoot_result_t, shoot, shoot_converged, monodromy_fd
   use trainsim_floquet, only: floquet_multipliers, stability_of
   use trainsim_contact_sequence, only: monodromy_stats_t, same_sequence
   use trainsim_monodromy_map, only: monodromy_map_stats, flow_signature, monodromy_choice, mono_auto, &
                                     monodromy_variational
   implicit none
   private

   public :: branch_problem_t, point_hook_i, branch_options_t, branch_point_t, branch_t, continue_branch
   public :: switch_period_doubling
   public :: branch_done, branch_no_start, branch_step_min, branch_budget, branch_failed, branch_fold, branch_stale

   !> branch_t%status, and a failed point's status (branch_point_t%status): why it stopped
   !> (or, with restarts, why a stretch of the branch ended): 1 no periodic orbit near the
   !> start, 2 the corrector failed at the smallest step (not at a fold), 3 the point
   !> budget spent, 4 an error, 5 the corrector failed at the smallest step at a fold (a
   !> fold test function heading for its sign change: a fold it could not turn, D-174); a failed
   !> point only: 6 stale, t0 in a contact that strikes within the period (not an orbit, D-188).
   integer, parameter :: branch_done = 0, branch_no_start = 1, branch_step_min = 2, branch_budget = 3, &
                         branch_failed = 4, branch_fold = 5, branch_stale = 6

   !> The deck at a parameter value: extend and give `model_at`; `retune` (optional) changes
   !> only the parameter's value in a model built at another, not building the deck (D-131).
   type, abstract :: branch_problem_t
   contains
      procedure(model_at_i), deferred :: model_at
      procedure :: retune => problem_retune
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
      !> stored as a point of kind 'grazing' and crossed with full Newton (D-115)
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
      real(wp), allocatable :: mem(:)             !< the map's memory at t0 and which it held
      logical, allocatable :: kept(:)             !< (period_map_t's mem, kept: D-150)
      complex(wp), allocatable :: mu(:)
      character(len=:), allocatable :: stability   !< stable / marginal / unstable
      character(len=:), allocatable :: kind        !< '' (a regular point), fold, period-doubling, neimark-sacker, grazing
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
      type(model_t) :: base          !< the first model `model_at` built (retuned at each lambda)
      logical :: has_base = .false., tried_base = .false.
      real(wp) :: lin_lam = huge(1.0_wp), lin_period = 0.0_wp, lin_t0 = 0.0_wp   !< the last linearisation's (`store`)
   end type ctx_t

   !> an accepted point's data for the next step
   type :: node_t
      real(wp), allocatable :: z(:), px(:), a(:, :), t(:), m(:, :)
      complex(wp), allocatable :: mu(:)
      integer :: corrector = 0, stale = 0   !< stale: `stale_check` (D-188)
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

   interface
      module subroutine rephase_point(c, br, cur, moved, err)
         type(ctx_t), intent(inout) :: c
         type(branch_t), intent(inout) :: br
         type(node_t), intent(inout) :: cur
         logical, intent(out) :: moved
         type(error_t), allocatable, intent(out) :: err
      end subroutine rephase_point
      module subroutine t0_to_open(c, z, x, moved, err)
         type(ctx_t), intent(inout) :: c
         real(wp), intent(in) :: z(:)
         real(wp), intent(out) :: x(:)
         logical, intent(out) :: moved
         type(error_t), allocatable, intent(out) :: err
      end subroutine t0_to_open
      module logical function closed_loop(br, before, c) result(closed)
         type(branch_t), intent(in) :: br
         integer, intent(in) :: before
         type(ctx_t), intent(in) :: c
      end function closed_loop
      module subroutine cross_grazing(c, br, p, q, ds, opt)
         type(ctx_t), intent(inout) :: c
         type(branch_t), intent(inout) :: br
         type(node_t), intent(in) :: p
         type(node_t), intent(inout) :: q
         real(wp), intent(in) :: ds
         type(branch_options_t), intent(in) :: opt
      end subroutine cross_grazing
      module subroutine detect(c, br, p, q, ds, opt)
         type(ctx_t), intent(inout) :: c
         type(branch_t), intent(inout) :: br
         type(node_t), intent(in) :: p, q
         real(wp), intent(in) :: ds
         type(branch_options_t), intent(in) :: opt
      end subroutine detect
      module subroutine start_resumed(c, resume, opt, br, cur, t_prev, ds, err)
         type(ctx_t), intent(inout) :: c
         type(branch_t), intent(in) :: resume
         type(branch_options_t), intent(in) :: opt
         type(branch_t), intent(inout) :: br
         type(node_t), intent(out) :: cur
         real(wp), allocatable, intent(out) :: t_prev(:)
         real(wp), intent(out) :: ds
         type(error_t), allocatable, intent(out) :: err
      end subroutine start_resumed
      module subroutine at(c, lam, err)
         type(ctx_t), intent(inout) :: c
         real(wp), intent(in) :: lam
         type(error_t), allocatable, intent(out) :: err
      end subroutine at
      module subroutine evaluate(c, z, px, why, err)
         type(ctx_t), intent(inout) :: c
         real(wp), intent(in) :: z(:)
         real(wp), allocatable, intent(out) :: px(:)
         character(len=:), allocatable, intent(out) :: why
         type(error_t), allocatable, intent(out) :: err
      end subroutine evaluate
      module subroutine linearise(c, p, t_prev, err)
         type(ctx_t), intent(inout) :: c
         type(node_t), intent(inout) :: p
         real(wp), intent(in) :: t_prev(:)
         type(error_t), allocatable, intent(out) :: err
      end subroutine linearise
      module subroutine correct(c, p, z_pred, opt, q, why, full, px_pred)
         type(ctx_t), intent(inout) :: c
         type(node_t), intent(in) :: p
         real(wp), intent(in) :: z_pred(:)
         type(branch_options_t), intent(in) :: opt
         type(node_t), intent(out) :: q
         character(len=:), allocatable, intent(out) :: why
         logical, intent(in), optional :: full
         real(wp), allocatable, intent(inout), optional :: px_pred(:)
      end subroutine correct
      module subroutine store(br, c, p, ds, kind, border, segment)
         type(branch_t), intent(inout) :: br
         type(ctx_t), intent(inout) :: c
         type(node_t), intent(in) :: p
         real(wp), intent(in) :: ds, border(:)
         character(len=*), intent(in) :: kind
         integer, intent(in) :: segment
      end subroutine store
   end interface

   !> Restarts past a failure and failed points, the first point shot (trainsim_arclength_restart.f90,
   !> D-119); stale points and their release (trainsim_arclength_release.f90, D-188)
   interface
      module subroutine start_shot(c, lam0, opt, br, cur, t_prev, ds, err)
         type(ctx_t), intent(inout) :: c
         real(wp), intent(in) :: lam0
         type(branch_options_t), intent(in) :: opt
         type(branch_t), intent(inout) :: br
         type(node_t), intent(out) :: cur
         real(wp), allocatable, intent(out) :: t_prev(:)
         real(wp), intent(out) :: ds
         type(error_t), allocatable, intent(out) :: err
      end subroutine start_shot
      module subroutine stale_check(c, q)
         type(ctx_t), intent(inout) :: c
         type(node_t), intent(inout) :: q
      end subroutine stale_check
      module subroutine release(c, opt, br, cur_stale, before, q, restarts, released, err)
         type(ctx_t), intent(inout) :: c
         type(branch_options_t), intent(in) :: opt
         type(branch_t), intent(inout) :: br
         logical, intent(in) :: cur_stale
         integer, intent(in) :: before
         type(node_t), intent(inout) :: q
         integer, intent(in) :: restarts
         logical, intent(out) :: released
         type(error_t), allocatable, intent(out) :: err
      end subroutine release
      module subroutine fold_ahead(br, fold, note)
         type(branch_t), intent(in) :: br
         logical, intent(out) :: fold
         character(len=:), allocatable, intent(out) :: note
      end subroutine fold_ahead
      module subroutine restart(c, opt, br, cur, ds, restarts, err)
         type(ctx_t), intent(inout) :: c
         type(branch_options_t), intent(in) :: opt
         type(branch_t), intent(inout) :: br
         type(node_t), intent(inout) :: cur
         real(wp), intent(inout) :: ds
         integer, intent(inout) :: restarts
         type(error_t), allocatable, intent(out) :: err
      end subroutine restart
      module subroutine failed_point(br, lam, status, message)
         type(branch_t), intent(inout) :: br
         real(wp), intent(in) :: lam
         integer, intent(in) :: status
         character(len=*), intent(in) :: message
      end subroutine failed_point
   end interface

contains

   subroutine problem_retune(self, lam, model, done, err)   !< the default: not done (`model_at` builds it)
      class(branch_problem_t), intent(in) :: self
      real(wp), intent(in) :: lam
      type(model_t), intent(inout) :: model
      logical, intent(out) :: done
      type(error_t), allocatable, intent(out) :: err
      associate (unused => self, unused_lam => lam, unused_model => model); end associate
      done = .false.
   end subroutine problem_retune

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
         call report_points(br, stored, err, hook)
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
   end subroutine continue_branch

   !> Branch switching at the period-doubling point br%pts(ipd): the doubled branch
   !> (2k forcing periods per orbit) from that point, whose P^2 has the multiplier +1
   !> with M's eigenvector v for -1 (inverse iteration on S^-1 (M^2 - I) S): the
   !> first point by full Newton on the hyperplane v'(z - z_pd - ds v) = 0 (the
   !> period-k branch crosses it far away: its tangent is across v), then the
   !> continuation as `continue_branch` (opt%k is the period-k branch's). br2%status
   !> branch_no_start when no doubled orbit is found down to ds_min.
   subroutine switch_period_doubling(prob, br, ipd, opt, br2, err, hook)
      class(branch_problem_t), intent(in) :: prob
      type(branch_t), intent(in) :: br
      integer, intent(in) :: ipd
      type(branch_options_t), intent(in) :: opt
      type(branch_t), intent(out) :: br2
      type(error_t), allocatable, intent(out) :: err
      procedure(point_hook_i), optional :: hook
      type(ctx_t) :: c
      type(node_t) :: cur, nxt
      real(wp), allocatable :: b(:, :), v(:), t_dir(:)
      integer, allocatable :: ipiv(:)
      character(len=:), allocatable :: why
      real(wp) :: ds
      integer :: n, it, info, stored, i, restarts
      allocate (c%prob, source=prob)
      allocate (br2%pts(0))
      c%sig = opt%nonsmooth
      c%k = 2*opt%k
      c%fd = opt%fd_lam
      c%s = br%scale
      c%ls = br%lam_scale
      c%phase = br%phase
      associate (p => br%pts(ipd))
         call at(c, p%lam, err)                          ! (for t_start)
         if (allocated(err)) return
         c%phase = (p%t0 - c%t_start)/p%period          ! its own t0
         c%lam = huge(1.0_wp)
         call at(c, p%lam, err)
         if (allocated(err)) return
         call monodromy_choice(opt%monodromy, c%pm%model, c%salt, err)
         if (allocated(err)) return
         n = c%pm%n
         c%n = n
         br2%scale = c%s
         br2%lam_scale = c%ls
         br2%phase = c%phase
         cur%z = [p%x/c%s, p%lam/c%ls]
      end associate
      call evaluate(c, cur%z, cur%px, why, err)
      if (.not. allocated(err) .and. len(why) > 0) call fatal_error(err, 'the period-doubling point: '//why, err_input)
      if (allocated(err)) return
      allocate (t_dir(n + 1), v(n), ipiv(n))
      t_dir = 0.0_wp
      t_dir(n + 1) = 1.0_wp
      call linearise(c, cur, t_dir, err)
      if (allocated(err) .and. allocated(cur%a)) deallocate (err)   ! (the bordered system is singular there)
      if (allocated(err)) return
      v = 1.0_wp/sqrt(real(n, wp))
      do it = 1, 4   ! inverse iteration: the null vector of S^-1 (M^2 - I) S
         b = cur%a(:, 1:n)
         do i = 1, n
            b(i, i) = b(i, i) + 1.0e-9_wp
         end do
         call dgesv(n, 1, b, n, ipiv, v, n, info)
         if (info /= 0) exit
         v = v/norm2(v)
      end do
      cur%t = [v, 0.0_wp]
      call store(br2, c, cur, 0.0_wp, 'period-doubling', cur%t, 1)
      ds = opt%ds
      do
         call correct(c, cur, cur%z + ds*cur%t, opt, nxt, why, full=.true.)
         if (len(why) == 0) then
            call linearise(c, nxt, cur%t, err)
            if (allocated(err)) then
               why = err%message
               deallocate (err)
            end if
         end if
         if (len(why) == 0) exit
         if (ds <= opt%ds_min) then
            br2%status = branch_no_start
            br2%message = 'no period-doubled orbit found next to lambda = '//str(br%pts(ipd)%lam, 10)//': '//why
            br2%maps = c%maps
            return
         end if
         ds = max(0.5_wp*ds, opt%ds_min)
      end do
      call store(br2, c, nxt, ds, '', cur%t, 1)
      cur = nxt
      br2%pts(size(br2%pts))%ds_next = ds
      stored = 0
      restarts = 0
      call follow(c, br2, cur, ds, opt, stored, restarts, err, hook)
   end subroutine switch_period_doubling

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
      character(len=:), allocatable :: why, note
      real(wp), allocatable :: px_pred(:)
      logical :: crossed, rephased, fold, cur_stale, released
      integer :: before
      rephased = .false.
      cur_stale = .false.
      do
         call report_points(br, stored, err, hook)
         if (allocated(err)) return
         if (size(br%pts) >= opt%max_points) then
            br%status = branch_budget
            br%message = 'the budget of '//str(opt%max_points)//' points was spent at lambda = '// &
                         str(cur%z(c%n + 1)*c%ls, 10)
            exit
         end if
         call correct(c, cur, cur%z + ds*cur%t, opt, nxt, why, px_pred=px_pred)
         if (len(why) > 0 .and. opt%nonsmooth) call correct(c, cur, cur%z + ds*cur%t, opt, nxt, why, .true., px_pred)
         crossed = .false.
         if (len(why) == 0) then
            call linearise(c, nxt, cur%t, err)
            if (allocated(err)) then
               why = err%message
               deallocate (err)
            end if
            if (len(why) == 0 .and. opt%nonsmooth) call stale_check(c, nxt)   ! (after its last map: D-188)
         end if
         if (opt%nonsmooth .and. .not. rephased) then
            ! a memory contact reaching t0 (odd events) or a failed step: move t0 first
            if (len(why) > 0 .or. modulo(nxt%st%events, 2) /= 0) then
               call rephase_point(c, br, cur, rephased, err)
               if (allocated(err)) return
               if (rephased) cycle
            end if
         end if
         before = size(br%pts)
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
               call fold_ahead(br, fold, note)
               br%status = merge(branch_fold, branch_step_min, fold)
               br%message = 'the step reached its minimum '//str(opt%ds_min, 3)//' at lambda = '// &
                            str(cur%z(c%n + 1)*c%ls, 10)//note//' and the corrector still failed: '//why
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
         if (.not. crossed) call detect(c, br, cur, nxt, ds, opt)
         if (closed_loop(br, before, c)) then
            br%status = branch_done
            br%message = 'the branch closed on itself: the '//br%pts(size(br%pts))%kind//' point at lambda = '// &
                         str(br%pts(size(br%pts))%lam, 10)//' was met before'
            exit
         end if
         released = .false.
         if (nxt%stale > 0) then   ! (not an orbit of the train: a failed point, released if it can be)
            call release(c, opt, br, cur_stale, before, nxt, restarts, released, err)
            if (allocated(err)) return
            if (released) br%pts(size(br%pts))%ds = ds   ! (its step along the stale map: fold_ahead's h)
         else
            call store(br, c, nxt, ds, '', cur%t, restarts + 1)
         end if
         cur_stale = nxt%stale > 0
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
      call report_points(br, stored, err, hook)
      if (.not. allocated(err) .and. present(hook)) call hook(br, 0, err)
   end subroutine follow

   !> The points of br after `stored` given to `hook` (if present), in order.
   subroutine report_points(br, stored, err, hook)
      type(branch_t), intent(in) :: br
      integer, intent(inout) :: stored
      type(error_t), allocatable, intent(inout) :: err
      procedure(point_hook_i), optional :: hook
      if (.not. present(hook)) return
      do while (stored < size(br%pts))
         stored = stored + 1
         call hook(br, stored, err)
         if (allocated(err)) return
      end do
   end subroutine report_points
end module trainsim_arclength
