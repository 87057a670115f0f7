!> Sinks of the library interfaces (the C interface, the Python package): a run's
!> sampled history kept in memory, and a tee that hands a run to two sinks.
!>
!> `capture_sink_t` keeps, when `series` is set, every sample as one column of a
!> (column, sample) table whose columns are the datasets of the HDF5 history
!> (docs/output-format.md), one per column of each: `time`, `states/<name>`,
!> `nodes/theta/<id>`, `nodes/omega/<id>`, `elements/<field>/<id>` (torque_left,
!> torque_right, displacement, force, contact, pairs), `energy/<name>`,
!> `inputs/<name>`, each with the unit the history gives it. The integers (contact,
!> pairs) are stored as reals (exact). Without `series` it reads only the node speeds
!> (a sweep run's sink does the same: the same samples, D-34) and keeps, as a sweep
!> does, each node's speed range from `t_metrics` on.
module trainsim_capture
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: string_t
   use trainsim_sink, only: sink_t, run_meta_t, sample_t, event_t, run_stats_t, element_metrics_t
   implicit none
   private

   public :: capture_sink_t, tee_sink_t

   character(len=*), parameter :: energy_names(5) = [character(len=10) :: &
      'kinetic', 'potential', 'dissipated', 'input', 'balance']

   !> A run's samples in memory (with `series`) and the node speed range.
   type, extends(sink_t) :: capture_sink_t
      logical :: series = .false.                     !< keep every sample
      real(wp) :: t_metrics = 0.0_wp                  !< the speed range starts here (metrics_from moves it)
      real(wp), allocatable :: wmin(:), wmax(:)       !< node speed range over t >= t_metrics
      type(string_t), allocatable :: names(:), units(:)   !< per column
      real(wp), allocatable :: data(:, :)             !< (column, sample), columns 1:n_rows used
      integer :: n_rows = 0
   contains
      procedure :: open => cap_open
      procedure :: write_sample => cap_sample
      procedure :: speeds_only => cap_speeds_only
      procedure :: metrics_from => cap_metrics_from
      procedure :: close => cap_close
   end type capture_sink_t

   !> Two sinks as one (an HDF5 history and a capture).
   type, extends(sink_t) :: tee_sink_t
      class(sink_t), pointer :: a => null(), b => null()
   contains
      procedure :: open => tee_open
      procedure :: write_sample => tee_sample
      procedure :: close => tee_close
      procedure :: abort => tee_abort
      procedure :: write_event => tee_write_event
      procedure :: update_event => tee_update_event
      procedure :: stores_samples => tee_stores_samples
      procedure :: speeds_only => tee_speeds_only
      procedure :: metrics_from => tee_metrics_from
   end type tee_sink_t

contains

   subroutine cap_open(self, meta, err)
      class(capture_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      integer :: nn
      nn = size(meta%node_ids)
      if (allocated(self%wmin)) deallocate (self%wmin, self%wmax)
      allocate (self%wmin(nn), self%wmax(nn))
      self%wmin = huge(1.0_wp)
      self%wmax = -huge(1.0_wp)
      self%n_rows = 0
      if (allocated(self%names)) deallocate (self%names, self%units)
      if (allocated(self%data)) deallocate (self%data)
      if (.not. self%series) then
         allocate (self%names(0), self%units(0), self%data(0, 0))
         return
      end if
      call label(meta, self%names, self%units)
      allocate (self%data(size(self%names), 256))
   end subroutine cap_open

   !> Column names and units, in the order of `cap_sample`'s row.
   subroutine label(meta, names, units)
      type(run_meta_t), intent(in) :: meta
      type(string_t), allocatable, intent(out) :: names(:), units(:)
      character(len=:), allocatable :: u_force, u_torque, u_energy, d, nm
      integer :: i, n, ne
      if (meta%units == 'si') then
         u_force = 'N'; u_torque = 'N*m'; u_energy = 'J'
      else
         u_force = 'lbf'; u_torque = 'lbf*in'; u_energy = 'lbf*in'
      end if
      ne = size(meta%element_ids)
      n = 1 + size(meta%state_names) + 2*size(meta%node_ids) + 6*ne + 5 + count_inputs(meta)
      allocate (names(n), units(n))
      n = 0
      call add('time', 's')
      do i = 1, size(meta%state_names)
         nm = meta%state_names(i)%s
         if (ends(nm, '.angle')) then
            call add('states/'//nm, 'rad')
         else if (ends(nm, '.speed')) then
            call add('states/'//nm, 'rad/s')
         else if (ends(nm, '.current')) then
            call add('states/'//nm, 'A')
         else if (index(nm, 'energy.') == 1) then
            call add('states/'//nm, u_energy)
         else
            call add('states/'//nm, '1')
         end if
      end do
      call per_node('nodes/theta/', 'rad')
      call per_node('nodes/omega/', 'rad/s')
      call per_element('elements/torque_left/', u_torque)
      call per_element('elements/torque_right/', u_torque)
      do i = 1, ne
         call add('elements/displacement/'//meta%element_ids(i)%s, disp_unit(i))
      end do
      do i = 1, ne
         d = u_force
         if (disp_unit(i) == 'rad') d = u_torque   ! an angle's force is a torque (shafts)
         call add('elements/force/'//meta%element_ids(i)%s, d)
      end do
      call per_element('elements/contact/', '1')
      call per_element('elements/pairs/', '1')
      do i = 1, size(energy_names)
         call add('energy/'//trim(energy_names(i)), u_energy)
      end do
      do i = 1, count_inputs(meta)
         if (len(meta%input_series_units(i)%s) > 0) then
            call add('inputs/'//meta%input_series_names(i)%s, meta%input_series_units(i)%s)
         else
            call add('inputs/'//meta%input_series_names(i)%s, '1')
         end if
      end do
   contains
      subroutine add(name, unit)
         character(len=*), intent(in) :: name, unit
         n = n + 1
         names(n)%s = name
         units(n)%s = unit
      end subroutine add
      subroutine per_node(prefix, unit)
         character(len=*), intent(in) :: prefix, unit
         integer :: k
         do k = 1, size(meta%node_ids)
            call add(prefix//meta%node_ids(k)%s, unit)
         end do
      end subroutine per_node
      subroutine per_element(prefix, unit)
         character(len=*), intent(in) :: prefix, unit
         integer :: k
         do k = 1, ne
            call add(prefix//meta%element_ids(k)%s, unit)
         end do
      end subroutine per_element
      function disp_unit(k) result(u)
         integer, intent(in) :: k
         character(len=:), allocatable :: u
         u = 'rad'
         if (allocated(meta%element_disp_units)) then
            if (len(meta%element_disp_units(k)%s) > 0) u = meta%element_disp_units(k)%s
         end if
      end function disp_unit
   end subroutine label

   integer function count_inputs(meta) result(n)
      type(run_meta_t), intent(in) :: meta
      n = 0
      if (allocated(meta%input_series_names)) n = size(meta%input_series_names)
   end function count_inputs

   pure logical function ends(s, tail)
      character(len=*), intent(in) :: s, tail
      ends = .false.
      if (len(s) >= len(tail)) ends = s(len(s) - len(tail) + 1:) == tail
   end function ends

   subroutine cap_sample(self, s, err)
      class(capture_sink_t), intent(inout) :: self
      type(sample_t), intent(in) :: s
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: grown(:, :)
      integer :: k, nc
      if (s%t >= self%t_metrics) then
         self%wmin = min(self%wmin, s%omega)
         self%wmax = max(self%wmax, s%omega)
      end if
      if (.not. self%series) return
      nc = size(self%data, 1)
      if (self%n_rows == size(self%data, 2)) then
         allocate (grown(nc, 2*size(self%data, 2)))
         grown(:, 1:self%n_rows) = self%data(:, 1:self%n_rows)
         call move_alloc(grown, self%data)
      end if
      self%n_rows = self%n_rows + 1
      associate (row => self%data(:, self%n_rows))
         k = 1
         row(k) = s%t
         call put(s%y)
         call put(s%theta)
         call put(s%omega)
         call put(s%torque_left)
         call put(s%torque_right)
         call put(s%displacement)
         call put(s%force)
         call put(real(s%contact, wp))
         call put(real(s%pairs, wp))
         call put(s%energy)
         if (allocated(s%inputs)) call put(s%inputs)
      end associate
   contains
      subroutine put(v)
         real(wp), intent(in) :: v(:)
         self%data(k + 1:k + size(v), self%n_rows) = v
         k = k + size(v)
      end subroutine put
   end subroutine cap_sample

   !> Without a series, only the speeds are read (as a sweep run's sink).
   pure logical function cap_speeds_only(self) result(only)
      class(capture_sink_t), intent(in) :: self
      only = .not. self%series
   end function cap_speeds_only

   subroutine cap_metrics_from(self, t)
      class(capture_sink_t), intent(inout) :: self
      real(wp), intent(in) :: t
      self%t_metrics = t
   end subroutine cap_metrics_from

   subroutine cap_close(self, events, stats, metrics, err)
      class(capture_sink_t), intent(inout) :: self
      type(event_t), intent(in) :: events(:)
      type(run_stats_t), intent(in) :: stats
      type(element_metrics_t), intent(in) :: metrics(:)
      type(error_t), allocatable, intent(out) :: err
      associate (u1 => self, u2 => events, u3 => stats, u4 => metrics)
      end associate
   end subroutine cap_close

   ! ------------------------------------------------------------------ tee

   subroutine tee_open(self, meta, err)
      class(tee_sink_t), intent(inout) :: self
      type(run_meta_t), intent(in) :: meta
      type(error_t), allocatable, intent(out) :: err
      call self%a%open(meta, err)
      if (.not. allocated(err)) call self%b%open(meta, err)
   end subroutine tee_open

   subroutine tee_sample(self, s, err)
      class(tee_sink_t), intent(inout) :: self
      type(sample_t), intent(in) :: s
      type(error_t), allocatable, intent(out) :: err
      call self%a%write_sample(s, err)
      if (.not. allocated(err)) call self%b%write_sample(s, err)
   end subroutine tee_sample

   subroutine tee_close(self, events, stats, metrics, err)
      class(tee_sink_t), intent(inout) :: self
      type(event_t), intent(in) :: events(:)
      type(run_stats_t), intent(in) :: stats
      type(element_metrics_t), intent(in) :: metrics(:)
      type(error_t), allocatable, intent(out) :: err
      call self%a%close(events, stats, metrics, err)
      if (.not. allocated(err)) call self%b%close(events, stats, metrics, err)
   end subroutine tee_close

   subroutine tee_abort(self)
      class(tee_sink_t), intent(inout) :: self
      call self%a%abort()
      call self%b%abort()
   end subroutine tee_abort

   subroutine tee_write_event(self, row, ev, err)
      class(tee_sink_t), intent(inout) :: self
      integer, intent(in) :: row
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      call self%a%write_event(row, ev, err)
      if (.not. allocated(err)) call self%b%write_event(row, ev, err)
   end subroutine tee_write_event

   subroutine tee_update_event(self, row, ev, err)
      class(tee_sink_t), intent(inout) :: self
      integer, intent(in) :: row
      type(event_t), intent(in) :: ev
      type(error_t), allocatable, intent(out) :: err
      call self%a%update_event(row, ev, err)
      if (.not. allocated(err)) call self%b%update_event(row, ev, err)
   end subroutine tee_update_event

   pure logical function tee_stores_samples(self) result(stores)
      class(tee_sink_t), intent(in) :: self
      stores = self%a%stores_samples() .or. self%b%stores_samples()
   end function tee_stores_samples

   !> Speeds only if both read only speeds (a sink that takes no samples reads none).
   pure logical function tee_speeds_only(self) result(only)
      class(tee_sink_t), intent(in) :: self
      only = (self%a%speeds_only() .or. .not. self%a%stores_samples()) .and. &
             (self%b%speeds_only() .or. .not. self%b%stores_samples())
   end function tee_speeds_only

   subroutine tee_metrics_from(self, t)
      class(tee_sink_t), intent(inout) :: self
      real(wp), intent(in) :: t
      call self%a%metrics_from(t)
      call self%b%metrics_from(t)
   end subroutine tee_metrics_from
end module trainsim_capture