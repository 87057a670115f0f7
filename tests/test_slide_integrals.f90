!> The speed-dependent tooth friction's integrals along a line of contact
!> (trainsim_slide_integrals, D-129): J = int tanh((a_v + b_v s)/v_r) (a + b s) ds and
!> its partials in a_v and b_v, against composite Gauss-Legendre quadrature of the
!> integrands themselves on panels narrower than 1/100 of the tanh's width
!> (error ~ rounding), in both of the module's branches (the closed form, and
!> 5-point Gauss-Legendre when x = v/v_r changes by less than 0.1), across the
!> branches' threshold, and the dilogarithm against known values.
program test_slide_integrals
   use trainsim_kinds, only: wp, pi
   use trainsim_slide_integrals, only: tanh_integral, li2_neg
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   implicit none
   real(wp), parameter :: thr = 0.1_wp*1.0e-2_wp/0.6_wp   !< b_v at the branches' threshold, v_r = 1e-2 over 0.6

   call suite_begin('speed-dependent tooth friction: tanh integrals along a line of contact (D-129)')
   call dilogarithm()
   call against_quadrature('slide reverses inside, v_r = 0.1 (closed form)', 0.5_wp, 1.0_wp, -3.0_wp, 9.0_wp, &
                           0.1_wp, 0.1_wp, 0.7_wp)
   call against_quadrature('slide reverses inside, v_r = 1e-3 (closed form, |x| to 3600)', 0.5_wp, 1.0_wp, -3.0_wp, &
                           9.0_wp, 1.0e-3_wp, 0.1_wp, 0.7_wp)
   call against_quadrature('one sign, x from 2.9 to 8.3 (closed form)', 0.5_wp, -1.0_wp, 2.0_wp, 9.0_wp, 1.0_wp, &
                           0.1_wp, 0.7_wp)
   call against_quadrature('b_v < 0, reverses inside (closed form)', 1.5_wp, 1.0_wp, 3.0_wp, -9.0_wp, 0.1_wp, &
                           0.1_wp, 0.7_wp)
   call against_quadrature('near rest, x about 0.01 (Gauss-Legendre)', 0.5_wp, 1.0_wp, 1.0e-4_wp, 2.0e-4_wp, &
                           1.0e-2_wp, 0.1_wp, 0.7_wp)
   call against_quadrature('near rest, x about 50 (Gauss-Legendre)', 0.5_wp, 1.0_wp, 0.5_wp, 1.0e-3_wp, 1.0e-2_wp, &
                           0.1_wp, 0.7_wp)
   call against_quadrature('b_v = 0 (Gauss-Legendre)', 0.5_wp, 1.0_wp, 0.02_wp, 0.0_wp, 1.0e-2_wp, 0.1_wp, 0.7_wp)
   call against_quadrature('just above the threshold (closed form)', 0.5_wp, 1.0_wp, -0.4_wp*thr, thr*1.001_wp, &
                           1.0e-2_wp, 0.1_wp, 0.7_wp)
   call against_quadrature('just below the threshold (Gauss-Legendre)', 0.5_wp, 1.0_wp, -0.4_wp*thr, thr*0.999_wp, &
                           1.0e-2_wp, 0.1_wp, 0.7_wp)
   call branches_meet()
   call suite_end()

contains

   subroutine dilogarithm()
      call test_begin('Li2(-z): Li2(-1) = -pi^2/12, Li2(-1/2), Li2(-z) ~ -z + z^2/4 for small z')
      call check('Li2(-1)', li2_neg(1.0_wp), -pi**2/12.0_wp, rel_tol=2.0e-16_wp)
      call check('Li2(-1/2)', li2_neg(0.5_wp), -0.44841420692364620244_wp, rel_tol=4.0e-16_wp)
      call check('Li2(-1e-6)', li2_neg(1.0e-6_wp), -1.0e-6_wp + 0.25e-12_wp - 1.0e-18_wp/9.0_wp, rel_tol=4.0e-16_wp)   ! Landen's two terms: 2 ulp
      call check('Li2(0)', li2_neg(0.0_wp), 0.0_wp, abs_tol=0.0_wp)
   end subroutine dilogarithm

   !> J, dJ/da_v, dJ/db_v by composite 5-point Gauss-Legendre in s, panels of at most
   !> 0.01 in x (and at least 200), the panel edges at the slide's reversal.
   subroutine reference(a, b, av, bv, vr, lo, hi, v, dav, dbv)
      real(wp), intent(in) :: a, b, av, bv, vr, lo, hi
      real(wp), intent(out) :: v, dav, dbv
      real(wp), parameter :: gx(5) = [-0.9061798459386639927976_wp, -0.5384693101056830910363_wp, 0.0_wp, &
                                      0.5384693101056830910363_wp, 0.9061798459386639927976_wp]
      real(wp), parameter :: gw(5) = [0.2369268850561890875143_wp, 0.4786286704993664680413_wp, &
                                      0.5688888888888888888889_wp, 0.4786286704993664680413_wp, &
                                      0.2369268850561890875143_wp]
      real(wp) :: edges(3), p0, p1, h, s, t, q, w
      integer :: ne, seg, np, i, k
      edges(1) = lo; ne = 1
      if (bv /= 0.0_wp) then
         if (-av/bv > lo .and. -av/bv < hi) then
            ne = ne + 1; edges(ne) = -av/bv
         end if
      end if
      ne = ne + 1; edges(ne) = hi
      v = 0.0_wp; dav = 0.0_wp; dbv = 0.0_wp
      do seg = 1, ne - 1
         p0 = edges(seg); p1 = edges(seg + 1)
         np = max(200, ceiling(abs(bv)*(p1 - p0)/vr/0.01_wp))
         h = (p1 - p0)/np
         do i = 0, np - 1
            do k = 1, 5
               s = p0 + h*(i + 0.5_wp + 0.5_wp*gx(k))
               w = 0.5_wp*h*gw(k)
               t = tanh((av + bv*s)/vr)
               q = a + b*s
               v = v + w*t*q
               dav = dav + w*(1.0_wp - t*t)/vr*q
               dbv = dbv + w*(1.0_wp - t*t)/vr*s*q
            end do
         end do
      end do
   end subroutine reference

   subroutine against_quadrature(label, a, b, av, bv, vr, lo, hi)
      character(len=*), intent(in) :: label
      real(wp), intent(in) :: a, b, av, bv, vr, lo, hi
      real(wp) :: v, dav, dbv, rv, rdav, rdbv, scale
      call test_begin(label)
      call tanh_integral(a, b, av, bv, vr, lo, hi, v, dav, dbv)
      call reference(a, b, av, bv, vr, lo, hi, rv, rdav, rdbv)
      scale = (abs(a) + abs(b)*max(abs(lo), abs(hi)))*(hi - lo)   ! the integral's bound (|tanh| <= 1)
      ! both sides exact to rounding: ~1e-16 per term, summed over up to 1e6 quadrature nodes
      call check('J against quadrature / bound', abs(v - rv)/scale, 0.0_wp, abs_tol=1.0e-13_wp)
      call check('dJ/da_v against quadrature / max(|.|, bound / v_r)', abs(dav - rdav)/max(abs(rdav), scale/vr), &
                 0.0_wp, abs_tol=1.0e-12_wp)
      call check('dJ/db_v against quadrature / max(|.|, bound / v_r)', abs(dbv - rdbv)/max(abs(rdbv), scale/vr), &
                 0.0_wp, abs_tol=1.0e-12_wp)
   end subroutine against_quadrature

   !> Just below and just above the threshold |b_v| (hi - lo) = 0.1 v_r: the two
   !> branches give the same J and partials to rounding (no jump in the force).
   subroutine branches_meet()
      real(wp) :: v1, d1, e1, v2, d2, e2, bv, scale
      call test_begin('the Gauss-Legendre and closed-form branches meet at |b_v| (hi - lo) = 0.1 v_r')
      bv = 0.1_wp*1.0e-2_wp/0.6_wp
      call tanh_integral(0.5_wp, 1.0_wp, -0.4_wp*bv, bv*(1.0_wp - 1.0e-12_wp), 1.0e-2_wp, 0.1_wp, 0.7_wp, v1, d1, e1)
      call tanh_integral(0.5_wp, 1.0_wp, -0.4_wp*bv, bv*(1.0_wp + 1.0e-12_wp), 1.0e-2_wp, 0.1_wp, 0.7_wp, v2, d2, e2)
      scale = 1.2_wp*0.6_wp
      ! at the threshold the closed form's correction carries (v_r/(b_v (hi - lo)))^2 = 100 times
      ! the rounding of its bounded primitives (~1e-14 of the bound): 1e-12
      call check('J: |closed form - Gauss-Legendre| / bound', abs(v1 - v2)/scale, 0.0_wp, abs_tol=1.0e-12_wp)
      call check('dJ/da_v: relative', abs(d1 - d2)/abs(d1), 0.0_wp, abs_tol=1.0e-12_wp)
      call check('dJ/db_v: relative', abs(e1 - e2)/abs(e1), 0.0_wp, abs_tol=1.0e-12_wp)
   end subroutine branches_meet
end program test_slide_integrals
