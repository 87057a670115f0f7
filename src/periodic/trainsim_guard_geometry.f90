!> What the saltation matrices need of a guard and a contact at (t, x), from the
!> model alone (trainsim_monodromy, D-102): the face a clearance is on, a guard's
!> gradient, a contact's approach velocity.
module trainsim_guard_geometry
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_clearance_element, only: clearance_element_t
   implicit none
   private

   public :: face_of, guard_gradient, approach

contains

   !> The face element e is in contact on (+1 / -1), 0 if open, not a clearance or e = 0.
   integer function face_of(model, e) result(face)
      type(model_t), intent(in) :: model
      integer, intent(in) :: e
      face = 0
      if (e < 1) return
      select type (el => model%elements(e)%e)
      class is (clearance_element_t)
         face = el%cl%mode
      end select
   end function face_of

   !> dg_j/dx (the physical states) and dg_j/dt at (t, x) by central
   !> differences: a guard is affine in the angles within a mode, so the
   !> differences are exact but for rounding (steps 1e-5 of each state's size).
   subroutine guard_gradient(model, t, x, j, nv, gt)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, x(:)
      integer, intent(in) :: j
      real(wp), intent(out) :: nv(:), gt
      real(wp) :: xp(size(x)), g(model%n_guards), gp, hx, ht
      integer :: k
      xp = x
      do k = 1, size(nv)
         hx = 1.0e-5_wp*max(1.0_wp, abs(x(k)))
         xp(k) = x(k) + hx
         call model%guards(t, xp, g)
         gp = g(j)
         xp(k) = x(k) - hx
         call model%guards(t, xp, g)
         nv(k) = (gp - g(j))/(2.0_wp*hx)
         xp(k) = x(k)
      end do
      ht = 1.0e-5_wp*max(1.0e-3_wp, abs(t))
      call model%guards(t + ht, x, g)
      gp = g(j)
      call model%guards(t - ht, x, g)
      gt = (gp - g(j))/(2.0_wp*ht)
   end subroutine guard_gradient

   !> The approach velocity of clearance e on `face` at (t, x), as `cl_update` takes it.
   real(wp) function approach(model, e, t, x, face) result(v)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: e, face
      real(wp), intent(in) :: t, x(:)
      call model%kinematics(t, x)
      v = 0.0_wp
      select type (el => model%elements(e)%e)
      class is (clearance_element_t)
         v = face*(el%cl%r1*model%omega(el%left) - el%cl%r2*model%omega(el%right))
      end select
   end function approach
end module trainsim_guard_geometry
