!> The model's families on the hot path: the row types of its tables (a node
!> that is a plain inertia or held, an element that is a linear spring or a
!> clearance in its hot form, D-35, a guard row, a load) and the hot form's
!> arithmetic (torques, guards, elastic energy, contact force), written once
!> for every kernel that evaluates it.
module trainsim_model_families
   use trainsim_kinds, only: wp
   use trainsim_element, only: hot_form_t, hf_open, hf_yang_sun, hg_none
   implicit none
   private

   public :: fast_node_t, fast_element_t, guard_row_t, fast_load_t
   public :: nk_other, nk_plain, nk_held
   public :: lf_general, lf_undamped, lf_unit, lf_open, lf_yang_sun, lf_cl_linear
   public :: hot_potential, hot_force, hot_torques, hot_guards

   !> Kinds of node on the hot path.
   integer, parameter :: nk_other = 0, nk_plain = 1, nk_held = 2

   !> A node on the hot path: its kind, state offset and, for a plain inertia,
   !> J and d; for a held node its inertia J and, with a constant speed, that speed.
   type :: fast_node_t
      integer :: kind = nk_other
      integer :: off = 0
      logical :: const_speed = .false.
      real(wp) :: j = 1.0_wp, d = 0.0_wp, w = 0.0_wp, theta0 = 0.0_wp
      real(wp) :: load0 = 0.0_wp   !< sum of its loads if all are constant (else 0: summed at t)
   end type fast_node_t

   !> An element on the hot path: its nodes and, for a linear spring, k, c, r1, r2.
   type :: fast_element_t
      integer :: l = 0, r = 0, ng = 0
      logical :: linear = .false.
      real(wp) :: k = 0.0_wp, c = 0.0_wp, r1 = 1.0_wp, r2 = 1.0_wp
      !> The form of a linear spring in `rhs_simple` (lf_*), and the state index
      !> of the angle of its left and right node if a plain inertia, else 0
      !> (`rhs_simple` and `guards` read those straight from y).
      integer :: form = 0, yl = 0, yr = 0
      !> The form of the element's hot form (D-35, the record in the model's fh)
      !> for its guards (hg_*); its torque form is `form` (lf_open, lf_yang_sun,
      !> lf_cl_linear).
      integer :: gform = hg_none
      !> The hot form's elastic energy (`hot_potential`) and its status (the
      !> displacement and signed force `rhs_simple` leaves in el_disp, el_force,
      !> the contact its mode) agree bit for bit with the element's own
      !> `potential_energy` and `status` at `refresh_hot`'s probe states (D-36).
      logical :: hot_pe = .false., hot_status = .false.
      !> The element's elastic energy is neither a linear spring's nor its hot
      !> form's (counted in n_cold: `rhs_simple` then leaves no energy).
      logical :: cold = .true.
   end type fast_element_t

   !> An element with guards, as `model_guards` reads it: where its guards are
   !> its hot form's (D-35) and both its nodes are plain inertias (form 1:
   !> faces, 2: faces and the zone window; 0: asked as before), the record's
   !> guard fields and the state indices of its nodes' angles, in one place
   !> (refreshed with the hot form, `refresh_hot`).
   type :: guard_row_t
      integer :: form = 0, o = 0, yl = 0, yr = 0, mode = 0
      logical :: lo_open = .false.
      real(wp) :: r1 = 1.0_wp, r2 = 1.0_wp, b = 0.0_wp, th_lo = 0.0_wp, th_hi = 0.0_wp
   end type guard_row_t

   !> Forms of a linear spring in `rhs_simple`: the terms that are exactly zero
   !> or exactly a factor 1 are left out (the same values, fewer operations on
   !> the RHS's critical path): general, undamped (c = 0), undamped with unit
   !> lever arms (a shaft: c = 0, r1 = r2 = 1).
   integer, parameter :: lf_general = 1, lf_undamped = 2, lf_unit = 3
   !> Forms of a clearance element in its current mode (its hot form, D-35):
   !> open, closed with the yang_sun law, closed with the linear law.
   integer, parameter :: lf_open = 4, lf_yang_sun = 5, lf_cl_linear = 6

   !> A load on the hot path: its node and, when constant, its value.
   type :: fast_load_t
      integer :: node = 0
      logical :: const = .false.
      real(wp) :: v = 0.0_wp
   end type fast_load_t

contains

   !> Elastic energy of a hot form (D-36): cl_potential's arithmetic (c k p^2/2
   !> closed, 0 open), the operations `rhs_simple` does.
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

   !> Signed contact force of a hot form (D-36): fs of `hot_torques`.
   pure real(wp) function hot_force(h, thl, wl, thr, wr) result(fs)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: d, dd, p, pdot, f
      fs = 0.0_wp
      if (h%kind == hf_open) return
      d = h%r1*thl - h%r2*thr
      dd = h%r1*wl - h%r2*wr
      p = h%s*d - h%b
      pdot = h%s*dd
      if (h%kind == hf_yang_sun) then
         f = h%c*(h%k*p + h%dmp*p*pdot)
      else
         f = h%c*(h%k*p) + h%dmp*pdot
      end if
      if (h%no_tension) f = max(f, 0.0_wp)
      fs = h%s*f
   end function hot_force

   !> Torques (and the power dissipated) of a hot form (D-35): ce_torques and
   !> ce_torques_dissipation's arithmetic, the same operations in the same order.
   pure subroutine hot_torques(h, thl, wl, thr, wr, tl, tr, pw)
      type(hot_form_t), intent(in) :: h
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, pw
      real(wp) :: d, dd, p, pdot, f, fs
      if (h%kind == hf_open) then
         fs = 0.0_wp
         tl = -(fs*h%r1)
         tr = fs*h%r2
         pw = 0.0_wp
         return
      end if
      d = h%r1*thl - h%r2*thr
      dd = h%r1*wl - h%r2*wr
      p = h%s*d - h%b
      pdot = h%s*dd
      if (h%kind == hf_yang_sun) then
         f = h%c*(h%k*p + h%dmp*p*pdot)                                  ! eqs. (3.18)-(3.19)
      else
         f = h%c*(h%k*p) + h%dmp*pdot
      end if
      if (h%no_tension) f = max(f, 0.0_wp)
      fs = h%s*f
      tl = -(fs*h%r1)
      tr = fs*h%r2
      pw = (h%s*fs - h%c*(h%k*p))*pdot
   end subroutine hot_torques

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
end module trainsim_model_families
