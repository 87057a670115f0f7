!> The keyed joint's load-dependent lineal stiffness, eqs. (4.35)-(4.37) of the
!> thesis (tight, loose and average fit), which the contact law of a keyed joint
!> (trainsim_contact) and `trainsim gear-calc` evaluate.
module trainsim_key_fit
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: fit_none, fit_tight, fit_loose, fit_average, key_lineal_stiffness

   !> Load-dependent keyed-joint stiffness fits, eqs. (4.35)-(4.37)
   integer, parameter :: fit_none = 0, fit_tight = 1, fit_loose = 2, fit_average = 3

contains

   !> Lineal key stiffness (lbf/in per inch of key) at key force P (lbf), eqs.
   !> (4.35) tight, (4.36) loose, (4.37) average fit; P is held inside the
   !> fitted range [100, 60000] lbf. Returns dk/dP too.
   pure subroutine key_lineal_stiffness(fit, p_lbf, k, dk)
      integer, intent(in) :: fit
      real(wp), intent(in) :: p_lbf
      real(wp), intent(out) :: k, dk
      real(wp) :: p, a, b, c, den
      p = min(max(p_lbf, 100.0_wp), 60000.0_wp)
      select case (fit)
      case (fit_tight)
         if (p >= 9000.0_wp) then
            k = 0.46_wp*p + 272400.0_wp; dk = 0.46_wp
            if (p_lbf /= p) dk = 0.0_wp
            return
         end if
         a = 98800.0_wp; b = 0.0846_wp; c = 17.1_wp
      case (fit_loose)
         a = 85800.0_wp; b = 0.0774_wp; c = 4.62_wp
      case default
         if (p >= 22500.0_wp) then
            k = 0.46_wp*p + 272400.0_wp; dk = 0.46_wp
            if (p_lbf /= p) dk = 0.0_wp
            return
         end if
         a = 99500.0_wp; b = 0.073_wp; c = 4.05_wp
      end select
      den = 1.0_wp + b*log(1.0_wp/p)
      k = a/den - c*p
      dk = a*b/(p*den**2) - c
      if (p_lbf /= p) dk = 0.0_wp
   end subroutine key_lineal_stiffness
end module trainsim_key_fit
