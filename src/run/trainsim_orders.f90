!> Amplitudes of signals at the orders of a rotation (issue 26 item 5, D-104): for a
!> gear mesh, its transmission error and mesh force at mesh orders 0..n_orders
!> (order 1 = once per tooth of the driver: the phase phi = N theta_driver).
!>
!> The samples (t_j, rate w_j = dphi/dt, signals x_j) come in time order. The phase
!> is the trapezoidal integral of the rate, phi_j = phi_{j-1} + (w_{j-1} + w_j)(t_j -
!> t_{j-1})/2 (exact for a rate linear in time: a constant speed or a linear ramp),
!> and the order-k coefficient is the trapezoidal rule in the phase,
!>
!>     c_k = (1/Phi) int x e^(-i k phi) dphi,   Phi = phi_last - phi_first,
!>
!> reported as the amplitude A_k = 2 |c_k| (k >= 1: x = A_0 + sum A_k cos(k phi + psi_k))
!> and A_0 = Re c_0, the mean. On samples evenly spaced in phase over a whole number
!> of cycles, the trapezoidal rule is exact for every order below half the samples a
!> cycle (it is the discrete Fourier transform): a single harmonic comes back to
!> rounding (test_gear_metrics). The figures are taken over the whole cycles of the
!> samples (the last partial cycle is left out, its step cut at the cycle's end with x
!> linear along it), so a mean much larger than the harmonics (a TE behind a backlash)
!> does not leak into them.
!>
!> One cos/sin per sample (the higher orders by the Chebyshev recurrence), the phase
!> reduced to [0, 2 pi). No allocation: fixed-size state. Every sample is taken: passing
!> over samples (at most 128 a cycle) made the grid uneven at each cycle's end, and the
!> trapezoidal rule lost its exactness (3e-3 on a single harmonic, measured).
module trainsim_orders
   use trainsim_kinds, only: wp, two_pi
   implicit none
   private

   public :: order_tracker_t, n_orders, n_order_signals

   !> Orders kept above the mean (mesh orders 1..n_orders).
   integer, parameter :: n_orders = 4
   !> Signals per tracker (a mesh: 1 transmission error, 2 mesh force).
   integer, parameter :: n_order_signals = 2

   type :: order_tracker_t
      integer :: n = 0                         !< samples taken
      real(wp) :: t = 0.0_wp, w = 0.0_wp       !< the last sample's time and phase rate
      real(wp) :: phi = 0.0_wp                 !< the last sample's phase, reduced to [0, 2 pi)
      real(wp) :: span = 0.0_wp                !< phase advanced since the first sample
      real(wp) :: t0 = 0.0_wp                  !< the first sample's time
      integer :: cycles_done = 0               !< whole cycles completed (the snapshot's)
      !> the largest |w_j - w_(j-1)| / (t_j - t_(j-1)) over successive samples: the phase
      !> rate's largest mean acceleration over a sample interval (a rattle criterion's
      !> driver acceleration, N alpha_max; trainsim_rattle, D-134)
      real(wp) :: amax = 0.0_wp
      complex(wp) :: c_whole(0:n_orders, n_order_signals) = (0.0_wp, 0.0_wp)   !< c over those whole cycles
      !> the last sample's x e^(-i k phi), real and imaginary parts
      real(wp) :: gr(0:n_orders, n_order_signals) = 0.0_wp, gi(0:n_orders, n_order_signals) = 0.0_wp
      !> int x e^(-i k phi) dphi so far, real and imaginary parts
      real(wp) :: cr(0:n_orders, n_order_signals) = 0.0_wp, ci(0:n_orders, n_order_signals) = 0.0_wp
   contains
      procedure :: push => ot_push
      procedure :: amplitudes => ot_amplitudes
      procedure :: cycles => ot_cycles
   end type order_tracker_t

contains

   !> The sample (t, w, x): time, phase rate (rad/s of the order-1 phase), signal values.
   !> Real arithmetic: cos k phi and sin k phi by the Chebyshev recurrence from one
   !> cos/sin (D-104).
   pure subroutine ot_push(self, t, w, x)
      class(order_tracker_t), intent(inout) :: self
      real(wp), intent(in) :: t, w, x(n_order_signals)
      real(wp) :: dphi, h, c1, s1, ck(0:n_orders), sk(0:n_orders), gr, gi
      integer :: j, k
      if (self%n > 0) then
         if (.not. t > self%t) return     ! (a repeated instant adds nothing)
         self%amax = max(self%amax, abs(w - self%w)/(t - self%t))
         dphi = 0.5_wp*(self%w + w)*(t - self%t)
         self%phi = self%phi + dphi
         if (self%phi >= two_pi .or. self%phi < 0.0_wp) self%phi = modulo(self%phi, two_pi)
         if (abs(self%span + dphi) >= two_pi*real(self%cycles_done + 1, wp)) call whole_cycles(self, dphi, x)
      else
         dphi = 0.0_wp
         self%phi = 0.0_wp
         self%t0 = t
      end if
      c1 = cos(self%phi); s1 = sin(self%phi)
      ck(0) = 1.0_wp; sk(0) = 0.0_wp; ck(1) = c1; sk(1) = s1
      do k = 2, n_orders
         ck(k) = 2.0_wp*c1*ck(k - 1) - ck(k - 2)
         sk(k) = 2.0_wp*c1*sk(k - 1) - sk(k - 2)
      end do
      h = 0.5_wp*dphi   ! (0 for the first sample: its g only)
      do j = 1, n_order_signals
         do k = 0, n_orders
            gr = x(j)*ck(k); gi = -x(j)*sk(k)   ! x e^(-i k phi)
            self%cr(k, j) = self%cr(k, j) + h*(self%gr(k, j) + gr)
            self%ci(k, j) = self%ci(k, j) + h*(self%gi(k, j) + gi)
            self%gr(k, j) = gr; self%gi(k, j) = gi
         end do
      end do
      self%span = self%span + dphi
      self%n = self%n + 1
      self%t = t
      self%w = w
   end subroutine ot_push

   !> Before the step of dphi from the last sample to the sample x: each whole cycle the
   !> step completes, |phase since the first sample| = 2 pi m, gives the snapshot c_whole of
   !> the integral up to it (the step cut there, x and the phase linear along the step).
   pure subroutine whole_cycles(self, dphi, x)
      type(order_tracker_t), intent(inout) :: self
      real(wp), intent(in) :: dphi, x(n_order_signals)
      real(wp) :: goal, frac, phc, xc(n_order_signals)
      integer :: k
      if (dphi == 0.0_wp) return
      do
         goal = two_pi*real(self%cycles_done + 1, wp)
         if (abs(self%span + dphi) < goal) return
         frac = (goal - abs(self%span))/abs(dphi)
         xc = self%gr(0, :) + frac*(x - self%gr(0, :))
         phc = self%phi - (1.0_wp - frac)*dphi   ! (self%phi is already the new sample's)
         do k = 0, n_orders
            self%c_whole(k, :) = cmplx(self%cr(k, :) + 0.5_wp*frac*dphi*(self%gr(k, :) + xc*cos(k*phc)), &
                                       self%ci(k, :) + 0.5_wp*frac*dphi*(self%gi(k, :) - xc*sin(k*phc)), wp)
         end do
         self%cycles_done = self%cycles_done + 1
      end do
   end subroutine whole_cycles

   !> a(0:n_orders, signal): the mean (order 0) and the amplitudes 2 |c_k| over the whole
   !> cycles completed (over the samples' span when not one cycle is complete; 0 before a
   !> phase advanced).
   pure subroutine ot_amplitudes(self, a)
      class(order_tracker_t), intent(in) :: self
      real(wp), intent(out) :: a(0:n_orders, n_order_signals)
      complex(wp) :: c(0:n_orders, n_order_signals)
      real(wp) :: span
      a = 0.0_wp
      c = cmplx(self%cr, self%ci, wp); span = self%span
      if (self%cycles_done > 0) then
         c = self%c_whole; span = sign(two_pi*real(self%cycles_done, wp), self%span)
      end if
      if (span == 0.0_wp) return
      a = 2.0_wp*abs(c)/abs(span)
      a(0, :) = real(c(0, :), wp)/span
   end subroutine ot_amplitudes

   !> Order-1 cycles covered so far.
   pure real(wp) function ot_cycles(self) result(c)
      class(order_tracker_t), intent(in) :: self
      c = abs(self%span)/two_pi
   end function ot_cycles
end module trainsim_orders
