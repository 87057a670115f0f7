!> Brake: friction between a node and a fixed node (ground) or a second node, scaled by an engagement e(t) in [0, 1] (D-81): a holding brake engages at standstill.
!> The modes, the friction law and the guards are trainsim_friction_element's
!> (docs/elements.md "Friction elements").
module trainsim_el_brake
   use trainsim_error, only: error_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_element, only: element_t
   use trainsim_friction_element, only: friction_element_t, read_friction
   implicit none
   private

   public :: brake_t, new_brake

   type, extends(friction_element_t) :: brake_t
   contains
      procedure :: configure => brake_configure
   end type brake_t

contains

   !> Registry factory: a new, unconfigured brake.
   subroutine new_brake(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (brake_t :: el)
   end subroutine new_brake

   subroutine brake_configure(self, grp, units, err)
      class(brake_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      self%one_way = .false.
      call read_friction(self, grp, .true., err)
   end subroutine brake_configure
end module trainsim_el_brake
