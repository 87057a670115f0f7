!> Clearance coupling: an angular dead zone between two shafts (total
!> clearance in rad), torsional stiffness and a selectable contact law:
!> 'linear' spring-damper (default), 'elasto_backlash' (Modelica, never pulls)
!> or 'yang_sun' as the gears (its restitution fits need a line speed: the
!> relative angular speed times `radius`).
module trainsim_el_clearance_coupling
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list
   use trainsim_clearance_element, only: clearance_element_t
   use trainsim_element, only: element_t
   implicit none
   private

   public :: clearance_coupling_t, new_clearance_coupling

   type, extends(clearance_element_t) :: clearance_coupling_t
      real(wp) :: radius = 1.0_wp
   contains
      procedure :: configure => cc_configure
      procedure :: displacement_unit => cc_displacement_unit
      procedure :: params => cc_params
   end type clearance_coupling_t

contains

   !> Registry factory: a new, unconfigured clearance coupling.
   subroutine new_clearance_coupling(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (clearance_coupling_t :: el)
   end subroutine new_clearance_coupling

   subroutine cc_configure(self, grp, units, err)
      class(clearance_coupling_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: clearance
      call grp%get_real('clearance', clearance, err); if (allocated(err)) return
      call grp%get_real('stiffness', self%cl%law%k, err); if (allocated(err)) return
      call grp%get_real('radius', self%radius, err, default=1.0_wp); if (allocated(err)) return
      if (.not. clearance >= 0.0_wp) then
         call fatal_error(err, grp%where('clearance')//': error: clearance must be >= 0 rad, got '//str(clearance), &
                          err_input)
      else if (.not. self%cl%law%k > 0.0_wp) then
         call fatal_error(err, grp%where('stiffness')//': error: stiffness must be > 0, got '//str(self%cl%law%k), &
                          err_input)
      else if (.not. self%radius > 0.0_wp) then
         call fatal_error(err, grp%where('radius')//': error: radius must be > 0, got '//str(self%radius), err_input)
      end if
      if (allocated(err)) return
      self%cl%b = 0.5_wp*clearance
      self%cl%r1 = 1.0_wp
      self%cl%r2 = 1.0_wp
      call self%cl%law%configure(grp, units, self%radius, 'linear', err)
   end subroutine cc_configure

   pure function cc_displacement_unit(self) result(u)
      class(clearance_coupling_t), intent(in) :: self
      character(len=:), allocatable :: u
      associate (unused => self)
      end associate
      u = 'rad'
   end function cc_displacement_unit

   function cc_params(self) result(p)
      class(clearance_coupling_t), intent(in) :: self
      type(param_list_t) :: p
      ! One structure constructor: assigning p%names, then p%values trips gfortran 12's
      ! false -Wuninitialized on the descriptors of the unallocated components.
      p = make_param_list([character(len=40) :: 'clearance', 'stiffness', 'contact_damping', 'radius'], &
                       [2.0_wp*self%cl%b, self%cl%law%k, self%cl%law%c, self%radius])
   end function cc_params
end module trainsim_el_clearance_coupling
