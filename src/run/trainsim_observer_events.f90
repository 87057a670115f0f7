!> The observer (trainsim_observer) at the run's start, its events and its end: the
!> sink opened and the first sample (`start`), the event table's rows streamed to the
!> sink as events happen (`record_events`), the state at a local event instant of
!> RK4 (`step_part`), and the metrics, statistics and last rows at the end (`finish`).
submodule(trainsim_observer) trainsim_observer_events
   use trainsim_event, only: ev_zone
   use trainsim_rattle, only: rattle_mesh_t, rattle_mesh, rattle_criterion, impact_energy
   implicit none

contains

   !> Begin a run at (t, y): open the sink and record the first sample.
   module subroutine obs_start(self, model, t, y, sink, err)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:)
      class(sink_t), intent(inout), target :: sink   !< kept by the observer until finish (events)
      type(error_t), allocatable, intent(out) :: err
      integer :: nn, ne, nmax, i
      type(run_meta_t) :: meta
      nn = size(model%nodes); ne = size(model%elements)
      allocate (self%s%y(model%n_y), self%s%theta(nn), self%s%omega(nn))
      allocate (self%s%torque_left(ne), self%s%torque_right(ne), self%s%displacement(ne), self%s%force(ne))
      allocate (self%s%contact(ne), self%s%pairs(ne))
      self%drivers = input_drivers(model)
      ! (input_series_count from the drivers just found: one pass over the nodes'
      ! driving inputs, not two; startup7b)
      allocate (self%s%inputs(size(model%loads) + count(model%speed_of /= 0) + size(self%drivers)))
      allocate (self%res%el(ne), self%res%events(ne), self%open_row(ne))
      self%open_row = 0
      self%out => sink
      self%n_events = 0
      self%keep_events = model%run%keep_events
      if (self%keep_events) allocate (self%kept(256))
      self%track = model%run%track_energy
      self%t_metrics = model%run%t_start + model%run%settle_time
      ! settling until periodic: the metrics start when the run has settled (simulate)
      if (model%run%settle_tol > 0.0_wp) self%t_metrics = huge(1.0_wp)
      self%t_prev = t
      ! the peak-to-peak metrics are computed online (memory independent of the
      ! run length); the whole series of samples is kept in memory only when the
      ! caller asks (keep_series)
      allocate (self%turns(ne))
      self%turns%hyst = p2p_hysteresis
      allocate (self%turn_d1(ne), self%turn_d2(ne))
      self%turn_init = .false.
      self%turn_gap = 0.25_wp*model%run%dt
      self%keep = model%run%keep_series
      self%take_samples = sink%stores_samples()
      self%speeds_only = self%take_samples .and. sink%speeds_only()
      self%want_whole = (self%take_samples .and. .not. self%speeds_only) .or. self%keep
      nmax = 0
      if (self%keep) nmax = 1024
      allocate (self%res%series_t(nmax), self%res%series_disp(ne, nmax))
      allocate (self%res%series_theta(nn, nmax), self%res%series_omega(nn, nmax))
      allocate (self%th_prev(nn), self%om_prev(nn), self%force_prev(ne), self%disp_prev(ne), self%torque_prev(ne), &
                self%contact_prev(ne))
      self%contact_prev = 0
      allocate (self%t_counted(ne))
      self%t_counted = -huge(1.0_wp)
      ! the gear meshes' orders over a settled window only (settle_time or settle_tol: the
      ! window is the vibration's, not a start-up's), so a run without one pays nothing a step
      self%mesh_el = [integer ::]
      if (allocated(self%qs%mesh) .and. (model%run%settle_time > 0.0_wp .or. model%run%settle_tol > 0.0_wp)) then
         if (size(self%qs%mesh) == ne) self%mesh_el = pack([(i, i=1, ne)], self%qs%mesh)
      end if
      allocate (self%orders(size(self%mesh_el)))
      self%mesh_drv = [(model%elements(self%mesh_el(i))%e%left, i=1, size(self%mesh_el))]
      self%mesh_rate = [(two_pi/self%qs%period(self%mesh_el(i)), i=1, size(self%mesh_el))]
      self%res%kv_absent = kv_absent(self%qs)   ! (the print-out's warning, the file's attribute: D-138)
      if (sink%needs_meta()) then
         meta = make_meta(model)
         meta%kv_absent = self%res%kv_absent
         call sink%open(meta, err)
      else
         call sink%open(run_meta_t(), err)
      end if
      if (allocated(err)) return
      call self%step(model, t, y)
      call self%sample(model, t, t, y, sink, err)
      self%started = .not. allocated(err)
   end subroutine obs_start

   !> At a local event instant (integrator_t%local_instant, D-32): only the
   !> elements els, whose nodes (among `nodes`) are integration points at t,
   !> are evaluated and folded into the metrics. Every other element's state
   !> at t is an interpolation inside a step that ends later: its extremes are
   !> taken at that step's end, as on any step; the energy at the step's end.
   !> (Fixed-step integrators only: no peak refinement inside steps.)
   module subroutine obs_step_part(self, model, t, y, nodes, els)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:)
      integer, intent(in) :: nodes(:), els(:)
      call self%fill_part(model, t, y, nodes, els)
      call self%update_part(t, els)
   end subroutine obs_step_part

   !> `fill` for the nodes `nodes` and the elements els only (their nodes among
   !> `nodes`). The sample buffer is then not a whole sample: its time is set so
   !> that `sample` fills it again.
   module subroutine obs_fill_part(self, model, t, y, nodes, els)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:)
      integer, intent(in) :: nodes(:), els(:)
      integer :: k, i, l, r
      call model%kinematics_part(t, y, nodes)
      if (model%any_needs_loads) call model%apply_loads(t)
      self%s%t = -huge(1.0_wp)
      self%s_whole = .false.
      do k = 1, size(nodes)
         self%s%theta(nodes(k)) = model%theta(nodes(k))
         self%s%omega(nodes(k)) = model%omega(nodes(k))
      end do
      do k = 1, size(els)
         i = els(k)
         call model%element_torques(i, self%s%torque_left(i), self%s%torque_right(i))
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
   end subroutine obs_fill_part

   !> Record events that happened at (t, y) (the state after the mode update):
   !> each row goes to the sink now; a contact's row is kept (slot i of
   !> self%res%events for element i) until the contact ends, then handed over
   !> again with its peak force and duration.
   module subroutine obs_record_events(self, model, t, y, evs, nev, err, nodes, els)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:)
      type(event_t), intent(in) :: evs(:)
      integer, intent(in) :: nev
      type(error_t), allocatable, intent(out) :: err
      !> at a local event instant (see step_part): its nodes and elements (the
      !> events' elements among them); only those are evaluated
      integer, intent(in), optional :: nodes(:), els(:)
      type(event_t) :: row
      integer :: k, i
      if (nev == 0) return
      if (present(els)) then
         call self%fill_part(model, t, y, nodes, els)
      else
         call self%fill(model, t, y)
      end if
      do k = 1, nev
         i = evs(k)%element
         self%n_events = self%n_events + 1
         row = evs(k)
         associate (e => model%elements(i)%e)
            row%theta_left = self%s%theta(e%left)
            row%omega_left = self%s%omega(e%left)
            row%theta_right = self%s%theta(e%right)
            row%omega_right = self%s%omega(e%right)
            row%displacement = self%s%displacement(i)
            row%force = self%s%force(i)
         end associate
         associate (m => self%res%el(i))
            select case (evs(k)%kind)
            case (ev_contact_front, ev_contact_rear)
               if (m%open_event > 0) then   ! a new contact ends the one in progress
                  self%res%events(i)%duration = t - self%res%events(i)%t
                  call close_row(i)
                  if (allocated(err)) return
               end if
               row%peak_force = abs(self%s%force(i))
               self%res%events(i) = row
               self%open_row(i) = self%n_events
               m%open_event = i
               if (t >= self%t_metrics) then
                  m%impacts = m%impacts + 1
                  m%max_approach_velocity = max(m%max_approach_velocity, abs(evs(k)%approach_velocity))
                  ! (the sum of V_i^2 / 2 until finish makes it the impact energy, D-134)
                  m%rattle_energy = m%rattle_energy + 0.5_wp*evs(k)%approach_velocity**2
               end if
            case (ev_separation)
               if (m%open_event > 0) then
                  associate (o => self%res%events(i))
                     o%duration = t - o%t
                     o%peak_force = max(o%peak_force, abs(self%s%force(i)))
                     if (o%t >= self%t_metrics) m%max_peak_force = max(m%max_peak_force, o%peak_force)
                     row%peak_force = o%peak_force
                     row%duration = o%duration
                  end associate
                  call close_row(i)
                  if (allocated(err)) return
               end if
               m%open_event = 0
               if (t >= self%t_metrics) m%separations = m%separations + 1
            case (ev_zone)
               if (t >= self%t_metrics) m%zone_changes = m%zone_changes + 1
            end select                       ! (stick and slip rows, D-81: in the table only)
         end associate
         call self%out%write_event(self%n_events, row, err)
         if (allocated(err)) return
         if (self%keep_events) call keep_row(self%n_events, row)
      end do
      ! the state just after the mode change belongs to the metrics too: a mesh
      ! force jumps at a zone change, and its peak may be right there. (No
      ! sample is written: samples stay on the output grid, and the event
      ! table holds the state at each event.)
      if (present(els)) then
         call self%update_part(t, els)
         return
      end if
      call self%update_metrics(model, t)
      if (self%refine_peaks) call self%keep_step_end()
   contains
      !> Element j's contact ended: its row, final, to the sink (and the kept table).
      subroutine close_row(j)
         integer, intent(in) :: j
         call self%out%update_event(self%open_row(j), self%res%events(j), err)
         if (self%keep_events) self%kept(self%open_row(j)) = self%res%events(j)
         self%open_row(j) = 0
      end subroutine close_row
      subroutine keep_row(n, r)
         integer, intent(in) :: n
         type(event_t), intent(in) :: r
         type(event_t), allocatable :: tmp(:)
         if (n > size(self%kept)) then
            allocate (tmp(2*size(self%kept)))
            tmp(1:n - 1) = self%kept(1:n - 1)
            call move_alloc(tmp, self%kept)
         end if
         self%kept(n) = r
      end subroutine keep_row
   end subroutine obs_record_events

   !> End of a successful run: the rows of contacts still open to the sink,
   !> close the sink and fill the result. With `interrupted`, the end of a run
   !> stopped at t by a signal: the history ends at the last output time
   !> already written (the state at t is not added), and the statistics say
   !> the run did not complete.
   module subroutine obs_finish(self, model, t, y, stats, sink, result, err, interrupted)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:)
      type(run_stats_t), intent(in) :: stats
      class(sink_t), intent(inout) :: sink
      type(run_result_t), intent(out) :: result
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: interrupted
      type(event_t) :: no_rows(0)
      integer :: i
      real(wp) :: a(0:n_orders, 2), half_v2(size(model%elements))
      logical :: stopped
      stopped = .false.
      if (present(interrupted)) stopped = interrupted
      ! contacts still open at the end count towards the peak force; their rows
      ! get the peak force so far (duration stays -1)
      do i = 1, size(model%elements)
         if (self%res%el(i)%open_event > 0) then
            associate (o => self%res%events(i))
               if (o%t >= self%t_metrics) self%res%el(i)%max_peak_force = max(self%res%el(i)%max_peak_force, o%peak_force)
            end associate
            call sink%update_event(self%open_row(i), self%res%events(i), err)
            if (allocated(err)) return
            if (self%keep_events) self%kept(self%open_row(i)) = self%res%events(i)
         end if
      end do
      if (self%s%t < t .and. .not. stopped) then   ! make sure the final state is in the file
         call self%fill(model, t, y)
         call self%emit(sink, err)
         if (allocated(err)) return
      end if
      self%res%stats = stats
      self%res%stats%events = int(self%n_events, i8)
      self%res%stats%t_final = t
      self%res%stats%completed = .not. stopped
      self%res%t_sampled = self%t_sampled
      deallocate (self%res%events)
      if (self%keep_events) then
         self%res%events = self%kept(1:self%n_events)
         deallocate (self%kept)
      else
         allocate (self%res%events(0))
      end if
      do i = 1, size(model%elements)
         call self%turns(i)%figures(self%res%el(i)%p2p_range, self%res%el(i)%p2p_mean, self%res%el(i)%p2p_swings)
         self%res%el(i)%p2p_exact = self%turns(i)%exact
      end do
      call load_sharing(model%share_set, self%res%el)
      call dynamic_factor(self%qs, self%res%el)
      half_v2 = self%res%el%rattle_energy   ! (the sums of V_i^2 / 2)
      self%res%el%rattle_energy = 0.0_wp
      do i = 1, size(self%mesh_el)   ! the mesh orders of TE and force (D-104)
         call self%orders(i)%amplitudes(a)
         self%res%el(self%mesh_el(i))%te_order = a(1:, 1)
         self%res%el(self%mesh_el(i))%force_order = a(1:, 2)
         self%res%el(self%mesh_el(i))%force_mean = a(0, 2)
         associate (m => self%res%el(self%mesh_el(i)))   ! rattle index: impacts a mesh cycle (D-105)
            if (self%orders(i)%cycles() > 0.0_wp) m%rattle_impacts = real(m%impacts, wp)/self%orders(i)%cycles()
         end associate
         call rattle_figures(model, self%mesh_el(i), self%orders(i), self%mesh_rate(i), &
                             half_v2(self%mesh_el(i)), t - self%t_metrics, self%res%el(self%mesh_el(i)))
      end do
      if (allocated(self%qs%mesh) .and. t > self%t_metrics) then   ! rattle index: the time out of contact
         where (self%qs%mesh) self%res%el%rattle_open = self%res%el%time_out_of_contact/(t - self%t_metrics)
      end if
      self%out => null()
      call sink%close(no_rows, self%res%stats, self%res%el, err)
      if (allocated(err)) return
      result = self%res
      result%y_final = y
      result%t_final = t
      result%series_t = result%series_t(1:self%n_series)
      result%series_disp = result%series_disp(:, 1:self%n_series)
      result%series_theta = result%series_theta(:, 1:self%n_series)
      result%series_omega = result%series_omega(:, 1:self%n_series)
   end subroutine obs_finish

   !> The output sample at t_out (the state at t, t >= t_metrics) into the gear meshes'
   !> order trackers (D-104): each mesh's TE, mesh force and its driver's speed, from the
   !> sample buffer when it is whole, else from the model's workspace at t (its
   !> displacements are in the buffer: the observer's short way), else filled.
   module subroutine obs_feed_orders(self, model, t_out, t, y)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t_out, t, y(:)
      integer :: q, i, l, r, c, p
      real(wp) :: d, f, w
      logical :: ws
      ws = model%ws_step_end .and. model%ws_t == t
      if (.not. (self%s_whole .or. ws)) then
         call self%fill(model, t, y)
         self%s%t = t_out
      end if
      do q = 1, size(self%mesh_el)
         i = self%mesh_el(q)
         l = model%elements(i)%e%left; r = model%elements(i)%e%right
         if (self%s_whole) then
            f = self%s%force(i); w = self%s%omega(l)
         else if (model%ws_status(i)) then
            f = model%el_force(i); w = model%omega(l)
         else
            call model%elements(i)%e%status(model%theta(l), model%omega(l), model%theta(r), model%omega(r), d, f, c, p)
            w = model%omega(l)
         end if
         call self%orders(q)%push(t_out, self%mesh_rate(q)*w, [self%s%displacement(i), f])
      end do
   end subroutine obs_feed_orders

   !> The rattle indices from the literature of the gear mesh i (D-134,
   !> trainsim_rattle) into m: Brosey's criterion from the driver's largest acceleration
   !> between output samples (the tracker's, over its phase rate N omega_driver) and the
   !> mean mesh force; the impact energy from half_v2 (the window's sum of V_i^2 / 2) per
   !> mesh cycle and per second of the window. 0 without a mesh cycle (as rattle_impacts).
   subroutine rattle_figures(model, i, ot, rate, half_v2, window, m)
      type(model_t), intent(in) :: model
      integer, intent(in) :: i
      type(order_tracker_t), intent(in) :: ot
      real(wp), intent(in) :: rate, half_v2, window
      type(element_metrics_t), intent(inout) :: m
      type(rattle_mesh_t) :: c
      real(wp) :: e
      if (.not. ot%cycles() > 0.0_wp) return
      c = rattle_mesh(model, i)
      m%rattle_criterion = rattle_criterion(c, ot%amax/rate, m%force_mean)
      e = impact_energy(c, half_v2)
      m%rattle_energy = e/ot%cycles()
      if (window > 0.0_wp) m%rattle_power = e/window
   end subroutine rattle_figures

   !> The load-sharing factor of each set of planet meshes (D-96): K = N max F_i / sum F_i
   !> over the set's N meshes, F_i = max(force_max, -force_min) (the largest mesh force
   !> of the metrics window, either face); 0 (K >= 1 for every set) for an element of
   !> no set, and for a set that carried no load (sum F_i = 0).
   subroutine load_sharing(set, m)
      integer, allocatable, intent(in) :: set(:)   !< per element, 0 none (unallocated: none)
      type(element_metrics_t), intent(inout) :: m(:)
      real(wp) :: f(size(m)), total, top
      integer :: i, k, n
      m%load_sharing = 0.0_wp
      if (.not. allocated(set)) return
      if (size(set) /= size(m) .or. size(m) == 0) return
      do i = 1, size(m)
         f(i) = max(0.0_wp, m(i)%force_max, -m(i)%force_min)   ! (0: no sample in the window)
      end do
      do k = 1, maxval(set)
         n = count(set == k)
         if (n == 0) cycle
         total = sum(f, mask=set == k)
         top = maxval(f, mask=set == k)
         if (total > 0.0_wp) where (set == k) m%load_sharing = n*top/total
      end do
   end subroutine load_sharing

   !> The dynamic factor of each gear mesh (D-103): Kv = F_dyn / |F_s|, F_s the static mesh
   !> force of largest magnitude over a mesh cycle (qs, trainsim_quasi_static), F_dyn
   !> the largest mesh force of the metrics window on the face F_s presses (force_max
   !> for F_s > 0, -force_min for F_s < 0). With the static figures into m. 0 where no
   !> static reference was computed, F_s = 0 (an unloaded mesh), or the window is empty.
   subroutine dynamic_factor(qs, m)
      type(static_ref_t), intent(in) :: qs
      type(element_metrics_t), intent(inout) :: m(:)
      integer :: i
      real(wp) :: fdyn
      m%kv = 0.0_wp
      if (.not. qs%computed) return
      if (size(qs%force) /= size(m)) return
      do i = 1, size(m)
         if (.not. qs%mesh(i)) cycle
         m(i)%static_force = qs%force(i)
         m(i)%static_te_mean = qs%te_mean(i)
         m(i)%static_te_p2p = qs%te_max(i) - qs%te_min(i)
         if (qs%force(i) == 0.0_wp .or. m(i)%force_max < m(i)%force_min) cycle
         fdyn = m(i)%force_max
         if (qs%force(i) < 0.0_wp) fdyn = -m(i)%force_min
         m(i)%kv = max(0.0_wp, fdyn)/abs(qs%force(i))
      end do
   end subroutine dynamic_factor
end submodule trainsim_observer_events
