!> A run as a library call: model in, metrics and events out (in memory),
!> histories to whatever sink the caller passes. No global state: any number
!> of runs per process, on copies of one model.
module trainsim_simulate
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_internal
   use trainsim_model, only: model_t
   use trainsim_sink, only: sink_t, run_stats_t
   use trainsim_observer, only: observer_t, run_result_t
   use trainsim_rk4, only: integrate_rk4
   use trainsim_cvode, only: integrate_sundials
   implicit none
   private

   public :: simulate

contains

   !> Integrate `model` from t_start to t_end with its integrator.
   !> On error the sink is aborted (no partial output left as if good).
   subroutine simulate(model, sink, result, err)
      type(model_t), intent(inout) :: model
      class(sink_t), intent(inout) :: sink
      type(run_result_t), intent(out) :: result
      type(error_t), allocatable, intent(out) :: err
      type(observer_t) :: obs
      type(run_stats_t) :: stats
      real(wp), allocatable :: y(:)
      real(wp) :: t
      integer(i8) :: c0, c1, rate

      call system_clock(c0, rate)
      t = model%run%t_start
      call model%initial_state(y)
      call model%init_modes(t, y)
      call obs%start(model, t, y, sink, err)
      if (allocated(err)) then
         call sink%abort()
         return
      end if
      select case (model%run%integrator)
      case ('rk4')
         call integrate_rk4(model, obs, sink, t, y, stats, .false., err)
      case ('rk4-thesis')
         call integrate_rk4(model, obs, sink, t, y, stats, .true., err)
      case ('cvode-bdf', 'cvode-adams', 'arkode-dp', 'arkode-verner')
         call integrate_sundials(model, obs, sink, t, y, stats, err)
      case default
         call fatal_error(err, "internal: integrator '"//model%run%integrator//"' not dispatched", err_internal)
      end select
      if (allocated(err)) then
         call sink%abort()
         return
      end if
      call system_clock(c1)
      stats%wall_time = real(c1 - c0, wp)/real(rate, wp)
      call obs%finish(model, t, y, stats, sink, result, err)
      if (allocated(err)) call sink%abort()
   end subroutine simulate
end module trainsim_simulate
