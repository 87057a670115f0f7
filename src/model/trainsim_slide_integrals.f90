!> Integrals along a line of contact of the speed-dependent tooth friction
!> coefficient (trainsim_tooth_friction, tooth_friction_model = 'speed'; D-129):
!>   J = int_lo^hi tanh(v(s)/v_r) (a + b s) ds,   v(s) = a_v + b_v s,
!> with its partials in a_v and b_v (the Jacobian's in the speeds):
!>   dJ/da_v = int sech^2(x) (a + b s) ds / v_r,  dJ/db_v = int sech^2(x) s (a + b s) ds / v_r.
!> In x = v/v_r (s = sigma0 + sigma1 x, sigma1 = v_r/b_v) the primitives are closed:
!>   int tanh = ln cosh x,  int x tanh x = x^2/2 - pi^2/24 + x ln(1 + e^(-2x)) - Li2(-e^(-2x))/2 (x >= 0),
!>   int sech^2 = tanh x,  int x sech^2 = x tanh x - ln cosh x,  int x^2 sech^2 = x^2 tanh x - 2 int x tanh x.
!> Written as the sign (the 'constant' model's integral, exact) less a correction
!> phi(|x|) = 1 - tanh|x| = 2/(e^(2|x|) + 1) whose primitives are bounded (ln 2,
!> pi^2/24), so no large terms cancel at any speed. When x changes by less than
!> 0.1 over the segment (b_v near 0, the gears near rest) the substitution
!> divides by a small b_v: 5-point Gauss-Legendre instead (the integrands are
!> analytic, their poles pi/2 away in x: error below (0.05/(pi/2))^10 / 4, i.e. 1e-16).
!> Near that threshold the correction's rounding is amplified by (v_r/(b_v (hi - lo)))^2
!> <= 100: the two branches meet to ~1e-13 of the integral's bound (test_slide_integrals).
!> Pure arithmetic: no allocation, no I/O (the right-hand side's hot path).
module trainsim_slide_integrals
   use trainsim_kinds, only: wp, pi
   implicit none
   private

   public :: tanh_integral, signed_integral, li2_neg

   real(wp), parameter :: ln2 = 0.6931471805599453094_wp
   !> Gauss-Legendre, 5 points on [-1, 1]
   real(wp), parameter :: gx(5) = [-0.9061798459386640_wp, -0.5384693101056831_wp, 0.0_wp, &
                                   0.5384693101056831_wp, 0.9061798459386640_wp]
   real(wp), parameter :: gw(5) = [0.2369268850561891_wp, 0.4786286704993665_wp, 0.5688888888888889_wp, &
                                   0.4786286704993665_wp, 0.2369268850561891_wp]

contains

   !> J, dJ/da_v, dJ/db_v (module note) over [lo, hi].
   pure subroutine tanh_integral(a, b, av, bv, vr, lo, hi, v, dav, dbv)
      real(wp), intent(in) :: a, b, av, bv, vr, lo, hi
      real(wp), intent(out) :: v, dav, dbv
      real(wp) :: s, t, q, w, x0, x1, s0, s1, aa, bb, ds
      integer :: k
      if (.not. abs(bv)*(hi - lo) > 0.1_wp*vr) then
         v = 0.0_wp; dav = 0.0_wp; dbv = 0.0_wp
         do k = 1, 5
            s = 0.5_wp*(lo + hi) + 0.5_wp*(hi - lo)*gx(k)
            w = 0.5_wp*(hi - lo)*gw(k)
            t = tanh((av + bv*s)/vr)
            q = a + b*s
            v = v + w*t*q
            dav = dav + w*(1.0_wp - t*t)/vr*q
            dbv = dbv + w*(1.0_wp - t*t)/vr*s*q
         end do
         return
      end if
      x0 = (av + bv*lo)/vr; x1 = (av + bv*hi)/vr
      s0 = -av/bv; s1 = vr/bv                  ! s = s0 + s1 x
      aa = a + b*s0; bb = b*s1                 ! a + b s = aa + bb x
      ! the sign's integral (as 'constant'), less the correction phi(|x|)
      call signed_integral(a, b, av, bv, lo, hi, v, ds)
      v = v - s1*(aa*(q0(x1) - q0(x0)) + bb*(q1(x1) - q1(x0)))
      dav = s1/vr*(aa*(tanh(x1) - tanh(x0)) + bb*(r1(x1) - r1(x0)))
      dbv = s1/vr*(s0*aa*(tanh(x1) - tanh(x0)) + (s0*bb + s1*aa)*(r1(x1) - r1(x0)) + s1*bb*(r2(x1) - r2(x0)))
   end subroutine tanh_integral

   !> int_lo^hi sign(av + bv s) (a + b s) ds and its partial in s* = -av/bv
   !> (0 when s* lies outside (lo, hi) or bv = 0).
   pure subroutine signed_integral(a, b, av, bv, lo, hi, v, dv_ds)
      real(wp), intent(in) :: a, b, av, bv, lo, hi
      real(wp), intent(out) :: v, dv_ds
      real(wp) :: sc, sg
      dv_ds = 0.0_wp
      if (bv == 0.0_wp) then
         sg = 0.0_wp
         if (av /= 0.0_wp) sg = sign(1.0_wp, av)
         v = sg*(prim(hi) - prim(lo))
         return
      end if
      sg = sign(1.0_wp, bv)
      sc = max(lo, min(hi, -av/bv))
      v = sg*(prim(hi) + prim(lo) - 2.0_wp*prim(sc))
      if (sc > lo .and. sc < hi) dv_ds = -2.0_wp*sg*(a + b*sc)
   contains
      pure real(wp) function prim(s)
         real(wp), intent(in) :: s
         prim = s*(a + 0.5_wp*b*s)
      end function prim
   end subroutine signed_integral

   !> phi(y) = 1 - tanh(y) and z = e^(-2y), y >= 0.
   pure subroutine phi_of(y, phi, z)
      real(wp), intent(in) :: y
      real(wp), intent(out) :: phi, z
      z = exp(-2.0_wp*y)
      phi = 2.0_wp*z/(1.0_wp + z)
   end subroutine phi_of

   !> int_0^x sign(t) phi(|t|) dt = ln 2 - ln(1 + e^(-2|x|)) (even).
   pure real(wp) function q0(x)
      real(wp), intent(in) :: x
      q0 = ln2 - ln1p(exp(-2.0_wp*abs(x)))
   end function q0

   !> int_0^x |t| phi(|t|) dt = sign(x) (pi^2/24 - y ln(1 + z) + Li2(-z)/2), y = |x| (odd).
   pure real(wp) function q1(x)
      real(wp), intent(in) :: x
      q1 = sign(1.0_wp, x)*p1(abs(x))
   end function q1

   pure real(wp) function p1(y)
      real(wp), intent(in) :: y
      real(wp) :: z
      z = exp(-2.0_wp*y)
      p1 = pi**2/24.0_wp - y*ln1p(z) + 0.5_wp*li2_neg(z)
   end function p1

   !> int_0^x t sech^2 t dt = x tanh x - ln cosh x = ln 2 - y phi(y) - ln(1 + z) (even).
   pure real(wp) function r1(x)
      real(wp), intent(in) :: x
      real(wp) :: phi, z
      call phi_of(abs(x), phi, z)
      r1 = ln2 - abs(x)*phi - ln1p(z)
   end function r1

   !> int_0^x t^2 sech^2 t dt = x^2 tanh x - 2 int_0^x t tanh t dt = sign(x) (2 P1(y) - y^2 phi(y)) (odd).
   pure real(wp) function r2(x)
      real(wp), intent(in) :: x
      real(wp) :: phi, z, y
      y = abs(x)
      call phi_of(y, phi, z)
      r2 = sign(1.0_wp, x)*(2.0_wp*p1(y) - y*y*phi)
   end function r2

   !> ln(1 + z) for z >= 0, accurate for small z (Goldberg's correction: u = 1 + z
   !> rounded, ln(u) z/(u - 1)); Fortran has no log1p.
   pure real(wp) function ln1p(z)
      real(wp), intent(in) :: z
      real(wp) :: u
      u = 1.0_wp + z
      if (u == 1.0_wp) then
         ln1p = z
      else
         ln1p = log(u)*z/(u - 1.0_wp)
      end if
   end function ln1p

   !> The dilogarithm Li2(-z) for 0 <= z <= 1, by Landen's identity
   !> Li2(-z) = -ln(1 + z)^2/2 - Li2(w), w = z/(1 + z) <= 1/2, and Li2(w) = sum w^k/k^2.
   pure real(wp) function li2_neg(z) result(f)
      real(wp), intent(in) :: z
      real(wp) :: w, wk, term, s
      integer :: k
      w = z/(1.0_wp + z)
      s = 0.0_wp; wk = 1.0_wp
      do k = 1, 60
         wk = wk*w
         term = wk/real(k*k, wp)
         s = s + term
         if (term <= 1.0e-17_wp*s) exit
      end do
      f = -0.5_wp*ln1p(z)**2 - s
   end function li2_neg
end module trainsim_slide_integrals
