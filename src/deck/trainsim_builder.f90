!> Deck -> model: reads the &run, &node, &element, &load and &initial groups,
!> validates every field and reports errors with file, line, group and key.
module trainsim_builder
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: string_t, to_lower, str, join
   use trainsim_units, only: make_units
   use trainsim_deck, only: deck_t, deck_group_t
   use trainsim_limits, only: check_magnitude, check_params
   use trainsim_signal, only: signal_t, signal_from_group
   use trainsim_speed_law, only: load_from_group
   use trainsim_motion, only: motion_t, motion_from_group
   use trainsim_registry, only: make_node, make_element, node_type_names, element_type_names
   use trainsim_model, only: model_t, load_t
   use trainsim_element, only: element_t, max_ports
   use trainsim_integrator_registry, only: integrator_names
   use trainsim_id_table, only: id_table_t
   use trainsim_param_list, only: param_list_t
   use trainsim_plausibility, only: check_plausibility
   use trainsim_controller_deck, only: read_controllers, link_controllers
   use trainsim_planetary_deck, only: expand_planetary, mark_share_sets
   implicit none
   private

   public :: build_model, integrator_names, check_run_times
   public :: max_abs_time, max_steps, max_samples

   !> Limits of &run (docs/deck.md): beyond them a run cannot end in reasonable time or
   !> memory, or time itself is not resolved; each is checked by read_run, naming the key.
   real(wp), parameter :: max_abs_time = 1.0e12_wp   !< |t_start|, |t_end| in s (~32 000 years)
   real(wp), parameter :: max_steps = 1.0e12_wp      !< (t_end - t_start)/dt
   real(wp), parameter :: max_samples = 1.0e9_wp     !< output samples: (t_end - t_start)/output_interval
   !> dt must exceed this many units of double-precision spacing at the run's largest |t|,
   !> or t + dt rounds back to t
   real(wp), parameter :: min_dt_spacings = 1.0e3_wp

contains

   !> Build a model from a parsed deck. The deck's text moves into the model
   !> (`deck%text` is deallocated afterwards).
   subroutine build_model(deck, model, err)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      type(id_table_t) :: node_ids   ! node id -> node index, for look-ups in O(1)
      type(string_t) :: groups(8)
      type(param_list_t), allocatable :: np(:), ep(:)   ! params(), asked once for both checks (D-114)
      integer :: i

      ! (not an array constructor of string_t(...): gfortran 12 leaks their strings,
      ! 50 bytes a run of a sweep)
      groups(1)%s = 'run'; groups(2)%s = 'node'; groups(3)%s = 'element'; groups(4)%s = 'load'
      groups(5)%s = 'initial'; groups(6)%s = 'controller'
      groups(7)%s = 'fmu'; groups(8)%s = 'planetary'   ! (&fmu: read by trainsim fmu alone)
      call deck%check_group_names(groups, err, also='sweep (read by trainsim sweep)')
      if (allocated(err)) return
      model%deck_file = deck%file
      call move_alloc(deck%text, model%deck_text)   ! not copied: a deck may be 100 MB
      call read_run(deck, model, err); if (allocated(err)) return
      call expand_planetary(deck, model%units, err); if (allocated(err)) return   ! into &node, &element (D-93)
      call read_nodes(deck, model, node_ids, np, err); if (allocated(err)) return
      call read_elements(deck, model, node_ids, ep, err); if (allocated(err)) return
      call mark_share_sets(deck, model)   ! each stage's sun meshes and ring meshes (D-96)
      call read_loads(deck, model, node_ids, err); if (allocated(err)) return
      call read_controllers(deck, model, node_ids, err); if (allocated(err)) return
      ! &initial before finalize: its tables hold held nodes' angles and speeds (D-114)
      call read_initial(deck, model, node_ids, err); if (allocated(err)) return
      do i = 1, size(model%nodes)   ! a prescribed acceleration starts from the &initial speed
         if (model%speed_of(i) /= 0) model%speeds(model%speed_of(i))%w0 = model%nodes(i)%n%omega0
      end do
      call model%finalize()
      call link_controllers(model)   ! (the sensors' state offsets: finalize's)
      do i = 1, size(deck%groups)
         associate (g => deck%groups(i))
            if (g%named('run')) call g%check_unused(err, 'the &run group')
            if (g%named('load')) call g%check_unused(err, 'a &load group')
            if (g%named('initial')) call g%check_unused(err, 'an &initial group')
         end associate
         if (allocated(err)) return
      end do
      allocate (model%warnings(0))
      call check_plausibility(deck, model, model%warnings, err, ep, np)
      if (.not. allocated(err)) call move_alloc(ep, model%element_params)   ! every element's, kept (D-175)
   end subroutine build_model

   subroutine read_run(deck, model, err)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(inout) :: model
      type(error_t), allocatable, intent(out) :: err
      integer :: n, i
      character(len=:), allocatable :: units_name, jac_kind
      real(wp) :: tmp

      n = deck%count_groups('run')
      if (n /= 1) then
         call fatal_error(err, deck%file//': error: the deck must have exactly one &run group, found '//str(n), err_input)
         return
      end if
      do i = 1, size(deck%groups)
         if (deck%groups(i)%named('run')) exit
      end do
      associate (g => deck%groups(i), r => model%run)
         call g%get_string('title', model%title, err, default=''); if (allocated(err)) return
         call g%get_string('units', units_name, err, default='in-lbf-s'); if (allocated(err)) return
         call make_units(units_name, model%units, err)
         if (allocated(err)) then
            err%message = g%where('units')//': error: '//err%message
            return
         end if
         call g%get_real('t_start', r%t_start, err, default=0.0_wp); if (allocated(err)) return
         call g%get_real('t_end', r%t_end, err); if (allocated(err)) return
         call g%get_real('dt', r%dt, err); if (allocated(err)) return
         call g%get_string('integrator', r%integrator, err, default='rk4'); if (allocated(err)) return
         r%integrator = to_lower(r%integrator)
         call g%get_string('output', r%output, err, default=''); if (allocated(err)) return
         call g%get_real('output_interval', r%output_interval, err, default=0.0_wp); if (allocated(err)) return
         tmp = r%rtol; call g%get_real('rtol', r%rtol, err, default=tmp); if (allocated(err)) return
         tmp = r%atol_angle; call g%get_real('atol_angle', r%atol_angle, err, default=tmp); if (allocated(err)) return
         tmp = r%atol_speed; call g%get_real('atol_speed', r%atol_speed, err, default=tmp); if (allocated(err)) return
         tmp = r%atol_current; call g%get_real('atol_current', r%atol_current, err, default=tmp); if (allocated(err)) return
         call g%get_real('max_step', r%max_step, err, default=0.0_wp); if (allocated(err)) return
         call g%get_real('event_tol', r%event_tol, err, default=0.0_wp); if (allocated(err)) return
         call g%get_real('settle_time', r%settle_time, err, default=0.0_wp); if (allocated(err)) return
         call g%get_real('settle_tol', r%settle_tol, err, default=0.0_wp); if (allocated(err)) return
         call g%get_real('settle_period', r%settle_period, err, default=0.0_wp); if (allocated(err)) return
         call g%get_real('settle_max_time', r%settle_max_time, err, default=0.0_wp); if (allocated(err)) return
         call g%get_logical('track_energy', r%track_energy, err, default=.true.); if (allocated(err)) return
         call g%get_real('energy_check', r%energy_check, err, default=0.1_wp); if (allocated(err)) return
         if (.not. (r%energy_check >= 0.0_wp .and. r%energy_check <= 1.0_wp)) then
            call fatal_error(err, g%where('energy_check')//': error: energy_check must be in [0, 1] (a fraction of '// &
                             'the energy scale; 0 turns the check off), got '//str(r%energy_check), err_input)
            return
         end if
         call g%get_int('compression', r%compression, err, default=0); if (allocated(err)) return
         if (r%compression < 0 .or. r%compression > 9) then
            call fatal_error(err, g%where('compression')//': error: compression must be a zlib level in [0, 9] '// &
                             '(0: none), got '//str(r%compression), err_input)
            return
         end if
         call g%get_string('jacobian', jac_kind, err, default='analytic'); if (allocated(err)) return
         select case (to_lower(jac_kind))
         case ('analytic'); r%analytic_jacobian = .true.
         case ('difference_quotient', 'dq'); r%analytic_jacobian = .false.
         case default
            call fatal_error(err, g%where('jacobian')//": error: unknown jacobian '"//jac_kind// &
                             "'; valid: analytic (default), difference_quotient", err_input)
            return
         end select
         call g%get_string('initial_state', jac_kind, err, default='deck'); if (allocated(err)) return
         select case (to_lower(jac_kind))
         case ('deck'); r%preload = .false.
         case ('preload'); r%preload = .true.
         case default
            call fatal_error(err, g%where('initial_state')//": error: unknown initial_state '"//jac_kind// &
                             "'; valid: deck (default: the &initial angles), preload (the static wind-up)", err_input)
            return
         end select

         call check_run(g, r, err)
      end associate
   end subroutine read_run

   !> The values of &run read by read_run against each other and the limits of &run: the
   !> times, the step, the output interval, the tolerances, the settling keys, the
   !> integrator's name; output_interval is capped at the run's length.
   subroutine check_run(g, r, err)
      use trainsim_model, only: run_settings_t
      type(deck_group_t), intent(inout) :: g
      type(run_settings_t), intent(inout) :: r
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: blame
      type(string_t), allocatable :: valid(:)
      logical :: ok
      real(wp) :: span
      integer :: n

      ! Every real is finite here (the deck reader rejects nan, inf and overflow).
      ! Limits divide by a constant, never by a deck value, so no check can overflow.
      span = 0.0_wp
      if (abs(r%t_start) <= max_abs_time .and. abs(r%t_end) <= max_abs_time) span = r%t_end - r%t_start
      if (.not. r%dt > 0.0_wp) then
         call fatal_error(err, g%where('dt')//': error: time step dt must be > 0, got '//str(r%dt), err_input)
      else if (abs(r%t_start) > max_abs_time) then
         call fatal_error(err, g%where('t_start')//': error: t_start = '//str(r%t_start)//' is beyond the '// &
                          'time limit of +-'//str(max_abs_time)//' s', err_input)
      else if (abs(r%t_end) > max_abs_time) then
         call fatal_error(err, g%where('t_end')//': error: t_end = '//str(r%t_end)//' is beyond the '// &
                          'time limit of +-'//str(max_abs_time)//' s', err_input)
      else if (.not. r%t_end > r%t_start) then
         call fatal_error(err, g%where('t_end')//': error: t_end must be later than t_start ('//str(r%t_start)// &
                          '), got '//str(r%t_end), err_input)
      else if (span/max_steps > r%dt) then
         call fatal_error(err, g%where('dt')//': error: time step dt = '//str(r%dt)//' s would take more than '// &
                          '1e12 steps over the run of '//str(span)//' s', err_input)
      else if (r%dt > span) then
         call fatal_error(err, g%where('dt')//': error: time step dt = '//str(r%dt)// &
                          ' is longer than the run (t_end - t_start = '//str(span)//')', err_input)
      else if (r%dt < min_dt_spacings*spacing(max(abs(r%t_start), abs(r%t_end)))) then
         call fatal_error(err, g%where('dt')//': error: time step dt = '//str(r%dt)//' s is too fine for '// &
                          'the times of the run: near t = '//str(max(abs(r%t_start), abs(r%t_end)))// &
                          ' s double precision resolves only '//str(spacing(max(abs(r%t_start), abs(r%t_end))))// &
                          ' s (dt must exceed 1000 times that; shift t_start towards 0)', err_input)
      else if (.not. r%output_interval >= 0.0_wp) then
         call fatal_error(err, g%where('output_interval')//': error: output_interval must be >= 0, got '// &
                          str(r%output_interval), err_input)
      else if (r%output_interval > 0.0_wp .and. span/max_samples > r%output_interval) then
         call fatal_error(err, g%where('output_interval')//': error: output_interval = '// &
                          str(r%output_interval)//' s would write more than 1e9 samples over the run of '// &
                          str(span)//' s (the output limit); raise it', err_input)
      else if (r%output_interval == 0.0_wp .and. span/max_samples > r%dt) then
         call fatal_error(err, g%where('output_interval')//': error: output_interval = 0 stores a sample '// &
                          'every dt = '//str(r%dt)//' s: more than 1e9 samples over the run of '//str(span)// &
                          ' s (the output limit); give an output_interval of at least '// &
                          str(span/max_samples)//' s', err_input)
      else if (.not. (r%rtol > 0.0_wp .and. r%rtol < 1.0_wp)) then
         call fatal_error(err, g%where('rtol')//': error: rtol must be in (0, 1), got '//str(r%rtol), err_input)
      else if (r%max_step > 0.0_wp .and. span/max_steps > r%max_step) then
         call fatal_error(err, g%where('max_step')//': error: max_step = '//str(r%max_step)//' s would need '// &
                          'more than 1e12 steps over the run of '//str(span)//' s: raise it (0 chooses it from '// &
                          'the highest frequency)', err_input)
      end if
      if (allocated(err)) return
      call g%require_positive('atol_angle', r%atol_angle, err)
      call g%require_positive('atol_speed', r%atol_speed, err)
      call g%require_positive('atol_current', r%atol_current, err)
      call g%require_nonnegative('max_step', r%max_step, err)
      call g%require_nonnegative('event_tol', r%event_tol, err)
      call g%require_nonnegative('settle_time', r%settle_time, err)
      call g%require_nonnegative('settle_period', r%settle_period, err)
      call g%require_nonnegative('settle_max_time', r%settle_max_time, err)
      if (allocated(err)) return
      if (.not. (r%settle_tol >= 0.0_wp .and. r%settle_tol < 1.0_wp)) then
         call fatal_error(err, g%where('settle_tol')//': error: settle_tol must be in [0, 1) (0: no settling '// &
                          'check), got '//str(r%settle_tol), err_input)
         return
      end if
      call check_run_times(r, blame, err)
      if (allocated(err)) then
         err%message = g%where(blame)//': error: '//err%message
         return
      end if
      ! an interval longer than the run means its first and last sample only: say so
      ! with the run's length, which keeps every sample count derived from it small
      r%output_interval = min(r%output_interval, span)
      valid = integrator_names()
      ok = .false.
      do n = 1, size(valid)
         if (valid(n)%s == r%integrator) ok = .true.
      end do
      if (.not. ok) then
         call fatal_error(err, g%where('integrator')//": error: unknown integrator '"//r%integrator// &
                          "'; valid integrators are: "//join(valid, ', '), err_input)
         return
      end if
   end subroutine check_run

   !> The end of the run's metrics window and of the settling budget against the limits
   !> of &run, once t_end and settle_time are known (read_run, and again after the derived
   !> parameters settle_cycles, measure_cycles, settle_max_cycles, which set them):
   !> settle_time (and settle_max_time) must leave a measured window before t_end, and
   !> the longest run (t_end, or with settling the budget plus the measured window) must
   !> be within the time, step and sample limits. `blame` names the &run key to blame; the
   !> message carries no location (the caller adds the deck line or the --set argument).
   subroutine check_run_times(r, blame, err)
      use trainsim_model, only: run_settings_t, settle_budget
      type(run_settings_t), intent(in) :: r
      character(len=:), allocatable, intent(out) :: blame
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: span, t_last
      character(len=:), allocatable :: key
      blame = ''
      if (.not. (abs(r%t_end) <= max_abs_time)) then
         call refuse('t_end', 't_end = '//str(r%t_end)//' is beyond the time limit of +-'//str(max_abs_time)//' s')
         return
      end if
      if (.not. (r%settle_time < r%t_end - r%t_start)) then
         call refuse('settle_time', 'settle_time = '//str(r%settle_time)//' s reaches the end of the run (t_end - '// &
                     't_start = '//str(r%t_end - r%t_start)//' s): no time would be left to measure the metrics in; '// &
                     'take a settle_time below that or a later t_end')
         return
      end if
      if (r%settle_tol > 0.0_wp .and. r%settle_max_time > 0.0_wp .and. r%settle_max_time < r%settle_time) then
         call refuse('settle_max_time', 'settle_max_time = '//str(r%settle_max_time)//' s is shorter than '// &
                     'settle_time = '//str(r%settle_time)//' s (the least settling)')
         return
      end if
      t_last = r%t_end
      key = 't_end'
      if (r%settle_tol > 0.0_wp) then
         t_last = r%t_end + settle_budget(r) - r%settle_time
         key = 'settle_max_time'
      end if
      if (.not. (abs(t_last) <= max_abs_time)) then
         call refuse(key, 'the run may last until t = '//str(t_last)//' s (the settling budget plus the measured '// &
                     'window), beyond the time limit of +-'//str(max_abs_time)//' s')
         return
      end if
      span = t_last - r%t_start
      if (span/max_steps > r%dt) then
         call refuse(key, 'time step dt = '//str(r%dt)//' s would take more than 1e12 steps over the run of '// &
                     str(span)//' s, beyond the time limit')
      else if (r%output_interval > 0.0_wp .and. span/max_samples > r%output_interval) then
         call refuse(key, 'output_interval = '//str(r%output_interval)//' s would write more than 1e9 samples '// &
                     'over the run of '//str(span)//' s, beyond the time limit of the output')
      else if (r%output_interval == 0.0_wp .and. span/max_samples > r%dt) then
         call refuse(key, 'output_interval = 0 stores a sample every dt = '//str(r%dt)//' s: more than 1e9 '// &
                     'samples over the run of '//str(span)//' s, beyond the time limit of the output')
      end if
   contains
      subroutine refuse(k, text)
         character(len=*), intent(in) :: k, text
         call fatal_error(err, text, err_input)
         blame = k
      end subroutine refuse
   end subroutine check_run_times

   subroutine read_nodes(deck, model, node_ids, np, err)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(inout) :: model
      type(id_table_t), intent(inout) :: node_ids
      type(param_list_t), allocatable, intent(out) :: np(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: i, k, j
      character(len=:), allocatable :: id, tname
      logical :: has_id

      allocate (model%nodes(deck%count_groups('node'))); allocate (np(size(model%nodes)))
      if (size(model%nodes) == 0) then
         call fatal_error(err, deck%file//': error: the deck has no &node group (a train needs at least one node)', &
                          err_input)
         return
      end if
      call node_ids%reserve(size(model%nodes))
      k = 0
      do i = 1, size(deck%groups)
         if (.not. deck%groups(i)%named('node')) cycle
         k = k + 1
         associate (g => deck%groups(i))
            call g%get_optional_string('id', id, has_id, err); if (allocated(err)) return
            if (.not. has_id) id = 'n'//str(k); call g%get_string('type', tname, err); if (allocated(err)) return
            call node_ids%insert(id, k, j)
            if (j /= 0) then
               call fatal_error(err, g%where('id')//": error: duplicate node id '"//id//"' (already used by node "// &
                                str(j)//')', err_input)
               return
            end if
            call make_node(tname, model%nodes(k)%n)
            if (.not. allocated(model%nodes(k)%n)) then
               call fatal_error(err, g%where('type')//": error: unknown node type '"//tname// &
                                "'; valid node types are: "//join(node_type_names(), ', '), err_input)
               return
            end if
            call move_alloc(id, model%nodes(k)%n%id)   ! (moved, not copied: D-175)
            model%nodes(k)%n%origin = g%where()
            call model%nodes(k)%n%configure(g, model%units, err); if (allocated(err)) return
            np(k) = model%nodes(k)%n%params()
            call check_params(g, np(k), err); if (allocated(err)) return
            if (.not. g%all_used()) call g%check_unused(err, "node type '"//model%nodes(k)%n%type_name//"'"); if (allocated(err)) return
         end associate
      end do
   end subroutine read_nodes

   subroutine read_elements(deck, model, node_ids, ep, err)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(inout) :: model
      type(id_table_t), intent(in) :: node_ids
      type(param_list_t), allocatable, intent(out) :: ep(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: i, k, j, nn
      character(len=:), allocatable :: id, tname, lid, rid
      logical :: has_id, has_left, has_right
      type(id_table_t) :: element_ids

      allocate (model%elements(deck%count_groups('element'))); allocate (ep(size(model%elements)))
      nn = size(model%nodes)
      call element_ids%reserve(size(model%elements))
      k = 0
      do i = 1, size(deck%groups)
         if (.not. deck%groups(i)%named('element')) cycle
         k = k + 1
         associate (g => deck%groups(i))
            call g%get_optional_string('id', id, has_id, err); if (allocated(err)) return
            if (.not. has_id) id = 'e'//str(k); call g%get_string('type', tname, err); if (allocated(err)) return
            call element_ids%insert(id, k, j)
            if (j /= 0) then
               call fatal_error(err, g%where('id')//": error: duplicate element id '"//id//"'", err_input)
               return
            end if
            call make_element(tname, model%elements(k)%e)
            if (.not. allocated(model%elements(k)%e)) then
               call fatal_error(err, g%where('type')//": error: unknown element type '"//tname// &
                                "'; valid element types are: "//join(element_type_names(), ', '), err_input)
               return
            end if
            associate (e => model%elements(k)%e)
               call move_alloc(id, e%id)   ! (moved, not copied: D-175)
               e%origin = g%where()
               ! serial chain by default (TRAIN's numbering): element k joins nodes k and k+1,
               ! taken by index (0 beyond the last node: the message names '' as before; D-157)
               call g%get_optional_string('left', lid, has_left, err); if (allocated(err)) return
               call g%get_optional_string('right', rid, has_right, err); if (allocated(err)) return
               e%left = merge(k, 0, k <= nn); e%right = merge(k + 1, 0, k + 1 <= nn)
               if (has_left) e%left = node_ids%get(lid); if (has_right) e%right = node_ids%get(rid)
               if (e%left == 0) then
                  call fatal_error(err, g%where('left')//": error: element '"//e%id//"' joins node '"//lid// &
                                   "', which is not defined"//trim(merge(' (give left = ...)', '                  ', &
                                   len(lid) == 0)), err_input)
                  return
               end if
               if (e%right == 0) then
                  call fatal_error(err, g%where('right')//": error: element '"//e%id//"' joins node '"//rid// &
                                   "', which is not defined"//trim(merge(' (give right = ...)', '                   ', &
                                   len(rid) == 0)), err_input)
                  return
               end if
               if (e%left == e%right) then
                  if (.not. has_left) lid = model%nodes(e%left)%n%id   ! (the default, named)
                  call fatal_error(err, g%where('right')//": error: element '"//e%id//"' joins node '"//lid// &
                                   "' to itself", err_input)
                  return
               end if
               call e%configure(g, model%units, err); if (allocated(err)) return
               call read_ports(g, e, node_ids, err); if (allocated(err)) return
               ep(k) = e%params()
               call check_params(g, ep(k), err); if (allocated(err)) return
               if (.not. g%all_used()) call g%check_unused(err, "element type '"//e%type_name//"'"); if (allocated(err)) return
            end associate
         end associate
      end do
   end subroutine read_elements

   !> The further ports an n-port element named in `configure` (its port_keys,
   !> D-73, e.g. a gear pair's `carrier`): each key's node, which must be
   !> defined and none of the element's other ports.
   subroutine read_ports(g, e, node_ids, err)
      type(deck_group_t), intent(inout) :: g
      class(element_t), intent(inout) :: e
      type(id_table_t), intent(in) :: node_ids
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: pid
      integer :: k, j
      if (.not. allocated(e%port_keys)) return   ! two ports (n_ports): no empty lists (D-157)
      if (size(e%port_keys) > max_ports - 2) error stop 'read_ports: an element type declares more than max_ports ports'
      if (allocated(e%more_ports)) deallocate (e%more_ports)
      allocate (e%more_ports(size(e%port_keys)))
      e%more_ports = 0
      do k = 1, size(e%port_keys)
         associate (key => e%port_keys(k)%s)
            call g%get_string(key, pid, err); if (allocated(err)) return
            e%more_ports(k) = node_ids%get(pid)
            if (e%more_ports(k) == 0) then
               call fatal_error(err, g%where(key)//": error: element '"//e%id//"' has "//key//" = '"//pid// &
                                "', a node which is not defined", err_input)
               return
            end if
            do j = 1, k + 1
               if (e%port(j) /= e%more_ports(k)) cycle
               call fatal_error(err, g%where(key)//": error: element '"//e%id//"' has "//key//" = '"//pid// &
                                "', which is already its "//trim(port_name(j))//" node; an element's ports are "// &
                                'distinct nodes (give the '//key//' a node of its own)', err_input)
               return
            end do
         end associate
      end do
   contains
      !> The deck key of port j.
      function port_name(j) result(name)
         integer, intent(in) :: j
         character(len=:), allocatable :: name
         select case (j)
         case (1); name = 'left'
         case (2); name = 'right'
         case default; name = e%port_keys(j - 2)%s
         end select
      end function port_name
   end subroutine read_ports

   subroutine read_loads(deck, model, node_ids, err)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(inout) :: model
      type(id_table_t), intent(in) :: node_ids
      type(error_t), allocatable, intent(out) :: err
      integer :: i, inode, nloads, nspeeds
      character(len=:), allocatable :: nid, quantity
      type(signal_t) :: sig
      type(load_t), allocatable :: loads(:)
      type(motion_t), allocatable :: speeds(:)

      ! at most one load or speed per &load group: size once, trim at the end
      nloads = deck%count_groups('load')
      allocate (loads(nloads), speeds(nloads), model%speed_of(size(model%nodes)))
      nloads = 0
      nspeeds = 0
      model%speed_of = 0
      do i = 1, size(deck%groups)
         if (.not. deck%groups(i)%named('load')) cycle
         associate (g => deck%groups(i))
            call g%get_string('node', nid, err); if (allocated(err)) return
            inode = node_ids%get(nid)
            if (inode == 0) then
               call fatal_error(err, g%where('node')//": error: load on node '"//nid//"', which is not defined", &
                                err_input)
               return
            end if
            call g%get_string('quantity', quantity, err, default='torque'); if (allocated(err)) return
            quantity = to_lower(quantity)
            select case (quantity)
            case ('torque')
               nloads = nloads + 1
               call load_from_group(g, inode, loads(nloads), err); if (allocated(err)) return
            case ('speed', 'angle', 'acceleration')
               call signal_from_group(g, sig, err); if (allocated(err)) return
               if (.not. model%nodes(inode)%n%can_prescribe_speed()) then
                  call fatal_error(err, g%where('quantity')//": error: node '"//nid//"' of type '"// &
                                   model%nodes(inode)%n%type_name//"' cannot have a prescribed "//quantity// &
                                   " (only 'inertia' nodes can)", err_input)
                  return
               end if
               if (model%speed_of(inode) /= 0) then
                  call fatal_error(err, g%where('node')//": error: node '"//nid//"' already has a prescribed "// &
                                   "speed, angle or acceleration", err_input)
                  return
               end if
               nspeeds = nspeeds + 1
               call motion_from_group(g, quantity, sig, speeds(nspeeds), err); if (allocated(err)) return
               ! a prescribed angle starts at its value at 0 (the &initial angle overrides it)
               if (quantity == 'angle') model%nodes(inode)%n%theta0 = sig%value(0.0_wp)
               model%speed_of(inode) = nspeeds
            case ('voltage')
               call signal_from_group(g, sig, err); if (allocated(err)) return
               call model%nodes(inode)%n%attach_voltage(sig, g%where('quantity'), err); if (allocated(err)) return
            case default
               call fatal_error(err, g%where('quantity')//": error: unknown load quantity '"//quantity// &
                                "'; valid quantities are: torque, speed, angle, acceleration, voltage", err_input)
               return
            end select
         end associate
      end do
      model%loads = loads(1:nloads)
      model%speeds = speeds(1:nspeeds)
   end subroutine read_loads

   subroutine read_initial(deck, model, node_ids, err)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(inout) :: model
      type(id_table_t), intent(in) :: node_ids
      type(error_t), allocatable, intent(out) :: err
      integer :: i, inode, j
      character(len=:), allocatable :: nid
      real(wp) :: speed
      logical, allocatable :: seen(:)
      real(wp) :: tmp

      allocate (seen(size(model%nodes)))
      seen = .false.
      ! 'all' groups first, so that per-node groups override them
      do i = 1, size(deck%groups)
         if (.not. deck%groups(i)%named('initial')) cycle
         associate (g => deck%groups(i))
            call g%get_string('node', nid, err); if (allocated(err)) return
            if (to_lower(nid) /= 'all') cycle
            call g%get_real('speed', speed, err); if (allocated(err)) return
            call check_magnitude(g, 'speed', speed, err); if (allocated(err)) return
            do j = 1, size(model%nodes)
               if (.not. model%nodes(j)%n%is_fixed()) model%nodes(j)%n%omega0 = speed
            end do
         end associate
      end do
      do i = 1, size(deck%groups)
         if (.not. deck%groups(i)%named('initial')) cycle
         associate (g => deck%groups(i))
            call g%get_string('node', nid, err); if (allocated(err)) return
            if (to_lower(nid) == 'all') cycle
            inode = node_ids%get(nid)
            if (inode == 0) then
               call fatal_error(err, g%where('node')//": error: initial conditions for node '"//nid// &
                                "', which is not defined", err_input)
               return
            end if
            if (seen(inode)) then
               call fatal_error(err, g%where('node')//": error: node '"//nid//"' has two &initial groups", err_input)
               return
            end if
            seen(inode) = .true.
            associate (nd => model%nodes(inode)%n)
               tmp = nd%theta0; call g%get_real('angle', nd%theta0, err, default=tmp); if (allocated(err)) return
               tmp = nd%omega0; call g%get_real('speed', nd%omega0, err, default=tmp); if (allocated(err)) return
               call check_magnitude(g, 'angle', nd%theta0, err)
               call check_magnitude(g, 'speed', nd%omega0, err); if (allocated(err)) return
               call nd%set_initial_extra(g, err); if (allocated(err)) return
               if (nd%is_fixed() .and. nd%omega0 /= 0.0_wp) then
                  call fatal_error(err, g%where('speed')//": error: node '"//nid//"' is fixed; its speed must be 0", &
                                   err_input)
                  return
               end if
            end associate
         end associate
      end do
   end subroutine read_initial
end module trainsim_builder
