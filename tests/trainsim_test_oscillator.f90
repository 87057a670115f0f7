!> Closed forms of a harmonically forced, damped one-degree-of-freedom oscillator
!> J th'' + c th' + kk th = f0 + a sin(W t) (underdamped): the dead-zone oscillator of
!> the shooting and continuation tests (test_periodic, test_continuation), whose contact
!> orbit is assembled from exact linear segments (kk = k, or k + k2 in contact).
module trainsim_test_oscillator
   use trainsim_kinds, only: wp
   implicit none
   private
   public :: oscillator_t

   !> J, c and the forcing amplitude a (the stiffness and the constant torque are per segment)
   type :: oscillator_t
      real(wp) :: jj = 1.0_wp, c = 0.0_wp, amp = 0.0_wp
   contains
      procedure :: particular => osc_particular
      procedure :: expb => osc_expb
      procedure :: zp => osc_zp
      procedure :: flow => osc_flow
   end type oscillator_t

contains

   !> The steady state of J th'' + c th' + kk th = f0 + a sin(W t): f0/kk + p sin + q cos.
   subroutine osc_particular(self, kk, w, p, q)
      class(oscillator_t), intent(in) :: self
      real(wp), intent(in) :: kk, w
      real(wp), intent(out) :: p, q
      real(wp) :: d, e
      d = kk - self%jj*w**2
      e = self%c*w
      p = self%amp*d/(d**2 + e**2)
      q = -self%amp*e/(d**2 + e**2)
   end subroutine osc_particular

   !> exp(B tau) of B = [0 1; -kk/J -c/J] (underdamped), closed form.
   function osc_expb(self, kk, tau) result(e)
      class(oscillator_t), intent(in) :: self
      real(wp), intent(in) :: kk, tau
      real(wp) :: e(2, 2)
      real(wp) :: al, be, b(2, 2)
      al = -self%c/(2.0_wp*self%jj)
      be = sqrt(kk/self%jj - al**2)
      b = reshape([0.0_wp, -kk/self%jj, 1.0_wp, -self%c/self%jj], [2, 2])
      e = reshape([1.0_wp, 0.0_wp, 0.0_wp, 1.0_wp], [2, 2])*cos(be*tau)
      b(1, 1) = b(1, 1) - al
      b(2, 2) = b(2, 2) - al
      e = exp(al*tau)*(e + sin(be*tau)/be*b)
   end function osc_expb

   !> The segment's steady state (angle, speed) at t.
   function osc_zp(self, kk, f0, w, t) result(v)
      class(oscillator_t), intent(in) :: self
      real(wp), intent(in) :: kk, f0, w, t
      real(wp) :: v(2)
      real(wp) :: p, q
      call self%particular(kk, w, p, q)
      v = [f0/kk + p*sin(w*t) + q*cos(w*t), w*(p*cos(w*t) - q*sin(w*t))]
   end function osc_zp

   !> The exact flow of a linear segment (stiffness kk, constant torque f0) from (ts, z0) to te.
   function osc_flow(self, kk, f0, w, ts, z0, te) result(z)
      class(oscillator_t), intent(in) :: self
      real(wp), intent(in) :: kk, f0, w, ts, z0(2), te
      real(wp) :: z(2)
      z = matmul(self%expb(kk, te - ts), z0 - self%zp(kk, f0, w, ts)) + self%zp(kk, f0, w, te)
   end function osc_flow
end module trainsim_test_oscillator
