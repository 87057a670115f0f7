!> no_tension clips a contact force at zero: max(F, 0) has a kink where the
!> unclipped force passes zero in contact, and event-located RK4 keeps its
!> fourth order only if that kink is an event (D-136). A disk pressed into a
!> clearance coupling to ground (linear law, Kelvin-Voigt) is released from
!> rest: the damping takes the force to zero while the penetration is still
!> positive, after which the disk flies off at constant speed. The closed form
!> is the damped oscillator up to the root t* of k x + c x' = 0, then a straight
!> line. The observed order of the final state (the slope of log error against
!> log h) is >= 3.5 with the clip's guard; the same coupling without it (a test
!> plug-in: what the code did before D-136) falls to about 2 (a kink inside a
!> step: local error O(h^2)).
!> elasto_backlash (F = 0 if tc + td <= 0, else tc + min(tc, td)) has both kinks
!> located alike: a disk thrown into a clearance coupling at v0 meets the face
!> with td = c v0 > tc = 0 (F = 2 k x), leaves that branch where k x = c x'
!> (the min), follows the damped oscillator until k x + c x' = 0 (the clip) and
!> flies off; each phase has a closed form.
module coupling_no_clip_guard_plugin
   use trainsim_kinds, only: wp
   use trainsim_el_clearance_coupling, only: clearance_coupling_t
   implicit none
   private
   public :: coupling_no_clip_guard_t

   !> The coupling with its face guards only (no tension_guard).
   type, extends(clearance_coupling_t) :: coupling_no_clip_guard_t
   contains
      procedure :: guards => faces_only
   end type coupling_no_clip_guard_t

contains

   pure subroutine faces_only(self, thl, wl, thr, wr, g)
      class(coupling_no_clip_guard_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      associate (u1 => wl, u2 => wr)
      end associate
      call self%cl%guards(thl, thr, g(1:2))
   end subroutine faces_only
end module coupling_no_clip_guard_plugin

program test_no_tension_event
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_event, only: ev_separation
   use trainsim_el_clearance_coupling, only: clearance_coupling_t
   use coupling_no_clip_guard_plugin, only: coupling_no_clip_guard_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check_true
   use trainsim_test_support, only: load_model_text, run_model, nl, loglog_slope
   implicit none

   !> inertia, contact stiffness and damping (omega0 = 100 rad/s, zeta = 0.3),
   !> half clearance, initial penetration, end time, coarse step
   real(wp), parameter :: jd = 1.0_wp, k = 1.0e4_wp, c = 60.0_wp, b = 0.01_wp, x0 = 1.0e-3_wp
   real(wp), parameter :: t_end = 0.1_wp, h0 = 1.0e-3_wp
   !> elasto_backlash's start: angle th0 (a gap b - th0 to the face) at speed v0
   real(wp), parameter :: th0 = 0.009_wp, v0 = 0.5_wp

   call suite_begin('no_tension clip as an event (RK4 order)')
   call test_released_damped_contact_keeps_fourth_order()
   call test_elasto_backlash_branches_keep_fourth_order()
   call suite_end()

contains

   !> Final (angle, speed) of the disk at step h, with or without the clip's
   !> guard: the linear law with no_tension released from x0 (`elasto` false),
   !> or elasto_backlash thrown in at v0 from the gap g0.
   function final_state(h, guarded, elasto, n_sep) result(y)
      real(wp), intent(in) :: h
      logical, intent(in) :: guarded, elasto
      integer, intent(out) :: n_sep
      real(wp) :: y(2)
      type(model_t) :: m
      type(run_result_t) :: r
      type(coupling_no_clip_guard_t) :: plain
      character(len=24) :: a
      character(len=:), allocatable :: law
      integer :: i
      write (a, '(es22.15)') h
      law = "no_tension = .true. /"//nl//"&initial node = 'a', angle = 0.011 /"
      if (elasto) law = "contact_law = 'elasto_backlash' /"//nl//"&initial node = 'a', angle = 0.009, speed = 0.5 /"
      call load_model_text("&run t_end = 0.1, dt = "//trim(a)//", output_interval = 0.01, integrator = 'rk4' /"//nl// &
                           "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl// &
                           "&node id = 'ground', type = 'fixed' /"//nl// &
                           "&element id = 'stop', type = 'clearance_coupling', left = 'a', right = 'ground', "// &
                           "clearance = 0.02, stiffness = 1e4, contact_damping = 60.0, "//law, m)
      if (.not. guarded) then               ! the coupling as it was, in the plug-in without the clip's guard
         select type (e => m%elements(1)%e)
         type is (clearance_coupling_t)
            plain%clearance_coupling_t = e
         class default
            error stop 'the deck''s first element is not a clearance coupling'
         end select
         deallocate (m%elements(1)%e)
         allocate (m%elements(1)%e, source=plain)
         call m%finalize()
      end if
      call run_model(m, r)
      y = r%y_final(1:2)
      n_sep = 0
      do i = 1, size(r%events)
         if (r%events(i)%kind == ev_separation) n_sep = n_sep + 1
      end do
   end function final_state

   !> The closed form at t_end: x'' = -(k x + c x')/J from x0 at rest until
   !> k x + c x' = 0 at t* (clip_time), then x = x* + v* (t - t*) (clipped
   !> force zero; the separation at x = 0 changes nothing). y = (angle, speed at t_end, t*, x*).
   function closed_form() result(y)
      real(wp) :: y(4)
      real(wp) :: tc, x, v
      tc = clip_time(x0, 0.0_wp)
      call osc_from(x0, 0.0_wp, tc, x, v)
      y = [b + x + v*(t_end - tc), v, tc, x]
   end function closed_form

   !> The first time k x + c x' = 0 on the damped oscillator from (xa, va)
   !> with k xa + c va > 0, by bisection to roundoff: k x + c x' is e^(-al t)
   !> times a sinusoid of the damped frequency wd, so it changes sign exactly
   !> once within the half period pi/wd, where every state is -e^(-al pi/wd)
   !> times the start's.
   real(wp) function clip_time(xa, va) result(lo)
      real(wp), intent(in) :: xa, va
      real(wp) :: hi, tm, x, v
      integer :: i
      lo = 0.0_wp
      hi = acos(-1.0_wp)/sqrt(k/jd - (c/(2.0_wp*jd))**2)
      do i = 1, 200
         tm = 0.5_wp*(lo + hi)
         call osc_from(xa, va, tm, x, v)
         if (k*x + c*v > 0.0_wp) then
            lo = tm
         else
            hi = tm
         end if
      end do
   end function clip_time

   !> The damped oscillator J x'' + c x' + k x = 0 from (xa, va): x(t), x'(t).
   subroutine osc_from(xa, va, t, x, v)
      real(wp), intent(in) :: xa, va, t
      real(wp), intent(out) :: x, v
      real(wp) :: w0, al, wd, bb
      w0 = sqrt(k/jd)
      al = c/(2.0_wp*jd)
      wd = sqrt(w0**2 - al**2)
      bb = (va + al*xa)/wd
      x = exp(-al*t)*(xa*cos(wd*t) + bb*sin(wd*t))
      v = exp(-al*t)*(va*cos(wd*t) - (wd*xa + al*bb)*sin(wd*t))
   end subroutine osc_from

   !> elasto_backlash's closed form at t_end: free flight from th0 at v0 to the
   !> face (t0), x'' = -2 k x/J from x = 0, x' = v0 while k x < c x' (the
   !> branch 2 tc) until k x = c x' (t1 = t0 + tau1: tan(w2 tau1) = c w2/k), the
   !> damped oscillator from there until k x + c x' = 0 (t2 = t1 + tau2, the
   !> clip, clip_time), then a straight line. y = (angle, speed at t_end, t1, t2, x at t2).
   function closed_form_elasto() result(y)
      real(wp) :: y(5)
      real(wp) :: w2, t0, tau1, tau2, x1, v1, x, v
      w2 = sqrt(2.0_wp*k/jd)
      t0 = (b - th0)/v0
      tau1 = atan(c*w2/k)/w2
      x1 = v0/w2*sin(w2*tau1)
      v1 = v0*cos(w2*tau1)
      tau2 = clip_time(x1, v1)
      call osc_from(x1, v1, tau2, x, v)
      y = [b + x + v*(t_end - t0 - tau1 - tau2), v, t0 + tau1, t0 + tau1 + tau2, x]
   end function closed_form_elasto

   !> The order: the least-squares slope of log e(h) against log h over h0/2^j,
   !> j = 0 .. 3, e the error against the closed form (angle per x0, speed per
   !> x0 omega0). A slope, not one ratio: a kink's O(h^2) error depends on where
   !> the kink falls in its step.
   !> elasto_backlash (`elasto`): per v0/w2 and v0 (w2 = sqrt(2k/J), the first branch's).
   real(wp) function observed_order(guarded, e0, elasto) result(p)
      logical, intent(in) :: guarded
      real(wp), intent(out) :: e0
      logical, intent(in) :: elasto
      integer, parameter :: n = 4
      real(wp) :: h(n), e(n), y(2), yc(5), scale(2)
      integer :: j, n_sep
      if (elasto) then
         yc = closed_form_elasto()
         scale = [v0/sqrt(2.0_wp*k/jd), v0]
      else
         yc(1:4) = closed_form()
         scale = [x0, x0*sqrt(k/jd)]
      end if
      do j = 1, n
         h(j) = h0*0.5_wp**(j - 1)
         y = final_state(h(j), guarded, elasto, n_sep)
         if (n_sep /= 1) error stop 'the disk did not separate once: the test''s premise failed'
         e(j) = max(abs(y(1) - yc(1))/scale(1), abs(y(2) - yc(2))/scale(2))
      end do
      e0 = e(1)
      print '(a,l2,a,4es10.2)', '    clip guarded', guarded, ': error at h0 / 2^j, j = 0 .. 3:', e
      p = loglog_slope(h, e)
   end function observed_order

   subroutine test_released_damped_contact_keeps_fourth_order()
      real(wp) :: p_guard, p_plain, e_guard, e_plain, yc(4)
      call test_begin('released_damped_contact_keeps_fourth_order')
      yc = closed_form()
      ! the premise: the force reached zero with the disk still pressed in (x* > 0)
      print '(a,es12.4,a,es12.4)', '    closed form: the force reaches zero at t* =', yc(3), ' s with x* =', yc(4)
      call check_true('the clip acts with the disk pressed in (x* > x0/100) and moving out', &
                      yc(4) > 0.01_wp*x0 .and. yc(2) < 0.0_wp)
      p_guard = observed_order(.true., e_guard, .false.)
      p_plain = observed_order(.false., e_plain, .false.)
      print '(a,f6.2,a,f6.2)', '    observed order: with the clip''s guard', p_guard, ', without', p_plain
      call check_true('with the guard: order >= 3.5 (RK4: 4)', p_guard >= 3.5_wp)
      call check_true('without it: order < 3 (a kink inside a step: 2)', p_plain < 3.0_wp)
      call check_true('without it: error at h0 >= 10 x the error with it', e_plain >= 10.0_wp*e_guard)
   end subroutine test_released_damped_contact_keeps_fourth_order

   !> elasto_backlash's min (2 tc -> tc + td) and clip (-> 0) as events: order 4.
   subroutine test_elasto_backlash_branches_keep_fourth_order()
      real(wp) :: p_guard, p_plain, e_guard, e_plain, yc(5)
      call test_begin('elasto_backlash_branches_keep_fourth_order')
      yc = closed_form_elasto()
      print '(a,es12.4,a,es12.4,a,es12.4)', '    closed form: the min switches at t1 =', yc(3), &
         ' s, the clip at t2 =', yc(4), ' s with x =', yc(5)
      call check_true('both kinks inside the contact (t2 > t1, x(t2) > 0) and the disk moving out', &
                      yc(4) > yc(3) .and. yc(5) > 0.0_wp .and. yc(2) < 0.0_wp)
      p_guard = observed_order(.true., e_guard, .true.)
      p_plain = observed_order(.false., e_plain, .true.)
      print '(a,f6.2,a,f6.2)', '    observed order: with the guard', p_guard, ', without', p_plain
      call check_true('with the guard: order >= 3.5 (RK4: 4)', p_guard >= 3.5_wp)
      call check_true('without it: order < 3 (kinks inside steps: 2)', p_plain < 3.0_wp)
      call check_true('without it: error at h0 >= 10 x the error with it', e_plain >= 10.0_wp*e_guard)
   end subroutine test_elasto_backlash_branches_keep_fourth_order
end program test_no_tension_event
