!> A feedback controller for a DC motor's armature voltage, and the positioning
!> sequence it may run (docs/elements.md, "controller"; docs/deck.md, &controller).
!>
!> The controller measures one node's angle or speed m (the sensor: any node with
!> states, before or after a clearance) and sets the motor's voltage
!>   u = kp e + ki z + ud,   e = r(t) - m,
!>   ud = -kd (m - f)/tf     (the derivative of the measurement through a first-order
!>                            filter of time constant tf: -kd s/(tf s + 1) m)
!>   z' = e                  (the integral of the error; see anti-windup)
!>   f' = (m - f)/tf         (the filter's state)
!> then bounds it: v = min(max(u, lo), hi) with the supply limits [v_min, v_max] and,
!> with a current limit i_max, lo = k_e w - R i_max, hi = k_e w + R i_max (w the
!> motor's speed): at v = hi the armature obeys L i' = R (i_max - i), so a current
!> below i_max stays below it (the limit of an ideal current loop). z and f are
!> states 4 and 5 of the motor.
!> Anti-windup: 'conditional' (z' = 0 while v /= u and e drives u further past
!> the bound), 'back_calculation' (z' = e + (v - u)/(ki t_t)) or 'none'.
!> A sequence (the setpoint's table read as steps, target k from time t_k) holds
!> the motor at 0 V (armature shorted) with z frozen (or, with `hold = 'servo'`,
!> keeps the loop closed on target k) from the moment the sensor is within
!> `tolerance` of target k and slower than `speed_tolerance` (the positioner
!> element's guard locates it) until t_{k+1}; its brake command is that hold.
module trainsim_controller
   use trainsim_kinds, only: wp
   use trainsim_signal, only: signal_t
   implicit none
   private

   public :: controller_t, sequence_t, sequence_holds
   public :: ctl_speed, ctl_angle, aw_none, aw_conditional, aw_back_calculation, ctl_nstates

   integer, parameter :: ctl_angle = 1, ctl_speed = 2   !< which sensor state: y(offset + kind)
   integer, parameter :: aw_none = 0, aw_conditional = 1, aw_back_calculation = 2
   integer, parameter :: ctl_nstates = 2                !< z (integral) and f (derivative filter)

   !> The positioning sequence's targets and its progress (shared by the motor's
   !> controller, which reads it, and the positioner element, which advances it at
   !> its events).
   type :: sequence_t
      real(wp), allocatable :: t(:), target(:)   !< target(k) holds from t(k) to t(k+1)
      real(wp) :: tol = 0.0_wp, speed_tol = 0.0_wp
      integer :: reached = 0                     !< the last slot whose target was reached
   end type sequence_t

   type :: controller_t
      integer :: kind = ctl_speed
      integer :: sensor = 0                  !< node index of the sensor
      integer :: sensor_state = 0            !< y(sensor_state) is the measured quantity
      real(wp) :: kp = 0.0_wp, ki = 0.0_wp, kd = 0.0_wp, tf = 0.0_wp
      real(wp) :: v_min = -huge(1.0_wp), v_max = huge(1.0_wp), i_max = 0.0_wp   !< i_max = 0: none
      integer :: anti_windup = aw_conditional
      real(wp) :: tracking_time = 0.0_wp
      real(wp) :: m0 = 0.0_wp                !< the measurement at the start (f's initial value)
      logical :: servo_hold = .false.        !< hold by the loop (true) or at 0 V (false, the default)
      type(signal_t) :: setpoint
      type(sequence_t), pointer :: seq => null()
   contains
      procedure :: law => ctl_law
      procedure :: held => ctl_held
      procedure :: rates => ctl_rates
      procedure :: jacobian => ctl_jacobian
   end type controller_t

contains

   !> Whether the sequence holds the motor at t (brake command on).
   pure logical function ctl_held(self, t) result(h)
      class(controller_t), intent(in) :: self
      real(wp), intent(in) :: t
      h = .false.
      if (.not. associated(self%seq)) return
      h = sequence_holds(self%seq, t)
   end function ctl_held

   !> The controller at (t, y): the error e, the unbounded output u, the voltage v
   !> and which bound is active (0 none, +1 upper, -1 lower; 2 held by the sequence).
   !> o is the motor's offset, r_arm, k_e its resistance and back-emf constant.
   pure subroutine ctl_law(self, t, y, o, r_arm, k_e, e, u, v, bound)
      class(controller_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:), r_arm, k_e
      integer, intent(in) :: o
      real(wp), intent(out) :: e, u, v
      integer, intent(out) :: bound
      real(wp) :: m, lo, hi
      integer :: k
      m = y(self%sensor_state)
      if (associated(self%seq)) then
         k = max(1, slot_at(self%seq%t, t))
         e = self%seq%target(k) - m
      else
         e = self%setpoint%value(t) - m
      end if
      u = self%kp*e + self%ki*y(o + 4)
      if (self%kd > 0.0_wp) u = u - self%kd*(m - y(o + 5))/self%tf
      lo = self%v_min
      hi = self%v_max
      if (self%i_max > 0.0_wp) then
         lo = max(lo, k_e*y(o + 2) - r_arm*self%i_max)
         hi = min(hi, k_e*y(o + 2) + r_arm*self%i_max)
      end if
      bound = 0
      v = u
      if (v < lo) then
         v = lo; bound = -1
      end if
      if (v > hi) then
         v = hi; bound = 1
      end if
      if (self%held(t) .and. .not. self%servo_hold) then
         v = 0.0_wp; bound = 2
      end if
   end subroutine ctl_law

   !> z' and f' (the controller's states, y(o+4) and y(o+5)) into dydt.
   pure subroutine ctl_rates(self, t, y, o, e, u, v, bound, dydt)
      class(controller_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:), e, u, v
      integer, intent(in) :: o, bound
      real(wp), intent(inout) :: dydt(:)
      associate (unused => t)
      end associate
      dydt(o + 4) = e
      if (bound == 2) then
         dydt(o + 4) = 0.0_wp
      else if (self%anti_windup == aw_conditional .and. bound /= 0) then
         if (e*(u - v) > 0.0_wp) dydt(o + 4) = 0.0_wp
      else if (self%anti_windup == aw_back_calculation) then
         dydt(o + 4) = e + (v - u)/(self%ki*self%tracking_time)
      end if
      dydt(o + 5) = 0.0_wp
      if (self%kd > 0.0_wp) dydt(o + 5) = (y(self%sensor_state) - y(o + 5))/self%tf
   end subroutine ctl_rates

   !> Add the controller's part of d(dydt)/dy to jac: the voltage's partials in the
   !> current's row (divided by the inductance l) and the rows of z and f.
   pure subroutine ctl_jacobian(self, t, y, o, r_arm, k_e, l, jac)
      class(controller_t), intent(in) :: self
      real(wp), intent(in) :: t, y(:), r_arm, k_e, l
      integer, intent(in) :: o
      real(wp), intent(inout) :: jac(:, :)
      real(wp) :: e, u, v, du_dm, dz_du
      integer :: bound, s
      call self%law(t, y, o, r_arm, k_e, e, u, v, bound)
      s = self%sensor_state
      du_dm = -self%kp
      if (self%kd > 0.0_wp) du_dm = du_dm - self%kd/self%tf
      if (bound == 0) then                        ! v = u
         jac(o + 3, s) = jac(o + 3, s) + du_dm/l
         jac(o + 3, o + 4) = jac(o + 3, o + 4) + self%ki/l
         if (self%kd > 0.0_wp) jac(o + 3, o + 5) = jac(o + 3, o + 5) + self%kd/self%tf/l
      else if (abs(bound) == 1 .and. self%i_max > 0.0_wp) then   ! v on a bound: on the current limit's, k_e w
         if (abs(v - (k_e*y(o + 2) + real(bound, wp)*r_arm*self%i_max)) == 0.0_wp) &
            jac(o + 3, o + 2) = jac(o + 3, o + 2) + k_e/l
      end if
      ! the integral's row: z' = e (de/dm = -1), frozen, or back-calculated
      if (bound == 2) then
         continue
      else if (self%anti_windup == aw_back_calculation) then
         dz_du = 1.0_wp/(self%ki*self%tracking_time)
         jac(o + 4, s) = jac(o + 4, s) - 1.0_wp
         if (bound /= 0) then                     ! z' = e + (v - u)/(ki t_t), v fixed by the bound
            jac(o + 4, s) = jac(o + 4, s) - dz_du*du_dm
            jac(o + 4, o + 4) = jac(o + 4, o + 4) - dz_du*self%ki
            if (self%kd > 0.0_wp) jac(o + 4, o + 5) = jac(o + 4, o + 5) - dz_du*self%kd/self%tf
         end if
      else if (.not. (self%anti_windup == aw_conditional .and. bound /= 0 .and. e*(u - v) > 0.0_wp)) then
         jac(o + 4, s) = jac(o + 4, s) - 1.0_wp
      end if
      if (self%kd > 0.0_wp) then
         jac(o + 5, s) = jac(o + 5, s) + 1.0_wp/self%tf
         jac(o + 5, o + 5) = jac(o + 5, o + 5) - 1.0_wp/self%tf
      end if
   end subroutine ctl_jacobian

   !> Whether the sequence holds at t (its brake command): the slot of t reached.
   pure logical function sequence_holds(seq, t) result(h)
      type(sequence_t), intent(in) :: seq
      real(wp), intent(in) :: t
      h = seq%reached >= slot_at(seq%t, t)
   end function sequence_holds

   !> The slot of the sequence at t: the last k with times(k) <= t (0 before the first).
   pure integer function slot_at(times, t) result(i)
      real(wp), intent(in) :: times(:), t
      integer :: lo, hi, mid
      i = 0
      if (size(times) == 0) return
      if (t < times(1)) return
      lo = 1; hi = size(times)
      do while (hi > lo)
         mid = (lo + hi + 1)/2
         if (times(mid) <= t) then
            lo = mid
         else
            hi = mid - 1
         end if
      end do
      i = lo
   end function slot_at
end module trainsim_controller
