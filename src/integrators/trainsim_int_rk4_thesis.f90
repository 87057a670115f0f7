!> 'rk4-thesis': the scheme of the thesis's program (Appendix F). The modes are
!> set from the state at the start of each step and frozen over it; there is
!> no event location: a guard found negative at the start of a step is an
!> event at that instant. While any clearance is closed the step is dt/10.
!> Steps end at the breakpoints of the inputs (with the last stage at the left
!> limit, as in 'rk4'); App. F's program stepped over a load step, which is a
!> first-order error the driver does not reproduce.
module trainsim_int_rk4_thesis
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_integrator, only: integrator_t, adv_step, adv_reached, adv_event
   use trainsim_int_rk4, only: rk4_t
   implicit none
   private

   public :: rk4_thesis_t, new_rk4_thesis

   !> Step reduction while a clearance is closed (App. F).
   real(wp), parameter :: contact_step_fraction = 0.1_wp

   type, extends(rk4_t) :: rk4_thesis_t
   contains
      procedure :: advance => thesis_advance
   end type rk4_thesis_t

contains

   !> Factory (registry row 'rk4-thesis').
   subroutine new_rk4_thesis(integ)
      class(integrator_t), allocatable, intent(out) :: integ
      allocate (rk4_thesis_t :: integ)
   end subroutine new_rk4_thesis

   subroutine thesis_advance(self, model, t_goal, t, y, status, err)
      class(rk4_thesis_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t_goal
      real(wp), intent(inout) :: t, y(:)
      integer, intent(out) :: status
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: h
      logical :: at_bp
      if (self%ng > 0) then
         call model%guards(t, y, self%g0)
         if (any(self%g0 < 0.0_wp)) then
            status = adv_event
            return
         end if
      end if
      h = self%dt
      if (model%any_contact()) h = contact_step_fraction*self%dt
      h = min(h, t_goal - t)
      at_bp = self%stop_is_breakpoint .and. t + h >= self%t_stop - self%tiny_t
      call model%rhs(t, y, self%k1)
      self%stats%rhs_evals = self%stats%rhs_evals + 1
      call self%step(model, t, y, h, self%ynew, at_bp)
      y = self%ynew
      t = t + h
      self%stats%steps = self%stats%steps + 1
      status = adv_step
      if (t >= t_goal - self%tiny_t) status = adv_reached
   end subroutine thesis_advance
end module trainsim_int_rk4_thesis
