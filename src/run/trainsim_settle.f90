!> Settling until periodic (&run settle_tol, D-44): the state sampled once per settle
!> period outside the step loop, compared with the samples one to settle_kmax periods
!> before, and the verdict that starts the metrics and sets the end of the run.
module trainsim_settle
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_model, only: model_t, settle_budget
   use trainsim_sink, only: sink_t
   use trainsim_observer, only: observer_t
   implicit none
   private

   public :: settle_t, settle_setup, settle_sample, settle_kmax

   !> Settling until periodic (D-44): the longest attractor period looked for, in
   !> settle periods.
   integer, parameter :: settle_kmax = 8
   !> The tolerance of the verdict at settle_time of a run with no settle_tol (D-44).
   real(wp), parameter :: settle_check_tol = 1.0e-3_wp

   !> Settling until periodic (&run settle_tol, D-44): the state is sampled at
   !> t_start + j T (T = settle_period), once per period, outside the step loop. The
   !> state is every element's displacement (its deformation: relative angle, or
   !> transmission error) and every node's speed; sample j is compared with samples
   !> j - k, k = 1 .. settle_kmax, component by component, relative to the largest
   !> magnitude the component has had at the samples so far (one scale for all
   !> speeds, which share a unit; one per element, whose units differ):
   !>     r_k(j) = max_c |x_c(j) - x_c(j - k)| / s_c.
   !> Settled (periodic) at the first j with t_j >= t_start + settle_time and
   !> r_1(j) <= tol; an attractor of k > 1 periods when r_k <= tol at two successive
   !> samples while r_1 > sqrt(tol) (far from repeating after one period: a transient
   !> decaying towards a 1-periodic state has r_k ~ r_1 and reaches tol with k = 1
   !> within a period or two). Not settled when t_start + settle_max_time passes first.
   !> The metrics then start at t_j and the run ends a measured window later (the
   !> deck's t_end - t_start - settle_time, a whole number of the k periods).
   type :: settle_t
      logical :: on = .false., done = .false.
      !> no settle_tol but a settle_time and a period: only a verdict at settle_time
      !> (to check_tol), the run and its metrics unchanged
      logical :: check_only = .false.
      real(wp) :: period = 0.0_wp, tol = 0.0_wp, t_min = 0.0_wp, t_budget = 0.0_wp, measure = 0.0_wp
      real(wp) :: t0 = 0.0_wp, t_next = 0.0_wp, t_settled = 0.0_wp
      integer :: j = -1                 !< index of the last sample (sample 0: t_start)
      integer :: k = 0                  !< periods of the attractor found (0: none)
      integer :: status = 0             !< run_stats_t%settle_status
      real(wp), allocatable :: x(:, :)  !< (component, 0:settle_kmax) ring of samples
      real(wp), allocatable :: scale(:) !< per component: largest magnitude so far
      integer :: hits(settle_kmax) = 0  !< per k: successive samples with r_k <= tol
   end type settle_t

contains

   !> Settling until periodic (settle_t): set up from &run, and model%run%t_end moved
   !> to the latest end the settling budget allows (simulate puts it back).
   subroutine settle_setup(model, st, err)
      type(model_t), intent(inout) :: model
      type(settle_t), intent(inout) :: st
      type(error_t), allocatable, intent(out) :: err
      integer :: n
      if (.not. model%run%settle_tol > 0.0_wp) then
         ! a fixed settle_time: say whether the response has settled by then
         if (.not. (model%run%settle_time > 0.0_wp .and. model%run%settle_period > 0.0_wp)) return
         st%check_only = .true.
      else if (.not. model%run%settle_period > 0.0_wp) then
         call fatal_error(err, '&run settle_tol = '//str(model%run%settle_tol)//' needs a settle_period: give '// &
                          '&run settle_period (s), or a gear pair with teeth whose mesh period sets it', err_input)
         return
      end if
      st%on = .true.
      st%period = model%run%settle_period
      st%tol = model%run%settle_tol
      st%t0 = model%run%t_start
      st%t_min = model%run%t_start + model%run%settle_time
      st%t_budget = model%run%t_start + settle_budget(model%run)
      if (st%check_only) then
         st%tol = settle_check_tol
         st%t_budget = st%t_min
      end if
      st%measure = model%run%t_end - st%t_min
      st%t_next = st%t0
      n = size(model%elements) + size(model%nodes)
      allocate (st%x(n, 0:settle_kmax), st%scale(n))
      st%x = 0.0_wp
      st%scale = 0.0_wp
      if (st%check_only) return
      model%run%t_end = st%t_budget + st%measure + real(settle_kmax + 1, wp)*st%period
   end subroutine settle_setup

   !> Sample the state at (t, y), a settle instant t0 + j T, and decide whether the
   !> response has settled (settle_t); when it has (or the budget is spent), the
   !> observer's metrics start at t and `t_end` becomes the end of the measured window.
   subroutine settle_sample(model, obs, sink, st, t, y, t_end)
      type(model_t), intent(inout) :: model
      type(observer_t), intent(inout) :: obs
      class(sink_t), intent(inout) :: sink
      type(settle_t), intent(inout) :: st
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: t_end
      integer :: ne, e, c, p, slot, k, kk
      real(wp) :: f, w, r1, measure
      ne = size(model%elements)
      st%j = st%j + 1
      slot = modulo(st%j, settle_kmax + 1)
      call model%kinematics(t, y)
      do e = 1, ne
         call model%elements(e)%e%status_at(model%theta, model%omega, st%x(e, slot), f, c, p)   ! (ports: D-73)
      end do
      st%x(ne + 1:, slot) = model%omega
      st%scale(1:ne) = max(st%scale(1:ne), abs(st%x(1:ne, slot)))
      w = max(maxval(st%scale(ne + 1:)), maxval(abs(model%omega)))
      st%scale(ne + 1:) = w
      st%t_next = st%t0 + real(st%j + 1, wp)*st%period
      r1 = huge(1.0_wp)
      do k = 1, min(settle_kmax, st%j)
         f = maxval(abs(st%x(:, slot) - st%x(:, modulo(st%j - k, settle_kmax + 1)))/max(st%scale, tiny(1.0_wp)))
         if (k == 1) r1 = f
         if (f <= st%tol) then
            st%hits(k) = st%hits(k) + 1
         else
            st%hits(k) = 0
         end if
      end do
      if (t < st%t_min - 1.0e-9_wp*st%period) return
      kk = 0
      if (st%hits(1) >= 1) then
         kk = 1
      else if (r1 > sqrt(st%tol)) then
         do k = 2, min(settle_kmax, st%j)
            if (st%hits(k) >= 2) then
               kk = k
               exit
            end if
         end do
      end if
      if (kk > 0) then
         st%status = 1
         st%k = kk
      else if (t >= st%t_budget - 1.0e-9_wp*st%period) then
         st%status = 2
      else
         return
      end if
      st%done = .true.
      st%t_settled = t
      if (st%check_only) return
      measure = st%measure
      if (kk > 1) measure = real(kk, wp)*st%period*max(1.0_wp, aint(measure/(real(kk, wp)*st%period) + 1.0_wp - &
                                                                      1.0e-9_wp))
      t_end = t + measure
      obs%t_metrics = t
      call sink%metrics_from(t)
   end subroutine settle_sample
end module trainsim_settle
