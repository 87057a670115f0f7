!> 'euler': explicit Euler on the t_start + k dt grid, with event location by
!> bisection on the Euler step map. First order: for tests (it shows that an
!> integrator is one file and one registry row, and the conformance suite
!> measures its order) and teaching, not for production runs.
module trainsim_int_euler
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_integrator, only: integrator_t, adv_step, adv_reached, adv_event
   use trainsim_fixed_step, only: fixed_step_t
   implicit none
   private

   public :: euler_t, new_euler

   type, extends(fixed_step_t) :: euler_t
      real(wp), allocatable :: f(:), ynew(:), g(:)
   contains
      procedure :: start => euler_start
      procedure :: advance => euler_advance
   end type euler_t

contains

   !> Factory (registry row 'euler').
   subroutine new_euler(integ)
      class(integrator_t), allocatable, intent(out) :: integ
      allocate (euler_t :: integ)
   end subroutine new_euler

   subroutine euler_start(self, model, t, y, err)
      class(euler_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t, y(:)
      type(error_t), allocatable, intent(out) :: err
      allocate (self%f(size(y)), self%ynew(size(y)), self%g(model%n_guards))
      call self%start_grid(model, t)
   end subroutine euler_start

   subroutine euler_advance(self, model, t_goal, t, y, status, err)
      class(euler_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t_goal
      real(wp), intent(inout) :: t, y(:)
      integer, intent(out) :: status
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: t_grid, h, a, b
      t_grid = self%grid_target(t)
      h = min(t_grid, t_goal) - t
      call model%rhs(t, y, self%f)
      self%stats%rhs_evals = self%stats%rhs_evals + 1
      self%ynew = y + h*self%f
      status = adv_step
      if (size(self%g) > 0) then
         call model%guards(t + h, self%ynew, self%g)
         if (any(self%g < 0.0_wp)) then
            ! bisection on s -> guards(y + s f): end where a guard is negative
            a = 0.0_wp; b = h
            do while (b - a > self%event_tol)
               self%ynew = y + 0.5_wp*(a + b)*self%f
               call model%guards(t + 0.5_wp*(a + b), self%ynew, self%g)
               if (any(self%g < 0.0_wp)) then
                  b = 0.5_wp*(a + b)
               else
                  a = 0.5_wp*(a + b)
               end if
            end do
            y = y + b*self%f
            t = t + b
            self%stats%root_returns = self%stats%root_returns + 1
            status = adv_event
            return
         end if
      end if
      y = self%ynew
      t = t + h
      if (t >= t_grid - self%tiny_t) then
         t = t_grid
         call self%count_grid_step()
      end if
      if (t >= t_goal - self%tiny_t) status = adv_reached
   end subroutine euler_advance
end module trainsim_int_euler
