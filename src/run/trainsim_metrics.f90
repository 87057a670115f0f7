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

   public :: peak_to_peak

contains

   !> Peak-to-peak figures of x(t) for t >= t_from (see the module note).
   pure subroutine peak_to_peak(t, x, t_from, hyst, p2p_range, p2p_mean, n_swings)
      real(wp), intent(in) :: t(:), x(:), t_from, hyst
      real(wp), intent(out) :: p2p_range, p2p_mean
      integer, intent(out) :: n_swings
      integer :: i, i0, dir
      real(wp) :: xmax, xmin, h, cand, last_max, total
      logical :: have_max
      p2p_range = 0.0_wp; p2p_mean = 0.0_wp; n_swings = 0
      i0 = 0
      do i = 1, size(t)
         if (t(i) >= t_from) then
            i0 = i
            exit
         end if
      end do
      if (i0 == 0 .or. i0 >= size(t)) return
      xmax = maxval(x(i0:)); xmin = minval(x(i0:))
      p2p_range = xmax - xmin
      if (p2p_range <= 0.0_wp) return
      h = hyst*p2p_range
      ! dir = +1 while rising towards a maximum, -1 while falling towards a minimum
      dir = 0; cand = x(i0); have_max = .false.; last_max = 0.0_wp; total = 0.0_wp
      do i = i0 + 1, size(t)
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
   end subroutine peak_to_peak
end module trainsim_metrics
