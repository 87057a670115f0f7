!> Every output sample is the solution at its own time, under every integrator
!> of the registry (a row added later is tested without editing this suite).
!> Before D-49 the SUNDIALS integrators (ONE_STEP mode) returned a root that
!> lay beyond the output time in the same internal step, and the driver took
!> the state at the root as the sample: on tests/decks/sample_before_event.nml
!> 3-7 of 501 samples of node a were off its closed form by up to 1.2e-2, and
!> on the Table 7.1 train under cvode-bdf 25 of 801 samples by up to 1.7e-3 rad.
!> - sample_before_event: node a is a damped oscillator alone on its shaft,
!>   a(t) = exp(-5 t) (cos(wd t) + (5/wd) sin(wd t)), wd = sqrt(1e4 - 25); node
!>   b beside it hits a clearance. Every sample of a within 1e-6 of a(t), each
!>   method at settings where its own error is well below that (measured: rk4
!>   at dt 1e-4 6e-10, the adaptive ones at rtol 1e-10 below 1e-8).
!> - the Table 7.1 train (two backlash meshes in series, 0.02 s, 801 samples):
!>   every node angle of every sample within 1e-6 rad of RK4 at dt 1.25e-7
!>   (RK4 at dt 2.5e-7 agrees with it to 1e-14 rad, at dt 2.5e-6 to 7e-13).
!> A first-order method (euler) cannot reach 1e-6 in a sane number of steps
!> (3.7e-4 at dt 1e-6 on the oscillator): its samples are checked through the
!> Richardson extrapolation 2 y(h/2) - y(h) of two runs, whose error is O(h^2);
!> a sample holding a later state would not extrapolate away.
program test_samples_at_own_time
   use trainsim_kinds, only: wp
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_integrator_registry, only: integrator_entry_t, integrator_registry
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, run_model
   implicit none

   character(len=*), parameter :: oscillator_deck = 'tests/decks/sample_before_event.nml'
   character(len=*), parameter :: train_deck = 'inputs/two_clearance.nml'
   type(integrator_entry_t), allocatable :: rows(:)
   real(wp), allocatable :: t_ref(:), theta_ref(:, :)
   integer :: i

   call suite_begin('every output sample is the solution at its own time (every registry row)')
   allocate (rows, source=integrator_registry())   ! not `rows = ...`: gfortran 12 false -Wuninitialized
   call reference_train(t_ref, theta_ref)
   do i = 1, size(rows)
      call test_oscillator(rows(i))
      call test_two_clearance_train(rows(i))
   end do
   call suite_end()

contains

   !> Run `deck` under the method of `row` at settings for which its error is
   !> far below 1e-6 (fixed step: dt; adaptive: rtol 1e-10); the samples
   !> (times, node angles); euler: the Richardson extrapolation at dt and dt/2.
   subroutine samples(deck, row, dt_fixed, t_end, t, theta, n_events)
      character(len=*), intent(in) :: deck
      type(integrator_entry_t), intent(in) :: row
      real(wp), intent(in) :: dt_fixed, t_end
      real(wp), allocatable, intent(out) :: t(:), theta(:, :)
      integer, intent(out) :: n_events
      real(wp), allocatable :: t2(:), theta2(:, :)
      integer :: n2
      call one_run(deck, row, dt_fixed, t_end, t, theta, n_events)
      if (row%fixed_step .and. row%order < 2) then
         call one_run(deck, row, 0.5_wp*dt_fixed, t_end, t2, theta2, n2)
         if (size(t2) /= size(t)) error stop 'test: the two euler runs have different output grids'
         theta = 2.0_wp*theta2 - theta
      end if
   end subroutine samples

   !> One run of `deck` under `row`'s method to t_end on the deck's output grid.
   subroutine one_run(deck, row, dt, t_end, tt, th, nev)
      character(len=*), intent(in) :: deck
      type(integrator_entry_t), intent(in) :: row
      real(wp), intent(in) :: dt, t_end
      real(wp), allocatable, intent(out) :: tt(:), th(:, :)
      integer, intent(out) :: nev
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: dout
      call load_model(deck, m)
      dout = m%run%output_interval
      if (.not. dout > 0.0_wp) dout = m%run%dt
      m%run%integrator = row%name
      m%run%t_end = t_end
      m%run%output_interval = dout          ! the deck's output grid for every method
      if (row%fixed_step) then
         m%run%dt = dt
      else
         m%run%rtol = 1.0e-10_wp
         m%run%atol_angle = 1.0e-14_wp
         m%run%atol_speed = 1.0e-12_wp
      end if
      call run_model(m, r)
      tt = r%series_t
      th = r%series_theta
      nev = size(r%events)
   end subroutine one_run

   !> dt of a fixed-step method of this order for the oscillator deck (adaptive: unused).
   pure real(wp) function dt_for(row, dt4, dt1) result(dt)
      type(integrator_entry_t), intent(in) :: row
      real(wp), intent(in) :: dt4, dt1
      dt = dt4
      if (row%order < 2) dt = dt1
   end function dt_for

   subroutine test_oscillator(row)
      type(integrator_entry_t), intent(in) :: row
      real(wp), allocatable :: t(:), theta(:, :)
      real(wp) :: wd, worst, e, a_exact
      integer :: k, ia, n_events, n_off, k_worst
      type(model_t) :: m
      call test_begin(row%name//': sample_before_event, every sample of node a as the closed form')
      call load_model(oscillator_deck, m)
      ia = m%node_index('a')
      ! rk4 at dt 1e-4 (error 6e-10); euler at 1e-6 and 5e-7 extrapolated
      call samples(oscillator_deck, row, dt_for(row, 1.0e-4_wp, 1.0e-6_wp), 0.5_wp, t, theta, n_events)
      call check(row%name//': 501 samples', size(t) == 501)
      ! the clearance of b must close during the run, or nothing here is tested
      call check(row%name//': node b hits its clearance (events: '//str(n_events)//')', n_events >= 2)
      wd = sqrt(1.0e4_wp - 25.0_wp)
      worst = 0.0_wp
      k_worst = 1
      n_off = 0
      do k = 1, size(t)
         a_exact = exp(-5.0_wp*t(k))*(cos(wd*t(k)) + (5.0_wp/wd)*sin(wd*t(k)))
         e = abs(theta(ia, k) - a_exact)
         if (e > 1.0e-6_wp) n_off = n_off + 1
         if (e > worst) then
            worst = e
            k_worst = k
         end if
      end do
      call check(row%name//': samples of a off the closed form by more than 1e-6 ('//str(n_off)//')', n_off == 0)
      call check(row%name//': largest |a - a(t)| (at t = '//str(t(k_worst))//' s)', worst, 0.0_wp, abs_tol=1.0e-6_wp)
   end subroutine test_oscillator

   !> RK4 at dt 1.25e-7 on the Table 7.1 train (0.02 s: 25 mesh periods).
   subroutine reference_train(t, theta)
      real(wp), allocatable, intent(out) :: t(:), theta(:, :)
      type(integrator_entry_t) :: rk4
      integer :: n_events
      rk4 = integrator_entry_t('rk4', '', 4, .true., .true., null())
      call samples(train_deck, rk4, 1.25e-7_wp, 0.02_wp, t, theta, n_events)
   end subroutine reference_train

   subroutine test_two_clearance_train(row)
      type(integrator_entry_t), intent(in) :: row
      real(wp), allocatable :: t(:), theta(:, :)
      real(wp) :: worst, dt
      integer :: k, n_off, n_events, k_worst
      call test_begin(row%name//': Table 7.1 train, every sample as RK4 at dt 1.25e-7')
      ! rk4: dt 2.5e-6 (7e-13 rad off the reference); rk4-thesis, whose contact
      ! modes are frozen per step (first order at an event): 2.5e-7 (1.8e-7 rad);
      ! euler: 1e-7 and 5e-8 extrapolated
      dt = dt_for(row, 2.5e-6_wp, 1.0e-7_wp)
      if (row%fixed_step .and. .not. row%locates_events) dt = 2.5e-7_wp
      call samples(train_deck, row, dt, 0.02_wp, t, theta, n_events)
      call check(row%name//': the reference''s output times', size(t) == size(t_ref))
      if (size(t) /= size(t_ref)) return
      call check(row%name//': the same times', all(abs(t - t_ref) <= 1.0e-12_wp))
      call check(row%name//': the meshes open and close (events: '//str(n_events)//')', n_events >= 4)
      n_off = 0
      worst = 0.0_wp
      k_worst = 1
      do k = 1, size(t)
         if (maxval(abs(theta(:, k) - theta_ref(:, k))) > 1.0e-6_wp) n_off = n_off + 1
         if (maxval(abs(theta(:, k) - theta_ref(:, k))) > worst) then
            worst = maxval(abs(theta(:, k) - theta_ref(:, k)))
            k_worst = k
         end if
      end do
      call check(row%name//': samples with a node angle off by more than 1e-6 rad ('//str(n_off)//')', n_off == 0)
      call check(row%name//': largest node angle difference (rad, at t = '//str(t(k_worst))//' s)', worst, 0.0_wp, &
                 abs_tol=1.0e-6_wp)
   end subroutine test_two_clearance_train
end program test_samples_at_own_time
