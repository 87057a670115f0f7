!> The saltation monodromy in shooting and the non-smooth continuation (issue 27;
!> docs/periodic.md "Through contact-sequence changes"; D-115).
!>
!> 1. Shooting with the monodromy from the variational equations with saltation
!>    matrices against central differences, on the Table 5.5 rig (shafts damped, 485
!>    teeth/s) and the Table 7.1 two-clearance train (260 teeth/s): the same orbit (both
!>    converge to 1e-10 of the state scale: 1e-8 asserted), the monodromy matrices
!>    equal to 1e-6 (issue 27's bar for M against differences; the differences' own
!>    error is ~1e-8, docs/periodic.md), Newton in fewer period maps.
!> 2. The damped rig continued in the mesh frequency from 645 teeth/s downward: the
!>    corrector used to stall at 503.565 teeth/s; the branch now passes it, reports
!>    the grazing where the teeth first separate, turns at two folds (the jumps) with
!>    only unstable points between them, and stable points (near 600 teeth/s, above the
!>    band, and near 450, inside it) equal brute-force runs from the deck's start settled
!>    until periodic (settle_tol 1e-8, then the contraction's window) to 1e-6 of the state
!>    scale. Brute force across each fold: a run started
!>    on the stable orbit next to a fold, 0.1 % beyond it, leaves it (a jump) - so the
!>    folds lie where the brute-force hysteresis band ends. The two stable stretches
!>    join at a change of the contact sequence (per guard and order, D-121) near 394.28
!>    teeth/s, located from each of them, where the branch closes on itself.
module nonsmooth_rig_problem
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_deck, only: deck_t
   use trainsim_arclength, only: branch_problem_t
   use trainsim_test_support, only: damped_rig_model
   implicit none
   private
   public :: rig_problem_t

   !> the Table 5.5 rig, shafts damped, at mesh frequency lambda (teeth/s)
   type, extends(branch_problem_t) :: rig_problem_t
      type(deck_t) :: deck
   contains
      procedure :: model_at => rig_model_at
   end type rig_problem_t

contains

   subroutine rig_model_at(self, lam, model, err)
      class(rig_problem_t), intent(in) :: self
      real(wp), intent(in) :: lam
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      call damped_rig_model(self%deck, lam, model, err)
   end subroutine rig_model_at
end module nonsmooth_rig_problem

program test_nonsmooth_continuation
   use nonsmooth_rig_problem, only: rig_problem_t
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_deck, only: read_deck
   use trainsim_observer, only: run_result_t
   use trainsim_period_map, only: period_map_t, forcing_period
   use trainsim_shooting, only: shoot_options_t, shoot_result_t, shoot, shoot_converged
   use trainsim_monodromy_map, only: monodromy_variational
   use trainsim_arclength, only: branch_options_t, branch_t, branch_point_t, continue_branch, branch_done
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, run_model
   implicit none

   type(rig_problem_t) :: rig
   type(error_t), allocatable :: err

   call suite_begin('saltation monodromy in shooting; continuation through contact-sequence changes')
   call read_deck('inputs/gregory_harris_munro.nml', rig%deck, err)
   if (allocated(err)) error stop 'cannot read inputs/gregory_harris_munro.nml'
   call test_saltation_equals_differences_in_shooting()
   call test_rig_branch_through_grazing_to_the_folds()
   call suite_end()

contains

   !> Shooting with both monodromies on the damped rig and the two-clearance train.
   subroutine test_saltation_equals_differences_in_shooting()
      type(model_t) :: m
      call test_begin('saltation_equals_differences_in_shooting')
      call rig%model_at(485.0_wp, m, err)
      call check('the damped rig at 485 teeth/s', .not. allocated(err))
      call compare_monodromies('rig', m)
      call load_model('inputs/two_clearance.nml', m)
      call compare_monodromies('two-clearance train', m)
   end subroutine test_saltation_equals_differences_in_shooting

   subroutine compare_monodromies(what, m)
      character(len=*), intent(in) :: what
      type(model_t), intent(in) :: m
      type(period_map_t) :: pm
      type(shoot_options_t) :: opt
      type(shoot_result_t) :: rf, rs
      real(wp) :: period, dx, dm
      real(wp), allocatable :: s(:)
      integer :: i
      call forcing_period(m, period, err)
      call pm%setup(m, period, 1, err)
      call shoot(pm, opt, rf, err)
      call check(what//': shooting with differences converged', .not. allocated(err) .and. rf%status == shoot_converged)
      call pm%setup(m, period, 1, err)
      call shoot(pm, opt, rs, err, monodromy=monodromy_variational)
      call check(what//': shooting with saltation converged', .not. allocated(err) .and. rs%status == shoot_converged)
      if (rf%status /= shoot_converged .or. rs%status /= shoot_converged) return
      s = rf%scale
      dx = maxval(abs(rf%x - rs%x)/s)
      dm = 0.0_wp
      do i = 1, size(s)
         dm = max(dm, maxval(abs(rf%m(i, :) - rs%m(i, :))*s/s(i)))
      end do
      dm = dm/maxval([(maxval(abs(rf%m(i, :))*s/s(i)), i=1, size(s))])
      write (*, '(4x,a,2(a,i0),a,2(i0,a),2(a,es9.2))') what, ': Newton steps ', rf%newton, ' / ', rs%newton, &
         ', period maps ', rf%maps, ' (differences) / ', rs%maps, ' (saltation)', '; orbits differ by ', dx, &
         ', monodromies by ', dm
      call check(what//': the same orbit (1e-8 of the scale): '//str(dx, 3), dx <= 1.0e-8_wp)
      call check(what//': the same monodromy (1e-6): '//str(dm, 3), dm <= 1.0e-6_wp)
      call check(what//': fewer period maps with saltation', rs%maps < rf%maps)
      call pm%finish()
   end subroutine compare_monodromies

   !> The damped rig's branch from 645 teeth/s down.
   subroutine test_rig_branch_through_grazing_to_the_folds()
      type(branch_options_t) :: opt
      type(branch_t) :: br
      integer :: i, nf, ng, f(2), i600, i540, below
      logical :: mid_unstable, first_stable
      call test_begin('rig_branch_through_grazing_to_the_folds')
      opt%lam_min = 385.0_wp
      opt%lam_max = 645.0_wp
      opt%direction = -1
      call continue_branch(rig, 645.0_wp, opt, br, err)
      call check('the branch ran', .not. allocated(err))
      if (allocated(err)) return
      write (*, '(4x,i0,a,i0,a,i0,a,a)') size(br%pts), ' points, ', br%maps, ' period maps, ', br%passes, &
         ' variational passes; status: ', br%message
      call check('the branch ended by itself (status '//str(br%status)//')', br%status == branch_done)
      nf = 0
      ng = 0
      do i = 1, size(br%pts)
         if (br%pts(i)%kind == 'grazing') ng = ng + 1
         if (br%pts(i)%kind == 'fold' .and. nf < 2) then
            nf = nf + 1
            f(nf) = i
         end if
      end do
      call check('a grazing point reported', ng >= 1)
      call check('two folds (got '//str(nf)//')', nf == 2)
      if (nf < 2) return
      write (*, '(4x,a,2f16.9,a)') 'folds at ', br%pts(f(1))%lam, br%pts(f(2))%lam, ' teeth/s'
      below = count(br%pts(1:f(1))%lam < 503.5_wp)
      call check('the first segment passes 503.565 teeth/s ('//str(below)//' points below 503.5)', below >= 3)
      ! (failed points apart: the stale points after the grazing at 555.12 and on the unstable
      ! stretch, each followed by its released orbit, D-188)
      first_stable = all([(br%pts(i)%stability == 'stable' .or. br%pts(i)%kind == 'grazing' .or. &
                           br%pts(i)%status /= branch_done, i=1, f(1) - 1)])
      mid_unstable = all([(br%pts(i)%stability == 'unstable' .or. br%pts(i)%kind /= '' .or. &
                           br%pts(i)%status /= branch_done, i=f(1) + 1, f(2) - 1)])
      call check('stable down to the first fold', first_stable)
      call check('unstable between the folds', mid_unstable .and. f(2) > f(1) + 3)
      call check('the folds: jump-down below jump-up', br%pts(f(1))%lam < br%pts(f(2))%lam)
      i600 = nearest_point(br%pts(1:f(1)), 600.0_wp)
      i540 = nearest_point(br%pts(1:f(1)), 450.0_wp)
      call settled_equals_point(br%pts(i600))
      call settled_equals_point(br%pts(i540))
      call jumps_beyond_fold(br, f(1), -1.0e-3_wp)
      call jumps_beyond_fold(br, f(2), 1.0e-3_wp)
      call stretches_join_at_a_sequence_change(br, f(1))
   end subroutine test_rig_branch_through_grazing_to_the_folds

   !> The two stable stretches (645 down to the fold f1 at 392.43, and back down from
   !> the fold at 534.17) join where the contact sequence (guards and their order)
   !> changes near 394.28 teeth/s: located on the first stretch with stable points on
   !> both sides, and again, independently (bisection from the other stretch), where
   !> the branch ends closed on itself: the same lambda to the location tolerance
   !> (1e-7 |lambda_0|), the same orbit (the second visit's state carried onto the
   !> first's orbit: 1e-5 of the scale, the orbit's change over that lambda
   !> tolerance), and the fold f1 is not met twice.
   subroutine stretches_join_at_a_sequence_change(br, f1)
      type(branch_t), intent(in) :: br
      integer, intent(in) :: f1
      type(model_t) :: m
      type(period_map_t) :: pm
      real(wp) :: period, d
      integer :: i, j, nl
      j = 0
      do i = 2, f1 - 1
         if (br%pts(i)%kind == 'grazing' .and. br%pts(i)%lam < 400.0_wp) j = i
      end do
      call check('a contact-sequence change on the first stretch between the fold and 400 teeth/s', j > 0)
      if (j == 0) return
      nl = size(br%pts)
      write (*, '(4x,a,2f16.9,a)') 'the stretches join at ', br%pts(j)%lam, br%pts(nl)%lam, ' teeth/s'
      call check('stable on both sides of it', br%pts(j - 1)%stability == 'stable' .and. &
                 br%pts(j + 1)%stability == 'stable')
      call check('the branch ends at a grazing point', br%pts(nl)%kind == 'grazing' .and. nl > f1 + 3)
      call check('closed on itself there', index(br%message, 'closed on itself') > 0)
      call check('the same lambda (1e-7 of 645)', abs(br%pts(nl)%lam - br%pts(j)%lam) <= 1.0e-7_wp*645.0_wp)
      call check('the fold at 392.43 met once', count([(br%pts(i)%kind == 'fold' .and. br%pts(i)%lam < 400.0_wp, &
                                                         i=1, nl)]) == 1)
      call map_at_point(br%pts(j), m, pm, period)
      d = distance_to_orbit(pm, br%pts(j), br%pts(nl)%x, br%pts(nl)%t0)
      write (*, '(4x,a,es9.2,a)') 'the second visit is ', d, ' of the scale from the first visit''s orbit'
      call check('the same orbit (1e-5 of the scale)', d <= 1.0e-5_wp)
      call pm%finish()
   end subroutine stretches_join_at_a_sequence_change

   integer function nearest_point(pts, lam) result(k)
      type(branch_point_t), intent(in) :: pts(:)
      real(wp), intent(in) :: lam
      k = minloc(abs(pts%lam - lam), dim=1)
   end function nearest_point

   !> The period map at lambda (default the point's own) at the point's phase of the
   !> forcing (its t0 at its own lambda); period: the forcing period there.
   subroutine map_at_point(p, m, pm, period, lam)
      type(branch_point_t), intent(in) :: p
      type(model_t), intent(out) :: m
      type(period_map_t), intent(inout) :: pm
      real(wp), intent(out) :: period
      real(wp), intent(in), optional :: lam
      real(wp) :: phase
      call rig%model_at(p%lam, m, err)
      phase = (p%t0 - m%run%t_start)/p%period
      if (present(lam)) call rig%model_at(lam, m, err)
      call forcing_period(m, period, err)
      m%run%t_start = m%run%t_start + phase*period
      call pm%setup(m, period, 1, err)
   end subroutine map_at_point

   !> A run from the deck's initial state settled until periodic (settle_tol 1e-8),
   !> then N more periods with |mu|^N <= (1 - |mu|)/10 (test_periodic's window), ends
   !> on the branch point's orbit: its reduced state to 1e-6 of the scale.
   subroutine settled_equals_point(p)
      type(branch_point_t), intent(in) :: p
      type(model_t) :: m
      type(period_map_t) :: pm
      type(run_result_t) :: run
      real(wp) :: mu, d, period
      integer :: nper
      call map_at_point(p, m, pm, period)
      mu = maxval(abs(p%mu))
      nper = ceiling(log(0.1_wp*(1.0_wp - mu))/log(mu)) + 1
      m%run%settle_tol = 1.0e-8_wp
      m%run%settle_period = p%period
      m%run%settle_time = 20.0_wp*p%period
      m%run%settle_max_time = 12000.0_wp*p%period   ! (|mu| 0.997: ~7000 periods from O(1) to 1e-8)
      m%run%t_end = m%run%t_start + m%run%settle_time + real(nper, wp)*p%period
      m%run%output_interval = p%period/16.0_wp
      call run_model(m, run)
      d = distance_to_orbit(pm, p, run%y_final, run%t_final)
      write (*, '(4x,a,f12.6,a,i0,a,es9.2)') 'settled run at ', p%lam, ' teeth/s (window ', nper, &
         ' periods): distance to the branch orbit ', d
      call check('settled at '//str(p%lam, 8)//' (status 1)', run%stats%settle_status == 1)
      call check('the settled run ends on the branch orbit (1e-6 of the scale)', d <= 1.0e-6_wp)
      call pm%finish()
   end subroutine settled_equals_point

   !> The reduced-state distance (of the scale) of the state y at t from the orbit of
   !> p carried to t's phase.
   real(wp) function distance_to_orbit(pm, p, y, t) result(d)
      type(period_map_t), intent(inout) :: pm
      type(branch_point_t), intent(in) :: p
      real(wp), intent(in) :: y(:), t
      real(wp) :: tau, yo(size(pm%y0)), x(pm%n)
      tau = modulo(t - p%t0, p%period)
      call pm%flow(p%x, tau, yo, err)
      x = y(1:pm%n)
      x(pm%ang) = x(pm%ang) - pm%w*(t - p%t0 - tau)   ! the rigid rotation over the whole periods between
      d = maxval(abs(x - yo(1:pm%n))/pm%scale(p%x))
   end function distance_to_orbit

   !> Brute force across a fold: the stable branch point next to fold f (on the side
   !> before it), run at lambda_fold (1 + rel) - beyond the fold - for 3000 periods
   !> from that orbit's state, ends far from it (1e-3 of the scale): no orbit there,
   !> the run jumps.
   subroutine jumps_beyond_fold(br, f, rel)
      type(branch_t), intent(in) :: br
      integer, intent(in) :: f
      real(wp), intent(in) :: rel
      type(model_t) :: m
      type(period_map_t) :: pm
      real(wp) :: x(size(br%pts(f)%x)), d, lam, period
      integer :: j
      j = f
      do while (j > 1)
         j = j - 1
         if (br%pts(j)%stability == 'stable') exit
      end do
      if (f > 1 .and. br%pts(f - 1)%stability /= 'stable') then   ! the stable side is after the fold
         j = f
         do while (j < size(br%pts))
            j = j + 1
            if (br%pts(j)%stability == 'stable') exit
         end do
      end if
      lam = br%pts(f)%lam*(1.0_wp + rel)
      call map_at_point(br%pts(j), m, pm, period, lam)
      call pm%map(br%pts(j)%x, x, err, periods=3000)
      call check('the run beyond the fold ran', .not. allocated(err))
      d = maxval(abs(x - br%pts(j)%x)/pm%scale(br%pts(j)%x))
      write (*, '(4x,a,f12.6,a,f12.6,a,es9.2)') 'from the stable orbit at ', br%pts(j)%lam, ', 3000 periods at ', &
         lam, ' teeth/s: moved by ', d
      call check('beyond the fold at '//str(br%pts(f)%lam, 9)//' the run leaves the branch (a jump)', d > 1.0e-3_wp)
      call pm%finish()
   end subroutine jumps_beyond_fold
end program test_nonsmooth_continuation
