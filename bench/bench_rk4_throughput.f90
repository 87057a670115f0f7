!> RK4 throughput benchmark of `simulate` with the fixed-step event-located
!> RK4 ('rk4'), no output (null sink):
!>   1. the Table 5.5 rig (4 nodes; shaft - gear pair - shaft, dt = 8e-6 s,
!>      2e6 steps) with an ideal gear and with the spur gear with backlash,
!>      energy tracking off and on, against a hand-specialised loop of the same
!>      equations (bench_reference), timed in the same run, interleaved; the
!>      final states are compared so the two are known to be the same equations;
!>   2. uniform serial chains of 10 .. 5000 nodes, all shafts, and with a spur
!>      gear with backlash as every 10th element: ns per node-step, events,
!>      RHS evaluations per event;
!>   3. peak resident memory against run length (child processes of this program).
!> With `--hdf5` it also times HDF5 output on the rig (every step, every 10th);
!> with `rig`, `chain` or `rss` it runs that section only; `--profile CASE`
!> (ideal-off, ideal-on, backlash-off, backlash-on, ref-ideal, ref-backlash; chain-shafts,
!> chain-backlash: the 1000-node chain, 3000 steps)
!> runs one run alone, for `perf record`.
!>
!> Decks are built as strings, parsed and built outside the timed region; the
!> timed region is one call of `simulate` (sink open/close included), timed in
!> CPU time (the HDF5 section in wall time). Each figure is the fastest of
!> n_rep runs; the A/B pairs are interleaved (A, B, A, B, ...) so machine load
!> hits both alike. See docs/benchmarks.md.
program bench_rk4_throughput
   use, intrinsic :: iso_fortran_env, only: compiler_version, compiler_options, output_unit, error_unit, int64
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t
   use trainsim_deck, only: deck_t, parse_deck
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_simulate, only: simulate
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_hdf5, only: hdf5_sink_t
   use trainsim_version, only: version_string
   use bench_build_info, only: build_type
   use bench_reference, only: ref_result_t, ref_rig
   implicit none

   !> Repetitions per figure (the minimum is reported).
   integer, parameter :: n_rep = 5
   !> Steps of a rig run (the issue's figure: 2e6 steps of 8e-6 s).
   integer(i8), parameter :: rig_steps = 2000000_i8
   real(wp), parameter :: rig_dt = 8.0e-6_wp, chain_dt = 5.0e-3_wp
   character(len=*), parameter :: hrule = repeat('-', 100)

   character(len=:), allocatable :: h5_path, arg
   integer(int64) :: c_start, c_stop, c_rate
   integer :: nargs
   integer(i8) :: n_rss
   character(len=:), allocatable :: rss_file

   nargs = command_argument_count()
   if (nargs >= 2) then
      call get_arg(1, arg)
      if (arg == '--profile') then
         ! profiling mode (perf record): one trainsim run of the rig, no reference
         call get_arg(2, arg)
         call profile_run(arg)
         stop
      end if
      if (arg == '--rss') then
         ! child mode: one run of the backlash rig, then print the peak RSS
         call get_arg(2, arg)
         read (arg, *) n_rss
         rss_file = ''
         if (nargs >= 3) call get_arg(3, rss_file)
         call rss_child(n_rss, rss_file)
         stop
      end if
   end if

   call system_clock(c_start, c_rate)
   h5_path = temp_h5_path()
   write (output_unit, '(a)') 'trainsim RK4 throughput benchmark (bench/bench_rk4_throughput.f90)'
   write (output_unit, '(a)') '  trainsim version : '//version_string
   write (output_unit, '(a)') '  build type       : '//build_type
   write (output_unit, '(a)') '  compiler         : '//compiler_version()
   write (output_unit, '(a)') '  compiler options : '//compiler_options()
   write (output_unit, '(a,i0,a)') '  method           : best of ', n_rep, &
      ' timed calls, A/B interleaved; CPU time of this process (cpu_time); null sink'
   write (output_unit, '(a)') ''

   arg = ''
   if (nargs >= 1) call get_arg(1, arg)
   if (arg == '' .or. arg == '--hdf5' .or. arg == 'rig') call rig_section()
   if (arg == '' .or. arg == '--hdf5' .or. arg == 'chain') call chain_section()
   if (arg == '' .or. arg == '--hdf5' .or. arg == 'rss') call rss_section()
   if (arg == '--hdf5') call hdf5_section()

   call system_clock(c_stop)
   write (output_unit, '(a)') ''
   write (output_unit, '(a,f6.1,a)') 'total benchmark wall time: ', real(c_stop - c_start, wp)/real(c_rate, wp), ' s'

contains

   !> 1. The rig: trainsim against the reference, ideal and backlash gear.
   subroutine rig_section()
      type(model_t) :: m_off, m_on
      type(run_result_t) :: r_off, r_on
      type(ref_result_t) :: ref, ref_short
      type(run_result_t) :: r_short
      real(wp) :: t_ref, t_off, t_on, secs, t_end, dy, dshort
      integer :: variant, rep
      logical :: bl
      character(len=8) :: names(2) = ['ideal   ', 'backlash']

      t_end = real(rig_steps, wp)*rig_dt
      write (output_unit, '(a,i0,a)') '1. Table 5.5 rig (4 nodes, node 1 held at 80 rad/s), rk4, dt = 8e-6 s, ', &
         rig_steps, ' steps, no output'
      write (output_unit, '(a)') hrule
      write (output_unit, '(a)') 'gear      reference  trainsim   trainsim   ref/ts     ref/ts    energy   '// &
         'events  RHS/event  max|dy| vs ref'
      write (output_unit, '(a)') '          [Msteps/s] off [Ms/s] on [Ms/s]  (off)      (on)      cost            '// &
         '(extra)    final / 0.1 s run'
      write (output_unit, '(a)') hrule
      do variant = 1, 2
         bl = variant == 2
         t_ref = huge(1.0_wp); t_off = huge(1.0_wp); t_on = huge(1.0_wp)
         do rep = 1, n_rep
            call time_ref(bl, t_end, ref, secs); t_ref = min(t_ref, secs)
            call load(rig_deck(t_end, rig_dt, .false., bl), m_off)
            call time_run(m_off, r_off, secs); t_off = min(t_off, secs)
            call load(rig_deck(t_end, rig_dt, .true., bl), m_on)
            call time_run(m_on, r_on, secs); t_on = min(t_on, secs)
         end do
         if (r_off%stats%steps /= rig_steps .or. ref%steps /= rig_steps) call die('rig: unexpected number of steps')
         dy = maxval(abs(r_off%y_final(1:6) - ref%y))
         ! a short run as well: a rattling gear amplifies differences of 1e-9 dt in
         ! the event times over 2e6 steps, so the equations are compared on 0.1 s
         call ref_rig(bl, 0.1_wp, rig_dt, ref_short)
         call load(rig_deck(0.1_wp, rig_dt, .false., bl), m_off)
         call time_run(m_off, r_short, secs)
         dshort = maxval(abs(r_short%y_final(1:6) - ref_short%y))
         write (output_unit, '(a8,3f10.3,2f10.3,a9,i9,f9.2,es11.2,a,es9.2)') names(variant), &
            1.0e-6_wp*real(rig_steps, wp)/t_ref, 1.0e-6_wp*real(rig_steps, wp)/t_off, &
            1.0e-6_wp*real(rig_steps, wp)/t_on, t_ref/t_off, t_ref/t_on, pct(t_on, t_off), r_off%stats%events, &
            extra_rhs_per_event(r_off), dy, ' /', dshort
         if (bl) write (output_unit, '(a,i0,a,f6.2,a)') '          reference: ', ref%events, &
            ' events, ', real(ref%located, wp)/real(max(ref%events, 1_i8), wp), &
            ' RHS per event spent locating (step map)'
         write (output_unit, '(a,f6.2,a,f6.2,a)') '          trainsim: steps taken in blocks (D-38) ', &
            100.0_wp*real(r_off%stats%block_steps, wp)/real(r_off%stats%steps, wp), ' % (energy off), ', &
            100.0_wp*real(r_on%stats%block_steps, wp)/real(r_on%stats%steps, wp), ' % (on)'
         flush (output_unit)
      end do
      write (output_unit, '(a)') hrule
      write (output_unit, '(a)') '  ref/ts: trainsim steps/s over the reference''s (1 = as fast as the hand-written loop);'
      write (output_unit, '(a)') '  energy cost: trainsim with track_energy on against off; RHS/event (extra): '// &
         '(RHS - 4 steps)/events'
      write (output_unit, '(a)') ''
   end subroutine rig_section

   !> 2. Serial chains: shafts only, and a backlash gear as every 10th element.
   subroutine chain_section()
      integer, parameter :: sizes(4) = [10, 100, 1000, 5000]
      type(model_t) :: m
      type(run_result_t) :: rs, rb
      real(wp) :: ts, tb, secs, t_end
      integer :: j, rep, n
      integer(i8) :: nsteps
      write (output_unit, '(a)') '2. Serial chains: J = 1, shafts k = 1e4 (every 10th element a spur gear with backlash, '// &
         'k = 1e4, half backlash 1e-3), node 1 starts at 1 rad/s, rk4, dt = 5e-3 s, energy off'
      write (output_unit, '(a)') hrule
      write (output_unit, '(a)') ' nodes    steps   shafts [ns/node-step]  backlash [ns/node-step]   ratio    events  '// &
         'events/step  RHS/event'
      write (output_unit, '(a)') hrule
      do j = 1, size(sizes)
         n = sizes(j)
         nsteps = max(200_i8, int(3.0e6_wp/real(n, wp), i8))
         t_end = real(nsteps, wp)*chain_dt
         ts = huge(1.0_wp); tb = huge(1.0_wp)
         do rep = 1, n_rep
            call load(chain_deck(n, t_end, chain_dt, .false.), m)
            call time_run(m, rs, secs); ts = min(ts, secs)
            call load(chain_deck(n, t_end, chain_dt, .true.), m)
            call time_run(m, rb, secs); tb = min(tb, secs)
         end do
         write (output_unit, '(i6,i9,f16.1,f25.1,f13.2,i10,f12.3,f11.2)') n, nsteps, &
            1.0e9_wp*ts/real(nsteps*n, wp), 1.0e9_wp*tb/real(nsteps*n, wp), tb/ts, rb%stats%events, &
            real(rb%stats%events, wp)/real(nsteps, wp), extra_rhs_per_event(rb)
         flush (output_unit)
      end do
      write (output_unit, '(a)') hrule
      write (output_unit, '(a)') '  ratio: backlash chain over shaft chain, per node-step'
      write (output_unit, '(a)') ''
   end subroutine chain_section

   !> 3. Peak RSS of a whole process running the backlash rig for n steps,
   !> without an output file (null sink) and with one (a sample every 100
   !> steps, every event): the run's memory must not grow with its length.
   subroutine rss_section()
      integer(i8), parameter :: lens(3) = [200000_i8, 2000000_i8, 20000000_i8]
      character(len=:), allocatable :: exe, out, h5
      character(len=256) :: line
      integer :: i, j, u, ios, cstat
      call get_arg(0, exe)
      out = h5_path//'.rss'
      h5 = h5_path//'.rss.h5'
      write (output_unit, '(a)') '3. Peak resident memory (VmHWM of a child process) against run length, backlash rig, '// &
         'energy on; without a file (null sink) and with one (a sample every 100 steps, every event)'
      write (output_unit, '(a)') hrule
      write (output_unit, '(a)') '     steps     events   peak RSS [MB]   file [MB]'
      do j = 1, 2
         do i = 1, size(lens)
            if (j == 1) then
               write (line, '(a,i0,a)') '"'//exe//'" --rss ', lens(i), ' > "'//out//'"'
            else
               write (line, '(a,i0,a)') '"'//exe//'" --rss ', lens(i), ' "'//h5//'" > "'//out//'"'
            end if
            call execute_command_line(trim(line), exitstat=ios, cmdstat=cstat)
            call remove_file(h5)
            if (ios /= 0 .or. cstat /= 0) then
               write (output_unit, '(a)') '   (child failed)'
               cycle
            end if
            open (newunit=u, file=out, status='old', action='read', iostat=ios)
            if (ios /= 0) cycle
            read (u, '(a)', iostat=ios) line
            close (u, status='delete')
            write (output_unit, '(a)') '  '//trim(line)
            flush (output_unit)
         end do
      end do
      write (output_unit, '(a)') hrule
      write (output_unit, '(a)') ''
   end subroutine rss_section

   !> Profiling mode: one trainsim run of the rig (2e6 steps), the case named
   !> by `which`: ideal-off, ideal-on, backlash-off or backlash-on; or one run
   !> of the reference loop: ref-ideal, ref-backlash; or of the 1000-node chain
   !> of section 2 for 3000 steps: chain-shafts, chain-backlash.
   subroutine profile_run(which)
      character(len=*), intent(in) :: which
      type(model_t) :: m
      type(run_result_t) :: r
      type(ref_result_t) :: ref
      real(wp) :: secs
      if (index(which, 'chain-') == 1) then
         ! chain-shafts or chain-backlash: the 1000-node chain of section 2 (3000 steps)
         call load(chain_deck(1000, 3000.0_wp*chain_dt, chain_dt, index(which, 'backlash') > 0), m)
         call time_run(m, r, secs)
         write (output_unit, '(a,f8.3,a,f8.1,a,i0,a)') which//': ', secs, ' s, ', 1.0e9_wp*secs/3.0e6_wp, &
            ' ns/node-step, ', r%stats%events, ' events'
         return
      end if
      if (index(which, 'ref-') == 1) then
         call time_ref(index(which, 'backlash') > 0, real(rig_steps, wp)*rig_dt, ref, secs)
         write (output_unit, '(a,f8.3,a,f8.1,a)') which//': ', secs, ' s, ', 1.0e9_wp*secs/real(rig_steps, wp), ' ns/step'
         return
      end if
      call load(rig_deck(real(rig_steps, wp)*rig_dt, rig_dt, index(which, '-on') > 0, &
                         index(which, 'backlash') > 0), m)
      call time_run(m, r, secs)
      write (output_unit, '(a,f8.3,a,f8.1,a)') which//': ', secs, ' s, ', 1.0e9_wp*secs/real(rig_steps, wp), ' ns/step'
   end subroutine profile_run

   !> Child of rss_section: one run (to `file` if not ''), then
   !> "steps events peak-RSS-MB [file-MB]".
   subroutine rss_child(n, file)
      integer(i8), intent(in) :: n
      character(len=*), intent(in) :: file
      type(model_t) :: m
      type(run_result_t) :: r
      type(hdf5_sink_t) :: h5
      type(error_t), allocatable :: err
      real(wp) :: secs
      integer(i8) :: bytes
      character(len=:), allocatable :: text
      if (len(file) == 0) then
         call load(rig_deck(real(n, wp)*rig_dt, rig_dt, .true., .true.), m)
         call time_run(m, r, secs)
         write (output_unit, '(i10,i11,f16.2)') r%stats%steps, r%stats%events, real(vm_hwm_kb(), wp)/1024.0_wp
      else
         text = rig_deck(real(n, wp)*rig_dt, rig_dt, .true., .true.)
         text = text(1:index(text, '/') - 1)//', output_interval = '//r2s(100.0_wp*rig_dt)//' '//text(index(text, '/'):)
         call load(text, m)
         h5%path = file
         call simulate(m, h5, r, err)
         if (allocated(err)) call die(err%message)
         inquire (file=file, size=bytes)
         write (output_unit, '(i10,i11,f16.2,f12.1)') r%stats%steps, r%stats%events, real(vm_hwm_kb(), wp)/1024.0_wp, &
            real(bytes, wp)/1.0e6_wp
      end if
   end subroutine rss_child

   !> Optional: HDF5 output on the rig (ideal gear, energy on).
   subroutine hdf5_section()
      type(model_t) :: m
      type(run_result_t) :: r
      type(hdf5_sink_t) :: h5
      type(error_t), allocatable :: err
      real(wp) :: t_end, interval(2), best, secs
      integer(i8) :: nsteps, bytes
      integer(int64) :: c0, c1, rate
      integer :: i, rep
      character(len=:), allocatable :: text
      nsteps = 100000_i8
      t_end = real(nsteps, wp)*rig_dt
      interval = [0.0_wp, 10.0_wp*rig_dt]
      write (output_unit, '(a)') '4. HDF5 output, ideal-gear rig, energy on, 1e5 steps'
      do i = 1, 2
         best = huge(1.0_wp)
         do rep = 1, n_rep
            text = rig_deck(t_end, rig_dt, .true., .false.)
            text = text(1:index(text, '/') - 1)//", output = '"//h5_path//"', output_interval = "// &
                   r2s(interval(i))//' '//text(index(text, '/'):)
            call load(text, m)
            call remove_file(h5_path)
            h5%path = m%run%output
            call system_clock(c0, rate)
            call simulate(m, h5, r, err)
            call system_clock(c1)
            if (allocated(err)) call die(err%message)
            secs = real(c1 - c0, wp)/real(rate, wp)
            best = min(best, secs)
            inquire (file=h5_path, size=bytes)
            call remove_file(h5_path)
         end do
         write (output_unit, '(a,es10.3,a,f9.1,a,f8.2,a)') '  output_interval = ', interval(i), ': ', &
            1.0e9_wp*best/real(nsteps, wp), ' ns/step, ', real(bytes, wp)/1.0e6_wp, ' MB'
      end do
   end subroutine hdf5_section

   !> Parse and build a model from deck text.
   subroutine load(text, m)
      character(len=*), intent(in) :: text
      type(model_t), intent(out) :: m
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      call parse_deck(text, 'bench', deck, err)
      if (allocated(err)) call die(err%message)
      call build_model(deck, m, err)
      if (allocated(err)) call die(err%message)
   end subroutine load

   !> One timed call of simulate with a null sink. Timed in CPU time: on a
   !> shared machine the wall time also counts the time the process waits for
   !> a core, which hits long runs more often than short ones.
   subroutine time_run(m, r, secs)
      type(model_t), intent(inout) :: m
      type(run_result_t), intent(out) :: r
      real(wp), intent(out) :: secs
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      real(wp) :: c0, c1
      call cpu_time(c0)
      call simulate(m, none, r, err)
      call cpu_time(c1)
      if (allocated(err)) call die(err%message)
      secs = c1 - c0
   end subroutine time_run

   !> One timed run of the reference loop.
   subroutine time_ref(backlash, t_end, ref, secs)
      logical, intent(in) :: backlash
      real(wp), intent(in) :: t_end
      type(ref_result_t), intent(out) :: ref
      real(wp), intent(out) :: secs
      real(wp) :: c0, c1
      call cpu_time(c0)
      call ref_rig(backlash, t_end, rig_dt, ref)
      call cpu_time(c1)
      secs = c1 - c0
   end subroutine time_ref

   !> RHS evaluations beyond 4 per grid step, per event.
   real(wp) function extra_rhs_per_event(r) result(x)
      type(run_result_t), intent(in) :: r
      x = 0.0_wp
      if (r%stats%events > 0) x = real(r%stats%rhs_evals - 4*r%stats%steps, wp)/real(r%stats%events, wp)
   end function extra_rhs_per_event

   !> The Table 5.5 rig (Cook 1989) at 80 rad/s: ideal gear, or the spur gear with backlash.
   function rig_deck(t_end, dt, track, backlash) result(text)
      real(wp), intent(in) :: t_end, dt
      logical, intent(in) :: track, backlash
      character(len=:), allocatable :: text
      character(len=*), parameter :: nl = new_line('a')
      text = "&run title = 'bench: Table 5.5 rig', t_end = "//r2s(t_end)//', dt = '//r2s(dt)// &
             ", integrator = 'rk4', track_energy = "//merge('.true. ', '.false.', track)//' /'//nl// &
             "&node id = 'n1', type = 'inertia', inertia = 100.0 /"//nl// &
             "&node id = 'n2', type = 'inertia', inertia = 0.987 /"//nl// &
             "&node id = 'n3', type = 'inertia', inertia = 0.987 /"//nl// &
             "&node id = 'n4', type = 'inertia', inertia = 100.0 /"//nl// &
             "&element id = 'e1', type = 'shaft', stiffness = 32000.0 /"//nl
      if (backlash) then
         text = text//"&element id = 'e2', type = 'spur_gear', stiffness = 234500.0, rb_driver = 3.7588, "// &
                'rb_driven = 3.7588, teeth = 32, contact_ratio = 1.6676, approach_angle = 0.1637, '// &
                'half_backlash = 0.005 /'//nl
      else
         text = text//"&element id = 'e2', type = 'ideal_gear', stiffness = 234500.0, rb_driver = 3.7588, "// &
                'rb_driven = 3.7588 /'//nl
      end if
      text = text//"&element id = 'e3', type = 'shaft', stiffness = 32000.0 /"//nl// &
             "&initial node = 'all', speed = 80.0 /"//nl// &
             "&initial node = 'n1', angle = -0.187847 /"//nl// &
             "&initial node = 'n2', angle = -0.212810 /"//nl// &
             "&initial node = 'n3', angle = -0.214283 /"//nl// &
             "&initial node = 'n4', angle = -0.239246 /"//nl// &
             "&load node = 'n1', quantity = 'speed', kind = 'constant', value = 80.0 /"//nl// &
             "&load node = 'n4', kind = 'constant', value = -798.8 /"
   end function rig_deck

   !> A serial chain of n unit inertias joined by shafts of stiffness 1e4, free at
   !> both ends; with `backlash`, every 10th element is a spur gear pair with unit
   !> base radii, the same stiffness and half backlash 1e-3. Node 1 starts at
   !> 1 rad/s, the others at rest: a wave runs down the chain and back, and each
   !> gear it reaches rattles.
   function chain_deck(n, t_end, dt, backlash) result(text)
      integer, intent(in) :: n
      real(wp), intent(in) :: t_end, dt
      logical, intent(in) :: backlash
      character(len=:), allocatable :: text
      character(len=:), allocatable :: buf
      character(len=256) :: line
      integer :: i, k
      allocate (character(len=512 + 256*(3*n + 1)) :: buf)
      k = 0
      call append(buf, k, "&run title = 'bench: serial chain', t_end = "//r2s(t_end)//', dt = '//r2s(dt)// &
                  ", integrator = 'rk4', track_energy = .false. /")
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

   !> Peak resident set (VmHWM, kB) of this process from /proc/self/status (-1 if unknown).
   integer function vm_hwm_kb() result(kb)
      character(len=256) :: line
      integer :: u, ios
      kb = -1
      open (newunit=u, file='/proc/self/status', status='old', action='read', iostat=ios)
      if (ios /= 0) return
      do
         read (u, '(a)', iostat=ios) line
         if (ios /= 0) exit
         if (line(1:6) == 'VmHWM:') then
            read (line(7:), *, iostat=ios) kb
            exit
         end if
      end do
      close (u)
   end function vm_hwm_kb

   !> "+12.3%" : x relative to ref.
   function pct(x, ref) result(s)
      real(wp), intent(in) :: x, ref
      character(len=9) :: s
      write (s, '(sp,f8.1,a)') 100.0_wp*(x/ref - 1.0_wp), '%'
   end function pct

   !> A real in full precision, for deck text.
   function r2s(x) result(s)
      real(wp), intent(in) :: x
      character(len=:), allocatable :: s
      character(len=32) :: buf
      write (buf, '(es24.16e3)') x
      s = trim(adjustl(buf))
   end function r2s

   subroutine get_arg(i, a)
      integer, intent(in) :: i
      character(len=:), allocatable, intent(out) :: a
      integer :: n
      call get_command_argument(i, length=n)
      allocate (character(len=n) :: a)
      if (n > 0) call get_command_argument(i, a)
   end subroutine get_arg

   !> $TMPDIR (or /tmp) / trainsim_bench_<clock>.h5
   function temp_h5_path() result(path)
      character(len=:), allocatable :: path
      character(len=4096) :: dir
      character(len=24) :: tag
      integer :: n, stat
      integer(int64) :: c
      call get_environment_variable('TMPDIR', dir, n, stat)
      if (stat /= 0 .or. n == 0) dir = '/tmp'
      call system_clock(c)
      write (tag, '(i0)') c
      path = trim(dir)//'/trainsim_bench_'//trim(tag)//'.h5'
   end function temp_h5_path

   subroutine remove_file(path)
      character(len=*), intent(in) :: path
      integer :: u, ios
      logical :: there
      inquire (file=path, exist=there)
      if (.not. there) return
      open (newunit=u, file=path, status='old', iostat=ios)
      if (ios == 0) close (u, status='delete', iostat=ios)
   end subroutine remove_file

   subroutine die(msg)
      character(len=*), intent(in) :: msg
      write (error_unit, '(a)') 'bench_rk4_throughput: '//msg
      call remove_file(h5_path)
      error stop 1
   end subroutine die
end program bench_rk4_throughput
