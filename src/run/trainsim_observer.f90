!> What every integrator reports to after each accepted step and each event:
!> keeps the metrics engineers look at (torque and displacement extremes,
!> impacts, approach velocities, peak contact forces, loss of contact), the
!> event table (with each contact's peak force and duration), and hands
!> samples to the sink at the output interval and at every event.
!>
!> Memory does not grow with the run: event rows are streamed to the sink as
!> they happen (sink_t%write_event; a contact's row again with its final peak
!> force and duration when it ends, sink_t%update_event), only the rows of the
!> contacts in progress are kept (one per element), and the peak-to-peak
!> figures come from an online detector (trainsim_metrics). The whole event
!> table is kept in the result only when run%keep_events asks for it.
module trainsim_observer
   use trainsim_kinds, only: wp, i8, two_pi
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_element, only: element_slot_t
   use trainsim_input_series, only: input_drivers, input_series_values
   use trainsim_sink, only: sink_t, sample_t, event_t, run_stats_t, element_metrics_t, &
                            ev_contact_front, ev_contact_rear, ev_separation, run_meta_t
   use trainsim_run_meta, only: make_meta
   use trainsim_metrics, only: p2p_detector_t, push_samples, push_block, push_value, turn_extreme
   use trainsim_quasi_static, only: static_ref_t, kv_absent
   use trainsim_orders, only: order_tracker_t, n_orders
   implicit none
   private

   public :: observer_t, element_metrics_t, run_result_t, make_meta, p2p_hysteresis

   !> Hysteresis of the peak-to-peak detector, as a fraction of the range (D-17).
   real(wp), parameter :: p2p_hysteresis = 0.1_wp

   !> What a run returns in memory.
   type :: run_result_t
      type(run_stats_t) :: stats
      !> the event table, in time order (only if run%keep_events; else size 0).
      !> During a run, the observer's own copy holds instead the row of each
      !> element's contact in progress (slot el(i)%open_event = i).
      type(event_t), allocatable :: events(:)
      type(element_metrics_t), allocatable :: el(:)
      real(wp), allocatable :: y_final(:)
      real(wp) :: t_final = 0.0_wp
      !> the last output time handed to the sink (the end of the history)
      real(wp) :: t_sampled = -huge(1.0_wp)
      real(wp) :: energy_residual_max = 0.0_wp  !< max |stored + dissipated - input - E0|
      real(wp) :: energy_scale = 0.0_wp         !< max of stored energy and work input
      real(wp), allocatable :: series_t(:), series_disp(:, :)   !< (element, sample) if keep_series
      real(wp), allocatable :: series_theta(:, :), series_omega(:, :)   !< (node, sample) if keep_series
      !> why the gear meshes have no Kv or static TE ('': computed, or no gear mesh; D-138)
      character(len=:), allocatable :: kv_absent
   end type run_result_t

   type :: observer_t
      !> The sample buffer. After `step` (no peak refinement) it holds at s%t
      !> only what the peak-to-peak detectors read, each element's
      !> displacement, and the energies (s_whole = .false.); the whole sample is
      !> filled when someone takes it (a sink that stores samples,
      !> keep_series) or an event is recorded (D-34).
      type(sample_t) :: s
      logical :: s_whole = .false.                   !< s is a whole sample at s%t
      logical :: take_samples = .true.               !< the sink stores samples (sink_t%stores_samples)
      logical :: speeds_only = .false.               !< the sink reads t and omega only (sink_t%speeds_only)
      logical :: want_whole = .true.                 !< a sink that reads whole samples, or keep: a sample must be whole
      type(run_result_t) :: res
      integer :: n_events = 0                        !< rows handed to the sink so far
      integer, allocatable :: open_row(:)            !< per element: row number of its contact in progress
      logical :: keep_events = .false.               !< keep the whole table in `kept` (run%keep_events)
      type(event_t), allocatable :: kept(:)
      class(sink_t), pointer :: out => null()       !< the run's sink (set by start)
      logical :: started = .false.                   !< start opened the sink and took the first sample
      real(wp) :: t_sampled = -huge(1.0_wp)          !< the last output time handed to the sink
      real(wp) :: t_prev = 0.0_wp, t_metrics = 0.0_wp
      integer :: n_series = 0
      logical :: keep = .false.                      !< keep the whole series of samples (keep_series)
      type(p2p_detector_t), allocatable :: turns(:)  !< per element: peak-to-peak detector of the displacement
      !> The extremes of each element's displacement between output samples
      !> (D-48): the displacement at the last two step ends (turn_d1 at
      !> turn_t1, the later), per element. A turning point of the step-end
      !> sequence (fixed-step integrators) gives the extreme of the parabola
      !> through the three; with peak refinement (adaptive integrators) the
      !> displacement rate changing sign over a step gives the extreme on the
      !> step's cubic Hermite interpolant. Either goes to the detector between
      !> the samples around it.
      !> A step end closer than turn_gap (a quarter of dt) to the last one taken
      !> (a step cut short by an event or an output time) is passed over: the
      !> parabola through points that close would be set by rounding.
      real(wp), allocatable :: turn_d1(:), turn_d2(:)
      real(wp) :: turn_t1 = 0.0_wp, turn_t2 = 0.0_wp, turn_gap = 0.0_wp
      integer, allocatable :: turn_hits(:)   !< a block's turning points (at most one a step: sized to the block)
      logical :: turn_init = .false.
      logical :: track = .false.
      !> Locate contact-force and displacement peaks inside each step (adaptive
      !> integrators, whose steps are long): the previous step end is kept.
      logical :: refine_peaks = .false.
      real(wp), allocatable :: th_prev(:), om_prev(:), force_prev(:), disp_prev(:), torque_prev(:)
      integer, allocatable :: contact_prev(:)
      integer, allocatable :: drivers(:)             !< nodes with a driving input (trainsim_input_series)
      !> per element: the time up to which its time out of contact is counted by
      !> a local event instant (step_part) past t_prev (-huge: none)
      real(wp), allocatable :: t_counted(:)
      type(static_ref_t) :: qs   !< the gear meshes' static reference (set before start; Kv at finish, D-103)
      !> the gear meshes (qs%mesh): their elements, and the order tracker of each, fed
      !> with the output samples from t_metrics on (TE and mesh force, D-104)
      integer, allocatable :: mesh_el(:)
      integer, allocatable :: mesh_drv(:)           !< its driver (left node)
      real(wp), allocatable :: mesh_rate(:)         !< N: the order-1 phase per radian of the driver
      type(order_tracker_t), allocatable :: orders(:)
   contains
      procedure :: start => obs_start
      procedure :: step => obs_step
      procedure :: fold_block => obs_fold_block
      procedure :: step_part => obs_step_part
      procedure :: sample => obs_sample
      procedure, private :: update_metrics => obs_update_metrics
      procedure, private :: fill_part => obs_fill_part
      procedure, private :: update_part => obs_update_part
      procedure, private :: keep_step_end => obs_keep_step_end
      procedure, private :: refine => obs_refine
      procedure :: record_events => obs_record_events
      procedure :: finish => obs_finish
      procedure, private :: feed_orders => obs_feed_orders
      procedure, private :: fill => obs_fill
      procedure, private :: emit => obs_emit
   end type observer_t


   ! The run's start and end and its events (submodule trainsim_observer_events,
   ! src/run/trainsim_observer_events.f90)
   interface
      module subroutine obs_start(self, model, t, y, sink, err)
         class(observer_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: t, y(:)
         class(sink_t), intent(inout), target :: sink   !< kept by the observer until finish (events)
         type(error_t), allocatable, intent(out) :: err
      end subroutine obs_start
      module subroutine obs_step_part(self, model, t, y, nodes, els)
         class(observer_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: t, y(:)
         integer, intent(in) :: nodes(:), els(:)
      end subroutine obs_step_part
      module subroutine obs_fill_part(self, model, t, y, nodes, els)
         class(observer_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: t, y(:)
         integer, intent(in) :: nodes(:), els(:)
      end subroutine obs_fill_part
      module subroutine obs_record_events(self, model, t, y, evs, nev, err, nodes, els)
         class(observer_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: t, y(:)
         type(event_t), intent(in) :: evs(:)
         integer, intent(in) :: nev
         type(error_t), allocatable, intent(out) :: err
         integer, intent(in), optional :: nodes(:), els(:)
      end subroutine obs_record_events
      module subroutine obs_feed_orders(self, model, t_out, t, y)
         class(observer_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: t_out, t, y(:)
      end subroutine obs_feed_orders
      module subroutine obs_finish(self, model, t, y, stats, sink, result, err, interrupted)
         class(observer_t), intent(inout) :: self
         type(model_t), intent(inout) :: model
         real(wp), intent(in) :: t, y(:)
         type(run_stats_t), intent(in) :: stats
         class(sink_t), intent(inout) :: sink
         type(run_result_t), intent(out) :: result
         type(error_t), allocatable, intent(out) :: err
         logical, intent(in), optional :: interrupted
      end subroutine obs_finish
   end interface

contains

   !> Evaluate the recorded quantities at (t, y) into the sample buffer. When
   !> the integrator has just evaluated the RHS at (t, y) (RK4's end-of-step
   !> stage, model%ws_step_end), the kinematics and the element torques are
   !> read from the model's workspace (bit for bit what would be recomputed).
   subroutine obs_fill(self, model, t, y)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:)
      integer :: i, l, r
      logical :: ws
      ws = model%ws_step_end .and. model%ws_t == t
      self%s_whole = .true.
      if (.not. ws) then
         call model%kinematics(t, y)
         if (model%any_needs_loads) call model%apply_loads(t)   ! torques of elements that read their nodes' loads
      end if
      self%s%t = t
      self%s%y(:) = y
      self%s%theta(:) = model%theta
      self%s%omega(:) = model%omega
      if (ws) then
         self%s%torque_left(:) = model%el_torque(1, :size(self%s%torque_left))   ! (not its zero column, D-95)
         self%s%torque_right(:) = model%el_torque(2, :size(self%s%torque_right))
      else
         do i = 1, size(model%elements)
            call model%element_torques(i, self%s%torque_left(i), self%s%torque_right(i))
         end do
      end if
      do i = 1, size(model%elements)
         if (ws) then
            if (model%status_in_ws(i)) then   ! a linear spring's status, computed by the RHS
               self%s%displacement(i) = model%el_disp(i)
               self%s%force(i) = model%el_force(i)
               self%s%contact(i) = 1
               self%s%pairs(i) = 0
               cycle
            end if
         end if
         if (model%nport) then                              ! (over its ports: D-73)
            call model%elements(i)%e%status_at(model%theta, model%omega, self%s%displacement(i), self%s%force(i), &
                                               self%s%contact(i), self%s%pairs(i))
            cycle
         end if
         associate (e => model%elements(i)%e)
            l = e%left; r = e%right
            call e%status(model%theta(l), model%omega(l), model%theta(r), model%omega(r), &
                          self%s%displacement(i), self%s%force(i), self%s%contact(i), self%s%pairs(i))
         end associate
      end do
      if (size(self%s%inputs) > 0) call input_series_values(model, self%drivers, t, self%s%inputs)
      if (self%track) call fill_energy(self, model, y)
   end subroutine obs_fill

   !> The energies of the sample at (s%t, y), the kinematics at (s%t, y) in the
   !> workspace. When the integrator has just evaluated the RHS there and the
   !> kernel left the stored energy (model%ws_energy, D-36), it is read from
   !> the workspace (bit for bit `workspace_energy`'s), else computed.
   subroutine fill_energy(self, model, y)
      type(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:)
      real(wp) :: stored
      if (model%ws_energy .and. model%ws_step_end .and. model%ws_t == self%s%t) then
         stored = model%ws_stored
         self%s%energy(2) = model%ws_elastic
      else
         call model%workspace_energy(y, stored, self%s%energy(2))
      end if
      self%s%energy(1) = stored - self%s%energy(2)
      self%s%energy(3) = y(model%n_states + 1)
      self%s%energy(4) = y(model%n_states + 2)
      self%s%energy(5) = stored + self%s%energy(3) - self%s%energy(4) - model%energy0
   end subroutine fill_energy

   !> The sample's energies into the balance figures.
   subroutine fold_energy(self)
      type(observer_t), intent(inout) :: self
      call balance_fold(self%s%energy(1), self%s%energy(2), self%s%energy(3), self%s%energy(4), self%s%energy(5), &
                        self%res%energy_residual_max, self%res%energy_scale)
   end subroutine fold_energy

   !> A sample's energies (kinetic, elastic, dissipated, input, residual) into
   !> the balance figures: the largest residual and the energy scale.
   pure subroutine balance_fold(ek, ep, wd, wi, res, rmax, scale)
      real(wp), intent(in) :: ek, ep, wd, wi, res
      real(wp), intent(inout) :: rmax, scale
      rmax = max(rmax, abs(res))
      scale = max(scale, abs(ek + ep), abs(wi), abs(wd))
   end subroutine balance_fold

   !> The kernel of `step`'s short way on plain arrays (dummies: no aliasing, the array
   !> descriptors read once): per element, its status from the workspace (a
   !> linear spring or a clearance element's hot form whose status the RHS
   !> computed: ws_status, D-36) or from the element, then fold_element's
   !> updates in fold_element's order.
   subroutine fold_ws(t, on, t_prev, el_torque, el_disp, el_force, el_contact, in_ws, elements, theta, omega, disp, m, &
                      events, t_counted)
      real(wp), intent(in) :: t, t_prev
      logical, intent(in) :: on    !< t >= t_metrics
      real(wp), intent(in), contiguous :: el_torque(:, :), el_disp(:), el_force(:), theta(:), omega(:), t_counted(:)
      integer, intent(in), contiguous :: el_contact(:)
      logical, intent(in), contiguous :: in_ws(:)
      type(element_slot_t), intent(in), contiguous :: elements(:)
      real(wp), intent(inout), contiguous :: disp(:)
      type(element_metrics_t), intent(inout), contiguous :: m(:)
      type(event_t), intent(inout), contiguous :: events(:)
      integer :: i, k, c, p
      real(wp) :: d, f, torque, t0
      do i = 1, size(elements)
         if (in_ws(i)) then
            d = el_disp(i)
            f = el_force(i)
            c = el_contact(i)
         else
            call elements(i)%e%status_at(theta, omega, d, f, c, p)
         end if
         torque = el_torque(2, i)
         disp(i) = d
         k = m(i)%open_event
         if (k > 0) events(k)%peak_force = max(events(k)%peak_force, abs(f))
         if (on) then
            m(i)%force_min = min(m(i)%force_min, f)
            m(i)%force_max = max(m(i)%force_max, f)
            m(i)%torque_min = min(m(i)%torque_min, torque)
            m(i)%torque_max = max(m(i)%torque_max, torque)
            m(i)%disp_min = min(m(i)%disp_min, d)
            m(i)%disp_max = max(m(i)%disp_max, d)
            t0 = max(t_prev, t_counted(i))
            if (c == 0 .and. t > t0) m(i)%time_out_of_contact = m(i)%time_out_of_contact + (t - t0)
         end if
      end do
   end subroutine fold_ws

   !> Cubic Hermite interpolation on a step of length h at tau in [0, 1]: the
   !> value x and its rate v from the values and rates at both ends.
   pure subroutine hermite(x0, v0, x1, v1, h, tau, x, v)
      real(wp), intent(in) :: x0, v0, x1, v1, h, tau
      real(wp), intent(out) :: x, v
      real(wp) :: t2, t3
      t2 = tau*tau; t3 = t2*tau
      x = (2.0_wp*t3 - 3.0_wp*t2 + 1.0_wp)*x0 + (t3 - 2.0_wp*t2 + tau)*h*v0 + (3.0_wp*t2 - 2.0_wp*t3)*x1 + &
          (t3 - t2)*h*v1
      v = ((6.0_wp*t2 - 6.0_wp*tau)*x0 + (6.0_wp*tau - 6.0_wp*t2)*x1)/h + (3.0_wp*t2 - 4.0_wp*tau + 1.0_wp)*v0 + &
          (3.0_wp*t2 - 2.0_wp*tau)*v1
   end subroutine hermite

   !> Write the current sample to the sink; feed the turning points of the
   !> peak-to-peak metrics, and the in-memory series when it is kept.
   subroutine obs_emit(self, sink, err)
      class(observer_t), intent(inout) :: self
      class(sink_t), intent(inout) :: sink
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: t2(:), d2(:, :), th2(:, :), om2(:, :)
      integer :: n
      if (self%s%t >= self%t_metrics) call push_samples(self%turns, self%s%displacement)
      if (self%keep) then
         if (self%n_series == size(self%res%series_t)) then
            n = self%n_series
            allocate (t2(2*n), d2(size(self%res%series_disp, 1), 2*n))
            allocate (th2(size(self%s%theta), 2*n), om2(size(self%s%theta), 2*n))
            t2(1:n) = self%res%series_t(1:n)
            d2(:, 1:n) = self%res%series_disp(:, 1:n)
            th2(:, 1:n) = self%res%series_theta(:, 1:n)
            om2(:, 1:n) = self%res%series_omega(:, 1:n)
            call move_alloc(t2, self%res%series_t)
            call move_alloc(d2, self%res%series_disp)
            call move_alloc(th2, self%res%series_theta)
            call move_alloc(om2, self%res%series_omega)
         end if
         self%n_series = self%n_series + 1
         self%res%series_t(self%n_series) = self%s%t
         self%res%series_disp(:, self%n_series) = self%s%displacement
         self%res%series_theta(:, self%n_series) = self%s%theta
         self%res%series_omega(:, self%n_series) = self%s%omega
      end if
      if (self%take_samples) then
         call sink%write_sample(self%s, err)
         self%t_sampled = self%s%t
      end if
   end subroutine obs_emit

   !> After every step of the integrator: update the metrics at (t, y).
   subroutine obs_step(self, model, t, y)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:)
      ! the short way (D-34): no peak refinement, and the integrator has just
      ! evaluated the RHS at (t, y) (model%ws_step_end). Each element's
      ! displacement, force, contact and torque on its right node are taken
      ! from the model's workspace (bit for bit what `fill` puts in the
      ! sample) and folded into the metrics as `update_metrics` does; only the
      ! displacements (and the energies) go to the sample buffer (s_whole = .false.)
      if (.not. self%refine_peaks .and. model%ws_step_end) then
         if (model%ws_t == t) then
            self%s%t = t
            self%s_whole = .false.
            call fold_ws(t, t >= self%t_metrics, self%t_prev, model%el_torque, model%el_disp, model%el_force, &
                         model%el_contact, model%ws_status, model%elements, model%theta, model%omega, self%s%displacement, &
                         self%res%el, self%res%events, self%t_counted)
            if (self%track) then
               if (model%ws_energy) then
                  ! fill_energy with the stored energy the kernel left (D-36), written out
                  self%s%energy(2) = model%ws_elastic
                  self%s%energy(1) = model%ws_stored - model%ws_elastic
                  self%s%energy(3) = y(model%n_states + 1)
                  self%s%energy(4) = y(model%n_states + 2)
                  self%s%energy(5) = model%ws_stored + self%s%energy(3) - self%s%energy(4) - model%energy0
               else
                  call fill_energy(self, model, y)
               end if
               call fold_energy(self)
            end if
            call track_turns(self, t)
            self%t_prev = t
            return
         end if
      end if
      call self%fill(model, t, y)
      if (self%refine_peaks) then
         call self%refine(model, t)
         call refine_turns(self, model, t)
      else
         call track_turns(self, t)
      end if
      call self%update_metrics(model, t)
      if (self%refine_peaks) call self%keep_step_end()
   end subroutine obs_step

   !> The step end t (the displacements in the sample buffer) into each
   !> element's last three step ends: where the middle one is a turning point,
   !> the extreme of the parabola through the three to the element's
   !> peak-to-peak detector (from t_metrics on). Only a turning point costs
   !> more than the compare and the shift (D-48). A step end within turn_gap of
   !> the last one is passed over.
   subroutine track_turns(self, t)
      type(observer_t), intent(inout) :: self
      real(wp), intent(in) :: t
      integer :: i
      real(wp) :: d, x, tx
      if (.not. self%turn_init) then   ! the run's first point: no turn before it
         self%turn_d1 = self%s%displacement
         self%turn_d2 = self%s%displacement
         self%turn_t1 = t; self%turn_t2 = t
         self%turn_init = .true.
         return
      end if
      if (.not. t - self%turn_t1 >= self%turn_gap) return
      do i = 1, size(self%turn_d1)
         d = self%s%displacement(i)
         if ((d - self%turn_d1(i))*(self%turn_d1(i) - self%turn_d2(i)) < 0.0_wp) then
            call turn_extreme(self%turn_t2, self%turn_t1, t, self%turn_d2(i), self%turn_d1(i), d, x, tx)
            if (tx >= self%t_metrics) call push_value(self%turns(i), x)
         end if
         self%turn_d2(i) = self%turn_d1(i)
         self%turn_d1(i) = d
      end do
      self%turn_t2 = self%turn_t1
      self%turn_t1 = t
   end subroutine track_turns

   !> With peak refinement: the extremes of each element's displacement inside
   !> the step (t_prev, t], where its rate changes sign between the step's
   !> ends, located on the cubic Hermite interpolant of its nodes (as
   !> obs_refine's peaks) by bisection on the rate, to the element's
   !> peak-to-peak detector (from t_metrics on). The displacement is affine in
   !> the node angles (every element's is), so its rate is the displacement of
   !> the node speeds less that of zero angles.
   subroutine refine_turns(self, model, t)
      type(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: t
      integer, parameter :: n_bisect = 60
      real(wp) :: h, r0, r1, a, b, c, rc, thl, wl, thr, wr, x
      integer :: i, l, r, it
      h = t - self%t_prev
      if (.not. h > 0.0_wp) return
      do i = 1, size(model%elements)
         if (model%nport) then
            if (model%elements(i)%e%n_ports() > 2) cycle   ! (the interpolants of two ports only, D-73)
         end if
         associate (e => model%elements(i)%e)
            l = e%left; r = e%right
            r0 = rate(self%om_prev(l), self%om_prev(r))
            r1 = rate(self%s%omega(l), self%s%omega(r))
            if (.not. r0*r1 < 0.0_wp) cycle
            a = 0.0_wp; b = 1.0_wp
            do it = 1, n_bisect
               c = 0.5_wp*(a + b)
               call hermite(self%th_prev(l), self%om_prev(l), self%s%theta(l), self%s%omega(l), h, c, thl, wl)
               call hermite(self%th_prev(r), self%om_prev(r), self%s%theta(r), self%s%omega(r), h, c, thr, wr)
               rc = rate(wl, wr)
               if (rc*r0 > 0.0_wp) then
                  a = c
               else
                  b = c
               end if
            end do
            c = 0.5_wp*(a + b)
            call hermite(self%th_prev(l), self%om_prev(l), self%s%theta(l), self%s%omega(l), h, c, thl, wl)
            call hermite(self%th_prev(r), self%om_prev(r), self%s%theta(r), self%s%omega(r), h, c, thr, wr)
            x = e%displacement(thl, thr)
            if (self%t_prev + c*h >= self%t_metrics) call push_value(self%turns(i), x)
         end associate
      end do
   contains
      real(wp) function rate(w_l, w_r)
         real(wp), intent(in) :: w_l, w_r
         rate = model%elements(i)%e%displacement(w_l, w_r) - model%elements(i)%e%displacement(0.0_wp, 0.0_wp)
      end function rate
   end subroutine refine_turns

   !> The steps of a block an integrator has just taken (model%blk, D-38),
   !> folded into the metrics as `step` would fold them one by one (its short
   !> way: the steps' ends are in the block's columns, every element's status
   !> and the stored energy among them: model_t%block_ok), the same updates in
   !> the same order per element. With `samples`, the end of every step of the
   !> block is also an output time, and the sink takes no whole samples:
   !> `sample` after each step (its displacements to the peak-to-peak
   !> detectors; to a sink that reads the speeds only, each step's t and speeds).
   subroutine obs_fold_block(self, model, samples, err)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      logical, intent(in) :: samples
      type(error_t), allocatable, intent(out) :: err
      integer :: n, j, j0, js, i, nh
      real(wp) :: d1, d2, rmax, scale, e0
      n = model%blk%n
      if (n == 0) return
      if (.not. allocated(self%turn_hits)) allocate (self%turn_hits(model%blk%cap))
      if (size(self%turn_hits) < model%blk%cap) then
         deallocate (self%turn_hits)
         allocate (self%turn_hits(model%blk%cap))
      end if
      associate (b => model%blk)
         j0 = 1   ! the first step at or after t_metrics (the metrics' start)
         do while (j0 <= n)
            if (b%t(j0) >= self%t_metrics) exit
            j0 = j0 + 1
         end do
         ! `track_turns` from js on: a block's steps end on the grid (D-38), all but
         ! the first are whole steps, so only the first can be passed over for
         ! turn_gap; a block of that one step alone takes no turn (js > n)
         js = 1
         if (.not. b%t(1) - self%turn_t1 >= self%turn_gap) js = 2
         if (js > n) js = n + 1
         do i = 1, size(model%elements)
            d1 = self%turn_d1(i); d2 = self%turn_d2(i)
            call fold_cols(size(model%elements), b%cap, i, n, j0, js, self%t_prev, b%t, b%disp, b%force, b%torque, &
                           model%el_contact(i), self%res%el(i), self%res%events, self%t_counted(i), &
                           self%turn_d1(i), self%turn_d2(i), self%turn_hits, nh)
            if (js <= n) call el_turns(self, i, b%t, b%disp, n, j0, js, samples, d1, d2, nh)
         end do
         if (js <= n) then
            if (n > js) then
               self%turn_t2 = b%t(n - 1)
            else
               self%turn_t2 = self%turn_t1
            end if
            self%turn_t1 = b%t(n)
         end if
         if (self%track) then
            ! the short way's energies (the stored energy from the kernel, D-36),
            ! the figures in registers and the sample's energies the last step's (D-169)
            rmax = self%res%energy_residual_max
            scale = self%res%energy_scale
            e0 = model%energy0
            do j = 1, n
               call balance_fold(b%stored(j) - b%elastic(j), b%elastic(j), b%work(1, j), b%work(2, j), &
                                 b%stored(j) + b%work(1, j) - b%work(2, j) - e0, rmax, scale)
            end do
            self%res%energy_residual_max = rmax
            self%res%energy_scale = scale
            self%s%energy(2) = b%elastic(n)
            self%s%energy(1) = b%stored(n) - b%elastic(n)
            self%s%energy(3) = b%work(1, n)
            self%s%energy(4) = b%work(2, n)
            self%s%energy(5) = b%stored(n) + self%s%energy(3) - self%s%energy(4) - e0
         end if
         if (samples .and. size(self%mesh_el) > 0) then   ! every step end an output sample (D-104)
            do j = j0, n
               call block_orders(self, model, b%t(j), b%disp(:, j), b%force(:, j), b%omega(:, j))
            end do
         end if
         if (samples .and. self%speeds_only) then
            do j = 1, n
               self%s%t = b%t(j)
               self%s%omega(:) = b%omega(:, j)
               call self%out%write_sample(self%s, err)
               if (allocated(err)) return
            end do
            self%t_sampled = b%t(n)
         end if
         self%s%displacement(:) = b%disp(:, n)
         self%s%t = b%t(n)
         self%s_whole = .false.
         self%t_prev = b%t(n)
      end associate
   end subroutine obs_fold_block

   !> `track_turns` for element i over the n steps of a block, from the turning
   !> points `fold_cols` found (turn_hits(1:nh)) and its last two points before
   !> the block (d1 the later, d2); with `samples`, each step's displacement
   !> (from step j0 on) to the detector too, after the extreme found at that
   !> step, as `step` and then `sample` push them.
   subroutine el_turns(self, i, tc, disp, n, j0, js, samples, d1, d2, nh)
      type(observer_t), intent(inout) :: self
      real(wp), intent(in) :: tc(:), disp(:, :), d1, d2
      integer, intent(in) :: i, n, j0, js, nh
      logical, intent(in) :: samples
      integer :: j, jj, q
      real(wp) :: ta, tb, da, db, x, tx
      jj = j0   ! the next sample to push
      do q = 1, nh
         j = self%turn_hits(q)
         ! the two points taken before step j's end: in the block, or the last ones before it
         if (j - 2 >= js) then
            ta = tc(j - 2); da = disp(i, j - 2); tb = tc(j - 1); db = disp(i, j - 1)
         else if (j - 1 >= js) then
            ta = self%turn_t1; da = d1; tb = tc(j - 1); db = disp(i, j - 1)
         else
            ta = self%turn_t2; da = d2; tb = self%turn_t1; db = d1
         end if
         call turn_extreme(ta, tb, tc(j), da, db, disp(i, j), x, tx)
         if (tx >= self%t_metrics) then
            if (samples .and. jj < j) call push_block(self%turns(i:i), disp(i:i, :), jj, j - 1)
            jj = max(jj, j)
            call push_value(self%turns(i), x)
         end if
      end do
      if (samples .and. jj <= n) call push_block(self%turns(i:i), disp(i:i, :), jj, n)
   end subroutine el_turns

   !> One step end of a block, an output sample at t >= t_metrics, into the gear
   !> meshes' order trackers: the block's displacements, forces and node speeds (D-104).
   subroutine block_orders(self, model, t, disp, force, omega)
      type(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: t, disp(:), force(:), omega(:)
      integer :: q, i
      real(wp) :: x(2)
      do q = 1, size(self%mesh_el)
         i = self%mesh_el(q)
         x(1) = disp(i); x(2) = force(i)
         call self%orders(q)%push(t, self%mesh_rate(q)*omega(self%mesh_drv(q)), x)
      end do
   end subroutine block_orders

   !> `fold_ws` for element i over the n steps of a block (explicit-shape
   !> arrays: the block's columns, (element, step)), and the scan for its
   !> turning points in the same pass over its displacements: the steps j = js
   !> .. n at whose end the point before is one (`track_turns`' test) into
   !> hits(1:nh), from the element's last two points d1 (later), d2, which are
   !> advanced to the block's last two. A contact's mode does not change inside
   !> a block (events end blocks): contact holds for all its steps.
   subroutine fold_cols(ne, cap, i, n, j0, js, t_prev, tc, disp, force, torque, contact, m, events, t_counted, &
                        d1, d2, hits, nh)
      integer, intent(in) :: ne, cap, i, n
      integer, intent(in) :: j0   !< the first step at or after t_metrics
      integer, intent(in) :: js   !< the first step taken for turning points
      real(wp), intent(in) :: t_prev, tc(cap), disp(ne, cap), force(ne, cap), torque(ne, cap)
      integer, intent(in) :: contact
      type(element_metrics_t), intent(inout) :: m
      type(event_t), intent(inout) :: events(:)
      real(wp), intent(in) :: t_counted
      real(wp), intent(inout) :: d1, d2
      integer, intent(inout) :: hits(cap)
      integer, intent(out) :: nh
      integer :: j, k, jf
      real(wp) :: pk, fmin, fmax, tmin, tmax, dmin, dmax, tp, t0, tout, a, b, d, da, ab
      k = m%open_event
      if (k > 0) then
         pk = events(k)%peak_force
         do j = 1, n
            pk = max(pk, abs(force(i, j)))
         end do
         events(k)%peak_force = pk
      end if
      fmin = m%force_min; fmax = m%force_max
      tmin = m%torque_min; tmax = m%torque_max
      dmin = m%disp_min; dmax = m%disp_max
      a = d1; b = d2; nh = 0
      jf = max(j0, js)   ! from jf on both; before it, one of them
      ! (no internal procedures for these: the variables they would share stay in registers)
      do j = j0, min(jf - 1, n)   ! the extremes alone (before js)
         fmin = min(fmin, force(i, j)); fmax = max(fmax, force(i, j))
         tmin = min(tmin, torque(i, j)); tmax = max(tmax, torque(i, j))
         dmin = min(dmin, disp(i, j)); dmax = max(dmax, disp(i, j))
      end do
      ! (the test (d - a)*(a - b) < 0 with a - b carried: the last point's d - a, D-161)
      ab = a - b
      do j = js, min(jf - 1, n)   ! the turning points alone (before j0)
         d = disp(i, j)
         da = d - a
         if (da*ab < 0.0_wp) then
            nh = nh + 1
            hits(nh) = j
         end if
         ab = da
         b = a; a = d
      end do
      do j = jf, n
         d = disp(i, j)
         fmin = min(fmin, force(i, j))
         fmax = max(fmax, force(i, j))
         tmin = min(tmin, torque(i, j))
         tmax = max(tmax, torque(i, j))
         dmin = min(dmin, d)
         dmax = max(dmax, d)
         da = d - a
         if (da*ab < 0.0_wp) then
            nh = nh + 1
            hits(nh) = j
         end if
         ab = da
         b = a; a = d
      end do
      d1 = a; d2 = b
      if (j0 > n) return
      m%force_min = fmin; m%force_max = fmax
      m%torque_min = tmin; m%torque_max = tmax
      m%disp_min = dmin; m%disp_max = dmax
      if (contact == 0) then
         tout = m%time_out_of_contact
         do j = j0, n
            tp = t_prev
            if (j > 1) tp = tc(j - 1)
            t0 = max(tp, t_counted)
            if (tc(j) > t0) tout = tout + (tc(j) - t0)
         end do
         m%time_out_of_contact = tout
      end if
   end subroutine fold_cols

   !> `update_metrics` for the elements els only, at a local event instant:
   !> t_prev stays (the other elements' last point), each element's time out
   !> of contact is counted to t (t_counted).
   subroutine obs_update_part(self, t, els)
      class(observer_t), intent(inout) :: self
      real(wp), intent(in) :: t
      integer, intent(in) :: els(:)
      integer :: q
      do q = 1, size(els)
         call fold_element(self, els(q), t)
         self%t_counted(els(q)) = t
      end do
   end subroutine obs_update_part

   !> Fold element i of the sample buffer (filled at t) into its running metrics:
   !> the open contact's peak force, the extremes, and the time out of contact
   !> since the later of the last point (t_prev) and the element's own last
   !> local instant (t_counted).
   subroutine fold_element(self, i, t)
      type(observer_t), intent(inout) :: self
      integer, intent(in) :: i
      real(wp), intent(in) :: t
      integer :: k
      real(wp) :: t0
      associate (m => self%res%el(i))
         k = m%open_event
         if (k > 0) self%res%events(k)%peak_force = max(self%res%events(k)%peak_force, abs(self%s%force(i)))
         if (t >= self%t_metrics) then
            m%force_min = min(m%force_min, self%s%force(i))
            m%force_max = max(m%force_max, self%s%force(i))
            m%torque_min = min(m%torque_min, self%s%torque_right(i))
            m%torque_max = max(m%torque_max, self%s%torque_right(i))
            m%disp_min = min(m%disp_min, self%s%displacement(i))
            m%disp_max = max(m%disp_max, self%s%displacement(i))
            t0 = max(self%t_prev, self%t_counted(i))
            if (self%s%contact(i) == 0 .and. t > t0) m%time_out_of_contact = m%time_out_of_contact + (t - t0)
         end if
      end associate
   end subroutine fold_element

   !> The step end just filled, as the start of the next step's interpolation.
   subroutine obs_keep_step_end(self)
      class(observer_t), intent(inout) :: self
      self%th_prev = self%s%theta
      self%om_prev = self%s%omega
      self%force_prev = self%s%force
      self%disp_prev = self%s%displacement
      self%torque_prev = self%s%torque_right
      self%contact_prev = self%s%contact
   end subroutine obs_keep_step_end

   !> Peaks inside the step (t_prev, t] of every element in contact on the same
   !> face over the whole step (events end steps, so its mode did not change):
   !> the node angles are interpolated by the cubic Hermite polynomial through
   !> their angles and speeds at both ends (exact for steady rotation, O(h^4)
   !> for the vibration), the element's force and displacement evaluated along
   !> it, and an interior extreme located by golden section. No right-hand side
   !> is evaluated. Results go to the open contact's peak force and the extremes.
   subroutine obs_refine(self, model, t)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: t
      real(wp), parameter :: gr = 0.6180339887498949_wp
      integer, parameter :: n_golden = 30
      real(wp) :: h, fm, dm, tm, a, b, c, d, fc, fd, f_best, d_best, tau_best
      integer :: i, l, r, it, k, q
      h = t - self%t_prev
      if (.not. h > 0.0_wp) return
      do i = 1, size(model%elements)
         if (self%s%contact(i) == 0 .or. self%s%contact(i) /= self%contact_prev(i)) cycle
         if (model%nport) then
            if (model%elements(i)%e%n_ports() > 2) cycle   ! (the interpolants of two ports only, D-73)
         end if
         l = model%elements(i)%e%left
         r = model%elements(i)%e%right
         ! 1: |force| maximum, 2: displacement extreme on the contact side,
         ! 3 and 4: maximum and minimum of the torque on the right node; the
         ! middle of the step, evaluated once, says which have an interior extreme
         call at(0.5_wp, fm, dm)
         q = 3
         tm = merit(0.5_wp)
         do q = 1, 4
            select case (q)
            case (1)
               if (.not. abs(fm) > max(abs(self%force_prev(i)), abs(self%s%force(i)))) cycle
            case (2)
               if (.not. self%s%contact(i)*dm > max(self%s%contact(i)*self%disp_prev(i), &
                                                   self%s%contact(i)*self%s%displacement(i))) cycle
            case (3)
               if (.not. tm > max(self%torque_prev(i), self%s%torque_right(i))) cycle
            case (4)
               if (.not. -tm > max(-self%torque_prev(i), -self%s%torque_right(i))) cycle
            end select
            a = 0.0_wp; b = 1.0_wp
            c = b - gr*(b - a); d = a + gr*(b - a)
            fc = merit(c); fd = merit(d)
            do it = 1, n_golden
               if (fc > fd) then
                  b = d; d = c; fd = fc; c = b - gr*(b - a); fc = merit(c)
               else
                  a = c; c = d; fc = fd; d = a + gr*(b - a); fd = merit(d)
               end if
            end do
            tau_best = 0.5_wp*(a + b)
            call at(tau_best, f_best, d_best)
            associate (m => self%res%el(i))
               k = m%open_event
               if (q == 1 .and. k > 0) self%res%events(k)%peak_force = max(self%res%events(k)%peak_force, abs(f_best))
               if (self%t_prev + tau_best*h >= self%t_metrics) then
                  select case (q)
                  case (1)
                     m%force_min = min(m%force_min, f_best)
                     m%force_max = max(m%force_max, f_best)
                  case (2)
                     m%disp_min = min(m%disp_min, d_best)
                     m%disp_max = max(m%disp_max, d_best)
                  case (3)
                     m%torque_max = max(m%torque_max, merit(tau_best))
                  case (4)
                     m%torque_min = min(m%torque_min, -merit(tau_best))
                  end select
               end if
            end associate
         end do
      end do
   contains
      !> What is maximised at tau: |force|, the displacement towards the contact
      !> face, the torque on the right node, or minus that torque.
      real(wp) function merit(tau)
         real(wp), intent(in) :: tau
         real(wp) :: f, dd, thl, wl, thr, wr, tl, tr
         select case (q)
         case (1, 2)
            call at(tau, f, dd)
            merit = abs(f)
            if (q == 2) merit = self%s%contact(i)*dd
         case default
            call hermite(self%th_prev(l), self%om_prev(l), self%s%theta(l), self%s%omega(l), h, tau, thl, wl)
            call hermite(self%th_prev(r), self%om_prev(r), self%s%theta(r), self%s%omega(r), h, tau, thr, wr)
            call model%elements(i)%e%torques(thl, wl, thr, wr, tl, tr)
            merit = tr
            if (q == 4) merit = -tr
         end select
      end function merit
      !> Force and displacement of element i at t_prev + tau h on the interpolant.
      subroutine at(tau, f, dd)
         real(wp), intent(in) :: tau
         real(wp), intent(out) :: f, dd
         real(wp) :: thl, wl, thr, wr
         integer :: contact, pairs
         call hermite(self%th_prev(l), self%om_prev(l), self%s%theta(l), self%s%omega(l), h, tau, thl, wl)
         call hermite(self%th_prev(r), self%om_prev(r), self%s%theta(r), self%s%omega(r), h, tau, thr, wr)
         call model%elements(i)%e%status(thl, wl, thr, wr, dd, f, contact, pairs)
      end subroutine at
   end subroutine obs_refine

   !> Fold the sample buffer (filled at t) into the running metrics: extremes,
   !> the open contacts' peak forces, time out of contact, the energy residual.
   subroutine obs_update_metrics(self, model, t)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: t
      integer :: i, k
      real(wp) :: t0
      ! fold_element for every element, the time test once
      do i = 1, size(model%elements)
         k = self%res%el(i)%open_event
         if (k > 0) self%res%events(k)%peak_force = max(self%res%events(k)%peak_force, abs(self%s%force(i)))
      end do
      if (t >= self%t_metrics) then
         do i = 1, size(model%elements)
            associate (m => self%res%el(i), f => self%s%force(i), tr => self%s%torque_right(i), &
                       dd => self%s%displacement(i))
               m%force_min = min(m%force_min, f)
               m%force_max = max(m%force_max, f)
               m%torque_min = min(m%torque_min, tr)
               m%torque_max = max(m%torque_max, tr)
               m%disp_min = min(m%disp_min, dd)
               m%disp_max = max(m%disp_max, dd)
               t0 = max(self%t_prev, self%t_counted(i))
               if (self%s%contact(i) == 0 .and. t > t0) m%time_out_of_contact = m%time_out_of_contact + (t - t0)
            end associate
         end do
      end if
      if (self%track) call fold_energy(self)
      self%t_prev = t
   end subroutine obs_update_metrics

   !> The output sample at output time t_out (the state (t, y), with t within
   !> the driver's tolerance of t_out): written with the time t_out exactly.
   subroutine obs_sample(self, model, t_out, t, y, sink, err)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t_out, t, y(:)
      class(sink_t), intent(inout) :: sink
      type(error_t), allocatable, intent(out) :: err
      if (self%s%t == t .and. .not. self%want_whole) then
         ! `emit` for a sample no one takes whole: the peak-to-peak detectors,
         ! and for a sink that reads the speeds only (a sweep run), the node
         ! speeds the integrator has just left in the workspace (bit for bit
         ! what `fill` copies); without them, the whole sample as below
         if (self%speeds_only) then
            if (model%ws_step_end .and. model%ws_t == t) then
               self%s%omega(:) = model%omega
            else
               call self%fill(model, t, y)
            end if
         end if
         self%s%t = t_out
         if (t_out >= self%t_metrics) then
            call push_samples(self%turns, self%s%displacement)
            if (size(self%mesh_el) > 0) call self%feed_orders(model, t_out, t, y)
         end if
         if (self%speeds_only) then
            call sink%write_sample(self%s, err)
            self%t_sampled = t_out
         end if
         return
      end if
      if (self%s%t /= t .or. .not. self%s_whole) call self%fill(model, t, y)
      self%s%t = t_out
      if (t_out >= self%t_metrics .and. size(self%mesh_el) > 0) call self%feed_orders(model, t_out, t, y)
      call self%emit(sink, err)
   end subroutine obs_sample

end module trainsim_observer
