!> EL4, spur gear pair with backlash (Ch. III; App. A, F, H).
!>
!> Mesh force along the line of action with clearance 2b (see trainsim_contact),
!> stiffness c k with c = 1 in the single-pair zone and c = two_pair_factor
!> (1.8 by default, Table 3.1; 2 in App. A/H and the listing) in the two-pair
!> zone of the driver's angle. Zones follow the Pascal `Mode` function of
!> App. F: with u = N (theta + alpha) / (2 pi) and n = INT(u) + 1, one pair is in
!> contact while 2 pi (n - 2 + m_p)/N - alpha < theta < 2 pi n/N - alpha.
!> zone_function = 'periodic' (default) uses floor for INT; 'truncate' is the
!> listing's TRUNC, which makes every negative u a two-pair zone.
!>
!> Parameters either as TRAIN's seven constants (stiffness, rb_driver,
!> rb_driven, teeth, contact_ratio, approach_angle, half_backlash) or from gear
!> geometry (teeth_driver, teeth_driven, diametral_pitch [1/in] or module [mm],
!> pressure_angle [deg], face_width, backlash [total, along the line of action]);
!> the mesh stiffness then defaults to eq. (3.9) per unit face width.
!> stiffness_model, the static transmission error and tooth faults (issue 26):
!> trainsim_mesh_excitation, through trainsim_excited_mesh.
module trainsim_el_spur_gear
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t, to_lower
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_limits, only: check_magnitude
   use trainsim_param_list, only: param_list_t, make_param_list, append_params, add_choice, guarded_product, &
      guarded_ratio
   use trainsim_event, only: event_t, ev_zone
   use trainsim_element, only: lin_state_t, lin_zone_single, lin_zone_stiffest
   use trainsim_clearance_element, only: clearance_hot_form
   use trainsim_element, only: element_t, hot_form_t, hg_faces_zone, hg_none, hf_none
   use trainsim_excited_mesh, only: em_torques_dissipation, em_status, em_guards, configure_mesh_excitation
   use trainsim_friction_mesh, only: friction_mesh_t
   use trainsim_mesh_excitation, only: model_name
   use trainsim_gear_mesh, only: accept_mesh, check_internal_radii, internal_contact_ratio
   implicit none
   private

   public :: spur_gear_t, new_spur_gear, contact_ratio, mesh_zone, tooth_phase, max_teeth

   !> Largest tooth count accepted (a 10 m wheel at module 1 mm); more is a typing error.
   real(wp), parameter :: max_teeth = 1.0e4_wp
   !> |driver angle| beyond which the tooth phase is taken at this value: the
   !> state has run away (the integrators stop at 1e100), and the phase
   !> arithmetic must not overflow on the way there.
   real(wp), parameter :: theta_cap = 1.0e250_wp

   !> teeth, alpha, phase (mesh_phase), pairs (the zone) and the excitation: excited_mesh_t;
   !> the tooth friction (eqs. 3.13-3.14, D-98; off at tooth_friction = 0): friction_mesh_t.
   type, extends(friction_mesh_t) :: spur_gear_t
      real(wp) :: mp = 1.0_wp             !< contact ratio
      real(wp) :: c2 = 1.8_wp             !< stiffness factor in the two-pair zone
      logical :: truncate = .false.       !< zone_function = 'truncate'
      logical :: internal = .false.       !< mesh = 'internal': a pinion (left) in a ring gear (right)
      real(wp) :: th_lo = 0.0_wp, th_hi = 0.0_wp   !< driver-angle bounds of the current zone
      logical :: lo_open = .false.        !< the zone has no lower bound (truncate, u < 0)
      ! geometry (0 when given as TRAIN constants)
      real(wp) :: teeth2 = 0.0_wp, pitch_module = 0.0_wp, phi = 0.0_wp, face = 0.0_wp
   contains
      procedure :: configure => spur_configure
      procedure :: n_guards => spur_n_guards
      procedure :: guards => spur_guards
      procedure :: init_mode => spur_init_mode
      procedure :: update_mode => spur_update_mode
      procedure :: status => spur_status
      procedure :: params => spur_params
      procedure :: factor => spur_factor
      procedure :: state_factor => spur_state_factor
      procedure :: hot_form => spur_hot_form
      procedure, private :: set_zone
      ! tooth friction (D-98): with tooth_friction = 0 these are the excited mesh's
      procedure :: torques_dissipation => spur_torques_dissipation
      procedure :: friction_jacobian => spur_friction_jacobian
      procedure, private :: roll
   end type spur_gear_t

contains

   !> Registry factory: a new, unconfigured spur gear pair.
   subroutine new_spur_gear(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (spur_gear_t :: el)
   end subroutine new_spur_gear

   !> Contact ratio of a standard full-depth pair (App. F `Contratio`): radii
   !> r1, r2 of the pitch circles, addendum a, pressure angle phi.
   pure real(wp) function contact_ratio(phi, r1, r2, a) result(mp)
      real(wp), intent(in) :: phi, r1, r2, a
      real(wp) :: ro1, ro2, rb1, rb2, lab
      ro1 = r1 + a; ro2 = r2 + a
      rb1 = r1*cos(phi); rb2 = r2*cos(phi)
      lab = sqrt(ro1**2 - rb1**2) + sqrt(ro2**2 - rb2**2) - (r1 + r2)*sin(phi)
      mp = lab/(pi*a*cos(phi))   ! length of action / base pitch (p_b = pi m cos phi, module m = addendum a)
   end function contact_ratio

   !> Tooth phase u = N (theta + alpha)/(2 pi) of the driver angle theta, safe
   !> for any finite theta (|theta| held at theta_cap; D-26).
   pure real(wp) function tooth_phase(theta, alpha, teeth) result(u)
      real(wp), intent(in) :: theta, alpha, teeth
      u = (max(min(theta, theta_cap), -theta_cap) + alpha)*(teeth/two_pi)
   end function tooth_phase

   !> Mesh zone at tooth phase u = N (theta + alpha)/(2 pi): number of pairs and
   !> the bounds [u_lo, u_hi] of the zone in u. u_lo = -huge marks a zone with
   !> no lower bound (truncate, u < 0). Real arithmetic throughout: any finite u
   !> is safe; beyond 2**52 the zone is narrower than u's resolution (D-26).
   pure subroutine mesh_zone(u, mp, truncate, pairs, u_lo, u_hi)
      real(wp), intent(in) :: u, mp
      logical, intent(in) :: truncate
      integer, intent(out) :: pairs
      real(wp), intent(out) :: u_lo, u_hi
      real(wp) :: m
      if (truncate .and. u < 0.0_wp) then
         ! TRUNC: n = 1 on (-1, 1); on every negative u the single-pair window is empty
         pairs = 2; u_lo = -huge(1.0_wp); u_hi = mp - 1.0_wp
         return
      end if
      m = aint(u)                 ! floor in real arithmetic (no default-integer overflow)
      if (m > u) m = m - 1.0_wp
      if (u - m <= mp - 1.0_wp) then
         pairs = 2; u_lo = m; u_hi = m + mp - 1.0_wp
      else
         pairs = 1; u_lo = m + mp - 1.0_wp; u_hi = m + 1.0_wp
      end if
   end subroutine mesh_zone

   subroutine spur_configure(self, grp, units, err)
      class(spur_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: zf
      real(wp) :: pd, modl, kw, bl, r1p, r2p, k, kdef
      logical :: geometry, has_pitch, has_module
      call accept_mesh(self, grp, self%internal, err)   ! external or internal, on an optional carrier (D-73)
      if (allocated(err)) return

      ! both asked (has records the query), so neither key is reported as unknown
      has_pitch = grp%has('diametral_pitch')
      has_module = grp%has('module')
      geometry = has_pitch .or. has_module
      if (geometry) then
         if (has_pitch .and. has_module) then
            call fatal_error(err, grp%where('module')//': error: give diametral_pitch or module, not both', err_input)
            return
         end if
         if (grp%holds('half_backlash')) then   ! the constants form's key in the geometry form (D-62)
            call fatal_error(err, grp%where('half_backlash')//": error: half_backlash belongs to TRAIN's constants "// &
                             'form (rb_driver, rb_driven, teeth, ...); this group gives module or diametral_pitch, '// &
                             "so it is in the geometry form, whose key is 'backlash': the TOTAL backlash along the "// &
                             'line of action, 2 x half_backlash (give backlash = 2 x your value, in '//units%length//')', &
                             err_input)
            return
         end if
         call grp%expect([character(len=12) :: 'teeth_driver', 'teeth_driven'])   ! a step apart (D-62)
         call grp%get_real('teeth_driver', self%teeth, err); if (allocated(err)) return
         call grp%get_real('teeth_driven', self%teeth2, err); if (allocated(err)) return
         call grp%get_real('pressure_angle', self%phi, err, default=20.0_wp); if (allocated(err)) return
         call grp%get_real('face_width', self%face, err); if (allocated(err)) return
         call grp%get_real('backlash', bl, err); if (allocated(err)) return
         if (grp%has('diametral_pitch')) then
            call grp%get_real('diametral_pitch', pd, err); if (allocated(err)) return
            call grp%require_positive('diametral_pitch', pd, err); if (allocated(err)) return
            self%pitch_module = 1.0_wp/pd/units%to_inch          ! module in deck length units
         else
            call grp%get_real('module', modl, err); if (allocated(err)) return
            call grp%require_positive('module', modl, err); if (allocated(err)) return
            self%pitch_module = modl/25.4_wp/units%to_inch
         end if
         call grp%require_positive('teeth_driver', self%teeth, err); if (allocated(err)) return
         call grp%require_positive('teeth_driven', self%teeth2, err); if (allocated(err)) return
         if (.not. self%face > 0.0_wp) then
            call fatal_error(err, grp%where('face_width')//': error: face_width must be > 0, got '//str(self%face)// &
                             ' '//units%length, err_input)
            return
         end if
         ! ranges before the geometry arithmetic (squares of radii): D-26, D-28
         call check_teeth('teeth_driver', self%teeth)
         call check_teeth('teeth_driven', self%teeth2)
         call check_magnitude(grp, 'face_width', self%face, err)
         if (grp%has('diametral_pitch')) call check_magnitude(grp, 'diametral_pitch', pd, err)
         if (grp%has('module')) call check_magnitude(grp, 'module', modl, err)
         if (allocated(err)) return
         if (.not. (self%phi > 0.0_wp .and. self%phi < 45.0_wp)) then
            call fatal_error(err, grp%where('pressure_angle')//': error: pressure_angle must be in (0, 45) degrees, got '// &
                             str(self%phi), err_input)
            return
         end if
         if (.not. bl >= 0.0_wp) then
            call fatal_error(err, grp%where('backlash')//': error: backlash must be >= 0, got '//str(bl)//' '// &
                             units%length, err_input)
            return
         end if
         self%phi = self%phi*pi/180.0_wp
         r1p = 0.5_wp*self%teeth*self%pitch_module
         r2p = 0.5_wp*self%teeth2*self%pitch_module
         self%cl%r1 = r1p*cos(self%phi)
         self%cl%r2 = r2p*cos(self%phi)
         call check_internal_radii(grp, self%internal, self%teeth, self%teeth2, 'teeth_driven', err)
         if (allocated(err)) return
         if (self%internal) then
            self%mp = internal_contact_ratio(self%phi, r1p, r2p, self%pitch_module)
            if (.not. (self%mp >= 1.0_wp .and. self%mp <= 2.0_wp)) then
               call fatal_error(err, grp%where('teeth_driven')//': error: this internal pair ('//str(self%teeth)// &
                                ' and '//str(self%teeth2)//' teeth) has contact ratio '//str(self%mp)// &
                                ' (outside [1, 2]; 0: the ring''s tip circle lies inside its base circle)', err_input)
               return
            end if
         else
            self%mp = contact_ratio(self%phi, r1p, r2p, self%pitch_module)
         end if
         self%alpha = pi*self%mp/self%teeth                      ! App. E
         self%cl%b = 0.5_wp*bl
         ! eq. (3.9): deflection W (0.39 + 1.49 cos phi) 1e-7 / F in inch-lbf (steel)
         kdef = 1.0e7_wp/(0.39_wp + 1.49_wp*cos(self%phi))*units%to_inch**2/units%to_lbf
         call grp%get_real('stiffness_per_width', kw, err, default=kdef); if (allocated(err)) return
         call grp%require_positive('stiffness_per_width', kw, err); if (allocated(err)) return
         call grp%get_real('stiffness', k, err, default=kw*self%face); if (allocated(err)) return
         self%cl%law%k = k
      else
         call configure_constants(self, grp, units, err); if (allocated(err)) return
      end if
      call grp%require_positive('stiffness', self%cl%law%k, err); if (allocated(err)) return
      if (.not. (self%mp >= 1.0_wp .and. self%mp <= 2.0_wp)) then
         call fatal_error(err, grp%where('contact_ratio')//': error: contact ratio must be in [1, 2], got '// &
                          str(self%mp), err_input)
         return
      end if
      if (.not. geometry) call check_teeth('teeth', self%teeth)
      if (allocated(err)) return
      ! the approach angle lies on the path of contact: 0 <= alpha <= 2 pi m_p / N (App. E: pi m_p / N)
      if (.not. (self%alpha >= 0.0_wp .and. self%alpha <= two_pi*self%mp/self%teeth)) then
         call fatal_error(err, grp%where('approach_angle')//': error: approach_angle must be in [0, 2 pi m_p/N] = [0, '// &
                          str(two_pi*self%mp/self%teeth)//'] rad (the angle of the path of contact), got '// &
                          str(self%alpha), err_input)
         return
      end if
      call grp%get_real('two_pair_factor', self%c2, err, default=1.8_wp); if (allocated(err)) return
      if (.not. (self%c2 >= 1.0_wp .and. self%c2 <= 2.0_wp)) then
         call fatal_error(err, grp%where('two_pair_factor')//': error: two_pair_factor must be in [1, 2], got '// &
                          str(self%c2), err_input)
         return
      end if
      call grp%get_real('mesh_phase', self%phase, err, default=0.0_wp); if (allocated(err)) return
      if (.not. (self%phase > -1.0_wp .and. self%phase < 1.0_wp)) then
         call fatal_error(err, grp%where('mesh_phase')//': error: mesh_phase (a fraction of a tooth) must be in '// &
                          '(-1, 1), got '//str(self%phase), err_input)
         return
      end if
      call grp%get_string('zone_function', zf, err, default='periodic'); if (allocated(err)) return
      select case (to_lower(zf))
      case ('periodic'); self%truncate = .false.
      case ('truncate'); self%truncate = .true.
      case default
         call fatal_error(err, grp%where('zone_function')//": error: unknown zone_function '"//zf// &
                          "'; valid: periodic, truncate", err_input)
         return
      end select
      call self%cl%law%configure(grp, units, 1.0_wp, 'yang_sun', err); if (allocated(err)) return
      call self%fric%configure(grp, units, self%cl%r1, self%cl%r2, self%teeth, self%mp, self%alpha, self%phi, &
                               self%internal, err)
      if (allocated(err)) return
      ! the mesh excitation (issue 26; D-100); the geometry form's pitch, pressure angle and face for iso6336
      call configure_mesh_excitation(self, grp, units, self%teeth2, self%mp, self%c2, self%pitch_module, self%phi, &
                                     self%face, self%internal, err)
   contains

      !> Error unless 1 <= n <= max_teeth (NaN fails).
      subroutine check_teeth(key, n)
         character(len=*), intent(in) :: key
         real(wp), intent(in) :: n
         if (allocated(err)) return
         if (.not. (n >= 1.0_wp .and. n <= max_teeth .and. n == aint(n))) call fatal_error(err, grp%where(key)// &
            ': error: '//key//' must be in [1, '//str(max_teeth)//'] and a whole number of teeth, got '//str(n), err_input)
      end subroutine check_teeth
   end subroutine spur_configure

   !> TRAIN's seven constants (stiffness, rb_driver, rb_driven, teeth, contact_ratio,
   !> approach_angle, half_backlash): the form without module or diametral_pitch.
   subroutine configure_constants(self, grp, units, err)
      class(spur_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      if (grp%holds('backlash')) then   ! the geometry form's key in the constants form (D-62)
         call fatal_error(err, grp%where('backlash')//": error: backlash (the TOTAL backlash along the line of "// &
                          'action) belongs to the geometry form (module or diametral_pitch, teeth_driver, '// &
                          "teeth_driven, face_width); this group gives neither module nor diametral_pitch, so it "// &
                          "is in TRAIN's constants form, whose key is 'half_backlash' = backlash / 2 (give "// &
                          'half_backlash = half your value, in '//units%length//')', err_input)
         return
      end if
      call grp%get_real('stiffness', self%cl%law%k, err); if (allocated(err)) return
      call grp%expect([character(len=9) :: 'rb_driver', 'rb_driven'])   ! a step apart (D-62)
      call grp%get_real('rb_driver', self%cl%r1, err); if (allocated(err)) return
      call grp%get_real('rb_driven', self%cl%r2, err); if (allocated(err)) return
      call grp%get_real('teeth', self%teeth, err); if (allocated(err)) return
      call grp%get_real('contact_ratio', self%mp, err); if (allocated(err)) return
      call grp%get_real('approach_angle', self%alpha, err); if (allocated(err)) return
      call grp%get_real('half_backlash', self%cl%b, err); if (allocated(err)) return
      call grp%require_positive('rb_driver', self%cl%r1, err); if (allocated(err)) return
      call grp%require_positive('rb_driven', self%cl%r2, err); if (allocated(err)) return
      call grp%require_positive('teeth', self%teeth, err); if (allocated(err)) return
      call check_internal_radii(grp, self%internal, self%cl%r1, self%cl%r2, 'rb_driven', err)
      if (allocated(err)) return
      if (.not. self%cl%b >= 0.0_wp) then
         call fatal_error(err, grp%where('half_backlash')//': error: half_backlash must be >= 0, got '// &
                          str(self%cl%b)//' '//units%length, err_input)
         return
      end if
   end subroutine configure_constants

   !> Set the zone from the driver angle.
   subroutine set_zone(self, thl)
      class(spur_gear_t), intent(inout) :: self
      real(wp), intent(in) :: thl
      real(wp) :: u, u_lo, u_hi
      u = tooth_phase(thl, self%alpha, self%teeth) + self%phase   ! (phase 0: u as before, bit for bit)
      call mesh_zone(u, self%mp, self%truncate, self%pairs, u_lo, u_hi)
      self%zone_m = u_hi - merge(self%mp - 1.0_wp, 1.0_wp, self%pairs == 2)   ! the newest pair's entry
      u_lo = u_lo - self%phase; u_hi = u_hi - self%phase
      ! an unbounded side has no guard value (spur_guards): no huge numbers reach the root finder
      self%lo_open = u_lo == -huge(1.0_wp)
      if (self%lo_open) then
         self%th_lo = -huge(1.0_wp)
      else
         self%th_lo = u_lo*(two_pi/self%teeth) - self%alpha
      end if
      self%th_hi = u_hi*(two_pi/self%teeth) - self%alpha
   end subroutine set_zone

   !> Stiffness factor of the current zone (1 single pair, two_pair_factor two
   !> pairs), or of the excited mesh at thl (stiffness_model, faults).
   pure real(wp) function spur_factor(self, thl) result(c)
      class(spur_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl
      real(wp) :: dc, e, de
      if (self%ex%active) then
         call self%excitation(thl, c, dc, e, de)
      else if (self%pairs == 2) then
         c = self%c2
      else
         c = 1.0_wp
      end if
   end function spur_factor

   !> Stiffness factor in a linearisation state: the zone at t_start, single
   !> pair (1) or two pairs (two_pair_factor, the stiffest).
   pure real(wp) function spur_state_factor(self, state) result(c)
      class(spur_gear_t), intent(in) :: self
      type(lin_state_t), intent(in) :: state
      select case (state%zone)
      case (lin_zone_single)
         c = merge(self%ex%cmin, 1.0_wp, self%ex%varies)
      case (lin_zone_stiffest)
         c = merge(self%ex%cmax, self%c2, self%ex%varies)
      case default
         c = self%factor(0.0_wp)
      end select
   end function spur_state_factor

   pure integer function spur_n_guards(self) result(n)
      class(spur_gear_t), intent(in) :: self
      n = 4 + self%fric%n_guards()
   end function spur_n_guards

   !> Guards 1-2: faces; 3-4: the driver angle inside its zone.
   pure subroutine spur_guards(self, thl, wl, thr, wr, g)
      class(spur_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      call em_guards(self, thl, wl, thr, wr, g(1:2))   ! the faces (with no_tension, the clip's: D-136)
      ! a zone without lower bound: a constant positive guard (never crosses), as
      ! the faces not in play; a huge value defeats CVODE's root finding (D-26)
      if (self%lo_open) then
         g(3) = 1.0_wp
      else
         g(3) = thl - self%th_lo
      end if
      g(4) = self%th_hi - thl
      if (size(g) > 4) call self%fric%guards(self%roll(thl), self%pairs, self%cl%mode, wl, wr, g(5:))   ! slides
   end subroutine spur_guards

   subroutine spur_init_mode(self, thl, wl, thr, wr)
      class(spur_gear_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: a, va
      call self%set_zone(thl)
      call self%shift(thl, wl, a, va)
      call self%cl%init(a, va, thr, wr, self%factor(thl))
      if (self%fric%n_guards() > 0) call self%fric%set_signs(self%roll(thl), self%pairs, self%cl%mode, wl, wr)
   end subroutine spur_init_mode

   subroutine spur_update_mode(self, t, thl, wl, thr, wr, fired, ev, nev)
      class(spur_gear_t), intent(inout) :: self
      real(wp), intent(in) :: t, thl, wl, thr, wr
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      integer :: old
      real(wp) :: lo, hi, a, va
      associate (u1 => t, u2 => thr)
      end associate
      nev = 0
      if (fired(3) .or. fired(4)) then
         old = self%pairs
         lo = self%th_lo; hi = self%th_hi
         call self%set_zone(thl)
         ! the new zone must lie beyond the bound that fired. A root finder may
         ! return with the angle still at (or a rounding short of) the bound, and
         ! with 'truncate' the unbounded zone of u < 0 ends at the same bound as
         ! the two-pair zone [0, m_p - 1] of u >= 0: without this the zone would
         ! not change, its guard would stay at zero (an inactive root for CVODE)
         ! and the change would be seen late (D-26).
         if (fired(4) .and. self%th_hi <= hi) then
            call self%set_zone(hi + 1.0e-12_wp*max(1.0_wp, abs(hi)))
         else if (fired(3) .and. self%th_lo >= lo) then
            call self%set_zone(lo - 1.0e-12_wp*max(1.0_wp, abs(lo)))
         end if
         if (old /= self%pairs) then
            nev = nev + 1
            ev(nev) = event_t(kind=ev_zone)
         end if
      end if
      call self%shift(thl, wl, a, va)
      call self%cl%update(va, wr, fired(1:2), ev, nev)
      if (self%fric%n_guards() == 0) return
      if (any(fired(1:4))) then   ! new pairs or face: the slides' signs from the state
         call self%fric%set_signs(self%roll(thl), self%pairs, self%cl%mode, wl, wr)
      else
         call self%fric%flip(fired(5:), ev, nev)
      end if
   end subroutine spur_update_mode

   !> TE = delta (length), force = signed mesh force, contact = face, pairs = zone (1/2).
   pure subroutine spur_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(spur_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      call em_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      pairs = self%pairs
   end subroutine spur_status

   !> Hot form (D-35): the clearance element's with the zone's factor (constant
   !> until the next zone event) and the zone window of guards 3-4.
   pure subroutine spur_hot_form(self, form)
      class(spur_gear_t), intent(in) :: self
      type(hot_form_t), intent(out) :: form
      call clearance_hot_form(self, form)
      form%guards = hg_faces_zone
      form%lo_open = self%lo_open
      form%th_lo = self%th_lo
      form%th_hi = self%th_hi
      form%exact = .true.   ! (its torques, guards, energy and status are the record's in every mode: D-167)
      ! an excited mesh (issue 26): the torques stay with `torques` while the
      ! stiffness varies or the TE moves the faces (their guards too)
      if (self%ex%varies .or. self%ex%has_te) form%kind = hf_none
      if (self%ex%has_te .or. self%cl%law%clip_guard()) form%guards = hg_none   ! (the clip: D-136)
      if (self%fric%on()) then   ! friction: the general path (D-98)
         form%kind = hf_none
         form%guards = hg_none
      end if
   end subroutine spur_hot_form

   !> Roll of the trailing pair in contact: its contact point's distance along the
   !> line of action from the start of contact, r_b1 (theta - theta_A), theta_A the
   !> driver angle at which it entered (the current zone's bounds).
   pure real(wp) function roll(self, thl) result(s)
      class(spur_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl
      real(wp) :: th_a
      th_a = self%th_hi - (two_pi/self%teeth)*merge(1.0_wp, self%mp - 1.0_wp, self%pairs == 1)
      s = self%cl%r1*(thl - th_a)
   end function roll

   !> Torques, dissipated power: the excited mesh's plus the tooth friction
   !> (trainsim_tooth_friction) on the normal force of the face in contact.
   pure subroutine spur_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
      class(spur_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, p
      real(wp) :: c, fs, a, va
      if (.not. self%fric%on()) then
         call em_torques_dissipation(self, thl, wl, thr, wr, tl, tr, p)
         return
      end if
      call self%shift(thl, wl, a, va)   ! (the mesh excitation's TE: a = thl without one)
      c = self%factor(thl)
      fs = self%cl%contact_force(c, a, va, thr, wr)
      tl = -fs*self%cl%r1
      tr = fs*self%cl%r2
      p = self%cl%dissipation(c, a, va, thr, wr)
      if (self%cl%mode*fs > 0.0_wp) call self%fric%add(self%roll(thl), self%pairs, self%cl%mode, self%cl%mode*fs, &
                                                       wl, wr, tl, tr, p)
   end subroutine spur_torques_dissipation

   !> The friction's partials (friction_mesh_t's torque_jacobian): the pairs at the roll.
   pure subroutine spur_friction_jacobian(self, thl, wl, wr, w, dw, jt)
      class(spur_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, wr, w, dw(4)
      real(wp), intent(inout) :: jt(2, 4)
      call self%fric%add_jacobian(self%roll(thl), self%pairs, self%cl%mode, w, dw, wl, wr, self%cl%r1, jt)
   end subroutine spur_friction_jacobian

   function spur_params(self) result(p)
      class(spur_gear_t), intent(in) :: self
      type(param_list_t) :: p
      ! derived: gear_ratio = omega_driver / omega_driven = r2 / r1; base pitch 2 pi r1 / N;
      ! c2 k; the driver angle of one tooth, 2 pi / N
      p = make_param_list([character(len=40) :: 'stiffness', 'rb_driver', 'rb_driven', &
                       'teeth', 'contact_ratio', 'approach_angle', &
                       'half_backlash', 'two_pair_factor', &
                       'min_approach_velocity', 'initial_contact_velocity', &
                       'gear_ratio', 'base_pitch', 'two_pair_stiffness', &
                       'mesh_period_angle'], &
                       [self%cl%law%k, self%cl%r1, self%cl%r2, self%teeth, self%mp, self%alpha, &
                        self%cl%b, self%c2, self%cl%law%v_min, &
                        self%cl%law%v_initial, guarded_ratio(self%cl%r2, self%cl%r1), guarded_ratio(two_pi*self%cl%r1, self%teeth), &
                        guarded_product(self%c2, self%cl%law%k), guarded_ratio(two_pi, self%teeth)])
      ! zone_function: the file's attribute truncate_zones (1 = 'truncate', 0 = 'periodic')
      call add_choice(p, 'truncate_zones', merge(1.0_wp, 0.0_wp, self%truncate), &
                      merge('truncate', 'periodic', self%truncate))
      if (self%internal) call add_choice(p, 'internal_mesh', 1.0_wp, 'internal')   ! (external pairs: as before)
      if (self%phase /= 0.0_wp) call append_params(p, [character(len=40) :: 'mesh_phase'], [self%phase])
      if (self%ex%active) then   ! (an unexcited mesh: as before)
         call add_choice(p, 'stiffness_model', real(self%ex%model, wp), model_name(self%ex%model))
         call append_params(p, [character(len=40) :: 'mean_stiffness_factor', 'hunting_period'], &
                            [self%ex%cmean, self%ex%hunting_period()])
      end if
      if (self%fric%on()) then   ! (without tooth friction: as before)
         call append_params(p, [character(len=40) :: 'tooth_friction', 'tooth_friction_velocity'], &
                            [self%fric%mu, self%fric%v_reg])
         call add_choice(p, 'tooth_friction_speed', merge(1.0_wp, 0.0_wp, self%fric%speed), &
                         trim(merge('speed   ', 'constant', self%fric%speed)))
      end if
      if (self%pitch_module > 0.0_wp) then
         call append_params(p, [character(len=40) :: 'teeth_driven', 'module_length', 'pressure_angle_rad', 'face_width'], &
                            [self%teeth2, self%pitch_module, self%phi, self%face])
      end if
   end function spur_params
end module trainsim_el_spur_gear
