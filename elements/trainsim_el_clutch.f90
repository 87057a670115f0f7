!> Clutch: friction between two nodes scaled by an engagement e(t) in [0, 1]; the static limit e(t) torque_static is its torque capacity (D-81).
!> The modes, the friction law and the guards are trainsim_friction_element's
!> (docs/elements.md "Friction elements").
module trainsim_el_clutch
   use trainsim_error, only: error_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_element, only: element_t
   use trainsim_friction_element, only: friction_element_t, read_friction
   implicit none
   private

   public :: clutch_t, new_clutch

   type, extends(friction_element_t) :: clutch_t
   contains
      procedure :: configure => clutch_configure
   end type clutch_t

contains

   !> Registry factory: a new, unconfigured clutch.
   subroutine new_clutch(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (clutch_t :: el)
   end subroutine new_clutch

   subroutine clutch_configure(self, grp, units, err)
      class(clutch_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      self%one_way = .false.
      call read_friction(self, grp, .true., err)
   end subroutine clutch_configure
end module trainsim_el_clutch
