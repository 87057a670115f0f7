!> Worm gear pair: left node the worm, right node the wheel. A lossy gear
!> (trainsim_el_lossy_gear) along the wheel's pitch circle: lever arms
!> r2 = wheel_radius, r1 = r2 / ratio (the lead over 2 pi: one worm turn moves
!> the wheel's pitch circle by one lead), mesh stiffness and backlash along it,
!> and the efficiencies of the inclined plane (trainsim_worm_calc,
!> docs/elements.md "worm_gear"):
!>   eta_f = (cos an - mu tan g)/(cos an + mu cot g)   (worm drives)
!>   eta_b = (cos an - mu cot g)/(cos an + mu tan g)   (wheel drives)
!> or both given. eta_b <= 0 is a self-locking pair: back-driven, the mesh
!> brakes the worm, and a worm stopped under load is held (stuck, D-81).
module trainsim_el_worm_gear
   use trainsim_kinds, only: wp, pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list
   use trainsim_element, only: element_t
   use trainsim_el_lossy_gear, only: lossy_gear_t, read_mesh, get_efficiency
   use trainsim_worm_calc, only: worm_efficiencies
   implicit none
   private

   public :: worm_gear_t, new_worm_gear

   type, extends(lossy_gear_t) :: worm_gear_t
      real(wp) :: ratio = 1.0_wp
      real(wp) :: lead_angle = 0.0_wp, pressure_angle = 0.0_wp, mu = -1.0_wp   !< deg, deg; mu < 0: not given
   contains
      procedure :: configure => worm_configure
      procedure :: params => worm_params
   end type worm_gear_t

contains

   !> Registry factory: a new, unconfigured worm gear pair.
   subroutine new_worm_gear(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (worm_gear_t :: el)
   end subroutine new_worm_gear

   subroutine worm_configure(self, grp, units, err)
      class(worm_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: rw
      call grp%get_real('ratio', self%ratio, err); if (allocated(err)) return
      call grp%get_real('wheel_radius', rw, err); if (allocated(err)) return
      if (.not. self%ratio > 0.0_wp) then
         call fatal_error(err, grp%where('ratio')//': error: ratio (worm turns per wheel turn) must be > 0, got '// &
                          str(self%ratio), err_input)
         return
      else if (.not. rw > 0.0_wp) then
         call fatal_error(err, grp%where('wheel_radius')//': error: wheel pitch radius must be > 0, got '//str(rw), &
                          err_input)
         return
      end if
      self%cl%r2 = rw
      self%cl%r1 = rw/self%ratio
      if (grp%has('friction_coefficient')) then
         if (grp%holds('efficiency_forward') .or. grp%holds('efficiency_backward')) then
            call fatal_error(err, grp%where('friction_coefficient')//': error: give friction_coefficient (with '// &
                             'lead_angle), or efficiency_forward and efficiency_backward, not both', err_input)
            return
         end if
         call read_friction(self, grp, err); if (allocated(err)) return
      else
         call get_efficiency(grp, 'efficiency_forward', self%eta_f, .false., err); if (allocated(err)) return
         call get_efficiency(grp, 'efficiency_backward', self%eta_b, .true., err); if (allocated(err)) return
         if (self%eta_b > self%eta_f) then
            call fatal_error(err, grp%where('efficiency_backward')//': error: a worm''s backward efficiency '// &
                             str(self%eta_b)//' above its forward efficiency '//str(self%eta_f)//' (the '// &
                             'inclined plane gives eta_b < eta_f for lead angles below 45 deg)', err_input)
            return
         end if
      end if
      call read_mesh(self, grp, units, err)
   end subroutine worm_configure

   !> lead_angle in (0, 90) deg, pressure_angle (normal) in (0, 45) deg, default
   !> 20, friction_coefficient in [0, 1): the efficiencies of trainsim_worm_calc.
   subroutine read_friction(self, grp, err)
      class(worm_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(error_t), allocatable, intent(out) :: err
      call grp%get_real('friction_coefficient', self%mu, err); if (allocated(err)) return
      call grp%get_real('lead_angle', self%lead_angle, err); if (allocated(err)) return
      call grp%get_real('pressure_angle', self%pressure_angle, err, default=20.0_wp); if (allocated(err)) return
      if (.not. (self%mu >= 0.0_wp .and. self%mu < 1.0_wp)) then
         call fatal_error(err, grp%where('friction_coefficient')//': error: friction coefficient must be in '// &
                          '[0, 1), got '//str(self%mu), err_input)
      else if (.not. (self%lead_angle > 0.0_wp .and. self%lead_angle < 90.0_wp)) then
         call fatal_error(err, grp%where('lead_angle')//': error: lead angle must be in (0, 90) degrees, got '// &
                          str(self%lead_angle), err_input)
      else if (.not. (self%pressure_angle > 0.0_wp .and. self%pressure_angle < 45.0_wp)) then
         call fatal_error(err, grp%where('pressure_angle')//': error: normal pressure angle must be in (0, 45) '// &
                          'degrees, got '//str(self%pressure_angle), err_input)
      end if
      if (allocated(err)) return
      call worm_efficiencies(self%lead_angle*pi/180.0_wp, self%pressure_angle*pi/180.0_wp, self%mu, &
                             self%eta_f, self%eta_b)
      if (.not. self%eta_f > 0.0_wp) call fatal_error(err, grp%where('lead_angle')//': error: lead angle '// &
         str(self%lead_angle)//' deg with friction '//str(self%mu)//' gives a forward efficiency of '// &
         str(self%eta_f)//' (the worm cannot drive the wheel either)', err_input)
   end subroutine read_friction

   function worm_params(self) result(p)
      class(worm_gear_t), intent(in) :: self
      type(param_list_t) :: p
      p = make_param_list([character(len=40) :: 'ratio', 'wheel_radius', 'stiffness', 'backlash', &
                           'lead_angle', 'pressure_angle', 'friction_coefficient', &
                           'efficiency_forward', 'efficiency_backward'], &
                          [self%ratio, self%cl%r2, self%cl%law%k, 2.0_wp*self%cl%b, self%lead_angle, &
                           self%pressure_angle, self%mu, self%eta_f, self%eta_b])
   end function worm_params
end module trainsim_el_worm_gear
