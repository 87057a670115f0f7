!> Counters and timings of a run: filled by the integrators, printed by the
!> report and written by the output sinks.
module trainsim_run_stats
   use trainsim_kinds, only: wp, i8
   implicit none
   private

   public :: run_stats_t

   !> Counters and timings of a run.
   type :: run_stats_t
      integer(i8) :: steps = 0, rhs_evals = 0, jac_evals = 0, root_returns = 0
      integer(i8) :: error_test_fails = 0, conv_fails = 0, events = 0, rejected = 0
      !> steps an integrator took in blocks (`advance_block`, D-38), among `steps`
      integer(i8) :: block_steps = 0
      real(wp) :: wall_time = 0.0_wp, t_final = 0.0_wp
      logical :: completed = .false.
      !> settling until periodic (&run settle_tol, D-44): 0 not asked, 1 settled,
      !> 2 not settled within settle_max_time (the metrics are then of a transient);
      !> without settle_tol, the verdict at a fixed settle_time (to 1e-3): 3 settled,
      !> 4 not settled (the metrics are of a transient)
      integer :: settle_status = 0
      integer :: settle_periods = 0       !< settle periods run before the metrics started
      integer :: settle_k = 0             !< the response repeats after k periods (1: periodic; 0: not found)
      real(wp) :: t_metrics = 0.0_wp      !< start of the metrics' window (t_start + settle_time without settling)
   end type run_stats_t
end module trainsim_run_stats
