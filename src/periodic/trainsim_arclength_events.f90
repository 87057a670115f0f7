!> The steps of trainsim_arclength's continuation (its submodule; docs/periodic.md
!> "Continuation", "Through contact-sequence changes"; D-108, D-115): the map
!> set up at a parameter value, a point's linearisation, the corrector (chord or full
!> Newton), a point stored; and the non-smooth part: the forcing phase moved when a
!> memory contact drifts onto t0, a contact-sequence change (grazing) located and
!> crossed, a closed branch recognised, folds / period-doubling / Neimark-Sacker
!> points detected and located.
submodule(trainsim_arclength) trainsim_arclength_events
   implicit none

contains

   !> The period map set up at lambda (the first model retuned to lambda where the
   !> problem can, D-131, else the deck rebuilt there; t0 = t_start + phase T).
   !> A retuned model's session skips the fixed-step check when every load is a
   !> constant: the first model's set-up made it, and a retune changes nothing it
   !> reads but the deck's start, from which the map never integrates (D-163).
   module procedure at
      type(model_t) :: m
      real(wp) :: period
      logical :: done
      integer :: l
      if (lam == c%lam) return
      if (c%lam == huge(1.0_wp)) c%lin_lam = huge(1.0_wp)   ! (a set-up forced again: e.g. a new phase)
      c%lam = huge(1.0_wp)
      done = .false.
      if (c%has_base) then
         m = c%base
         call c%prob%retune(lam, m, done, err)
         if (allocated(err)) deallocate (err)   ! (built again below: its message names the deck)
         c%has_base = done                      ! (else built at every lambda from now on)
      end if
      if (.not. done) then
         call c%prob%model_at(lam, m, err)
         if (allocated(err)) return
         if (.not. c%tried_base) c%base = m
         c%has_base = .not. c%tried_base
         c%tried_base = .true.
      end if
      call forcing_period(m, period, err)
      if (allocated(err)) return
      c%t_start = m%run%t_start
      m%run%t_start = m%run%t_start + c%phase*period
      if (done .and. allocated(m%loads)) then
         do l = 1, size(m%loads)
            done = done .and. m%loads(l)%torque%is_constant()
         end do
      end if
      call c%pm%setup(m, period, c%k, err, keep_memory=allocated(c%pm%mem), step_checked=done)   ! (memory: D-150)
      if (allocated(err)) return
      c%lam = lam
   end procedure at

   !> px = P(x; lambda) for the scaled z = (x/s, lambda/l). why: the integration failed.
   module procedure evaluate
      type(error_t), allocatable :: e
      why = ''
      allocate (px(c%n))
      call at(c, z(c%n + 1)*c%ls, err)
      if (allocated(err)) return
      call c%pm%map(z(1:c%n)*c%s, px, e)
      c%maps = c%maps + 1
      if (allocated(e)) why = 'the period map failed: '//e%message
   end procedure evaluate

   !> The point's monodromy, multipliers, scaled Jacobian A and tangent (oriented along
   !> t_prev). The monodromy first, on the map as the corrector left it at lambda, then
   !> dP/dlambda by central differences; lambda's period and t0 kept for `store`, so
   !> that the map is not set up at lambda again (D-132). (A forward difference from
   !> p%px, one map fewer, moved the fold at 534.17 teeth/s by 4e-6: rejected.)
   module procedure linearise
      real(wp) :: x(c%n), lam, h, pp(c%n), pq(c%n)
      real(wp), allocatable :: b(:, :), rhs(:)
      character(len=:), allocatable :: why
      integer :: i, n, info
      integer :: ipiv(c%n + 1)
      n = c%n
      x = p%z(1:n)*c%s
      lam = p%z(n + 1)*c%ls
      h = c%fd*c%ls
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
      c%lin_lam = lam
      c%lin_period = c%pm%period
      c%lin_t0 = c%pm%t0
      call map_at(lam + h, pp)
      if (allocated(err)) return
      call map_at(lam - h, pq)
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
   end procedure linearise

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
   !> of its own contact sequence: the non-smooth corrector, D-115). why = ''
   !> if it converged. It stops as failed, before its steps are spent, where it
   !> cannot converge (D-172): the chord when its residual grows, or when at its
   !> last rate of contraction the steps left would not bring it below 10 tol;
   !> Newton when its residual grows twice, or grows after a step that reduced it
   !> (its first step from the predictor may overshoot; a later growth is a
   !> contact sequence it bounces between). px_pred: the map at z_pred, set by the
   !> chord and taken from it by Newton after the chord (not mapped again).
   module procedure correct
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
         if (it == 0 .and. present(px_pred)) then
            if (allocated(px_pred) .and. newton) then
               px = px_pred
               why = ''
            else
               if (allocated(px_pred)) deallocate (px_pred)   ! (a chord's: the last predictor's)
               call evaluate(c, q%z, px, why, err)
               if (len(why) == 0 .and. .not. allocated(err)) px_pred = px
            end if
         else
            call evaluate(c, q%z, px, why, err)
         end if
         if (allocated(err)) why = err%message
         if (len(why) > 0) return
         r = maxval(abs(px/c%s - q%z(1:n)))
         q%px = px
         q%residual = r
         q%corrector = it
         if (r <= opt%tol) return
         if (.not. r < r_old) then
            grown = grown + 1
            if (.not. newton .or. grown > 1 .or. it >= 2) then
               why = 'the corrector diverged at lambda = '//str(lam, 10)//' (residual '//str(r, 3)//' after '// &
                     str(r_old, 3)//')'
               return
            end if
         else if (.not. newton .and. it >= 2) then
            if (r*(r/r_old)**(opt%max_corrector - it) > 10.0_wp*opt%tol) then
               why = 'the chord converges too slowly at lambda = '//str(lam, 10)//' (residual '//str(r, 3)// &
                     ' after '//str(r_old, 3)//', '//str(opt%max_corrector - it)//' steps left)'
               return
            end if
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
   end procedure correct

   !> Append the point p (with its kind: '' or a bifurcation) to the branch.
   module procedure store
      type(branch_point_t) :: bp
      type(error_t), allocatable :: err
      bp%lam = p%z(c%n + 1)*c%ls
      if (bp%lam == c%lin_lam .and. bp%lam /= c%lam) then   ! (linearised there: its period and t0 kept)
         bp%period = c%lin_period
         bp%t0 = c%lin_t0
      else
         call at(c, bp%lam, err)   ! (the map at the point's own lambda: its period and t0)
         bp%period = c%pm%period
         bp%t0 = c%pm%t0
      end if
      bp%x = p%z(1:c%n)*c%s
      bp%mem = c%pm%mem
      bp%kept = c%pm%kept
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
   end procedure store

   !> The first point of a resumed branch: its last stored point.
   module procedure start_resumed
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
      if (allocated(br%pts(last)%mem)) then   ! (the point's memory, not the deck's start: D-154)
         if (size(br%pts(last)%mem) == size(c%pm%mem) .and. size(br%pts(last)%kept) == size(c%pm%kept)) then
            c%pm%mem = br%pts(last)%mem
            c%pm%mem_end = c%pm%mem
            c%pm%kept = br%pts(last)%kept
         end if
      end if
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
   end procedure start_resumed

   !> Move the forcing phase t0 of the accepted point cur to the middle of the
   !> longest stretch of its orbit with every memory contact open (as shooting
   !> does, D-99): along a branch the contacts drift in phase, and one that spans
   !> t0 makes the map wrong (its impact's damping is not in the state). cur's x
   !> becomes its state at the new t0, its Jacobian and tangent (oriented by the
   !> old one's lambda-component) are taken again. moved: whether t0 moved.
   module procedure rephase_point
      real(wp) :: x(c%n), t_dir(c%n + 1)
      character(len=:), allocatable :: why
      call t0_to_open(c, cur%z, x, moved, err)
      if (allocated(err) .or. .not. moved) return
      br%phase = c%phase
      cur%z(1:c%n) = x/c%s
      t_dir = 0.0_wp
      t_dir(c%n + 1) = sign(1.0_wp, cur%t(c%n + 1))
      call evaluate(c, cur%z, cur%px, why, err)
      if (.not. allocated(err) .and. len(why) > 0) call fatal_error(err, 'moving t0: '//why, err_input)
      if (.not. allocated(err)) call linearise(c, cur, t_dir, err)
   end procedure rephase_point

   !> The map at the point z's lambda with t0 moved into the longest stretch with every
   !> memory contact that opens open (`rephase`, D-99); x: z's state at the new t0 (at
   !> the old one if t0 did not move), c%phase the new phase. moved: whether t0 moved.
   module procedure t0_to_open
      real(wp) :: t0_old
      moved = .false.
      call at(c, z(c%n + 1)*c%ls, err)
      if (allocated(err)) return
      x = z(1:c%n)*c%s
      t0_old = c%pm%t0
      call c%pm%rephase(x, err)
      if (allocated(err)) return
      c%maps = c%maps + 2
      moved = c%pm%t0 /= t0_old
      if (moved) c%phase = (c%pm%t0 - c%t_start)/c%pm%period
   end procedure t0_to_open

   !> Whether a fold or grazing point stored after index `before` repeats an earlier
   !> one (lambda to 1e-7 of |lambda_0|, the state to 1e-6 of its scale, or where t0
   !> moved in between the multipliers' moduli to 1e-4): a closed branch, which the
   !> continuation would go round again. A grazing met again is where two stretches
   !> of the branch join at a contact-sequence change (D-121).
   module procedure closed_loop
      integer :: i, j
      closed = .false.
      do i = before + 1, size(br%pts)
         if (.not. folded(br%pts(i)%kind)) cycle
         do j = 1, before
            if (.not. folded(br%pts(j)%kind)) cycle
            if (abs(br%pts(i)%lam - br%pts(j)%lam) > 1.0e-7_wp*c%ls) cycle
            if (abs(br%pts(i)%t0 - br%pts(j)%t0) <= 1.0e-9_wp*br%pts(i)%period) then
               if (maxval(abs(br%pts(i)%x - br%pts(j)%x)/c%s) > 1.0e-6_wp) cycle
            else if (maxval(abs(abs(br%pts(i)%mu) - abs(br%pts(j)%mu))) > 1.0e-4_wp) then
               cycle   ! (t0 moved in between: the state is another section's; the multipliers are not)
            end if
            closed = .true.
         end do
      end do
   contains
      logical function folded(kind)
         character(len=*), intent(in) :: kind
         folded = kind == 'fold' .or. kind == 'grazing'
      end function folded
   end procedure closed_loop

   !> A contact-sequence change between the accepted p and q (q = p + ds along p's
   !> tangent, corrected, its sequence another): the grazing orbit located by
   !> bisection on the arclength from p (each trial corrected by full Newton on p's
   !> hyperplane; a trial that fails counts as past the change) to lam_tol, the
   !> last point of p's sequence stored as kind 'grazing' (after the bifurcations
   !> between p and it), and q's tangent oriented along the secant from it: the
   !> multipliers and the tangent jump there (the map's derivative is
   !> discontinuous), and the branch goes on in q's sequence (D-115).
   !> A trial's sequence is that of its flow alone (no variational pass), each trial
   !> predicted from the last one in p's sequence and corrected by the chord with
   !> the Jacobian of the nearest such trial (full Newton where the chord fails);
   !> the point kept is linearised once at the end, and if that pass fails or meets
   !> another sequence (an impact the flow does not count), the bisection is done
   !> again with every trial by full Newton and linearised, as before (D-149).
   module procedure cross_grazing
      type(node_t) :: a
      type(error_t), allocatable :: err
      type(monodromy_stats_t) :: sp
      real(wp) :: sa
      logical :: ok
      ok = .false.
      a = p
      sa = 0.0_wp
      call flow_sequence(c, p, sp, err)
      if (.not. allocated(err)) then
         call bisect(.true., a, sa)
         ok = .true.
         if (sa > 0.0_wp) then
            call linearise(c, a, p%t, err)
            ok = .not. allocated(err)
            if (ok) ok = same_sequence(a%st, p%st)
         end if
      end if
      if (allocated(err)) deallocate (err)
      if (.not. ok) then
         a = p
         sa = 0.0_wp
         call bisect(.false., a, sa)
      end if
      if (sa > 0.0_wp) call detect(c, br, p, a, sa, opt)
      call store(br, c, a, sa, 'grazing', a%t, br%pts(size(br%pts))%segment)
      if (dot_product(q%t, q%z - a%z) < 0.0_wp) q%t = -q%t
   contains
      !> sa (from 0) and a (from p): the last trial in p's sequence; cheap: by the
      !> trials' flow (a not linearised), else by their variational passes
      subroutine bisect(cheap, a, sa)
         logical, intent(in) :: cheap
         type(node_t), intent(inout) :: a
         real(wp), intent(inout) :: sa
         type(node_t) :: r, pj
         type(monodromy_stats_t) :: sr
         type(error_t), allocatable :: e
         character(len=:), allocatable :: why
         real(wp), allocatable :: px_pred(:)
         real(wp) :: sb, sm
         integer :: it
         logical :: same
         sb = ds
         pj = p
         do it = 1, 60
            if (abs(sb - sa)*abs(p%t(c%n + 1)) <= opt%lam_tol .and. abs(sb - sa) <= 1.0e3_wp*opt%lam_tol) exit
            sm = 0.5_wp*(sa + sb)
            if (cheap) then
               ! from the last trial in p's sequence, on the same hyperplane t_p'(z - z_p) = sm:
               ! the chord with the Jacobian of that sequence's nearest trial, else full Newton
               call correct(c, pj, a%z + (sm - sa)*p%t, opt, r, why, px_pred=px_pred)
               if (len(why) > 0) call correct(c, p, a%z + (sm - sa)*p%t, opt, r, why, full=.true., px_pred=px_pred)
            else
               call correct(c, p, p%z + sm*p%t, opt, r, why, full=.true.)
            end if
            same = .false.
            if (len(why) == 0 .and. cheap) then
               call flow_sequence(c, r, sr, e)
               same = .not. allocated(e)
               if (same) same = same_sequence(sr, sp)
            else if (len(why) == 0) then
               call linearise(c, r, p%t, e)
               same = .not. allocated(e)
               if (same) same = same_sequence(r%st, p%st)
            end if
            if (allocated(e)) deallocate (e)
            if (same) then
               sa = sm
               a = r
               if (allocated(r%a)) pj%a = r%a   ! (full Newton's last Jacobian, near r)
            else
               sb = sm
            end if
         end do
      end subroutine bisect
   end procedure cross_grazing

   !> The contact sequence of the flow over the orbit of point p (its events only:
   !> no variational pass, no impacts counted).
   subroutine flow_sequence(c, p, st, err)
      type(ctx_t), intent(inout) :: c
      type(node_t), intent(in) :: p
      type(monodromy_stats_t), intent(out) :: st
      type(error_t), allocatable, intent(out) :: err
      call at(c, p%z(c%n + 1)*c%ls, err)
      if (allocated(err)) return
      call flow_signature(c%pm, p%z(1:c%n)*c%s, st, err)
      c%passes = c%passes + 1
   end subroutine flow_sequence

   !> The bifurcations between the accepted points p and q (q = p + ds along p's
   !> tangent, corrected), each located and stored before q.
   module procedure detect
      integer :: j
      character(len=*), parameter :: kinds(3) = [character(len=15) :: 'fold', 'period-doubling', 'neimark-sacker']
      do j = 1, 3
         if (test_fn(j, p, c%n) * test_fn(j, q, c%n) < 0.0_wp) call locate(c, br, p, q, ds, opt, j, trim(kinds(j)))
      end do
   end procedure detect

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
      type(node_t) :: r, best, pj
      type(branch_options_t) :: o
      type(error_t), allocatable :: err
      real(wp) :: sa, sb, fa, fb, sm, fm, la, lb, s_best
      character(len=:), allocatable :: why
      integer :: it, side
      sa = 0.0_wp
      sb = ds
      fa = test_fn(j, p, c%n)
      fb = test_fn(j, q, c%n)
      la = p%z(c%n + 1)
      lb = q%z(c%n + 1)
      best = q
      s_best = ds
      pj = p   ! (p's tangent and hyperplanes; the Jacobian of the end nearer the zero)
      if (abs(fb) < abs(fa)) pj%a = q%a
      side = 0
      do it = 1, 40
         sm = sb - fb*(sb - sa)/(fb - fa)
         ! from the last trial, on the same hyperplane t_p'(z - z_p) = sm, the chord with the
         ! Jacobian of the last trial (D-181); as before (from p, p's Jacobian) where it fails
         call correct(c, pj, best%z + (sm - s_best)*p%t, opt, r, why)
         if (len(why) > 0) call correct(c, p, p%z + sm*p%t, opt, r, why)
         if (len(why) == 0) call linearise(c, r, p%t, err)
         if (allocated(err) .or. len(why) > 0) exit
         fm = test_fn(j, r, c%n)
         best = r
         s_best = sm
         pj%a = r%a
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
      if (j == 1) then
         ! a fold's lambda is a turning point of the branch: a point off the curve by the
         ! corrector's tolerance can sit 1e-8 of lambda from it (534.17: 4.8e-6 teeth/s between
         ! two secant paths). The last trial is corrected again, on its own hyperplane, to
         ! tol/100 (D-181); where that fails it is kept as it is
         o = opt
         o%tol = 1.0e-2_wp*opt%tol
         pj%a = best%a
         call correct(c, pj, best%z, o, r, why)
         if (len(why) == 0) call linearise(c, r, p%t, err)
         if (len(why) == 0 .and. .not. allocated(err)) best = r
      end if
      call store(br, c, best, sm, kind, p%t, br%pts(size(br%pts))%segment)
   end subroutine locate
end submodule trainsim_arclength_events
