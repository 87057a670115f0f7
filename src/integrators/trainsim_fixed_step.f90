!> What the fixed-step integrators share: the grid t_start + k dt (never
!> accumulated), the instant tolerance and the event tolerance. A step ends at
!> the next grid point or earlier at the driver's goal; `rk4_t` and `euler_t`
!> extend this type.
module trainsim_fixed_step
   use trainsim_kinds, only: wp, i8
   use trainsim_model, only: model_t
   use trainsim_integrator, only: integrator_t
   implicit none
   private

   public :: fixed_step_t

   type, abstract, extends(integrator_t) :: fixed_step_t
      real(wp) :: dt = 0.0_wp, t0 = 0.0_wp, t_end = 0.0_wp
      real(wp) :: tiny_t = 0.0_wp       !< times closer than this are one instant
      real(wp) :: event_tol = 0.0_wp    !< width of the final bracket of a located event
      integer(i8) :: istep = 1          !< index of the next grid point t0 + istep dt
   contains
      procedure, non_overridable :: start_grid => fs_start_grid
      procedure, non_overridable :: grid_target => fs_grid_target
      procedure, non_overridable :: count_grid_step => fs_count_grid_step
   end type fixed_step_t

contains

   !> The grid of a run from t (dt, t_end and event_tol from the deck).
   subroutine fs_start_grid(self, model, t)
      class(fixed_step_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: t
      self%dt = model%run%dt
      self%t0 = t
      self%t_end = model%run%t_end
      self%tiny_t = 1.0e-12_wp*self%dt
      self%event_tol = model%run%event_tol
      if (self%event_tol <= 0.0_wp) self%event_tol = 1.0e-9_wp*self%dt
      self%istep = 1
   end subroutine fs_start_grid

   !> The next grid point after t (a step located to end just at a grid point
   !> completes that grid step).
   real(wp) function fs_grid_target(self, t) result(t_grid)
      class(fixed_step_t), intent(inout) :: self
      real(wp), intent(in) :: t
      t_grid = min(self%t0 + real(self%istep, wp)*self%dt, self%t_end)
      if (t >= t_grid - self%tiny_t) then
         call self%count_grid_step()
         t_grid = min(self%t0 + real(self%istep, wp)*self%dt, self%t_end)
      end if
   end function fs_grid_target

   !> The step to grid point istep is complete.
   subroutine fs_count_grid_step(self)
      class(fixed_step_t), intent(inout) :: self
      self%istep = self%istep + 1
      self%stats%steps = self%stats%steps + 1
   end subroutine fs_count_grid_step
end module trainsim_fixed_step
