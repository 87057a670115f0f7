!> EL1, shaft: massless visco-elastic torsion spring (Appendix H, eqs. H.1-H.2):
!>   T = b (x_l - x_r) + d (w_l - w_r) ;  left node gets -T, right node +T.
module trainsim_el_shaft
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list
   use trainsim_element, only: element_t, lin_state_t
   implicit none
   private

   public :: shaft_t, new_shaft

   !> Torsional stiffness b (torque/rad) and internal damping d (torque*s/rad).
   type, extends(element_t) :: shaft_t
      real(wp) :: k = 0.0_wp, c = 0.0_wp
   contains
      procedure :: configure => shaft_configure
      procedure :: torques => shaft_torques
      procedure :: stiffness_matrix => shaft_stiffness
      procedure :: linearise => shaft_linearise
      procedure :: potential_energy => shaft_potential
      procedure :: dissipation_power => shaft_dissipation
      procedure :: params => shaft_params
      procedure :: torque_jacobian => shaft_jacobian
      procedure :: linear_spring => shaft_linear_spring
   end type shaft_t

contains

   !> Registry factory: a new, unconfigured shaft.
   subroutine new_shaft(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (shaft_t :: el)
   end subroutine new_shaft

   subroutine shaft_configure(self, grp, units, err)
      class(shaft_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      call grp%get_real('stiffness', self%k, err); if (allocated(err)) return
      call grp%get_real('damping', self%c, err, default=0.0_wp); if (allocated(err)) return
      call grp%require_positive('stiffness', self%k, err)
      call grp%require_nonnegative('damping', self%c, err)
   end subroutine shaft_configure

   pure subroutine shaft_torques(self, thl, wl, thr, wr, tl, tr)
      class(shaft_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      tr = self%k*(thl - thr) + self%c*(wl - wr)   ! eq. (H.1)/(H.2)
      tl = -tr
   end subroutine shaft_torques

   !> A linear spring-damper with unit lever arms (the model's fast path).
   pure subroutine shaft_linear_spring(self, linear, k, c, r1, r2)
      class(shaft_t), intent(in) :: self
      logical, intent(out) :: linear
      real(wp), intent(out) :: k, c, r1, r2
      k = self%k; c = self%c; r1 = 1.0_wp; r2 = 1.0_wp
      linear = .true.
   end subroutine shaft_linear_spring

   pure subroutine shaft_stiffness(self, k)
      class(shaft_t), intent(in) :: self
      real(wp), intent(out) :: k(2, 2)
      k = self%k*reshape([1.0_wp, -1.0_wp, -1.0_wp, 1.0_wp], [2, 2])
   end subroutine shaft_stiffness

   !> k and the shaft's own damping d, in every state (eq. H.1).
   pure subroutine shaft_linearise(self, state, inv_jl, inv_jr, k, c)
      class(shaft_t), intent(in) :: self
      type(lin_state_t), intent(in) :: state
      real(wp), intent(in) :: inv_jl, inv_jr
      real(wp), intent(out) :: k(2, 2), c(2, 2)
      associate (u1 => state, u2 => inv_jl, u3 => inv_jr)
      end associate
      k = self%k*reshape([1.0_wp, -1.0_wp, -1.0_wp, 1.0_wp], [2, 2])
      c = self%c*reshape([1.0_wp, -1.0_wp, -1.0_wp, 1.0_wp], [2, 2])
   end subroutine shaft_linearise

   pure real(wp) function shaft_potential(self, thl, thr) result(e)
      class(shaft_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      e = 0.5_wp*self%k*(thl - thr)**2
   end function shaft_potential

   pure real(wp) function shaft_dissipation(self, thl, wl, thr, wr) result(p)
      class(shaft_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      associate (u1 => thl, u2 => thr)
      end associate
      p = self%c*(wl - wr)**2
   end function shaft_dissipation

   pure subroutine shaft_jacobian(self, thl, wl, thr, wr, jt)
      class(shaft_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      associate (u1 => thl, u2 => wl, u3 => thr, u4 => wr)
      end associate
      jt(2, :) = [self%k, self%c, -self%k, -self%c]
      jt(1, :) = -jt(2, :)
   end subroutine shaft_jacobian

   function shaft_params(self) result(p)
      class(shaft_t), intent(in) :: self
      type(param_list_t) :: p
      ! One structure constructor: assigning p%names, then p%values trips gfortran 12's
      ! false -Wuninitialized on the descriptors of the unallocated components.
      p = make_param_list([character(len=40) :: 'stiffness', 'damping'], &
                       [self%k, self%c])
   end function shaft_params
end module trainsim_el_shaft
