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
   use trainsim_strings, only: str
   use trainsim_model, only: model_t, rigid_speeds
   use trainsim_signal, only: ramp_signal
   use trainsim_derived, only: set_mesh_frequency
   use trainsim_builder, only: check_run_times
   use trainsim_quasi_static, only: mesh_period_angle
   use trainsim_orders, only: order_tracker_t, n_orders, n_order_signals
   use trainsim_sink, only: sink_t, run_meta_t, sample_t, event_t, run_stats_t, element_metrics_t
   implicit none
   private

   public :: runup_spec_t, runup_blocks_t, runup_sink_t, prepare_runup, runup_mesh, min_samples_per_cycle

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
      integer, allocatable :: impacts(:)                  !< contact onsets in the block
   end type runup_blocks_t

   !> The sink that tracks the mesh's orders block by block (output samples only: the
   !> samples at events are skipped for the orders, the grid stays even, D-104).
   type, extends(sink_t) :: runup_sink_t
      integer :: el = 0, drv = 0          !< the mesh element and its driver node
      real(wp) :: teeth = 0.0_wp          !< N: order-1 phase per radian of the driver
      real(wp) :: t_track = 0.0_wp        !< the ramp's start: blocks begin there
      real(wp) :: t_grid = 0.0_wp, dout = 0.0_wp   !< the output grid t_grid + k dout
      integer :: block_cycles = 20
      type(order_tracker_t), private :: ot
      real(wp), private :: dmin = huge(1.0_wp), dmax = -huge(1.0_wp), fmin = huge(1.0_wp), fmax = -huge(1.0_wp)
      integer, private :: hits = 0, contact_prev = 0
      type(runup_blocks_t) :: blocks
   contains
      procedure :: open => ru_open
      procedure :: write_sample => ru_sample
      procedure :: close => ru_close
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
   subroutine prepare_runup(model, ie, spec, where_from, where_to, where_rate, t_a, err)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: ie
      type(runup_spec_t), intent(in) :: spec
      character(len=*), intent(in) :: where_from, where_to, where_rate
      real(wp), intent(out) :: t_a
      type(error_t), allocatable, intent(out) :: err
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
         call fatal_error(err, where_from//": error: no node of the train of '"//model%elements(ie)%e%id// &
                          "' has a prescribed speed (&load quantity = 'speed'): a run-up drives its speed on a "// &
                          'ramp; hold the driver at a constant speed in the deck', err_input)
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
                self%blocks%force_min(0), self%blocks%force_max(0), self%blocks%kv(0), self%blocks%impacts(0))
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
         b%impacts = [b%impacts, self%hits]
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
   end subroutine start_block

   !> The end of the run: Kv of each block from the run's static reference (D-103, at
   !> the loads as the run starts): the block's largest force on the face F_s presses
   !> over |F_s|. The last, partial block is left out.
   subroutine ru_close(self, events, stats, metrics, err)
      class(runup_sink_t), intent(inout) :: self
      type(event_t), intent(in) :: events(:)
      type(run_stats_t), intent(in) :: stats
      type(element_metrics_t), intent(in) :: metrics(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: fs
      associate (u1 => events, u2 => stats, u3 => err)
      end associate
      if (self%el < 1 .or. self%el > size(metrics)) return
      fs = metrics(self%el)%static_force
      if (fs > 0.0_wp) then
         self%blocks%kv = self%blocks%force_max/fs
      else if (fs < 0.0_wp) then
         self%blocks%kv = -self%blocks%force_min/abs(fs)
      end if
   end subroutine ru_close
end module trainsim_runup
