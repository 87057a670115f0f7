!> Figures read off a time series, defined precisely (docs/decisions.md, D-17):
!>
!> * p2p_range: max - min over the samples with t >= t_from.
!> * p2p_mean: the thesis's "average peak-to-peak error from the first peak to
!>   the last full peak". The extrema of x(t) are taken with a hysteresis of
!>   `hyst` times p2p_range (a turn counts only once x has come back by that
!>   much, so ripples are not peaks); the sequence starts at the first maximum;
!>   each maximum followed by a minimum is one swing; p2p_mean is the mean of
!>   those swings (the last maximum without a following minimum is not full).
module trainsim_metrics
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: peak_to_peak, peak_to_peak_values, turning_points_t

   !> The turning points of a sampled signal, kept online: the first sample, every
   !> sample where the direction changes, and (after `close`) the last one. The
   !> hysteresis peak detector below only ever looks at the running extreme of
   !> each monotone stretch, which is its end, so it gives exactly the same
   !> figures on the turning points as on every sample, for a fraction of the
   !> memory (two values per oscillation instead of every output sample).
   type :: turning_points_t
      real(wp), allocatable :: x(:)
      integer :: n = 0
      real(wp) :: last = 0.0_wp
      integer :: dir = 0
      logical :: open = .false.
   contains
      procedure :: push => tp_push
      procedure :: close => tp_close
      procedure, private :: append => tp_append
   end type turning_points_t

contains

   !> Peak-to-peak figures of x(t) for t >= t_from (see the module note).
   pure subroutine peak_to_peak(t, x, t_from, hyst, p2p_range, p2p_mean, n_swings)
      real(wp), intent(in) :: t(:), x(:), t_from, hyst
      real(wp), intent(out) :: p2p_range, p2p_mean
      integer, intent(out) :: n_swings
      integer :: i, i0
      i0 = 0
      do i = 1, size(t)
         if (t(i) >= t_from) then
            i0 = i
            exit
         end if
      end do
      if (i0 == 0) then
         p2p_range = 0.0_wp; p2p_mean = 0.0_wp; n_swings = 0
         return
      end if
      call peak_to_peak_values(x(i0:), hyst, p2p_range, p2p_mean, n_swings)
   end subroutine peak_to_peak

   !> Peak-to-peak figures of the sample values x (or of their turning points).
   pure subroutine peak_to_peak_values(x, hyst, p2p_range, p2p_mean, n_swings)
      real(wp), intent(in) :: x(:), hyst
      real(wp), intent(out) :: p2p_range, p2p_mean
      integer, intent(out) :: n_swings
      integer :: i, dir
      real(wp) :: h, cand, last_max, total
      logical :: have_max
      p2p_range = 0.0_wp; p2p_mean = 0.0_wp; n_swings = 0
      if (size(x) < 2) return
      p2p_range = maxval(x) - minval(x)
      if (p2p_range <= 0.0_wp) return
      h = hyst*p2p_range
      ! dir = +1 while rising towards a maximum, -1 while falling towards a minimum
      dir = 0; cand = x(1); have_max = .false.; last_max = 0.0_wp; total = 0.0_wp
      do i = 2, size(x)
         select case (dir)
         case (0)
            if (x(i) >= cand + h) then
               dir = 1; cand = x(i)
            else if (x(i) <= cand - h) then
               dir = -1; cand = x(i)
            end if
         case (1)
            if (x(i) > cand) then
               cand = x(i)
            else if (x(i) <= cand - h) then   ! cand was a maximum
               have_max = .true.; last_max = cand
               dir = -1; cand = x(i)
            end if
         case (-1)
            if (x(i) < cand) then
               cand = x(i)
            else if (x(i) >= cand + h) then   ! cand was a minimum
               if (have_max) then
                  total = total + (last_max - cand)
                  n_swings = n_swings + 1
               end if
               dir = 1; cand = x(i)
            end if
         end select
      end do
      if (n_swings > 0) p2p_mean = total/real(n_swings, wp)
   end subroutine peak_to_peak_values

   !> Take the next sample.
   subroutine tp_push(self, x)
      class(turning_points_t), intent(inout) :: self
      real(wp), intent(in) :: x
      integer :: d
      if (.not. self%open) then
         call self%append(x)
         self%open = .true.
         self%last = x
         return
      end if
      d = 0
      if (x > self%last) d = 1
      if (x < self%last) d = -1
      if (d == 0) return
      if (self%dir /= 0 .and. d /= self%dir) call self%append(self%last)   ! self%last was a turn
      self%dir = d
      self%last = x
   end subroutine tp_push

   !> After the last sample: keep it (the end of the final monotone stretch).
   subroutine tp_close(self)
      class(turning_points_t), intent(inout) :: self
      if (self%open .and. self%dir /= 0) call self%append(self%last)
      self%open = .false.
   end subroutine tp_close

   subroutine tp_append(self, x)
      class(turning_points_t), intent(inout) :: self
      real(wp), intent(in) :: x
      real(wp), allocatable :: grown(:)
      if (.not. allocated(self%x)) allocate (self%x(64))
      if (self%n == size(self%x)) then
         allocate (grown(2*self%n))
         grown(1:self%n) = self%x(1:self%n)
         call move_alloc(grown, self%x)
      end if
      self%n = self%n + 1
      self%x(self%n) = x
   end subroutine tp_append
end module trainsim_metrics
