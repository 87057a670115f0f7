!> Restarts of a branch past a failure (D-119; docs/periodic.md "Restarts: the
!> sweep goes on"): a failed point stored with its reason, the orbit shot again further
!> on in lambda from the last orbit's state, the branch going on as a new segment.
submodule(trainsim_arclength) trainsim_arclength_restart
   implicit none

contains

   !> Whether the corrector's failure at the smallest step is at a fold it could not turn
   !> (D-174), by the fold's test functions along the branch, not by a multiplier's
   !> closeness to +1 (a damped train's slow modes sit near it without any fold): the
   !> tangent's lambda-component, and mu - 1 of each real multiplier (with the previous
   !> point's real one nearest it: the factors of det(M - I) that change its sign; a complex
   !> pair near +1 shrinks det without one), change sign where a real multiplier passes +1.
   !> Each is extrapolated linearly in arclength from the
   !> stretch's last two regular points (t_lambda is linear in arclength through a fold;
   !> short of it, where the branch bends more, the line is late): a zero within three more
   !> steps of the last one's length, and falling, is a fold ahead. note: why, in words.
   module procedure fold_ahead
      character(len=*), parameter :: names(2) = [character(len=30) :: 'the tangent''s lambda-part', &
                                                 'a real multiplier'], &
                                     ends(2) = [character(len=12) :: 'changes sign', 'reaches +1']
      real(wp), parameter :: off(2) = [0.0_wp, 1.0_wp]
      real(wp) :: f(2, 2), h, s   ! f(:, j): test j at the two points
      integer :: l, m, j
      fold = .false.
      l = last_regular(br, size(br%pts), 0)
      m = 0
      if (l > 0) m = last_regular(br, l - 1, br%pts(l)%segment)
      if (m == 0) then
         note = ' (not known to be a fold: one point in this stretch)'
         return
      end if
      h = br%pts(l)%ds
      f(:, 1) = [br%pts(m)%tangent(size(br%pts(m)%tangent)), br%pts(l)%tangent(size(br%pts(l)%tangent))]
      f(:, 2) = nearest_pair(br%pts(m)%mu, br%pts(l)%mu)
      do j = 1, 2
         if (f(1, j)*f(2, j) <= 0.0_wp .or. abs(f(2, j)) >= abs(f(1, j))) cycle
         s = h*abs(f(2, j))/(abs(f(1, j)) - abs(f(2, j)))
         if (s > 3.0_wp*h) cycle
         fold = .true.
         note = ' (a fold: '//trim(names(j))//' went from '//str(f(1, j) + off(j), 6)//' to '// &
                str(f(2, j) + off(j), 6)//' over the last step, '//str(h, 3)//', and '//trim(ends(j))//' '// &
                str(s, 3)//' further on)'
         return
      end do
      note = ' (not at a fold: neither the tangent''s lambda-part ('//str(f(1, 1), 3)//' -> '//str(f(2, 1), 3)// &
             ') nor a real multiplier heads for +1 within 3 steps of '//str(h, 3)//')'
   contains
      !> the index of the last regular point up to i (of segment seg, or any with seg 0); 0: none
      integer function last_regular(br, i, seg) result(k)
         type(branch_t), intent(in) :: br
         integer, intent(in) :: i, seg
         do k = i, 1, -1
            if (br%pts(k)%status /= branch_done) cycle
            if (seg > 0 .and. br%pts(k)%segment /= seg) exit
            if (len(br%pts(k)%kind) == 0 .and. allocated(br%pts(k)%tangent) .and. allocated(br%pts(k)%mu)) return
         end do
         k = 0
      end function last_regular
      !> (mu_a - 1, mu_b - 1) of the real multiplier mu_b of b and the real one of a nearest
      !> it, the pair whose mu_b - 1 would reach 0 first, extrapolated; (0, 0): none heads there
      function nearest_pair(a, b) result(d)
         complex(wp), intent(in) :: a(:), b(:)
         real(wp) :: d(2), da, best
         integer :: i, k
         d = 0.0_wp
         best = huge(1.0_wp)
         do i = 1, size(b)
            if (abs(aimag(b(i))) > 1.0e-8_wp*abs(b(i))) cycle
            da = huge(1.0_wp)
            do k = 1, size(a)
               if (abs(aimag(a(k))) > 1.0e-8_wp*abs(a(k))) cycle
               if (abs(real(a(k) - b(i), wp)) < abs(da - real(b(i), wp) + 1.0_wp)) da = real(a(k), wp) - 1.0_wp
            end do
            if (da == huge(1.0_wp)) cycle
            associate (db => real(b(i), wp) - 1.0_wp)
               if (da*db <= 0.0_wp .or. abs(db) >= abs(da)) cycle
               if (abs(db)/(abs(da) - abs(db)) < best) then
                  best = abs(db)/(abs(da) - abs(db))
                  d = [da, db]
               end if
            end associate
         end do
      end function nearest_pair
   end procedure fold_ahead

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

   !> The first point: the orbit shot at lam0; t0 there (moved by shooting to an
   !> instant with no memory contact in progress) kept as a phase of the period.
   module procedure start_shot
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
   end procedure start_shot

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
