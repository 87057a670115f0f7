!> The abstract node: a lumped inertia (or ground, or a motor) with its own
!> states. Appendix G: x_i1 angle, x_i2 speed (+ x_13 current for the motor).
!> `derivatives` receives the net torque acting on the node from its elements
!> and external loads.
module trainsim_node
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_signal, only: signal_t
   use trainsim_param_list, only: param_list_t
   use trainsim_strings, only: string_t
   implicit none
   private

   public :: node_t, node_slot_t

   type, abstract :: node_t
      character(len=:), allocatable :: id
      character(len=:), allocatable :: type_name
      !> where the deck defines it ("deck.nml:3: &node #1"; '' if not from a deck)
      character(len=:), allocatable :: origin
      integer :: offset = 0            !< y(offset+1:offset+nstates()) are this node's states
      real(wp) :: theta0 = 0.0_wp      !< initial angle
      real(wp) :: omega0 = 0.0_wp      !< initial speed
   contains
      procedure(configure_i), deferred :: configure
      procedure(nstates_i), deferred :: nstates
      procedure(derivatives_i), deferred :: derivatives
      procedure :: inertia => nd_inertia
      procedure :: kinematics => nd_kinematics
      procedure :: initial_state => nd_initial_state
      procedure :: set_initial_extra => nd_set_initial_extra
      procedure :: stored_energy => nd_stored_energy
      procedure :: dissipation_power => nd_dissipation_power
      procedure :: input_power => nd_input_power
      procedure :: is_fixed => nd_is_fixed
      procedure :: can_prescribe_speed => nd_can_prescribe_speed
      procedure :: attach_voltage => nd_attach_voltage
      procedure :: driving_input => nd_driving_input
      procedure :: driving_input_value => nd_driving_input_value
      procedure :: state_names => nd_state_names
      procedure :: params => nd_params
      procedure :: jacobian => nd_jacobian
      procedure :: breakpoints => nd_breakpoints
      procedure :: plain_inertia => nd_plain_inertia
   end type node_t

   !> A slot in the model's node list.
   type :: node_slot_t
      class(node_t), allocatable :: n
   end type node_slot_t

   abstract interface
      !> Read and validate the node's own keys.
      subroutine configure_i(self, grp, units, err)
         import :: node_t, deck_group_t, units_t, error_t
         class(node_t), intent(inout) :: self
         type(deck_group_t), intent(inout) :: grp
         type(units_t), intent(in) :: units
         type(error_t), allocatable, intent(out) :: err
      end subroutine configure_i
      !> Number of states the node owns.
      pure integer function nstates_i(self)
         import :: node_t
         class(node_t), intent(in) :: self
      end function nstates_i
      !> State derivatives given the net torque acting on the node.
      pure subroutine derivatives_i(self, t, y, torque, dydt)
         import :: node_t, wp
         class(node_t), intent(in) :: self
         real(wp), intent(in) :: t, y(:), torque
         real(wp), intent(inout) :: dydt(:)
      end subroutine derivatives_i
   end interface

contains

   !> Rotational inertia (0 for a fixed node).
   pure real(wp) function nd_inertia(self) result(j)
      class(node_t), intent(in) :: self
      associate (unused => self)
      end associate
      j = 0.0_wp
   end function nd_inertia

   !> Angle and speed from the state vector (default: states 1 and 2).
   pure subroutine nd_kinematics(self, y, theta, omega)
      class(node_t), intent(in) :: self
      real(wp), intent(in) :: y(:)
      real(wp), intent(out) :: theta, omega
      theta = y(self%offset + 1)
      omega = y(self%offset + 2)
   end subroutine nd_kinematics

   !> Write the initial states into y.
   pure subroutine nd_initial_state(self, y)
      class(node_t), intent(in) :: self
      real(wp), intent(inout) :: y(:)
      y(self%offset + 1) = self%theta0
      y(self%offset + 2) = self%omega0
   end subroutine nd_initial_state

   !> Initial value of a node-specific state (e.g. motor current) from &initial.
   subroutine nd_set_initial_extra(self, grp, err)
      class(node_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => self, u2 => grp)
      end associate
      if (allocated(err)) return
   end subroutine nd_set_initial_extra

   !> Energy stored in the node (kinetic, + magnetic for a motor).
   pure real(wp) function nd_stored_energy(self, y) result(e)
      class(node_t), intent(in) :: self
      real(wp), intent(in) :: y(:)
      real(wp) :: th, om
      if (self%nstates() == 0) then
         e = 0.0_wp
         return
      end if
      call self%kinematics(y, th, om)
      e = 0.5_wp*self%inertia()*om**2
   end function nd_stored_energy

   !> Power dissipated in the node (external damping, winding resistance).
   pure real(wp) function nd_dissipation_power(self, y) result(p)
      class(node_t), intent(in) :: self
      real(wp), intent(in) :: y(:)
      associate (u1 => self, u2 => y)
      end associate
      p = 0.0_wp
   end function nd_dissipation_power

   !> Power fed in by a source inside the node (motor: e*i).
   pure real(wp) function nd_input_power(self, t, y) result(p)
      class(node_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:)
      associate (u1 => self, u2 => y, u3 => t)
      end associate
      p = 0.0_wp
   end function nd_input_power

   !> Whether the node is a plain rigid disk (optional capability, default no):
   !> kinematics (angle, speed) = its states 1 and 2, derivatives x1' = x2,
   !> J x2' = -d x2 + T (eqs. G.1-G.2), stored energy J x2^2/2, dissipation
   !> d x2^2, no input power. The model then integrates such nodes from arrays
   !> without calls through the node (the hot path); it checks the claim
   !> against `derivatives` at the start of every run.
   pure subroutine nd_plain_inertia(self, plain, j, d)
      class(node_t), intent(in) :: self
      logical, intent(out) :: plain
      real(wp), intent(out) :: j, d
      associate (unused => self)
      end associate
      j = 0.0_wp
      d = 0.0_wp
      plain = .false.
   end subroutine nd_plain_inertia

   !> Whether the node is ground.
   pure logical function nd_is_fixed(self) result(f)
      class(node_t), intent(in) :: self
      associate (unused => self)
      end associate
      f = .false.
   end function nd_is_fixed

   !> Whether a prescribed speed may be imposed on this node type.
   pure logical function nd_can_prescribe_speed(self) result(f)
      class(node_t), intent(in) :: self
      associate (unused => self)
      end associate
      f = .false.
   end function nd_can_prescribe_speed

   !> Attach a voltage source (only nodes with an armature accept one).
   subroutine nd_attach_voltage(self, sig, where, err)
      class(node_t), intent(inout) :: self
      type(signal_t), intent(in) :: sig
      character(len=*), intent(in) :: where
      type(error_t), allocatable, intent(out) :: err
      associate (unused => sig)
      end associate
      call fatal_error(err, where//": error: node '"//self%id//"' of type '"//self%type_name// &
                       "' has no voltage input (only type 'dc_motor' has)", err_input)
   end subroutine nd_attach_voltage

   !> The time function that drives the node itself, for the history's /inputs
   !> (a DC motor's voltage): its quantity and unit, '' when there is none (the default).
   pure subroutine nd_driving_input(self, quantity, unit)
      class(node_t), intent(in) :: self
      character(len=:), allocatable, intent(out) :: quantity, unit
      associate (unused => self)
      end associate
      quantity = ''
      unit = ''
   end subroutine nd_driving_input

   !> The value at t of the node's driving input (see `driving_input`); 0 by default.
   pure real(wp) function nd_driving_input_value(self, t) result(v)
      class(node_t), intent(in) :: self
      real(wp), intent(in) :: t
      associate (u1 => self, u2 => t)
      end associate
      v = 0.0_wp
   end function nd_driving_input_value

   !> Names of the node's states, for the output file.
   pure subroutine nd_state_names(self, names)
      class(node_t), intent(in) :: self
      type(string_t), intent(out) :: names(:)
      if (size(names) >= 1) names(1)%s = self%id//'.angle'
      if (size(names) >= 2) names(2)%s = self%id//'.speed'
   end subroutine nd_state_names

   !> Add d(dydt)/dy of the node's own states to jac at constant net torque, and
   !> return dtorque(k) = d(dydt of state k)/d(net torque). Default: none.
   pure subroutine nd_jacobian(self, t, y, jac, dtorque)
      class(node_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: jac(:, :)
      real(wp), intent(out) :: dtorque(:)
      associate (u1 => self, u2 => t, u3 => y, u4 => jac)
      end associate
      dtorque = 0.0_wp
   end subroutine nd_jacobian

   !> Times where an input of the node itself jumps or kinks (default: none).
   pure subroutine nd_breakpoints(self, bp)
      class(node_t), intent(in) :: self
      real(wp), allocatable, intent(out) :: bp(:)
      associate (unused => self)
      end associate
      allocate (bp(0))
   end subroutine nd_breakpoints

   !> Parameters as used, for the output file.
   function nd_params(self) result(p)
      class(node_t), intent(in) :: self
      type(param_list_t) :: p
      associate (unused => self)
      end associate
      allocate (p%names(0), p%values(0))
   end function nd_params
end module trainsim_node
