!> The positioner: the event side of a controller's positioning sequence
!> (trainsim_controller). Made by the builder from a &controller group with
!> `sequence = .true.` (not a deck element type); its left port is the sensor
!> node, its right port the motor (or, when the sensor is the motor, another
!> node); it carries no torque. Its one guard watches the next target k:
!>   g = max(|th - target(k)|/tolerance, |w|/speed_tolerance) - 1,
!> which falls below zero when the sensor is within the tolerance of the target
!> and nearly at rest; the mode update then marks slot k reached (and the slots
!> after it whose targets lie within the tolerance of the same angle), which the
!> motor's controller reads as "hold" (0 V, integral frozen, brake command on)
!> until the next slot's time. Event kind 'target_reached'.
module trainsim_el_positioner
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list
   use trainsim_element, only: element_t
   use trainsim_event, only: event_t, ev_target_reached
   use trainsim_controller, only: sequence_t
   implicit none
   private

   public :: positioner_t

   type, extends(element_t) :: positioner_t
      type(sequence_t), pointer :: seq => null()
   contains
      procedure :: configure => pos_configure
      procedure :: torques => pos_torques
      procedure :: torque_jacobian => pos_jacobian
      procedure :: n_guards => pos_n_guards
      procedure :: guards => pos_guards
      procedure :: init_mode => pos_init_mode
      procedure :: update_mode => pos_update_mode
      procedure :: params => pos_params
   end type positioner_t

contains

   !> Nothing to read: the builder sets the sequence (trainsim_controller_deck).
   subroutine pos_configure(self, grp, units, err)
      class(positioner_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => self, u2 => grp, u3 => units)
      end associate
      if (allocated(err)) return
   end subroutine pos_configure

   pure subroutine pos_torques(self, thl, wl, thr, wr, tl, tr)
      class(positioner_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      associate (u1 => self, u2 => thl, u3 => wl, u4 => thr, u5 => wr)
      end associate
      tl = 0.0_wp
      tr = 0.0_wp
   end subroutine pos_torques

   pure subroutine pos_jacobian(self, thl, wl, thr, wr, jt)
      class(positioner_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      associate (u1 => self, u2 => thl, u3 => wl, u4 => thr, u5 => wr)
      end associate
      jt = 0.0_wp
   end subroutine pos_jacobian

   pure integer function pos_n_guards(self) result(n)
      class(positioner_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 1
   end function pos_n_guards

   !> The distance to the next target in tolerances (1 after the last target).
   pure subroutine pos_guards(self, thl, wl, thr, wr, g)
      class(positioner_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      integer :: k
      associate (u1 => thr, u2 => wr)
      end associate
      k = self%seq%reached + 1
      if (k > size(self%seq%target)) then
         g(1) = 1.0_wp
      else
         g(1) = max(abs(thl - self%seq%target(k))/self%seq%tol, abs(wl)/self%seq%speed_tol) - 1.0_wp
      end if
   end subroutine pos_guards

   !> Before the first target's time the motor is held; a sensor already at rest on
   !> the first targets counts them reached.
   subroutine pos_init_mode(self, thl, wl, thr, wr)
      class(positioner_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      associate (u1 => thr, u2 => wr)
      end associate
      self%seq%reached = 0
      call advance(self%seq, thl, wl)
   end subroutine pos_init_mode

   subroutine pos_update_mode(self, t, thl, wl, thr, wr, fired, ev, nev)
      class(positioner_t), intent(inout) :: self
      real(wp), intent(in) :: t, thl, wl, thr, wr
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      associate (u1 => thr, u2 => wr)
      end associate
      nev = 0
      if (.not. fired(1)) return
      if (self%seq%reached >= size(self%seq%target)) return
      self%seq%reached = self%seq%reached + 1
      call advance(self%seq, thl, wl)
      nev = 1
      ev(1)%t = t
      ev(1)%kind = ev_target_reached
   end subroutine pos_update_mode

   !> Mark reached every next target the sensor (th, w) already sits on.
   subroutine advance(seq, th, w)
      type(sequence_t), intent(inout) :: seq
      real(wp), intent(in) :: th, w
      do while (seq%reached < size(seq%target))
         if (.not. (abs(th - seq%target(seq%reached + 1)) < seq%tol .and. abs(w) < seq%speed_tol)) exit
         seq%reached = seq%reached + 1
      end do
   end subroutine advance

   function pos_params(self) result(p)
      class(positioner_t), intent(in) :: self
      type(param_list_t) :: p
      p = make_param_list([character(len=40) :: 'tolerance', 'speed_tolerance'], [self%seq%tol, self%seq%speed_tol])
   end function pos_params
end module trainsim_el_positioner
