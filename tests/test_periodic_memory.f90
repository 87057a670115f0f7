!> Element memory in the period map (issue 27, D-150): the yang_sun law's damping
!> D is fixed by the impact that closed a contact and kept while it lasts, state
!> outside y. A contact that never opens keeps the D of its transient's last
!> impact, so a contact-keeping periodic orbit is one of a family (one per D) and
!> the period map takes D as a parameter from the start state.
!>
!> 1. The accessors: a memory held on a clearance is what a contact found closed
!>    when the modes are chosen begins with (not the law's start, D = 0, D-13);
!>    an open one takes its own at its impact.
!> 2. The Fig. 5.11 sweep's runs (inputs/sweep_ghm_mesh_frequency.nml, shafts
!>    damped 500 lb in s/rad, the sweep's fixed start) at 395 and 405 teeth/s keep
!>    contact once settled (docs: verification/continuation/README.md, where the
!>    branch from the law's start was 2.9 % and 9.3 % off them in p2p). Shooting
!>    from a run's state with the run's memory finds an orbit on which the contact
!>    never opens and the memory repeats, and the run continued until the
!>    contraction bound |mu|^N r0 is below 1e-8 equals that orbit to 1e-6 of the
!>    state scale (measured 6.9e-9, 9.6e-9); the orbit from the same state with the
!>    law's start (D = 0, what the map took before D-150) is another, more than 100
!>    times that 1e-6 away (measured 2.1e-4, 4.9e-4): the memory matters, the check
!>    can fail.
!>
!> No closed form: the law's damping force D p pdot is not linear in the state,
!> so a contact-keeping orbit is not the linear oscillator's even with D fixed.
program test_periodic_memory
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_deck, only: deck_t, read_deck
   use trainsim_overrides, only: split_sweep_groups
   use trainsim_deck, only: deck_group_t
   use trainsim_session, only: session_t
   use trainsim_clearance_element, only: clearance_element_t
   use trainsim_period_map, only: period_map_t, forcing_period
   use trainsim_shooting, only: shoot_options_t, shoot_result_t, shoot, shoot_converged
   use trainsim_monodromy_map, only: monodromy_variational
   use trainsim_floquet, only: floquet_multipliers
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, nl, damped_rig_model
   implicit none

   type(deck_t) :: deck
   type(error_t), allocatable :: err
   type(deck_group_t), allocatable :: sweeps(:)

   call suite_begin('element memory in the period map (D-150)')
   call test_held_memory_is_taken_by_a_closed_contact()
   call read_deck('inputs/sweep_ghm_mesh_frequency.nml', deck, err)
   if (allocated(err)) error stop 'cannot read inputs/sweep_ghm_mesh_frequency.nml'
   call split_sweep_groups(deck, sweeps)   ! (a sweep run's deck: the &sweep groups are the sweep's)
   call test_contact_keeping_runs_equal_the_orbit_of_their_memory()
   call suite_end()

contains

   !> A disk pressed into a yang_sun clearance coupling at the start, and one released
   !> into it from inside the clearance.
   subroutine test_held_memory_is_taken_by_a_closed_contact()
      type(model_t) :: m
      real(wp), allocatable :: y(:)
      real(wp) :: mem(3), held(3)
      call test_begin('held_memory_is_taken_by_a_closed_contact')
      held = [123.0_wp, 0.5_wp, 2.0_wp]
      call load_model_text("&run t_end = 0.1, dt = 1.0e-4 /"//nl// &
                           "&node id = 'a', type = 'inertia', inertia = 1.0 /"//nl// &
                           "&node id = 'ground', type = 'fixed' /"//nl// &
                           "&element id = 'stop', type = 'clearance_coupling', left = 'a', right = 'ground', "// &
                           "clearance = 0.02, stiffness = 1e4, contact_law = 'yang_sun' /"//nl// &
                           "&initial node = 'a', angle = 0.011, speed = 0.5 /", m)
      call m%initial_state(y)
      select type (el => m%elements(1)%e)
      class is (clearance_element_t)
         call check('yang_sun: a memory of 3 (D, e, V_i)', el%memory_size() == 3)
         call m%init_modes(m%run%t_start, y)
         call el%get_memory(mem)
         call check('closed at the start, no memory held: the law''s start D = 0, e = 1', &
                    mem(1) == 0.0_wp .and. mem(2) == 1.0_wp)
         call el%set_memory(held)
         call m%init_modes(m%run%t_start, y)
         call el%get_memory(mem)
         call check('closed at the start with a memory held: it goes on with it', all(mem == held))
         y(1) = 0.0_wp   ! (inside the clearance: open)
         call m%init_modes(m%run%t_start, y)
         call check('open: no contact in progress', .not. el%in_contact())
      class default
         call check('the deck''s element is a clearance element', .false.)
      end select
   end subroutine test_held_memory_is_taken_by_a_closed_contact

   subroutine test_contact_keeping_runs_equal_the_orbit_of_their_memory()
      call test_begin('contact_keeping_runs_equal_the_orbit_of_their_memory')
      call one_frequency(395.0_wp)
      call one_frequency(405.0_wp)
   end subroutine test_contact_keeping_runs_equal_the_orbit_of_their_memory

   !> The damped rig at lam teeth/s (the sweep deck's run with the shafts damped).
   subroutine rig_at(lam, m)
      real(wp), intent(in) :: lam
      type(model_t), intent(out) :: m
      call damped_rig_model(deck, lam, m, err)
      if (allocated(err)) error stop 'the damped rig: '//err%message
   end subroutine rig_at

   subroutine one_frequency(lam)
      real(wp), intent(in) :: lam
      integer, parameter :: n0 = 600, n_max = 40000
      type(model_t) :: m
      type(session_t), allocatable :: s
      type(period_map_t) :: pm
      type(shoot_options_t) :: opt
      type(shoot_result_t) :: res, res0
      complex(wp), allocatable :: mu(:)
      real(wp), allocatable :: mem_start(:), mem_run(:), x0(:), x1(:)
      real(wp) :: period, t_start, r0, r, r_start, mu_max
      integer :: nper
      call rig_at(lam, m)
      call forcing_period(m, period, err)
      if (allocated(err)) error stop err%message
      t_start = m%run%t_start
      ! the sweep's run: a session from the deck's start, n0 mesh periods
      m%run%t_end = t_start + real(n0 + n_max + 2, wp)*period
      call pm%setup(m, period, 1, err)
      call check(str(lam)//' teeth/s: the period map sets up', .not. allocated(err))
      if (allocated(err)) return
      allocate (s)
      call s%start(m, err, reference=.false.)
      if (allocated(err)) error stop err%message
      mem_start = pm%memory_of(s%model)
      call s%advance(t_start + real(n0, wp)*period, err)
      call check('  the run advances', .not. allocated(err))
      if (allocated(err)) return
      mem_run = pm%memory_of(s%model)
      x0 = reduced(pm, s, t_start)
      write (*, '(a,f7.1,a,2es14.6,a,es11.4)') '    ', lam, ' teeth/s: D from the start, of the run ', &
         mem_start(1), mem_run(1), ', V_i ', mem_run(3)
      call check('  the run''s contact closed at an impact (its D is not the law''s start)', &
                 mem_run(1) > 0.0_wp .and. mem_start(1) == 0.0_wp)
      ! its orbit: shooting from the run's state with the run's memory
      pm%mem = mem_run
      opt%transient = 0
      call shoot(pm, opt, res, err, monodromy=monodromy_variational, x_start=x0)
      call check('  the shooting converged ('//res%message//')', .not. allocated(err) .and. res%status == shoot_converged)
      if (allocated(err) .or. res%status /= shoot_converged) return
      call check('  the contact never opens on the orbit (t0 not moved)', pm%t0 == t_start)
      call check('  the memory repeats: the map ends with the memory it began with', all(pm%mem_end == pm%mem))
      call floquet_multipliers(res%m, mu, err)
      mu_max = maxval(abs(mu))
      call check('  the orbit is stable: max |mu| = '//str(mu_max, 6)//' < 1', mu_max < 1.0_wp)
      if (.not. mu_max < 1.0_wp) return
      ! the run goes on until the contraction bound |mu|^N r0 is below 1e-8
      r0 = maxval(abs(x0 - res%x)/res%scale)
      nper = min(n_max, max(1, ceiling(log(1.0e-8_wp/r0)/log(mu_max))))
      call s%advance(t_start + real(n0 + nper, wp)*period, err)
      call check('  the run goes on', .not. allocated(err))
      if (allocated(err)) return
      x1 = reduced(pm, s, t_start)
      call check('  the run kept contact and its memory', all(pm%memory_of(s%model) == mem_run))
      r = maxval(abs(x1 - res%x)/res%scale)
      write (*, '(a,es10.3,a,i0,a,es10.3,a,i0,a,f9.6,a)') '    run vs orbit: ', r0, ' after ', n0, ' periods, ', r, &
         ' after ', n0 + nper, ' (max |mu| ', mu_max, ')'
      call check('  the settled run equals the orbit of its memory to 1e-6 of the state scale', r <= 1.0e-6_wp)
      ! the orbit from the same state with the law's start D = 0 (what the map took before D-150)
      pm%mem = mem_start
      call shoot(pm, opt, res0, err, monodromy=monodromy_variational, x_start=x1)
      if (.not. allocated(err) .and. res0%status == shoot_converged) then
         r_start = maxval(abs(x1 - res0%x)/res%scale)
         write (*, '(a,es10.3)') '    the orbit with D = 0 vs the run: ', r_start
         call check('  with the law''s start (D = 0) the orbit is another (> 100 times the 1e-6 above)', &
                    r_start > 1.0e-4_wp)
      else
         call check('  with D = 0 no orbit near the run''s state (another orbit or none)', .true.)
      end if
      call s%finish()
      call pm%finish()
   end subroutine one_frequency

   !> The session's state reduced as pm's at its t0 = t_start (angles less the rigid rotation).
   function reduced(pm, ss, t_start) result(x)
      type(period_map_t), intent(in) :: pm
      type(session_t), intent(in) :: ss
      real(wp), intent(in) :: t_start
      real(wp), allocatable :: x(:)
      x = ss%y(1:pm%n)
      x(pm%ang) = x(pm%ang) - pm%w*(ss%t - t_start)
   end function reduced
end program test_periodic_memory
