!> Off-line calculator of a cylindrical worm pair's constants (`trainsim worm`):
!> ratio, lead angle, friction angle, the forward and backward mesh efficiencies
!> and self-locking, from the geometry and a friction coefficient, with a deck
!> fragment for the `worm_gear` element. The efficiencies are those of the
!> inclined plane with the normal pressure angle (Shigley, Mechanical
!> Engineering Design, worm gear force analysis; Niemann/Winter,
!> Maschinenelemente III; ISO/TR 14521): with tan rho' = mu / cos alpha_n,
!>   eta_f = tan gamma / tan(gamma + rho') = (cos an - mu tan g)/(cos an + mu cot g)
!>   eta_b = tan(gamma - rho') / tan gamma = (cos an - mu cot g)/(cos an + mu tan g)
!> and the pair is self-locking (the wheel cannot drive the worm) iff eta_b <= 0,
!> i.e. gamma <= rho'.
module trainsim_worm_calc
   use trainsim_kinds, only: wp, pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_key_calc, only: unset
   implicit none
   private

   public :: worm_input_t, worm_result_t, worm_calc, worm_report, worm_efficiencies

   !> A worm pair as `trainsim worm` takes it: the worm's diameter in the units'
   !> length, the (axial) module always in mm and the diametral pitch in 1/in.
   type :: worm_input_t
      type(units_t) :: units
      real(wp) :: starts = unset, teeth = unset             !< z1 (worm threads), z2 (wheel teeth)
      real(wp) :: diametral_pitch = unset, module_mm = unset
      real(wp) :: worm_diameter = unset                     !< worm pitch diameter d1
      real(wp) :: diameter_factor = unset                   !< q = d1 / m (instead of d1)
      real(wp) :: pressure_angle_deg = 20.0_wp              !< normal pressure angle alpha_n
      real(wp) :: friction = unset                          !< mu in the mesh
      real(wp) :: stiffness = unset                         !< optional: the fragment's mesh stiffness
      character(len=:), allocatable :: id
   end type worm_input_t

   type :: worm_result_t
      real(wp) :: ratio = 0.0_wp                  !< i = z2 / z1 = omega_worm / omega_wheel
      real(wp) :: module_len = 0.0_wp             !< module as a length
      real(wp) :: d1 = 0.0_wp, d2 = 0.0_wp        !< worm and wheel pitch diameters
      real(wp) :: centre_distance = 0.0_wp
      real(wp) :: lead = 0.0_wp                   !< axial advance per worm turn, pi m z1
      real(wp) :: lead_angle = 0.0_wp             !< gamma, rad
      real(wp) :: friction_angle = 0.0_wp         !< rho' = atan(mu / cos alpha_n), rad
      real(wp) :: eta_f = 1.0_wp, eta_b = 1.0_wp
      logical :: self_locking = .false.
      type(string_t), allocatable :: warnings(:)
   end type worm_result_t

contains

   !> Forward and backward efficiency at lead angle gamma, normal pressure angle
   !> alpha_n (rad) and friction coefficient mu (the module's header).
   pure subroutine worm_efficiencies(gamma, alpha_n, mu, eta_f, eta_b)
      real(wp), intent(in) :: gamma, alpha_n, mu
      real(wp), intent(out) :: eta_f, eta_b
      real(wp) :: ca, tg
      ca = cos(alpha_n)
      tg = tan(gamma)
      eta_f = (ca - mu*tg)/(ca + mu/tg)
      eta_b = (ca - mu/tg)/(ca + mu*tg)
   end subroutine worm_efficiencies

   subroutine worm_calc(inp, res, err)
      type(worm_input_t), intent(in) :: inp
      type(worm_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: m_mm, alpha_n
      allocate (res%warnings(0))
      if (inp%starts == unset .or. inp%teeth == unset .or. inp%friction == unset) then
         call fatal_error(err, 'worm: error: --starts Z1, --teeth Z2 and --friction MU are required', err_input)
         return
      end if
      if (.not. (inp%starts >= 1.0_wp .and. inp%starts <= 10.0_wp .and. inp%starts == aint(inp%starts))) then
         call fatal_error(err, 'worm: error: --starts (threads of the worm) must be a whole number in [1, 10], got '// &
                          str(inp%starts), err_input)
         return
      end if
      if (.not. (inp%teeth >= 5.0_wp .and. inp%teeth <= 1.0e4_wp .and. inp%teeth == aint(inp%teeth))) then
         call fatal_error(err, 'worm: error: --teeth (teeth of the wheel) must be a whole number in [5, 10000], got '// &
                          str(inp%teeth), err_input)
         return
      end if
      if (.not. (inp%friction >= 0.0_wp .and. inp%friction < 1.0_wp)) then
         call fatal_error(err, 'worm: error: --friction (coefficient of friction in the mesh) must be in [0, 1), got '// &
                          str(inp%friction), err_input)
         return
      end if
      if (inp%pressure_angle_deg > 0.0_wp .and. inp%pressure_angle_deg < 1.0_wp) then
         call fatal_error(err, 'worm: error: pressure angle '//str(inp%pressure_angle_deg)//' deg looks like '// &
                          'radians: give it in degrees', err_input)
         return
      else if (.not. (inp%pressure_angle_deg > 0.0_wp .and. inp%pressure_angle_deg < 45.0_wp)) then
         call fatal_error(err, 'worm: error: normal pressure angle must be in (0, 45) degrees, got '// &
                          str(inp%pressure_angle_deg), err_input)
         return
      end if
      call worm_pitch(inp, m_mm, err); if (allocated(err)) return
      res%module_len = m_mm/25.4_wp/inp%units%to_inch
      if ((inp%worm_diameter == unset) .eqv. (inp%diameter_factor == unset)) then
         call fatal_error(err, 'worm: error: give the worm''s pitch diameter (--worm-diameter D1) or its diameter '// &
                          'factor (--diameter-factor Q = D1 / module), exactly one', err_input)
         return
      end if
      if (inp%worm_diameter /= unset) then
         res%d1 = inp%worm_diameter
      else
         res%d1 = inp%diameter_factor*res%module_len
      end if
      if (.not. (res%d1 >= 2.0_wp*res%module_len .and. res%d1 <= 100.0_wp*res%module_len)) then
         call fatal_error(err, 'worm: error: worm pitch diameter '//str(res%d1, 4)//' '//inp%units%length// &
                          ' is '//str(res%d1/res%module_len, 3)//' modules: outside [2, 100] (is it in '// &
                          inp%units%length//'?)', err_input)
         return
      end if
      res%ratio = inp%teeth/inp%starts
      res%d2 = inp%teeth*res%module_len
      res%centre_distance = 0.5_wp*(res%d1 + res%d2)
      res%lead = pi*res%module_len*inp%starts
      res%lead_angle = atan(inp%starts*res%module_len/res%d1)   ! tan gamma = z1 m / d1
      alpha_n = inp%pressure_angle_deg*pi/180.0_wp
      res%friction_angle = atan(inp%friction/cos(alpha_n))
      call worm_efficiencies(res%lead_angle, alpha_n, inp%friction, res%eta_f, res%eta_b)
      res%self_locking = res%eta_b <= 0.0_wp
      if (res%d1/res%module_len < 6.0_wp .or. res%d1/res%module_len > 25.0_wp) &
         res%warnings = [res%warnings, string_t('worm: warning: diameter factor q = '// &
                         str(res%d1/res%module_len, 3)//' is unusual (DIN 3976: about 6 to 20)')]
      if (inp%friction > 0.0_wp .and. inp%friction < 0.01_wp) &
         res%warnings = [res%warnings, string_t('worm: warning: friction '//str(inp%friction)// &
                         ' is below any lubricated worm mesh (about 0.02 to 0.1)')]
   end subroutine worm_calc

   !> Exactly one of diametral pitch (1/in) and module (mm); the module in mm.
   subroutine worm_pitch(inp, m_mm, err)
      type(worm_input_t), intent(in) :: inp
      real(wp), intent(out) :: m_mm
      type(error_t), allocatable, intent(out) :: err
      m_mm = 0.0_wp
      if ((inp%diametral_pitch == unset) .eqv. (inp%module_mm == unset)) then
         call fatal_error(err, 'worm: error: give the diametral pitch (--diametral-pitch, 1/in) or the module '// &
                          '(--module, mm), exactly one', err_input)
      else if (inp%diametral_pitch /= unset) then
         if (.not. (inp%diametral_pitch >= 0.25_wp .and. inp%diametral_pitch <= 200.0_wp)) then
            call fatal_error(err, 'worm: error: diametral pitch must be in [0.25, 200] 1/in, got '// &
                             str(inp%diametral_pitch), err_input)
         else
            m_mm = 25.4_wp/inp%diametral_pitch
         end if
      else
         if (.not. (inp%module_mm >= 0.05_wp .and. inp%module_mm <= 100.0_wp)) then
            call fatal_error(err, 'worm: error: module must be in [0.05, 100] mm, got '//str(inp%module_mm), err_input)
         else
            m_mm = inp%module_mm
         end if
      end if
   end subroutine worm_pitch

   subroutine worm_report(inp, res, unit)
      type(worm_input_t), intent(in) :: inp
      type(worm_result_t), intent(in) :: res
      integer, intent(in) :: unit
      character(len=:), allocatable :: l, id
      real(wp), parameter :: deg = 180.0_wp/pi
      l = inp%units%length
      id = 'worm'
      if (allocated(inp%id)) id = inp%id
      write (unit, '(a)') 'worm pair ('//inp%units%name//'): '//str(inp%starts)//' start(s), '//str(inp%teeth)// &
         ' wheel teeth, module '//str(res%module_len, 5)//' '//l//', normal pressure angle '// &
         str(inp%pressure_angle_deg)//' deg, mu '//str(inp%friction)
      write (unit, '(a)') '  ratio i = z2/z1            '//str(res%ratio)
      write (unit, '(a)') '  worm pitch diameter d1     '//str(res%d1, 5)//' '//l//'  (q = '// &
         str(res%d1/res%module_len, 4)//')'
      write (unit, '(a)') '  wheel pitch diameter d2    '//str(res%d2, 5)//' '//l
      write (unit, '(a)') '  centre distance            '//str(res%centre_distance, 5)//' '//l
      write (unit, '(a)') '  lead                       '//str(res%lead, 5)//' '//l
      write (unit, '(a)') '  lead angle gamma           '//str(res%lead_angle*deg, 5)//' deg  (tan gamma = z1 m/d1)'
      write (unit, '(a)') '  friction angle rho''        '//str(res%friction_angle*deg, 5)// &
         ' deg  (tan rho'' = mu/cos alpha_n)'
      write (unit, '(a)') '  forward efficiency eta_f   '//str(res%eta_f, 5)//'  (worm drives)'
      write (unit, '(a)') '  backward efficiency eta_b  '//str(res%eta_b, 5)//'  (wheel drives)'
      if (res%self_locking) then
         write (unit, '(a)') '  self-locking: yes (eta_b <= 0, gamma <= rho''): the wheel cannot drive the worm'
      else
         write (unit, '(a)') '  self-locking: no (eta_b > 0): the wheel back-drives the worm'
      end if
      write (unit, '(a)') ''
      write (unit, '(a)') '! deck fragment (trainsim worm): left node the worm, right node the wheel'
      if (inp%units%name == 'si') write (unit, '(a)') "! needs &run units = 'si'"
      write (unit, '(a)') "&element id = '"//id//"', type = 'worm_gear', ratio = "//str(res%ratio)// &
         ', wheel_radius = '//str(0.5_wp*res%d2)//','
      write (unit, '(a)') '   lead_angle = '//str(res%lead_angle*deg)//', pressure_angle = '// &
         str(inp%pressure_angle_deg)//', friction_coefficient = '//str(inp%friction)//','
      if (inp%stiffness /= unset) then
         write (unit, '(a)') '   stiffness = '//str(inp%stiffness)//', contact_damping = 0.0 /   ! the linear law; '// &
            'its damping (force*s/length) as known'
      else
         write (unit, '(a)') '   stiffness = K /   ! K: the mesh stiffness along the wheel''s pitch circle ('// &
            inp%units%force//'/'//l//'), not from the geometry'
      end if
   end subroutine worm_report
end module trainsim_worm_calc
