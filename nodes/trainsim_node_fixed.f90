!> Ground: a node that does not move (angle held at its initial value).
module trainsim_node_fixed
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_node, only: node_t
   implicit none
   private

   public :: fixed_node_t, new_fixed_node

   !> A fixed node: no states, speed zero.
   type, extends(node_t) :: fixed_node_t
   contains
      procedure :: configure => fixed_configure
      procedure :: nstates => fixed_nstates
      procedure :: derivatives => fixed_derivatives
      procedure :: kinematics => fixed_kinematics
      procedure :: initial_state => fixed_initial_state
      procedure :: is_fixed => fixed_is_fixed
   end type fixed_node_t

contains

   !> Registry factory: a new, unconfigured fixed node.
   subroutine new_fixed_node(nd)
      class(node_t), allocatable, intent(out) :: nd
      allocate (fixed_node_t :: nd)
   end subroutine new_fixed_node

   subroutine fixed_configure(self, grp, units, err)
      class(fixed_node_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => self, u2 => grp, u3 => units)
      end associate
      if (allocated(err)) return
   end subroutine fixed_configure

   pure integer function fixed_nstates(self) result(n)
      class(fixed_node_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 0
   end function fixed_nstates

   pure subroutine fixed_derivatives(self, t, y, torque, dydt)
      class(fixed_node_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:), torque
      real(wp), intent(inout) :: dydt(:)
      associate (u1 => self, u2 => t, u3 => y, u4 => torque, u5 => dydt)
      end associate
   end subroutine fixed_derivatives

   pure subroutine fixed_kinematics(self, y, theta, omega)
      class(fixed_node_t), intent(in) :: self
      real(wp), intent(in) :: y(:)
      real(wp), intent(out) :: theta, omega
      associate (unused => y)
      end associate
      theta = self%theta0
      omega = 0.0_wp
   end subroutine fixed_kinematics

   pure subroutine fixed_initial_state(self, y)
      class(fixed_node_t), intent(in) :: self
      real(wp), intent(inout) :: y(:)
      associate (u1 => self, u2 => y)
      end associate
   end subroutine fixed_initial_state

   pure logical function fixed_is_fixed(self) result(f)
      class(fixed_node_t), intent(in) :: self
      associate (unused => self)
      end associate
      f = .true.
   end function fixed_is_fixed
end module trainsim_node_fixed
