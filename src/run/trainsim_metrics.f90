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

   public :: peak_to_peak, peak_to_peak_values, p2p_detector_t, push_samples, push_block, push_value, turn_extreme

   !> State of the hysteresis peak detector (as in peak_to_peak_values).
   type :: p2p_state_t
      integer :: dir = 0                     !< 0 none yet, +1 rising, -1 falling
      real(wp) :: cand = 0.0_wp              !< running extreme of the current edge
      real(wp) :: last_ext = 0.0_wp          !< last confirmed extreme (the first sample before)
      logical :: have_max = .false.
      real(wp) :: last_max = 0.0_wp, total = 0.0_wp
      integer :: n_swings = 0
   end type p2p_state_t

   !> Extremes kept for a replay, per signal (8 B each); half are folded when full.
   integer, parameter :: p2p_log_size = 512

   !> The peak-to-peak figures of a sampled signal, computed online in bounded
   !> memory: the hysteresis peak detector of peak_to_peak_values run sample by
   !> sample with the threshold h = hyst * (range so far), which never
   !> decreases and ends at the definition's hyst * (whole range).
   !>
   !> When the range grows, h rises to h'. The detector's state is still the
   !> state of a detector run with h' from the start if every edge between
   !> confirmed extremes (the first from the first sample) is at least h':
   !> such a detector confirms the same extremes, only later in each edge. The
   !> edge still growing (last confirmed extreme to the running extreme) is
   !> checked as the detector would with h'. If either fails, the detector is
   !> run again with h' over the extremes confirmed so far (the detector on
   !> those alone gives what it gives on every sample, for any threshold at
   !> least the ones they were found with), from a folded state: the log holds
   !> the last p2p_log_size extremes, and when full its older half is folded
   !> (run through the detector) into that state. The replay is exact if the
   !> folded part's edges are all at least h'; if not (the range grew, after
   !> more than p2p_log_size/2 extremes, past ten times an edge already
   !> folded), the past cannot be re-decided without the whole series: the
   !> detector goes on with h', and `exact` becomes .false. Edges are compared
   !> with a margin of a few ulps of the signal, so `exact` = .true. guarantees
   !> the whole-series figures, to the bit.
   type :: p2p_detector_t
      real(wp) :: hyst = 0.1_wp
      integer :: n = 0                       !< samples seen
      real(wp) :: x1 = 0.0_wp, xmin = 0.0_wp, xmax = 0.0_wp, h = 0.0_wp
      logical :: exact = .true.
      type(p2p_state_t) :: s                 !< the detector now
      type(p2p_state_t) :: f                 !< the detector before the log (folded part)
      real(wp) :: e_min = huge(1.0_wp)       !< shortest confirmed edge
      real(wp) :: e_min_f = huge(1.0_wp)     !< shortest edge of the folded part
      real(wp), allocatable :: log(:)        !< extremes confirmed after f%cand
      integer :: n_log = 0
      integer :: replays = 0                 !< diagnostics: replays made
   contains
      procedure :: push => det_push
      procedure :: figures => det_figures
   end type p2p_detector_t

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

   !> One sample through the detector with threshold h (the loop body of
   !> peak_to_peak_values). On return `confirmed` says whether an extreme was
   !> confirmed (its value: st%last_ext) and `edge` its distance from the one before.
   pure subroutine feed(st, x, h, confirmed, edge)
      type(p2p_state_t), intent(inout) :: st
      real(wp), intent(in) :: x, h
      logical, intent(out) :: confirmed
      real(wp), intent(out) :: edge
      confirmed = .false.; edge = 0.0_wp
      select case (st%dir)
      case (0)
         if (x >= st%cand + h) then
            st%dir = 1; st%cand = x
         else if (x <= st%cand - h) then
            st%dir = -1; st%cand = x
         end if
      case (1)
         if (x > st%cand) then
            st%cand = x
         else if (x <= st%cand - h) then   ! cand was a maximum
            confirmed = .true.; edge = abs(st%cand - st%last_ext); st%last_ext = st%cand
            st%have_max = .true.; st%last_max = st%cand
            st%dir = -1; st%cand = x
         end if
      case (-1)
         if (x < st%cand) then
            st%cand = x
         else if (x >= st%cand + h) then   ! cand was a minimum
            confirmed = .true.; edge = abs(st%cand - st%last_ext); st%last_ext = st%cand
            if (st%have_max) then
               st%total = st%total + (st%last_max - st%cand)
               st%n_swings = st%n_swings + 1
            end if
            st%dir = 1; st%cand = x
         end if
      end select
   end subroutine feed

   !> Take the next sample.
   subroutine det_push(self, x)
      class(p2p_detector_t), intent(inout) :: self
      real(wp), intent(in) :: x
      real(wp) :: h_new, edge, margin
      logical :: confirmed, redo
      self%n = self%n + 1
      if (self%n == 1) then
         self%x1 = x; self%xmin = x; self%xmax = x
         self%s%cand = x; self%s%last_ext = x
         self%f = self%s
         return
      end if
      if (x < self%xmin .or. x > self%xmax) then
         self%xmin = min(self%xmin, x); self%xmax = max(self%xmax, x)
         h_new = self%hyst*(self%xmax - self%xmin)
         if (h_new > self%h) then
            margin = 16.0_wp*epsilon(1.0_wp)*max(abs(self%xmin), abs(self%xmax))
            ! the confirmed edges, and the edge still growing as the detector would see it with h_new
            redo = self%e_min < h_new + margin
            if (self%s%dir > 0) redo = redo .or. .not. (self%s%cand >= self%s%last_ext + h_new)
            if (self%s%dir < 0) redo = redo .or. .not. (self%s%cand <= self%s%last_ext - h_new)
            self%h = h_new
            if (redo) then
               if (self%e_min_f < h_new + margin) self%exact = .false.
               call replay(self)
            end if
         end if
      end if
      if (.not. self%h > 0.0_wp) return   ! all samples so far equal: nothing to decide
      call feed(self%s, x, self%h, confirmed, edge)
      if (confirmed) then
         self%e_min = min(self%e_min, edge)
         call keep(self, self%s%last_ext)
      end if
   contains
      !> The detector again with threshold self%h: from the folded state over
      !> the logged extremes and the running extreme. The log is rewritten in
      !> place with the extremes confirmed now: feeding log(i) confirms at most
      !> one, so the i-th write lands at or before i, on an entry already read.
      !> The running extreme fed last can confirm one more than the log held
      !> (the folded state's own running extreme, confirmed by log(1), is not
      !> in the log): that one goes through `keep`, which folds a full log.
      subroutine replay(d)
         type(p2p_detector_t), intent(inout) :: d
         real(wp) :: c
         integer :: i, n_old
         logical :: conf
         real(wp) :: e
         d%replays = d%replays + 1
         c = d%s%cand
         n_old = d%n_log
         d%s = d%f
         d%e_min = d%e_min_f
         d%n_log = 0
         do i = 1, n_old
            call feed(d%s, d%log(i), d%h, conf, e)
            if (conf) then
               d%e_min = min(d%e_min, e)
               d%n_log = d%n_log + 1
               d%log(d%n_log) = d%s%last_ext
            end if
         end do
         call feed(d%s, c, d%h, conf, e)
         if (conf) then
            d%e_min = min(d%e_min, e)
            call keep(d, d%s%last_ext)
         end if
      end subroutine replay
   end subroutine det_push

   !> One sample per detector: x(i) to det(i) (push_one).
   subroutine push_samples(det, x)
      type(p2p_detector_t), intent(inout) :: det(:)
      real(wp), intent(in) :: x(:)
      integer :: i
      do i = 1, size(det)
         call push_one(det(i), x(i))
      end do
   end subroutine push_samples

   !> `push_samples` for the samples j0 .. n of a block, x(element, sample):
   !> each detector takes its samples in order, detector by detector (they are
   !> independent: the same as column by column, D-38).
   subroutine push_block(det, x, j0, n)
      type(p2p_detector_t), intent(inout) :: det(:)
      real(wp), intent(in) :: x(:, :)
      integer, intent(in) :: j0, n
      integer :: i, j, js
      real(wp) :: xv, lo, hi, h, cand
      do i = 1, size(det)
         associate (d => det(i))
            ! push_one's usual sample (inside the range seen so far, on an edge
            ! that confirms nothing) in a loop of its own per edge direction, on
            ! the detector's state in registers (the count added after it); any
            ! other sample goes to push_one itself
            j = j0
            do while (j <= n)
               lo = d%xmin; hi = d%xmax; h = d%h; cand = d%s%cand
               js = j
               ! (where cand - h >= lo, xv > cand - h is xv >= lo too, and stays so:
               ! cand only grows on a rising edge; cand + h <= hi likewise; D-161)
               if (d%n > 0 .and. h > 0.0_wp) then
                  if (d%s%dir == 1 .and. cand - h >= lo) then
                     do while (j <= n)
                        xv = x(i, j)
                        if (.not. (xv <= hi .and. xv > cand - h)) exit
                        if (xv > cand) cand = xv
                        j = j + 1
                     end do
                  else if (d%s%dir == 1) then
                     do while (j <= n)
                        xv = x(i, j)
                        if (.not. (xv >= lo .and. xv <= hi .and. xv > cand - h)) exit
                        if (xv > cand) cand = xv
                        j = j + 1
                     end do
                  else if (d%s%dir == -1 .and. cand + h <= hi) then
                     do while (j <= n)
                        xv = x(i, j)
                        if (.not. (xv >= lo .and. xv < cand + h)) exit
                        if (xv < cand) cand = xv
                        j = j + 1
                     end do
                  else if (d%s%dir == -1) then
                     do while (j <= n)
                        xv = x(i, j)
                        if (.not. (xv >= lo .and. xv <= hi .and. xv < cand + h)) exit
                        if (xv < cand) cand = xv
                        j = j + 1
                     end do
                  end if
               end if
               d%n = d%n + (j - js); d%s%cand = cand
               if (j > n) exit
               call push_one(d, x(i, j))
               j = j + 1
            end do
         end associate
      end do
   end subroutine push_block

   !> One value x (a sample, or an extreme between samples) to detector d (push_one).
   subroutine push_value(d, x)
      type(p2p_detector_t), intent(inout) :: d
      real(wp), intent(in) :: x
      call push_one(d, x)
   end subroutine push_value

   !> The extreme of the parabola through (ta, da), (tb, db), (tc, dc), where
   !> ta < tb < tc and db is a strict turning point of the three (db - da and
   !> dc - db of opposite signs): its value x and time tx, in (ta, tc). On a
   !> smooth signal sampled every h, x is the signal's extreme to O(h^4) (a
   !> sine with 50 points a period: 6e-6 of its amplitude; the point db alone:
   !> 2e-3). D-48.
   pure subroutine turn_extreme(ta, tb, tc, da, db, dc, x, tx)
      real(wp), intent(in) :: ta, tb, tc, da, db, dc
      real(wp), intent(out) :: x, tx
      real(wp) :: s1, s2, c1, c2
      s1 = (db - da)/(tb - ta)          ! the slopes on each side
      s2 = (dc - db)/(tc - tb)
      c2 = (s2 - s1)/(tc - ta)          ! p(t) = db + c1 (t - tb) + c2 (t - tb)^2
      c1 = s1 + c2*(tb - ta)
      x = db; tx = tb
      if (.not. c2 /= 0.0_wp) return    ! opposite slopes too small to differ (underflow)
      x = db - c1*c1/(4.0_wp*c2)
      tx = tb - c1/(2.0_wp*c2)
   end subroutine turn_extreme

   !> One sample x to detector d: det_push's own steps written out for the
   !> usual sample, one inside the range seen so far (the threshold does not
   !> move, so det_push would only feed it), and det_push itself for the
   !> others: the same state, without a call through the type per sample.
   subroutine push_one(d, x)
      type(p2p_detector_t), intent(inout) :: d
      real(wp), intent(in) :: x
      logical :: confirmed
      real(wp) :: edge
      if (d%n > 0 .and. x >= d%xmin .and. x <= d%xmax) then
         d%n = d%n + 1
         if (.not. d%h > 0.0_wp) return
         ! feed's branches that confirm nothing: a rising edge not yet
         ! down by h from its maximum, a falling one not yet up by h
         if (d%s%dir == 1 .and. x > d%s%cand - d%h) then
            if (x > d%s%cand) d%s%cand = x
            return
         else if (d%s%dir == -1 .and. x < d%s%cand + d%h) then
            if (x < d%s%cand) d%s%cand = x
            return
         end if
         call feed(d%s, x, d%h, confirmed, edge)
         if (confirmed) then
            d%e_min = min(d%e_min, edge)
            call keep(d, d%s%last_ext)
         end if
      else
         call d%push(x)
      end if
   end subroutine push_one

   !> Log a confirmed extreme; when the log is full, fold its older half into
   !> the folded state (run through the detector with the threshold now).
   subroutine keep(self, v)
      type(p2p_detector_t), intent(inout) :: self
      real(wp), intent(in) :: v
      integer :: i, m
      logical :: conf
      real(wp) :: e
      if (.not. allocated(self%log)) allocate (self%log(p2p_log_size))
      if (self%n_log == size(self%log)) then
         m = size(self%log)/2
         do i = 1, m
            call feed(self%f, self%log(i), self%h, conf, e)
            if (conf) self%e_min_f = min(self%e_min_f, e)
         end do
         if (self%f%dir /= 0) self%e_min_f = min(self%e_min_f, abs(self%f%cand - self%f%last_ext))
         do i = 1, self%n_log - m   ! forward copy (overlapping sections: no temporary)
            self%log(i) = self%log(m + i)
         end do
         self%n_log = self%n_log - m
      end if
      self%n_log = self%n_log + 1
      self%log(self%n_log) = v
   end subroutine keep

   !> The figures of the samples pushed so far (see peak_to_peak_values).
   pure subroutine det_figures(self, p2p_range, p2p_mean, n_swings)
      class(p2p_detector_t), intent(in) :: self
      real(wp), intent(out) :: p2p_range, p2p_mean
      integer, intent(out) :: n_swings
      p2p_range = 0.0_wp; p2p_mean = 0.0_wp; n_swings = 0
      if (self%n < 2) return
      p2p_range = self%xmax - self%xmin
      if (p2p_range <= 0.0_wp) return
      n_swings = self%s%n_swings
      if (n_swings > 0) p2p_mean = self%s%total/real(n_swings, wp)
   end subroutine det_figures
end module trainsim_metrics
