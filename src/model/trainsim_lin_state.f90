!> The state an element is linearised in (trainsim_element's `linearise`,
!> `trainsim modes`, the RK4 step advice), kept apart from the element type.
module trainsim_lin_state
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: lin_state_t, lin_start, lin_closed, lin_stiffest
   public :: lin_contact_initial, lin_contact_closed
   public :: lin_zone_initial, lin_zone_single, lin_zone_stiffest

   !> Contact state of a linearisation: as at t_start, or every clearance closed.
   integer, parameter :: lin_contact_initial = 1, lin_contact_closed = 2
   !> Mesh position of a linearisation: the zone at t_start, the softest (single
   !> pair, shortest contact lines) or the stiffest (two pairs, longest lines).
   integer, parameter :: lin_zone_initial = 1, lin_zone_single = 2, lin_zone_stiffest = 3

   !> The state an element is linearised in (`linearise`, `trainsim modes`, the
   !> RK4 step advice). `impact_scale` in [0, 1] scales the impact damping a
   !> closed contact law can give at most (D-25). A later state (linearised about
   !> the static preload) is a new `contact` value. `load_torque`: the largest
   !> torque the loads can drive through one element (trainsim_modes'
   !> load_torque_bound; 0: not known), which a contact closed gently under load
   !> carries at a penetration that sets its damping (D-55).
   type :: lin_state_t
      integer :: contact = lin_contact_initial
      integer :: zone = lin_zone_initial
      real(wp) :: impact_scale = 1.0_wp
      real(wp) :: load_torque = 0.0_wp
   end type lin_state_t

   !> As the run starts: current contact state and mesh zone.
   type(lin_state_t), parameter :: lin_start = lin_state_t(lin_contact_initial, lin_zone_initial, 1.0_wp, 0.0_wp)
   !> Every clearance closed, mesh zones as at t_start.
   type(lin_state_t), parameter :: lin_closed = lin_state_t(lin_contact_closed, lin_zone_initial, 1.0_wp, 0.0_wp)
   !> The stiffest state a run can reach: clearances closed, gears at their largest stiffness factor.
   type(lin_state_t), parameter :: lin_stiffest = lin_state_t(lin_contact_closed, lin_zone_stiffest, 1.0_wp, 0.0_wp)
end module trainsim_lin_state
