!> The plug-in registry: one table per plug-in kind (nodes, elements). A row
!> holds everything the rest of trainsim knows about a type: its canonical
!> name, its aliases (TRAIN's el1..el4, n01/n02), a one-line summary, an
!> example deck fragment (the keys and valid values of a typical instance)
!> with the keys that must be > 0 and >= 0, and the factory that allocates
!> it. `make_element`, `make_node`, the lists of valid names in error messages
!> and the conformance suite (tests/test_conformance.f90) all read the table.
!>
!> Adding an element = one new file in elements/ (with its `new_<type>`
!> factory) + one row in `element_registry` (docs/plugins.md).
module trainsim_registry
   use trainsim_strings, only: string_t
   use trainsim_deck_group, only: same_key   ! (case-insensitive, without a lowered copy)
   use trainsim_node, only: node_t
   use trainsim_element, only: element_t
   use trainsim_node_inertia, only: new_inertia_node
   use trainsim_node_fixed, only: new_fixed_node
   use trainsim_node_dc_motor, only: new_dc_motor_node
   use trainsim_el_shaft, only: new_shaft
   use trainsim_el_ideal_gear, only: new_ideal_gear
   use trainsim_el_spur_gear, only: new_spur_gear
   use trainsim_el_keyed_joint, only: new_keyed_joint
   use trainsim_el_clearance_coupling, only: new_clearance_coupling
   use trainsim_el_helical_gear, only: new_helical_gear
   use trainsim_el_damper, only: new_damper
   use trainsim_el_bearing_friction, only: new_bearing_friction
   use trainsim_el_brake, only: new_brake
   use trainsim_el_clutch, only: new_clutch
   use trainsim_el_one_way_clutch, only: new_one_way_clutch
   use trainsim_el_lossy_gear, only: new_lossy_gear
   use trainsim_el_worm_gear, only: new_worm_gear
   use trainsim_el_rigid, only: new_rigid_gear, new_rigid_join
   use trainsim_el_rigid_lossy, only: new_rigid_lossy_gear
   implicit none
   private

   public :: make_node, make_element, node_type_names, element_type_names
   public :: element_row_t, node_row_t, element_registry, node_registry

   abstract interface
      !> Allocate a new, unconfigured element of one concrete type.
      subroutine element_factory_i(el)
         import :: element_t
         class(element_t), allocatable, intent(out) :: el
      end subroutine element_factory_i
      !> Allocate a new, unconfigured node of one concrete type.
      subroutine node_factory_i(nd)
         import :: node_t
         class(node_t), allocatable, intent(out) :: nd
      end subroutine node_factory_i
   end interface

   !> One element type: what the deck, the messages, the docs and the
   !> conformance suite know about it.
   type :: element_row_t
      character(len=:), allocatable :: name            !< canonical type name (lower case)
      type(string_t), allocatable :: aliases(:)        !< other accepted names (lower case)
      character(len=:), allocatable :: summary         !< one line, for listings
      !> keys and valid values of a typical instance, as in a deck ("stiffness = 5.0e4, ...")
      character(len=:), allocatable :: example
      type(string_t), allocatable :: positive(:)       !< keys of the example that must be > 0
      type(string_t), allocatable :: nonnegative(:)    !< keys of the example that must be >= 0
      procedure(element_factory_i), pointer, nopass :: make => null()
   end type element_row_t

   !> One node type (same fields as an element row).
   type :: node_row_t
      character(len=:), allocatable :: name
      type(string_t), allocatable :: aliases(:)
      character(len=:), allocatable :: summary
      character(len=:), allocatable :: example
      type(string_t), allocatable :: positive(:)
      type(string_t), allocatable :: nonnegative(:)
      procedure(node_factory_i), pointer, nopass :: make => null()
   end type node_row_t

contains

   !> The element types, one row each, in the order they are listed to users.
   function element_registry() result(rows)
      type(element_row_t), allocatable :: rows(:)
      call element_table(rows)
   end function element_registry

   !> The node types, one row each.
   function node_registry() result(rows)
      type(node_row_t), allocatable :: rows(:)
      call node_table(rows)
   end function node_registry

   !> THE ELEMENT TABLE: one row per element type.
   !> (Built once: gfortran 12 leaks the strings of an array constructor of rows, about
   !> 10 kB a call, and every model build calls it; a 10^5-run sweep grew by 1 GB.)
   subroutine element_table(rows)
      type(element_row_t), allocatable, intent(out) :: rows(:)
      type(element_row_t), allocatable, save :: table(:)
      if (allocated(table)) then
         rows = table
         return
      end if
      table = [ &
             element_row('shaft', 'el1', 'massless visco-elastic torsion spring (App. H, eqs. H.1-H.2)', &
                         'stiffness = 5.0e4, damping = 2.0', 'stiffness', 'damping', new_shaft), &
             element_row('keyed_joint', 'el2', 'shaft and hub keyed with clearance (Ch. IV, eqs. H.3-H.14)', &
                         'diameter = 2.0, half_clearance = 0.01, stiffness = 1.0e6, initial_contact_velocity = 1.0', &
                         'diameter stiffness', 'half_clearance initial_contact_velocity', new_keyed_joint), &
             element_row('ideal_gear', 'el3', 'gear pair without backlash, constant mesh stiffness (eqs. H.15-H.16)', &
                         'stiffness = 1.0e6, rb_driver = 1.0, rb_driven = 2.0', 'stiffness rb_driver rb_driven', '', &
                         new_ideal_gear), &
             element_row('spur_gear', 'el4', 'spur gear pair with backlash and one/two-pair mesh zones (Ch. III)', &
                         'stiffness = 1.0e6, rb_driver = 1.0, rb_driven = 1.5, teeth = 20, contact_ratio = 1.5, '// &
                         'approach_angle = 0.1, half_backlash = 0.01, initial_contact_velocity = 2.0', &
                         'stiffness rb_driver rb_driven teeth', 'half_backlash initial_contact_velocity', new_spur_gear), &
             element_row('helical_gear', '', 'helical gear pair with backlash, contact-line stiffness (Ch. VI)', &
                         'rb_driver = 1.0, rb_driven = 1.5, teeth = 24, profile_contact_ratio = 1.5, '// &
                         'base_helix_angle = 18.0, face_width = 1.3, half_backlash = 0.01, initial_contact_velocity = 2.0', &
                         'rb_driver rb_driven teeth face_width', 'half_backlash initial_contact_velocity', &
                         new_helical_gear), &
             element_row('clearance_coupling', '', 'angular dead zone with a spring-damper contact law', &
                         'clearance = 0.02, stiffness = 1.0e4, contact_damping = 3.0, radius = 1.5', &
                         'stiffness radius', 'clearance contact_damping', new_clearance_coupling), &
             element_row('damper', '', 'torsional viscous damper (dashpot), T = c (w_l - w_r)', &
                         'damping = 40.0', 'damping', '', new_damper), &
             element_row('bearing_friction', '', 'Coulomb/Stribeck/viscous friction that sticks (right: a fixed node)', &
                         'torque_sliding = 2.0, torque_static = 3.0, stribeck_speed = 0.1, viscous = 0.01', '', &
                         'torque_sliding stribeck_speed viscous', new_bearing_friction), &
             element_row('brake', '', 'friction brake to ground or between two nodes, engagement e(t) in [0, 1]', &
                         'torque_sliding = 50.0, torque_static = 60.0, stribeck_speed = 0.5, viscous = 0.2, '// &
                         'engagement = 1.0', '', 'torque_sliding stribeck_speed viscous engagement', new_brake), &
             element_row('clutch', '', 'friction clutch between two nodes, engagement e(t) in [0, 1]', &
                         'torque_sliding = 80.0, torque_static = 100.0, stribeck_speed = 1.0, viscous = 0.5, '// &
                         'engagement = 1.0', '', 'torque_sliding stribeck_speed viscous engagement', new_clutch), &
             element_row('one_way_clutch', 'freewheel', 'freewheel: locked against w_left < w_right, free otherwise', &
                         'capacity = 500.0, torque_sliding = 0.5, viscous = 0.02', 'capacity', &
                         'torque_sliding viscous', new_one_way_clutch), &
             element_row('lossy_gear', '', 'gear pair with mesh efficiency by power flow, backlash, stiffness', &
                         'rb_driver = 1.0, rb_driven = 2.0, stiffness = 1.0e6, efficiency_forward = 0.95, '// &
                         'efficiency_backward = 0.9, backlash = 0.004, contact_damping = 10.0', &
                         'rb_driver rb_driven stiffness efficiency_forward efficiency_backward', &
                         'backlash contact_damping', new_lossy_gear), &
             element_row('worm_gear', '', 'worm pair: efficiencies from lead angle and friction, self-locking', &
                         'ratio = 40.0, wheel_radius = 3.0, lead_angle = 5.7, friction_coefficient = 0.05, '// &
                         'stiffness = 1.0e6, backlash = 0.004, contact_damping = 10.0', &
                         'ratio wheel_radius stiffness lead_angle', 'friction_coefficient backlash contact_damping', &
                         new_worm_gear), &
             element_row('rigid_gear', '', 'gear pair without compliance: the constraint r1 w_l = r2 w_r', &
                         'rb_driver = 1.0, rb_driven = 2.0', 'rb_driver rb_driven', '', new_rigid_gear), &
             element_row('rigid_lossy_gear', '', 'rigid gear pair with mesh efficiencies: power flow, held', &
                         'rb_driver = 1.0, rb_driven = 2.0, efficiency_forward = 0.95, efficiency_backward = 0.9', &
                         'rb_driver rb_driven efficiency_forward efficiency_backward', '', new_rigid_lossy_gear), &
             element_row('rigid_join', '', 'two nodes one rigid body: the constraint w_l = w_r', '', '', '', &
                         new_rigid_join) &
             ]
      rows = table
   end subroutine element_table

   !> THE NODE TABLE: one row per node type.
   subroutine node_table(rows)
      type(node_row_t), allocatable, intent(out) :: rows(:)
      type(node_row_t), allocatable, save :: table(:)      ! (built once, as the element table)
      if (allocated(table)) then
         rows = table
         return
      end if
      table = [ &
             node_row('inertia', 'n01', 'rigid disk with viscous damping to ground (eqs. G.1-G.2)', &
                      'inertia = 0.5, damping = 0.3', 'inertia', 'damping', new_inertia_node), &
             node_row('fixed', 'ground', 'ground: a node that does not move', '', '', '', new_fixed_node), &
             node_row('dc_motor', 'n02', 'constant-field DC motor with its armature circuit (eqs. G.3-G.5)', &
                      'inertia = 0.1, damping = 0.01, torque_constant = 0.5, inductance = 0.01, resistance = 1.0, '// &
                      'back_emf_constant = 0.0565', 'inertia torque_constant inductance resistance back_emf_constant', &
                      'damping', new_dc_motor_node) &
             ]
      rows = table
   end subroutine node_table

   !> Canonical element type names, in table order.
   function element_type_names() result(names)
      type(string_t), allocatable :: names(:)
      type(element_row_t), allocatable :: rows(:)
      integer :: i
      call element_table(rows)
      allocate (names(size(rows)))
      do i = 1, size(rows)
         names(i)%s = rows(i)%name
      end do
   end function element_type_names

   !> Canonical node type names, in table order.
   function node_type_names() result(names)
      type(string_t), allocatable :: names(:)
      type(node_row_t), allocatable :: rows(:)
      integer :: i
      call node_table(rows)
      allocate (names(size(rows)))
      do i = 1, size(rows)
         names(i)%s = rows(i)%name
      end do
   end function node_type_names

   !> Allocate an element of the named type (canonical name or alias, any
   !> case), with type_name set to the canonical name; unallocated if unknown.
   subroutine make_element(type_name, el)
      character(len=*), intent(in) :: type_name
      class(element_t), allocatable, intent(out) :: el
      type(element_row_t), allocatable, save :: rows(:)   ! one copy, not one per element (D-74)
      integer :: i
      if (.not. allocated(rows)) call element_table(rows)
      do i = 1, size(rows)
         if (matches(type_name, rows(i)%name, rows(i)%aliases)) then
            call rows(i)%make(el)
            el%type_name = rows(i)%name
            return
         end if
      end do
   end subroutine make_element

   !> Allocate a node of the named type (canonical name or alias, any case),
   !> with type_name set to the canonical name; unallocated if unknown.
   subroutine make_node(type_name, nd)
      character(len=*), intent(in) :: type_name
      class(node_t), allocatable, intent(out) :: nd
      type(node_row_t), allocatable, save :: rows(:)   ! one copy, not one per node (D-74)
      integer :: i
      if (.not. allocated(rows)) call node_table(rows)
      do i = 1, size(rows)
         if (matches(type_name, rows(i)%name, rows(i)%aliases)) then
            call rows(i)%make(nd)
            nd%type_name = rows(i)%name
            return
         end if
      end do
   end subroutine make_node

   !> Whether `given` names the type `name` or one of its aliases (case-insensitive).
   pure logical function matches(given, name, aliases)
      character(len=*), intent(in) :: given, name
      type(string_t), intent(in) :: aliases(:)
      integer :: j
      matches = same_key(name, given)   ! (no lowered copy of `given` a comparison)
      do j = 1, size(aliases)
         matches = matches .or. same_key(aliases(j)%s, given)
      end do
   end function matches

   !> A row of the element table; the lists are blank-separated words.
   function element_row(name, aliases, summary, example, positive, nonnegative, make) result(row)
      character(len=*), intent(in) :: name, aliases, summary, example, positive, nonnegative
      procedure(element_factory_i) :: make
      type(element_row_t) :: row
      row%name = name
      call split_words(aliases, row%aliases)
      row%summary = summary
      row%example = example
      call split_words(positive, row%positive)
      call split_words(nonnegative, row%nonnegative)
      row%make => make
   end function element_row

   !> A row of the node table; the lists are blank-separated words.
   function node_row(name, aliases, summary, example, positive, nonnegative, make) result(row)
      character(len=*), intent(in) :: name, aliases, summary, example, positive, nonnegative
      procedure(node_factory_i) :: make
      type(node_row_t) :: row
      row%name = name
      call split_words(aliases, row%aliases)
      row%summary = summary
      row%example = example
      call split_words(positive, row%positive)
      call split_words(nonnegative, row%nonnegative)
      row%make => make
   end function node_row

   !> The blank-separated words of `text`.
   pure subroutine split_words(text, list)
      character(len=*), intent(in) :: text
      type(string_t), allocatable, intent(out) :: list(:)
      integer :: i, start
      allocate (list(0))
      start = 0
      do i = 1, len(text) + 1
         if (i <= len(text)) then
            if (text(i:i) /= ' ') then
               if (start == 0) start = i
               cycle
            end if
         end if
         if (start > 0) then
            list = [list, string_t(text(start:i - 1))]
            start = 0
         end if
      end do
   end subroutine split_words
end module trainsim_registry
