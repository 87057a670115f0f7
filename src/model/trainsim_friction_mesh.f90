!> An excited gear mesh with tooth friction (trainsim_tooth_friction): the parent
!> of the spur gear (friction per pair, D-98) and the helical gear (friction over
!> the lines of contact, D-116). It holds what the two share: the friction's
!> data, `torques` and `dissipation_power` through the type's own
!> `torques_dissipation` while the friction is on, and the Jacobian's common part
!> (the excited mesh's, then the friction's partials on the normal force of the
!> face in contact, `friction_jacobian`). With tooth_friction = 0 every procedure
!> is the excited mesh's (trainsim_excited_mesh), bit for bit.
module trainsim_friction_mesh
   use trainsim_kinds, only: wp
   use trainsim_excited_mesh, only: excited_mesh_t, em_torques, em_dissipation, em_torque_jacobian
   use trainsim_tooth_friction, only: tooth_friction_t
   implicit none
   private

   public :: friction_mesh_t

   type, abstract, extends(excited_mesh_t) :: friction_mesh_t
      type(tooth_friction_t) :: fric      !< tooth friction: off at tooth_friction = 0
   contains
      procedure :: torques => fm_torques
      procedure :: dissipation_power => fm_dissipation
      procedure :: torque_jacobian => fm_torque_jacobian
      procedure(friction_jacobian_i), deferred :: friction_jacobian
   end type friction_mesh_t

   abstract interface
      !> Add the friction's partials in (thl, wl, thr, wr) to jt under the normal
      !> force w > 0 of the face in contact, its partials dw.
      pure subroutine friction_jacobian_i(self, thl, wl, wr, w, dw, jt)
         import :: friction_mesh_t, wp
         class(friction_mesh_t), intent(in) :: self
         real(wp), intent(in) :: thl, wl, wr, w, dw(4)
         real(wp), intent(inout) :: jt(2, 4)
      end subroutine friction_jacobian_i
   end interface

contains

   pure subroutine fm_torques(self, thl, wl, thr, wr, tl, tr)
      class(friction_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      real(wp) :: p
      if (self%fric%on()) then
         call self%torques_dissipation(thl, wl, thr, wr, tl, tr, p)
      else
         call em_torques(self, thl, wl, thr, wr, tl, tr)
      end if
   end subroutine fm_torques

   pure real(wp) function fm_dissipation(self, thl, wl, thr, wr) result(p)
      class(friction_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: tl, tr
      if (self%fric%on()) then
         call self%torques_dissipation(thl, wl, thr, wr, tl, tr, p)
      else
         p = em_dissipation(self, thl, wl, thr, wr)
      end if
   end function fm_dissipation

   !> The excited mesh's Jacobian plus the friction's partials.
   pure subroutine fm_torque_jacobian(self, thl, wl, thr, wr, jt)
      class(friction_mesh_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      real(wp) :: fs, a, va
      call em_torque_jacobian(self, thl, wl, thr, wr, jt)
      if (.not. self%fric%on()) return
      call self%shift(thl, wl, a, va)
      fs = self%cl%contact_force(self%factor(thl), a, va, thr, wr)
      if (self%cl%mode*fs > 0.0_wp) call self%friction_jacobian(thl, wl, wr, self%cl%mode*fs, &
                                                                self%cl%mode*jt(2, :)/self%cl%r2, jt)
   end subroutine fm_torque_jacobian
end module trainsim_friction_mesh
