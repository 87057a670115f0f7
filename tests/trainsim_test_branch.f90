!> A continuation problem for the tests (test_continuation, test_period_doubling): a
!> model whose first load is a sine, continued in its angular frequency.
module trainsim_test_branch
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_arclength, only: branch_problem_t
   implicit none
   private
   public :: sine_problem_t, sine_retuned_t, retunes_done

   !> the model `base` at forcing frequency lambda = W (rad/s) of its first load
   type, extends(branch_problem_t) :: sine_problem_t
      type(model_t) :: base
   contains
      procedure :: model_at => sine_model_at
   end type sine_problem_t

   !> the same, its models retuned to lambda (the frequency set in a model built at
   !> another: D-131) instead of copied from `base` at every lambda
   type, extends(sine_problem_t) :: sine_retuned_t
   contains
      procedure :: retune => sine_retune
   end type sine_retuned_t

   integer, save :: retunes_done = 0   !< sine_retune's calls (the reuse path taken)

contains

   subroutine sine_model_at(self, lam, model, err)
      class(sine_problem_t), intent(in) :: self
      real(wp), intent(in) :: lam
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      model = self%base
      model%loads(1)%torque%omega = lam
      model%loads(1)%torque%integral_at_zero = -model%loads(1)%torque%amplitude/lam*cos(model%loads(1)%torque%phase)
   end subroutine sine_model_at

   subroutine sine_retune(self, lam, model, done, err)
      class(sine_retuned_t), intent(in) :: self
      real(wp), intent(in) :: lam
      type(model_t), intent(inout) :: model
      logical, intent(out) :: done
      type(error_t), allocatable, intent(out) :: err
      associate (unused => self)
      end associate
      model%loads(1)%torque%omega = lam
      model%loads(1)%torque%integral_at_zero = -model%loads(1)%torque%amplitude/lam*cos(model%loads(1)%torque%phase)
      retunes_done = retunes_done + 1
      done = .true.
   end subroutine sine_retune
end module trainsim_test_branch
