!> The impact damping's memory in the variational pass (trainsim_monodromy,
!> D-102): a yang_sun contact fixes its damping D(V_i) (eq. 3.12) where it
!> closes, V_i its approach velocity, until it opens; D's sensitivity to x(t0)
!> enters the variational equations through df/dD.
module trainsim_impact_memory
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_clearance_element, only: clearance_element_t
   use trainsim_contact, only: law_yang_sun, contact_law_t
   use trainsim_guard_geometry, only: face_of, approach
   implicit none
   private

   public :: impact_gradient, damping_column

contains

   !> Element e (a clearance) closed at (t, x) with the damping D(V_i) of eq.
   !> (3.12), V_i its approach velocity there: dD/dV_i (central differences of
   !> the law) and dV_i/dx (gv, the first size(gv) states). found: D depends on
   !> V_i (only the yang_sun law's does, above its floor v_min).
   subroutine impact_gradient(model, e, t, x, dd_dv, gv, found)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: e
      real(wp), intent(in) :: t, x(:)
      real(wp), intent(out) :: dd_dv, gv(:)
      logical, intent(out) :: found
      type(contact_law_t) :: lw
      real(wp) :: v, hv, dp, dm, xp(size(x)), vp, hx
      integer :: k, face
      found = .false.
      dd_dv = 0.0_wp
      gv = 0.0_wp
      face = face_of(model, e)
      select type (el => model%elements(e)%e)
      class is (clearance_element_t)
         if (el%cl%law%law /= law_yang_sun) return
         v = approach(model, e, t, x, face)
         if (abs(v) <= el%cl%law%v_min) return            ! D from the floor: no dependence on x
         hv = 1.0e-6_wp*abs(v)
         lw = el%cl%law; call lw%begin_contact(v + hv, .false.); dp = lw%d
         lw = el%cl%law; call lw%begin_contact(v - hv, .false.); dm = lw%d
         dd_dv = (dp - dm)/(2.0_wp*hv)
      class default
         return
      end select
      xp = x
      do k = 1, size(gv)                                 ! dV_i/dx: V_i is linear in the speeds
         hx = 1.0e-5_wp*max(1.0_wp, abs(x(k)))
         xp(k) = x(k) + hx
         vp = approach(model, e, t, xp, face)
         xp(k) = x(k) - hx
         gv(k) = (vp - approach(model, e, t, xp, face))/(2.0_wp*hx)
         xp(k) = x(k)
      end do
      found = .true.
   end subroutine impact_gradient

   !> df/dD of clearance e (yang_sun, in contact) at (t, x): its contact force
   !> F = c (k p + D p pdot) (eqs. 3.18-3.19) gives dF/dD = c p pdot (0 where
   !> no_tension clips F), put on its nodes' states as their Jacobians put a
   !> torque: through dtq, the nodes' gains d(dydt of state k)/d(net torque)
   !> (5, nodes) where given (the Jacobian's constant part, D-170: only the
   !> element's nodes' kinematics), else through the nodes' own Jacobians (jac:
   !> scratch they add to). current: the workspace holds the kinematics of e's
   !> nodes at (t, x) already (the split Jacobian's varying part just took them, D-186).
   subroutine damping_column(model, e, t, x, jac, b, dtq, current)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: e
      real(wp), intent(in) :: t, x(:)
      real(wp), intent(inout) :: jac(:, :)
      real(wp), intent(out) :: b(:)
      real(wp), intent(in), optional :: dtq(:, :)
      logical, intent(in), optional :: current
      real(wp) :: s, c, p, pdot, dfs, g(8), tq(2)
      integer :: l, r, a, nd, k, ns
      b = 0.0_wp
      l = model%elements(e)%e%left
      r = model%elements(e)%e%right
      if (present(current)) then
         if (.not. current) call model%kinematics_part(t, x, [l, r])
      else if (present(dtq)) then
         call model%kinematics_part(t, x, [l, r])
      else
         call model%kinematics(t, x)
      end if
      select type (el => model%elements(e)%e)
      class is (clearance_element_t)
         if (el%cl%mode == 0) return
         s = real(el%cl%mode, wp)
         c = el%factor(model%theta(l))
         p = s*(el%cl%r1*model%theta(l) - el%cl%r2*model%theta(r)) - el%cl%b
         pdot = s*(el%cl%r1*model%omega(l) - el%cl%r2*model%omega(r))
         if (el%cl%law%no_tension .and. c*(el%cl%law%k*p + el%cl%law%d*p*pdot) < 0.0_wp) return
         dfs = s*c*p*pdot
         tq = [-el%cl%r1*dfs, el%cl%r2*dfs]
      class default
         return
      end select
      do a = 1, 2
         nd = l
         if (a == 2) nd = r
         if (model%speed_of(nd) /= 0) cycle
         ns = model%nodes(nd)%n%nstates()
         if (ns == 0) cycle
         if (present(dtq)) then
            g(1:ns) = dtq(1:ns, nd)
         else
            call model%nodes(nd)%n%jacobian(t, x, jac, g(1:ns))
         end if
         do k = 1, ns
            b(model%nodes(nd)%n%offset + k) = b(model%nodes(nd)%n%offset + k) + g(k)*tq(a)
         end do
      end do
   end subroutine damping_column
end module trainsim_impact_memory
