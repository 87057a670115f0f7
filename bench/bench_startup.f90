!> Start-up benchmark (issue #22 item 5, D-64): the time from a deck's
!> text to the end of the first step, in process, phase by phase as `trainsim
!> run --no-output` does it (app/main.f90 `load` and `do_run`):
!>   parse      parse_deck of the deck's text;
!>   prepare    prepare_model (build, derived values, settle period);
!>   refuse     check_fixed_step (the refusals of D-55);
!>   advice     rk4_dt_limit as the run starts and in the stiffest state;
!>   first step simulate with t_end = dt (one step, null sink: its own set-up).
!> Cases: a 200-node chain with a backlash gear as every 10th element (400
!> states: dense advice before D-64) and shaft chains of 1 000, 5 000 and
!> 20 000 nodes (and backlash chains of the same sizes); CPU time, best of
!> n_rep. The ratio column is time over the previous row's time (the node
!> count grows 5x, 4x): linear start-up shows ratios equal to the growth.
!>
!> `bench_startup dense` instead times the dense advice (`rk4_dt_limit(...,
!> dense=.true.)`, both states) of backlash chains of 8 .. 64 nodes against the
!> O(n) bound, for the threshold dense_state_limit.
!>
!> `bench_startup bound` times `rk4_dt_bound` alone (the model set up
!> outside the timed region) on the chains, per node.
!>
!> Run from the build tree (Release): ./bench/bench_startup [dense|bound]
program bench_startup
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit, compiler_version
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_deck, only: deck_t, parse_deck
   use trainsim_overrides, only: override_t
   use trainsim_prepare, only: prepare_model
   use trainsim_model, only: model_t
   use trainsim_modes, only: rk4_dt_limit, dense_state_limit, rk4_dt_bound, with_loads
   use trainsim_element, only: lin_start, lin_stiffest
   use trainsim_simulate, only: simulate, check_fixed_step
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_version, only: version_string
   use bench_build_info, only: build_type
   implicit none

   integer, parameter :: n_rep = 3
   integer, parameter :: n_phase = 5
   character(len=10), parameter :: phase_name(n_phase) = [character(len=10) :: 'parse', 'prepare', 'refuse', &
                                                          'advice', 'first step']
   real(wp), parameter :: chain_dt = 5.0e-3_wp
   character(len=32) :: arg

   arg = ''
   if (command_argument_count() > 0) call get_command_argument(1, arg)
   write (output_unit, '(a)') 'trainsim start-up benchmark (bench/bench_startup.f90)'
   write (output_unit, '(a)') '  trainsim version : '//version_string
   write (output_unit, '(a)') '  build type       : '//build_type
   write (output_unit, '(a)') '  compiler         : '//compiler_version()
   write (output_unit, '(a,i0,a)') '  method           : CPU time (cpu_time), best of ', n_rep, ' per phase'
   if (arg == 'dense') then
      call dense_section()
   else if (arg == 'bound') then
      call bound_section()
   else
      call startup_section()
   end if

contains

   !> Start-up of the chains, phase by phase.
   subroutine startup_section()
      integer, parameter :: sizes(4) = [1000, 5000, 20000, 0]
      real(wp) :: t(n_phase), prev
      integer :: i
      write (output_unit, '(/,a,i0,a)') 'Start-up to the end of the first step, s (dense advice up to ', &
         dense_state_limit, ' states)'
      write (output_unit, '(a18,6a11,a8)') 'chain', (phase_name(i), i=1, n_phase), 'total', 'ratio'
      call startup_of(200, .true., t)
      call print_row('200, backlash', t, -1.0_wp)
      prev = -1.0_wp
      do i = 1, 3
         call startup_of(sizes(i), .false., t)
         call print_row(str(sizes(i))//', shafts', t, prev)
         prev = sum(t)
      end do
      prev = -1.0_wp
      do i = 1, 3
         call startup_of(sizes(i), .true., t)
         call print_row(str(sizes(i))//', backlash', t, prev)
         prev = sum(t)
      end do
   end subroutine startup_section

   !> The dense advice against the bound on small backlash chains.
   subroutine dense_section()
      integer, parameter :: sizes(5) = [8, 16, 24, 32, 48]
      type(model_t) :: m
      type(error_t), allocatable :: err
      real(wp) :: c0, c1, best_d, best_b, dt_d(2), dt_b(2), om
      integer :: i, r
      write (output_unit, '(/,a)') 'Advice as the run starts and in the stiffest state: dense (dgeev) against the O(n) bound'
      write (output_unit, '(a8,a8,2a14,2a14,a10)') 'nodes', 'states', 'dense, s', 'bound, s', 'dt dense', 'dt bound', &
         'ratio'
      do i = 1, size(sizes)
         best_d = huge(1.0_wp); best_b = huge(1.0_wp)
         do r = 1, n_rep
            call load(chain_deck(sizes(i), .true.), m)
            call cpu_time(c0)
            call rk4_dt_limit(m, lin_start, dt_d(1), om, err, dense=.true.)
            call rk4_dt_limit(m, lin_stiffest, dt_d(2), om, err, dense=.true.)
            call cpu_time(c1)
            best_d = min(best_d, c1 - c0)
            call cpu_time(c0)
            call rk4_dt_limit(m, lin_start, dt_b(1), om, err, dense=.false.)
            call rk4_dt_limit(m, lin_stiffest, dt_b(2), om, err, dense=.false.)
            call cpu_time(c1)
            best_b = min(best_b, c1 - c0)
         end do
         if (m%n_states <= dense_state_limit) then
            ! below the threshold `dense=.false.` is dense too: time the bound alone
            best_b = -1.0_wp
         end if
         write (output_unit, '(i8,i8,2es14.3,2es14.4,f10.4)') sizes(i), m%n_states, best_d, best_b, minval(dt_d), &
            minval(dt_b), minval(dt_b)/minval(dt_d)
      end do
   end subroutine dense_section

   !> The O(n) bound alone, stiffest state, on the chains (best of 10 calls).
   subroutine bound_section()
      integer, parameter :: sizes(4) = [200, 1000, 5000, 20000]
      type(model_t) :: m
      real(wp), allocatable :: y(:)
      real(wp) :: c0, c1, best, dt, bound, prev
      integer :: i, r
      write (output_unit, '(/,a)') 'rk4_dt_bound alone (stiffest state, backlash chains), best of 10 calls'
      write (output_unit, '(a8,a14,a14,a10)') 'nodes', 'seconds', 'us per node', 'ratio'
      prev = -1.0_wp
      do i = 1, size(sizes)
         call load(chain_deck(sizes(i), .true.), m)
         call m%initial_state(y)
         call m%init_modes(m%run%t_start, y)
         best = huge(1.0_wp)
         do r = 1, 10
            call cpu_time(c0)
            call rk4_dt_bound(m, with_loads(m, lin_stiffest), y, dt, bound)
            call cpu_time(c1)
            best = min(best, c1 - c0)
         end do
         if (prev > 0.0_wp) then
            write (output_unit, '(i8,es14.3,f14.3,f10.2)') sizes(i), best, 1.0e6_wp*best/sizes(i), best/prev
         else
            write (output_unit, '(i8,es14.3,f14.3)') sizes(i), best, 1.0e6_wp*best/sizes(i)
         end if
         prev = best
      end do
   end subroutine bound_section

   !> Best-of-n_rep CPU time of each start-up phase of a chain of n nodes.
   subroutine startup_of(n, backlash, best)
      integer, intent(in) :: n
      logical, intent(in) :: backlash
      real(wp), intent(out) :: best(n_phase)
      character(len=:), allocatable :: text
      type(deck_t) :: deck
      type(model_t) :: m
      type(override_t) :: none(0)
      type(error_t), allocatable :: err
      type(run_result_t) :: res
      type(null_sink_t) :: sink
      real(wp) :: c(0:n_phase), dt_safe, om, f, z
      integer :: r
      text = chain_deck(n, backlash)
      best = huge(1.0_wp)
      do r = 1, n_rep
         call cpu_time(c(0))
         call parse_deck(text, 'bench', deck, err)
         call check(err)
         call cpu_time(c(1))
         call prepare_model(deck, none, m, err)
         call check(err)
         call cpu_time(c(2))
         call check_fixed_step(m, err)
         call check(err)
         call cpu_time(c(3))
         call rk4_dt_limit(m, lin_start, dt_safe, om, err, freq_hz=f, damping_ratio=z)
         call check(err)
         call rk4_dt_limit(m, lin_stiffest, dt_safe, om, err, freq_hz=f, damping_ratio=z)
         call check(err)
         call cpu_time(c(4))
         call simulate(m, sink, res, err)
         call check(err)
         call cpu_time(c(5))
         best = min(best, c(1:n_phase) - c(0:n_phase - 1))
      end do
   end subroutine startup_of

   subroutine print_row(label, t, prev)
      character(len=*), intent(in) :: label
      real(wp), intent(in) :: t(n_phase), prev
      character(len=8) :: ratio
      ratio = ''
      if (prev > 0.0_wp) write (ratio, '(f8.2)') sum(t)/prev
      write (output_unit, '(a18,6f11.4,a8)') label, t, sum(t), ratio
   end subroutine print_row

   !> The chain of bench_rk4_throughput (unit inertias, shafts k = 1e4, with
   !> `backlash` a spur gear with half backlash 1e-3 as every 10th element;
   !> node 1 starts at 1 rad/s), run for one step of chain_dt.
   function chain_deck(n, backlash) result(text)
      integer, intent(in) :: n
      logical, intent(in) :: backlash
      character(len=:), allocatable :: text
      character(len=:), allocatable :: buf
      character(len=256) :: line
      integer :: i, k
      allocate (character(len=512 + 256*(2*n + 1)) :: buf)
      k = 0
      write (line, '(a,es10.3,a,es10.3,a)') "&run title = 'bench: start-up', t_end = ", chain_dt, ', dt = ', &
         chain_dt, ", integrator = 'rk4', track_energy = .false. /"
      call append(buf, k, trim(line))
      do i = 1, n
         write (line, '(a,i0,a)') "&node id = 'n", i, "', type = 'inertia', inertia = 1.0 /"
         call append(buf, k, trim(line))
      end do
      do i = 1, n - 1
         if (backlash .and. mod(i, 10) == 0) then
            write (line, '(a,i0,a)') "&element id = 'e", i, "', type = 'spur_gear', stiffness = 1.0e4, "// &
               'rb_driver = 1.0, rb_driven = 1.0, teeth = 32, contact_ratio = 1.6, approach_angle = 0.1, '// &
               'half_backlash = 1.0e-3 /'
         else
            write (line, '(a,i0,a)') "&element id = 'e", i, "', type = 'shaft', stiffness = 1.0e4 /"
         end if
         call append(buf, k, trim(line))
      end do
      call append(buf, k, "&initial node = 'n1', speed = 1.0 /")
      text = buf(1:k - 1)
   end function chain_deck

   subroutine append(buf, k, s)
      character(len=*), intent(inout) :: buf
      integer, intent(inout) :: k
      character(len=*), intent(in) :: s
      buf(k + 1:k + len(s) + 1) = s//new_line('a')
      k = k + len(s) + 1
   end subroutine append

   subroutine load(text, m)
      character(len=*), intent(in) :: text
      type(model_t), intent(out) :: m
      type(deck_t) :: deck
      type(override_t) :: none(0)
      type(error_t), allocatable :: err
      call parse_deck(text, 'bench', deck, err)
      call check(err)
      call prepare_model(deck, none, m, err)
      call check(err)
   end subroutine load

   subroutine check(err)
      type(error_t), allocatable, intent(in) :: err
      if (.not. allocated(err)) return
      write (error_unit, '(a)') 'bench_startup: '//err%message
      error stop 1
   end subroutine check
end program bench_startup
