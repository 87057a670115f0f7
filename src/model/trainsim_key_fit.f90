!> The keyed joint's load-dependent lineal stiffness, eqs. (4.35)-(4.37) of the
!> thesis (tight, loose and average fit), which the contact law of a keyed joint
!> (trainsim_contact) and `trainsim gear-calc` evaluate.
module trainsim_key_fit
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: fit_none, fit_tight, fit_loose, fit_average, key_lineal_stiffness, key_fit_force

   !> Load-dependent keyed-joint stiffness fits, eqs. (4.35)-(4.37)
   integer, parameter :: fit_none = 0, fit_tight = 1, fit_loose = 2, fit_average = 3
   !> Each fit's k at its 100 lbf floor (`lineal`'s expression with fit_constants'
   !> values, folded by the compiler: the same bits as at run time, which
   !> test_key_fit asserts); key_fit_force starts from it without a log a call.
   real(wp), parameter, public :: key_k100(3) = [98800.0_wp/(1.0_wp + 0.0846_wp*log(1.0_wp/100.0_wp)) - 17.1_wp*100.0_wp, &
                                                 85800.0_wp/(1.0_wp + 0.0774_wp*log(1.0_wp/100.0_wp)) - 4.62_wp*100.0_wp, &
                                                 99500.0_wp/(1.0_wp + 0.073_wp*log(1.0_wp/100.0_wp)) - 4.05_wp*100.0_wp]

contains

   !> Lineal key stiffness (lbf/in per inch of key) at key force P (lbf), eqs.
   !> (4.35) tight, (4.36) loose, (4.37) average fit; P is held inside the
   !> fitted range [100, 60000] lbf. Returns dk/dP too.
   pure subroutine key_lineal_stiffness(fit, p_lbf, k, dk)
      integer, intent(in) :: fit
      real(wp), intent(in) :: p_lbf
      real(wp), intent(out) :: k, dk
      real(wp) :: a, b, c, p_lin
      call fit_constants(fit, a, b, c, p_lin)
      call lineal(a, b, c, p_lin, p_lbf, k, dk)
   end subroutine key_lineal_stiffness

   !> The constants of a fit: k = a/(1 + b ln(1/P)) - c P below P = p_lin lbf,
   !> 0.46 P + 272400 from there (huge: no such part).
   pure subroutine fit_constants(fit, a, b, c, p_lin)
      integer, intent(in) :: fit
      real(wp), intent(out) :: a, b, c, p_lin
      select case (fit)
      case (fit_tight)
         a = 98800.0_wp; b = 0.0846_wp; c = 17.1_wp; p_lin = 9000.0_wp
      case (fit_loose)
         a = 85800.0_wp; b = 0.0774_wp; c = 4.62_wp; p_lin = huge(1.0_wp)
      case default
         a = 99500.0_wp; b = 0.073_wp; c = 4.05_wp; p_lin = 22500.0_wp
      end select
   end subroutine fit_constants

   !> k and dk/dP of the fit with constants a, b, c, p_lin at P = p_lbf.
   pure subroutine lineal(a, b, c, p_lin, p_lbf, k, dk)
      real(wp), intent(in) :: a, b, c, p_lin, p_lbf
      real(wp), intent(out) :: k, dk
      real(wp) :: p, den
      p = min(max(p_lbf, 100.0_wp), 60000.0_wp)
      if (p >= p_lin) then
         k = 0.46_wp*p + 272400.0_wp; dk = 0.46_wp
      else
         den = 1.0_wp + b*log(1.0_wp/p)
         k = a/den - c*p
         dk = a*b/(p*den**2) - c
      end if
      if (p_lbf /= p) dk = 0.0_wp
   end subroutine lineal

   !> Key force (lbf) on a key pressed by lp = L p (in^2): F = k(F) L p solved by
   !> Newton from the stiffness at 100 lbf, six steps at most, then k(F) L p.
   !> A step that leaves F unchanged ends the loop: every later step would repeat
   !> it, and k is then the one at that F, so the result is the six steps' bit for
   !> bit (the SI tracker: 5.6 logs a force instead of 8).
   pure real(wp) function key_fit_force(fit, lp) result(f)
      integer, intent(in) :: fit
      real(wp), intent(in) :: lp
      real(wp) :: fl, fl_next, k, dk, g, a, b, c, p_lin
      integer :: it
      call fit_constants(fit, a, b, c, p_lin)
      fl = key_k100(merge(fit, fit_average, fit == fit_tight .or. fit == fit_loose))*lp   ! (fit_constants' default)
      do it = 1, 6
         call lineal(a, b, c, p_lin, abs(fl), k, dk)
         g = fl - k*lp
         fl_next = fl - g/(1.0_wp - dk*lp*sign(1.0_wp, fl))
         if (fl_next == fl) then
            f = k*lp
            return
         end if
         fl = fl_next
      end do
      call lineal(a, b, c, p_lin, abs(fl), k, dk)
      f = k*lp
   end function key_fit_force
end module trainsim_key_fit
