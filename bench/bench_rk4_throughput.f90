!> RK4 throughput benchmark: steps per second of `simulate` with the fixed-step
!> event-located RK4 ('rk4'), for
!>   1. the 4-node Table 5.5 rig with its gear pair replaced by an ideal gear,
!>      without output (energy tracking on / off) and with HDF5 output (every
!>      step / every 10th step);
!>   2. uniform serial chains of 10, 100 and 1000 nodes without output.
!>
!> Decks are built as strings, parsed and built outside the timed region; the
!> timed region is one call to `simulate` (sink open/close included). Each
!> figure is the fastest of `n_rep` runs; the run length is calibrated so that
!> every timed run takes at least `min_wall` seconds. See docs/benchmarks.md.
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
   implicit none

   !> Every timed run lasts at least this long (s of wall time) ...
   real(wp), parameter :: min_wall = 0.5_wp
   !> ... the calibration aims at this much, to stay above min_wall despite noise.
   real(wp), parameter :: target_wall = 0.6_wp
   !> Pilot runs grow until they take this long; the run length is extrapolated from them.
   real(wp), parameter :: pilot_wall = 0.05_wp
   !> Repetitions per figure (the minimum is reported).
   integer, parameter :: n_rep = 3

   integer, parameter :: rig = 1, chain = 2

   !> One benchmark configuration.
   type :: config_t
      character(len=:), allocatable :: label
      integer :: kind = rig
      integer :: n_nodes = 4
      logical :: track_energy = .true.
      logical :: hdf5 = .false.
      real(wp) :: output_interval = 0.0_wp
      real(wp) :: dt = 0.0_wp
   end type config_t

   !> What a measurement found (best of n_rep).
   type :: timing_t
      integer(i8) :: steps = 0
      real(wp) :: best = huge(1.0_wp)     !< s, fastest repetition
      real(wp) :: worst = 0.0_wp          !< s, slowest repetition
      real(wp) :: t_end = 0.0_wp          !< simulated time of each run
      integer(i8) :: file_bytes = -1      !< size of the HDF5 file (HDF5 cases)
   end type timing_t

   character(len=:), allocatable :: h5_path
   type(config_t) :: cfg(4), ccfg
   type(timing_t) :: tm(4), tc(2, 3)
   integer(int64) :: c_start, c_stop, c_rate
   integer :: i, j, sizes(3)
   real(wp) :: ns(2, 3)
   character(len=*), parameter :: hrule = repeat('-', 96)

   call system_clock(c_start, c_rate)
   h5_path = temp_h5_path()

   write (output_unit, '(a)') 'trainsim RK4 throughput benchmark (bench/bench_rk4_throughput.f90)'
   write (output_unit, '(a)') '  trainsim version : '//version_string
   write (output_unit, '(a)') '  build type       : '//build_type
   write (output_unit, '(a)') '  compiler         : '//compiler_version()
   write (output_unit, '(a)') '  compiler options : '//compiler_options()
   write (output_unit, '(a,i0,a,f4.2,a)') '  method           : best of ', n_rep, &
      ' timed calls of simulate(), each >= ', min_wall, ' s wall (system_clock, int64)'
   write (output_unit, '(a)') '  HDF5 temp file   : '//h5_path
   write (output_unit, '(a)') ''

   ! ------------------------------------------------------------------ 1. the rig
   cfg(1) = config_t('(a) no output, energy tracking on ', rig, 4, .true., .false., 0.0_wp, 8.0e-6_wp)
   cfg(2) = config_t('(b) no output, energy tracking off', rig, 4, .false., .false., 0.0_wp, 8.0e-6_wp)
   cfg(3) = config_t('(c) HDF5 every step               ', rig, 4, .true., .true., 0.0_wp, 8.0e-6_wp)
   cfg(4) = config_t('(d) HDF5 every 10th step          ', rig, 4, .true., .true., 8.0e-5_wp, 8.0e-6_wp)

   write (output_unit, '(a)') '1. Table 5.5 rig, gear pair -> ideal gear (4 nodes, 3 elements), rk4, dt = 8e-6 s'
   write (output_unit, '(a)') hrule
   write (output_unit, '(a)') 'case                                   sim.time[s]      steps   best[s]'// &
      '     steps/s   ns/step   vs (a)'
   write (output_unit, '(a)') hrule
   do i = 1, size(cfg)
      call measure(cfg(i), tm(i))
      write (output_unit, '(a36,f14.4,i11,f10.3,es12.4,f10.1,a9)') cfg(i)%label, tm(i)%t_end, tm(i)%steps, &
         tm(i)%best, real(tm(i)%steps, wp)/tm(i)%best, ns_per_step(tm(i)), &
         pct(ns_per_step(tm(i)), ns_per_step(tm(1)))
      flush (output_unit)
   end do
   write (output_unit, '(a)') hrule
   write (output_unit, '(a)') '  energy tracking overhead, (a) vs (b): '// &
      trim(adjustl(pct(ns_per_step(tm(1)), ns_per_step(tm(2)))))
   do i = 3, 4
      write (output_unit, '(a,f8.1,a,f6.1,a,f7.2,a)') '  '//cfg(i)%label(1:3)//' HDF5 file: ', &
         real(tm(i)%file_bytes, wp)/1.0e6_wp, ' MB, ', &
         real(tm(i)%file_bytes, wp)/real(max(samples_of(cfg(i), tm(i)), 1_i8), wp), &
         ' bytes/sample; cost over (a): ', &
         (ns_per_step(tm(i)) - ns_per_step(tm(1)))*real(tm(i)%steps, wp)/ &
         real(max(samples_of(cfg(i), tm(i)), 1_i8), wp)/1.0e3_wp, ' us per sample written'
   end do
   write (output_unit, '(a)') ''

   ! ------------------------------------------------------------------ 2. chains
   sizes = [10, 100, 1000]
   write (output_unit, '(a)') '2. Uniform serial chain: J = 1, shafts k = 1e4, no output, rk4, dt = 5e-3 s'
   write (output_unit, '(a)') hrule
   write (output_unit, '(a)') ' nodes  energy   sim.time[s]      steps   best[s]     steps/s     ns/step'// &
      '  ns/step/node'
   write (output_unit, '(a)') hrule
   do j = 1, size(sizes)
      do i = 1, 2
         ccfg = config_t('chain', chain, sizes(j), i == 2, .false., 0.0_wp, 5.0e-3_wp)
         call measure(ccfg, tc(i, j))
         ns(i, j) = ns_per_step(tc(i, j))
         write (output_unit, '(i6,a8,f14.1,i11,f10.3,es12.4,f12.1,f14.2)') sizes(j), &
            merge('    on', '   off', i == 2), tc(i, j)%t_end, tc(i, j)%steps, tc(i, j)%best, &
            real(tc(i, j)%steps, wp)/tc(i, j)%best, ns(i, j), ns(i, j)/real(sizes(j), wp)
         flush (output_unit)
      end do
   end do
   write (output_unit, '(a)') hrule
   write (output_unit, '(a)') '  energy tracking overhead (on vs off):'
   do j = 1, size(sizes)
      write (output_unit, '(a,i5,a,a)') '    ', sizes(j), ' nodes: ', trim(adjustl(pct(ns(2, j), ns(1, j))))
   end do
   write (output_unit, '(a)') '  scaling, ns/step ratio (energy off):'
   write (output_unit, '(a,f6.2,a,f6.2,a)') '    100/10 nodes: ', ns(1, 2)/ns(1, 1), &
      ' (ideal 10),  1000/100 nodes: ', ns(1, 3)/ns(1, 2), ' (ideal 10)'

   call system_clock(c_stop)
   write (output_unit, '(a)') ''
   write (output_unit, '(a,f6.1,a)') 'total benchmark wall time: ', real(c_stop - c_start, wp)/real(c_rate, wp), ' s'

contains

   !> Calibrate the run length of `c`, then time it n_rep times; keep the fastest.
   subroutine measure(c, r)
      type(config_t), intent(in) :: c
      type(timing_t), intent(out) :: r
      integer(i8) :: nsteps, steps, bytes
      real(wp) :: secs
      integer :: rep, attempt

      ! Pilot: grow the run until it is long enough to extrapolate from.
      nsteps = 256
      do
         call run_once(c, nsteps, secs, steps, bytes)
         if (secs >= pilot_wall) exit
         nsteps = nsteps*min(100_i8, max(2_i8, int(pilot_wall/max(secs, 1.0e-6_wp), i8)))
      end do
      nsteps = max(1_i8, ceiling(real(nsteps, wp)*target_wall/secs, i8))

      do attempt = 1, 4
         r = timing_t()
         do rep = 1, n_rep
            call run_once(c, nsteps, secs, steps, bytes)
            r%best = min(r%best, secs)
            r%worst = max(r%worst, secs)
         end do
         r%steps = steps
         r%file_bytes = bytes
         r%t_end = real(nsteps, wp)*c%dt
         if (r%best >= min_wall) exit
         ! machine got faster (other load went away): lengthen the run and repeat
         nsteps = ceiling(real(nsteps, wp)*target_wall/r%best, i8)
      end do
   end subroutine measure

   !> Build the model for `c` with `nsteps` steps and time one call of simulate.
   subroutine run_once(c, nsteps, secs, steps, bytes)
      type(config_t), intent(in) :: c
      integer(i8), intent(in) :: nsteps
      real(wp), intent(out) :: secs
      integer(i8), intent(out) :: steps, bytes
      character(len=:), allocatable :: text
      type(deck_t) :: deck
      type(model_t) :: model
      type(run_result_t) :: res
      type(error_t), allocatable :: err
      type(null_sink_t) :: none
      type(hdf5_sink_t) :: h5
      integer(int64) :: c0, c1, rate
      real(wp) :: t_end

      t_end = real(nsteps, wp)*c%dt
      select case (c%kind)
      case (rig)
         text = rig_deck(t_end, c%dt, c%track_energy, c%hdf5, c%output_interval)
      case default
         text = chain_deck(c%n_nodes, t_end, c%dt, c%track_energy)
      end select
      call parse_deck(text, 'bench:'//c%label, deck, err)
      if (allocated(err)) call die(err%message)
      call build_model(deck, model, err)
      if (allocated(err)) call die(err%message)

      bytes = -1
      if (c%hdf5) then
         call remove_file(h5_path)
         h5%path = model%run%output
         call system_clock(c0, rate)
         call simulate(model, h5, res, err)
         call system_clock(c1)
         if (allocated(err)) call die(err%message)
         inquire (file=h5_path, size=bytes)
         call remove_file(h5_path)
      else
         call system_clock(c0, rate)
         call simulate(model, none, res, err)
         call system_clock(c1)
         if (allocated(err)) call die(err%message)
      end if
      secs = real(c1 - c0, wp)/real(rate, wp)
      steps = res%stats%steps
      if (steps /= nsteps) call die('run of '//c%label//' took an unexpected number of steps')
   end subroutine run_once

   !> The Table 5.5 rig (Cook 1989) with its gear pair replaced by an ideal gear.
   function rig_deck(t_end, dt, track, hdf5, interval) result(text)
      real(wp), intent(in) :: t_end, dt, interval
      logical, intent(in) :: track, hdf5
      character(len=:), allocatable :: text
      character(len=*), parameter :: nl = new_line('a')
      text = "&run title = 'bench: Table 5.5 rig, ideal gear', t_end = "//r2s(t_end)//', dt = '//r2s(dt)// &
             ", integrator = 'rk4', track_energy = "//merge('.true. ', '.false.', track)
      if (hdf5) text = text//", output = '"//h5_path//"', output_interval = "//r2s(interval)
      text = text//' /'//nl// &
             "&node id = 'n1', type = 'inertia', inertia = 100.0 /"//nl// &
             "&node id = 'n2', type = 'inertia', inertia = 0.987 /"//nl// &
             "&node id = 'n3', type = 'inertia', inertia = 0.987 /"//nl// &
             "&node id = 'n4', type = 'inertia', inertia = 100.0 /"//nl// &
             "&element id = 'e1', type = 'shaft', stiffness = 32000.0 /"//nl// &
             "&element id = 'e2', type = 'ideal_gear', stiffness = 234500.0, rb_driver = 3.7588, "// &
             'rb_driven = 3.7588 /'//nl// &
             "&element id = 'e3', type = 'shaft', stiffness = 32000.0 /"//nl// &
             "&initial node = 'all', speed = 80.0 /"//nl// &
             "&initial node = 'n1', angle = -0.187847 /"//nl// &
             "&initial node = 'n2', angle = -0.212810 /"//nl// &
             "&initial node = 'n3', angle = -0.214283 /"//nl// &
             "&initial node = 'n4', angle = -0.239246 /"//nl// &
             "&load node = 'n1', quantity = 'speed', kind = 'constant', value = 80.0 /"//nl// &
             "&load node = 'n4', kind = 'constant', value = -798.8 /"
   end function rig_deck

   !> A uniform serial chain of n unit inertias joined by shafts of stiffness 1e4,
   !> free at both ends; node 1 starts at speed 1.
   function chain_deck(n, t_end, dt, track) result(text)
      integer, intent(in) :: n
      real(wp), intent(in) :: t_end, dt
      logical, intent(in) :: track
      character(len=:), allocatable :: text
      character(len=:), allocatable :: buf
      character(len=64) :: line
      integer :: i, k
      ! One buffer large enough for every line (the deck grows linearly with n).
      allocate (character(len=512 + 64*(2*n + 1)) :: buf)
      k = 0
      call append(buf, k, "&run title = 'bench: serial chain', t_end = "//r2s(t_end)//', dt = '//r2s(dt)// &
                  ", integrator = 'rk4', track_energy = "//merge('.true. ', '.false.', track)//' /')
      do i = 1, n
         write (line, '(a,i0,a)') "&node id = 'n", i, "', type = 'inertia', inertia = 1.0 /"
         call append(buf, k, trim(line))
      end do
      do i = 1, n - 1
         write (line, '(a,i0,a)') "&element id = 'e", i, "', type = 'shaft', stiffness = 1.0e4 /"
         call append(buf, k, trim(line))
      end do
      call append(buf, k, "&initial node = 'n1', speed = 1.0 /")
      text = buf(1:k - 1)   ! without the last new line
   end function chain_deck

   !> Append line `s` and a new line to buf(1:k).
   subroutine append(buf, k, s)
      character(len=*), intent(inout) :: buf
      integer, intent(inout) :: k
      character(len=*), intent(in) :: s
      buf(k + 1:k + len(s) + 1) = s//new_line('a')
      k = k + len(s) + 1
   end subroutine append

   !> Output samples written in an HDF5 case (initial sample + one per interval).
   integer(i8) function samples_of(c, r) result(n)
      type(config_t), intent(in) :: c
      type(timing_t), intent(in) :: r
      if (c%output_interval > 0.0_wp) then
         n = 1 + nint(r%t_end/c%output_interval, i8)
      else
         n = 1 + r%steps
      end if
   end function samples_of

   real(wp) function ns_per_step(r)
      type(timing_t), intent(in) :: r
      ns_per_step = 1.0e9_wp*r%best/real(max(r%steps, 1_i8), wp)
   end function ns_per_step

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
      call remove_file(h5_path//'.part')
      error stop 1
   end subroutine die
end program bench_rk4_throughput
