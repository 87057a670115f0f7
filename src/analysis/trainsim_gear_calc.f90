!> Off-line calculators of element constants (§8.3, recommendation 5): a spur
!> gear pair from its geometry (App. E; eqs. 3.9, 3.12), and (re-exported from
!> trainsim_key_calc) a keyed joint from its size and fit (Ch. IV, eqs.
!> 4.35-4.37). `trainsim gear` and `trainsim key` print the results and a deck
!> fragment ready to paste.
!>
!> Inputs are checked for plausibility: a value that is most likely a unit slip
!> (a pressure angle in radians, a module in metres, a weight density given as a
!> mass density) is an error naming the slip; an unusual but possible value is a
!> warning kept in the result.
module trainsim_gear_calc
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_key_calc, only: key_input_t, key_result_t, key_calc, key_report, key_max_points, unset
   use trainsim_el_spur_gear, only: contact_ratio
   use trainsim_limits, only: param_min, param_max
   implicit none
   private

   public :: gear_input_t, gear_result_t, gear_calc, gear_report
   public :: key_input_t, key_result_t, key_calc, key_report
   public :: steel_mass_density_ips, steel_youngs_ips, unset, key_max_points

   !> Steel as App. E.1 takes it: J = 1.148e-3 r_p^4 F (lbf s^2 in), i.e.
   !> pi rho_m / 2 = 1.148e-3, rho_m = 7.3085e-4 lbf s^2/in^4 (7811 kg/m^3;
   !> App. E's own 0.282 lb/in^3 / 386 in/s^2 gives 1.1476e-3, printed 1.148e-3).
   real(wp), parameter :: steel_mass_density_ips = 2.0_wp*1.148e-3_wp/pi
   !> Young's modulus of steel behind eq. (3.9), psi.
   real(wp), parameter :: steel_youngs_ips = 30.0e6_wp
   !> Standard gravity, in/s^2 (weight density / g = mass density).
   real(wp), parameter :: g_ips = 386.088_wp

   !> A spur gear pair as `trainsim gear` takes it. Lengths, E and density in the
   !> units of `units`; diametral pitch always 1/in and module always mm (as the
   !> spur_gear element's geometry form).
   type :: gear_input_t
      type(units_t) :: units
      real(wp) :: teeth1 = unset, teeth2 = unset
      real(wp) :: diametral_pitch = unset, module_mm = unset
      real(wp) :: pressure_angle_deg = 20.0_wp
      real(wp) :: face_width = unset
      real(wp) :: backlash = 0.0_wp            !< total, along the line of action
      real(wp) :: youngs_modulus = unset       !< default: steel, 30e6 psi
      real(wp) :: density = unset              !< mass density; default App. E's steel
      real(wp) :: stiffness_per_width = unset  !< default eq. (3.9) scaled by E/E_steel
      real(wp) :: stiffness = unset            !< default stiffness_per_width * face_width
      real(wp) :: target_frequency = unset     !< Hz: the inertia that puts a gear there
      real(wp) :: approach_velocity = unset    !< length/s: Yang-Sun D at this V_i
      character(len=:), allocatable :: id      !< element id in the deck fragment
   end type gear_input_t

   !> Everything `trainsim gear` derives (units of the input's unit system).
   type :: gear_result_t
      real(wp) :: module_len = 0.0_wp          !< module (= addendum) as a length
      real(wp) :: rp1 = 0.0_wp, rp2 = 0.0_wp   !< pitch radii
      real(wp) :: rb1 = 0.0_wp, rb2 = 0.0_wp   !< base radii
      real(wp) :: ro1 = 0.0_wp, ro2 = 0.0_wp   !< outside radii
      real(wp) :: addendum = 0.0_wp
      real(wp) :: length_of_action = 0.0_wp    !< z, App. E
      real(wp) :: base_pitch = 0.0_wp          !< p_b = pi m cos(phi)
      real(wp) :: contact_ratio = 0.0_wp       !< m_p = z / p_b
      real(wp) :: approach_angle = 0.0_wp      !< alpha = pi m_p / N1, rad
      real(wp) :: gear_ratio = 0.0_wp          !< N2 / N1
      real(wp) :: phi = 0.0_wp                 !< pressure angle, rad
      real(wp) :: density = 0.0_wp, youngs_modulus = 0.0_wp
      real(wp) :: j1 = 0.0_wp, j2 = 0.0_wp     !< solid disks of the pitch circles (App. E.1)
      real(wp) :: stiffness_per_width = 0.0_wp, stiffness = 0.0_wp
      real(wp) :: half_backlash = 0.0_wp
      !> Inertias that put the driver / the driven gear at target_frequency on the
      !> mesh spring, the other held: J = k R_b^2 / (2 pi f)^2 (App. E.3). 0 if no target.
      real(wp) :: j1_target = 0.0_wp, j2_target = 0.0_wp
      !> Goldsmith restitution (App. E.2) and D of eq. (3.12) at approach_velocity (0 if none).
      real(wp) :: restitution = 0.0_wp, damping_d = 0.0_wp
      !> Natural frequencies of each gear alone on the mesh spring, the other held (Hz).
      real(wp) :: f1 = 0.0_wp, f2 = 0.0_wp
      type(string_t), allocatable :: warnings(:)
   end type gear_result_t

contains

   ! ----------------------------------------------------------------- gear pair

   !> Derive the constants of a spur gear pair (App. E, eqs. 3.9, 3.12).
   subroutine gear_calc(inp, res, err)
      type(gear_input_t), intent(in) :: inp
      type(gear_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: m_mm, rho_si, e_ref, v_ips, kw_steel

      allocate (res%warnings(0))
      call check_teeth('teeth (driver)', inp%teeth1, err); if (allocated(err)) return
      call check_teeth('teeth (driven)', inp%teeth2, err); if (allocated(err)) return
      call check_pitch(inp, m_mm, err); if (allocated(err)) return
      call check_pressure_angle(inp%pressure_angle_deg, res, err); if (allocated(err)) return
      if (inp%face_width == unset) then
         call fatal_error(err, 'gear: error: the face width is required (--face-width)', err_input)
         return
      end if
      call require_positive('face width', inp%face_width, err); if (allocated(err)) return
      if (.not. inp%backlash >= 0.0_wp) then
         call fatal_error(err, 'gear: error: backlash must be >= 0, got '//str(inp%backlash), err_input)
         return
      end if

      ! App. E.3
      res%phi = inp%pressure_angle_deg*pi/180.0_wp
      res%module_len = m_mm/25.4_wp/inp%units%to_inch
      res%addendum = res%module_len
      res%rp1 = 0.5_wp*inp%teeth1*res%module_len
      res%rp2 = 0.5_wp*inp%teeth2*res%module_len
      res%ro1 = res%rp1 + res%addendum
      res%ro2 = res%rp2 + res%addendum
      res%rb1 = res%rp1*cos(res%phi)
      res%rb2 = res%rp2*cos(res%phi)
      call check_size(inp, res, m_mm, err); if (allocated(err)) return
      res%length_of_action = sqrt(res%ro1**2 - res%rb1**2) + sqrt(res%ro2**2 - res%rb2**2) - &
                             (res%rp1 + res%rp2)*sin(res%phi)
      res%base_pitch = pi*res%module_len*cos(res%phi)
      res%contact_ratio = contact_ratio(res%phi, res%rp1, res%rp2, res%addendum)   ! App. F Contratio
      res%approach_angle = pi*res%contact_ratio/inp%teeth1                          ! App. E
      res%gear_ratio = inp%teeth2/inp%teeth1
      res%half_backlash = 0.5_wp*inp%backlash
      if (.not. (res%contact_ratio >= 1.0_wp .and. res%contact_ratio <= 2.0_wp)) then
         call fatal_error(err, 'gear: error: the contact ratio is '//str(res%contact_ratio, 5)// &
                          '; trainsim models 1 <= m_p <= 2 (standard full-depth teeth: more teeth or a larger '// &
                          'pressure angle raise it)', err_input)
         return
      end if
      if (inp%backlash > 0.5_wp*res%base_pitch) then
         call fatal_error(err, 'gear: error: backlash '//str(inp%backlash, 4)//' '//inp%units%length// &
                          ' is more than half the base pitch '//str(res%base_pitch, 5)//' '//inp%units%length// &
                          ' (the teeth would not mesh): is it in the wrong length unit?', err_input)
         return
      end if

      ! material
      e_ref = steel_youngs_ips*inp%units%to_inch**2/inp%units%to_lbf
      res%youngs_modulus = e_ref
      if (inp%youngs_modulus /= unset) res%youngs_modulus = inp%youngs_modulus
      call check_youngs(inp, res, err); if (allocated(err)) return
      res%density = steel_mass_density_ips*inp%units%to_inch**4/inp%units%to_lbf
      if (inp%density /= unset) res%density = inp%density
      rho_si = res%density*inp%units%to_lbf/inp%units%to_inch**4*lbf_s2_in4_to_kg_m3()
      call check_density(inp, res, rho_si, err); if (allocated(err)) return

      ! App. E.1: each gear a solid disk of its pitch circle, J = pi rho r_p^4 F / 2
      res%j1 = 0.5_wp*pi*res%density*res%rp1**4*inp%face_width
      res%j2 = 0.5_wp*pi*res%density*res%rp2**4*inp%face_width

      ! eq. (3.9): deflection W (0.39 + 1.49 cos phi) 1e-7 / F for steel (lbf, in);
      ! eq. (3.8) is proportional to 1/E, so another material scales it by E/E_steel
      kw_steel = 1.0e7_wp/(0.39_wp + 1.49_wp*cos(res%phi))*inp%units%to_inch**2/inp%units%to_lbf
      res%stiffness_per_width = kw_steel*res%youngs_modulus/e_ref
      if (inp%stiffness_per_width /= unset) then
         call require_positive('stiffness per width', inp%stiffness_per_width, err); if (allocated(err)) return
         res%stiffness_per_width = inp%stiffness_per_width
         if (inp%stiffness_per_width > 20.0_wp*kw_steel .or. inp%stiffness_per_width < 0.01_wp*kw_steel) &
            call warn(res, 'stiffness per width '//str(inp%stiffness_per_width, 4)//' is '// &
                      str(inp%stiffness_per_width/kw_steel, 3)//' x eq. (3.9) for steel ('//str(kw_steel, 4)// &
                      ' '//inp%units%force//'/'//inp%units%length//' per '//inp%units%length//'): check its unit')
      end if
      res%stiffness = res%stiffness_per_width*inp%face_width
      if (inp%stiffness /= unset) then
         call require_positive('stiffness', inp%stiffness, err); if (allocated(err)) return
         res%stiffness = inp%stiffness
      end if
      res%f1 = sqrt(res%stiffness*res%rb1**2/res%j1)/two_pi
      res%f2 = sqrt(res%stiffness*res%rb2**2/res%j2)/two_pi

      ! App. E.3: 350 = (1/2 pi) sqrt(k R_b2^2 / J2)
      if (inp%target_frequency /= unset) then
         call require_positive('target frequency', inp%target_frequency, err); if (allocated(err)) return
         res%j1_target = res%stiffness*res%rb1**2/(two_pi*inp%target_frequency)**2
         res%j2_target = res%stiffness*res%rb2**2/(two_pi*inp%target_frequency)**2
      end if

      ! App. E.2 and eq. (3.12)
      if (inp%approach_velocity /= unset) then
         call require_positive('approach velocity', inp%approach_velocity, err); if (allocated(err)) return
         v_ips = inp%approach_velocity*inp%units%to_inch
         res%restitution = min(max(1.0_wp - 0.019_wp*v_ips**0.48_wp, 0.0_wp), 1.0_wp)
         res%damping_d = 6.0_wp*(1.0_wp - res%restitution)*res%stiffness/ &
                         (((2.0_wp*res%restitution - 1.0_wp)**2 + 3.0_wp)*inp%approach_velocity)
         if (v_ips > 100.0_wp) call warn(res, 'approach velocity '//str(inp%approach_velocity, 4)//' '// &
                                         inp%units%length//'/s is above 100 in/s, beyond the impacts '// &
                                         'Goldsmith''s fit was made for: check its unit')
      end if
   end subroutine gear_calc

   !> 1 lbf s^2/in^4 in kg/m^3.
   pure real(wp) function lbf_s2_in4_to_kg_m3() result(f)
      f = 4.4482216152605_wp/0.0254_wp**4
   end function lbf_s2_in4_to_kg_m3

   subroutine check_teeth(what, n, err)
      character(len=*), intent(in) :: what
      real(wp), intent(in) :: n
      type(error_t), allocatable, intent(out) :: err
      if (n == unset) then
         call fatal_error(err, 'gear: error: '//what//' is required (--teeth N1 N2)', err_input)
      else if (.not. (n >= 5.0_wp .and. n <= 1.0e4_wp)) then
         call fatal_error(err, 'gear: error: '//what//' = '//str(n)//'; expected 5 to 10000 teeth', err_input)
      else if (n /= aint(n)) then
         call fatal_error(err, 'gear: error: '//what//' = '//str(n)//' is not a whole number of teeth', err_input)
      end if
   end subroutine check_teeth

   subroutine require_positive(what, x, err)
      character(len=*), intent(in) :: what
      real(wp), intent(in) :: x
      type(error_t), allocatable, intent(out) :: err
      if (.not. (x >= param_min .and. x <= param_max)) &
         call fatal_error(err, 'gear: error: '//what//' must be > 0, in ['//str(param_min)//', '//str(param_max)// &
                          '] (the range a deck accepts), got '//str(x), err_input)
   end subroutine require_positive

   !> Exactly one of diametral pitch (1/in) and module (mm); returns the module in mm.
   subroutine check_pitch(inp, m_mm, err)
      type(gear_input_t), intent(in) :: inp
      real(wp), intent(out) :: m_mm
      type(error_t), allocatable, intent(out) :: err
      m_mm = 0.0_wp
      if ((inp%diametral_pitch == unset) .eqv. (inp%module_mm == unset)) then
         call fatal_error(err, 'gear: error: give the diametral pitch (--diametral-pitch, teeth per inch of '// &
                          'pitch diameter) or the module (--module, mm), exactly one', err_input)
         return
      end if
      if (inp%diametral_pitch /= unset) then
         call require_positive('diametral pitch', inp%diametral_pitch, err); if (allocated(err)) return
         m_mm = 25.4_wp/inp%diametral_pitch
         if (inp%diametral_pitch > 200.0_wp) then
            call fatal_error(err, 'gear: error: diametral pitch '//str(inp%diametral_pitch)//' /in is a module of '// &
                             str(m_mm, 3)//' mm: finer than any gear. The diametral pitch is in teeth per inch of '// &
                             'pitch diameter (a pitch per metre or per mm? a module? use --module for mm)', err_input)
         else if (inp%diametral_pitch < 0.25_wp) then
            call fatal_error(err, 'gear: error: diametral pitch '//str(inp%diametral_pitch)//' /in is a module of '// &
                             str(m_mm, 3)//' mm: coarser than any gear. Was the circular pitch or a pitch diameter '// &
                             'given? (diametral pitch = teeth / pitch diameter in inches)', err_input)
         end if
      else
         call require_positive('module', inp%module_mm, err); if (allocated(err)) return
         m_mm = inp%module_mm
         if (m_mm < 0.05_wp) then
            call fatal_error(err, 'gear: error: module '//str(m_mm)//' mm is finer than any gear: the module is in '// &
                             'mm (was it given in metres? then use '//str(m_mm*1000.0_wp)//')', err_input)
         else if (m_mm > 100.0_wp) then
            call fatal_error(err, 'gear: error: module '//str(m_mm)//' mm is coarser than any gear: the module is in '// &
                             'mm (was it given in micrometres, or is it a pitch diameter?)', err_input)
         end if
      end if
   end subroutine check_pitch

   !> Degrees, in (0, 45); below 1 it is taken for radians (an error that says so).
   subroutine check_pressure_angle(deg, res, err)
      real(wp), intent(in) :: deg
      type(gear_result_t), intent(inout) :: res
      type(error_t), allocatable, intent(out) :: err
      if (deg > 0.0_wp .and. deg < 1.0_wp) then
         call fatal_error(err, 'gear: error: pressure angle '//str(deg)//' deg looks like radians ('// &
                          str(deg*180.0_wp/pi, 4)//' deg): give it in degrees', err_input)
      else if (.not. (deg > 0.0_wp .and. deg < 45.0_wp)) then
         call fatal_error(err, 'gear: error: pressure angle must be in (0, 45) degrees, got '//str(deg), err_input)
      else if (deg < 10.0_wp .or. deg > 35.0_wp) then
         call warn(res, 'pressure angle '//str(deg)//' deg is unusual (standard: 14.5, 20, 25)')
      end if
   end subroutine check_pressure_angle

   !> Radii and face width a physical gear can have (no micrometre base circles).
   subroutine check_size(inp, res, m_mm, err)
      type(gear_input_t), intent(in) :: inp
      type(gear_result_t), intent(inout) :: res
      real(wp), intent(in) :: m_mm
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: to_m, rb_m, nmin
      to_m = inp%units%to_inch*0.0254_wp
      rb_m = min(res%rb1, res%rb2)*to_m
      if (rb_m < 1.0e-3_wp .or. max(res%rb1, res%rb2)*to_m > 20.0_wp) then
         call fatal_error(err, 'gear: error: base radius '//str(min(res%rb1, res%rb2), 4)//' '//inp%units%length// &
                          ' ('//str(rb_m, 3)//' m) from a module of '//str(m_mm, 4)//' mm: implausible; the module '// &
                          'is in mm and the diametral pitch in 1/in, whatever the unit system', err_input)
         return
      end if
      if (inp%face_width*to_m > 5.0_wp .or. inp%face_width > 20.0_wp*res%rp1 .or. &
          inp%face_width < 0.002_wp*res%rp1) then
         call fatal_error(err, 'gear: error: face width '//str(inp%face_width)//' '//inp%units%length//' with a '// &
                          'pitch radius of '//str(res%rp1, 4)//' '//inp%units%length//': is the face width in the '// &
                          "unit system's length ("//inp%units%length//')?', err_input)
         return
      end if
      if (inp%face_width > 3.0_wp*2.0_wp*res%rp1) call warn(res, 'face width '//str(inp%face_width)// &
         ' is more than 3 x the driver''s pitch diameter: check its unit')
      nmin = 2.0_wp/sin(inp%pressure_angle_deg*pi/180.0_wp)**2
      if (min(inp%teeth1, inp%teeth2) < nmin) call warn(res, 'fewer than '//str(nmin, 3)// &
         ' teeth: standard full-depth teeth undercut at this pressure angle (the contact ratio is then optimistic)')
   end subroutine check_size

   subroutine check_youngs(inp, res, err)
      type(gear_input_t), intent(in) :: inp
      type(gear_result_t), intent(inout) :: res
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: e_pa
      call require_positive('Young''s modulus', res%youngs_modulus, err); if (allocated(err)) return
      e_pa = res%youngs_modulus*inp%units%to_lbf/inp%units%to_inch**2*(4.4482216152605_wp/0.0254_wp**2)
      if (e_pa < 1.0e8_wp .or. e_pa > 1.0e12_wp) then
         call fatal_error(err, "gear: error: Young's modulus "//str(res%youngs_modulus, 4)//' '//inp%units%force// &
                          '/'//inp%units%length//'^2 ('//str(e_pa, 3)//' Pa): implausible; '// &
                          trim(merge('in SI it is in Pa (GPa x 1e9)        ', &
                                     'in in-lbf-s it is in psi (Mpsi x 1e6)', inp%units%name == 'si')), err_input)
      end if
   end subroutine check_youngs

   subroutine check_density(inp, res, rho_si, err)
      type(gear_input_t), intent(in) :: inp
      type(gear_result_t), intent(inout) :: res
      real(wp), intent(in) :: rho_si
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: unit
      call require_positive('density', res%density, err); if (allocated(err)) return
      if (rho_si >= 300.0_wp .and. rho_si <= 25000.0_wp) return
      unit = inp%units%force//'*s^2/'//inp%units%length//'^4'
      if (inp%units%name /= 'si' .and. res%density > 0.01_wp .and. res%density < 1.0_wp) then
         call fatal_error(err, 'gear: error: density '//str(res%density)//' '//unit//' looks like a weight density '// &
                          'in lb/in^3: the mass density is that / g, '//str(res%density/g_ips, 4)//' '//unit, err_input)
      else if (inp%units%name == 'si' .and. res%density > 0.3_wp .and. res%density < 25.0_wp) then
         call fatal_error(err, 'gear: error: density '//str(res%density)//' kg/m^3 looks like g/cm^3: '// &
                          'use '//str(res%density*1000.0_wp)//' kg/m^3', err_input)
      else
         call fatal_error(err, 'gear: error: density '//str(res%density)//' '//unit//' ('//str(rho_si, 3)// &
                          ' kg/m^3): no solid is that light or heavy; the density is the mass density in '//unit, &
                          err_input)
      end if
   end subroutine check_density

   subroutine warn(res, text)
      type(gear_result_t), intent(inout) :: res
      character(len=*), intent(in) :: text
      res%warnings = [res%warnings, string_t('gear: warning: '//text)]
   end subroutine warn

   !> Print the derived constants and a deck fragment (TRAIN's seven constants).
   subroutine gear_report(inp, res, unit)
      type(gear_input_t), intent(in) :: inp
      type(gear_result_t), intent(in) :: res
      integer, intent(in) :: unit
      character(len=:), allocatable :: l, id, mass_unit, n1, n2
      l = inp%units%length
      id = 'mesh'
      n1 = 'gear1'; n2 = 'gear2'
      if (allocated(inp%id)) then   ! nodes after the id, so several stages paste into one deck (D-62)
         id = inp%id
         n1 = id//'_driver'; n2 = id//'_driven'
      end if
      mass_unit = inp%units%force//'*s^2/'//l//'^4'
      write (unit, '(a)') 'spur gear pair ('//inp%units%name//'; App. E, eqs. 3.9, 3.12)'
      write (unit, '(a)') '  teeth                 '//str(inp%teeth1)//' : '//str(inp%teeth2)// &
         '   gear ratio N2/N1 = '//fx(res%gear_ratio, 5)
      write (unit, '(a)') '  module                '//fx(res%module_len*inp%units%to_inch*25.4_wp, 5)//' mm = 1/'// &
         fx(1.0_wp/(res%module_len*inp%units%to_inch), 5)//' in (addendum '//fx(res%addendum, 5)//' '//l//')'
      write (unit, '(a)') '  pressure angle        '//fx(inp%pressure_angle_deg, 4)//' deg = '//fx(res%phi, 6)//' rad'
      write (unit, '(a)') '  pitch radius   r_p    '//fx(res%rp1, 5)//'  '//fx(res%rp2, 5)//' '//l
      write (unit, '(a)') '  outside radius R_o    '//fx(res%ro1, 5)//'  '//fx(res%ro2, 5)//' '//l
      write (unit, '(a)') '  base radius    R_b    '//fx(res%rb1, 5)//'  '//fx(res%rb2, 5)//' '//l
      write (unit, '(a)') '  length of action z    '//fx(res%length_of_action, 5)//' '//l
      write (unit, '(a)') '  base pitch     p_b    '//fx(res%base_pitch, 5)//' '//l
      write (unit, '(a)') '  contact ratio  m_p    '//fx(res%contact_ratio, 4)//'   (z / p_b)'
      write (unit, '(a)') '  approach angle alpha  '//fx(res%approach_angle, 4)//' rad   (pi m_p / N1)'
      write (unit, '(a)') '  half backlash  b      '//str(res%half_backlash, 4)//' '//l
      write (unit, '(a)') '  material              E = '//str(res%youngs_modulus, 4)//' '//inp%units%force//'/'//l// &
         '^2, density = '//str(res%density, 4)//' '//mass_unit
      write (unit, '(a)') '  inertia (pitch disk)  J1 = '//str(res%j1, 4)//'  J2 = '//str(res%j2, 4)//' '// &
         inp%units%inertia//'   (App. E.1: pi rho r_p^4 F / 2)'
      write (unit, '(a)') '  mesh stiffness        k = '//str(res%stiffness, 4)//' '//inp%units%force//'/'//l// &
         '   ('//str(res%stiffness_per_width, 4)//' per '//l//' of face; eq. 3.9 unless given)'
      write (unit, '(a)') '  one gear on the mesh  f1 = '//fx(res%f1, 1)//' Hz  f2 = '//fx(res%f2, 1)// &
         ' Hz   (the other held; sqrt(k R_b^2/J)/2pi)'
      if (inp%target_frequency /= unset) then
         write (unit, '(a)') '  for '//fx(inp%target_frequency, 1)//' Hz:          J1 = '//str(res%j1_target, 5)// &
            '  J2 = '//str(res%j2_target, 5)//' '//inp%units%inertia//'   (k R_b^2/(2 pi f)^2, App. E.3)'
      end if
      if (inp%approach_velocity /= unset) then
         write (unit, '(a)') '  impact at V_i = '//str(inp%approach_velocity, 4)//' '//l//'/s:  e = '// &
            fx(res%restitution, 5)//' (Goldsmith, App. E.2)  D = '//str(res%damping_d, 4)//' '// &
            inp%units%force//'*s/'//l//'^2   (eq. 3.12)'
      end if
      write (unit, '(a)') ''
      write (unit, '(a)') '! deck fragment (trainsim gear): nodes and mesh, TRAIN''s seven constants'
      if (inp%units%name == 'si') write (unit, '(a)') "! needs &run units = 'si'"
      write (unit, '(a)') "&node id = '"//n1//"', type = 'inertia', inertia = "//str(res%j1, 6)//' /'
      write (unit, '(a)') "&element id = '"//id//"', type = 'spur_gear', stiffness = "//str(res%stiffness, 6)// &
         ', rb_driver = '//str(res%rb1, 7)//', rb_driven = '//str(res%rb2, 7)//','
      write (unit, '(a)') '   teeth = '//str(inp%teeth1)//', contact_ratio = '//str(res%contact_ratio, 7)// &
         ', approach_angle = '//str(res%approach_angle, 7)//', half_backlash = '//str(res%half_backlash, 6)//','
      write (unit, '(a)') "   left = '"//n1//"', right = '"//n2//"' /"
      if (inp%target_frequency /= unset) then
         write (unit, '(a)') "&node id = '"//n2//"', type = 'inertia', inertia = "//str(res%j2_target, 6)// &
            ' /   ! driven gear at '//fx(inp%target_frequency, 1)//' Hz'
      else
         write (unit, '(a)') "&node id = '"//n2//"', type = 'inertia', inertia = "//str(res%j2, 6)//' /'
      end if
   end subroutine gear_report

   !> Fixed notation with `d` decimals.
   function fx(x, d) result(s)
      real(wp), intent(in) :: x
      integer, intent(in) :: d
      character(len=:), allocatable :: s
      character(len=40) :: buf
      character(len=12) :: fmt
      if (.not. abs(x) < 1.0e15_wp) then   ! f0.d would not fit the buffer
         s = str(x, 6)
         return
      end if
      write (fmt, '(a,i0,a)') '(f0.', d, ')'
      write (buf, fmt) x
      s = trim(adjustl(buf))
      if (s(1:1) == '.') s = '0'//s
   end function fx

   ! ---------------------------------------------------------------- keyed joint

end module trainsim_gear_calc
