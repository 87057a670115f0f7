!> Periodic orbits by shooting (issue 27; docs/periodic.md): a harmonically
!> forced one-degree-of-freedom oscillator with a dead zone, whose periodic
!> orbit and Floquet multipliers are known in closed form when it never
!> reaches its clearance, and assembled from the exact linear segments when it
!> does (the matching conditions solved to 1e-12): the shooting's orbit and
!> multipliers to 1e-8 of the scale. The Table 5.5 rig at 485 teeth/s: the
!> shooting's orbit equals the state of a run that settled until periodic,
!> within the settling tolerance, and its multipliers say stable.
program test_periodic
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_period_map, only: period_map_t, forcing_period
   use trainsim_shooting, only: shoot_options_t, shoot_result_t, shoot, shoot_converged
   use trainsim_floquet, only: floquet_multipliers, stability_of
   use trainsim_orbit, only: orbit_run, orbit_grazing, graze_tol
   use trainsim_sink, only: null_sink_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check, check_close
   use trainsim_test_support, only: load_model, load_model_text, run_model, nl
   use trainsim_test_oscillator, only: oscillator_t
   implicit none

   real(wp), parameter :: pi = 3.14159265358979323846264338327950_wp
   ! the oscillator: J th'' + c th' + k th + k2 dz_b(th) = t0 + a sin(W t)
   real(wp), parameter :: jj = 1.0_wp, c1 = 2.0_wp, k1 = 100.0_wp, k2 = 100.0_wp, tq0 = 60.0_wp, amp = 50.0_wp
   type(oscillator_t), parameter :: osc = oscillator_t(jj, c1, amp)

   call suite_begin('periodic orbits by shooting: closed forms and the Table 5.5 rig')
   call test_linear_oscillator_closed_form()
   call test_dead_zone_oscillator_segments()
   call test_two_periods_square_the_multipliers()
   call test_grazing_gap_closed_form()
   call test_multiple_shooting_same_orbit()
   call test_ghm_rig_equals_settled_run(8.0e-6_wp)
   call suite_end()

contains

   !> The oscillator's deck: a disk on a damped shaft to ground and a dead zone of
   !> half width b to ground (contact law linear, no damping: a continuous force).
   subroutine oscillator(b, model)
      real(wp), intent(in) :: b
      type(model_t), intent(out) :: model
      call load_model_text('&run t_end = 1.0, dt = 1e-4, integrator = ''rk4'', output_interval = 1e-4 /'//nl// &
                           "&node id='g', type='fixed' /"//nl//"&node id='m', type='inertia', inertia="//str(jj)//' /'// &
                           nl//"&element type='shaft', left='m', right='g', stiffness="//str(k1)//', damping='// &
                           str(c1)//' /'//nl//"&element type='clearance_coupling', left='m', right='g', clearance="// &
                           str(2.0_wp*b)//', stiffness='//str(k2)//', contact_damping=0 /'//nl// &
                           "&load node='m', kind='sine', offset="//str(tq0)//', amplitude='//str(amp)// &
                           ', frequency=1.2732395447351628 /', model)
   end subroutine oscillator

   !> The four matching conditions of the contact orbit, v = (ta, va, tb, vb).
   function matching(v, b, w, period) result(g)
      real(wp), intent(in) :: v(4), b, w, period
      real(wp) :: g(4)
      g(1:2) = osc%flow(k1 + k2, tq0 + k2*b, w, v(1), [b, v(2)], v(3)) - [b, v(4)]
      g(3:4) = osc%flow(k1, tq0, w, v(3), [b, v(4)], v(1) + period) - [b, v(2)]
   end function matching

   !> Shoot the oscillator's orbit (b the half clearance).
   subroutine shoot_oscillator(b, m, res, mu, w, k, grazing_gap, segments)
      real(wp), intent(in) :: b
      type(model_t), intent(out) :: m
      type(shoot_result_t), intent(out) :: res
      complex(wp), allocatable, intent(out) :: mu(:)
      real(wp), intent(out) :: w
      integer, intent(in), optional :: k
      !> the grazing check's gap on the orbit's run (orbit_grazing)
      real(wp), intent(out), optional :: grazing_gap
      integer, intent(in), optional :: segments
      type(period_map_t) :: pm
      type(shoot_options_t) :: opt
      type(error_t), allocatable :: err
      type(run_result_t) :: run
      type(null_sink_t) :: none
      real(wp), allocatable :: gap(:)
      real(wp) :: period
      integer :: kk, worst
      kk = 1
      if (present(k)) kk = k
      call oscillator(b, m)
      w = m%loads(1)%torque%omega
      call forcing_period(m, period, err)
      call check('the forcing period is the sine load''s', .not. allocated(err))
      call pm%setup(m, period, kk, err)
      call check('the period map sets up', .not. allocated(err))
      if (present(segments)) opt%segments = segments
      call shoot(pm, opt, res, err)
      call check('the shooting ran without an integration error', .not. allocated(err))
      call check('the shooting converged ('//res%message//')', res%status == shoot_converged)
      write (*, '(a,i0,a,i0,a,es10.3)') '    Newton steps ', res%newton, ', period maps ', res%maps, &
         ', residual ', res%residual
      call floquet_multipliers(res%m, mu, err)
      call check('the multipliers are computed', .not. allocated(err))
      if (present(grazing_gap)) then
         call orbit_run(m, pm, res%x, none, run, err)
         call check('the orbit''s run', .not. allocated(err))
         call orbit_grazing(m, run, gap, worst)
         call check('the clearance is the element checked', worst == 2)
         grazing_gap = gap(2)
      end if
      call pm%finish()
   end subroutine shoot_oscillator

   !> The linear oscillator's orbit is also an orbit of two periods: shooting over
   !> k = 2 finds the same state and the squares of the one-period multipliers.
   subroutine test_two_periods_square_the_multipliers()
      type(model_t) :: m
      type(shoot_result_t) :: r1, r2
      complex(wp), allocatable :: mu1(:), mu2(:)
      real(wp) :: w
      integer :: j
      call test_begin('two_periods_square_the_multipliers')
      call shoot_oscillator(2.0_wp, m, r1, mu1, w)
      call shoot_oscillator(2.0_wp, m, r2, mu2, w, k=2)
      call check_close('angle at t0 (of the angle scale)', r2%x(1)/r1%scale(1), r1%x(1)/r1%scale(1), abs_tol=1.0e-8_wp)
      call check_close('speed at t0 (of the speed scale)', r2%x(2)/r1%scale(2), r1%x(2)/r1%scale(2), abs_tol=1.0e-8_wp)
      do j = 1, 2   ! (mu^2 of a conjugate pair keeps the order by |mu|; the imaginary parts may swap)
         call check_close('|mu_'//str(j)//'(2T)| = |mu_'//str(j)//'(T)|^2', abs(mu2(j)), abs(mu1(j))**2, &
                          abs_tol=1.0e-8_wp)
      end do
      call check_close('Re mu(2T) = Re mu(T)^2', real(mu2(1)), real(mu1(1)**2), abs_tol=1.0e-8_wp)
      call check_close('|Im mu(2T)| = |Im mu(T)^2|', abs(aimag(mu2(1))), abs(aimag(mu1(1)**2)), abs_tol=1.0e-8_wp)
      call check('stable', stability_of(mu2) == 'stable')
   end subroutine test_two_periods_square_the_multipliers

   !> Multiple shooting (4 segments of the period) finds the contact orbit of the
   !> dead-zone oscillator and its multipliers as single shooting does, to 1e-8 of the
   !> scale (the monodromy the product of the segments' Jacobians).
   subroutine test_multiple_shooting_same_orbit()
      type(model_t) :: m
      type(shoot_result_t) :: r1, r4
      complex(wp), allocatable :: mu1(:), mu4(:)
      real(wp) :: w
      integer :: j
      call test_begin('multiple_shooting_same_orbit')
      call shoot_oscillator(1.2_wp, m, r1, mu1, w)
      call shoot_oscillator(1.2_wp, m, r4, mu4, w, segments=4)
      call check('four segments were shot', r4%segments == 4)
      call check_close('angle at t0 (of the angle scale)', r4%x(1)/r1%scale(1), r1%x(1)/r1%scale(1), abs_tol=1.0e-8_wp)
      call check_close('speed at t0 (of the speed scale)', r4%x(2)/r1%scale(2), r1%x(2)/r1%scale(2), abs_tol=1.0e-8_wp)
      do j = 1, 2
         call check_close('multiplier '//str(j)//', real part', real(mu4(j)), real(mu1(j)), abs_tol=1.0e-8_wp)
         call check_close('multiplier '//str(j)//', imaginary part', aimag(mu4(j)), aimag(mu1(j)), abs_tol=1.0e-8_wp)
      end do
   end subroutine test_multiple_shooting_same_orbit

   !> The grazing check against the closed form: the linear orbit's largest angle is
   !> t0/k + sqrt(p^2 + q^2); with the half clearance b at 1 + 1e-5 times it the orbit
   !> just fails to touch (gap (b - th_max)/b = 9.99990e-6: grazing), at b = 2 it stays
   !> 0.065 of b away (not grazing). The run's extremes are samples every dt (1e-4 s):
   !> off by at most (W dt)^2/8 of the amplitude, 5.4e-8 of b here: checked to 1e-7.
   subroutine test_grazing_gap_closed_form()
      type(model_t) :: m
      type(shoot_result_t) :: res
      complex(wp), allocatable :: mu(:)
      real(wp) :: w, p, q, th_max, gap, b
      call test_begin('grazing_gap_closed_form')
      call osc%particular(k1, 8.0_wp, p, q)
      th_max = tq0/k1 + hypot(p, q)
      b = th_max*(1.0_wp + 1.0e-5_wp)
      call shoot_oscillator(b, m, res, mu, w, grazing_gap=gap)
      call check_close('gap of an orbit that just fails to touch', gap, (b - th_max)/b, abs_tol=1.0e-7_wp)
      call check('reported as grazing (gap <= graze_tol)', gap <= graze_tol)
      call shoot_oscillator(2.0_wp, m, res, mu, w, grazing_gap=gap)
      call check_close('gap of an orbit far from its clearance', gap, (2.0_wp - th_max)/2.0_wp, abs_tol=1.0e-7_wp)
      call check('not grazing', gap > graze_tol)
   end subroutine test_grazing_gap_closed_form

   !> Never in contact (b = 2 rad, amplitude 1.27 rad about 0.6): the orbit is the
   !> linear steady state, th(0) = t0/k + q, w(0) = p W, and the multipliers are
   !> exp(lambda T), lambda = -c/2J +- i sqrt(k/J - (c/2J)^2).
   subroutine test_linear_oscillator_closed_form()
      type(model_t) :: m
      type(shoot_result_t) :: res
      complex(wp), allocatable :: mu(:)
      complex(wp) :: lam
      real(wp) :: w, p, q, period, s_th, s_w
      call test_begin('linear_oscillator_orbit_and_multipliers_closed_form')
      call shoot_oscillator(2.0_wp, m, res, mu, w)
      call osc%particular(k1, w, p, q)
      period = 2.0_wp*pi/w
      s_w = res%scale(2)
      s_th = res%scale(1)
      call check_close('angle at t0 (of the angle scale)', res%x(1)/s_th, (tq0/k1 + q)/s_th, abs_tol=1.0e-8_wp)
      call check_close('speed at t0 (of the speed scale)', res%x(2)/s_w, p*w/s_w, abs_tol=1.0e-8_wp)
      lam = cmplx(-c1/(2.0_wp*jj), sqrt(k1/jj - (c1/(2.0_wp*jj))**2), kind=wp)
      call check_close('multiplier 1, real part', real(mu(1)), real(exp(lam*period)), abs_tol=1.0e-8_wp)
      call check_close('multiplier 1, imaginary part', aimag(mu(1)), aimag(exp(lam*period)), abs_tol=1.0e-8_wp)
      call check_close('multiplier 2, imaginary part', aimag(mu(2)), -aimag(exp(lam*period)), abs_tol=1.0e-8_wp)
      call check('stable: |mu| = exp(-c T / 2J) < 1', abs(mu(1)) < 1.0_wp)
   end subroutine test_linear_oscillator_closed_form

   !> In contact once per period (b = 1.2 rad): the orbit is a free segment (k) and a
   !> contact segment (k + k2, torque t0 + k2 b), each an exact linear flow; the entry
   !> (ta, va) and exit (tb, vb) at th = b solve the four matching conditions
   !>     flow_contact(ta, (b, va) -> tb) = (b, vb),   flow_free(tb, (b, vb) -> ta + T) = (b, va)
   !> (Newton, to 1e-12). The force is continuous at th = b, so the saltation matrices
   !> are the identity and M = exp(B_free (T - tb + ta)) exp(B_contact (tb - ta)).
   subroutine test_dead_zone_oscillator_segments()
      real(wp), parameter :: b = 1.2_wp
      type(model_t) :: m
      type(shoot_result_t) :: res
      complex(wp), allocatable :: mu(:)
      real(wp) :: w, period, u(4), fu(4), jac(4, 4), du(4), up(4), mm(2, 2), z(2), tt, tr, det, s_th, s_w, r, th_min
      complex(wp) :: ev(2), disc
      integer :: it, j
      call test_begin('dead_zone_oscillator_orbit_from_linear_segments')
      call shoot_oscillator(b, m, res, mu, w)
      period = 2.0_wp*pi/w
      ! the guess: the crossings of th = b by the linear (no-contact) steady state
      block
         real(wp) :: p, q, rr, psi, s
         call osc%particular(k1, w, p, q)
         rr = hypot(p, q)
         psi = atan2(q, p)
         s = asin((b - tq0/k1)/rr)
         u(1) = (s - psi)/w
         u(3) = (pi - s - psi)/w
         u(2) = rr*w*cos(w*u(1) + psi)
         u(4) = rr*w*cos(w*u(3) + psi)
      end block
      do it = 1, 50
         fu = matching(u, b, w, period)
         if (maxval(abs(fu)/[b, abs(u(2)), b, abs(u(2))]) < 1.0e-14_wp) exit
         do j = 1, 4
            up = u
            up(j) = u(j) + 1.0e-7_wp*max(abs(u(j)), 1.0e-3_wp)
            jac(:, j) = (matching(up, b, w, period) - fu)/(up(j) - u(j))
         end do
         du = -fu
         call solve4(jac, du)
         u = u + du
      end do
      r = maxval(abs(matching(u, b, w, period))/[b, abs(u(2)), b, abs(u(2))])
      call check('the matching conditions are solved to 1e-12 (residual '//str(r, 3)//')', r <= 1.0e-12_wp)
      call check('the orbit enters contact rising and leaves it falling', u(2) > 0.0_wp .and. u(4) < 0.0_wp .and. &
                 u(3) > u(1) .and. u(3) < u(1) + period)
      ! the reference orbit stays in its assumed regions (free: -b < th < b; contact: th > b)
      th_min = huge(1.0_wp)
      do j = 1, 999
         tt = u(3) + (u(1) + period - u(3))*real(j, wp)/1000.0_wp
         z = osc%flow(k1, tq0, w, u(3), [b, u(4)], tt)
         th_min = min(th_min, b - abs(z(1)))
         tt = u(1) + (u(3) - u(1))*real(j, wp)/1000.0_wp
         z = osc%flow(k1 + k2, tq0 + k2*b, w, u(1), [b, u(2)], tt)
         th_min = min(th_min, z(1) - b)
      end do
      call check('the reference orbit stays within its segments'' regions', th_min > 0.0_wp)
      ! its state at t0 = 0
      tt = u(1) + modulo(0.0_wp - u(1), period)
      if (tt < u(3)) then
         z = osc%flow(k1 + k2, tq0 + k2*b, w, u(1), [b, u(2)], tt)
      else
         z = osc%flow(k1, tq0, w, u(3), [b, u(4)], tt)
      end if
      s_th = res%scale(1)
      s_w = res%scale(2)
      call check_close('angle at t0 (of the angle scale)', res%x(1)/s_th, z(1)/s_th, abs_tol=1.0e-8_wp)
      call check_close('speed at t0 (of the speed scale)', res%x(2)/s_w, z(2)/s_w, abs_tol=1.0e-8_wp)
      mm = matmul(osc%expb(k1, u(1) + period - u(3)), osc%expb(k1 + k2, u(3) - u(1)))
      tr = mm(1, 1) + mm(2, 2)
      det = mm(1, 1)*mm(2, 2) - mm(1, 2)*mm(2, 1)
      disc = sqrt(cmplx(tr**2 - 4.0_wp*det, 0.0_wp, kind=wp))
      ev = [(tr + disc)/2.0_wp, (tr - disc)/2.0_wp]
      if (abs(ev(2)) > abs(ev(1)) .or. (abs(abs(ev(2)) - abs(ev(1))) < 1.0e-14_wp .and. aimag(ev(2)) > aimag(ev(1)))) &
         ev = [ev(2), ev(1)]
      do j = 1, 2
         call check_close('multiplier '//str(j)//', real part', real(mu(j)), real(ev(j)), abs_tol=1.0e-8_wp)
         call check_close('multiplier '//str(j)//', imaginary part', aimag(mu(j)), aimag(ev(j)), abs_tol=1.0e-8_wp)
      end do
   end subroutine test_dead_zone_oscillator_segments

   integer function count_of(text, what) result(k)
      character(len=*), intent(in) :: text, what
      integer :: i, j
      k = 0
      i = 1
      do
         j = index(text(i:), what)
         if (j == 0) exit
         k = k + 1
         i = i + j + len(what) - 1
      end do
   end function count_of

   function replace_all(text, what, by) result(out)
      character(len=*), intent(in) :: text, what, by
      character(len=:), allocatable :: out
      integer :: i, j
      out = ''
      i = 1
      do
         j = index(text(i:), what)
         if (j == 0) exit
         out = out//text(i:i + j - 2)//by
         i = i + j + len(what) - 1
      end do
      out = out//text(i:)
   end function replace_all

   !> Gaussian elimination with partial pivoting, 4 x 4.
   subroutine solve4(a, x)
      real(wp), intent(inout) :: a(4, 4), x(4)
      integer :: i, k, p
      real(wp) :: f, row(4), s
      do k = 1, 4
         p = k - 1 + maxloc(abs(a(k:, k)), 1)
         row = a(k, :); a(k, :) = a(p, :); a(p, :) = row
         s = x(k); x(k) = x(p); x(p) = s
         do i = k + 1, 4
            f = a(i, k)/a(k, k)
            a(i, :) = a(i, :) - f*a(k, :)
            x(i) = x(i) - f*x(k)
         end do
      end do
      do k = 4, 1, -1
         x(k) = (x(k) - dot_product(a(k, k + 1:), x(k + 1:)))/a(k, k)
      end do
   end subroutine solve4

   !> The Table 5.5 rig at 485 teeth/s with damped shafts (c = 500 lb-in s/rad: the
   !> bundled deck's shafts are undamped, and its end-inertia modes have multipliers on
   !> the unit circle, |mu| - 1 = +4e-7 and +2e-9 measured, so no run settles onto its
   !> orbit; docs/periodic.md): a run settled until periodic (settle_tol 1e-8, then 10
   !> more mesh periods) ends on the orbit the shooting finds: element displacements and
   !> node speeds at t_start + j T within tol mu/(1 - mu) (mu the largest |multiplier|:
   !> a state that repeats to tol after a period lies that far from the fixed point at
   !> most), relative to their magnitudes; every |mu| < 1.
   subroutine test_ghm_rig_equals_settled_run(dt)
      real(wp), parameter :: tol = 1.0e-8_wp
      real(wp), intent(in) :: dt
      type(model_t) :: m, mr
      type(period_map_t) :: pm
      type(shoot_options_t) :: opt
      type(shoot_result_t) :: res
      type(run_result_t) :: run
      type(error_t), allocatable :: err
      complex(wp), allocatable :: mu(:)
      character(len=:), allocatable :: text
      real(wp) :: period, y(64), bound, d_run(3), d_orb(3), w_run(4), w_orb(4), r
      integer :: e, c, p, u, n, nper
      real(wp) :: f, tau, sd(3)
      call test_begin('ghm_rig_orbit_equals_settled_run')
      open (newunit=u, file='inputs/gregory_harris_munro.nml', access='stream', form='unformatted')
      inquire (unit=u, size=n)
      allocate (character(len=n) :: text)
      read (u) text
      close (u)
      call check('the bundled deck has undamped shafts', count_of(text, 'damping = 0.0') == 2)
      call load_model_text(replace_all(text, 'damping = 0.0', 'damping = 500.0'), m)
      m%run%dt = dt
      m%run%output_interval = dt
      call forcing_period(m, period, err)
      call check('the mesh period is the forcing period', .not. allocated(err))
      call check_close('mesh period = 2 pi / (32 x 95.2286 rad/s)', period, 2.0_wp*pi/(32.0_wp*95.2286_wp), &
                       rel_tol=1.0e-12_wp)
      call pm%setup(m, period, 1, err)
      call check('the period map sets up', .not. allocated(err))
      opt%transient = 20
      call shoot(pm, opt, res, err)
      call check('the shooting ran', .not. allocated(err))
      call check('the shooting converged ('//res%message//')', res%status == shoot_converged)
      write (*, '(a,i0,a,i0,a,es10.3)') '    Newton steps ', res%newton, ', period maps ', res%maps, &
         ', residual ', res%residual
      call floquet_multipliers(res%m, mu, err)
      write (*, '(a,*(es22.14))') '    |mu| - 1: ', abs(mu) - 1.0_wp
      call check('stable: every |mu| < 1', abs(mu(1)) < 1.0_wp)
      ! the settled run
      mr = m
      mr%run%settle_tol = tol
      mr%run%settle_period = period
      mr%run%settle_time = 20.0_wp*period
      mr%run%settle_max_time = 4000.0_wp*period
      ! the measured window: N periods with |mu|^N <= (1 - |mu|)/10, so that a state
      ! within tol/(1 - |mu|) of the orbit where it settled (the contraction's bound, in
      ! the norm of M's eigenvectors) is within tol at the end with a factor 10 to spare
      ! for the componentwise norm (the eigenvectors' conditioning)
      nper = ceiling(log(0.1_wp*(1.0_wp - abs(mu(1))))/log(abs(mu(1)))) + 1
      write (*, '(a,i0,a)') '    measured window ', nper, ' mesh periods'
      mr%run%t_end = mr%run%t_start + mr%run%settle_time + real(nper, wp)*period
      mr%run%output_interval = period/16.0_wp   ! (the settling's scales from the samples)
      call run_model(mr, run)
      call check('the run settled (status 1, k = 1)', run%stats%settle_status == 1 .and. run%stats%settle_k == 1)
      write (*, '(a,i0,a)') '    settled after ', run%stats%settle_periods, ' mesh periods'
      ! the two states' element displacements and node speeds
      ! the orbit carried from its phase t0 (where no contact is in progress) to the run's
      tau = modulo(m%run%t_start - pm%t0, period)
      write (*, '(a,es12.4,a)') '    the orbit''s phase t0 - t_start = ', pm%t0 - m%run%t_start, ' s'
      y = 0.0_wp
      call pm%flow(res%x, tau, y(1:size(pm%y0)), err)
      call check('the orbit is carried to the run''s phase', .not. allocated(err))
      call mr%kinematics(pm%t0 + tau, y(1:size(pm%y0)))
      do e = 1, 3
         call mr%elements(e)%e%status_at(mr%theta, mr%omega, d_orb(e), f, c, p)
      end do
      w_orb = mr%omega
      call mr%kinematics(run%t_final, run%y_final)
      do e = 1, 3
         call mr%elements(e)%e%status_at(mr%theta, mr%omega, d_run(e), f, c, p)
      end do
      w_run = mr%omega
      call check_close('the run ended a whole number of mesh periods after t_start', &
                       modulo((run%t_final - m%run%t_start)/period + 0.5_wp, 1.0_wp) - 0.5_wp, 0.0_wp, abs_tol=1.0e-6_wp)
      ! the settling's metric (D-44): per element, relative to its largest |displacement|
      ! in the run; speeds relative to the largest |speed|
      sd = maxval(abs(run%series_disp), dim=2)
      r = max(maxval(abs(d_run - d_orb)/sd), maxval(abs(w_run - w_orb))/maxval(abs(run%series_omega)))
      bound = tol
      call check('the settled state is the orbit''s: r = '//str(r, 3)//' <= settle_tol = '//str(bound, 3), r <= bound)
      call pm%finish()
   end subroutine test_ghm_rig_equals_settled_run
end program test_periodic
