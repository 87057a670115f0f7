!> Bearing friction: friction of a node in its bearing against ground (right: a fixed node), stuck or slipping (D-81).
!> The modes, the friction law and the guards are trainsim_friction_element's
!> (docs/elements.md "Friction elements").
module trainsim_el_bearing_friction
   use trainsim_error, only: error_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_element, only: element_t
   use trainsim_friction_element, only: friction_element_t, read_friction
   implicit none
   private

   public :: bearing_friction_t, new_bearing_friction

   type, extends(friction_element_t) :: bearing_friction_t
   contains
      procedure :: configure => bearing_friction_configure
   end type bearing_friction_t

contains

   !> Registry factory: a new, unconfigured bearing_friction.
   subroutine new_bearing_friction(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (bearing_friction_t :: el)
   end subroutine new_bearing_friction

   subroutine bearing_friction_configure(self, grp, units, err)
      class(bearing_friction_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      self%one_way = .false.
      call read_friction(self, grp, .false., err)
   end subroutine bearing_friction_configure
end module trainsim_el_bearing_friction
