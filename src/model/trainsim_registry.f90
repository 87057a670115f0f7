!> The plug-in registry: node and element type names -> concrete types.
!> Adding an element = one new file in elements/ + one line in each table here.
module trainsim_registry
   use trainsim_strings, only: string_t, to_lower
   use trainsim_node, only: node_t
   use trainsim_element, only: element_t
   use trainsim_node_inertia, only: inertia_node_t
   use trainsim_node_fixed, only: fixed_node_t
   use trainsim_node_dc_motor, only: dc_motor_node_t
   use trainsim_el_shaft, only: shaft_t
   use trainsim_el_ideal_gear, only: ideal_gear_t
   use trainsim_el_spur_gear, only: spur_gear_t
   use trainsim_el_keyed_joint, only: keyed_joint_t
   use trainsim_el_clearance_coupling, only: clearance_coupling_t
   use trainsim_el_helical_gear, only: helical_gear_t
   implicit none
   private

   public :: make_node, make_element, node_type_names, element_type_names

contains

   !> Canonical element type names (TRAIN aliases: el1 shaft, el2 keyed_joint, el3 ideal_gear, el4 spur_gear).
   function element_type_names() result(names)
      type(string_t), allocatable :: names(:)
      names = [string_t('shaft'), string_t('keyed_joint'), string_t('ideal_gear'), string_t('spur_gear'), &
               string_t('helical_gear'), string_t('clearance_coupling')]
   end function element_type_names

   !> Canonical node type names (TRAIN aliases: n01 inertia, n02 dc_motor).
   function node_type_names() result(names)
      type(string_t), allocatable :: names(:)
      names = [string_t('inertia'), string_t('fixed'), string_t('dc_motor')]
   end function node_type_names

   !> Allocate an element of the named type; unallocated if the name is unknown.
   subroutine make_element(type_name, el)
      character(len=*), intent(in) :: type_name
      class(element_t), allocatable, intent(out) :: el
      select case (to_lower(type_name))
      case ('shaft', 'el1'); allocate (shaft_t :: el); el%type_name = 'shaft'
      case ('ideal_gear', 'el3'); allocate (ideal_gear_t :: el); el%type_name = 'ideal_gear'
      case ('spur_gear', 'el4'); allocate (spur_gear_t :: el); el%type_name = 'spur_gear'
      case ('keyed_joint', 'el2'); allocate (keyed_joint_t :: el); el%type_name = 'keyed_joint'
      case ('helical_gear'); allocate (helical_gear_t :: el); el%type_name = 'helical_gear'
      case ('clearance_coupling'); allocate (clearance_coupling_t :: el); el%type_name = 'clearance_coupling'
      end select
   end subroutine make_element

   !> Allocate a node of the named type; unallocated if the name is unknown.
   subroutine make_node(type_name, nd)
      character(len=*), intent(in) :: type_name
      class(node_t), allocatable, intent(out) :: nd
      select case (to_lower(type_name))
      case ('inertia', 'n01'); allocate (inertia_node_t :: nd); nd%type_name = 'inertia'
      case ('fixed', 'ground'); allocate (fixed_node_t :: nd); nd%type_name = 'fixed'
      case ('dc_motor', 'n02'); allocate (dc_motor_node_t :: nd); nd%type_name = 'dc_motor'
      end select
   end subroutine make_node
end module trainsim_registry
