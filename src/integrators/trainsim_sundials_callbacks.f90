!> What SUNDIALS calls back (trainsim_sundials): the right-hand side, the Jacobian, the
!> guards as root functions, the error weights and the error handler, `bind(C)` and
!> returning 0 on success, with the model recovered from the user data (`cv_user_t`);
!> and the tolerances and default maximum step the set-up gives the solver (D-50).
module trainsim_sundials_callbacks
   use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_char, c_null_char, c_f_pointer, &
                                          c_associated, c_loc
   use fsundials_nvector_mod, only: N_Vector, FN_VGetArrayPointer
   use fsundials_matrix_mod, only: SUNMatrix
   use fsunmatrix_dense_mod, only: FSUNDenseMatrix_Data
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_modes, only: modes_t, compute_modes
   implicit none
   private

   public :: cv_user_t, cv_rhs, cv_jac, cv_roots, cv_error_handler, cv_ewt
   public :: cvode_max_step, cvode_abstol, cvode_weights

   !> The node angle that rtol is relative to (D-50), in rad: a node angle's
   !> tolerance is rtol*angle_resolution + atol_angle, whatever the angle
   !> itself (how far a node has turned is no measure of what matters: the
   !> deformations across the elements, and a gear's position in its mesh
   !> cycle, are). 1e-5 rad is 1 um at a 0.1 m radius, the order of a mesh
   !> deflection's resolution; the smallest static deflections and clearances
   !> of the bundled trains are 1e-4 to 1e-3 rad.
   real(wp), parameter, public :: angle_resolution = 1.0e-5_wp
   !> Part of |angle| added to an angle's tolerance: 10 units of rounding, so
   !> that a tight rtol never asks an angle of several rad for more digits than
   !> double precision holds (SUNDIALS's "too much accuracy" test is 1 unit).
   real(wp), parameter :: angle_rounding = 10.0_wp*epsilon(1.0_wp)
   !> Fraction of the period of the highest linearised mode (clearances closed)
   !> used as the default maximum step.
   real(wp), parameter :: max_step_fraction = 0.1_wp
   !> Floor of the absolute tolerance of the energy-accounting states, per unit of 1 + E0.
   real(wp), parameter :: energy_atol_factor = 1.0e-6_wp

   !> What the callbacks see (user data): the caller's model and a few
   !> diagnostics written without allocation.
   type :: cv_user_t
      type(model_t), pointer :: model => null()
      integer :: ng = 0
      integer :: bad_state = 0            !< first state whose derivative was NaN
      real(wp) :: bad_t = 0.0_wp          !< time of that evaluation
      integer :: msg_len = 0
      character(len=512) :: msg = ''      !< last message SUNDIALS reported
      !> the error weights (cv_ewt, D-50): 1/(rel_i |y_i| + fixed_i); rel_i is
      !> rtol, or angle_rounding for a node angle (its tolerance does not grow
      !> with how far it turned, but for the angle's own rounding)
      real(wp), allocatable :: rel(:), fixed(:)
   end type cv_user_t

contains

   !> dy/dt for CVODE and ERKStep (same signature): model%rhs on the SUNDIALS
   !> vectors. 1 (recoverable) on NaN.
   integer(c_int) function cv_rhs(tn, sunvec_y, sunvec_f, user_data) result(ierr) bind(C)
      real(c_double), value :: tn
      type(N_Vector) :: sunvec_y, sunvec_f
      type(c_ptr), value :: user_data
      type(cv_user_t), pointer :: ud
      real(c_double), pointer :: yv(:), fv(:)
      integer :: i
      call c_f_pointer(user_data, ud)
      yv => FN_VGetArrayPointer(sunvec_y)
      fv => FN_VGetArrayPointer(sunvec_f)
      call ud%model%rhs(tn, yv, fv)
      ierr = 0
      do i = 1, size(fv)
         if (fv(i) /= fv(i)) then
            if (ud%bad_state == 0) then
               ud%bad_state = i
               ud%bad_t = tn
            end if
            ierr = 1
            return
         end if
      end do
   end function cv_rhs

   !> Dense Jacobian for CVODE BDF's Newton iteration: model%jacobian written
   !> straight into the SUNDIALS matrix (column-major, no copy, no allocation).
   integer(c_int) function cv_jac(tn, sunvec_y, sunvec_f, sunmat_j, user_data, tmp1, tmp2, tmp3) &
      result(ierr) bind(C)
      real(c_double), value :: tn
      type(N_Vector) :: sunvec_y, sunvec_f, tmp1, tmp2, tmp3
      type(SUNMatrix) :: sunmat_j
      type(c_ptr), value :: user_data
      type(cv_user_t), pointer :: ud
      real(c_double), pointer :: yv(:), jflat(:), jac(:, :)
      integer :: n
      call c_f_pointer(user_data, ud)
      yv => FN_VGetArrayPointer(sunvec_y)
      jflat => FSUNDenseMatrix_Data(sunmat_j)
      n = size(yv)
      call c_f_pointer(c_loc(jflat(1)), jac, [n, n])
      call ud%model%jacobian(tn, yv, jac)
      ierr = 0
      associate (u1 => sunvec_f, u2 => tmp1, u3 => tmp2, u4 => tmp3)   ! unused by this Jacobian
      end associate
   end function cv_jac

   !> The guards as root functions (CVODE and ERKStep alike).
   integer(c_int) function cv_roots(tn, sunvec_y, gout, user_data) result(ierr) bind(C)
      real(c_double), value :: tn
      type(N_Vector) :: sunvec_y
      real(c_double) :: gout(*)
      type(c_ptr), value :: user_data
      type(cv_user_t), pointer :: ud
      real(c_double), pointer :: yv(:)
      call c_f_pointer(user_data, ud)
      yv => FN_VGetArrayPointer(sunvec_y)
      call ud%model%guards(tn, yv, gout(1:ud%ng))
      ierr = 0
   end function cv_roots

   !> The error weights for CVODE's and ERKStep's error test and iterations
   !> (CVodeWFtolerances, ERKStepWFtolerances; D-50): w_i = 1/(rtol |y_i| + atol_i)
   !> for speeds, currents and energies as with SVtolerances, w_i = 1/(rtol
   !> angle_resolution + atol_i) for node angles (cvode_weights). No allocation.
   integer(c_int) function cv_ewt(sunvec_y, sunvec_ewt, user_data) result(ierr) bind(C)
      type(N_Vector) :: sunvec_y, sunvec_ewt
      type(c_ptr), value :: user_data
      type(cv_user_t), pointer :: ud
      real(c_double), pointer :: yv(:), w(:)
      integer :: i
      call c_f_pointer(user_data, ud)
      yv => FN_VGetArrayPointer(sunvec_y)
      w => FN_VGetArrayPointer(sunvec_ewt)
      do i = 1, size(w)
         w(i) = 1.0_wp/(ud%rel(i)*abs(yv(i)) + ud%fixed(i))
      end do
      ierr = 0
   end function cv_ewt

   !> CVODE's and ARKODE's error and warning messages: kept (the last one) for
   !> our own message instead of being printed to stderr.
   subroutine cv_error_handler(error_code, module, function, msg, user_data) bind(C)
      integer(c_int), value :: error_code
      type(c_ptr), value :: module, function, msg, user_data
      type(cv_user_t), pointer :: ud
      character(kind=c_char), pointer :: text(:)
      integer :: i
      if (error_code > 0) return    ! warnings (e.g. t + h = t) are not kept
      associate (u1 => module, u2 => function)
      end associate
      if (.not. (c_associated(user_data) .and. c_associated(msg))) return
      call c_f_pointer(user_data, ud)
      call c_f_pointer(msg, text, [len(ud%msg)])
      ud%msg_len = 0
      do i = 1, len(ud%msg)
         if (text(i) == c_null_char) exit
         ud%msg(i:i) = text(i)
         ud%msg_len = i
      end do
   end subroutine cv_error_handler

   !> Maximum step CVODE may take: run%max_step if > 0, else a tenth of the
   !> period of the highest linearised mode with every clearance closed
   !> (0: no bound, when the train has no elastic mode).
   subroutine cvode_max_step(model, hmax, omega_max)
      type(model_t), intent(in) :: model
      real(wp), intent(out) :: hmax, omega_max
      type(model_t) :: tmp
      type(modes_t) :: modes
      type(error_t), allocatable :: err
      omega_max = 0.0_wp
      tmp = model
      call compute_modes(tmp, modes, err, closed=.true.)
      if (.not. allocated(err)) omega_max = modes%omega_max
      if (model%run%max_step > 0.0_wp) then
         hmax = model%run%max_step
      else if (omega_max > 0.0_wp) then
         hmax = max_step_fraction*two_pi/omega_max
      else
         hmax = 0.0_wp
      end if
   end subroutine cvode_max_step

   !> Absolute tolerance of each state: node angles atol_angle, speeds
   !> atol_speed, a motor's current (third state) atol_current; the two
   !> energy-accounting states max(rtol, 1e-6)*(1 + |E0|) (loose: they are
   !> diagnostics, and must not set the step at tight rtol). E0 is the stored
   !> energy at t_start (set by model%init_modes).
   subroutine cvode_abstol(model, atol)
      type(model_t), intent(in) :: model
      real(wp), intent(out) :: atol(:)
      integer :: i, o, ns
      atol = model%run%atol_speed
      do i = 1, size(model%nodes)
         if (model%speed_of(i) /= 0) cycle
         ns = model%nodes(i)%n%nstates()
         o = model%nodes(i)%n%offset
         if (ns >= 1) atol(o + 1) = model%run%atol_angle
         if (ns >= 2) atol(o + 2) = model%run%atol_speed
         if (ns >= 3) atol(o + 3:o + ns) = model%run%atol_current
      end do
      if (model%run%track_energy) atol(model%n_states + 1:model%n_states + 2) = &
         max(model%run%rtol, energy_atol_factor)*(1.0_wp + abs(model%energy0))
   end subroutine cvode_abstol

   !> The error weights' parts (cv_ewt, D-50): rel = angle_rounding and fixed =
   !> rtol angle_resolution + atol_angle for each node angle, rel = rtol and
   !> fixed = atol (cvode_abstol) for the other states.
   pure subroutine cvode_weights(model, atol, rel, fixed)
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: atol(:)
      real(wp), intent(out) :: rel(:), fixed(:)
      integer :: i, o
      rel = model%run%rtol
      fixed = atol
      do i = 1, size(model%nodes)
         if (model%speed_of(i) /= 0) cycle
         if (model%nodes(i)%n%nstates() < 1) cycle
         o = model%nodes(i)%n%offset
         rel(o + 1) = angle_rounding
         fixed(o + 1) = model%run%rtol*angle_resolution + atol(o + 1)
      end do
   end subroutine cvode_weights
end module trainsim_sundials_callbacks
