!> A node's prescribed motion (docs/deck.md, "&load"): its speed, its angle or
!> its acceleration given as a function of time, the other two from the given
!> one's derivatives or exact integrals (D-78). The node's angle is
!> theta0 + `integral`(t): theta0 is its &initial angle (for a prescribed angle
!> the builder makes it default to the function's value at t = 0).
module trainsim_motion
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_deck, only: deck_group_t
   use trainsim_signal, only: signal_t
   implicit none
   private

   public :: motion_t, motion_of, motion_from_group
   !> What the time function gives: the angle, the speed or the acceleration.
   integer, parameter, public :: given_angle = 0, given_speed = 1, given_accel = 2

   type :: motion_t
      type(signal_t) :: f                        !< the deck's time function
      integer :: given = given_speed
      character(len=:), allocatable :: label     !< f's kind; 'angle: ...', 'acceleration: ...' otherwise
      real(wp) :: w0 = 0.0_wp                    !< a prescribed acceleration's speed at t = 0
   contains
      procedure :: value => motion_speed
      procedure :: integral => motion_angle_change
      procedure :: derivative => motion_acceleration
      procedure :: breakpoints => motion_breakpoints
      procedure :: is_constant => motion_is_constant
      generic :: assignment(=) => from_signal
      procedure, private :: from_signal => motion_from_signal
   end type motion_t

contains

   !> A prescribed motion of the given kind from its time function.
   function motion_of(f, given) result(m)
      type(signal_t), intent(in) :: f
      integer, intent(in) :: given
      type(motion_t) :: m
      m%f = f
      m%given = given
      select case (given)
      case (given_angle); m%label = 'angle: '//f%label
      case (given_accel); m%label = 'acceleration: '//f%label
      case default; m%label = f%label
      end select
   end function motion_of

   !> The motion of a &load group's `quantity` ('speed', 'angle', 'acceleration')
   !> with time function f. A prescribed angle takes the kinds constant and sine
   !> only (D-78): a piecewise-linear angle's speed would jump at its knots.
   subroutine motion_from_group(grp, quantity, f, m, err)
      type(deck_group_t), intent(in) :: grp
      character(len=*), intent(in) :: quantity
      type(signal_t), intent(in) :: f
      type(motion_t), intent(out) :: m
      type(error_t), allocatable, intent(out) :: err
      select case (quantity)
      case ('angle')
         if (f%label /= 'constant' .and. f%label /= 'sine') then
            call fatal_error(err, grp%where('kind')//": error: a prescribed angle of kind '"//f%label// &
                             "' would jump in speed at its knots; valid kinds for quantity = 'angle' "// &
                             "are: constant, sine (a table of speeds: quantity = 'speed')", err_input)
            return
         end if
         m = motion_of(f, given_angle)
      case ('acceleration')
         m = motion_of(f, given_accel)
      case default
         m = motion_of(f, given_speed)
      end select
   end subroutine motion_from_group

   !> `motion = signal`: a prescribed speed.
   subroutine motion_from_signal(self, f)
      class(motion_t), intent(out) :: self
      type(signal_t), intent(in) :: f
      self%f = f
      self%given = given_speed
      self%label = f%label
      self%w0 = 0.0_wp
   end subroutine motion_from_signal

   !> Speed at t.
   pure real(wp) function motion_speed(self, t) result(w)
      class(motion_t), intent(in) :: self
      real(wp), intent(in) :: t
      select case (self%given)
      case (given_speed); w = self%f%value(t)
      case (given_angle); w = self%f%derivative(t)
      case default; w = self%w0 + self%f%integral(t)
      end select
   end function motion_speed

   !> Angle at t minus the angle at 0 (the integral of the speed from 0 to t).
   pure real(wp) function motion_angle_change(self, t) result(a)
      class(motion_t), intent(in) :: self
      real(wp), intent(in) :: t
      select case (self%given)
      case (given_speed); a = self%f%integral(t)
      case (given_angle); a = self%f%value(t) - self%f%value(0.0_wp)
      case default; a = self%w0*t + self%f%integral2(t)
      end select
   end function motion_angle_change

   !> Acceleration at t (right derivative where the speed's slope jumps).
   pure real(wp) function motion_acceleration(self, t) result(a)
      class(motion_t), intent(in) :: self
      real(wp), intent(in) :: t
      select case (self%given)
      case (given_speed); a = self%f%derivative(t)
      case (given_angle); a = self%f%derivative2(t)
      case default; a = self%f%value(t)
      end select
   end function motion_acceleration

   !> Whether the speed is the same at every t (then `value`(0) is it).
   pure logical function motion_is_constant(self) result(c)
      class(motion_t), intent(in) :: self
      c = self%f%is_constant()
      if (self%given == given_accel) c = c .and. self%f%value0 == 0.0_wp
   end function motion_is_constant

   !> Times where the time function or its slope jumps.
   pure subroutine motion_breakpoints(self, bp)
      class(motion_t), intent(in) :: self
      real(wp), allocatable, intent(out) :: bp(:)
      call self%f%breakpoints(bp)
   end subroutine motion_breakpoints
end module trainsim_motion
