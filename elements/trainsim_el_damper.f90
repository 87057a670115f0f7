!> Torsional viscous damper: a massless dashpot between two nodes (no spring;
!> a spring in parallel is the `shaft` with damping). Not in the thesis.
!>   T = c (w_l - w_r) ;  left node gets -T, right node +T.
module trainsim_el_damper
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: string_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t
   use trainsim_element, only: element_t
   implicit none
   private

   public :: damper_t, new_damper

   !> Damping coefficient c (torque*s/rad).
   type, extends(element_t) :: damper_t
      real(wp) :: c = 0.0_wp
   contains
      procedure :: configure => damper_configure
      procedure :: torques => damper_torques
      procedure :: torque_jacobian => damper_jacobian
      procedure :: dissipation_power => damper_dissipation
      procedure :: linear_spring => damper_linear_spring
      procedure :: params => damper_params
   end type damper_t

contains

   !> Registry factory: a new, unconfigured damper.
   subroutine new_damper(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (damper_t :: el)
   end subroutine new_damper

   !> Reads `damping` (required, > 0).
   subroutine damper_configure(self, grp, units, err)
      class(damper_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      call grp%get_real('damping', self%c, err); if (allocated(err)) return
      call grp%require_positive('damping', self%c, err)
   end subroutine damper_configure

   !> T = c (w_l - w_r) on the right node, -T on the left.
   pure subroutine damper_torques(self, thl, wl, thr, wr, tl, tr)
      class(damper_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      associate (u1 => thl, u2 => thr)
      end associate
      tr = self%c*(wl - wr)
      tl = -tr
   end subroutine damper_torques

   !> d(tl, tr)/d(thl, wl, thr, wr): the speeds only.
   pure subroutine damper_jacobian(self, thl, wl, thr, wr, jt)
      class(damper_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      associate (u1 => thl, u2 => wl, u3 => thr, u4 => wr)
      end associate
      jt(2, :) = [0.0_wp, self%c, 0.0_wp, -self%c]
      jt(1, :) = -jt(2, :)
   end subroutine damper_jacobian

   !> c (w_l - w_r)^2, all of the power the element takes in.
   pure real(wp) function damper_dissipation(self, thl, wl, thr, wr) result(p)
      class(damper_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      associate (u1 => thl, u2 => thr)
      end associate
      p = self%c*(wl - wr)**2
   end function damper_dissipation

   !> A linear spring-damper with k = 0 and unit lever arms: the model evaluates
   !> it in the linear-spring family (docs/plugins.md, section 5).
   pure subroutine damper_linear_spring(self, linear, k, c, r1, r2)
      class(damper_t), intent(in) :: self
      logical, intent(out) :: linear
      real(wp), intent(out) :: k, c, r1, r2
      k = 0.0_wp; c = self%c; r1 = 1.0_wp; r2 = 1.0_wp
      linear = .true.
   end subroutine damper_linear_spring

   function damper_params(self) result(p)
      class(damper_t), intent(in) :: self
      type(param_list_t) :: p
      allocate (p%names(1), p%values(1))
      p%names(1)%s = 'damping'
      p%values(1) = self%c
   end function damper_params
end module trainsim_el_damper
