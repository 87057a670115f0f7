!> The calculators: trainsim gear (spur gear constants, App. E), trainsim key (the
!> keyed joint's stiffness curve, Ch. IV) and trainsim worm (a worm pair's ratio,
!> lead angle and efficiencies), each with a deck fragment.
module trainsim_cmd_calc
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str, string_t
   use trainsim_gear_calc, only: gear_input_t, gear_result_t, gear_calc, gear_report, &
                                 key_input_t, key_result_t, key_calc, key_report, key_max_points
   use trainsim_worm_calc, only: worm_input_t, worm_result_t, worm_calc, worm_report
   use trainsim_planetary_calc, only: planetary_input_t, planetary_result_t, planetary_calc, planetary_report
   use trainsim_units, only: units_t, make_units
   use trainsim_contact, only: fit_tight, fit_loose, fit_average
   use trainsim_cli, only: cmd, nargs, arg, quit, fail, real_value, text_value
   implicit none
   private

   public :: do_gear, do_key, do_worm, do_planetary

contains

   !> --units NAME for the calculators.
   subroutine calc_units(k, units)
      integer, intent(in) :: k
      type(units_t), intent(out) :: units
      type(error_t), allocatable :: err
      call make_units(text_value(k), units, err)
      if (allocated(err)) then
         write (error_unit, '(a)') 'trainsim: '//cmd//': error: --units: '//err%message
         call quit(2)
      end if
   end subroutine calc_units

   !> in-lbf-s, the calculators' default.
   subroutine default_units(units)
      type(units_t), intent(out) :: units
      type(error_t), allocatable :: err
      call make_units('in-lbf-s', units, err)
   end subroutine default_units

   !> trainsim gear: spur gear constants from the geometry (App. E) and a deck fragment.
   subroutine do_gear()
      type(gear_input_t) :: g
      type(gear_result_t) :: r
      type(error_t), allocatable :: err
      integer :: k
      call default_units(g%units)
      k = 2
      do while (k <= nargs)
         select case (arg(k))
         case ('--teeth')
            g%teeth1 = real_value(k)
            g%teeth2 = g%teeth1
            k = k + 1
            if (k < nargs) then   ! a second number: the driven gear's teeth
               if (verify(trim(arg(k + 1)), '0123456789.eE+') == 0) then
                  g%teeth2 = real_value(k)
                  k = k + 1
               end if
            end if
         case ('--diametral-pitch'); g%diametral_pitch = real_value(k); k = k + 1
         case ('--module'); g%module_mm = real_value(k); k = k + 1
         case ('--pressure-angle'); g%pressure_angle_deg = real_value(k); k = k + 1
         case ('--face-width'); g%face_width = real_value(k); k = k + 1
         case ('--backlash'); g%backlash = real_value(k); k = k + 1
         case ('--youngs-modulus'); g%youngs_modulus = real_value(k); k = k + 1
         case ('--density'); g%density = real_value(k); k = k + 1
         case ('--stiffness-per-width'); g%stiffness_per_width = real_value(k); k = k + 1
         case ('--stiffness'); g%stiffness = real_value(k); k = k + 1
         case ('--frequency'); g%target_frequency = real_value(k); k = k + 1
         case ('--approach-velocity'); g%approach_velocity = real_value(k); k = k + 1
         case ('--id'); g%id = text_value(k); k = k + 1
         case ('--units'); call calc_units(k, g%units); k = k + 1
         case default
            write (error_unit, '(a)') "trainsim: gear: error: unknown option '"//arg(k)//"'; valid: --teeth N1 [N2], "// &
               '--diametral-pitch P | --module M, --pressure-angle DEG, --face-width F, --backlash B, --units U, '// &
               '--youngs-modulus E, --density RHO, --stiffness-per-width KW, --stiffness K, --frequency HZ, '// &
               '--approach-velocity V, --id ID'
            call quit(2)
         end select
         k = k + 1
      end do
      call gear_calc(g, r, err)
      if (allocated(err)) call fail(err)
      call print_warnings(r%warnings)
      call gear_report(g, r, output_unit)
      call quit(0)
   end subroutine do_gear

   !> trainsim key: the keyed joint's stiffness curve (Ch. IV) and a deck fragment.
   subroutine do_key()
      type(key_input_t) :: q
      type(key_result_t) :: r
      type(error_t), allocatable :: err
      integer :: k
      real(wp) :: x
      call default_units(q%units)
      k = 2
      do while (k <= nargs)
         select case (arg(k))
         case ('--diameter'); q%diameter = real_value(k); k = k + 1
         case ('--key-length'); q%key_length = real_value(k); k = k + 1
         case ('--key-width'); q%key_width = real_value(k); k = k + 1
         case ('--key-height'); q%key_height = real_value(k); k = k + 1
         case ('--clearance'); q%clearance = real_value(k); k = k + 1
         case ('--torque-max'); q%torque_max = real_value(k); k = k + 1
         case ('--points')   ! checked as a real first: nint of 1e300 would overflow
            x = real_value(k)
            if (.not. (x >= 2.0_wp .and. x <= real(key_max_points, wp) .and. x == aint(x))) then
               write (error_unit, '(a)') 'trainsim: key: error: --points must be a whole number in [2, '// &
                  str(key_max_points)//'] (rows of the curve), got '//arg(k + 1)
               call quit(2)
            end if
            q%points = nint(x)
            k = k + 1
         case ('--id'); q%id = text_value(k); k = k + 1
         case ('--units'); call calc_units(k, q%units); k = k + 1
         case ('--fit')
            select case (text_value(k))
            case ('tight'); q%fit = fit_tight
            case ('loose'); q%fit = fit_loose
            case ('average'); q%fit = fit_average
            case ('all'); q%fit = 0
            case default
               write (error_unit, '(a)') "trainsim: key: error: unknown --fit '"//arg(k + 1)// &
                  "'; valid: tight (eq. 4.35), loose (4.36), average (4.37), all"
               call quit(2)
            end select
            k = k + 1
         case default
            write (error_unit, '(a)') "trainsim: key: error: unknown option '"//arg(k)//"'; valid: --diameter D, "// &
               '--key-length L, --key-width W, --key-height H, --clearance C, --fit tight|loose|average|all, '// &
               '--torque-max T, --points N, --units U, --id ID'
            call quit(2)
         end select
         k = k + 1
      end do
      call key_calc(q, r, err)
      if (allocated(err)) call fail(err)
      call print_warnings(r%warnings)
      call key_report(q, r, output_unit)
      call quit(0)
   end subroutine do_key

   !> trainsim worm: a worm pair's ratio, lead angle, efficiencies, self-locking and a deck fragment.
   subroutine do_worm()
      type(worm_input_t) :: w
      type(worm_result_t) :: r
      type(error_t), allocatable :: err
      integer :: k
      call default_units(w%units)
      k = 2
      do while (k <= nargs)
         select case (arg(k))
         case ('--starts'); w%starts = real_value(k); k = k + 1
         case ('--teeth'); w%teeth = real_value(k); k = k + 1
         case ('--diametral-pitch'); w%diametral_pitch = real_value(k); k = k + 1
         case ('--module'); w%module_mm = real_value(k); k = k + 1
         case ('--worm-diameter'); w%worm_diameter = real_value(k); k = k + 1
         case ('--diameter-factor'); w%diameter_factor = real_value(k); k = k + 1
         case ('--pressure-angle'); w%pressure_angle_deg = real_value(k); k = k + 1
         case ('--friction'); w%friction = real_value(k); k = k + 1
         case ('--stiffness'); w%stiffness = real_value(k); k = k + 1
         case ('--id'); w%id = text_value(k); k = k + 1
         case ('--units'); call calc_units(k, w%units); k = k + 1
         case default
            write (error_unit, '(a)') "trainsim: worm: error: unknown option '"//arg(k)//"'; valid: --starts Z1, "// &
               '--teeth Z2, --module M | --diametral-pitch P, --worm-diameter D1 | --diameter-factor Q, '// &
               '--pressure-angle DEG, --friction MU, --stiffness K, --units U, --id ID'
            call quit(2)
         end select
         k = k + 1
      end do
      call worm_calc(w, r, err)
      if (allocated(err)) call fail(err)
      call print_warnings(r%warnings)
      call worm_report(w, r, output_unit)
      call quit(0)
   end subroutine do_worm

   !> trainsim planetary: ratios, assembly, mesh phases and a deck fragment of a planetary stage.
   subroutine do_planetary()
      type(planetary_input_t) :: q
      type(planetary_result_t) :: r
      type(error_t), allocatable :: err
      integer :: k
      call default_units(q%units)
      k = 2
      do while (k <= nargs)
         select case (arg(k))
         case ('--teeth-sun'); q%zs = real_value(k); k = k + 1
         case ('--teeth-planet'); q%zp = real_value(k); k = k + 1
         case ('--teeth-ring'); q%zr = real_value(k); k = k + 1
         case ('--planets'); q%planets = real_value(k); k = k + 1
         case ('--module'); q%module_mm = real_value(k); k = k + 1
         case ('--diametral-pitch'); q%diametral_pitch = real_value(k); k = k + 1
         case ('--pressure-angle'); q%pressure_angle_deg = real_value(k); k = k + 1
         case ('--id'); q%id = text_value(k); k = k + 1
         case ('--units'); call calc_units(k, q%units); k = k + 1
         case default
            write (error_unit, '(a)') "trainsim: planetary: error: unknown option '"//arg(k)//"'; valid: "// &
               '--teeth-sun ZS, --teeth-planet ZP, --teeth-ring ZR, --planets N, --module M | --diametral-pitch P, '// &
               '--pressure-angle DEG, --units U, --id ID'
            call quit(2)
         end select
         k = k + 1
      end do
      call planetary_calc(q, r, err)
      if (allocated(err)) call fail(err)
      call print_warnings(r%warnings)
      call planetary_report(q, r, output_unit)
      call quit(0)
   end subroutine do_planetary

   !> A calculator's warnings on stderr, one a line.
   subroutine print_warnings(warnings)
      type(string_t), intent(in) :: warnings(:)
      integer :: j
      do j = 1, size(warnings)
         write (error_unit, '(a)') 'trainsim: '//warnings(j)%s
      end do
   end subroutine print_warnings
end module trainsim_cmd_calc
