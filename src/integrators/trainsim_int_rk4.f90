!> 'rk4': fixed-step classical RK4 with event location.
!>
!> The discrete modes are frozen inside a step, so the right-hand side is
!> smooth there and RK4 keeps its order. After each step the guards are
!> evaluated; if one went negative, its zero is located on the RK4 step map
!> itself (Illinois false position on s -> g(RK4(y, s))), the step ends there
!> and `advance` returns adv_event; the driver updates the modes and the next
!> step completes the grid step. Steps stay on the t_start + k dt grid; a step
!> also ends at the driver's goal (an output time or a breakpoint of the
!> inputs, where the last stage is taken at the left limit).
module trainsim_int_rk4
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_integrator, only: integrator_t, adv_step, adv_reached, adv_event
   use trainsim_fixed_step, only: fixed_step_t
   implicit none
   private

   public :: rk4_t, new_rk4

   type, extends(fixed_step_t) :: rk4_t
      integer :: ng = 0
      real(wp), allocatable :: k1(:), k2(:), k3(:), k4(:), ytmp(:), ynew(:), ys(:)
      real(wp), allocatable :: g0(:), g1(:), gs(:)
   contains
      procedure :: start => rk4_start
      procedure :: advance => rk4_advance
      procedure :: step => rk4_step
      procedure, private :: locate => rk4_locate
      procedure, private :: end_on_event => rk4_end_on_event
   end type rk4_t

contains

   !> Factory (registry row 'rk4').
   subroutine new_rk4(integ)
      class(integrator_t), allocatable, intent(out) :: integ
      allocate (rk4_t :: integ)
   end subroutine new_rk4

   subroutine rk4_start(self, model, t, y, err)
      class(rk4_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t, y(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: n
      n = size(y)
      self%ng = model%n_guards
      allocate (self%k1(n), self%k2(n), self%k3(n), self%k4(n), self%ytmp(n), self%ynew(n), self%ys(n))
      allocate (self%g0(self%ng), self%g1(self%ng), self%gs(self%ng))
      call self%start_grid(model, t)
   end subroutine rk4_start

   !> One classical RK4 step of size h from (t, y) into ynew; k1 = f(t, y) given.
   !> A step that ends on a breakpoint of the inputs takes its last stage at the
   !> left limit there (a load that jumps at t + h acts from t + h on).
   subroutine rk4_step(self, model, t, y, h, ynew, left_limit)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:), h
      real(wp), intent(out) :: ynew(:)
      logical, intent(in) :: left_limit
      real(wp) :: t4
      t4 = t + h
      if (left_limit) t4 = t + h - 1.0e-9_wp*h
      self%ytmp = y + 0.5_wp*h*self%k1
      call model%rhs(t + 0.5_wp*h, self%ytmp, self%k2)
      self%ytmp = y + 0.5_wp*h*self%k2
      call model%rhs(t + 0.5_wp*h, self%ytmp, self%k3)
      self%ytmp = y + h*self%k3
      call model%rhs(t4, self%ytmp, self%k4)
      ynew = y + (h/6.0_wp)*(self%k1 + 2.0_wp*(self%k2 + self%k3) + self%k4)
      self%stats%rhs_evals = self%stats%rhs_evals + 3
   end subroutine rk4_step

   !> One sub-step: to the next grid point, or to t_goal if that comes first.
   subroutine rk4_advance(self, model, t_goal, t, y, status, err)
      class(rk4_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t_goal
      real(wp), intent(inout) :: t, y(:)
      integer, intent(out) :: status
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: t_grid, t_sub, h
      logical :: at_bp
      t_grid = self%grid_target(t)
      t_sub = min(t_grid, t_goal)
      at_bp = self%stop_is_breakpoint .and. t_sub >= self%t_stop - self%tiny_t
      h = t_sub - t
      call model%rhs(t, y, self%k1)
      self%stats%rhs_evals = self%stats%rhs_evals + 1
      call self%step(model, t, y, h, self%ynew, at_bp)
      if (self%ng > 0) then
         call model%guards(t + h, self%ynew, self%g1)
         if (any(self%g1 < 0.0_wp)) then
            call self%end_on_event(model, h, t, y)
            status = adv_event
            return
         end if
      end if
      y = self%ynew
      t = t_sub
      if (t >= t_grid - self%tiny_t) then
         t = t_grid
         call self%count_grid_step()
      end if
      status = adv_step
      if (t >= t_goal - self%tiny_t) status = adv_reached
   end subroutine rk4_advance

   !> A guard went negative inside [t, t+h]: locate the earliest zero and end
   !> the step there (t, y at the located point).
   subroutine rk4_end_on_event(self, model, h, t, y)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: h
      real(wp), intent(inout) :: t, y(:)
      real(wp) :: s_best
      integer :: j
      call model%guards(t, y, self%g0)
      s_best = h
      do j = 1, self%ng
         if (self%g1(j) < 0.0_wp) s_best = min(s_best, self%locate(model, t, y, j, h, max(self%g0(j), 0.0_wp), &
                                                                   self%g1(j)))
      end do
      if (s_best < h) then
         call self%step(model, t, y, s_best, self%ys, .false.)
      else
         self%ys = self%ynew
      end if
      t = t + s_best
      y = self%ys
      self%stats%root_returns = self%stats%root_returns + 1
   end subroutine rk4_end_on_event

   !> Zero of guard j on s in (0, h]: Illinois false position on the RK4 step
   !> map; returns the end of the final bracket, where g < 0.
   real(wp) function rk4_locate(self, model, t, y, j, h, ga, gb) result(b)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:)
      integer, intent(in) :: j
      real(wp), intent(in) :: h, ga, gb
      real(wp) :: a, fa, fb, s, fs
      integer :: side, it
      a = 0.0_wp; b = h; fa = ga; fb = gb; side = 0
      ! self%k1 still holds f(t, y) from the step being located
      do it = 1, 200
         if (b - a <= self%event_tol) exit
         s = (a*fb - b*fa)/(fb - fa)
         ! keep the new point inside the bracket, away from its ends
         s = min(max(s, a + 0.01_wp*(b - a)), b - 0.01_wp*(b - a))
         call self%step(model, t, y, s, self%ys, .false.)
         call model%guards(t + s, self%ys, self%gs)
         fs = self%gs(j)
         if (fs < 0.0_wp) then
            b = s; fb = fs
            if (side == -1) fa = 0.5_wp*fa
            side = -1
         else
            a = s; fa = fs
            if (side == 1) fb = 0.5_wp*fb
            side = 1
         end if
      end do
   end function rk4_locate
end module trainsim_int_rk4
