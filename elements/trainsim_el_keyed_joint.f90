!> EL2, keyed joint (Ch. IV; App. H, eqs. H.3-H.14): a shaft and a hub joined
!> by a key with clearance. "A gear pair with one external and one internal
!> tooth": delta = (d/2)(th_l - th_r) along the key face, half clearance b,
!> constant contact stiffness k (force/length; Table 5.4: 2.03e6 lb/in) and
!> the impact laws of the gear pair.
!>
!> stiffness_fit = 'tight' | 'loose' | 'average' replaces the constant
!> stiffness by the load-dependent FEM fits of eqs. (4.35)-(4.37) (lineal
!> stiffness per inch of key, in lbf/in/in, as a function of the key force in
!> lbf; converted for other units) times key_length.
!> Not modelled: the friction torque while the key is out of contact
!> (eqs. 4.38-4.44), which acts only with an external torque on the hub; its
!> Table 5.4 constants (friction, friction_angle, phi, load_radius) are
!> accepted and recorded.
module trainsim_el_keyed_joint
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t, to_lower
   use trainsim_contact, only: fit_tight, fit_loose, fit_average, key_lineal_stiffness
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_sink, only: param_list_t
   use trainsim_clearance_element, only: clearance_element_t
   implicit none
   private

   public :: keyed_joint_t

   type, extends(clearance_element_t) :: keyed_joint_t
      real(wp) :: diameter = 0.0_wp
      real(wp) :: mu = 0.0_wp, phi = 0.0_wp, load_radius = 0.0_wp, friction_angle = 0.0_wp
      real(wp) :: key_length = 0.0_wp
   contains
      procedure :: configure => key_configure
      procedure :: params => key_params
   end type keyed_joint_t

contains

   subroutine key_configure(self, grp, units, err)
      class(keyed_joint_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: fit
      real(wp) :: kl, dk
      call grp%get_real('diameter', self%diameter, err); if (allocated(err)) return
      call grp%get_real('half_clearance', self%cl%b, err); if (allocated(err)) return
      call grp%get_string('stiffness_fit', fit, err, default='constant'); if (allocated(err)) return
      select case (to_lower(fit))
      case ('constant')
         call grp%get_real('stiffness', self%cl%law%k, err); if (allocated(err)) return
      case ('tight', 'loose', 'average')
         if (to_lower(fit) == 'tight') self%cl%law%fit = fit_tight
         if (to_lower(fit) == 'loose') self%cl%law%fit = fit_loose
         if (to_lower(fit) == 'average') self%cl%law%fit = fit_average
         call grp%get_real('key_length', self%key_length, err); if (allocated(err)) return
         if (.not. self%key_length > 0.0_wp) then
            call fatal_error(err, grp%where('key_length')//': error: key_length must be > 0, got '// &
                             str(self%key_length), err_input)
            return
         end if
         self%cl%law%key_length_in = self%key_length*units%to_inch
         self%cl%law%to_inch = units%to_inch
         self%cl%law%to_lbf = units%to_lbf
         ! eq. (3.12) needs one stiffness: the fit's at its lowest fitted load (100 lbf)
         call key_lineal_stiffness(self%cl%law%fit, 100.0_wp, kl, dk)
         self%cl%law%k = kl*self%cl%law%key_length_in*units%to_inch/units%to_lbf
      case default
         call fatal_error(err, grp%where('stiffness_fit')//": error: unknown stiffness_fit '"//fit// &
                          "'; valid: constant, tight, loose, average", err_input)
         return
      end select
      call grp%get_real('friction', self%mu, err, default=0.0_wp); if (allocated(err)) return
      call grp%get_real('phi', self%phi, err, default=0.0_wp); if (allocated(err)) return
      call grp%get_real('load_radius', self%load_radius, err, default=0.0_wp); if (allocated(err)) return
      call grp%get_real('friction_angle', self%friction_angle, err, default=0.0_wp); if (allocated(err)) return
      if (.not. self%diameter > 0.0_wp) then
         call fatal_error(err, grp%where('diameter')//': error: diameter must be > 0, got '//str(self%diameter), err_input)
      else if (.not. self%cl%b >= 0.0_wp) then
         call fatal_error(err, grp%where('half_clearance')//': error: half_clearance must be >= 0, got '// &
                          str(self%cl%b), err_input)
      else if (.not. self%cl%law%k > 0.0_wp) then
         call fatal_error(err, grp%where('stiffness')//': error: stiffness must be > 0, got '//str(self%cl%law%k), err_input)
      else if (.not. self%mu >= 0.0_wp) then
         call fatal_error(err, grp%where('friction')//': error: friction must be >= 0, got '//str(self%mu), err_input)
      end if
      if (allocated(err)) return
      self%cl%r1 = 0.5_wp*self%diameter
      self%cl%r2 = 0.5_wp*self%diameter
      call self%cl%law%configure(grp, units, 1.0_wp, 'yang_sun', err)
   end subroutine key_configure

   function key_params(self) result(p)
      class(keyed_joint_t), intent(in) :: self
      type(param_list_t) :: p
      p%names = [string_t('diameter'), string_t('half_clearance'), string_t('stiffness'), string_t('friction'), &
                 string_t('phi'), string_t('load_radius'), string_t('friction_angle'), string_t('min_approach_velocity')]
      p%values = [self%diameter, self%cl%b, self%cl%law%k, self%mu, self%phi, self%load_radius, &
                  self%friction_angle, self%cl%law%v_min]
      if (self%cl%law%fit /= 0) then
         p%names = [p%names, string_t('stiffness_fit'), string_t('key_length')]
         p%values = [p%values, real(self%cl%law%fit, wp), self%key_length]
      end if
   end function key_params
end module trainsim_el_keyed_joint
