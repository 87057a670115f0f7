!> One-way clutch (freewheel): locked (stuck) against the left node turning slower than the right, free otherwise; capacity bounds the locked torque (D-81).
!> The modes, the friction law and the guards are trainsim_friction_element's
!> (docs/elements.md "Friction elements").
module trainsim_el_one_way_clutch
   use trainsim_error, only: error_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_element, only: element_t
   use trainsim_friction_element, only: friction_element_t, read_friction
   implicit none
   private

   public :: one_way_clutch_t, new_one_way_clutch

   type, extends(friction_element_t) :: one_way_clutch_t
   contains
      procedure :: configure => one_way_clutch_configure
   end type one_way_clutch_t

contains

   !> Registry factory: a new, unconfigured one_way_clutch.
   subroutine new_one_way_clutch(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (one_way_clutch_t :: el)
   end subroutine new_one_way_clutch

   subroutine one_way_clutch_configure(self, grp, units, err)
      class(one_way_clutch_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      self%one_way = .true.
      call read_friction(self, grp, .false., err)
   end subroutine one_way_clutch_configure
end module trainsim_el_one_way_clutch
