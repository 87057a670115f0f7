!> Periodic orbits by shooting (issue 27): Newton on G(x) = P(x) - x, P the
!> period map (trainsim_period_map), from the end of a short transient (the
!> phase-free start: the deck's initial state integrated a few periods). The
!> monodromy matrix M = dP/dx is a procedure argument (`monodromy_i`):
!> central finite differences (`monodromy_fd`) by default, or the variational
!> equations with saltation matrices where they are available.
!>
!> Each Newton step solves (M - I) dx = -G and is damped: the full step, then
!> halves down to 1/64, the first whose residual ||G/s||_inf (s: the state
!> scale, period_map_t%scale) is below (1 - 1e-4 lambda) times the current
!> one. Converged when that residual is at most tol (1e-10 by default).
module trainsim_shooting
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_numeric
   use trainsim_strings, only: str
   use trainsim_period_map, only: period_map_t
   implicit none
   private

   public :: shoot_options_t, shoot_result_t, shoot, monodromy_i, monodromy_fd
   public :: shoot_converged, shoot_no_orbit, shoot_budget, shoot_singular, shoot_failed, shoot_floor

   !> shoot_result_t%status
   integer, parameter :: shoot_converged = 0, shoot_no_orbit = 1, shoot_budget = 2, shoot_singular = 3, &
                         shoot_failed = 4, shoot_floor = 5

   !> The monodromy matrix m = dP/dx at x (px = P(x), already evaluated).
   abstract interface
      subroutine monodromy_i(pm, x, px, m, err)
         import :: period_map_t, wp, error_t
         class(period_map_t), intent(inout) :: pm
         real(wp), intent(in) :: x(:), px(:)
         real(wp), intent(out) :: m(:, :)
         type(error_t), allocatable, intent(out) :: err
      end subroutine monodromy_i
   end interface

   type :: shoot_options_t
      real(wp) :: tol = 1.0e-10_wp     !< of the state scale
      integer :: max_newton = 25       !< Newton steps per start
      integer :: transient = 10        !< map applications (k periods each) before the first
      integer :: retries = 4           !< Newton restarted after 2x more transient (10 -> 30 -> 90 -> ...)
      real(wp) :: fd_step = 1.0e-6_wp  !< central-difference step, of the state scale
      integer :: segments = 1          !< multiple shooting: segments of the k periods (1: single)
   end type shoot_options_t

   type :: shoot_result_t
      integer :: status = shoot_failed
      character(len=:), allocatable :: message   !< why it did not converge ('' if it did)
      real(wp), allocatable :: x(:)              !< the orbit's reduced state at t0 (or the last iterate)
      real(wp), allocatable :: scale(:)          !< the state scale there
      real(wp), allocatable :: m(:, :)           !< the monodromy matrix at x
      real(wp) :: residual = huge(1.0_wp)        !< ||(P(x) - x)/scale||_inf
      real(wp), allocatable :: history(:)        !< the residual before each Newton step
      integer :: newton = 0                      !< Newton steps taken
      integer :: maps = 0                        !< period maps evaluated (all)
      integer :: transient = 0                   !< forcing periods of transient before the last Newton start
      integer :: attempts = 0                    !< Newton starts
      integer :: segments = 1                    !< segments shot (multiple shooting)
   end type shoot_result_t

   interface
      subroutine dgesv(n, nrhs, a, lda, ipiv, b, ldb, info)
         import :: wp
         integer, intent(in) :: n, nrhs, lda, ldb
         real(wp), intent(inout) :: a(lda, *), b(ldb, *)
         integer, intent(out) :: ipiv(*), info
      end subroutine dgesv
   end interface

contains

   !> The monodromy matrix by central differences: column j from P(x +- h_j e_j),
   !> h_j = opt fd_step times the state scale of component j.
   subroutine monodromy_fd(pm, x, px, m, err)
      class(period_map_t), intent(inout) :: pm
      real(wp), intent(in) :: x(:), px(:)
      real(wp), intent(out) :: m(:, :)
      type(error_t), allocatable, intent(out) :: err
      call monodromy_fd_step(pm, x, px, m, err, 1.0e-6_wp)
   end subroutine monodromy_fd

   subroutine monodromy_fd_step(pm, x, px, m, err, rel)
      class(period_map_t), intent(inout) :: pm
      real(wp), intent(in) :: x(:), px(:), rel
      real(wp), intent(out) :: m(:, :)
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: sc(size(x)), xp(size(x)), xm(size(x)), pp(size(x)), pmi(size(x)), h
      integer :: j
      associate (unused => px)
      end associate
      sc = pm%scale(x)
      do j = 1, size(x)
         h = rel*sc(j)
         xp = x
         xm = x
         xp(j) = x(j) + h
         xm(j) = x(j) - h
         h = xp(j) - xm(j)   ! the step as represented
         call pm%map(xp, pp, err)
         if (allocated(err)) return
         call pm%map(xm, pmi, err)
         if (allocated(err)) return
         m(:, j) = (pp - pmi)/h
      end do
   end subroutine monodromy_fd_step

   !> The periodic orbit of pm's map near the end of a transient from the deck's
   !> initial state (or from `x_start`), the memory pm%mem carried through it
   !> (D-150): Newton on P(x) - x with `monodromy` (default monodromy_fd). res%status says whether it converged and, if
   !> not, res%message why. When Newton finds no orbit near the start or spends
   !> its budget, the transient goes on (to three times its length so far) and
   !> Newton starts again, opt%retries times. err: the integration itself failed
   !> (a blow-up, an event flood) at a state the map was asked about.
   subroutine shoot(pm, opt, res, err, monodromy, x_start)
      class(period_map_t), intent(inout) :: pm
      type(shoot_options_t), intent(in) :: opt
      type(shoot_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      procedure(monodromy_i), optional :: monodromy
      real(wp), intent(in), optional :: x_start(:)
      real(wp), allocatable :: x(:), xt(:)
      logical, allocatable :: kept(:), open(:)
      logical :: lost
      integer :: attempt, periods, total, n0
      n0 = pm%n_evals
      if (present(x_start)) then
         x = x_start
      else
         x = pm%initial()
      end if
      allocate (xt(pm%n))
      periods = opt%transient*pm%k   ! the phase-free start: a short transient
      total = 0
      do attempt = 0, opt%retries
         if (periods > 0) then
            pm%kept = .true.   ! (a transient runs on as a run does: every memory held, D-156)
            call pm%map(x, xt, err, periods=periods, carry=.true.)   ! (the memory goes on, D-150)
            if (allocated(err)) return
            x = xt
            total = total + periods
         end if
         call pm%rephase(x, err)   ! no contact with a memory in progress at t0
         if (allocated(err)) return
         if (opt%segments > 1) then
            call pm%set_segments(opt%segments, x, err)
            if (allocated(err)) return
            call newton_segments(pm, opt, res, err)
         else
            call newton(pm, opt, x, res, err, monodromy)
            if (.not. allocated(err) .and. res%status == shoot_converged .and. size(pm%memory) > 0) then
               ! a contact held closed opened, or the orbit's memory contacts open otherwise than
               ! the transient's end did: t0 into an open stretch (D-150, D-156)
               kept = pm%kept
               lost = pm%memory_lost()
               call pm%open_samples(res%x, open, err)
               if (.not. allocated(err) .and. (lost .or. any(pm%kept .neqv. kept))) then
                  x = res%x
                  call pm%rephase(x, err)
                  if (.not. allocated(err)) call newton(pm, opt, x, res, err, monodromy)
               end if
            end if
         end if
         if (allocated(err)) return
         res%transient = total
         res%attempts = attempt + 1
         if (res%status /= shoot_no_orbit .and. res%status /= shoot_budget) exit
         periods = 2*max(total, pm%k)
      end do
      res%maps = pm%n_evals - n0
   end subroutine shoot

   !> Newton's verdict at step it with the residual r (of the state scale): r joins
   !> res%history; converged when r <= opt%tol, the budget spent after opt%max_newton steps.
   logical function newton_done(r, it, opt, res) result(done)
      real(wp), intent(in) :: r
      integer, intent(in) :: it
      type(shoot_options_t), intent(in) :: opt
      type(shoot_result_t), intent(inout) :: res
      res%history = [res%history, r]
      done = .true.
      if (r <= opt%tol) then
         res%status = shoot_converged
      else if (it > opt%max_newton) then
         res%status = shoot_budget
         res%message = 'the Newton budget of '//str(opt%max_newton)//' steps was spent at a residual of '// &
                       str(r, 3)//' of the state scale (tolerance '//str(opt%tol, 3)//')'
      else
         done = .false.
      end if
   end function newton_done

   !> Newton on P(x) - x from x (at pm's t0).
   subroutine newton(pm, opt, x_start, res, err, monodromy)
      class(period_map_t), intent(inout) :: pm
      type(shoot_options_t), intent(in) :: opt
      real(wp), intent(in) :: x_start(:)
      type(shoot_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      procedure(monodromy_i), optional :: monodromy
      real(wp), allocatable :: x(:), px(:), g(:), dx(:), xt(:), pt(:), a(:, :)
      integer, allocatable :: ipiv(:)
      real(wp) :: r, rt, lam
      integer :: n, it, i, info
      n = pm%n
      allocate (x(n), px(n), g(n), dx(n), xt(n), pt(n), a(n, n), ipiv(n), res%m(n, n))
      allocate (res%history(0))
      x = x_start
      call pm%map(x, px, err)
      if (allocated(err)) return
      res%scale = pm%scale(x)
      g = px - x
      r = maxval(abs(g)/res%scale)
      do it = 1, opt%max_newton + 1
         if (newton_done(r, it, opt, res)) exit
         call jacobian(x, px, res%m, err)
         if (allocated(err)) return
         a = res%m
         do i = 1, n
            a(i, i) = a(i, i) - 1.0_wp
         end do
         dx = -g
         call dgesv(n, 1, a, n, ipiv, dx, n, info)
         ! (a step of 1e8 state scales: M - I singular to the accuracy of M)
         if (info /= 0 .or. .not. all(abs(dx) <= 1.0e8_wp*res%scale)) then
            res%status = shoot_singular
            res%message = 'M - I is singular at Newton step '//str(it)//' (a Floquet multiplier at 1: a fold, '// &
                          'or a free rigid-body rotation with no node of prescribed speed)'
            exit
         end if
         res%newton = it
         ! the damped step
         lam = 1.0_wp
         do
            xt = x + lam*dx
            call pm%map(xt, pt, err)
            if (allocated(err)) then
               if (lam < 1.0_wp/32.0_wp) return
               deallocate (err)   ! a state too far out (a blow-up): a shorter step
               rt = huge(1.0_wp)
            else
               rt = maxval(abs(pt - xt)/res%scale)
            end if
            if (rt < (1.0_wp - 1.0e-4_wp*lam)*r .or. lam < 1.0_wp/64.0_wp) exit
            lam = 0.5_wp*lam
         end do
         if (.not. rt < (1.0_wp - 1.0e-4_wp*lam)*r .and. r < 1.0e-12_wp) then
            res%status = shoot_floor
            res%message = 'the residual stalled at '//str(r, 3)//' of the state scale, the rounding floor of the '// &
                          'period map, above the tolerance '//str(opt%tol, 3)//' (ask a looser one)'
            exit
         else if (.not. rt < (1.0_wp - 1.0e-4_wp*lam)*r) then
            res%status = shoot_no_orbit
            res%message = 'no periodic orbit near the start: Newton step '//str(it)//' could not lower the '// &
                          'residual '//str(r, 3)//' of the state scale even at 1/64 of the step (the start is '// &
                          'too far from an orbit, or the orbit too unstable to shoot over '//str(pm%k)//' period(s))'
            exit
         end if
         x = xt
         px = pt
         g = px - x
         r = rt
         res%scale = max(res%scale, pm%scale(x))
      end do
      res%x = x
      res%residual = r
      if (res%status == shoot_converged) then
         res%message = ''
         call jacobian(x, px, res%m, err)   ! at the orbit itself
         if (allocated(err)) return
      end if
   contains
      subroutine jacobian(xx, pxx, m, e)
         real(wp), intent(in) :: xx(:), pxx(:)
         real(wp), intent(out) :: m(:, :)
         type(error_t), allocatable, intent(out) :: e
         if (present(monodromy)) then
            call monodromy(pm, xx, pxx, m, e)
         else
            call monodromy_fd_step(pm, xx, pxx, m, e, opt%fd_step)
         end if
         if (.not. allocated(e)) then
            if (.not. all(abs(m) <= huge(1.0_wp))) call fatal_error(e, 'the monodromy matrix is not finite', &
                                                                    err_numeric)
         end if
      end subroutine jacobian
   end subroutine newton

   !> Multiple shooting (pm%set_segments done): Newton on the ns segment conditions
   !> S_j(x_j) - x_(j+1) = 0 (x_ns = x_0), the segments' Jacobians Phi_j by central
   !> differences, the block-cyclic system solved whole (dgesv), the step damped as in
   !> `newton`; the monodromy Phi_(ns-1) ... Phi_0 at the end. A long unstable period
   !> becomes ns short maps, each amplifying errors by its own part of the growth only.
   subroutine newton_segments(pm, opt, res, err)
      class(period_map_t), intent(inout) :: pm
      type(shoot_options_t), intent(in) :: opt
      type(shoot_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: x(:, :), sx(:, :), rr(:, :), xt(:, :), st(:, :), phi(:, :, :), a(:, :), dx(:)
      integer, allocatable :: ipiv(:)
      real(wp) :: r, rt, lam
      integer :: n, ns, nn, it, j, i, info
      n = pm%n
      ns = size(pm%seg_tau) - 1
      nn = n*ns
      res%segments = ns
      allocate (sx(n, 0:ns - 1), rr(n, 0:ns - 1), st(n, 0:ns - 1), phi(n, n, 0:ns - 1), a(nn, nn), dx(nn), &
                ipiv(nn), res%history(0))
      x = pm%seg_x
      res%scale = pm%scale(x(:, 0))
      call residuals(x, sx, rr, err)
      if (allocated(err)) return
      r = maxval(abs(rr)/spread(res%scale, 2, ns))
      do it = 1, opt%max_newton + 1
         if (newton_done(r, it, opt, res)) exit
         call jacobians(x, phi, err)
         if (allocated(err)) return
         a = 0.0_wp
         do j = 0, ns - 1
            a(j*n + 1:(j + 1)*n, j*n + 1:(j + 1)*n) = phi(:, :, j)
            do i = 1, n
               a(j*n + i, modulo(j + 1, ns)*n + i) = a(j*n + i, modulo(j + 1, ns)*n + i) - 1.0_wp
            end do
         end do
         dx = -reshape(rr, [nn])
         call dgesv(nn, 1, a, nn, ipiv, dx, nn, info)
         if (info /= 0 .or. .not. all(abs(reshape(dx, [n, ns])) <= 1.0e8_wp*spread(res%scale, 2, ns))) then
            res%status = shoot_singular
            res%message = 'the segment system is singular at Newton step '//str(it)//' (a Floquet multiplier at '// &
                          '1: a fold, or a free rigid-body rotation with no node of prescribed speed)'
            exit
         end if
         res%newton = it
         lam = 1.0_wp
         do
            xt = x + lam*reshape(dx, [n, ns])
            call residuals(xt, st, rr, err)
            if (allocated(err)) then
               if (lam < 1.0_wp/32.0_wp) return
               deallocate (err)
               rt = huge(1.0_wp)
            else
               rt = maxval(abs(rr)/spread(res%scale, 2, ns))
            end if
            if (rt < (1.0_wp - 1.0e-4_wp*lam)*r .or. lam < 1.0_wp/64.0_wp) exit
            lam = 0.5_wp*lam
         end do
         if (.not. rt < (1.0_wp - 1.0e-4_wp*lam)*r) then
            res%status = merge(shoot_floor, shoot_no_orbit, r < 1.0e-12_wp)
            res%message = 'no periodic orbit near the start: multiple-shooting step '//str(it)//' could not '// &
                          'lower the residual '//str(r, 3)//' of the state scale even at 1/64 of the step'
            if (r < 1.0e-12_wp) res%message = 'the residual stalled at '//str(r, 3)//' of the state scale, the '// &
                                              'rounding floor, above the tolerance '//str(opt%tol, 3)
            exit
         end if
         x = xt
         r = rt
      end do
      res%x = x(:, 0)
      res%residual = r
      allocate (res%m(n, n))
      if (res%status /= shoot_converged) return
      res%message = ''
      call jacobians(x, phi, err)
      if (allocated(err)) return
      res%m = phi(:, :, 0)
      do j = 1, ns - 1
         res%m = matmul(phi(:, :, j), res%m)
      end do
   contains
      subroutine residuals(xx, s_out, r_out, e)
         real(wp), intent(in) :: xx(:, 0:)
         real(wp), intent(out) :: s_out(:, 0:), r_out(:, 0:)
         type(error_t), allocatable, intent(out) :: e
         integer :: jj
         do jj = 0, ns - 1
            call pm%segment(jj, xx(:, jj), s_out(:, jj), e)
            if (allocated(e)) return
            r_out(:, jj) = s_out(:, jj) - xx(:, modulo(jj + 1, ns))
         end do
      end subroutine residuals
      subroutine jacobians(xx, ph, e)
         real(wp), intent(in) :: xx(:, 0:)
         real(wp), intent(out) :: ph(:, :, 0:)
         type(error_t), allocatable, intent(out) :: e
         real(wp) :: xp(n), xm(n), pp(n), pq(n), h
         integer :: jj, c
         do jj = 0, ns - 1
            do c = 1, n
               h = opt%fd_step*res%scale(c)
               xp = xx(:, jj)
               xm = xx(:, jj)
               xp(c) = xp(c) + h
               xm(c) = xm(c) - h
               call pm%segment(jj, xp, pp, e)
               if (allocated(e)) return
               call pm%segment(jj, xm, pq, e)
               if (allocated(e)) return
               ph(:, c, jj) = (pp - pq)/(xp(c) - xm(c))
            end do
         end do
      end subroutine jacobians
   end subroutine newton_segments
end module trainsim_shooting
