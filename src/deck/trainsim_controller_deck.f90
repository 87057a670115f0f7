!> The deck's &controller groups (docs/deck.md): each sets a DC motor's voltage
!> by feedback (trainsim_controller) and, with `sequence = .true.`, adds the
!> positioner element that locates the sequence's arrivals. Called by the builder:
!> read_controllers after the loads (before the state layout), link_controllers
!> after the &initial groups (the sensor's state index and initial value).
module trainsim_controller_deck
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, to_lower
   use trainsim_deck, only: deck_t, deck_group_t
   use trainsim_limits, only: check_magnitude
   use trainsim_signal, only: signal_from_group
   use trainsim_model, only: model_t
   use trainsim_element, only: element_slot_t
   use trainsim_id_table, only: id_table_t
   use trainsim_controller, only: controller_t, ctl_speed, ctl_angle, aw_none, aw_conditional, aw_back_calculation
   use trainsim_node_dc_motor, only: dc_motor_node_t
   use trainsim_el_positioner, only: positioner_t
   use trainsim_el_brake, only: brake_t
   implicit none
   private

   public :: read_controllers, link_controllers

contains

   !> Read every &controller group, attach each controller to its motor and add a
   !> positioner element for each sequence.
   subroutine read_controllers(deck, model, node_ids, err)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(inout) :: model
      type(id_table_t), intent(in) :: node_ids
      type(error_t), allocatable, intent(out) :: err
      integer :: i, k, im
      character(len=:), allocatable :: id
      type(controller_t) :: ctl

      k = 0
      do i = 1, size(deck%groups)
         if (.not. deck%groups(i)%named('controller')) cycle
         k = k + 1
         associate (g => deck%groups(i))
            call g%get_string('id', id, err, default='c'//str(k)); if (allocated(err)) return
            call read_one(g, model, node_ids, ctl, im, err); if (allocated(err)) return
            if (associated(ctl%seq)) then
               call command_brake(g, model, ctl, err); if (allocated(err)) return
               call add_positioner(g, model, id, ctl, im)
            end if
            select type (m => model%nodes(im)%n)
            type is (dc_motor_node_t)
               m%ctl = ctl
               m%controlled = .true.
            end select
            call g%check_unused(err, 'a &controller group'); if (allocated(err)) return
         end associate
      end do
   end subroutine read_controllers

   !> One group's keys into ctl; im is the motor's node index.
   subroutine read_one(g, model, node_ids, ctl, im, err)
      type(deck_group_t), intent(inout) :: g
      type(model_t), intent(inout) :: model
      type(id_table_t), intent(in) :: node_ids
      type(controller_t), intent(out) :: ctl
      integer, intent(out) :: im
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: mid, sid, word
      logical :: sequence

      call g%get_string('motor', mid, err); if (allocated(err)) return
      im = node_ids%get(mid)
      if (im == 0) then
         call fatal_error(err, g%where('motor')//": error: controller on motor '"//mid//"', a node which is not "// &
                          'defined', err_input)
         return
      end if
      select type (m => model%nodes(im)%n)
      type is (dc_motor_node_t)
         if (m%controlled) then
            call fatal_error(err, g%where('motor')//": error: motor '"//mid//"' already has a controller", err_input)
         else if (m%has_voltage) then
            call fatal_error(err, g%where('motor')//": error: motor '"//mid//"' has a voltage load; a controller "// &
                             'sets its voltage (remove the &load with quantity = voltage)', err_input)
         end if
      class default
         call fatal_error(err, g%where('motor')//": error: node '"//mid//"' is of type '"//m%type_name// &
                          "'; a controller drives a node of type 'dc_motor'", err_input)
      end select
      if (allocated(err)) return
      call g%get_string('sensor', sid, err, default=mid); if (allocated(err)) return
      ctl%sensor = node_ids%get(sid)
      if (ctl%sensor == 0) then
         call fatal_error(err, g%where('sensor')//": error: controller sensor on node '"//sid// &
                          "', which is not defined", err_input)
         return
      end if
      if (model%nodes(ctl%sensor)%n%nstates() < 2 .or. model%speed_of(ctl%sensor) /= 0) then
         call fatal_error(err, g%where('sensor')//": error: sensor node '"//sid//"' has no angle and speed of "// &
                          'its own (it is fixed or its speed is prescribed)', err_input)
         return
      end if
      call g%get_string('measure', word, err, default='speed'); if (allocated(err)) return
      select case (to_lower(word))
      case ('speed'); ctl%kind = ctl_speed
      case ('angle'); ctl%kind = ctl_angle
      case default
         call fatal_error(err, g%where('measure')//": error: unknown measure '"//word//"'; valid: speed, angle", &
                          err_input)
         return
      end select
      call read_gains(g, ctl, err); if (allocated(err)) return
      call g%get_logical('sequence', sequence, err, default=.false.); if (allocated(err)) return
      call signal_from_group(g, ctl%setpoint, err); if (allocated(err)) return
      if (.not. sequence) return
      if (size(model%nodes) < 2) then
         call fatal_error(err, g%where('sequence')//': error: a positioning sequence needs a second node '// &
                          '(its positioner element joins the sensor to another node)', err_input)
         return
      end if
      call read_sequence(g, ctl, err)
   end subroutine read_one

   !> Gains, filter, limits and anti-windup.
   subroutine read_gains(g, ctl, err)
      type(deck_group_t), intent(inout) :: g
      type(controller_t), intent(inout) :: ctl
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: word
      real(wp) :: big

      big = huge(1.0_wp)
      call g%get_real('kp', ctl%kp, err); if (allocated(err)) return
      call g%get_real('ki', ctl%ki, err, default=0.0_wp); if (allocated(err)) return
      call g%get_real('kd', ctl%kd, err, default=0.0_wp); if (allocated(err)) return
      call g%get_real('filter_time', ctl%tf, err, default=0.0_wp); if (allocated(err)) return
      call g%get_real('v_min', ctl%v_min, err, default=-big); if (allocated(err)) return
      call g%get_real('v_max', ctl%v_max, err, default=big); if (allocated(err)) return
      call g%get_real('current_limit', ctl%i_max, err, default=0.0_wp); if (allocated(err)) return
      call g%require_nonnegative('kp', ctl%kp, err)
      call g%require_nonnegative('ki', ctl%ki, err)
      call g%require_nonnegative('kd', ctl%kd, err)
      call g%require_nonnegative('filter_time', ctl%tf, err)
      call g%require_nonnegative('current_limit', ctl%i_max, err); if (allocated(err)) return
      if (ctl%kd > 0.0_wp .and. .not. ctl%tf > 0.0_wp) then
         call fatal_error(err, g%where('filter_time')//': error: a derivative gain kd = '//str(ctl%kd)// &
                          ' needs a derivative filter time filter_time > 0 (s), got '//str(ctl%tf), err_input)
         return
      end if
      if (.not. ctl%v_max > ctl%v_min) then
         call fatal_error(err, g%where('v_max')//': error: the supply limits are reversed: v_max = '// &
                          str(ctl%v_max)//' must exceed v_min = '//str(ctl%v_min), err_input)
         return
      end if
      call g%get_string('anti_windup', word, err, default='conditional'); if (allocated(err)) return
      select case (to_lower(word))
      case ('conditional'); ctl%anti_windup = aw_conditional
      case ('back_calculation'); ctl%anti_windup = aw_back_calculation
      case ('none'); ctl%anti_windup = aw_none
      case default
         call fatal_error(err, g%where('anti_windup')//": error: unknown anti_windup '"//word// &
                          "'; valid: conditional (default), back_calculation, none", err_input)
         return
      end select
      if (ctl%anti_windup /= aw_back_calculation) return
      call g%get_real('tracking_time', ctl%tracking_time, err); if (allocated(err)) return
      call g%require_positive('tracking_time', ctl%tracking_time, err); if (allocated(err)) return
      if (.not. ctl%ki > 0.0_wp) call fatal_error(err, g%where('anti_windup')//': error: back_calculation '// &
                                                  'needs an integral gain ki > 0, got ki = '//str(ctl%ki), err_input)
   end subroutine read_gains

   !> A positioning sequence: the setpoint's table as steps, the arrival tolerances.
   subroutine read_sequence(g, ctl, err)
      type(deck_group_t), intent(inout) :: g
      type(controller_t), intent(inout) :: ctl
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: word
      if (ctl%kind /= ctl_angle) then
         call fatal_error(err, g%where('sequence')//": error: a positioning sequence needs measure = 'angle'", &
                          err_input)
         return
      end if
      if (.not. allocated(ctl%setpoint%times)) then
         call fatal_error(err, g%where('sequence')//": error: a positioning sequence needs the targets as "// &
                          "kind = 'table' (times and values, or table_file)", err_input)
         return
      end if
      allocate (ctl%seq)
      ctl%seq%t = ctl%setpoint%times
      ctl%seq%target = ctl%setpoint%values
      call g%get_real('tolerance', ctl%seq%tol, err); if (allocated(err)) return
      call g%get_real('speed_tolerance', ctl%seq%speed_tol, err); if (allocated(err)) return
      call g%require_positive('tolerance', ctl%seq%tol, err)
      call g%require_positive('speed_tolerance', ctl%seq%speed_tol, err)
      call check_magnitude(g, 'tolerance', ctl%seq%tol, err); if (allocated(err)) return
      call g%get_string('hold', word, err, default='off'); if (allocated(err)) return
      select case (to_lower(word))
      case ('off'); ctl%servo_hold = .false.
      case ('servo'); ctl%servo_hold = .true.
      case default
         call fatal_error(err, g%where('hold')//": error: unknown hold '"//word//"'; valid: off (default: 0 V, "// &
                          'integral frozen), servo (the loop stays closed on the target)', err_input)
      end select
   end subroutine read_sequence

   !> A sequence's `brake` key: the brake element it commands (engagement 1 while
   !> the sequence holds, else 0).
   subroutine command_brake(g, model, ctl, err)
      type(deck_group_t), intent(inout) :: g
      type(model_t), intent(inout) :: model
      type(controller_t), intent(in) :: ctl
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: bid
      integer :: j
      if (.not. g%has('brake')) return
      call g%get_string('brake', bid, err); if (allocated(err)) return
      do j = 1, size(model%elements)
         if (model%elements(j)%e%id /= bid) cycle
         select type (b => model%elements(j)%e)
         type is (brake_t)
            b%command => ctl%seq
            return
         end select
         call fatal_error(err, g%where('brake')//": error: element '"//bid//"' is of type '"// &
                          model%elements(j)%e%type_name//"'; a sequence commands an element of type 'brake'", err_input)
         return
      end do
      call fatal_error(err, g%where('brake')//": error: the sequence's brake '"//bid//"' is not an element of the "// &
                       'deck', err_input)
   end subroutine command_brake

   !> Append the sequence's positioner element: left port the sensor, right port
   !> the motor (or, when the sensor is the motor, the first other node).
   subroutine add_positioner(g, model, id, ctl, im)
      type(deck_group_t), intent(in) :: g
      type(model_t), intent(inout) :: model
      character(len=*), intent(in) :: id
      type(controller_t), intent(in) :: ctl
      integer, intent(in) :: im
      type(element_slot_t), allocatable :: grown(:)
      integer :: n, j, other
      n = size(model%elements)
      allocate (grown(n + 1))
      do j = 1, n
         call move_alloc(model%elements(j)%e, grown(j)%e)
      end do
      allocate (positioner_t :: grown(n + 1)%e)
      other = im
      if (other == ctl%sensor) other = merge(1, 2, ctl%sensor /= 1)
      select type (p => grown(n + 1)%e)
      type is (positioner_t)
         p%seq => ctl%seq
         p%id = id
         p%type_name = 'positioner'
         p%origin = g%where()
         p%left = ctl%sensor
         p%right = other
      end select
      call move_alloc(grown, model%elements)
   end subroutine add_positioner

   !> After the layout and the &initial groups: each controller's sensor state and
   !> the measurement at the start.
   subroutine link_controllers(model)
      type(model_t), intent(inout) :: model
      integer :: i
      do i = 1, size(model%nodes)
         select type (m => model%nodes(i)%n)
         type is (dc_motor_node_t)
            if (.not. m%controlled) cycle
            associate (s => model%nodes(m%ctl%sensor)%n)
               m%ctl%sensor_state = s%offset + m%ctl%kind
               m%ctl%m0 = merge(s%theta0, s%omega0, m%ctl%kind == ctl_angle)
            end associate
         end select
      end do
   end subroutine link_controllers
end module trainsim_controller_deck
