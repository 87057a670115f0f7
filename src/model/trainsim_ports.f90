!> The model's side of n-port elements (D-73): an element's ports' angles and
!> speeds gathered from the node arrays, and its `port_*` procedures asked with
!> them (trainsim_model's general path, energy, events and Jacobian). Two-port
!> elements keep their own procedures there; nothing here allocates.
module trainsim_ports
   use trainsim_kinds, only: wp
   use trainsim_element, only: element_t, max_ports
   use trainsim_event, only: event_t
   implicit none
   private

   public :: port_kinematics, port_torques_at, general_torques, potential_at, port_init_at, port_update_at

contains

   !> The nodes of e's ports (ends) and their angles and speeds (th, w) from every
   !> node's (theta, omega); entries beyond e%n_ports() are 0.
   pure subroutine port_kinematics(e, theta, omega, ends, th, w)
      class(element_t), intent(in) :: e
      real(wp), intent(in) :: theta(:), omega(:)
      integer, intent(out) :: ends(max_ports)
      real(wp), intent(out) :: th(max_ports), w(max_ports)
      integer :: k
      ends = 0; th = 0.0_wp; w = 0.0_wp
      do k = 1, e%n_ports()
         ends(k) = e%port(k)
         th(k) = theta(ends(k))
         w(k) = omega(ends(k))
      end do
   end subroutine port_kinematics

   !> e's torques t(1:np) on its ports' nodes (ends) and the power it dissipates p.
   pure subroutine port_torques_at(e, theta, omega, ends, t, p)
      class(element_t), intent(in) :: e
      real(wp), intent(in) :: theta(:), omega(:)
      integer, intent(out) :: ends(max_ports)
      real(wp), intent(out) :: t(max_ports), p
      real(wp) :: th(max_ports), w(max_ports)
      integer :: np
      np = e%n_ports()
      call port_kinematics(e, theta, omega, ends, th, w)
      t = 0.0_wp
      call e%port_torques_dissipation(th(1:np), w(1:np), t(1:np), p)
   end subroutine port_torques_at

   !> Element e in the general RHS of a model with n-port elements (D-73), at
   !> every node's kinematics (theta, omega): its torques on ports 1, 2 in tl, tr
   !> (the caller adds them as a two-port element's), those on its further ports
   !> added to torque(node) here; with `track` its dissipated and input power
   !> added to pdiss, pin. A two-port element: its own procedures, as `rhs`.
   pure subroutine general_torques(e, theta, omega, torque, track, tl, tr, pdiss, pin)
      class(element_t), intent(in) :: e
      real(wp), intent(in) :: theta(:), omega(:)
      real(wp), intent(inout) :: torque(:), pdiss, pin
      logical, intent(in) :: track
      real(wp), intent(out) :: tl, tr
      real(wp) :: t(max_ports), p
      integer :: k, l, r, np, ends(max_ports)
      np = e%n_ports()
      if (np == 2) then
         l = e%left
         r = e%right
         call e%torques(theta(l), omega(l), theta(r), omega(r), tl, tr)
         if (track) then
            pdiss = pdiss + e%dissipation_power(theta(l), omega(l), theta(r), omega(r))
            if (e%supplies_power) pin = pin + e%input_power(theta(l), omega(l), theta(r), omega(r))
         end if
         return
      end if
      call port_torques_at(e, theta, omega, ends, t, p)
      if (track) then
         pdiss = pdiss + p
         if (e%supplies_power) pin = pin + e%port_input_power(theta(ends(1:np)), omega(ends(1:np)))
      end if
      do k = 3, np
         torque(ends(k)) = torque(ends(k)) + t(k)
      end do
      tl = t(1)
      tr = t(2)
   end subroutine general_torques

   !> e's elastic energy at the nodes' angles theta: `potential_energy` of its
   !> two nodes, or `port_potential_energy` over its ports.
   pure real(wp) function potential_at(e, theta) result(v)
      class(element_t), intent(in) :: e
      real(wp), intent(in) :: theta(:)
      real(wp) :: th(max_ports), w(max_ports)
      integer :: np, ends(max_ports)
      np = e%n_ports()
      if (np == 2) then
         v = e%potential_energy(theta(e%left), theta(e%right))
      else
         call port_kinematics(e, theta, theta, ends, th, w)
         v = e%port_potential_energy(th(1:np))
      end if
   end function potential_at

   !> `port_init_mode` of e at the nodes' kinematics.
   subroutine port_init_at(e, theta, omega)
      class(element_t), intent(inout) :: e
      real(wp), intent(in) :: theta(:), omega(:)
      real(wp) :: th(max_ports), w(max_ports)
      integer :: np, ends(max_ports)
      np = e%n_ports()
      call port_kinematics(e, theta, omega, ends, th, w)
      call e%port_init_mode(th(1:np), w(1:np))
   end subroutine port_init_at

   !> `port_update_mode` of e at the nodes' kinematics.
   subroutine port_update_at(e, t, theta, omega, fired, ev, nev)
      class(element_t), intent(inout) :: e
      real(wp), intent(in) :: t, theta(:), omega(:)
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      real(wp) :: th(max_ports), w(max_ports)
      integer :: np, ends(max_ports)
      np = e%n_ports()
      call port_kinematics(e, theta, omega, ends, th, w)
      call e%port_update_mode(t, th(1:np), w(1:np), fired, ev, nev)
   end subroutine port_update_at
end module trainsim_ports
