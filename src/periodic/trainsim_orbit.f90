!> A periodic orbit found by shooting, as a run: the k forcing periods from its
!> state at t0 integrated into a sink (the run's own metrics, events and
!> history), and the grazing check on its clearances.
!>
!> Grazing (D-99): an orbit whose displacement across a clearance turns at the
!> contact boundary, delta = +-b (a contact that just touches, or just fails to
!> open). For every clearance element the orbit's extremes of delta (the run's
!> metrics disp_min, disp_max) are compared with both faces, and the closest,
!>     gap = min |extreme -+ b| / b,
!> is reported; the orbit grazes when gap <= graze_tol. Only the orbit's
!> global extremes are looked at: a turn of delta near a face between them
!> is not seen.
module trainsim_orbit
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_model, only: model_t
   use trainsim_sink, only: sink_t, null_sink_t
   use trainsim_observer, only: run_result_t
   use trainsim_simulate, only: simulate
   use trainsim_clearance_element, only: clearance_element_t
   use trainsim_period_map, only: period_map_t
   implicit none
   private

   public :: orbit_run, orbit_grazing, graze_tol

   !> An orbit grazes when an extreme of a clearance's displacement lies within this
   !> fraction of the half clearance of a face (the extremes are the run's samples at
   !> its output times: a turn between samples is off by (w dt_out)^2/8 of the amplitude).
   real(wp), parameter :: graze_tol = 1.0e-3_wp

contains

   !> Run `model` over pm's k periods from the reduced state x at t0 into `sink`: the
   !> orbit's history, events and metrics (no settling); p2p_range from a second run two
   !> steps longer (the turning points at the seam, D-143).
   subroutine orbit_run(model, pm, x, sink, res, err, stale)
      type(model_t), intent(in) :: model
      type(period_map_t), intent(in) :: pm
      real(wp), intent(in) :: x(:)
      class(sink_t), intent(inout), target :: sink
      type(run_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      !> the first clearance with a memory (pm%memory) that is in contact at t0 and
      !> strikes on the orbit: that contact came from an impact whose damping the state
      !> at t0 does not hold, and the map restarts it with the law's start (D-99, D-144):
      !> not an orbit of the train. 0: none.
      integer, intent(out), optional :: stale
      type(model_t) :: m
      type(null_sink_t) :: none
      type(run_result_t) :: seam
      real(wp) :: y(size(pm%y0))
      integer :: i
      m = model
      y = pm%full_state(x)
      do i = 1, size(m%nodes)
         if (m%speed_of(i) /= 0 .or. m%nodes(i)%n%nstates() == 0) cycle
         if (m%nodes(i)%n%nstates() > 2) then
            call fatal_error(err, "the orbit's run needs nodes whose state is an angle and a speed; node '"// &
                             m%nodes(i)%n%id//"' has more (a motor's current)", err_input)
            return
         end if
         m%nodes(i)%n%theta0 = y(m%nodes(i)%n%offset + 1)
         m%nodes(i)%n%omega0 = y(m%nodes(i)%n%offset + 2)
      end do
      if (present(stale)) stale = stale_contact(m, pm, y)
      m%run%preload = .false.
      m%run%t_start = pm%t0
      m%run%t_end = pm%t0 + real(pm%k, wp)*pm%period
      m%run%settle_tol = 0.0_wp
      m%run%settle_time = 0.0_wp
      call pm%hold_memory(m)   ! (a contact closed at t0 goes on with the orbit's memory, D-150)
      call simulate(m, sink, res, err)
      if (allocated(err)) return
      ! p2p_range across the seam t0 = t0 + kT (D-143): a turning point in the first or
      ! last step of the window has no step end on one side there and falls back to a
      ! sample; the k periods and two steps beyond have each one inside. The range
      ! only: every other metric is of the k periods.
      m%run%t_end = m%run%t_end + 2.0_wp*m%run%dt
      call simulate(m, none, seam, err)
      if (allocated(err)) return
      do i = 1, min(size(res%el), size(seam%el))
         res%el(i)%p2p_range = max(res%el(i)%p2p_range, seam%el(i)%p2p_range)
      end do
      if (present(stale)) then
         if (stale > 0) then
            if (.not. res%el(stale)%impacts > 0) stale = 0
         end if
      end if
   end subroutine orbit_run

   !> The first clearance with a memory in contact in the full state y at t0 (0: none;
   !> orbit_run keeps it only if it strikes on the orbit).
   integer function stale_contact(m, pm, y) result(e)
      type(model_t), intent(inout) :: m
      type(period_map_t), intent(in) :: pm
      real(wp), intent(in) :: y(:)
      real(wp) :: d, f
      integer :: i, c, p
      e = 0
      if (size(pm%memory) == 0) return
      call m%kinematics(pm%t0, y)
      do i = 1, size(pm%memory)
         call m%elements(pm%memory(i))%e%status_at(m%theta, m%omega, d, f, c, p)   ! (d: delta; c is the mode's)
         select type (el => m%elements(pm%memory(i))%e)
         class is (clearance_element_t)
            if (abs(d) >= el%cl%b) then
               e = pm%memory(i)
               return
            end if
         end select
      end do
   end function stale_contact

   !> The grazing check on the orbit's run `res`: per element, the gap (the closest
   !> extreme of delta to a face, over the half clearance b; huge for an element
   !> without a clearance) and the smallest of them with its element (0: none).
   subroutine orbit_grazing(model, res, gap, worst)
      type(model_t), intent(in) :: model
      type(run_result_t), intent(in) :: res
      real(wp), allocatable, intent(out) :: gap(:)
      integer, intent(out) :: worst
      real(wp) :: b, lo, hi
      integer :: e
      allocate (gap(size(model%elements)))
      gap = huge(1.0_wp)
      worst = 0
      do e = 1, size(model%elements)
         select type (el => model%elements(e)%e)
         class is (clearance_element_t)
            b = el%cl%b
            if (.not. b > 0.0_wp) cycle
            lo = res%el(e)%disp_min
            hi = res%el(e)%disp_max
            gap(e) = min(abs(hi - b), abs(lo - b), abs(hi + b), abs(lo + b))/b
            if (worst == 0) then
               worst = e
            else if (gap(e) < gap(worst)) then
               worst = e
            end if
         end select
      end do
   end subroutine orbit_grazing
end module trainsim_orbit
