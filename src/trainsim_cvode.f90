!> SUNDIALS CVODE (BDF/Newton or Adams/fixed-point) with root-finding on the
!> element guards. All SUNDIALS calls live in this module.
module trainsim_cvode
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_model, only: model_t
   use trainsim_sink, only: sink_t, run_stats_t
   use trainsim_observer, only: observer_t
   implicit none
   private

   public :: integrate_cvode

contains

   !> Placeholder until the CVODE path lands (issue #4): refuses clearly.
   subroutine integrate_cvode(model, obs, sink, t, y, stats, err)
      type(model_t), intent(inout) :: model
      type(observer_t), intent(inout) :: obs
      class(sink_t), intent(inout) :: sink
      real(wp), intent(inout) :: t, y(:)
      type(run_stats_t), intent(inout) :: stats
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => obs, u2 => sink, u3 => t, u4 => y, u5 => stats)
      end associate
      call fatal_error(err, "integrator '"//model%run%integrator//"' is not available in this build", err_input)
   end subroutine integrate_cvode
end module trainsim_cvode
