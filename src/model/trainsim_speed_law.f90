!> How a torque load depends on its node's speed (docs/deck.md, "Loads that
!> depend on speed"; D-79): T = s(t) g(omega), s the load's time function and g
!> one of the laws below, after the Modelica Standard Library's
!> Rotational.Sources (tau_nominal = s(t), w_nominal = w_ref):
!>   linear        g = w/w_ref               (LinearSpeedDependentTorque, TorqueDirection = false)
!>   linear_abs    g = |w|/w_ref             (LinearSpeedDependentTorque, TorqueDirection = true)
!>   quadratic     g = (w/w_ref) |w/w_ref|   (QuadraticSpeedDependentTorque, TorqueDirection = false)
!>   quadratic_abs g = (w/w_ref)^2           (QuadraticSpeedDependentTorque, TorqueDirection = true)
!>   sign          g = w/w_ref for |w| < w_ref, sign(w) beyond (SignTorque, reg = Linear, w0 = w_ref)
!>   table         g = the piecewise-linear table of torque against speed, its end values beyond
!> A negative s(t) brakes (a load) where g > 0. The RHS asks `factor` and the
!> Jacobian `slope` = dg/dw; both are pure and allocate nothing.
module trainsim_speed_law
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: to_lower, str
   use trainsim_deck, only: deck_group_t
   use trainsim_limits, only: check_magnitude
   use trainsim_signal, only: signal_t, table_from_group, signal_from_group, constant_signal
   implicit none
   private

   public :: speed_law_t, speed_law_from_group, law_none, law_table, load_t, load_from_group

   integer, parameter :: law_none = 0, law_linear = 1, law_linear_abs = 2, law_quadratic = 3, &
                         law_quadratic_abs = 4, law_sign = 5, law_table = 6
   character(len=*), parameter :: law_names = 'linear, linear_abs, quadratic, quadratic_abs, sign, table'

   type :: speed_law_t
      integer :: kind = law_none
      real(wp) :: w_ref = 1.0_wp                 !< w_nominal, or the sign law's regularisation speed
      type(signal_t) :: curve                    !< the table law's torque against speed
   contains
      procedure :: factor => law_factor
      procedure :: slope => law_slope
   end type speed_law_t

   !> An external torque on a node: torque(t), or torque(t) g(omega) with a speed law.
   type :: load_t
      integer :: node = 0
      type(signal_t) :: torque
      type(speed_law_t) :: law
   contains
      procedure :: at => load_at
      procedure :: slope => load_slope
   end type load_t

contains

   !> The load's torque at t on a node turning at w.
   pure real(wp) function load_at(self, t, w) result(v)
      class(load_t), intent(in) :: self
      real(wp), intent(in) :: t, w
      if (self%law%kind == law_none) then
         v = self%torque%value(t)
      else
         v = self%torque%value(t)*self%law%factor(w)
      end if
   end function load_at

   !> d(load torque)/d w at t and w (its Jacobian entry).
   pure real(wp) function load_slope(self, t, w) result(d)
      class(load_t), intent(in) :: self
      real(wp), intent(in) :: t, w
      d = self%torque%value(t)*self%law%slope(w)
   end function load_slope

   !> A torque load on node `inode` from a &load group: its time function and,
   !> with `speed_law`, its law. A table law without `kind` and `value` takes the
   !> table's torques as they stand (s = 1).
   subroutine load_from_group(grp, inode, load, err)
      type(deck_group_t), intent(inout) :: grp
      integer, intent(in) :: inode
      type(load_t), intent(out) :: load
      type(error_t), allocatable, intent(out) :: err
      logical :: scaled
      load%node = inode
      if (grp%has('speed_law')) then
         call speed_law_from_group(grp, load%law, err); if (allocated(err)) return
      end if
      scaled = grp%holds('kind')
      if (.not. scaled) scaled = grp%holds('value')
      if (load%law%kind == law_table .and. .not. scaled) then
         load%torque = constant_signal(1.0_wp)
      else
         call signal_from_group(grp, load%torque, err)
      end if
   end subroutine load_from_group

   !> Read `speed_law` and its keys from a &load group (quantity 'torque').
   subroutine speed_law_from_group(grp, law, err)
      type(deck_group_t), intent(inout) :: grp
      type(speed_law_t), intent(out) :: law
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: name
      character(len=:), allocatable :: key
      call grp%get_string('speed_law', name, err); if (allocated(err)) return
      select case (to_lower(name))
      case ('linear'); law%kind = law_linear
      case ('linear_abs'); law%kind = law_linear_abs
      case ('quadratic'); law%kind = law_quadratic
      case ('quadratic_abs'); law%kind = law_quadratic_abs
      case ('sign'); law%kind = law_sign
      case ('table'); law%kind = law_table
      case default
         call fatal_error(err, grp%where('speed_law')//": error: unknown speed_law '"//name// &
                          "'; valid speed laws are: "//law_names, err_input)
         return
      end select
      if (law%kind == law_table) then
         call table_from_group(grp, 'speeds', 'torques', 'speed_table_file', law%curve, err)
         return
      end if
      key = merge('w_reg    ', 'w_nominal', law%kind == law_sign)
      key = trim(key)
      call grp%get_real(key, law%w_ref, err); if (allocated(err)) return
      call check_magnitude(grp, key, law%w_ref, err); if (allocated(err)) return
      if (.not. law%w_ref > 0.0_wp) then
         call fatal_error(err, grp%where(key)//': error: '//key//' must be > 0 rad/s, got '//str(law%w_ref), &
                          err_input)
         return
      end if
   end subroutine speed_law_from_group

   !> g(w): the factor of the load's time function at speed w.
   pure real(wp) function law_factor(self, w) result(g)
      class(speed_law_t), intent(in) :: self
      real(wp), intent(in) :: w
      real(wp) :: x
      x = w/self%w_ref
      select case (self%kind)
      case (law_linear); g = x
      case (law_linear_abs); g = abs(x)
      case (law_quadratic); g = x*abs(x)
      case (law_quadratic_abs); g = x*x
      case (law_sign); g = max(-1.0_wp, min(1.0_wp, x))
      case (law_table); g = self%curve%value(w)
      case default; g = 1.0_wp
      end select
   end function law_factor

   !> dg/dw at w (the right derivative at a table's knot; 0 where g is flat;
   !> at w = 0, linear_abs takes 0, the mean of its one-sided slopes).
   pure real(wp) function law_slope(self, w) result(d)
      class(speed_law_t), intent(in) :: self
      real(wp), intent(in) :: w
      select case (self%kind)
      case (law_linear); d = 1.0_wp/self%w_ref
      case (law_linear_abs); d = sign(1.0_wp, w)/self%w_ref
         if (w == 0.0_wp) d = 0.0_wp
      case (law_quadratic); d = 2.0_wp*abs(w)/self%w_ref**2
      case (law_quadratic_abs); d = 2.0_wp*w/self%w_ref**2
      case (law_sign)
         d = 0.0_wp
         if (abs(w) < self%w_ref) d = 1.0_wp/self%w_ref
      case (law_table); d = self%curve%derivative(w)
      case default; d = 0.0_wp
      end select
   end function law_slope
end module trainsim_speed_law
