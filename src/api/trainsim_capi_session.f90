!> The C interface to a run advanced by its caller (include/trainsim.h,
!> "Sessions"; trainsim_session): start a session from a simulation's model,
!> advance it to any later time, read the node angles and speeds, save points
!> and go back to them. The base of the FMU (issue 24). Each `trainsim_sim`
!> holds at most one session; starting again replaces it.
module trainsim_capi_session
   use, intrinsic :: iso_c_binding, only: c_int, c_double, c_size_t, c_ptr, c_associated
   use trainsim, only: error_t, wp, model_t, session_state_t, string_t
   use trainsim_strings, only: str
   use trainsim_capi, only: capi_sim_t, take, finish, misuse, built_model, code_argument, f_string
   implicit none
   private

contains

   !> `int trainsim_session_start(trainsim_sim *, const char *inputs)`: a session of
   !> the handle's model (built now if it is not) at t_start; inputs: the session's
   !> inputs, separated by commas (NULL or "": none): NODE (or NODE.tau) an input
   !> torque, NODE.speed the node's prescribed speed, NODE.voltage a motor's voltage.
   integer(c_int) function trainsim_session_start(p, inputs) result(code) bind(C, name='trainsim_session_start')
      type(c_ptr), value :: p, inputs
      type(capi_sim_t), pointer :: h
      type(model_t) :: model
      type(error_t), allocatable :: err
      type(string_t), allocatable :: ids(:)
      character(len=:), allocatable :: list
      integer :: a, b
      code = code_argument
      if (.not. take(p, h)) return
      call built_model(h, model, err)
      if (.not. allocated(err)) then
         if (.not. allocated(h%session)) allocate (h%session)
         if (allocated(h%saved)) deallocate (h%saved)
         allocate (h%saved(0))
         allocate (ids(0))
         list = ''
         if (c_associated(inputs)) list = f_string(inputs)
         a = 1
         do while (a <= len(list))
            b = index(list(a:), ',')
            if (b == 0) b = len(list) - a + 2
            if (len_trim(adjustl(list(a:a + b - 2))) > 0) ids = [ids, string_t(trim(adjustl(list(a:a + b - 2))))]
            a = a + b
         end do
         call h%session%start(model, err, ids)
      end if
      code = finish(h, err)
   end function trainsim_session_start

   !> `int trainsim_session_advance(trainsim_sim *, double t)`: advance the session
   !> to t (between the time reached and t_end).
   integer(c_int) function trainsim_session_advance(p, t) result(code) bind(C, name='trainsim_session_advance')
      type(c_ptr), value :: p
      real(c_double), value :: t
      type(capi_sim_t), pointer :: h
      type(error_t), allocatable :: err
      code = code_argument
      if (.not. live(p, h, code)) return
      call h%session%advance(real(t, wp), err)
      code = finish(h, err)
   end function trainsim_session_advance

   !> `int trainsim_session_set_torque(trainsim_sim *, const char *node, double value)`:
   !> the input torque on `node` (one of the session's inputs) from now on.
   integer(c_int) function trainsim_session_set_torque(p, node, value) result(code) &
      bind(C, name='trainsim_session_set_torque')
      type(c_ptr), value :: p, node
      real(c_double), value :: value
      code = set_input(p, node, value, '.tau', 'trainsim_session_set_torque')
   end function trainsim_session_set_torque

   !> `int trainsim_session_set_input(trainsim_sim *, const char *name, double value)`:
   !> the input `name` (NODE.tau or NODE, NODE.speed, NODE.voltage; one of the
   !> session's inputs) from now on.
   integer(c_int) function trainsim_session_set_input(p, name, value) result(code) &
      bind(C, name='trainsim_session_set_input')
      type(c_ptr), value :: p, name
      real(c_double), value :: value
      code = set_input(p, name, value, '', 'trainsim_session_set_input')
   end function trainsim_session_set_input

   !> The session's input name//suffix set to value.
   integer(c_int) function set_input(p, name, value, suffix, what) result(code)
      type(c_ptr), value :: p, name
      real(c_double), value :: value
      character(len=*), intent(in) :: suffix, what
      type(capi_sim_t), pointer :: h
      type(error_t), allocatable :: err
      code = code_argument
      if (.not. live(p, h, code)) return
      if (.not. c_associated(name)) then
         code = misuse(h, what//': the name is NULL')
         return
      end if
      call h%session%set_input(f_string(name)//suffix, real(value, wp), err)
      code = finish(h, err)
   end function set_input

   !> `int trainsim_session_state(trainsim_sim *, double *t, double *theta, double
   !> *omega, size_t n)`: the time reached and every node's angle and speed (n: the
   !> node count, trainsim_count(TRAINSIM_NODES)).
   integer(c_int) function trainsim_session_state(p, t, theta, omega, n) result(code) &
      bind(C, name='trainsim_session_state')
      type(c_ptr), value :: p
      real(c_double), intent(out) :: t
      integer(c_size_t), value :: n
      real(c_double), intent(out) :: theta(n), omega(n)
      type(capi_sim_t), pointer :: h
      code = code_argument
      if (.not. live(p, h, code)) return
      if (n /= size(h%session%model%nodes, kind=c_size_t)) then
         code = misuse(h, 'trainsim_session_state: n is not the node count')
         return
      end if
      call h%session%kinematics()
      t = real(h%session%t, c_double)
      theta = real(h%session%model%theta, c_double)
      omega = real(h%session%model%omega, c_double)
      code = 0
   end function trainsim_session_state

   !> `int trainsim_session_elements(trainsim_sim *, double *disp, double *force, double
   !> *contact, size_t n)`: every element's displacement, force (or torque) and contact
   !> state at the session's point, as a run records them (n: TRAINSIM_ELEMENTS count).
   integer(c_int) function trainsim_session_elements(p, disp, force, contact, n) result(code) &
      bind(C, name='trainsim_session_elements')
      type(c_ptr), value :: p
      integer(c_size_t), value :: n
      real(c_double), intent(out) :: disp(n), force(n), contact(n)
      type(capi_sim_t), pointer :: h
      real(wp), allocatable :: d(:), f(:)
      integer, allocatable :: c(:)
      code = code_argument
      if (.not. live(p, h, code)) return
      if (n /= size(h%session%model%elements, kind=c_size_t)) then
         code = misuse(h, 'trainsim_session_elements: n is not the element count')
         return
      end if
      allocate (d(n), f(n), c(n))
      call h%session%element_status(d, f, c)
      disp = real(d, c_double)
      force = real(f, c_double)
      contact = real(c, c_double)
      code = 0
   end function trainsim_session_elements

   !> `int trainsim_session_save(trainsim_sim *, int *point)`: save the session's
   !> point (time, state, modes); `point` numbers it for `trainsim_session_restore`.
   integer(c_int) function trainsim_session_save(p, point) result(code) bind(C, name='trainsim_session_save')
      type(c_ptr), value :: p
      integer(c_int), intent(out) :: point
      type(capi_sim_t), pointer :: h
      type(session_state_t) :: st
      type(error_t), allocatable :: err
      point = -1
      code = code_argument
      if (.not. live(p, h, code)) return
      call h%session%save(st, err)
      if (.not. allocated(err)) then
         h%saved = [h%saved, st]
         point = int(size(h%saved) - 1, c_int)
      end if
      code = finish(h, err)
   end function trainsim_session_save

   !> `int trainsim_session_restore(trainsim_sim *, int point)`: go back (or
   !> forward) to a saved point; the run continues from there bit for bit as it
   !> did the first time.
   integer(c_int) function trainsim_session_restore(p, point) result(code) bind(C, name='trainsim_session_restore')
      type(c_ptr), value :: p
      integer(c_int), value :: point
      type(capi_sim_t), pointer :: h
      type(error_t), allocatable :: err
      code = code_argument
      if (.not. live(p, h, code)) return
      if (point < 0 .or. point >= size(h%saved)) then
         code = misuse(h, 'trainsim_session_restore: no saved point '//str(int(point)))
         return
      end if
      call h%session%restore(h%saved(point + 1), err)
      code = finish(h, err)
   end function trainsim_session_restore

   !> The handle behind p with a started session (else code: a misuse).
   logical function live(p, h, code)
      type(c_ptr), intent(in) :: p
      type(capi_sim_t), pointer, intent(out) :: h
      integer(c_int), intent(inout) :: code
      live = take(p, h)
      if (.not. live) return
      live = allocated(h%session)
      if (live) live = h%session%started
      if (.not. live) code = misuse(h, 'no session: call trainsim_session_start first')
   end function live

end module trainsim_capi_session
