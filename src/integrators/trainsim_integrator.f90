!> The abstract integrator: what the driver loop (trainsim_driver) asks of
!> every time-stepping method. An integrator only advances the state; the
!> driver owns the output times, the breakpoints of the inputs, the event
!> handling at an instant, the budgets and the blow-up check, so that those
!> are written once for every method.
!>
!> The contract:
!> - `start` is called once with the initial state and the first stop time
!>   (the next breakpoint of the inputs, or t_end): the integrator must never
!>   step past the stop time.
!> - `advance` moves (t, y) towards t_goal (<= the stop time) and returns
!>   `adv_reached` (t is t_goal, to rounding), `adv_step` (one internal step
!>   taken, t < t_goal) or `adv_event` (a guard of the current modes went
!>   negative: t <= t_goal is the located crossing, the modes are not yet
!>   updated). An event beyond t_goal is held until t_goal has been returned
!>   (from the step's dense output): a sample is never a later state (D-49).
!> - `restart` is called after the driver changed the modes or passed a
!>   breakpoint: the right-hand side is not smooth across (t, y), so no history
!>   may be carried over. It gives the next stop time. A caller that changes y
!>   itself between two advances calls it too (D-37: RK4 checks y there, not
!>   at every step).
!> - `statistics` adds the integrator's counters to a run_stats_t.
!> - `finish` frees what `start` made (also after a failure).
!> Adding an integrator = one file with an extension of this type and its
!> factory + one row in trainsim_integrator_registry.
module trainsim_integrator
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_run_stats, only: run_stats_t
   implicit none
   private

   public :: integrator_t, adv_step, adv_reached, adv_event

   !> Outcomes of `advance`.
   integer, parameter :: adv_step = 0     !< one internal step taken, t < t_goal
   integer, parameter :: adv_reached = 1  !< t reached t_goal
   integer, parameter :: adv_event = 2    !< a guard crossed zero at t (modes not yet updated)

   type, abstract :: integrator_t
      !> Counters this integrator keeps itself (steps, RHS evaluations, ...).
      type(run_stats_t) :: stats
      !> The integrator must not step past t_stop; a step that ends there ends on
      !> a breakpoint of the inputs when stop_is_breakpoint (a jump or kink).
      real(wp) :: t_stop = 0.0_wp
      logical :: stop_is_breakpoint = .false.
      !> The caller handles local event instants through `local_instant` (the
      !> driver does): at such an instant `advance` may then set in y only the
      !> states `local_instant` names (and the energy states); the others are set
      !> when the local step ends, or ends early.
      logical :: region_instants = .false.
      !> `advance_block` takes plain steps in blocks (D-38): set by a
      !> constructor whose type implements it (an extension that steps
      !> differently inherits the procedure but not this flag).
      logical :: takes_blocks = .false.
   contains
      procedure(start_i), deferred :: start
      procedure(advance_i), deferred :: advance
      procedure :: advance_block => integrator_advance_block
      procedure :: restart => integrator_restart
      procedure, non_overridable :: statistics => integrator_statistics
      procedure :: flush_counters => integrator_flush_counters
      procedure :: finish => integrator_finish
      procedure :: fired => integrator_fired
      procedure :: may_miss_events => integrator_may_miss_events
      procedure :: local_instant => integrator_local_instant
      procedure, non_overridable :: set_stop => integrator_set_stop
   end type integrator_t

   abstract interface
      !> Prepare to integrate from (t, y); t_stop and stop_is_breakpoint are set.
      subroutine start_i(self, model, t, y, err)
         import :: integrator_t, model_t, wp, error_t
         class(integrator_t), intent(inout), target :: self
         type(model_t), intent(inout), target :: model
         real(wp), intent(in) :: t, y(:)
         type(error_t), allocatable, intent(out) :: err
      end subroutine start_i
      !> Advance (t, y) towards t_goal; status is one of adv_*.
      subroutine advance_i(self, model, t_goal, t, y, status, err)
         import :: integrator_t, model_t, wp, error_t
         class(integrator_t), intent(inout), target :: self
         type(model_t), intent(inout), target :: model
         real(wp), intent(in) :: t_goal
         real(wp), intent(inout) :: t, y(:)
         integer, intent(out) :: status
         type(error_t), allocatable, intent(out) :: err
      end subroutine advance_i
   end interface

contains

   !> Record the next stop time (the driver calls this before start/restart).
   subroutine integrator_set_stop(self, t_stop, is_breakpoint)
      class(integrator_t), intent(inout) :: self
      real(wp), intent(in) :: t_stop
      logical, intent(in) :: is_breakpoint
      self%t_stop = t_stop
      self%stop_is_breakpoint = is_breakpoint
   end subroutine integrator_set_stop

   !> Up to model%blk%cap plain steps toward t_goal in one call, each step's
   !> end in a column of model%blk, model%blk%n of them (D-38; see rk4_t's).
   !> Default: none (model%blk%n = 0); the caller then calls `advance`.
   subroutine integrator_advance_block(self, model, t_goal, t_tol, y_limit, t, y)
      class(integrator_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t_goal, t_tol, y_limit
      real(wp), intent(inout) :: t
      real(wp), intent(inout), contiguous :: y(:)
      associate (unused_s => self, unused_t => t_goal, unused_tol => t_tol, unused_l => y_limit, unused_tt => t, &
                 unused_y => y)
      end associate
      model%blk%n = 0
   end subroutine integrator_advance_block

   !> Default restart: one-step methods carry no history.
   subroutine integrator_restart(self, model, t, y, err)
      class(integrator_t), intent(inout), target :: self
      type(model_t), intent(inout), target :: model
      real(wp), intent(in) :: t, y(:)
      type(error_t), allocatable, intent(out) :: err
   end subroutine integrator_restart

   !> Bring self%stats up to date (an integrator whose library keeps counters
   !> of its own adds them here). Default: self%stats is always current.
   subroutine integrator_flush_counters(self)
      class(integrator_t), intent(inout) :: self
   end subroutine integrator_flush_counters

   !> Add this integrator's counters to stats (call once, at the end of a run).
   subroutine integrator_statistics(self, stats)
      class(integrator_t), intent(inout) :: self
      type(run_stats_t), intent(inout) :: stats
      call self%flush_counters()
      stats%steps = stats%steps + self%stats%steps
      stats%rhs_evals = stats%rhs_evals + self%stats%rhs_evals
      stats%jac_evals = stats%jac_evals + self%stats%jac_evals
      stats%root_returns = stats%root_returns + self%stats%root_returns
      stats%error_test_fails = stats%error_test_fails + self%stats%error_test_fails
      stats%conv_fails = stats%conv_fails + self%stats%conv_fails
      stats%rejected = stats%rejected + self%stats%rejected
      stats%block_steps = stats%block_steps + self%stats%block_steps
   end subroutine integrator_statistics

   !> The guards that fired at an event the integrator returned (default: those
   !> below zero; a root finder may also report a crossing located just above).
   subroutine integrator_fired(self, g, fired)
      class(integrator_t), intent(inout) :: self
      real(wp), intent(in) :: g(:)
      logical, intent(out) :: fired(:)
      fired = g < 0.0_wp
   end subroutine integrator_fired

   !> Whether a guard may be below zero at the end of an advance without the
   !> integrator having reported it (a root finder can miss a crossing that
   !> goes down and up inside one step): the driver then checks the guards at
   !> every output time. Default: no (the state at the end of every step was
   !> checked by `advance` itself). Asked once per run: the answer may not change.
   pure logical function integrator_may_miss_events(self) result(may)
      class(integrator_t), intent(in) :: self
      may = .false.
   end function integrator_may_miss_events

   !> Whether the event `advance` just returned is a local event instant (D-32):
   !> only the states `states` of the nodes `nodes` are integration points at t
   !> (the others are interpolations inside a step that ends later), only the
   !> guards of the elements `gels` can have fired, and `els` are the elements
   !> with both nodes among `nodes`. The driver and the observer then work on
   !> those alone. Default: no (every event instant is one of the whole train).
   logical function integrator_local_instant(self, nodes, states, els, gels) result(local)
      class(integrator_t), intent(in), target :: self
      integer, pointer, contiguous, intent(out) :: nodes(:), states(:), els(:), gels(:)
      nodes => null(); states => null(); els => null(); gels => null()
      local = .false.
   end function integrator_local_instant

   !> Default finish: nothing to free.
   subroutine integrator_finish(self)
      class(integrator_t), intent(inout) :: self
   end subroutine integrator_finish
end module trainsim_integrator
