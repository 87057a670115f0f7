!> The run conditions a deck's &run group gives (times, step, integrator,
!> tolerances, output, settling, energy tracking): part of every model
!> (`model_t%run`), re-exported by trainsim_model.
module trainsim_run_settings
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: run_settings_t

   !> Run conditions from the &run group.
   type :: run_settings_t
      real(wp) :: t_start = 0.0_wp, t_end = 0.0_wp, dt = 0.0_wp
      real(wp) :: output_interval = 0.0_wp      !< 0: every step
      character(len=:), allocatable :: integrator  !< 'rk4', 'rk4-thesis', 'cvode-bdf', 'cvode-adams', 'arkode-dp', 'arkode-verner'
      character(len=:), allocatable :: output      !< HDF5 file name
      real(wp) :: rtol = 1.0e-8_wp
      real(wp) :: atol_angle = 1.0e-14_wp, atol_speed = 1.0e-8_wp, atol_current = 1.0e-8_wp
      real(wp) :: max_step = 0.0_wp             !< CVODE maximum step (0: from the highest frequency)
      real(wp) :: event_tol = 0.0_wp            !< event time tolerance (0: 1e-9 dt)
      real(wp) :: settle_time = 0.0_wp          !< metrics ignore t < t_start + settle_time
      !> settle until periodic (docs/sweeps.md#settling): 0 off; else the state sampled
      !> every settle_period must repeat to this relative tolerance (or with k <= 8
      !> periods) before the metrics start, within settle_max_time after t_start
      real(wp) :: settle_tol = 0.0_wp
      real(wp) :: settle_period = 0.0_wp        !< s (0: the first gear pair's mesh period at t_start)
      real(wp) :: settle_max_time = 0.0_wp      !< s (0: 1000 settle periods)
      logical :: track_energy = .true.          !< integrate dissipated energy and work input
      !> a run whose energy residual ends above this fraction of its energy
      !> scale fails (exit 1, D-55); 0: no such check
      real(wp) :: energy_check = 0.1_wp
      logical :: keep_series = .false.          !< keep displacement series in memory (sweeps)
      logical :: keep_events = .false.          !< keep the whole event table in the result (else streamed to the sink only)
      integer :: compression = 0                !< zlib level of the HDF5 history (0: none)
      logical :: analytic_jacobian = .true.     !< CVODE BDF: model%jacobian, else difference quotients
      logical :: preload = .false.              !< initial_state = 'preload': angles from the static wind-up
      !> plain steps in blocks where the output allows (D-38); .false.: step by
      !> step (a switch for comparing the two paths; not a deck key)
      logical :: step_blocks = .true.
   end type run_settings_t
end module trainsim_run_settings
