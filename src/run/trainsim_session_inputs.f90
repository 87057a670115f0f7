!> What a session (trainsim_session) changes in its model: its inputs and its
!> positioning sequences.
!>
!> Inputs (co-simulation inputs, docs/fmu.md), named `NODE` or `NODE.tau` (an
!> external torque), `NODE.speed` (the node's prescribed speed) or `NODE.voltage`
!> (a DC motor's supply voltage). A value is held from the time it is set on
!> (zero-order hold):
!> - a speed input replaces the motion the deck prescribes on the node (a `&load`
!>   with quantity 'speed', 'angle' or 'acceleration'): from time tc the node
!>   turns at the constant speed v, its angle continuous at tc (theta(tc) + v (t - tc));
!> - a voltage input replaces the motor's voltage function e(t) by the constant v
!>   (a motor under a &controller has no voltage input: the controller sets it).
!> Both start at the deck's value at t_start, so an input left alone runs the
!> deck's value of t_start on.
!>
!> Sequences (D-89): a &controller's positioning sequence is shared by pointer
!> between the motor's controller, its positioner element and a brake it commands
!> (D-76). A session gives its model sequences of its own (`own_sequences`), so
!> that the caller's model and other sessions are not advanced by it, and a saved
!> point keeps each sequence's progress (`sequence_progress`), restored with it.
module trainsim_session_inputs
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_model, only: model_t
   use trainsim_signal, only: constant_signal
   use trainsim_controller, only: sequence_t
   use trainsim_node_dc_motor, only: dc_motor_node_t
   use trainsim_el_positioner, only: positioner_t
   use trainsim_friction_element, only: friction_element_t
   implicit none
   private

   public :: in_torque, in_speed, in_voltage, input_of, check_input, input_start_value
   public :: hold_speed, hold_voltage
   public :: own_sequences, release_sequences, sequence_progress, set_sequence_progress

   integer, parameter :: in_torque = 1, in_speed = 2, in_voltage = 3
   character(len=*), parameter :: kind_word(3) = [character(len=7) :: 'torque', 'speed', 'voltage']

contains

   !> The node id and the kind of the input `name` (NODE, NODE.tau, NODE.speed, NODE.voltage).
   subroutine input_of(name, node, kind)
      character(len=*), intent(in) :: name
      character(len=:), allocatable, intent(out) :: node
      integer, intent(out) :: kind
      integer :: dot
      dot = index(name, '.', back=.true.)
      kind = in_torque
      node = name
      if (dot == 0) return
      select case (name(dot + 1:))
      case ('tau'); kind = in_torque
      case ('speed'); kind = in_speed
      case ('voltage'); kind = in_voltage
      case default; return
      end select
      node = name(:dot - 1)
   end subroutine input_of

   !> Whether node i of `model` can take an input of `kind` (else err: why, naming it).
   subroutine check_input(model, i, node, kind, err)
      type(model_t), intent(in) :: model
      integer, intent(in) :: i, kind
      character(len=*), intent(in) :: node
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: what
      what = 'input '//trim(kind_word(kind))//" on node '"//node//"': "
      if (i == 0) then
         call fatal_error(err, what//'the deck has no node of that id', err_input)
         return
      end if
      select case (kind)
      case (in_torque)
         if (model%nodes(i)%n%nstates() == 0 .or. model%is_held(i)) &
            call fatal_error(err, what//'the node is fixed or its speed is prescribed (a torque there moves '// &
                             'nothing; an input speed: NODE.speed)', err_input)
      case (in_speed)
         if (.not. model%is_held(i)) &
            call fatal_error(err, what//"the deck prescribes no motion there (an input speed replaces a &load "// &
                             "quantity = 'speed', 'angle' or 'acceleration' on the node)", err_input)
      case (in_voltage)
         select type (n => model%nodes(i)%n)
         type is (dc_motor_node_t)
            if (n%controlled) call fatal_error(err, what//'the motor''s voltage is set by its &controller', err_input)
         class default
            call fatal_error(err, what//"the node is of type '"//n%type_name//"' (only a 'dc_motor' has a voltage)", &
                             err_input)
         end select
      end select
   end subroutine check_input

   !> The deck's value at t of the quantity an input of `kind` on node i replaces
   !> (a torque input adds to the deck's loads: 0).
   real(wp) function input_start_value(model, i, kind, t) result(v)
      type(model_t), intent(in) :: model
      integer, intent(in) :: i, kind
      real(wp), intent(in) :: t
      v = 0.0_wp
      select case (kind)
      case (in_speed)
         v = model%speeds(model%speed_of(i))%value(t)
      case (in_voltage)
         select type (n => model%nodes(i)%n)
         type is (dc_motor_node_t)
            v = n%voltage%value(t)
         end select
      end select
   end function input_start_value

   !> Held node i turns at the constant speed v from t on, its angle continuous
   !> at t (the state y gives the other nodes'; the angle is theta0 + v t with
   !> theta0 = theta(t) - v t). changed: whether the motion was not that already.
   subroutine hold_speed(model, i, t, y, v, changed)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: i
      real(wp), intent(in) :: t, y(:), v
      logical, intent(out) :: changed
      real(wp) :: th
      integer :: s
      s = model%speed_of(i)
      changed = .not. (model%speeds(s)%is_constant() .and. model%speeds(s)%value(t) == v)
      if (.not. changed) return
      call model%kinematics(t, y)
      th = model%theta(i)
      model%speeds(s) = constant_signal(v)
      model%nodes(i)%n%theta0 = th - v*t
      call model%build_fast_path()
   end subroutine hold_speed

   !> Motor node i's supply voltage is the constant v from now on. changed:
   !> whether it was not that already.
   subroutine hold_voltage(model, i, v, changed)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: i
      real(wp), intent(in) :: v
      logical, intent(out) :: changed
      changed = .false.
      select type (n => model%nodes(i)%n)
      type is (dc_motor_node_t)
         changed = .not. (n%voltage%is_constant() .and. n%voltage%value0 == v)
         if (changed) n%voltage = constant_signal(v)
      end select
   end subroutine hold_voltage

   !> Give each positioning sequence of `model` a copy of its own (its targets
   !> and progress), pointed at by the motor's controller, the positioner element
   !> and a brake it commands, as they pointed at the one they shared.
   subroutine own_sequences(model)
      type(model_t), intent(inout) :: model
      type(sequence_t), pointer :: old, new
      integer :: i, k
      do i = 1, size(model%nodes)
         select type (n => model%nodes(i)%n)
         type is (dc_motor_node_t)
            if (.not. associated(n%ctl%seq)) cycle
            old => n%ctl%seq
            allocate (new, source=old)
            n%ctl%seq => new
            do k = 1, size(model%elements)
               select type (e => model%elements(k)%e)
               class is (positioner_t)
                  if (associated(e%seq, old)) e%seq => new
               class is (friction_element_t)
                  if (associated(e%command, old)) e%command => new
               end select
            end do
         end select
      end do
   end subroutine own_sequences

   !> Free the sequences `own_sequences` gave `model` (the model is dropped next).
   subroutine release_sequences(model)
      type(model_t), intent(inout) :: model
      integer :: i
      if (.not. allocated(model%nodes)) return
      do i = 1, size(model%nodes)
         select type (n => model%nodes(i)%n)
         type is (dc_motor_node_t)
            if (associated(n%ctl%seq)) deallocate (n%ctl%seq)
         end select
      end do
   end subroutine release_sequences

   !> Each sequence's progress (the last slot reached), motors in node order.
   subroutine sequence_progress(model, reached)
      type(model_t), intent(in) :: model
      integer, allocatable, intent(out) :: reached(:)
      integer :: i
      allocate (reached(0))
      do i = 1, size(model%nodes)
         select type (n => model%nodes(i)%n)
         type is (dc_motor_node_t)
            if (associated(n%ctl%seq)) reached = [reached, n%ctl%seq%reached]
         end select
      end do
   end subroutine sequence_progress

   !> Set each sequence's progress (as `sequence_progress` gave it).
   subroutine set_sequence_progress(model, reached)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: reached(:)
      integer :: i, k
      k = 0
      do i = 1, size(model%nodes)
         select type (n => model%nodes(i)%n)
         type is (dc_motor_node_t)
            if (.not. associated(n%ctl%seq)) cycle
            k = k + 1
            n%ctl%seq%reached = reached(k)
         end select
      end do
   end subroutine set_sequence_progress

end module trainsim_session_inputs
