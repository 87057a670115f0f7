!> Every point a continuation stores as an orbit is a periodic orbit of the train at its
!> own parameter (issue 27, D-188).
!>
!> Table 7.1 (inputs/sweep_two_clearance.nml) with 500 lb in s/rad on shafts 1, 3, 5,
!> continued in mesh1's frequency from 450 teeth/s down to 385: both meshes keep contact
!> from 450 (their memory, yang_sun's D = 0 of the start, held at t0), mesh1 begins to
!> strike at the grazing 433.2506 and mesh2 at 426.656. With t0 left inside mesh1's
!> contact, the map restarted that contact at t0 with the held D = 0 while its impact
!> within the period sets D(V_i): 7d9a978 stored 10 such points in 433.23 ... 389.04 as
!> orbits (a warning at the branch's end, D-144).
!>
!> The check, for each stored regular point: the train's period map from its state x at
!> its t0, with the memory the orbit itself carries there (the memory at the end of one
!> period from x, every memory contact held: a contact closed at t0 goes on with it, as
!> in a run), G = P(x) - x in the branch's scale; |G|_inf must be below the corrector's
!> tolerance (1e-10). A stale point's is ~1e-4 (measured on 7d9a978: the test fails
!> there); an orbit with t0 in an open stretch of every striking contact, or whose
!> contacts never open, repeats its memory, and its G is the corrector's residual.
!> Also asserted: the stale points are stored as failed points of reason 6, and where t0
!> moved into the open stretch gives an orbit by Newton at the same lambda (396.02 and
!> 389.04 teeth/s) that orbit is stored after its stale point.
module t71_problem
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_deck, only: deck_t
   use trainsim_arclength, only: branch_problem_t
   use trainsim_test_support, only: model_with_sets
   implicit none
   private
   public :: t71_problem_t

   !> Table 7.1, shafts 1, 3, 5 damped 500 lb in s/rad, at mesh1's frequency lambda (teeth/s)
   type, extends(branch_problem_t) :: t71_problem_t
      type(deck_t) :: deck
   contains
      procedure :: model_at => t71_model_at
   end type t71_problem_t

contains

   subroutine t71_model_at(self, lam, model, err)
      class(t71_problem_t), intent(in) :: self
      real(wp), intent(in) :: lam
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      call model_with_sets(self%deck, [character(len=18) :: 'shaft1.damping=500', 'shaft3.damping=500', &
                           'shaft5.damping=500'], 'mesh1.mesh_frequency', lam, model, err)
   end subroutine t71_model_at
end module t71_problem

program test_branch_orbits
   use t71_problem, only: t71_problem_t
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_deck, only: deck_t, read_deck, deck_group_t
   use trainsim_overrides, only: split_sweep_groups
   use trainsim_period_map, only: period_map_t, forcing_period
   use trainsim_arclength, only: branch_options_t, branch_t, continue_branch, branch_done
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   implicit none

   type(t71_problem_t) :: prob
   type(error_t), allocatable :: err
   type(deck_group_t), allocatable :: sweeps(:)

   call suite_begin('stored branch points are orbits of the train (D-188)')
   call read_deck('inputs/sweep_two_clearance.nml', prob%deck, err)
   if (allocated(err)) error stop 'cannot read inputs/sweep_two_clearance.nml'
   call split_sweep_groups(prob%deck, sweeps)
   call test_table7_1_down_stores_orbits_only()
   call suite_end()

contains


   subroutine test_table7_1_down_stores_orbits_only()
      type(branch_options_t) :: opt
      type(branch_t) :: br
      real(wp) :: g, worst
      integer :: i, n_orbits, n_bad, n_stale, n_jump
      call test_begin('table7_1_down_stores_orbits_only')
      opt%lam_min = 385.0_wp
      opt%lam_max = 450.0_wp
      opt%direction = -1
      call continue_branch(prob, 450.0_wp, opt, br, err)
      call check('the branch ran', .not. allocated(err))
      if (allocated(err)) return
      write (*, '(4x,i0,a,i0,a,a)') size(br%pts), ' points, ', br%maps, ' period maps; status: ', br%message
      worst = 0.0_wp
      n_orbits = 0
      n_bad = 0
      n_stale = 0
      n_jump = 0
      do i = 1, size(br%pts)
         associate (p => br%pts(i))
            if (p%status /= branch_done) then
               write (*, '(4x,f12.6,a,i0,a)') p%lam, '  failed (reason ', p%status, '): '//p%message
               if (p%status == 6) n_stale = n_stale + 1   ! (branch_stale)
               if (i < size(br%pts)) then
                  if (br%pts(i + 1)%status == branch_done .and. br%pts(i + 1)%lam == p%lam) n_jump = n_jump + 1
               end if
               cycle
            end if
            g = train_residual(br, i)
            n_orbits = n_orbits + 1
            worst = max(worst, g)
            write (*, '(4x,f12.6,a,es9.2,a,es9.2,a,i0,2a)') p%lam, '  |G| ', g, ' (corrector ', p%residual, &
               ') segment ', p%segment, '  ', p%kind
            if (.not. g <= opt%tol) n_bad = n_bad + 1
         end associate
      end do
      call check(str(n_bad)//' of '//str(n_orbits)//' stored orbits have |P(x) - x| above the tolerance '// &
                 str(opt%tol, 3)//' with their own memory (worst '//str(worst, 3)//')', n_bad == 0 .and. n_orbits >= 8)
      call check('the branch left its range (status '//str(br%status)//')', br%status == branch_done)
      call check(str(n_stale)//' stale points stored as failed points (reason 6)', n_stale >= 1)
      call check(str(n_jump)//' stale points released: the orbit at the same lambda, t0 moved, stored next', &
                 n_jump >= 2)
      call check('orbits below the grazings', count(br%pts%status == branch_done .and. br%pts%lam < 426.0_wp) >= 2)
   end subroutine test_table7_1_down_stores_orbits_only

   !> |P(x) - x|_inf / s of point i, P the train's period map at the point's lambda from its
   !> t0 with the orbit's own memory at t0 (the memory after one period from x, held on
   !> every memory contact closed at t0).
   real(wp) function train_residual(br, i) result(g)
      type(branch_t), intent(in) :: br
      integer, intent(in) :: i
      type(model_t) :: m
      type(period_map_t) :: pm
      real(wp) :: period, phase
      real(wp), allocatable :: x1(:)
      g = huge(1.0_wp)
      associate (p => br%pts(i))
         call prob%model_at(p%lam, m, err)
         if (.not. allocated(err)) call forcing_period(m, period, err)
         if (allocated(err)) return
         phase = (p%t0 - m%run%t_start)/p%period
         m%run%t_start = m%run%t_start + phase*period
         call pm%setup(m, period, 1, err)
         if (allocated(err)) return
         if (allocated(p%mem)) then
            if (size(p%mem) == size(pm%mem)) pm%mem = p%mem
         end if
         pm%kept = .true.
         allocate (x1(size(p%x)))
         call pm%map(p%x, x1, err, carry=.true.)   ! (the memory the orbit carries at t0)
         if (.not. allocated(err)) call pm%map(p%x, x1, err)
         if (.not. allocated(err)) g = maxval(abs(x1 - p%x)/br%scale)
         call pm%finish()
      end associate
   end function train_residual
end program test_branch_orbits
