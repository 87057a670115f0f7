!> N01, passive inertia (Appendix G, eqs. G.1-G.2):
!>   x1' = x2,   J x2' = -d x2 + T   (T: net torque from elements and loads)
module trainsim_node_inertia
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list
   use trainsim_node, only: node_t
   implicit none
   private

   public :: inertia_node_t, new_inertia_node

   !> A rigid disk: inertia J and external (viscous, to ground) damping d.
   type, extends(node_t) :: inertia_node_t
      real(wp) :: j = 0.0_wp, d = 0.0_wp
   contains
      procedure :: configure => inertia_configure
      procedure :: nstates => inertia_nstates
      procedure :: derivatives => inertia_derivatives
      procedure :: inertia => inertia_inertia
      procedure :: dissipation_power => inertia_dissipation
      procedure :: can_prescribe_speed => inertia_can_prescribe
      procedure :: params => inertia_params
      procedure :: jacobian => inertia_jacobian
      procedure :: plain_inertia => inertia_plain
   end type inertia_node_t

contains

   !> Registry factory: a new, unconfigured inertia node.
   subroutine new_inertia_node(nd)
      class(node_t), allocatable, intent(out) :: nd
      allocate (inertia_node_t :: nd)
   end subroutine new_inertia_node

   subroutine inertia_configure(self, grp, units, err)
      class(inertia_node_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      call grp%get_real('inertia', self%j, err); if (allocated(err)) return
      call grp%get_real('damping', self%d, err, default=0.0_wp); if (allocated(err)) return
      call grp%require_positive('inertia', self%j, err)
      call grp%require_nonnegative('damping', self%d, err)
   end subroutine inertia_configure

   pure integer function inertia_nstates(self) result(n)
      class(inertia_node_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 2
   end function inertia_nstates

   pure subroutine inertia_derivatives(self, t, y, torque, dydt)
      class(inertia_node_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:), torque
      real(wp), intent(inout) :: dydt(:)
      associate (unused => t)
      end associate
      dydt(self%offset + 1) = y(self%offset + 2)                                 ! eq. (G.1)
      dydt(self%offset + 2) = (torque - self%d*y(self%offset + 2))/self%j         ! eq. (G.2)
   end subroutine inertia_derivatives

   pure real(wp) function inertia_inertia(self) result(j)
      class(inertia_node_t), intent(in) :: self
      j = self%j
   end function inertia_inertia

   pure real(wp) function inertia_dissipation(self, y) result(p)
      class(inertia_node_t), intent(in) :: self
      real(wp), intent(in) :: y(:)
      p = self%d*y(self%offset + 2)**2
   end function inertia_dissipation

   !> A plain rigid disk: the model's fast path integrates it from (J, d).
   pure subroutine inertia_plain(self, plain, j, d)
      class(inertia_node_t), intent(in) :: self
      logical, intent(out) :: plain
      real(wp), intent(out) :: j, d
      j = self%j
      d = self%d
      plain = .true.
   end subroutine inertia_plain

   pure logical function inertia_can_prescribe(self) result(f)
      class(inertia_node_t), intent(in) :: self
      associate (unused => self)
      end associate
      f = .true.
   end function inertia_can_prescribe

   pure subroutine inertia_jacobian(self, t, y, jac, dtorque)
      class(inertia_node_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: jac(:, :)
      real(wp), intent(out) :: dtorque(:)
      associate (u1 => t, u2 => y)
      end associate
      jac(self%offset + 1, self%offset + 2) = jac(self%offset + 1, self%offset + 2) + 1.0_wp
      jac(self%offset + 2, self%offset + 2) = jac(self%offset + 2, self%offset + 2) - self%d/self%j
      dtorque(1) = 0.0_wp
      dtorque(2) = 1.0_wp/self%j
   end subroutine inertia_jacobian

   function inertia_params(self) result(p)
      class(inertia_node_t), intent(in) :: self
      type(param_list_t) :: p
      ! One structure constructor: assigning p%names, then p%values trips gfortran 12's
      ! false -Wuninitialized on the descriptors of the unallocated components.
      p = make_param_list([character(len=40) :: 'inertia', 'damping'], &
                       [self%j, self%d])
   end function inertia_params
end module trainsim_node_inertia
