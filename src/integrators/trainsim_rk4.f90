!> Fixed-step classical RK4 with event location, and the thesis's scheme.
!>
!> Event-located RK4 ('rk4'): the discrete modes are frozen inside a step, so
!> the right-hand side is smooth there and RK4 keeps its order. After each step
!> the guards are evaluated; if one went negative, its zero is located on the
!> RK4 step map itself (Illinois false position on s -> g(RK4(y, s))), the step
!> ends there, the element's mode is updated and the step is completed to the
!> grid. Output stays on the t_start + k dt grid.
!>
!> Thesis mode ('rk4-thesis', Appendix F): modes are set from the state at the
!> start of each step and frozen over it; no location; while any clearance is
!> closed the step is dt/10.
module trainsim_rk4
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_numeric, err_interrupted
   use trainsim_interrupt, only: interrupt_signal
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_sink, only: sink_t, event_t, run_stats_t
   use trainsim_observer, only: observer_t
   implicit none
   private

   public :: integrate_rk4, check_state

   !> Work arrays of one integration (allocated once per run).
   type :: rk4_work_t
      real(wp), allocatable :: k1(:), k2(:), k3(:), k4(:), ytmp(:), ynew(:), ys(:)
      real(wp), allocatable :: g0(:), g1(:), gs(:)
      logical, allocatable :: fired(:)
      type(event_t) :: ev(64)
   end type rk4_work_t

contains

   !> One classical RK4 step of size h from (t, y) into ynew; k1 = f(t, y) given.
   !> A step that ends on a breakpoint of the inputs takes its last stage at the
   !> left limit there (a load that jumps at t + h acts from t + h on).
   subroutine rk4_step(model, t, y, h, w, ynew, stats, left_limit)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:), h
      type(rk4_work_t), intent(inout) :: w
      real(wp), intent(out) :: ynew(:)
      type(run_stats_t), intent(inout) :: stats
      logical, intent(in), optional :: left_limit
      real(wp) :: t4
      t4 = t + h
      if (present(left_limit)) then
         if (left_limit) t4 = t + h - 1.0e-9_wp*h
      end if
      w%ytmp = y + 0.5_wp*h*w%k1
      call model%rhs(t + 0.5_wp*h, w%ytmp, w%k2)
      w%ytmp = y + 0.5_wp*h*w%k2
      call model%rhs(t + 0.5_wp*h, w%ytmp, w%k3)
      w%ytmp = y + h*w%k3
      call model%rhs(t4, w%ytmp, w%k4)
      ynew = y + (h/6.0_wp)*(w%k1 + 2.0_wp*(w%k2 + w%k3) + w%k4)
      stats%rhs_evals = stats%rhs_evals + 3
   end subroutine rk4_step

   !> NaN or runaway state -> error naming the time, the state and the step.
   subroutine check_state(model, t, y, h, err)
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: t, y(:), h
      type(error_t), allocatable, intent(out) :: err
      integer :: i
      do i = 1, model%n_states
         if (y(i) /= y(i) .or. abs(y(i)) > 1.0e100_wp) then
            call fatal_error(err, 'the solution blew up at t = '//str(t)//' s (state '//str(i)// &
                             ' is '//trim(merge('NaN    ', 'runaway', y(i) /= y(i)))//'); the time step '//str(h)// &
                             ' s is probably above the stability limit: run `trainsim modes` on the deck '// &
                             'and take dt below 2.8/omega_max', err_numeric)
            return
         end if
      end do
   end subroutine check_state

   !> Integrate from (t, y) to t_end, reporting to the observer.
   subroutine integrate_rk4(model, obs, sink, t, y, stats, thesis, err)
      type(model_t), intent(inout) :: model
      type(observer_t), intent(inout) :: obs
      class(sink_t), intent(inout) :: sink
      real(wp), intent(inout) :: t
      real(wp), intent(inout) :: y(:)
      type(run_stats_t), intent(inout) :: stats
      logical, intent(in) :: thesis
      type(error_t), allocatable, intent(out) :: err
      type(rk4_work_t) :: w
      integer(i8) :: istep, nsteps
      real(wp) :: dt, t0, t_target, h, t_sub, tiny_t
      real(wp), allocatable :: bp(:)
      integer :: n, ng, ib
      logical :: at_bp

      n = size(y); ng = model%n_guards
      allocate (w%k1(n), w%k2(n), w%k3(n), w%k4(n), w%ytmp(n), w%ynew(n), w%ys(n))
      allocate (w%g0(ng), w%g1(ng), w%gs(ng), w%fired(ng))
      dt = model%run%dt
      t0 = model%run%t_start
      nsteps = ceiling((model%run%t_end - t0)/dt - 1.0e-9_wp, i8)
      call model%breakpoints(t, model%run%t_end, bp)
      ib = 1
      tiny_t = 1.0e-12_wp*dt

      if (thesis) then
         call thesis_loop()
         return
      end if

      do istep = 1, nsteps
         t_target = min(t0 + real(istep, wp)*dt, model%run%t_end)
         do while (t < t_target - tiny_t)
            ! end the sub-step at the next breakpoint of the inputs, if one comes first
            do while (ib <= size(bp))
               if (bp(ib) > t + tiny_t) exit
               ib = ib + 1
            end do
            t_sub = t_target
            at_bp = .false.
            if (ib <= size(bp)) then
               if (bp(ib) <= t_target + tiny_t) then
                  t_sub = min(bp(ib), t_target)
                  at_bp = .true.
               end if
            end if
            h = t_sub - t
            call model%rhs(t, y, w%k1)
            stats%rhs_evals = stats%rhs_evals + 1
            call rk4_step(model, t, y, h, w, w%ynew, stats, at_bp)
            if (ng > 0) then
               call model%guards(t + h, w%ynew, w%g1)
               if (any(w%g1 < 0.0_wp)) then
                  call handle_event(h)
                  if (allocated(err)) return
                  cycle
               end if
            end if
            y = w%ynew
            t = t_sub
            if (at_bp .and. abs(t_sub - t_target) <= tiny_t) t = t_target
         end do
         stats%steps = stats%steps + 1
         call check_state(model, t, y, dt, err); if (allocated(err)) return
         call obs%step(model, t, y, sink, err); if (allocated(err)) return
         ! interrupt check (SIGINT/SIGTERM; to move into the common driver)
         if (interrupt_signal() /= 0) call fatal_error(err, 'interrupted at t = '//str(t)//' s', err_interrupted)
         if (allocated(err)) return
      end do

   contains

      !> A guard went negative inside [t, t+h]: locate the earliest zero, end the
      !> step there, update the modes and report the events.
      subroutine handle_event(h)
         real(wp), intent(in) :: h
         real(wp) :: s_best, s, tol
         integer :: j, nev, pass
         call model%guards(t, y, w%g0)
         tol = model%run%event_tol
         if (tol <= 0.0_wp) tol = 1.0e-9_wp*dt
         s_best = h
         do j = 1, ng
            if (w%g1(j) < 0.0_wp) then
               s = locate(j, h, max(w%g0(j), 0.0_wp), w%g1(j), tol)
               s_best = min(s_best, s)
            end if
         end do
         if (s_best < h) then
            call rk4_step(model, t, y, s_best, w, w%ys, stats)
         else
            w%ys = w%ynew
         end if
         t = t + s_best
         y = w%ys
         stats%root_returns = stats%root_returns + 1
         ! several guards may be past zero at the located point: apply until none is
         do pass = 1, 4
            call model%guards(t, y, w%gs)
            w%fired = w%gs < 0.0_wp
            if (.not. any(w%fired)) exit
            nev = 0
            call model%apply_events(t, y, w%fired, w%ev, nev)
            call obs%record_events(model, t, y, w%ev, nev, sink, err)
            if (allocated(err)) return
         end do
      end subroutine handle_event

      !> Zero of guard j on s in (0, h]: Illinois false position on the RK4
      !> step map; returns the end of the final bracket where g < 0.
      real(wp) function locate(j, h, ga, gb, tol) result(b)
         integer, intent(in) :: j
         real(wp), intent(in) :: h, ga, gb, tol
         real(wp) :: a, fa, fb, s, fs
         integer :: side, it
         a = 0.0_wp; b = h; fa = ga; fb = gb; side = 0
         ! w%k1 still holds f(t, y) from the step being located
         do it = 1, 200
            if (b - a <= tol) exit
            s = (a*fb - b*fa)/(fb - fa)
            ! keep the new point inside the bracket, away from its ends
            s = min(max(s, a + 0.01_wp*(b - a)), b - 0.01_wp*(b - a))
            call rk4_step(model, t, y, s, w, w%ys, stats)
            call model%guards(t + s, w%ys, w%gs)
            fs = w%gs(j)
            if (fs < 0.0_wp) then
               b = s; fb = fs
               if (side == -1) fa = 0.5_wp*fa
               side = -1
            else
               a = s; fa = fs
               if (side == 1) fb = 0.5_wp*fb
               side = 1
            end if
         end do
      end function locate

      !> Appendix F: modes from the start-of-step state, frozen; dt/10 in contact.
      subroutine thesis_loop()
         integer :: nev
         real(wp) :: t_end
         t_end = model%run%t_end
         do while (t < t_end - 1.0e-12_wp*dt)
            if (ng > 0) then
               call model%guards(t, y, w%g0)
               w%fired = w%g0 < 0.0_wp
               if (any(w%fired)) then
                  nev = 0
                  call model%apply_events(t, y, w%fired, w%ev, nev)
                  call obs%record_events(model, t, y, w%ev, nev, sink, err)
                  if (allocated(err)) return
               end if
            end if
            h = dt
            if (model%any_contact()) h = 0.1_wp*dt
            h = min(h, t_end - t)
            call model%rhs(t, y, w%k1)
            stats%rhs_evals = stats%rhs_evals + 1
            call rk4_step(model, t, y, h, w, w%ynew, stats)
            y = w%ynew
            t = t + h
            stats%steps = stats%steps + 1
            call check_state(model, t, y, dt, err); if (allocated(err)) return
            call obs%step(model, t, y, sink, err); if (allocated(err)) return
            ! interrupt check (SIGINT/SIGTERM; to move into the common driver)
            if (interrupt_signal() /= 0) call fatal_error(err, 'interrupted at t = '//str(t)//' s', err_interrupted)
            if (allocated(err)) return
         end do
      end subroutine thesis_loop
   end subroutine integrate_rk4
end module trainsim_rk4
