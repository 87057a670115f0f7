!> Work-precision study of the integrators (issue 4): for each case and each
!> integrator setting, the error of the figures engineers read (peak-to-peak
!> transmission error, the first ten impact times, the peak shaft torque)
!> against a tight reference, versus RHS evaluations and wall time.
!> Writes CSV to stdout (and a summary to stderr); docs/plot_work_precision.py
!> draws docs/work_precision.png from it.
program bench_work_precision
   use, intrinsic :: iso_fortran_env, only: error_unit, int64
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_deck, only: deck_t, read_deck
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_simulate, only: simulate
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t, ev_contact_front, ev_contact_rear
   implicit none

   type :: figures_t
      real(wp) :: p2p = 0.0_wp, torque = 0.0_wp
      real(wp) :: impacts(10) = 0.0_wp
      integer :: n_impacts = 0
      integer(int64) :: rhs = 0
      real(wp) :: wall = 0.0_wp
      logical :: ok = .false.
   end type figures_t

   character(len=*), parameter :: ghm = 'inputs/gregory_harris_munro.nml'
   character(len=*), parameter :: duty = 'inputs/start_stop_two_clearances.nml'
   real(wp), parameter :: dts(5) = [3.2e-5_wp, 1.6e-5_wp, 8.0e-6_wp, 4.0e-6_wp, 2.0e-6_wp]
   real(wp), parameter :: rtols(6) = [1.0e-4_wp, 1.0e-5_wp, 1.0e-6_wp, 1.0e-7_wp, 1.0e-8_wp, 1.0e-9_wp]

   write (*, '(a)') 'case,integrator,setting,rhs_evals,wall_s,err_p2p,err_impact_times,err_peak_torque,n_impacts'
   call study('ghm_285', ghm, 2.0_wp*3.141592653589793_wp*285.0_wp/32.0_wp, 'mesh', 'shaft3', 8.0e-6_wp)
   call study('ghm_485', ghm, 2.0_wp*3.141592653589793_wp*485.0_wp/32.0_wp, 'mesh', 'shaft3', 8.0e-6_wp)
   call study('start_stop', duty, 0.0_wp, 'mesh', 'output_shaft', 1.0e-4_wp)

contains

   !> Load a deck; a positive `speed` replaces every initial and prescribed speed.
   subroutine load(path, speed, m)
      character(len=*), intent(in) :: path
      real(wp), intent(in) :: speed
      type(model_t), intent(out) :: m
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      integer :: i
      call read_deck(path, deck, err)
      if (.not. allocated(err)) call build_model(deck, m, err)
      if (allocated(err)) then
         write (error_unit, '(a)') err%message
         error stop 2
      end if
      m%run%output = ''
      m%run%track_energy = .false.
      if (speed > 0.0_wp) then
         do i = 1, size(m%nodes)
            m%nodes(i)%n%omega0 = speed
         end do
         do i = 1, size(m%speeds)
            m%speeds(i)%f%value0 = speed
         end do
      end if
   end subroutine load

   function run(m0, integrator, dt, rtol, mesh, shaft) result(f)
      type(model_t), intent(in) :: m0
      character(len=*), intent(in) :: integrator, mesh, shaft
      real(wp), intent(in) :: dt, rtol
      type(figures_t) :: f
      type(model_t) :: m
      type(run_result_t) :: r
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      integer :: i, im, is
      m = m0
      m%run%integrator = integrator
      if (dt > 0.0_wp) m%run%dt = dt
      if (rtol > 0.0_wp) then
         m%run%rtol = rtol
         m%run%atol_angle = rtol*1.0e-3_wp
         m%run%atol_speed = rtol*1.0e-1_wp
      end if
      call m%finalize()
      m%run%keep_events = .true.   ! the impact times are read from the table
      call simulate(m, none, r, err)
      if (allocated(err)) then
         write (error_unit, '(a)') '  skipped '//integrator//': '//err%message
         return
      end if
      im = 0; is = 0
      do i = 1, size(m%elements)
         if (m%elements(i)%e%id == mesh) im = i
         if (m%elements(i)%e%id == shaft) is = i
      end do
      f%p2p = r%el(im)%p2p_range
      f%torque = max(abs(r%el(is)%torque_max), abs(r%el(is)%torque_min))
      do i = 1, size(r%events)
         if (r%events(i)%element /= im) cycle
         if (r%events(i)%kind /= ev_contact_front .and. r%events(i)%kind /= ev_contact_rear) cycle
         if (f%n_impacts == 10) exit
         f%n_impacts = f%n_impacts + 1
         f%impacts(f%n_impacts) = r%events(i)%t
      end do
      f%rhs = r%stats%rhs_evals
      f%wall = r%stats%wall_time
      f%ok = .true.
   end function run

   subroutine report(name, integrator, setting, f, ref)
      character(len=*), intent(in) :: name, integrator
      real(wp), intent(in) :: setting
      type(figures_t), intent(in) :: f, ref
      real(wp) :: e_imp
      integer :: n
      if (.not. f%ok) return
      n = min(f%n_impacts, ref%n_impacts)
      e_imp = -1.0_wp                          ! no impacts to compare
      if (n > 0) e_imp = maxval(abs(f%impacts(1:n) - ref%impacts(1:n))/ref%impacts(1:n))
      if (f%n_impacts /= ref%n_impacts .and. ref%n_impacts > 0) e_imp = 1.0_wp   ! missed or extra impacts
      write (*, '(a,",",a,",",es10.3,",",i0,",",es10.3,3(",",es10.3),",",i0)') name, integrator, setting, f%rhs, &
         f%wall, abs(f%p2p - ref%p2p)/ref%p2p, e_imp, abs(f%torque - ref%torque)/ref%torque, f%n_impacts
   end subroutine report

   subroutine study(name, path, speed, mesh, shaft, out_dt)
      character(len=*), intent(in) :: name, path, mesh, shaft
      real(wp), intent(in) :: speed, out_dt
      type(model_t) :: m0
      type(figures_t) :: ref, f
      integer :: i
      call load(path, speed, m0)
      m0%run%output_interval = out_dt
      write (error_unit, '(a)') 'case '//name//': reference = event-located RK4 at dt = 5e-7 s'
      ref = run(m0, 'rk4', 5.0e-7_wp, 0.0_wp, mesh, shaft)
      write (error_unit, '(a,i0,a,es10.3,a,es12.5,a,es12.5)') '  reference: ', ref%n_impacts, ' impacts; wall ', &
         ref%wall, ' s; p2p ', ref%p2p, '; peak torque ', ref%torque
      f = run(m0, 'rk4-thesis', 8.0e-6_wp, 0.0_wp, mesh, shaft)
      call report(name, 'rk4-thesis', 8.0e-6_wp, f, ref)
      f = run(m0, 'rk4-thesis', 2.0e-6_wp, 0.0_wp, mesh, shaft)
      call report(name, 'rk4-thesis', 2.0e-6_wp, f, ref)
      do i = 1, size(dts)
         f = run(m0, 'rk4', dts(i), 0.0_wp, mesh, shaft)
         call report(name, 'rk4', dts(i), f, ref)
      end do
      do i = 1, size(rtols)
         f = run(m0, 'cvode-bdf', 0.0_wp, rtols(i), mesh, shaft)
         call report(name, 'cvode-bdf', rtols(i), f, ref)
         f = run(m0, 'cvode-adams', 0.0_wp, rtols(i), mesh, shaft)
         call report(name, 'cvode-adams', rtols(i), f, ref)
         f = run(m0, 'arkode-dp', 0.0_wp, rtols(i), mesh, shaft)
         call report(name, 'arkode-dp', rtols(i), f, ref)
         f = run(m0, 'arkode-verner', 0.0_wp, rtols(i), mesh, shaft)
         call report(name, 'arkode-verner', rtols(i), f, ref)
      end do
   end subroutine study
end program bench_work_precision
