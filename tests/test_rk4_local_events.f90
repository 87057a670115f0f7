!> Local (multirate) event steps of event-located RK4 (docs/decisions.md D-32,
!> docs/integrators.md): on a long chain with a few backlash gears an event
!> re-integrates only the region around its element, the rest of the train
!> keeps the unsplit step. Checked against the same integrator with every
!> event splitting the whole train's step (`multirate = .false.`, the path of
!> every small train) and against a fine-dt reference:
!> - the same events (element, kind) in the same order, and event times and
!>   final states whose error against the reference is of the global path's
!>   size (the scheme's extra local error, O(h^5) per event step, is of RK4's
!>   own order: its global error must be too);
!> - the error falls like dt^4 (order 4 kept: halving dt divides it by >= 10);
!> - the energy ledger closes to the same order as on the global path;
!> - the local path is taken on the long chain (no whole-train RHS beyond the
!>   4 per step) and never on a train where the region is not a small part;
!> - the guard floor (`model_t%guard_floor`, with which a local step skips the
!>   guard elements outside its region that cannot fire) is a lower bound of
!>   the guards over its box of angles, and a tight one.
program test_rk4_local_events
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_event, only: event_t, ev_contact_front, ev_contact_rear, ev_separation
   use trainsim_integrator, only: adv_event
   use trainsim_int_rk4, only: rk4_t
   use trainsim_observer, only: run_result_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text, run_model
   implicit none

   integer, parameter :: max_ev = 20000

   type :: run_t
      real(wp), allocatable :: y(:)
      real(wp) :: ledger = 0.0_wp, scale = 0.0_wp
      integer :: nev = 0
      real(wp), allocatable :: ev_t(:)
      integer, allocatable :: ev_el(:), ev_kind(:)
      integer(i8) :: steps = 0, rhs = 0, mr_steps = 0, mr_events = 0, collapses = 0
   end type run_t

   call suite_begin('rk4 local (multirate) event steps')
   call long_chain()
   call rattling_chain()
   call coarse_chain()
   call small_trains_stay_global()
   call guard_floor_bound()
   call suite_end()

contains

   !> A chain of n unit inertias, shafts k = 1e4 with damping c, a spur gear
   !> with backlash as element gear_at(:); node 1 starts at 1 rad/s.
   function chain_deck(n, gear_at, t_end, dt) result(text)
      integer, intent(in) :: n, gear_at(:)
      real(wp), intent(in) :: t_end, dt
      character(len=:), allocatable :: text
      character(len=256) :: line
      integer :: i
      write (line, '(a,es23.16,a,es23.16,a)') "&run title = 'chain', t_end = ", t_end, ', dt = ', dt, &
         ", integrator = 'rk4', event_tol = 1.0e-13 /"
      text = trim(line)//new_line('a')
      do i = 1, n
         write (line, '(a,i0,a)') "&node id = 'n", i, "', type = 'inertia', inertia = 1.0 /"
         text = text//trim(line)//new_line('a')
      end do
      do i = 1, n - 1
         if (any(gear_at == i)) then
            write (line, '(a,i0,a)') "&element id = 'e", i, "', type = 'spur_gear', stiffness = 1.0e4, "// &
               'rb_driver = 1.0, rb_driven = 1.0, teeth = 32, contact_ratio = 1.6, approach_angle = 0.1, '// &
               'half_backlash = 1.0e-3 /'
         else
            write (line, '(a,i0,a)') "&element id = 'e", i, "', type = 'shaft', stiffness = 1.0e4, damping = 0.5 /"
         end if
         text = text//trim(line)//new_line('a')
      end do
      text = text//"&initial node = 'n1', speed = 1.0 /"
   end function chain_deck

   !> Run the model with event-located RK4 at dt, the local event steps on or
   !> off, through a driver loop of its own (the settling of `simulate`).
   subroutine run(text, dt, multirate, r)
      character(len=*), intent(in) :: text
      real(wp), intent(in) :: dt
      logical, intent(in) :: multirate
      type(run_t), intent(out) :: r
      type(model_t) :: m
      type(rk4_t) :: integ
      type(error_t), allocatable :: err
      type(event_t), allocatable :: ev(:)
      real(wp), allocatable :: g(:)
      logical, allocatable :: fired(:)
      real(wp) :: t, t_end, stored
      integer :: status, nev, k, pass
      call load_model_text(text, m)
      m%run%dt = dt
      t = m%run%t_start
      t_end = m%run%t_end
      allocate (r%ev_t(max_ev), r%ev_el(max_ev), r%ev_kind(max_ev))
      call m%initial_state(r%y)
      call m%init_modes(t, r%y)
      allocate (g(m%n_guards), fired(m%n_guards), ev(64))
      integ%multirate = multirate
      call integ%set_stop(t_end, .false.)
      call integ%start(m, t, r%y, err)
      if (allocated(err)) error stop 'start'
      r%scale = m%energy0
      do while (t < t_end - 1.0e-9_wp*dt)
         call integ%advance(m, t_end, t, r%y, status, err)
         if (allocated(err)) error stop 'advance'
         if (status /= adv_event) cycle
         do pass = 1, 16
            call m%guards(t, r%y, g)
            fired = g < 0.0_wp
            if (.not. any(fired)) exit
            nev = 0
            call m%apply_events(t, r%y, fired, ev, nev)
            do k = 1, nev
               if (r%nev == max_ev) error stop 'too many events'
               r%nev = r%nev + 1
               r%ev_t(r%nev) = t
               r%ev_el(r%nev) = ev(k)%element
               r%ev_kind(r%nev) = ev(k)%kind
            end do
         end do
         call integ%restart(m, t, r%y, err)
      end do
      stored = m%stored_energy(t, r%y)
      r%ledger = stored + r%y(m%n_states + 1) - r%y(m%n_states + 2) - m%energy0
      r%steps = integ%stats%steps
      r%rhs = integ%stats%rhs_evals
      r%mr_steps = integ%mr_steps
      r%collapses = integ%mr_collapses
      r%mr_events = integ%mr_events
      call by_element(r)
   end subroutine run

   !> Events ordered by element, each element's in time order (events of
   !> different elements close in time may swap their order between runs).
   subroutine by_element(r)
      type(run_t), intent(inout) :: r
      integer :: i, j, e, k
      real(wp) :: t
      do i = 2, r%nev
         t = r%ev_t(i); e = r%ev_el(i); k = r%ev_kind(i)
         j = i - 1
         do while (j >= 1)
            if (r%ev_el(j) <= e) exit
            r%ev_t(j + 1) = r%ev_t(j); r%ev_el(j + 1) = r%ev_el(j); r%ev_kind(j + 1) = r%ev_kind(j)
            j = j - 1
         end do
         r%ev_t(j + 1) = t; r%ev_el(j + 1) = e; r%ev_kind(j + 1) = k
      end do
   end subroutine by_element

   !> Largest |difference| of event times (the same events in the same order
   !> assumed) and of the node states (angles, speeds) at the end.
   subroutine errors(a, b, n_states, e_t, e_y)
      type(run_t), intent(in) :: a, b
      integer, intent(in) :: n_states
      real(wp), intent(out) :: e_t, e_y
      integer :: i
      e_t = 0.0_wp
      do i = 1, min(a%nev, b%nev)
         e_t = max(e_t, abs(a%ev_t(i) - b%ev_t(i)))
      end do
      e_y = maxval(abs(a%y(1:n_states) - b%y(1:n_states)))
   end subroutine errors

   logical function same_events(a, b) result(same)
      type(run_t), intent(in) :: a, b
      same = a%nev == b%nev
      if (same) same = all(a%ev_el(1:a%nev) == b%ev_el(1:b%nev)) .and. all(a%ev_kind(1:a%nev) == b%ev_kind(1:b%nev))
   end function same_events

   subroutine long_chain()
      integer, parameter :: n = 200
      real(wp), parameter :: dt = 1.0e-3_wp, t_end = 2.4_wp
      character(len=:), allocatable :: deck
      type(run_t) :: ref, g1, m1, m2
      real(wp) :: et_g, ey_g, et_m, ey_m, et_m2, ey_m2, et_gm, ey_gm
      integer :: ns
      deck = chain_deck(n, [40, 80, 120, 160], t_end, dt)
      ns = 2*n
      call run(deck, dt/16.0_wp, .false., ref)
      call run(deck, dt, .false., g1)
      call run(deck, dt, .true., m1)
      call run(deck, dt/2.0_wp, .true., m2)
      call errors(g1, ref, ns, et_g, ey_g)
      call errors(m1, ref, ns, et_m, ey_m)
      call errors(m2, ref, ns, et_m2, ey_m2)
      call errors(m1, g1, ns, et_gm, ey_gm)
      write (*, '(a,i0,a,i0,a,i0,a,i0)') '    events: reference ', ref%nev, ', global ', g1%nev, ', local ', m1%nev, &
         ', local dt/2 ', m2%nev
      write (*, '(a,4es10.2)') '    event-time error: global, local, local dt/2, local - global:', et_g, et_m, et_m2, et_gm
      write (*, '(a,4es10.2)') '    final-state error: global, local, local dt/2, local - global:', ey_g, ey_m, ey_m2, ey_gm
      write (*, '(a,3es10.2,a,es10.2)') '    energy ledger: reference, global, local:', ref%ledger, g1%ledger, &
         m1%ledger, ' of E0 = ', ref%scale
      write (*, '(a,i0,a,i0,a,i0,a,i0)') '    local: ', m1%mr_steps, ' local event steps, ', m1%collapses, &
         ' collapsed; RHS ', m1%rhs, ' for ', m1%steps
      call test_begin('the local path is taken on a long chain')
      call check('local event steps taken', m1%mr_steps > 0)
      ! + 1: RK4 evaluates the next step's first stage after the last step (D-33)
      call check('no whole-train RHS beyond 4 per step', m1%rhs <= 4*m1%steps + 1)
      call check('the global path splits the whole step', g1%rhs > 4*g1%steps)
      call test_begin('the same events as the global path and the reference')
      call check('events happen', ref%nev > 20)
      call check('same events (element, kind, order) as the reference', same_events(m1, ref))
      call check('same events as the global path', same_events(m1, g1))
      call check('same events at dt/2', same_events(m2, ref))
      call test_begin('errors of the global path''s size, order 4')
      ! the local path's error is of the global path's order and size: at most
      ! 2x (each has an O(h^5) local error per step, the local one also the
      ! boundary's interpolation, O(h^4) in the torque over the sub-step)
      call check('event times within 2x the global path''s error', et_m <= 2.0_wp*et_g + 1.0e-12_wp)
      call check('final state within 2x the global path''s error', ey_m <= 2.0_wp*ey_g)
      ! order 4: halving dt divides the error by 16; >= 10 allows for the
      ! reference's own error and the next order
      call check('final-state error falls >= 10x from dt to dt/2', ey_m >= 10.0_wp*ey_m2)
      call check('event-time error falls >= 10x from dt to dt/2', et_m >= 10.0_wp*et_m2)
      call test_begin('the energy ledger closes to the global path''s order')
      call check('ledger within 2x the global path''s (or 1e-12 E0)', &
                 abs(m1%ledger) <= 2.0_wp*abs(g1%ledger) + 1.0e-12_wp*ref%scale)
      call through_simulate(deck, dt, g1, m1)
   end subroutine long_chain

   !> A chain of 300 nodes with a gear as every 10th element: several events
   !> in one step, in one region and in several.
   subroutine rattling_chain()
      integer, parameter :: n = 300
      real(wp), parameter :: dt = 1.0e-3_wp, t_end = 2.0_wp
      character(len=:), allocatable :: deck
      type(run_t) :: ref, g1, m1, m2
      real(wp) :: et_g, ey_g, et_m, ey_m, et_m2, ey_m2, et_gm, ey_gm
      integer :: i
      deck = chain_deck(n, [(10*i, i=1, 29)], t_end, dt)
      call run(deck, dt/16.0_wp, .false., ref)
      call run(deck, dt, .false., g1)
      call run(deck, dt, .true., m1)
      call run(deck, dt/2.0_wp, .true., m2)
      call errors(g1, ref, 2*n, et_g, ey_g)
      call errors(m1, ref, 2*n, et_m, ey_m)
      call errors(m2, ref, 2*n, et_m2, ey_m2)
      call errors(m1, g1, 2*n, et_gm, ey_gm)
      write (*, '(a,i0,a,i0,a,i0,a,i0)') '    events: reference ', ref%nev, ', global ', g1%nev, ', local ', m1%nev, &
         ', local dt/2 ', m2%nev
      write (*, '(a,4es10.2)') '    event-time error: global, local, local dt/2, local - global:', et_g, et_m, et_m2, et_gm
      write (*, '(a,4es10.2)') '    final-state error: global, local, local dt/2, local - global:', ey_g, ey_m, ey_m2, ey_gm
      write (*, '(a,3es10.2)') '    energy ledger: reference, global, local:', ref%ledger, g1%ledger, m1%ledger
      write (*, '(a,i0,a,i0,a,i0,a)') '    local: ', m1%mr_steps, ' local event steps with ', m1%mr_events, &
         ' events, ', m1%collapses, ' collapsed'
      call test_begin('a rattling chain: several events per local step')
      call check('more events than local steps', m1%mr_events > m1%mr_steps + 10)
      ! + 1: RK4 evaluates the next step's first stage after the last step (D-33)
      call check('no whole-train RHS beyond 4 per step', m1%rhs <= 4*m1%steps + 1)
      call check('same events as the reference', same_events(m1, ref))
      call check('same events as the global path', same_events(m1, g1))
      call check('event times within 2x the global path''s error', et_m <= 2.0_wp*et_g + 1.0e-12_wp)
      call check('final state within 2x the global path''s error', ey_m <= 2.0_wp*ey_g)
      call check('final-state error falls >= 10x from dt to dt/2', ey_m >= 10.0_wp*ey_m2)
      call check('ledger within 2x the global path''s (or 1e-12 E0)', &
                 abs(m1%ledger) <= 2.0_wp*abs(g1%ledger) + 1.0e-12_wp*ref%scale)
      call through_simulate(deck, dt, g1, m1)
   end subroutine rattling_chain

   !> The benchmark's chain (100 nodes, a gear as every 10th element, no
   !> damping, dt = 5 ms: omega_max dt = 1) for 10 s: guards outside a region
   !> dip below zero inside steps, so local steps end early (the state shown
   !> becomes the state). The run goes through, and the energy ledger loses
   !> what RK4 loses at this step (a quarter to a half of the energy in 10 s),
   !> the same order on both paths.
   subroutine coarse_chain()
      character(len=:), allocatable :: deck
      type(run_t) :: g1, m1
      type(model_t) :: m
      type(run_result_t) :: res
      integer :: i
      deck = chain_deck(100, [(10*i, i=1, 9)], 10.0_wp, 5.0e-3_wp)
      i = index(deck, ', damping = 0.5')
      do while (i > 0)
         deck = deck(1:i - 1)//deck(i + 15:)
         i = index(deck, ', damping = 0.5')
      end do
      call run(deck, 5.0e-3_wp, .false., g1)
      call run(deck, 5.0e-3_wp, .true., m1)
      write (*, '(a,i0,a,i0,a,i0,a,2es10.2)') '    coarse chain: events global ', g1%nev, ', local ', m1%nev, &
         ', local steps ended early ', m1%collapses, '; ledger global, local', g1%ledger, m1%ledger
      call test_begin('the benchmark''s coarse chain: local steps that end early')
      call check('some local steps end early', m1%collapses > 0)
      call check('most events on the local path', m1%mr_events > m1%nev/2)
      call check('energy lost within 2x the global path''s (RK4''s loss at omega dt = 1)', &
                 abs(m1%ledger) <= 2.0_wp*abs(g1%ledger) .and. m1%ledger < 0.0_wp)
      call load_model_text(deck, m)
      m%run%energy_check = 0.0_wp   ! RK4 loses a third of the energy here on purpose (D-55's check would stop it)
      call run_model(m, res)
      call check('through simulate: the same events as the mini-driver', size(res%events) == m1%nev)
   end subroutine coarse_chain

   !> The same chain through `simulate` (the real driver and observer): the
   !> final state is the mini-driver's, the ledger residual of the observer
   !> (every sample) stays at the order of the final one. At a local event
   !> instant the driver looks at the region's guards and modes alone, and the
   !> observer at the region's elements alone: the events and the final state
   !> are still the mini-driver's (which looks at the whole train there) bit for
   !> bit, and each gear's time out of contact is still the one its event rows
   !> give (out of contact from t_start, the teeth starting inside the backlash,
   !> to the first contact, and from each separation to the next contact).
   subroutine through_simulate(deck, dt, g1, m1)
      character(len=*), intent(in) :: deck
      real(wp), intent(in) :: dt
      type(run_t), intent(in) :: g1, m1
      type(model_t) :: m
      type(run_result_t) :: res
      type(run_t) :: s
      integer :: k, e, nst
      real(wp) :: toc, t_sep, worst
      logical :: out
      call load_model_text(deck, m)
      m%run%dt = dt
      call run_model(m, res)
      nst = m%n_states
      s%nev = size(res%events)
      allocate (s%ev_t(s%nev), s%ev_el(s%nev), s%ev_kind(s%nev))
      do k = 1, s%nev
         s%ev_t(k) = res%events(k)%t
         s%ev_el(k) = res%events(k)%element
         s%ev_kind(k) = res%events(k)%kind
      end do
      call by_element(s)
      worst = 0.0_wp
      do e = 1, size(res%el)
         if (m%elements(e)%e%n_guards() == 0) cycle
         toc = 0.0_wp
         out = .true.
         t_sep = m%run%t_start
         do k = 1, size(res%events)
            if (res%events(k)%element /= e) cycle
            select case (res%events(k)%kind)
            case (ev_contact_front, ev_contact_rear)
               if (out) toc = toc + (res%events(k)%t - t_sep)
               out = .false.
            case (ev_separation)
               if (.not. out) t_sep = res%events(k)%t
               out = .true.
            end select
         end do
         if (out) toc = toc + (res%t_final - t_sep)
         worst = max(worst, abs(toc - res%el(e)%time_out_of_contact))
      end do
      write (*, '(a,es10.2,a)') '    simulate: time out of contact against the event rows, worst ', worst, ' s'
      call test_begin('through simulate: the region alone at local event instants')
      call check('the same events and event times as the mini-driver, bit for bit', same_events(s, m1) .and. &
                 all(s%ev_t(1:s%nev) == m1%ev_t(1:m1%nev)))
      call check('the same final state as the mini-driver, bit for bit', all(res%y_final(1:nst) == m1%y(1:nst)))
      call check('each gear''s time out of contact is its event rows'' (to 1e-9 s)', worst <= 1.0e-9_wp)
      call test_begin('through simulate: the ledger residual at every sample')
      write (*, '(a,es10.2,a,es10.2)') '    simulate: max ledger residual ', res%energy_residual_max, &
         ' of scale ', res%energy_scale
      call check('events recorded', size(res%events) == g1%nev)
      call check('max residual <= 10x the global path''s final ledger (or 1e-12 of the scale)', &
                 res%energy_residual_max <= 10.0_wp*abs(g1%ledger) + 1.0e-12_wp*res%energy_scale)
   end subroutine through_simulate

   !> A train whose region is not a small part of it takes the global path
   !> (bit for bit: the same run with the local steps switched off).
   subroutine small_trains_stay_global()
      character(len=:), allocatable :: deck
      type(run_t) :: a, b
      deck = chain_deck(30, [15], 1.0_wp, 4.0e-3_wp)
      call run(deck, 4.0e-3_wp, .true., a)
      call run(deck, 4.0e-3_wp, .false., b)
      call test_begin('a 30-node chain stays on the global path')
      call check('events happen', a%nev > 5)
      call check('no local event step', a%mr_steps == 0)
      call check('bit for bit the global path', same_events(a, b) .and. all(a%y == b%y) .and. &
                 all(a%ev_t(1:a%nev) == b%ev_t(1:b%nev)))
   end subroutine small_trains_stay_global
   !> `guard_floor`: for a gear in each of its modes (free, contact on either
   !> face), over boxes of angles that do and do not reach a guard's zero, the
   !> floor is at most the least guard over the box and within 1e-9 of it (the
   !> guards are linear in the two angles: their least value over a box is at
   !> a corner).
   subroutine guard_floor_bound()
      type(model_t) :: m
      real(wp), allocatable :: y(:)
      real(wp), parameter :: radii(4) = [0.0_wp, 4.0e-4_wp, 1.5e-3_wp, 3.0e-3_wp]
      real(wp), parameter :: shifts(3) = [0.0_wp, 6.0e-4_wp, -1.3e-3_wp]
      integer :: gears(3), k, e, il, ir, a, b, c, d, kk, n_cases, n_pos, n_neg, n_contact
      real(wp) :: thl, thr, rl, rr, fl, exact, worst_over, worst_gap
      logical :: rows
      gears = [10, 20, 30]
      ! e20 (nodes 20, 21) starts pressed on one face, e30 (nodes 30, 31) on the other
      call load_model_text(chain_deck(40, gears, 1.0_wp, 1.0e-3_wp)//new_line('a')// &
                           "&initial node = 'n21', angle = 2.0e-3 /"//new_line('a')// &
                           "&initial node = 'n30', angle = 2.0e-3 /", m)
      call m%initial_state(y)
      call m%init_modes(m%run%t_start, y)
      n_cases = 0; n_pos = 0; n_neg = 0; n_contact = 0
      worst_over = -huge(1.0_wp); worst_gap = 0.0_wp
      rows = .true.
      do k = 1, size(gears)
         e = gears(k)
         call m%guard_angles(e, il, ir)
         if (il == 0) then
            rows = .false.
            cycle
         end if
         if (m%angle_guard(e, 1, y(il), y(ir)) == 1.0_wp .or. m%angle_guard(e, 2, y(il), y(ir)) == 1.0_wp) &
            n_contact = n_contact + 1
         do a = 1, size(shifts)
            do b = 1, size(radii)
               do c = 1, size(radii)
                  thl = y(il) + shifts(a)
                  thr = y(ir) - 0.5_wp*shifts(a)
                  rl = radii(b)
                  rr = radii(c)
                  fl = m%guard_floor(e, thl, rl, thr, rr)
                  exact = huge(1.0_wp)
                  do d = 0, 3
                     do kk = 1, m%elements(e)%e%n_guards()
                        exact = min(exact, m%angle_guard(e, kk, thl + merge(rl, -rl, mod(d, 2) == 1), &
                                                         thr + merge(rr, -rr, d >= 2)))
                     end do
                  end do
                  n_cases = n_cases + 1
                  if (exact > 0.0_wp) n_pos = n_pos + 1
                  if (exact < 0.0_wp) n_neg = n_neg + 1
                  worst_over = max(worst_over, fl - exact)
                  worst_gap = max(worst_gap, exact - fl)
               end do
            end do
         end do
      end do
      write (*, '(a,i0,a,i0,a,i0,a,es10.2,a,es10.2)') '    guard floor: ', n_cases, ' boxes (', n_pos, &
         ' with every guard above zero, ', n_neg, ' reaching below); floor - least guard <= ', worst_over, &
         ', least guard - floor <= ', worst_gap
      call test_begin('guard floor: a tight lower bound of the guards over a box of angles')
      call check('the gears have guard rows', rows)
      call check('free and pressed gears (two in contact)', n_contact == 2)
      call check('boxes on both sides of zero', n_pos > 10 .and. n_neg > 10)
      call check('the floor is at most the least guard', worst_over <= 0.0_wp)
      call check('the floor is within 1e-9 of the least guard', worst_gap <= 1.0e-9_wp)
   end subroutine guard_floor_bound
end program test_rk4_local_events
