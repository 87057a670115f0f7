!> Restarts of a branch past a failure (D-119; docs/periodic.md "Restarts: the
!> sweep goes on"): a failed point stored with its reason, the orbit shot again further
!> on in lambda from the last orbit's state, the branch going on as a new segment.
submodule(trainsim_arclength) trainsim_arclength_restart
   implicit none

contains

   !> A fold at p: a real multiplier within 0.05 of +1, or the tangent nearly normal
   !> to lambda (|t_lambda| < 0.05).
   module logical function at_fold(p, n)
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
   module subroutine restart(c, opt, br, cur, ds, restarts, err)
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
   module subroutine failed_point(br, lam, status, message)
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
end submodule trainsim_arclength_restart
