!> What an element reports when its discrete mode changes: one row of the
!> event table. Part of the model layer (elements produce events); the
!> recorder and the output sinks only read them.
module trainsim_event
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: event_t, ev_contact_front, ev_contact_rear, ev_separation, ev_zone, ev_stick, ev_slip_forward, ev_slip_backward, &
             ev_target_reached, ev_flow_forward, ev_flow_backward, ev_max_kind, ev_name, max_update_events

   !> Event kinds (column `kind` of the event table).
   integer, parameter :: ev_contact_front = 1 !< contact begins on the front face (impact)
   integer, parameter :: ev_contact_rear = 2  !< contact begins on the rear face (impact)
   integer, parameter :: ev_separation = 3    !< contact ends
   integer, parameter :: ev_zone = 4          !< tooth-zone change (one/two pairs in contact)
   !> Friction modes (D-81): stuck (force: the constraint torque), slipping with
   !> the relative speed positive or negative (force: the torque at the switch).
   integer, parameter :: ev_stick = 5, ev_slip_forward = 6, ev_slip_backward = 7
   integer, parameter :: ev_target_reached = 8 !< a positioning sequence reached its target (trainsim_controller)
   !> A lossy gear's power flow turned (D-91): the left now drives (forward) or
   !> is driven (backward), its left moving on (force: the mesh force).
   integer, parameter :: ev_flow_forward = 9, ev_flow_backward = 10
   integer, parameter :: ev_max_kind = 10      !< the kinds are 1..ev_max_kind (the C API lists their names)

   !> Most events one element may report from one mode update (`update_mode`
   !> writes ev(1:nev) with nev <= this): a face contact or separation per
   !> face and a zone change, with room to spare.
   integer, parameter :: max_update_events = 8

   !> One row of the event table.
   type :: event_t
      real(wp) :: t = 0.0_wp
      integer :: element = 0
      integer :: kind = 0
      real(wp) :: approach_velocity = 0.0_wp !< V_i captured at contact onset
      real(wp) :: restitution = 0.0_wp       !< e used for D (contact onsets)
      real(wp) :: damping = 0.0_wp           !< D of eq. (3.12) used for this contact
      real(wp) :: peak_force = 0.0_wp        !< largest |force| during this contact
      real(wp) :: duration = -1.0_wp         !< contact duration (-1 while open)
      !> the element's state just after the mode update: its nodes' angles and
      !> speeds, its relative displacement and its force (filled by the recorder)
      real(wp) :: theta_left = 0.0_wp, omega_left = 0.0_wp, theta_right = 0.0_wp, omega_right = 0.0_wp
      real(wp) :: displacement = 0.0_wp, force = 0.0_wp
   end type event_t

contains

   !> Name of an event kind.
   pure function ev_name(kind) result(name)
      integer, intent(in) :: kind
      character(len=:), allocatable :: name
      select case (kind)
      case (ev_contact_front); name = 'contact_front'
      case (ev_contact_rear); name = 'contact_rear'
      case (ev_separation); name = 'separation'
      case (ev_zone); name = 'zone'
      case (ev_stick); name = 'stick'
      case (ev_slip_forward); name = 'slip_forward'
      case (ev_slip_backward); name = 'slip_backward'
      case (ev_target_reached); name = 'target_reached'
      case (ev_flow_forward); name = 'flow_forward'
      case (ev_flow_backward); name = 'flow_backward'
      case default; name = 'unknown'
      end select
   end function ev_name
end module trainsim_event
