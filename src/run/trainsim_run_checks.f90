!> The checks of a run and what its messages advise: the fixed step against RK4's
!> stability limit before the run (`check_fixed_step`, also `trainsim check`), a state
!> that blew up (`check_state`, after every advance), the checks that a run is still
!> physical (`check_physical`, `check_ledger`, D-55), and the advice in their messages
!> (the limit, the mode that sets it, the integrator to use instead).
module trainsim_run_checks
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_input, err_numeric
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_integrator, only: integrator_t
   use trainsim_integrator_registry, only: integrator_registry, integrator_entry_t
   use trainsim_modes, only: rk4_dt_limit, limiting_part, rk4_dt_quick_states, load_torque_bound
   use trainsim_observer, only: observer_t
   use trainsim_element, only: lin_state_t, lin_stiffest, lin_start, lin_contact_closed
   implicit none
   private

   public :: check_fixed_step, check_state, check_physical, check_ledger, displacement_bounds, blowup_limit
   public :: guard_owner, is_fixed_step, remedy, window_text, modes_kept

   !> A state beyond this is a blow-up. Far above any physical angle, speed,
   !> current or energy; its square times any sane coefficient stays finite, so
   !> the check fires before a floating-point overflow can.
   real(wp), parameter :: blowup_limit = 1.0e50_wp

   !> A fixed step more than this many times RK4's stability limit of the
   !> starting state multiplies any excitation of the limiting mode by 1e12 or
   !> more per step: the run cannot mean anything, and a step of it can overflow
   !> before the blow-up check sees it. Below this factor the check is in time
   !> (a run 10x above the limit, as Table 5.2's, runs with a warning).
   real(wp), parameter :: max_dt_over_limit = 1.0e3_wp
   !> A limiting eigenvalue with at least this damping ratio (|Re| >= |Im|) is
   !> damping-dominated: a fixed step above its limit is refused (D-55).
   real(wp), parameter :: damped_ratio = 0.7071_wp

contains

   !> Each element's displacement bound (element%displacement_bound) from the
   !> loads (trainsim_modes' load_torque_bound) and its nodes' inertias.
   subroutine displacement_bounds(model, bound)
      type(model_t), intent(in) :: model
      real(wp), allocatable, intent(out) :: bound(:)
      real(wp) :: tq
      integer :: i
      allocate (bound(size(model%elements)))
      tq = load_torque_bound(model)
      do i = 1, size(model%elements)
         associate (e => model%elements(i)%e)
            bound(i) = e%displacement_bound(tq, inv_inertia(e%left), inv_inertia(e%right))
         end associate
      end do
   contains
      real(wp) function inv_inertia(j) result(r)
         integer, intent(in) :: j
         r = 0.0_wp
         if (model%is_held(j) .or. model%nodes(j)%n%is_fixed()) return
         if (model%nodes(j)%n%inertia() > 0.0_wp) r = 1.0_wp/model%nodes(j)%n%inertia()
      end function inv_inertia
   end subroutine displacement_bounds

   !> The checks that a run is still physical, at each output time from the
   !> observer's running metrics (D-55): no element's displacement beyond its
   !> bound (a mesh with its teeth through one another) ends the run at once;
   !> the first time the energy residual passes run%energy_check of the
   !> scale so far is kept for `check_ledger`. A run that fails them ends with
   !> exit 1 naming the element, the time, the check and a remedy for the
   !> integrator in use, instead of a wrong answer with exit 0.
   subroutine check_physical(model, obs, disp_bound, t_ledger, t, err)
      type(model_t), intent(inout) :: model
      type(observer_t), intent(in) :: obs
      real(wp), intent(in) :: disp_bound(:)   !< per element (displacement_bounds)
      real(wp), intent(inout) :: t_ledger     !< the first time the residual passed (-1: not yet)
      real(wp), intent(in) :: t
      type(error_t), allocatable, intent(out) :: err
      integer :: i
      real(wp) :: worst
      do i = 1, size(disp_bound)
         worst = max(abs(obs%res%el(i)%disp_min), abs(obs%res%el(i)%disp_max))
         if (.not. worst > disp_bound(i)) cycle
         if (obs%res%el(i)%disp_min > obs%res%el(i)%disp_max) cycle   ! nothing folded yet (settle_time)
         call fatal_error(err, "integrator '"//model%run%integrator//"': the displacement of element '"// &
                          model%elements(i)%e%id//"' reached "//str(sign(worst, obs%res%el(i)%disp_max + &
                          obs%res%el(i)%disp_min), 4)//' by t = '//str(t)//' s, beyond the '//str(disp_bound(i), 4)// &
                          ' a physical run can reach (the clearance plus ten times the largest of the clearance, '// &
                          'the static deflection under the loads and an impact at 100 in/s): the solution is wrong '// &
                          '(the displacement-bound check). '//physical_advice(model), err_numeric)
         return
      end do
      if (t_ledger < 0.0_wp .and. model%run%track_energy .and. model%run%energy_check > 0.0_wp) then
         if (obs%res%energy_residual_max > model%run%energy_check*obs%res%energy_scale) t_ledger = t
      end if
   end subroutine check_physical

   !> The energy ledger at the end of the run (D-55): a residual above
   !> run%energy_check (default 0.1) of the run's energy scale is a wrong
   !> solution, not an integration error: a correct run keeps it near 1e-6,
   !> RK4 at 0.95 x its stability limit below 1e-3 (check_dt_advice); a
   !> blown-up one has it equal to the scale. Judged at the end, where the scale
   !> is the run's: early on, one coarse step at an impact can be comparable to
   !> a scale that is still small (loads_table_ramp at 0.95 x its limit: 0.67
   !> at t = 0.022 s, 4e-4 at the end).
   subroutine check_ledger(model, obs, t_ledger, t, err)
      type(model_t), intent(inout) :: model
      type(observer_t), intent(in) :: obs
      real(wp), intent(in) :: t_ledger   !< the first time the residual passed (check_physical; -1: not yet)
      real(wp), intent(in) :: t
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: h_part, t_first
      type(model_t) :: tmp
      character(len=:), allocatable :: part
      if (.not. model%run%track_energy .or. .not. model%run%energy_check > 0.0_wp) return
      if (.not. obs%res%energy_residual_max > model%run%energy_check*obs%res%energy_scale) return
      t_first = t
      if (t_ledger >= 0.0_wp) t_first = t_ledger
      tmp = model
      call limiting_part(tmp, lin_stiffest, part, h_part)
      call fatal_error(err, "integrator '"//model%run%integrator//"': the energy ledger does not balance: at t = "// &
                       str(t)//' s the largest residual is '//str(obs%res%energy_residual_max, 4)// &
                       ' against an energy scale of '//str(obs%res%energy_scale, 4)//' (more than energy_check = '// &
                       str(model%run%energy_check)//' of it, first at t = '//str(t_first)//' s; the energy-ledger '// &
                       'check): the solution is wrong. The stiffest part of the train is '//part// &
                       ', with a step limit of its own of '//str(h_part, 4)//' s. '//physical_advice(model), &
                       err_numeric)
   end subroutine check_ledger

   !> NaN or runaway state after a step -> an error naming the time, the node
   !> and quantity, and the likely cause.
   !> With `states`, only those entries of y (a local event instant).
   subroutine check_state(model, integ, t, y, err, states)
      type(model_t), intent(inout) :: model
      class(integrator_t), intent(in) :: integ
      real(wp), intent(in) :: t, y(:)
      type(error_t), allocatable, intent(out) :: err
      integer, intent(in), optional :: states(:)
      integer :: i, k
      if (present(states)) then
         do k = 1, size(states)
            if (.not. abs(y(states(k))) <= blowup_limit) then   ! also true for NaN
               call blew_up(states(k))
               return
            end if
         end do
         return
      end if
      do i = 1, size(y)
         if (.not. abs(y(i)) <= blowup_limit) then   ! also true for NaN
            call blew_up(i)
            return
         end if
      end do
   contains
      subroutine blew_up(j)
         integer, intent(in) :: j
         call fatal_error(err, "integrator '"//model%run%integrator//"': the solution blew up at t = "//str(t)// &
                          ' s ('//model%state_label(j)//' is '//trim(merge('NaN    ', 'runaway', y(j) /= y(j)))// &
                          '). '//blowup_advice(model, integ), err_numeric)
      end subroutine blew_up
   end subroutine check_state

   !> What to try when a run is no longer physical: for a fixed step, a smaller
   !> dt than RK4's stability limit of the stiffest state (a step near the limit
   !> of a strongly damped mode is stable but does not resolve it) or an
   !> implicit method; for an adaptive one, its tolerances.
   function physical_advice(model) result(text)
      type(model_t), intent(inout) :: model
      character(len=:), allocatable :: text
      type(model_t) :: tmp
      type(error_t), allocatable :: lim_err
      real(wp) :: dt_safe, omega
      if (.not. is_fixed_step(model%run%integrator)) then
         text = remedy(model)
         if (index(model%run%integrator, 'arkode') == 1) text = text//"; or use integrator = 'cvode-bdf' if the train is stiff"
         return
      end if
      tmp = model
      call rk4_dt_limit(tmp, lin_stiffest, dt_safe, omega, lim_err)
      text = "Take a smaller dt, or use integrator = 'cvode-bdf'"
      if (.not. allocated(lim_err) .and. dt_safe < huge(1.0_wp)) text = 'Take dt well below '//str(dt_safe, 4)// &
         ' s, the RK4 stability limit of the stiffest state the run can reach (a step near the limit of a strongly '// &
         "damped mode is stable but does not resolve it), or use integrator = 'cvode-bdf'"
   end function physical_advice

   !> What to try after a blow-up: the step if it is above the stability
   !> limit (fixed-step methods), else the tolerances, else the inputs.
   function blowup_advice(model, integ) result(text)
      type(model_t), intent(inout) :: model
      class(integrator_t), intent(in) :: integ
      character(len=:), allocatable :: text
      associate (unused => integ)
      end associate
      text = remedy(model)
   end function blowup_advice

   !> What to try after a numerical failure, for the integrator in use: the
   !> step dt against RK4's stability limit (fixed-step methods), or the
   !> tolerances and max_step (adaptive ones, which do not use dt but as the
   !> output grid when output_interval is 0).
   function remedy(model) result(text)
      type(model_t), intent(inout) :: model
      character(len=:), allocatable :: text
      character(len=:), allocatable :: h
      if (is_fixed_step(model%run%integrator)) then
         text = stability_advice(model)
         return
      end if
      h = 'a smaller max_step'
      if (model%run%max_step > 0.0_wp) h = 'a smaller max_step (now '//str(model%run%max_step)//' s)'
      text = "Integrator '"//model%run%integrator//"' chooses its own steps: tighten rtol (now "//str(model%run%rtol)// &
             ') and the absolute tolerances, or set '//h//'; if that does not help, check the loads, stiffnesses '// &
             'and inertias of the deck for values out of proportion'
   end function remedy

   !> The event budget's window in words: dt for a fixed-step method, else the
   !> same span of time named as the deck's dt (an adaptive method does not step by it).
   function window_text(model) result(text)
      type(model_t), intent(in) :: model
      character(len=:), allocatable :: text
      if (is_fixed_step(model%run%integrator)) then
         text = 'dt = '//str(model%run%dt)//' s'
      else
         text = str(model%run%dt)//' s, the deck''s dt'
      end if
   end function window_text

   !> dt against the RK4 stability limit of the stiffest state the run can
   !> reach (every clearance closed, gears at their largest stiffness factor,
   !> the largest impact damping): blame the step if it is above, the inputs if not.
   function stability_advice(model) result(text)
      type(model_t), intent(inout) :: model
      character(len=:), allocatable :: text
      type(model_t) :: tmp
      type(error_t), allocatable :: err
      real(wp) :: dt_safe, omega, f_hz
      tmp = model
      call rk4_dt_limit(tmp, lin_stiffest, dt_safe, omega, err, freq_hz=f_hz)
      if (allocated(err)) then
         text = 'Check the deck for absurd loads or stiffnesses, and try a smaller dt'
         return
      end if
      if (.not. omega > 0.0_wp) then
         text = 'The train has no elastic mode: check the loads and inertias of the deck for absurd values'
         return
      end if
      if (model%run%dt > dt_safe) then
         text = 'The time step dt = '//str(model%run%dt)//' s is above the RK4 stability limit '//str(dt_safe, 4)// &
                ' s of the stiffest state the run can reach (every clearance closed, gears in their two-pair zone; '// &
                'its mode at '//str(f_hz, 5)//' Hz): take dt below that'
      else
         text = 'The time step dt = '//str(model%run%dt)//' s is within the RK4 stability limit '//str(dt_safe, 4)// &
                ' s of the stiffest state the run can reach: the inputs are more likely to blame; '// &
                'check the loads, stiffnesses, inertias and initial speeds of the deck for values out of proportion'
      end if
   end function stability_advice

   !> Whether the registry row of `name` is a fixed-step method.
   logical function is_fixed_step(name) result(fixed)
      character(len=*), intent(in) :: name
      type(integrator_entry_t), allocatable :: rows(:)
      integer :: i
      allocate (rows, source=integrator_registry())   ! not `rows = ...`: gfortran 12 false -Wuninitialized
      fixed = .false.
      do i = 1, size(rows)
         if (rows(i)%name == name) fixed = rows(i)%fixed_step
      end do
   end function is_fixed_step

   !> A fixed-step method is refused before the first step (exit 2) when
   !> - dt is absurdly far above the stability limit of the train as it starts,
   !>   or with every clearance closed and the gears at their stiffest
   !>   (max_dt_over_limit; impact damping left out: it moves RK4's radius only
   !>   between 2.6 and 2.95, nothing against a factor of 1000); or
   !> - dt is above the limit of either state (the stiffest with every contact
   !>   law's damping at its largest, a gentle closure under the loads included,
   !>   D-55) and the limiting eigenvalue is damping-dominated (damping ratio >=
   !>   1/sqrt 2): a step beyond the real-axis radius multiplies every state
   !>   change by |R(h lambda)| > 1, so no such mode stays unexcited (unlike an
   !>   undamped mode that the inputs may never touch, D-4).
   !> The message names the node or element that limits the step alone
   !> (`limiting_part`), its deck group, and the dt that would do.
   !> rk4-thesis steps dt/10 in contact; Euler's region reaches 2 on the real axis.
   !> `start_bound`: the O(n) bound of the train as it starts (`rk4_dt_quick` of
   !> `lin_start`, RK4's own radius), 0 where the check did not compute it.
   !> `stiffest(3)`: dt, bound on |lambda| and frequency (Hz) of `rk4_dt_quick` of
   !> `lin_stiffest`, what `rk4_dt_limit` gives above the dense limit (computed
   !> with the check's own bounds, D-139); 0 where the check did not compute it.
   subroutine check_fixed_step(model, err, start_bound, stiffest)
      type(model_t), intent(inout) :: model
      type(error_t), allocatable, intent(out) :: err
      real(wp), intent(out), optional :: start_bound, stiffest(3)
      type(integrator_entry_t), allocatable :: rows(:)
      type(lin_state_t) :: states(4)
      character(len=40), parameter :: state_text(4) = [character(len=40) :: 'the train as it starts', &
                                                       'the closed contacts', 'the train as it starts', &
                                                       'the stiffest state the run can reach']
      real(wp) :: dt_safe, omega, f_hz, zeta, h, rescale
      character(len=:), allocatable :: part, name, limit_name
      real(wp) :: dt_start, q_dt(4), q_bound(4), q_freq(4)
      integer :: i, k
      if (present(start_bound)) start_bound = 0.0_wp
      if (present(stiffest)) stiffest = 0.0_wp
      allocate (rows, source=integrator_registry())   ! not `rows = ...`: gfortran 12 false -Wuninitialized
      do i = 1, size(rows)
         if (rows(i)%name == model%run%integrator) exit
      end do
      if (i > size(rows)) return
      if (.not. rows(i)%fixed_step) return
      name = model%run%integrator
      limit_name = "the stability limit of integrator '"//name//"',"
      if (name(1:3) == 'rk4') limit_name = 'the RK4 stability limit'
      rescale = 1.0_wp
      if (name == 'euler') rescale = 2.0_wp/2.785_wp   ! real-axis radius of Euler's region against RK4's
      states = [lin_start, lin_stiffest, lin_start, lin_stiffest]
      states(2)%impact_scale = 0.0_wp
      ! contacts that may close later: the impact damping of D-25, not a gentle
      ! closure at the floor velocity under load, which a run need not reach
      ! (Chapter III case II with Smith's law closes at 21 in/s and runs right);
      ! the contacts closed at t_start have their own D (states(3)), and what a
      ! run does reach is caught at the output times (check_physical)
      states(4)%load_torque = -1.0_wp
      ! the O(n) bounds of states 1, 2 and 4 (3 is 1) and of lin_stiffest, at once:
      ! the modes initialised once, a state as stiff as the last one computed once
      ! (on the model itself, not a copy: the bound re-initialises its modes, as every
      ! run and session does again before its first step, D-107, startup3)
      call rk4_dt_quick_states(model, [states(1), states(2), states(4), lin_stiffest], q_dt, q_bound, q_freq)
      if (present(stiffest)) stiffest = [q_dt(4), q_bound(4), q_freq(4)]
      dt_start = 0.0_wp
      do k = 1, 4
         h = model%run%dt
         if (name == 'rk4-thesis' .and. states(k)%contact == lin_contact_closed) h = h/10.0_wp   ! App. F: dt/10 in contact
         ! the O(n) bound first: within it, every eigenvalue is stable (no eigenvalue problem);
         ! states(3) is states(1) (their bound once)
         if (k == 3) then
            dt_safe = dt_start
         else
            dt_safe = q_dt(min(k, 3))
         end if
         if (k == 1) dt_start = dt_safe
         if (k == 1 .and. present(start_bound)) start_bound = dt_safe
         if (k <= 2) then
            if (.not. h/max_dt_over_limit > dt_safe*rescale) cycle
         else
            if (.not. h > dt_safe*rescale) cycle
         end if
         call limit_of(states(k), dt_safe, f_hz, zeta)
         dt_safe = dt_safe*rescale
         if (k <= 2) then
            if (.not. h/max_dt_over_limit > dt_safe) cycle
         else
            if (.not. (h > dt_safe .and. zeta >= damped_ratio)) cycle
         end if
         call part_of(states(k), part)
         if (k <= 2) then
            call fatal_error(err, 'dt = '//str(model%run%dt)//' s is more than '//str(max_dt_over_limit)// &
                             ' times '//limit_name//' '//str(dt_safe, 4)//' s of '// &
                             trim(state_text(k))//' ('//mode_text(f_hz, zeta, omega)//'), set by '//part// &
                             ': any excitation of that mode would grow by 1e12 or more per step. Take dt below '// &
                             str(dt_safe, 4)//' s, or check the deck for a stiffness, damping, radius or inertia '// &
                             'out of proportion (a unit slip?)', err_input)
         else
            call fatal_error(err, 'dt = '//str(model%run%dt)//' s is above '//limit_name//' '// &
                             str(dt_safe, 4)//' s of '//trim(state_text(k))//' ('// &
                             mode_text(f_hz, zeta, omega)//'), set by '//part//'. That mode is damped, so '// &
                             'every step beyond the limit amplifies it (no wrong answer is given with exit 0 '// &
                             'instead, D-55): take dt below '//str(dt_safe, 4)//' s'// &
                             thesis_note(name == 'rk4-thesis' .and. states(k)%contact == lin_contact_closed)// &
                             ", or use integrator = 'cvode-bdf' (implicit: its step has no stability limit)"// &
                             gentle_hint(part), err_input)
         end if
         return
      end do
   contains
      subroutine limit_of(state, dt_lim, f, z)
         type(lin_state_t), intent(in) :: state
         real(wp), intent(out) :: dt_lim, f, z
         type(model_t) :: tmp
         type(error_t), allocatable :: lim_err
         tmp = model
         f = 0.0_wp; z = 0.0_wp
         call rk4_dt_limit(tmp, state, dt_lim, omega, lim_err, freq_hz=f, damping_ratio=z)
         if (allocated(lim_err)) dt_lim = huge(1.0_wp)
      end subroutine limit_of
      subroutine part_of(state, text)
         type(lin_state_t), intent(in) :: state
         character(len=:), allocatable, intent(out) :: text
         type(model_t) :: tmp
         real(wp) :: h_part
         tmp = model
         call limiting_part(tmp, state, text, h_part)
      end subroutine part_of
   end subroutine check_fixed_step

   !> rk4-thesis in contact: its step there is dt/10.
   function thesis_note(in_contact) result(text)
      logical, intent(in) :: in_contact
      character(len=:), allocatable :: text
      text = ''
      if (in_contact) text = ' x 10 (rk4-thesis steps dt/10 in contact)'
   end function thesis_note

   !> "the mode at 5690.8 Hz, damping ratio 0.17" or "an overdamped mode, |lambda| = 9.1E6 1/s".
   function mode_text(f_hz, zeta, omega) result(text)
      real(wp), intent(in) :: f_hz, zeta, omega
      character(len=:), allocatable :: text
      character(len=8) :: z
      if (f_hz > 0.0_wp .and. zeta < 1.0_wp) then
         write (z, '(f4.2)') max(zeta, 0.0_wp)
         text = 'the mode at '//str(f_hz, 5)//' Hz, damping ratio '//trim(z)
      else
         text = 'an overdamped mode, |lambda| = '//str(omega, 4)//' 1/s'
      end if
   end function mode_text

   !> The remedy for a yang_sun contact whose damping at the floor velocity sets the limit.
   function gentle_hint(part) result(text)
      character(len=*), intent(in) :: part
      character(len=:), allocatable :: text
      text = ''
      if (index(part, 'contact law') > 0) text = '; if it is a yang_sun contact: one that closes slower than '// &
         'min_approach_velocity gets the damping of that floor (D = 6(1-e)k/[((2e-1)^2+3) V], eq. (3.12)), '// &
         'which grows with the load it then carries: a larger min_approach_velocity (or '// &
         'initial_contact_velocity) lowers it'
   end function gentle_hint

   !> "element 'mesh'" for guard index j of the model.
   function guard_owner(model, j) result(text)
      type(model_t), intent(in) :: model
      integer, intent(in) :: j
      character(len=:), allocatable :: text
      integer :: i
      text = 'guard '//str(j)
      do i = size(model%elements), 1, -1
         if (model%guard_offset(i) < j) then
            text = "element '"//model%elements(i)%e%id//"'"
            return
         end if
      end do
   end function guard_owner

   !> Whether the elements' modes are still those the last `init_modes` set at (t, y),
   !> bit for bit (the step check's, D-183): nothing since changed a mode (an event, a
   !> preload, a rebuilt table unsets model%modes_at), so a run need not set them again.
   logical function modes_kept(model, t, y) result(kept)
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: t, y(:)
      integer :: i
      kept = .false.
      if (.not. allocated(model%modes_at)) return
      if (size(model%modes_at) /= size(y) + 1) return
      if (transfer(model%modes_at(1), 0_i8) /= transfer(t, 0_i8)) return
      do i = 1, size(y)
         if (transfer(model%modes_at(i + 1), 0_i8) /= transfer(y(i), 0_i8)) return
      end do
      kept = .true.
   end function modes_kept
end module trainsim_run_checks
