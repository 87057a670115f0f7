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
!> While the key is out of contact, bore friction couples shaft and hub
!> (eqs. 4.38-4.41, MODEL-NOTES 14): the hub's external torque T_h acts at the
!> load radius R (tangential force T_h/R, radial force at the angle phi), the
!> bore's normal force is F_n = (T_h/R)/(sin a + mu cos a) (4.38) with the
!> friction angle a of eq. (4.43), and the friction torque transmitted at the
!> bore radius d/2 is at most T_max = mu (d/2) |T_h| / (R |sin a + mu cos a|)
!> (4.40; the corrected second line of 4.44). It opposes the slip
!> w_shaft - w_hub as a regularised Coulomb law T_max tanh(slip/friction_velocity).
!> The hub is the right node; T_h is the sum of the external loads on it. With
!> no load on the hub (Table 5.4) there is no friction.
!>
!> bore_friction = 'key_force' (D-80) takes the bore's normal force from the force the
!> key actually transmits instead: the key's contact force F_c (its clearance law,
!> eqs. 4.47-4.48) acts on the hub at the bore radius d/2, and the bore reacts it with
!> a normal force of the same size (a hub whose own load is a couple), so the friction
!> torque is at most mu (d/2) |F_c| = mu |T_key| and opposes the slip as above, in and
!> out of contact (out of contact F_c = 0: no friction).
module trainsim_el_keyed_joint
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t, to_lower
   use trainsim_contact, only: fit_tight, fit_loose, fit_average, key_lineal_stiffness
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list, append_params, add_choice, guarded_product, &
      guarded_ratio
   use trainsim_clearance_element, only: clearance_element_t, clearance_hot_form
   use trainsim_element, only: element_t, hot_form_t, hf_none
   implicit none
   private

   public :: keyed_joint_t, new_keyed_joint

   type, extends(clearance_element_t) :: keyed_joint_t
      real(wp) :: diameter = 0.0_wp
      real(wp) :: mu = 0.0_wp, phi = 0.0_wp, load_radius = 0.0_wp, friction_angle = 0.0_wp
      real(wp) :: key_length = 0.0_wp
      real(wp) :: friction_velocity = 1.0e-3_wp   !< slip speed of the tanh regularisation, rad/s
      real(wp) :: fric_factor = 0.0_wp            !< T_max / |T_h| = mu (d/2) / (R |sin a + mu cos a|)
      logical :: key_force = .false.              !< bore_friction = 'key_force': T_max = mu |T_key| (D-80)
   contains
      procedure :: configure => key_configure
      procedure :: params => key_params
      procedure :: torques => key_torques
      procedure :: torque_jacobian => key_torque_jacobian
      procedure :: dissipation_power => key_dissipation
      procedure :: torques_dissipation => key_torques_dissipation
      procedure :: hot_form => key_hot_form
      procedure, private :: friction => key_friction
   end type keyed_joint_t

contains

   !> Registry factory: a new, unconfigured keyed joint.
   subroutine new_keyed_joint(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (keyed_joint_t :: el)
   end subroutine new_keyed_joint

   subroutine key_configure(self, grp, units, err)
      class(keyed_joint_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: fit, bore
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
      call grp%get_real('friction_angle', self%friction_angle, err, default=huge(1.0_wp)); if (allocated(err)) return
      call grp%get_real('friction_velocity', self%friction_velocity, err, default=1.0e-3_wp); if (allocated(err)) return
      call grp%require_positive('friction_velocity', self%friction_velocity, err); if (allocated(err)) return
      call grp%get_string('bore_friction', bore, err, default='hub_load'); if (allocated(err)) return
      select case (to_lower(bore))
      case ('hub_load'); self%key_force = .false.
      case ('key_force'); self%key_force = .true.
      case default
         call fatal_error(err, grp%where('bore_friction')//": error: unknown bore_friction '"//bore// &
                          "'; valid: hub_load (eqs. 4.38-4.44, the default), key_force (the key's contact force)", &
                          err_input)
         return
      end select
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
      if (self%friction_angle == huge(1.0_wp)) then
         ! eq. (4.43): tan a = (1 - mu tan phi) / (tan phi - mu)
         self%friction_angle = atan2(1.0_wp - self%mu*tan(self%phi), tan(self%phi) - self%mu)
         if (self%friction_angle > 0.5_wp*acos(-1.0_wp)) self%friction_angle = self%friction_angle - acos(-1.0_wp)
      end if
      if (self%mu > 0.0_wp .and. .not. self%key_force) then
         if (.not. self%load_radius > 0.0_wp) then
            call fatal_error(err, grp%where('load_radius')//': error: friction > 0 needs load_radius > 0 (the '// &
                             'radius at which the hub is loaded), got '//str(self%load_radius), err_input)
            return
         end if
         self%fric_factor = self%mu*0.5_wp*self%diameter/(self%load_radius* &
                            abs(sin(self%friction_angle) + self%mu*cos(self%friction_angle)))
         self%needs_loads = .true.
      end if
      call self%cl%law%configure(grp, units, 1.0_wp, 'yang_sun', err)
   end subroutine key_configure

   !> Bore friction torque on the hub (the shaft gets its reaction) and its
   !> derivative with respect to the slip (at a fixed normal force). 'hub_load':
   !> from the hub's external loads, zero while the key is in contact; 'key_force':
   !> from the key's torque on the hub `tkey` (its contact force times d/2).
   pure subroutine key_friction(self, wl, wr, tkey, tf, dtf)
      class(keyed_joint_t), intent(in) :: self
      real(wp), intent(in) :: wl, wr, tkey
      real(wp), intent(out) :: tf, dtf
      real(wp) :: tmax, x
      tf = 0.0_wp; dtf = 0.0_wp
      if (self%key_force) then
         tmax = self%mu*abs(tkey)                             ! mu (d/2) |F_c|
      else
         if (self%cl%mode /= 0 .or. self%fric_factor == 0.0_wp) return
         tmax = self%fric_factor*abs(self%ext_right)          ! eqs. (4.38), (4.40)
      end if
      x = (wl - wr)/self%friction_velocity
      tf = tmax*tanh(x)
      dtf = tmax/self%friction_velocity*(1.0_wp - tanh(x)**2)
   end subroutine key_friction

   pure subroutine key_torques(self, thl, wl, thr, wr, tl, tr)
      class(keyed_joint_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      real(wp) :: tf, dtf
      call self%cl%torques(1.0_wp, thl, wl, thr, wr, tl, tr)   ! eqs. (H.3)-(H.11), (4.45)-(4.48)
      call self%friction(wl, wr, tr, tf, dtf)                  ! eqs. (4.38)-(4.41), or D-80
      tl = tl - tf
      tr = tr + tf
   end subroutine key_torques

   pure subroutine key_torque_jacobian(self, thl, wl, thr, wr, jt)
      class(keyed_joint_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      real(wp) :: tf, dtf, tl, tkey, dn(4)
      call self%cl%torque_jacobian(1.0_wp, 0.0_wp, thl, wl, thr, wr, jt)
      tkey = 0.0_wp
      if (self%key_force) call self%cl%torques(1.0_wp, thl, wl, thr, wr, tl, tkey)
      call self%friction(wl, wr, tkey, tf, dtf)
      if (self%key_force .and. tkey /= 0.0_wp) then
         ! the normal force's own partials: d tf = mu sign(tkey) tanh(x) d tkey
         dn = self%mu*sign(1.0_wp, tkey)*tanh((wl - wr)/self%friction_velocity)*jt(2, :)
      else
         dn = 0.0_wp
      end if
      jt(1, :) = jt(1, :) - dn
      jt(2, :) = jt(2, :) + dn
      jt(1, 2) = jt(1, 2) - dtf; jt(1, 4) = jt(1, 4) + dtf
      jt(2, 2) = jt(2, 2) + dtf; jt(2, 4) = jt(2, 4) - dtf
   end subroutine key_torque_jacobian

   pure real(wp) function key_dissipation(self, thl, wl, thr, wr) result(p)
      class(keyed_joint_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: tf, dtf, tl, tkey
      tkey = 0.0_wp
      if (self%key_force) call self%cl%torques(1.0_wp, thl, wl, thr, wr, tl, tkey)
      call self%friction(wl, wr, tkey, tf, dtf)
      p = self%cl%dissipation(1.0_wp, thl, wl, thr, wr) + tf*(wl - wr)
   end function key_dissipation

   !> Its own `torques` and `dissipation_power` (not the clearance element's
   !> combined form: both add the bore friction), from one key fit: bit for bit
   !> the two calls (key_friction reads tkey only with key_force, where
   !> key_dissipation passes the clearance's tr, as key_torques does).
   pure subroutine key_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
      class(keyed_joint_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, p
      real(wp) :: tf, dtf, pc
      call self%cl%torques_dissipation(1.0_wp, thl, wl, thr, wr, tl, tr, pc)
      call self%friction(wl, wr, tr, tf, dtf)
      tl = tl - tf
      tr = tr + tf
      p = pc + tf*(wl - wr)
   end subroutine key_torques_dissipation

   !> Hot form (D-35): the clearance element's, whose torques are key_torques'
   !> when there is no bore friction (tf = 0: tl - 0 and tr + 0, equal values);
   !> with bore friction the torques stay with `torques` (the guards are the faces').
   pure subroutine key_hot_form(self, form)
      class(keyed_joint_t), intent(in) :: self
      type(hot_form_t), intent(out) :: form
      call clearance_hot_form(self, form)
      if (self%fric_factor /= 0.0_wp .or. (self%key_force .and. self%mu /= 0.0_wp)) form%kind = hf_none
   end subroutine key_hot_form

   function key_params(self) result(p)
      class(keyed_joint_t), intent(in) :: self
      type(param_list_t) :: p
      ! derived: angular stiffness k (d/2)^2 (torque/rad)
      p = make_param_list([character(len=40) :: 'diameter', 'half_clearance', 'stiffness', &
                       'friction', 'phi', 'load_radius', &
                       'friction_angle', 'min_approach_velocity', &
                       'friction_velocity', 'friction_capacity_per_hub_torque', &
                       'angular_stiffness'], &
                       [self%diameter, self%cl%b, self%cl%law%k, self%mu, self%phi, self%load_radius, &
                        self%friction_angle, self%cl%law%v_min, self%friction_velocity, self%fric_factor, &
                        guarded_product(self%cl%law%k, guarded_product(0.5_wp*self%diameter, 0.5_wp*self%diameter))])
      if (self%cl%law%fit /= 0) then
         ! the file's attribute stiffness_fit: 1 tight, 2 loose, 3 average
         call add_choice(p, 'stiffness_fit', real(self%cl%law%fit, wp), fit_word(self%cl%law%fit))
         call append_params(p, [character(len=40) :: 'key_length'], [self%key_length])
      end if
      if (self%key_force) call add_choice(p, 'bore_friction', 1.0_wp, 'key_force')   ! (hub_load: not written)
   end function key_params

   !> The deck word of a stiffness fit code.
   pure function fit_word(fit) result(w)
      integer, intent(in) :: fit
      character(len=:), allocatable :: w
      select case (fit)
      case (fit_tight); w = 'tight'
      case (fit_loose); w = 'loose'
      case (fit_average); w = 'average'
      case default; w = 'constant'
      end select
   end function fit_word
end module trainsim_el_keyed_joint
