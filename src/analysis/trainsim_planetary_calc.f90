!> Off-line calculator of a simple planetary stage (`trainsim planetary`): from the
!> tooth counts, the ratio for each choice of the held member (the Willis equation
!> (w_s - w_c)/(w_r - w_c) = -z_r/z_s), the planets' speed on the carrier, the assembly
!> condition of N equally spaced planets ((z_s + z_r)/N whole) and the planets' room
!> beside each other, the mesh phases of each planet (Parker and Lin 2004; the same
!> rule the &planetary group writes into its meshes) and a deck fragment.
module trainsim_planetary_calc
   use trainsim_kinds, only: wp, pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_key_calc, only: unset
   use trainsim_planetary_deck, only: planet_phases, assembles, max_planets
   implicit none
   private

   public :: planetary_input_t, planetary_result_t, planetary_calc, planetary_report, willis_ratios

   type :: planetary_input_t
      type(units_t) :: units
      real(wp) :: zs = unset, zp = unset, zr = unset   !< teeth of sun, planet, ring (ring: z_s + 2 z_p if not given)
      real(wp) :: planets = unset
      real(wp) :: diametral_pitch = unset, module_mm = unset
      real(wp) :: pressure_angle_deg = 20.0_wp
      character(len=:), allocatable :: id
   end type planetary_input_t

   type :: planetary_result_t
      real(wp) :: zr = 0.0_wp
      integer :: n = 0
      !> input / output speed ratio: ring held (sun -> carrier), sun held (ring -> carrier),
      !> carrier held (sun -> ring)
      real(wp) :: ratio(3) = 0.0_wp
      !> planet speed relative to the carrier per unit input speed, same order
      real(wp) :: planet(3) = 0.0_wp
      real(wp) :: module_len = 0.0_wp                  !< module as a length (0: not given)
      real(wp), allocatable :: psi(:), ps(:), pr(:)    !< planet angles (deg), sun and ring mesh phases
      type(string_t), allocatable :: warnings(:)
   end type planetary_result_t

contains

   !> Input/output speed ratios of the three fixed-member choices from Willis'
   !> equation, and each choice's planet speed on the carrier per unit input speed
   !> (w_p - w_c = -(z_s/z_p)(w_s - w_c)).
   pure subroutine willis_ratios(zs, zp, zr, ratio, planet)
      real(wp), intent(in) :: zs, zp, zr
      real(wp), intent(out) :: ratio(3), planet(3)
      ratio(1) = 1.0_wp + zr/zs          ! ring held: w_s/w_c
      ratio(2) = 1.0_wp + zs/zr          ! sun held: w_r/w_c
      ratio(3) = -zr/zs                  ! carrier held: w_s/w_r
      planet(1) = -(zs/zp)*(1.0_wp - 1.0_wp/ratio(1))   ! w_s = 1, w_c = 1/ratio
      planet(2) = (zs/zp)*(1.0_wp/ratio(2))             ! w_r = 1, w_s = 0, w_c = 1/ratio
      planet(3) = -(zs/zp)                              ! w_s = 1, w_c = 0
   end subroutine willis_ratios

   subroutine planetary_calc(inp, res, err)
      type(planetary_input_t), intent(in) :: inp
      type(planetary_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      integer :: k
      allocate (res%warnings(0))
      if (inp%zs == unset .or. inp%zp == unset .or. inp%planets == unset) then
         call fatal_error(err, 'planetary: error: --teeth-sun ZS, --teeth-planet ZP and --planets N are required', &
                          err_input)
         return
      end if
      call check_teeth('--teeth-sun', inp%zs); if (allocated(err)) return
      call check_teeth('--teeth-planet', inp%zp); if (allocated(err)) return
      res%zr = inp%zs + 2.0_wp*inp%zp
      if (inp%zr /= unset) then
         call check_teeth('--teeth-ring', inp%zr); if (allocated(err)) return
         if (inp%zr /= res%zr) then
            call fatal_error(err, 'planetary: error: --teeth-ring must be teeth_sun + 2 teeth_planet = '//str(res%zr)// &
                             ' (standard gears: the ring''s pitch circle holds the sun''s and two planets''), got '// &
                             str(inp%zr), err_input)
            return
         end if
      end if
      if (.not. (inp%planets >= 1.0_wp .and. inp%planets <= max_planets .and. inp%planets == aint(inp%planets))) then
         call fatal_error(err, 'planetary: error: --planets must be a whole number in [1, '//str(max_planets)// &
                          '], got '//str(inp%planets), err_input)
         return
      end if
      res%n = nint(inp%planets)
      if (.not. assembles(inp%zs, res%zr, res%n)) then
         call fatal_error(err, 'planetary: error: '//str(res%n)//' equally spaced planets cannot be assembled: '// &
                          '(z_s + z_r)/N = ('//str(inp%zs)//' + '//str(res%zr)//')/'//str(res%n)// &
                          ' is not a whole number; planet counts that assemble: '//divisors(nint(inp%zs + res%zr)), &
                          err_input)
         return
      end if
      ! neighbouring planets' tip circles (radius (z_p + 2) m/2) must not touch: the centres are
      ! (z_s + z_p) m sin(pi/N) apart (standard addendum m)
      if (res%n > 1) then
         if (.not. (inp%zs + inp%zp)*sin(pi/res%n) > inp%zp + 2.0_wp) &
            res%warnings = [res%warnings, string_t('planetary: warning: '//str(res%n)//' planets of '//str(inp%zp)// &
                            ' teeth do not fit around a sun of '//str(inp%zs)//': neighbouring tip circles overlap '// &
                            '((z_s + z_p) sin(pi/N) = '//str((inp%zs + inp%zp)*sin(pi/res%n), 4)//' <= z_p + 2)')]
      end if
      call willis_ratios(inp%zs, inp%zp, res%zr, res%ratio, res%planet)
      res%psi = [(360.0_wp*k/res%n, k=0, res%n - 1)]
      allocate (res%ps(res%n), res%pr(res%n))
      call planet_phases(inp%zs, res%zr, res%psi, res%ps, res%pr)
      if (inp%module_mm /= unset .and. inp%diametral_pitch /= unset) then
         call fatal_error(err, 'planetary: error: give --module or --diametral-pitch, not both', err_input)
         return
      end if
      if (inp%module_mm /= unset) res%module_len = inp%module_mm/25.4_wp/inp%units%to_inch
      if (inp%diametral_pitch /= unset) res%module_len = 1.0_wp/inp%diametral_pitch/inp%units%to_inch
   contains

      subroutine check_teeth(opt, z)
         character(len=*), intent(in) :: opt
         real(wp), intent(in) :: z
         if (.not. (z >= 1.0_wp .and. z <= 1.0e4_wp .and. z == aint(z))) &
            call fatal_error(err, 'planetary: error: '//opt//' must be a whole number of teeth in [1, 10000], got '// &
                             str(z), err_input)
      end subroutine check_teeth
   end subroutine planetary_calc

   !> The divisors of m up to max_planets, as text.
   function divisors(m) result(s)
      integer, intent(in) :: m
      character(len=:), allocatable :: s
      integer :: d
      s = ''
      do d = 1, min(m, max_planets)
         if (mod(m, d) == 0) s = s//merge(', ', '  ', len(s) > 0)//str(d)
      end do
      s = trim(adjustl(s))
   end function divisors

   subroutine planetary_report(inp, res, unit)
      type(planetary_input_t), intent(in) :: inp
      type(planetary_result_t), intent(in) :: res
      integer, intent(in) :: unit
      character(len=:), allocatable :: id
      integer :: k
      id = 'ps'
      if (allocated(inp%id)) id = inp%id
      write (unit, '(a)') 'planetary stage: sun '//str(inp%zs)//', planet '//str(inp%zp)//', ring '//str(res%zr)// &
         ' teeth, '//str(res%n)//' planets equally spaced'
      write (unit, '(a)') '  Willis: (w_sun - w_carrier)/(w_ring - w_carrier) = -z_r/z_s = '//str(-res%zr/inp%zs)
      write (unit, '(a)') '  ring held:    sun -> carrier  ratio '//str(res%ratio(1))//'  (w_sun/w_carrier = 1 + z_r/z_s)'
      write (unit, '(a)') '  sun held:     ring -> carrier ratio '//str(res%ratio(2))//'  (w_ring/w_carrier = 1 + z_s/z_r)'
      write (unit, '(a)') '  carrier held: sun -> ring     ratio '//str(res%ratio(3))//'  (w_sun/w_ring = -z_r/z_s)'
      write (unit, '(a)') '  planet speed on the carrier per unit input speed: ring held '//str(res%planet(1))// &
         ', sun held '//str(res%planet(2))//', carrier held '//str(res%planet(3))
      write (unit, '(a)') '  assembly: (z_s + z_r)/N = '//str(nint(inp%zs + res%zr)/res%n)//' (whole: the planets '// &
         'assemble equally spaced)'
      write (unit, '(a)') '  mesh phases relative to planet 1 (fractions of a tooth; -z psi/360 mod 1):'
      write (unit, '(a)') '    planet  angle (deg)  sun mesh  ring mesh'
      do k = 1, res%n
         write (unit, '(a)') '    '//str(k)//'  '//str(res%psi(k))//'  '//str(res%ps(k))//'  '//str(res%pr(k))
      end do
      write (unit, '(a)') ''
      write (unit, '(a)') '! deck fragment (trainsim planetary): ring held, sun and carrier free; give the inertias'
      if (inp%units%name == 'si') write (unit, '(a)') "! needs &run units = 'si'"
      write (unit, '(a)') "&planetary id = '"//id//"', planets = "//str(res%n)//', teeth_sun = '//str(inp%zs)// &
         ', teeth_planet = '//str(inp%zp)//', teeth_ring = '//str(res%zr)//','
      if (inp%diametral_pitch /= unset) then
         write (unit, '(a)') '   diametral_pitch = '//str(inp%diametral_pitch)//', pressure_angle = '// &
            str(inp%pressure_angle_deg)//', face_width = F,'
      else if (inp%module_mm /= unset) then
         write (unit, '(a)') '   module = '//str(inp%module_mm)//', pressure_angle = '//str(inp%pressure_angle_deg)// &
            ', face_width = F,'
      else
         write (unit, '(a)') '   module = M, pressure_angle = '//str(inp%pressure_angle_deg)//', face_width = F,'
      end if
      write (unit, '(a)') "   sun_backlash = B, ring_backlash = B, held = 'ring',"
      write (unit, '(a)') '   sun_inertia = JS, carrier_inertia = JC, planet_inertia = JP /'
   end subroutine planetary_report
end module trainsim_planetary_calc
