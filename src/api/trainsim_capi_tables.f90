!> The tables of the C interface (trainsim_capi): a run's metrics by name, with units,
!> as one flat list, and the columns of the event table. The metrics are the figures a
!> sweep file records of each run (docs/sweeps.md "The sweep file"), computed the same
!> way: per element `ID.force_min` ... `ID.static_te_p2p`, per node `ID.speed_min`,
!> `speed_max` (output samples from the start of the metrics' window), `end_angle`,
!> `end_speed`, `start_speed`, and `run.steps`, `run.rhs_evals`, `run.events`,
!> `run.energy_residual`, `run.settled` (1, 0, -1 not asked), `run.settle_periods`,
!> `run.settle_k`, `run.t_final`, `run.wall_time`.
module trainsim_capi_tables
   use trainsim_kinds, only: wp
   use trainsim_strings, only: string_t
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_orders, only: n_orders
   use trainsim_event, only: event_t
   use trainsim_sweep_file, only: element_metric_names, node_metric_names
   use trainsim_continuation, only: chain_state_t
   implicit none
   private

   public :: metric_table, event_columns, event_row

   integer, parameter :: n_run_values = 9   ! run.steps ... run.wall_time
   character(len=*), parameter :: ev_columns(14) = [character(len=17) :: 'time', 'element', 'kind', &
      'approach_velocity', 'restitution', 'damping', 'peak_force', 'duration', 'theta_left', 'omega_left', &
      'theta_right', 'omega_right', 'displacement', 'force']

contains

   !> Names, units and values of every metric of the run `res` of `model` (as built),
   !> which ended in the state `st`. `wmin`, `wmax`: the node speed range.
   subroutine metric_table(model, res, st, wmin, wmax, names, units, values)
      type(model_t), intent(in) :: model
      type(run_result_t), intent(in) :: res
      type(chain_state_t), intent(in) :: st
      real(wp), intent(in) :: wmin(:), wmax(:)
      type(string_t), allocatable, intent(out) :: names(:), units(:)
      real(wp), allocatable, intent(out) :: values(:)
      character(len=:), allocatable :: d, f, tq
      integer :: k, n, ne, nn, q
      ne = size(model%elements); nn = size(model%nodes)
      n = size(element_metric_names)*ne + size(node_metric_names)*nn + n_run_values
      allocate (names(n), units(n), values(n))
      n = 0
      tq = model%units%torque
      do k = 1, ne
         associate (e => res%el(k), id => model%elements(k)%e%id)
            d = model%elements(k)%e%displacement_unit()
            if (d == 'length') d = model%units%length
            f = model%units%force
            if (d == 'rad') f = tq   ! an angle's force is a torque (shafts)
            call add(id, 1, e%force_min, f); call add(id, 2, e%force_max, f)
            call add(id, 3, e%torque_min, tq); call add(id, 4, e%torque_max, tq)
            call add(id, 5, e%disp_min, d); call add(id, 6, e%disp_max, d)
            call add(id, 7, real(e%impacts, wp), '1'); call add(id, 8, real(e%separations, wp), '1')
            call add(id, 9, real(e%zone_changes, wp), '1')
            call add(id, 10, e%max_approach_velocity, d//'/s'); call add(id, 11, e%max_peak_force, f)
            call add(id, 12, e%time_out_of_contact, 's'); call add(id, 13, e%p2p_range, d)
            call add(id, 14, e%p2p_mean, d); call add(id, 15, real(e%p2p_swings, wp), '1')
            call add(id, 16, e%load_sharing, '1'); call add(id, 17, e%kv, '1')
            call add(id, 18, e%static_force, f); call add(id, 19, e%static_te_mean, d)
            call add(id, 20, e%static_te_p2p, d); call add(id, 21, e%force_mean, f)
            do q = 1, n_orders
               call add(id, 21 + q, e%te_order(q), d); call add(id, 21 + n_orders + q, e%force_order(q), f)
            end do
            call add(id, 30, e%rattle_impacts, '1'); call add(id, 31, e%rattle_open, '1')
            call add(id, 32, e%rattle_criterion, '1'); call add(id, 33, e%rattle_energy, tq)   ! (energy: the torque's unit)
            call add(id, 34, e%rattle_power, tq//'/s')
         end associate
      end do
      do k = 1, nn
         associate (id => model%nodes(k)%n%id)
            call put(id//'.'//trim(node_metric_names(1)), wmin(k), 'rad/s')
            call put(id//'.'//trim(node_metric_names(2)), wmax(k), 'rad/s')
            call put(id//'.'//trim(node_metric_names(3)), st%theta(k), 'rad')
            call put(id//'.'//trim(node_metric_names(4)), st%omega(k), 'rad/s')
            call put(id//'.'//trim(node_metric_names(5)), st%omega0(k), 'rad/s')
         end associate
      end do
      associate (s => res%stats)
         call put('run.steps', real(s%steps, wp), '1')
         call put('run.rhs_evals', real(s%rhs_evals, wp), '1')
         call put('run.events', real(s%events, wp), '1')
         values(n + 1) = 0.0_wp
         if (res%energy_scale > 0.0_wp) values(n + 1) = res%energy_residual_max/res%energy_scale
         call put('run.energy_residual', values(n + 1), '1')
         select case (s%settle_status)
         case (1, 3); call put('run.settled', 1.0_wp, '1')
         case (2, 4); call put('run.settled', 0.0_wp, '1')
         case default; call put('run.settled', -1.0_wp, '1')
         end select
         call put('run.settle_periods', real(s%settle_periods, wp), '1')
         call put('run.settle_k', real(s%settle_k, wp), '1')
         call put('run.t_final', res%t_final, 's')
         call put('run.wall_time', s%wall_time, 's')
      end associate
   contains
      subroutine add(id, m, v, u)
         character(len=*), intent(in) :: id, u
         integer, intent(in) :: m
         real(wp), intent(in) :: v
         call put(id//'.'//trim(element_metric_names(m)), v, u)
      end subroutine add
      subroutine put(name, v, u)
         character(len=*), intent(in) :: name, u
         real(wp), intent(in) :: v
         n = n + 1
         names(n)%s = name
         units(n)%s = u
         values(n) = v
      end subroutine put
   end subroutine metric_table

   !> The columns of the event table (as /events of a history file).
   function event_columns() result(names)
      type(string_t), allocatable :: names(:)
      integer :: k
      allocate (names(size(ev_columns)))
      do k = 1, size(ev_columns)
         names(k)%s = trim(ev_columns(k))
      end do
   end function event_columns

   !> One event as a row of event_columns (element: 1-based index; kind: 1..4).
   function event_row(ev) result(row)
      type(event_t), intent(in) :: ev
      real(wp) :: row(size(ev_columns))
      row = [ev%t, real(ev%element, wp), real(ev%kind, wp), ev%approach_velocity, ev%restitution, ev%damping, &
             ev%peak_force, ev%duration, ev%theta_left, ev%omega_left, ev%theta_right, ev%omega_right, &
             ev%displacement, ev%force]
   end function event_row
end module trainsim_capi_tables
