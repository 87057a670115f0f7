!> N02, constant-field DC motor (Appendix G, eqs. G.3-G.5):
!>   x1' = x2
!>   J x2' = -d x2 + alpha x3 + T          (T: net torque from elements and loads)
!>   L x3' = -R x3 - alpha' x2 + e(t)      (armature current x3, voltage e)
!> Electrical quantities in V, A, ohm, H; alpha in torque/A, alpha' in V*s/rad.
!> With a controller (a &controller group, trainsim_controller) e is the
!> controller's voltage and the motor has two more states: the controller's
!> integral z (x4) and derivative filter f (x5).
module trainsim_node_dc_motor
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_limits, only: check_magnitude
   use trainsim_signal, only: signal_t, constant_signal
   use trainsim_param_list, only: param_list_t, make_param_list
   use trainsim_node, only: node_t
   use trainsim_controller, only: controller_t, ctl_nstates
   implicit none
   private

   public :: dc_motor_node_t, new_dc_motor_node

   !> Armature inertia and damping plus the armature circuit.
   type, extends(node_t) :: dc_motor_node_t
      real(wp) :: j = 0.0_wp, d = 0.0_wp
      real(wp) :: alpha = 0.0_wp      !< torque constant (torque per ampere)
      real(wp) :: l = 0.0_wp          !< armature inductance, H
      real(wp) :: r = 0.0_wp          !< armature resistance, ohm
      real(wp) :: alpha_e = 0.0_wp    !< back-emf constant, V*s/rad
      real(wp) :: current0 = 0.0_wp
      real(wp) :: power_per_watt = 1.0_wp
      type(signal_t) :: voltage
      logical :: has_voltage = .false.
      logical :: controlled = .false.
      type(controller_t) :: ctl
   contains
      procedure :: configure => motor_configure
      procedure :: nstates => motor_nstates
      procedure :: derivatives => motor_derivatives
      procedure :: inertia => motor_inertia
      procedure :: initial_state => motor_initial_state
      procedure :: set_initial_extra => motor_set_initial_extra
      procedure :: stored_energy => motor_stored_energy
      procedure :: dissipation_power => motor_dissipation
      procedure :: input_power => motor_input_power
      procedure :: attach_voltage => motor_attach_voltage
      procedure :: state_names => motor_state_names
      procedure :: driving_input => motor_driving_input
      procedure :: driving_input_value => motor_driving_input_value
      procedure :: params => motor_params
      procedure :: jacobian => motor_jacobian
      procedure :: breakpoints => motor_breakpoints
      procedure :: applied_voltage => motor_applied_voltage
   end type dc_motor_node_t

contains

   !> Registry factory: a new, unconfigured DC motor node.
   subroutine new_dc_motor_node(nd)
      class(node_t), allocatable, intent(out) :: nd
      allocate (dc_motor_node_t :: nd)
   end subroutine new_dc_motor_node

   subroutine motor_configure(self, grp, units, err)
      class(dc_motor_node_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      call grp%get_real('inertia', self%j, err); if (allocated(err)) return
      call grp%get_real('damping', self%d, err, default=0.0_wp); if (allocated(err)) return
      call grp%get_real('torque_constant', self%alpha, err); if (allocated(err)) return
      call grp%get_real('inductance', self%l, err); if (allocated(err)) return
      call grp%get_real('resistance', self%r, err); if (allocated(err)) return
      call grp%get_real('back_emf_constant', self%alpha_e, err); if (allocated(err)) return
      call grp%require_positive('inertia', self%j, err); if (allocated(err)) return
      call grp%require_positive('inductance', self%l, err); if (allocated(err)) return
      call grp%require_positive('resistance', self%r, err); if (allocated(err)) return
      call grp%require_positive('torque_constant', self%alpha, err); if (allocated(err)) return
      call grp%require_positive('back_emf_constant', self%alpha_e, err); if (allocated(err)) return
      call grp%require_nonnegative('damping', self%d, err); if (allocated(err)) return
      self%power_per_watt = units%power_per_watt
      self%voltage = constant_signal(0.0_wp)
   end subroutine motor_configure

   pure integer function motor_nstates(self) result(n)
      class(dc_motor_node_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 3
      if (self%controlled) n = 3 + ctl_nstates
   end function motor_nstates

   pure subroutine motor_derivatives(self, t, y, torque, dydt)
      class(dc_motor_node_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:), torque
      real(wp), intent(inout) :: dydt(:)
      real(wp) :: e, u, v
      integer :: bound
      if (self%controlled) then
         call self%ctl%law(t, y, self%offset, self%r, self%alpha_e, e, u, v, bound)
         call self%ctl%rates(t, y, self%offset, e, u, v, bound, dydt)
      else
         v = self%voltage%value(t)
      end if
      associate (w => y(self%offset + 2), i => y(self%offset + 3))
         dydt(self%offset + 1) = w                                                        ! eq. (G.3)
         dydt(self%offset + 2) = (-self%d*w + self%alpha*i + torque)/self%j                ! eq. (G.4)
         dydt(self%offset + 3) = (-self%r*i - self%alpha_e*w + v)/self%l                   ! eq. (G.5)
      end associate
   end subroutine motor_derivatives

   pure real(wp) function motor_inertia(self) result(j)
      class(dc_motor_node_t), intent(in) :: self
      j = self%j
   end function motor_inertia

   pure subroutine motor_initial_state(self, y)
      class(dc_motor_node_t), intent(in) :: self
      real(wp), intent(inout) :: y(:)
      y(self%offset + 1) = self%theta0
      y(self%offset + 2) = self%omega0
      y(self%offset + 3) = self%current0
      if (self%controlled) then
         y(self%offset + 4) = 0.0_wp
         y(self%offset + 5) = self%ctl%m0
      end if
   end subroutine motor_initial_state

   subroutine motor_set_initial_extra(self, grp, err)
      class(dc_motor_node_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(error_t), allocatable, intent(out) :: err
      call grp%get_real('current', self%current0, err, default=0.0_wp)
      call check_magnitude(grp, 'current', self%current0, err)
   end subroutine motor_set_initial_extra

   pure real(wp) function motor_stored_energy(self, y) result(e)
      class(dc_motor_node_t), intent(in) :: self
      real(wp), intent(in) :: y(:)
      e = 0.5_wp*self%j*y(self%offset + 2)**2 + 0.5_wp*self%l*y(self%offset + 3)**2*self%power_per_watt
   end function motor_stored_energy

   pure real(wp) function motor_dissipation(self, y) result(p)
      class(dc_motor_node_t), intent(in) :: self
      real(wp), intent(in) :: y(:)
      p = self%d*y(self%offset + 2)**2 + self%r*y(self%offset + 3)**2*self%power_per_watt
   end function motor_dissipation

   !> Electrical power in minus the power the back-emf and torque constants
   !> fail to convert (zero when alpha = alpha' in consistent units).
   pure real(wp) function motor_input_power(self, t, y) result(p)
      class(dc_motor_node_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:)
      associate (w => y(self%offset + 2), i => y(self%offset + 3))
         p = self%applied_voltage(t, y)*i*self%power_per_watt + (self%alpha - self%alpha_e*self%power_per_watt)*i*w
      end associate
   end function motor_input_power

   !> The armature voltage: the controller's, else the voltage load's e(t).
   pure real(wp) function motor_applied_voltage(self, t, y) result(v)
      class(dc_motor_node_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp) :: e, u
      integer :: bound
      if (self%controlled) then
         call self%ctl%law(t, y, self%offset, self%r, self%alpha_e, e, u, v, bound)
      else
         v = self%voltage%value(t)
      end if
   end function motor_applied_voltage

   !> The armature voltage e(t) is the motor's driving input (the history's /inputs);
   !> a controller's voltage depends on the state: no time function to record.
   pure subroutine motor_driving_input(self, quantity, unit)
      class(dc_motor_node_t), intent(in) :: self
      character(len=:), allocatable, intent(out) :: quantity, unit
      quantity = ''
      unit = ''
      if (.not. self%has_voltage .or. self%controlled) return
      quantity = 'voltage'
      unit = 'V'
   end subroutine motor_driving_input

   pure real(wp) function motor_driving_input_value(self, t) result(v)
      class(dc_motor_node_t), intent(in) :: self
      real(wp), intent(in) :: t
      v = self%voltage%value(t)
   end function motor_driving_input_value

   subroutine motor_attach_voltage(self, sig, where, err)
      class(dc_motor_node_t), intent(inout) :: self
      type(signal_t), intent(in) :: sig
      character(len=*), intent(in) :: where
      type(error_t), allocatable, intent(out) :: err
      if (self%has_voltage) then
         call fatal_error(err, where//": error: node '"//self%id//"' already has a voltage load", err_input)
         return
      end if
      self%voltage = sig
      self%has_voltage = .true.
   end subroutine motor_attach_voltage

   pure subroutine motor_state_names(self, names)
      class(dc_motor_node_t), intent(in) :: self
      type(string_t), intent(out) :: names(:)
      names(1)%s = self%id//'.angle'
      names(2)%s = self%id//'.speed'
      names(3)%s = self%id//'.current'
      if (self%controlled) then
         names(4)%s = self%id//'.controller_integral'
         names(5)%s = self%id//'.controller_filter'
      end if
   end subroutine motor_state_names

   pure subroutine motor_jacobian(self, t, y, jac, dtorque)
      class(dc_motor_node_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: jac(:, :)
      real(wp), intent(out) :: dtorque(:)
      integer :: o
      o = self%offset
      jac(o + 1, o + 2) = jac(o + 1, o + 2) + 1.0_wp
      jac(o + 2, o + 2) = jac(o + 2, o + 2) - self%d/self%j
      jac(o + 2, o + 3) = jac(o + 2, o + 3) + self%alpha/self%j
      jac(o + 3, o + 2) = jac(o + 3, o + 2) - self%alpha_e/self%l
      jac(o + 3, o + 3) = jac(o + 3, o + 3) - self%r/self%l
      dtorque = 0.0_wp
      dtorque(2) = 1.0_wp/self%j
      if (self%controlled) call self%ctl%jacobian(t, y, o, self%r, self%alpha_e, self%l, jac)
   end subroutine motor_jacobian

   !> Knots of the armature voltage.
   pure subroutine motor_breakpoints(self, bp)
      class(dc_motor_node_t), intent(in) :: self
      real(wp), allocatable, intent(out) :: bp(:)
      if (self%controlled) then
         call self%ctl%setpoint%breakpoints(bp)
      else
         call self%voltage%breakpoints(bp)
      end if
   end subroutine motor_breakpoints

   function motor_params(self) result(p)
      class(dc_motor_node_t), intent(in) :: self
      type(param_list_t) :: p
      ! One structure constructor: assigning p%names, then p%values trips gfortran 12's
      ! false -Wuninitialized on the descriptors of the unallocated components.
      p = make_param_list([character(len=40) :: 'inertia', 'damping', 'torque_constant', 'inductance', &
                              'resistance', 'back_emf_constant'], &
                       [self%j, self%d, self%alpha, self%l, self%r, self%alpha_e])
   end function motor_params
end module trainsim_node_dc_motor
