!> The arithmetic of a family row as procedures, for the model's general path,
!> a part of the train and the tables' probes: a linear spring and a clearance
!> in its hot form with its contact law (D-35). Each is written once, in
!> trainsim_model_spring_law.inc and trainsim_model_contact_law.inc, which the
!> stage kernel (trainsim_model_stage.inc) includes too (D-70).
module trainsim_model_kernels
   use trainsim_kinds, only: wp
   use trainsim_element, only: element_t, hot_form_t, hf_none, hf_open, hf_yang_sun, hg_none
   implicit none
   private

   public :: spring, contact, hot_torques, hot_force, hot_potential, hot_guards, hot_probe

contains

   !> A linear spring (eqs. (H.1), (H.15)): trainsim_model_spring_law.inc, damped
   !> (f = k d + c dv) or not (c = 0: f = k d; dv is then 0).
   pure subroutine spring(damped, k, c, r1, r2, thl, wl, thr, wr, d, dv, f, tl, tr)
      logical, intent(in) :: damped
      real(wp), intent(in) :: k, c, r1, r2, thl, wl, thr, wr
      real(wp), intent(out) :: d, dv, f, tl, tr
      if (damped) then
#define DAMPED 1
#include "trainsim_model_spring_law.inc"
#undef DAMPED
      else
         dv = 0.0_wp
#define DAMPED 0
#include "trainsim_model_spring_law.inc"
#undef DAMPED
      end if
   end subroutine spring

   !> A clearance in its hot form (D-35): the contact law of trainsim_contact
   !> (its `cl_contact_force`) in the model, trainsim_model_contact_law.inc, by
   !> its kind (hf_open, hf_yang_sun, hf_linear).
   pure subroutine contact(kind, no_tension, s, c, k, dmp, b, r1, r2, thl, wl, thr, wr, d, p, pdot, fs, tl, tr)
      integer, intent(in) :: kind
      logical, intent(in) :: no_tension
      real(wp), intent(in) :: s, c, k, dmp, b, r1, r2, thl, wl, thr, wr
      real(wp), intent(out) :: d, p, pdot, fs, tl, tr
      real(wp) :: f
      select case (kind)
      case (hf_open)
#define LAW 0
#include "trainsim_model_contact_law.inc"
#undef LAW
      case (hf_yang_sun)
#define LAW 1
#include "trainsim_model_contact_law.inc"
#undef LAW
      case default
#define LAW 2
#include "trainsim_model_contact_law.inc"
#undef LAW
      end select
   end subroutine contact

   !> `contact` of a hot form h (an open one with k = dmp = b = 0, as its row).
   pure subroutine hot_contact(h, thl, wl, thr, wr, d, p, pdot, fs, tl, tr)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: d, p, pdot, fs, tl, tr
      if (h%kind == hf_open) then
         call contact(hf_open, .false., h%s, h%c, 0.0_wp, 0.0_wp, 0.0_wp, h%r1, h%r2, thl, wl, thr, wr, &
                      d, p, pdot, fs, tl, tr)
      else
         call contact(h%kind, h%no_tension, h%s, h%c, h%k, h%dmp, h%b, h%r1, h%r2, &
                      thl, wl, thr, wr, d, p, pdot, fs, tl, tr)
      end if
   end subroutine hot_contact

   !> Torques and the power dissipated of a hot form (D-35): ce_torques and
   !> ce_torques_dissipation's arithmetic, through `contact`.
   pure subroutine hot_torques(h, thl, wl, thr, wr, tl, tr, pw)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, pw
      real(wp) :: d, p, pdot, fs
      call hot_contact(h, thl, wl, thr, wr, d, p, pdot, fs, tl, tr)
      pw = 0.0_wp
      if (h%kind /= hf_open) pw = (h%s*fs - h%c*(h%k*p))*pdot
   end subroutine hot_torques

   !> Signed contact force of a hot form (D-36): fs of `contact`.
   pure real(wp) function hot_force(h, thl, wl, thr, wr) result(fs)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: d, p, pdot, tl, tr
      call hot_contact(h, thl, wl, thr, wr, d, p, pdot, fs, tl, tr)
   end function hot_force

   !> Elastic energy of a hot form (D-36): cl_potential's arithmetic (c k p^2/2
   !> closed, 0 open), as the kernels compute it.
   pure real(wp) function hot_potential(h, thl, thr) result(e)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, thr
      real(wp) :: d, p
      e = 0.0_wp
      if (h%kind == hf_open) return
      d = h%r1*thl - h%r2*thr
      p = h%s*d - h%b
      e = h%c*(0.5_wp*h%k*p**2)
   end function hot_potential

   !> Guards of a hot form (D-35): cl_guards' faces, and a zone window.
   pure subroutine hot_guards(h, thl, thr, g)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, thr
      real(wp), intent(out) :: g(4)
      real(wp) :: d
      d = h%r1*thl - h%r2*thr
      select case (h%mode)
      case (1)
         g(1) = d - h%b; g(2) = 1.0_wp
      case (-1)
         g(1) = 1.0_wp; g(2) = -d - h%b
      case default
         g(1) = h%b - d; g(2) = d + h%b
      end select
      if (h%lo_open) then
         g(3) = 1.0_wp
      else
         g(3) = thl - h%th_lo
      end if
      g(4) = h%th_hi - thl
   end subroutine hot_guards

   !> The element's own procedures against its hot form h (D-35) at three probe
   !> states (two with the face penetrated by a little, one anywhere): h%kind and
   !> h%guards set to none where they disagree, pe_ok (its elastic energy, asked
   !> only if pe_ok on entry) and st_ok (its status) false where those do
   !> (D-36). vouched: h vouches for itself (h%exact) and passed every probe,
   !> torques and guards both in a hot form (`refresh_hot` then skips the probes
   !> until the next `init_modes`, D-167).
   subroutine hot_probe(e, h, ng, pe_ok, st_ok, vouched)
      class(element_t), intent(in) :: e
      type(hot_form_t), intent(inout) :: h
      integer, intent(in) :: ng
      logical, intent(inout) :: pe_ok
      logical, intent(out) :: st_ok, vouched
      real(wp) :: x(4), g(4), gh(4), tl, tr, pw, htl, htr, hpw, pen, sd, sf
      integer :: p, sc, sp, kind0, guards0
      logical :: pe0
      st_ok = .true.
      kind0 = h%kind
      guards0 = h%guards
      pe0 = pe_ok
      do p = 1, 3
         if (h%kind == hf_none .and. h%guards == hg_none) exit
         ! two states with the face penetrated by a little, one anywhere
         x = [0.0_wp, 1.1_wp*p, 0.3_wp*p, -0.7_wp/p]
         pen = 0.25_wp*p*max(h%b, 1.0e-3_wp)
         if (h%r1 /= 0.0_wp) x(1) = (h%r2*x(3) + h%s*(h%b + pen))/h%r1
         if (p == 3) x = [0.37_wp, -1.3_wp, -0.52_wp, 2.1_wp]
         if (h%kind /= hf_none) then
            call e%torques(x(1), x(2), x(3), x(4), tl, tr)
            call hot_torques(h, x(1), x(2), x(3), x(4), htl, htr, hpw)
            if (.not. (tl == htl .and. tr == htr)) h%kind = hf_none
            call e%torques_dissipation(x(1), x(2), x(3), x(4), tl, tr, pw)
            if (.not. (tl == htl .and. tr == htr .and. pw == hpw)) h%kind = hf_none
            ! D-36: its elastic energy and status as `rhs_simple` leaves them
            ! (each until it disagrees; the energy only where it can be read)
            if (pe_ok) then
               if (.not. e%potential_energy(x(1), x(3)) == hot_potential(h, x(1), x(3))) pe_ok = .false.
            end if
            if (st_ok) then
               call e%status(x(1), x(2), x(3), x(4), sd, sf, sc, sp)
               if (.not. (sd == h%r1*x(1) - h%r2*x(3) .and. sf == hot_force(h, x(1), x(2), x(3), x(4)) .and. &
                          sc == h%mode)) st_ok = .false.
            end if
         end if
         if (h%guards /= hg_none) then
            call e%guards(x(1), x(2), x(3), x(4), g(1:ng))
            call hot_guards(h, x(1), x(3), gh)
            if (any(g(1:ng) /= gh(1:ng))) h%guards = hg_none
         end if
      end do
      vouched = h%exact .and. kind0 /= hf_none .and. guards0 /= hg_none .and. h%kind == kind0 .and. &
                h%guards == guards0 .and. st_ok .and. (pe_ok .eqv. pe0)
   end subroutine hot_probe

end module trainsim_model_kernels
