!> Unit systems. The equations are unit-agnostic (any consistent set); the
!> empirical fits of the thesis (Goldsmith and Smith restitution, keyed-joint
!> and tooth stiffness) were made in inch, pound-force, second: they convert
!> their arguments to those units and their results back.
module trainsim_units
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: to_lower
   implicit none
   private

   public :: units_t, make_units

   !> A consistent unit system: factors that convert its length and force to in and lbf.
   type :: units_t
      character(len=:), allocatable :: name       !< 'in-lbf-s' or 'si'
      character(len=:), allocatable :: length, force, torque, inertia
      real(wp) :: to_inch = 1.0_wp                !< length in these units times this = inch
      real(wp) :: to_lbf = 1.0_wp                 !< force in these units times this = lbf
      !> One watt expressed in these units' power (lbf*in/s per W for in-lbf-s), for motors.
      real(wp) :: power_per_watt = 1.0_wp
   contains
      procedure :: speed_to_ips    !< a line speed in these units -> in/s
      procedure :: stiffness_from_ips  !< lb/in -> these units' force/length
   end type units_t

contains

   !> Build a unit system from its deck name ('in-lbf-s' [default], 'ips', 'si', 'm-n-s').
   subroutine make_units(name, units, err)
      character(len=*), intent(in) :: name
      type(units_t), intent(out) :: units
      type(error_t), allocatable, intent(out) :: err
      select case (to_lower(trim(name)))
      case ('in-lbf-s', 'ips', 'inch')
         units%name = 'in-lbf-s'
         units%length = 'in'; units%force = 'lbf'; units%torque = 'lbf*in'
         units%inertia = 'lbf*in*s^2'
         units%to_inch = 1.0_wp; units%to_lbf = 1.0_wp
         units%power_per_watt = 1.0_wp/(0.0254_wp*4.4482216152605_wp)
      case ('si', 'm-n-s')
         units%name = 'si'
         units%length = 'm'; units%force = 'N'; units%torque = 'N*m'
         units%inertia = 'kg*m^2'
         units%to_inch = 1.0_wp/0.0254_wp
         units%to_lbf = 1.0_wp/4.4482216152605_wp
      case default
         call fatal_error(err, "unknown unit system '"//trim(name)//"'; valid: 'in-lbf-s' (default), 'si'", err_input)
      end select
   end subroutine make_units

   !> Convert a speed along a line (length/s) to in/s, for the empirical fits.
   elemental function speed_to_ips(self, v) result(v_ips)
      class(units_t), intent(in) :: self
      real(wp), intent(in) :: v
      real(wp) :: v_ips
      v_ips = v*self%to_inch
   end function speed_to_ips

   !> Convert a stiffness in lbf/in into these units' force per length.
   elemental function stiffness_from_ips(self, k_ips) result(k)
      class(units_t), intent(in) :: self
      real(wp), intent(in) :: k_ips
      real(wp) :: k
      k = k_ips*self%to_inch/self%to_lbf
   end function stiffness_from_ips
end module trainsim_units
