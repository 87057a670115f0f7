!> Conformance of every integrator in the registry (a row added later is
!> tested without editing this suite), on small trains with known answers:
!> - order: a fixed-step method's error falls by 2^order per halving of dt on
!>   an undamped two-disk oscillator (closed-form solution); an adaptive one
!>   meets its tolerance there;
!> - events: the first contact of a clearance in free flight is at gap/speed
!>   exactly (linear motion), located to the event tolerance by every method
!>   that locates events, and within one step by one that does not;
!> - output grid: every output time t_start + k*output_interval appears
!>   exactly, the last at t_end, through a load step off the grid;
!> - energy: the balance residual over a run with a load step converges at the
!>   method's order (fixed step) or stays at the tolerance (adaptive);
!> - no dropped events: 70 clearances closing at one instant give 70 events.
program test_integrator_conformance
   use trainsim_kinds, only: wp
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_event, only: ev_contact_front
   use trainsim_integrator_registry, only: integrator_entry_t, integrator_registry
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, run_model, nl
   implicit none

   type(integrator_entry_t), allocatable :: rows(:)
   integer :: i

   call suite_begin('integrator conformance (every registry row)')
   allocate (rows, source=integrator_registry())   ! not `rows = ...`: gfortran 12 false -Wuninitialized
   do i = 1, size(rows)
      call test_order(rows(i))
      call test_free_flight_contact(rows(i))
      call test_uniform_output_grid(rows(i))
      call test_energy_balance(rows(i))
   end do
   call test_no_event_is_dropped()
   call suite_end()

contains

   !> Two unit disks on a shaft of stiffness k, disk a started at 1 rad/s.
   function oscillator(name, dt, extra) result(text)
      character(len=*), intent(in) :: name, extra
      real(wp), intent(in) :: dt
      character(len=:), allocatable :: text
      text = "&run t_end = 0.1, dt = "//str(dt)//", integrator = '"//name//"', rtol = 1e-10, "// &
             "atol_angle = 1e-12, atol_speed = 1e-10, track_energy = .false."//extra//" /"//nl// &
             "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl// &
             "&node id = 'b', type = 'inertia', inertia = 1.0 /"//nl// &
             "&element id = 's', type = 'shaft', stiffness = 1.0e4 /"//nl// &
             "&initial node = 'a', speed = 1.0 /"//nl
   end function oscillator

   !> Error of disk a at t_end in angle and speed (the speed scaled by 1/w, so
   !> that a phase error does not vanish at a zero of either):
   !> theta_a = t/2 + sin(w t)/(2 w), omega_a = (1 + cos(w t))/2, w = sqrt(2 k / J).
   real(wp) function oscillator_error(name, dt) result(e)
      character(len=*), intent(in) :: name
      real(wp), intent(in) :: dt
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: w
      call load_model_text(oscillator(name, dt, ''), m)
      call run_model(m, r)
      w = sqrt(2.0e4_wp)
      associate (o => m%nodes(1)%n%offset)
         e = hypot(r%y_final(o + 1) - (0.05_wp + sin(0.1_wp*w)/(2.0_wp*w)), &
                   (r%y_final(o + 2) - 0.5_wp*(1.0_wp + cos(0.1_wp*w)))/w)
      end associate
   end function oscillator_error

   subroutine test_order(row)
      type(integrator_entry_t), intent(in) :: row
      real(wp) :: e1, e2, p
      call test_begin(row%name//': order of accuracy')
      if (row%fixed_step) then
         ! w dt = 0.028 and 0.014: in the asymptotic range of every method here
         ! (Euler's amplitude error there is n (w dt)^2 / 2 = 0.2 and 0.1)
         e1 = oscillator_error(row%name, 2.0e-4_wp)
         e2 = oscillator_error(row%name, 1.0e-4_wp)
         p = log(e1/e2)/log(2.0_wp)
         call check(row%name//': observed order '//str(p, 4)//' within 0.3 of the nominal '//str(row%order), &
                    abs(p - real(row%order, wp)) < 0.3_wp)
      else
         ! an adaptive method at rtol = 1e-10: global error within 1e3 rtol of the scale (0.05 rad)
         e1 = oscillator_error(row%name, 1.0e-3_wp)
         call check(row%name//': error '//str(e1)//' within 1e-7*0.05 rad', e1 < 5.0e-9_wp)
      end if
   end subroutine test_order

   !> Disk a at 2 rad/s, disk b at rest, a coupling with clearance 0.01 rad:
   !> in free flight delta = 2 t, contact at delta = b = 0.005, t = 2.5e-3 s.
   subroutine test_free_flight_contact(row)
      type(integrator_entry_t), intent(in) :: row
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: dt, tol
      call test_begin(row%name//': free-flight contact time')
      dt = 1.0e-4_wp
      call load_model_text("&run t_end = 0.004, dt = "//str(dt)//", integrator = '"//row%name//"', rtol = 1e-10 /"//nl// &
                           "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl// &
                           "&node id = 'b', type = 'inertia', inertia = 1.0 /"//nl// &
                           "&element id = 'c', type = 'clearance_coupling', clearance = 0.01, stiffness = 1.0e4, "// &
                           "contact_damping = 1.0 /"//nl// &
                           "&initial node = 'a', speed = 2.0 /"//nl, m)
      call run_model(m, r)
      call check(row%name//': a contact event', size(r%events) >= 1)
      if (size(r%events) < 1) return
      if (row%locates_events) then
         ! the located time: to the event tolerance (1e-9 dt) for fixed steps,
         ! to SUNDIALS's root tolerance (a few ulps of t, scaled by h) otherwise
         tol = 1.0e-9_wp*dt
         if (.not. row%fixed_step) tol = 1.0e-9_wp
      else
         tol = dt   ! detected at the start of the next step
      end if
      call check(row%name//': first event is a front contact', r%events(1)%kind == ev_contact_front)
      call check(row%name//': at gap/speed = 2.5e-3 s', r%events(1)%t, 2.5e-3_wp, abs_tol=tol)
      if (row%locates_events) call check(row%name//': approach velocity 2 rad/s (times the unit radius)', &
                                         r%events(1)%approach_velocity, 2.0_wp, rel_tol=1.0e-6_wp)
   end subroutine test_free_flight_contact

   !> Output every 3 dt with a load step at 0.01234 s (off both grids).
   subroutine test_uniform_output_grid(row)
      type(integrator_entry_t), intent(in) :: row
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: k, n, missing
      real(wp) :: dout
      call test_begin(row%name//': uniform output grid')
      call load_model_text(oscillator(row%name, 1.0e-4_wp, ', output_interval = 3.0e-4')// &
                           "&load node = 'b', kind = 'step', value0 = 0.0, value1 = 5.0, t_step = 0.01234 /"//nl, m)
      call run_model(m, r)
      dout = 3.0e-4_wp
      n = ceiling(0.1_wp/dout - 1.0e-6_wp)
      missing = 0
      do k = 0, n - 1
         if (.not. any(r%series_t == real(k, wp)*dout)) missing = missing + 1
      end do
      call check(row%name//': every t_start + k*output_interval is a sample time, exactly ('//str(missing)// &
                 ' missing of '//str(n)//')', missing == 0)
      call check(row%name//': the last sample is at t_end exactly', r%series_t(size(r%series_t)) == 0.1_wp)
   end subroutine test_uniform_output_grid

   !> Energy residual with a damped disk and a load step (a breakpoint).
   real(wp) function energy_residual(name, dt) result(res)
      character(len=*), intent(in) :: name
      real(wp), intent(in) :: dt
      type(model_t) :: m
      type(run_result_t) :: r
      call load_model_text("&run t_end = 0.05, dt = "//str(dt)//", integrator = '"//name//"', rtol = 1e-9 /"//nl// &
                           "&node id = 'a', type = 'inertia', inertia = 1.0, damping = 2.0 /"//nl// &
                           "&node id = 'b', type = 'inertia', inertia = 1.0 /"//nl// &
                           "&element id = 's', type = 'shaft', stiffness = 1.0e4 /"//nl// &
                           "&load node = 'a', kind = 'step', value0 = 0.0, value1 = 100.0, t_step = 0.01234 /"//nl// &
                           "&initial node = 'a', speed = 1.0 /"//nl, m)
      call run_model(m, r)
      res = r%energy_residual_max/r%energy_scale
   end function energy_residual

   subroutine test_energy_balance(row)
      type(integrator_entry_t), intent(in) :: row
      real(wp) :: e1, e2, expected
      call test_begin(row%name//': energy balance')
      if (row%fixed_step) then
         e1 = energy_residual(row%name, 1.0e-3_wp)
         e2 = energy_residual(row%name, 5.0e-4_wp)
         ! the residual is a global error: it falls by 2^order per halving (half of that at least)
         expected = 2.0_wp**row%order
         call check(row%name//': residual '//str(e1)//' -> '//str(e2)//' per halving of dt falls by >= 2^order/2', &
                    e1/e2 >= 0.5_wp*expected)
      else
         e1 = energy_residual(row%name, 1.0e-3_wp)
         call check(row%name//': residual '//str(e1)//' of the energy scale at rtol 1e-9 below 1e-6', e1 < 1.0e-6_wp)
      end if
   end subroutine test_energy_balance

   !> A hub driven at 1 rad/s, 70 leaves at rest, each on a coupling with the
   !> same clearance: all 70 close at one instant (the old fixed buffer held 64).
   subroutine test_no_event_is_dropped()
      type(model_t) :: m
      type(run_result_t) :: r
      character(len=:), allocatable :: text
      integer :: i, n_first
      call test_begin('seventy_simultaneous_contacts_are_all_recorded')
      text = "&run t_end = 0.006, dt = 1e-4 /"//nl//"&node id = 'hub', type = 'inertia', inertia = 100.0 /"//nl
      do i = 1, 70
         text = text//"&node id = 'n"//str(i)//"', type = 'inertia', inertia = 1.0 /"//nl// &
                "&element id = 'c"//str(i)//"', type = 'clearance_coupling', left = 'hub', right = 'n"//str(i)// &
                "', clearance = 0.01, stiffness = 1.0e3, contact_damping = 0.1 /"//nl
      end do
      text = text//"&initial node = 'hub', speed = 1.0 /"//nl
      call load_model_text(text, m)
      call run_model(m, r)
      n_first = count(abs(r%events%t - r%events(1)%t) <= 1.0e-12_wp .and. r%events%kind == ev_contact_front)
      call check('70 contacts at the first event instant (got '//str(n_first)//')', n_first == 70)
      call check('first contact at gap/speed = 5e-3 s', r%events(1)%t, 5.0e-3_wp, abs_tol=1.0e-12_wp)
   end subroutine test_no_event_is_dropped
end program test_integrator_conformance
