!> A run-up (issue 26 item 6, D-109): the driver of a gear mesh held at a mesh frequency
!> f_from for `settle_cycles` mesh cycles, then on a linear speed ramp to f_to at `rate`
!> teeth/s^2, its transmission error and mesh force tracked in mesh orders block by block:
!> each block is `block_cycles` whole mesh cycles of the ramp, and gives one point of the
!> figure a sweep gives (the amplitudes at orders 0..4 against the block's mesh frequency).
!>
!> The order tracker is the runs' own (trainsim_orders, D-104): the phase N theta_driver
!> by the trapezoidal rule on N omega_driver, exact for a linear ramp, so each order stays
!> in its bin while the speed changes. A block's mesh frequency is its cycles over its
!> duration, M / (t_cut - t_0): for a linear ramp the instantaneous frequency at the block's
!> midpoint in time, exactly.
!>
!> The run is `simulate`'s (any integrator, events, the static reference of D-103 at the
!> loads as the run starts): the ramp is the deck's prescribed speeds replaced by ramp
!> time functions (every prescribed speed the mesh's driver turns rigidly with, as
!> `mesh_frequency` sets them, D-43), and `runup_sink_t` takes the output samples.
module trainsim_runup
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_model, only: model_t, rigid_speeds
   use trainsim_signal, only: ramp_signal
   use trainsim_derived, only: set_mesh_frequency
   use trainsim_builder, only: check_run_times
   use trainsim_quasi_static, only: mesh_period_angle, static_ref_t, static_reference
   use trainsim_orders, only: order_tracker_t, n_orders, n_order_signals
   use trainsim_sink, only: sink_t, run_meta_t, sample_t, event_t, run_stats_t, element_metrics_t, &
      ev_contact_front, ev_contact_rear
   use trainsim_rattle, only: rattle_mesh_t, rattle_criterion, impact_energy
   implicit none
   private

   public :: runup_spec_t, runup_blocks_t, runup_sink_t, prepare_runup, runup_mesh, min_samples_per_cycle
   public :: ramp_static_reference

   !> Output samples a mesh cycle the tracker needs at the top of the range: orders 1..4
   !> are exact below half the samples a cycle (D-104), so at least 2 x 4 + 2.
   integer, parameter :: min_samples_per_cycle = 10

   !> What the user asks for (the &runup group or the command's options).
   type :: runup_spec_t
      character(len=:), allocatable :: mesh      !< element id ('': the first gear mesh)
      real(wp) :: f_from = 0.0_wp, f_to = 0.0_wp !< mesh frequencies, teeth/s
      real(wp) :: rate = 0.0_wp                  !< |df/dt|, teeth/s^2
      real(wp) :: settle_cycles = 100.0_wp       !< mesh cycles held at f_from before the ramp
      integer :: block_cycles = 20               !< mesh cycles per tracked block
   end type runup_spec_t

   !> The tracked blocks: per block its mesh frequency, time span and figures.
   type :: runup_blocks_t
      integer :: n = 0
      real(wp), allocatable :: f(:), t0(:), t1(:)         !< teeth/s; block start and end (s)
      !> (1 + order, block): row 1 the mean (order 0), row 1 + k the amplitude 2|c_k| of order k
      real(wp), allocatable :: te(:, :), force(:, :)
      real(wp), allocatable :: te_min(:), te_max(:), force_min(:), force_max(:)
      real(wp), allocatable :: kv(:)                      !< on the static load's face, 0 without a reference
      !> the static mesh force at the block's midpoint (ramp_static_reference; 0 without one)
      real(wp), allocatable :: static_force(:)
      integer, allocatable :: impacts(:)                  !< contact onsets in the block
      !> rattle indices (D-134, trainsim_rattle): Brosey's criterion from the
      !> driver's largest acceleration and the mean mesh force of the block, the impact
      !> energy 1/2 m_eq V_i^2 of the block's contact onsets per mesh cycle and per second
      real(wp), allocatable :: criterion(:), energy(:), power(:)
   end type runup_blocks_t

   !> The sink that tracks the mesh's orders block by block (output samples only: the
   !> samples at events are skipped for the orders, the grid stays even, D-104).
   type, extends(sink_t) :: runup_sink_t
      integer :: el = 0, drv = 0          !< the mesh element and its driver node
      real(wp) :: teeth = 0.0_wp          !< N: order-1 phase per radian of the driver
      real(wp) :: t_track = 0.0_wp        !< the ramp's start: blocks begin there
      real(wp) :: t_grid = 0.0_wp, dout = 0.0_wp   !< the output grid t_grid + k dout
      integer :: block_cycles = 20
      type(rattle_mesh_t) :: rc           !< the mesh's rattle constants (trainsim_rattle)
      type(order_tracker_t), private :: ot
      real(wp), private :: half_v2 = 0.0_wp   !< the block's contact onsets: the sum of V_i^2 / 2
      real(wp), private :: dmin = huge(1.0_wp), dmax = -huge(1.0_wp), fmin = huge(1.0_wp), fmax = -huge(1.0_wp)
      integer, private :: hits = 0, contact_prev = 0
      type(runup_blocks_t) :: blocks
   contains
      procedure :: open => ru_open
      procedure :: write_sample => ru_sample
      procedure :: close => ru_close
      procedure :: write_event => ru_event
   end type runup_sink_t

contains

   !> The element of the run-up: `id`, or the first gear mesh when id is ''. ie = 0 and a
   !> message when there is none (`where`: what names the key, e.g. "deck.nml:12: &runup #1, key 'mesh'").
   subroutine runup_mesh(model, id, where, ie, err)
      type(model_t), intent(in) :: model
      character(len=*), intent(in) :: id, where
      integer, intent(out) :: ie
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: meshes
      integer :: i
      ie = 0
      meshes = ''
      do i = 1, size(model%elements)
         if (mesh_period_angle(model, i) > 0.0_wp) then
            if (ie == 0 .and. len(id) == 0) ie = i
            if (model%elements(i)%e%id == id) ie = i
            meshes = meshes//merge(', ', '  ', len(meshes) > 0)//"'"//model%elements(i)%e%id//"'"
         end if
      end do
      if (ie > 0) return
      if (len(meshes) == 0) then
         call fatal_error(err, where//': error: a run-up tracks a gear mesh (spur_gear, helical_gear), and the '// &
                          'model has none', err_input)
      else
         call fatal_error(err, where//": error: '"//id//"' is not a gear mesh of the model; gear meshes: "// &
                          meshes(3:), err_input)
      end if
   end subroutine runup_mesh

   !> Turn `model` into the run-up of `spec` on its element ie: every speed at f_from
   !> (mesh_frequency, D-43), the prescribed speeds on ramps from t_a = t_start +
   !> settle_cycles / f_from to t_b = t_a + |f_to - f_from| / rate, t_end = t_b, no
   !> settling of the run's own (its /metrics are over the whole run). `where_from`,
   !> `where_to`, `where_rate`: what names each value in a message. On return t_a.
   subroutine prepare_runup(model, ie, spec, where_from, where_to, where_rate, t_a, err, torque_at)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: ie
      type(runup_spec_t), intent(in) :: spec
      character(len=*), intent(in) :: where_from, where_to, where_rate
      real(wp), intent(out) :: t_a
      type(error_t), allocatable, intent(out) :: err
      !> per node: where the deck drives it by a torque (its &load group, '' none), to name
      !> in the refusal of a torque-driven train
      type(string_t), intent(in), optional :: torque_at(:)
      real(wp), allocatable :: w(:)
      logical, allocatable :: known(:)
      character(len=:), allocatable :: blame
      real(wp) :: teeth, t_b, dout, cycles
      integer :: i, loop_el, n_held
      t_a = model%run%t_start
      if (.not. (spec%f_from > 0.0_wp .and. spec%f_from < huge(1.0_wp))) then
         call fatal_error(err, where_from//': error: the mesh frequency a run-up starts from must be > 0 teeth/s, got '// &
                          str(spec%f_from), err_input)
      else if (.not. (spec%f_to > 0.0_wp .and. spec%f_to < huge(1.0_wp))) then
         call fatal_error(err, where_to//': error: the mesh frequency a run-up ends at must be > 0 teeth/s, got '// &
                          str(spec%f_to), err_input)
      else if (spec%f_to == spec%f_from) then
         call fatal_error(err, where_to//': error: a run-up needs a range: from and to are both '//str(spec%f_to)// &
                          ' teeth/s (a single speed is a run: trainsim run --set ID.mesh_frequency=F)', err_input)
      else if (.not. (spec%rate > 0.0_wp .and. spec%rate < huge(1.0_wp))) then
         call fatal_error(err, where_rate//': error: the ramp rate must be > 0 teeth/s^2 (its sense comes from '// &
                          'from and to), got '//str(spec%rate), err_input)
      end if
      if (allocated(err)) return
      teeth = two_pi/mesh_period_angle(model, ie)
      ! the samples a cycle at the top of the range
      dout = model%run%output_interval
      if (.not. dout > 0.0_wp) dout = model%run%dt
      if (1.0_wp/(max(spec%f_from, spec%f_to)*dout) < real(min_samples_per_cycle, wp)) then
         call fatal_error(err, where_to//': error: at '//str(max(spec%f_from, spec%f_to))//' teeth/s the run''s '// &
                          'output interval '//str(dout)//' s gives '//str(1.0_wp/(max(spec%f_from, spec%f_to)*dout), 4)// &
                          ' samples a mesh cycle; tracking orders 1..4 needs at least '//str(min_samples_per_cycle)// &
                          ': lower &run output_interval (or dt) below '// &
                          str(1.0_wp/(max(spec%f_from, spec%f_to)*min_samples_per_cycle), 4)//' s, or the range', err_input)
         return
      end if
      call set_mesh_frequency(model, ie, spec%f_from, err)
      if (allocated(err)) then
         err%message = where_from//': '//err%message
         return
      end if
      call rigid_speeds(model, model%elements(ie)%e%left, two_pi*spec%f_from/teeth, w, known, loop_el)
      t_a = model%run%t_start + spec%settle_cycles/spec%f_from
      t_b = t_a + abs(spec%f_to - spec%f_from)/spec%rate
      cycles = 0.5_wp*(spec%f_from + spec%f_to)*(t_b - t_a)
      if (cycles < real(spec%block_cycles, wp)) then
         call fatal_error(err, where_rate//': error: the ramp from '//str(spec%f_from)//' to '//str(spec%f_to)// &
                          ' teeth/s at '//str(spec%rate)//' teeth/s^2 lasts '//str(cycles, 4)//' mesh cycles, '// &
                          'fewer than one block of '//str(spec%block_cycles)//': lower the rate', err_input)
         return
      end if
      n_held = 0
      do i = 1, size(model%nodes)
         if (.not. known(i) .or. model%speed_of(i) == 0) cycle
         model%speeds(model%speed_of(i)) = ramp_signal(t_a, t_b, w(i), w(i)*spec%f_to/spec%f_from)
         n_held = n_held + 1
      end do
      if (n_held == 0) then
         call refuse_torque_driven(model, ie, known, where_from, err, torque_at)
         return
      end if
      model%run%t_end = t_b
      model%run%settle_time = 0.0_wp
      model%run%settle_tol = 0.0_wp
      call check_run_times(model%run, blame, err)
      if (allocated(err)) then
         err%message = where_rate//': error: the run-up''s &run '//blame//': '//err%message
         return
      end if
      call model%build_fast_path()   ! (held speeds no longer constant)
   end subroutine prepare_runup

   !> A run-up of a train with no prescribed speed is refused (D-135): from, to and
   !> rate prescribe the mesh frequency against time, and a train driven by torque makes its
   !> speed a result of its loads and inertias. The message names the &load group that
   !> drives the train by torque (torque_at of a node of the train), else `where_from`.
   subroutine refuse_torque_driven(model, ie, known, where_from, err, torque_at)
      type(model_t), intent(in) :: model
      integer, intent(in) :: ie
      logical, intent(in) :: known(:)
      character(len=*), intent(in) :: where_from
      type(error_t), allocatable, intent(out) :: err
      type(string_t), intent(in), optional :: torque_at(:)
      character(len=:), allocatable :: at, why
      integer :: i
      at = where_from
      why = "no node of the train of '"//model%elements(ie)%e%id//"' has a prescribed speed"
      if (present(torque_at)) then
         do i = 1, min(size(known), size(torque_at))
            if (known(i) .and. len(torque_at(i)%s) > 0) then
               at = torque_at(i)%s
               why = "the train of '"//model%elements(ie)%e%id//"' is driven by a torque here (node '"// &
                     model%nodes(i)%n%id//"', quantity = 'torque'), and no node of it has a prescribed speed"
               exit
            end if
         end do
      end if
      call fatal_error(err, at//': error: '//why//': a run-up prescribes the mesh frequency against time '// &
                       '(from, to, rate), which a torque-driven train makes a result of its loads and inertias; '// &
                       "hold the driver's speed for the run-up (&load quantity = 'speed', kind = 'constant'), or "// &
                       "ramp its torque in trainsim run (&load kind = 'table')", err_input)
   end subroutine refuse_torque_driven

   subroutine ru_open(self, meta, err)
      class(runup_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      type(runup_blocks_t) :: none
      associate (unused => meta)
      end associate
      self%blocks = none
      allocate (self%blocks%f(0), self%blocks%t0(0), self%blocks%t1(0), self%blocks%te(n_orders + 1, 0), &
                self%blocks%force(n_orders + 1, 0), self%blocks%te_min(0), self%blocks%te_max(0), &
                self%blocks%force_min(0), self%blocks%force_max(0), self%blocks%kv(0), self%blocks%impacts(0), &
                self%blocks%static_force(0), self%blocks%criterion(0), self%blocks%energy(0), self%blocks%power(0))
      call start_block(self)
      self%contact_prev = 0
   end subroutine ru_open

   !> One sample: contacts and extremes from every sample of the ramp, the orders from
   !> the output samples; a block closed when its tracker has completed its cycles.
   subroutine ru_sample(self, s, err)
      class(runup_sink_t), intent(inout) :: self
      type(sample_t), intent(in) :: s
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: k, x(n_order_signals), w
      integer :: c
      c = s%contact(self%el)
      if (s%t < self%t_track) then
         self%contact_prev = c
         return
      end if
      if (c /= 0 .and. self%contact_prev == 0) self%hits = self%hits + 1
      self%contact_prev = c
      x = [s%displacement(self%el), s%force(self%el)]
      self%dmin = min(self%dmin, x(1)); self%dmax = max(self%dmax, x(1))
      self%fmin = min(self%fmin, x(2)); self%fmax = max(self%fmax, x(2))
      k = anint((s%t - self%t_grid)/self%dout)
      if (abs(s%t - (self%t_grid + k*self%dout)) > 1.0e-9_wp*self%dout) return   ! an event's sample
      w = self%teeth*s%omega(self%drv)
      call self%ot%push(s%t, w, x)
      if (self%ot%cycles_done >= self%block_cycles) then
         call close_block(self, s%t, w)
         call self%ot%push(s%t, w, x)     ! the next block starts at this sample
      end if
      associate (unused => err)
      end associate
   end subroutine ru_sample

   !> The block just completed: its amplitudes over its whole cycles, its mesh frequency
   !> M / (t_cut - t_0) (t_cut: the cycle's end inside the last step, phase linear there).
   subroutine close_block(self, t, w)
      type(runup_sink_t), intent(inout) :: self
      real(wp), intent(in) :: t, w
      real(wp) :: a(0:n_orders, n_order_signals), t_cut, excess
      integer :: m
      call self%ot%amplitudes(a)
      excess = abs(self%ot%span) - two_pi*real(self%ot%cycles_done, wp)
      t_cut = t - excess/abs(w)
      m = self%ot%cycles_done
      associate (b => self%blocks)
         b%n = b%n + 1
         b%f = [b%f, real(m, wp)/(t_cut - self%ot%t0)]
         b%t0 = [b%t0, self%ot%t0]
         b%t1 = [b%t1, t_cut]
         b%te = reshape([b%te, a(:, 1)], [n_orders + 1, b%n])
         b%force = reshape([b%force, a(:, 2)], [n_orders + 1, b%n])
         b%te_min = [b%te_min, self%dmin]; b%te_max = [b%te_max, self%dmax]
         b%force_min = [b%force_min, self%fmin]; b%force_max = [b%force_max, self%fmax]
         b%kv = [b%kv, 0.0_wp]
         b%static_force = [b%static_force, 0.0_wp]
         b%impacts = [b%impacts, self%hits]
         b%criterion = [b%criterion, rattle_criterion(self%rc, self%ot%amax/self%teeth, a(0, 2))]
         b%energy = [b%energy, impact_energy(self%rc, self%half_v2)/real(m, wp)]
         b%power = [b%power, impact_energy(self%rc, self%half_v2)/(t_cut - self%ot%t0)]
      end associate
      call start_block(self)
   end subroutine close_block

   subroutine start_block(self)
      type(runup_sink_t), intent(inout) :: self
      type(order_tracker_t) :: fresh
      self%ot = fresh
      self%dmin = huge(1.0_wp); self%dmax = -huge(1.0_wp)
      self%fmin = huge(1.0_wp); self%fmax = -huge(1.0_wp)
      self%hits = 0
      self%half_v2 = 0.0_wp
   end subroutine start_block

   !> A row of the event table: a contact onset of the mesh on the ramp adds its V_i^2 / 2
   !> to the block open when it happens (the impact energy, D-134).
   subroutine ru_event(self, row, ev, err)
      class(runup_sink_t), intent(inout) :: self
      integer, intent(in) :: row
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => row, u2 => err)
      end associate
      if (ev%element /= self%el .or. ev%t < self%t_track) return
      if (ev%kind == ev_contact_front .or. ev%kind == ev_contact_rear) &
         self%half_v2 = self%half_v2 + 0.5_wp*ev%approach_velocity**2
   end subroutine ru_event

   !> The end of the run (Kv along the ramp: ramp_static_reference, after the run).
   subroutine ru_close(self, events, stats, metrics, err)
      class(runup_sink_t), intent(inout) :: self
      type(event_t), intent(in) :: events(:)
      type(run_stats_t), intent(in) :: stats
      type(element_metrics_t), intent(in) :: metrics(:)
      type(error_t), allocatable, intent(out) :: err
      associate (u0 => self, u1 => events, u2 => stats, u3 => metrics, u4 => err)
      end associate
   end subroutine ru_close

   !> The static reference along the ramp (D-135): for each block of `sink` the
   !> static reference of D-103 at the block's midpoint t_m = (t_0 + t_1)/2, i.e. with the
   !> run's start moved to t_m: the loads and the prescribed speeds' accelerations at t_m
   !> (the preload's steady rigid rotation, D-30: the ramp's J alpha on every inertia), every
   !> free node's initial speed the rigid train's at t_m (damping at that speed counts), a
   !> held node at its deck angle at t_m.
   !> Kv of the block = its largest force on the face F_s presses over |F_s|; 0 (and
   !> static_force 0) where the static reference is not computed. The model's start and
   !> initial speeds are restored.
   subroutine ramp_static_reference(model, sink)
      type(model_t), intent(inout) :: model
      type(runup_sink_t), intent(inout) :: sink
      type(static_ref_t) :: qs
      real(wp), allocatable :: w0(:), th0(:), kappa(:)
      logical, allocatable :: known(:)
      real(wp) :: t_saved, tm, w_drv, fs
      integer :: k, n, nn, held, loop_el
      nn = size(model%nodes)
      t_saved = model%run%t_start
      w0 = [(model%nodes(n)%n%omega0, n=1, nn)]
      th0 = [(model%nodes(n)%n%theta0, n=1, nn)]
      call rigid_speeds(model, sink%drv, 1.0_wp, kappa, known, loop_el)
      held = 0
      do n = 1, nn
         if (known(n) .and. model%is_held(n) .and. kappa(n) /= 0.0_wp) then
            held = n
            exit
         end if
      end do
      associate (b => sink%blocks)
         b%kv = 0.0_wp; b%static_force = 0.0_wp
         if (held == 0) return
         do k = 1, b%n
            tm = 0.5_wp*(b%t0(k) + b%t1(k))
            w_drv = model%speeds(model%speed_of(held))%value(tm)/kappa(held)
            do n = 1, nn
               if (known(n)) model%nodes(n)%n%omega0 = kappa(n)*w_drv
               ! a held node at its starting angle at t_m (its angle at t_m is theta0 + the
               ! motion's integral, hundreds of radians along a ramp: the preload's residual
               ! would stall at their rounding); the positions span whole mesh cycles anyway
               if (model%is_held(n)) model%nodes(n)%n%theta0 = th0(n) - model%speeds(model%speed_of(n))%integral(tm)
            end do
            model%run%t_start = tm
            call static_reference(model, qs)
            if (.not. qs%computed) cycle
            fs = qs%force(sink%el)
            b%static_force(k) = fs
            if (fs > 0.0_wp) then
               b%kv(k) = max(0.0_wp, b%force_max(k))/fs
            else if (fs < 0.0_wp) then
               b%kv(k) = max(0.0_wp, -b%force_min(k))/abs(fs)
            end if
         end do
      end associate
      model%run%t_start = t_saved
      do n = 1, nn
         model%nodes(n)%n%omega0 = w0(n)
         model%nodes(n)%n%theta0 = th0(n)
      end do
   end subroutine ramp_static_reference
end module trainsim_runup
