!> Terminal output: the end-of-run summary and the modes table.
module trainsim_report
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_modes, only: modes_t
   use trainsim_sink, only: param_list_t
   use trainsim_element, only: element_t
   use trainsim_strings, only: str, string_t
   use trainsim_text_out, only: text_out_t
   implicit none
   private

   public :: print_summary, print_modes, print_parameters

contains

   !> Element parameters as used (derived values included; a choice key by its word),
   !> and, with initial_state = 'preload', the initial angles the preload found.
   subroutine print_parameters(model, unit)
      type(model_t), intent(in) :: model
      integer, intent(in) :: unit
      integer :: i, w
      type(text_out_t) :: out   ! the lines of '(4x,aW,1x,es15.7)' and '(4x,aW,1x,a15)'
      logical :: kept
      out%unit = unit
      kept = .false.   ! the builder's lists, not asked again (D-175)
      if (allocated(model%element_params)) kept = size(model%element_params) == size(model%elements)
      do i = 1, size(model%elements)
         if (kept) then
            call print_element(model%element_params(i))
         else
            call print_element(model%elements(i)%e%params())
         end if
      end do
      call out%flush()
      if (model%run%preload) then
         w = id_width(model, nodes=.true.)
         write (unit, '(a)') 'initial angles from the static preload (initial_state = ''preload''), rad:'
         do i = 1, size(model%nodes)
            associate (nd => model%nodes(i)%n)
               if (nd%nstates() == 0 .or. model%is_held(i)) cycle
               write (unit, '(4x,a'//str(w)//',es18.9)') nd%id, nd%theta0
            end associate
         end do
      end if
   contains
      !> Element i's lines.
      subroutine print_element(p)
         type(param_list_t), intent(in) :: p
         integer :: j, w
         if (size(p%names) == 0) return
         call out%a('element ', 0)   ! (piece by piece: no concatenated temporary a line)
         call out%a(model%elements(i)%e%id, 0)
         call out%a(' (', 0)
         call out%a(model%elements(i)%e%type_name, 0)
         call out%a('):', 0)
         call out%end_line()
         w = 24
         do j = 1, size(p%names)
            w = max(w, len(p%names(j)%s))
         end do
         do j = 1, size(p%names)
            call out%x(4)
            call out%a(p%names(j)%s, w)
            call out%x(1)
            if (has_word(p, j)) then
               call out%a(p%words(j)%s, 15)
            else
               call out%es(p%values(j), 15, 7)
            end if
            call out%end_line()
         end do
      end subroutine print_element
   end subroutine print_parameters

   !> Whether parameter j of p is printed as a word.
   pure logical function has_word(p, j)
      type(param_list_t), intent(in) :: p
      integer, intent(in) :: j
      has_word = .false.
      if (.not. allocated(p%words)) return
      if (j > size(p%words)) return
      has_word = len(p%words(j)%s) > 0
   end function has_word

   !> Column width that holds every node id (nodes) or element id, at least 12.
   pure integer function id_width(model, nodes) result(w)
      type(model_t), intent(in) :: model
      logical, intent(in) :: nodes
      integer :: i
      w = 12
      if (nodes) then
         do i = 1, size(model%nodes)
            w = max(w, len(model%nodes(i)%n%id))
         end do
      else
         do i = 1, size(model%elements)
            w = max(w, len(model%elements(i)%e%id))
         end do
      end if
   end function id_width

   !> The unit of element e's displacement in this unit system.
   function disp_unit(model, e) result(u)
      type(model_t), intent(in) :: model
      class(element_t), intent(in) :: e
      character(len=:), allocatable :: u
      u = e%displacement_unit()
      if (u == 'length') u = model%units%length
   end function disp_unit

   !> A fixed-point number with its leading zero (f0.d writes .174).
   function fixed(x, d) result(s)
      real(wp), intent(in) :: x
      integer, intent(in) :: d
      character(len=:), allocatable :: s
      character(len=40) :: buf
      write (buf, '(f0.'//str(d)//')') x
      s = trim(adjustl(buf))
      if (s(1:1) == '.') s = '0'//s
      if (len(s) > 1) then
         if (s(1:2) == '-.') s = '-0'//s(2:)
      end if
   end function fixed

   !> What an engineer reads after a run.
   subroutine print_summary(model, res, unit)
      type(model_t), intent(in) :: model
      type(run_result_t), intent(in) :: res
      integer, intent(in) :: unit
      integer :: i, j, w, wn, ns
      character(len=:), allocatable :: we, wt
      logical :: motors
      type(text_out_t) :: out
      type(string_t), allocatable :: units(:)   ! the distinct displacement units, in order met
      integer, allocatable :: du(:)   ! each element's, asked once: its index in units
      w = id_width(model, nodes=.false.)
      we = str(w)
      ns = 12   ! the type column
      do i = 1, size(model%elements)
         ns = max(ns, len(model%elements(i)%e%type_name))
      end do
      wt = str(ns)
      write (unit, '(a)') '--- run summary ---'
      write (unit, '(a,i0,a,i0,a)') 'steps ', res%stats%steps, ', RHS evaluations ', res%stats%rhs_evals, &
         ', wall time '//fixed(res%stats%wall_time, 3)//' s'
      write (unit, '(a,i0,a,es12.5,a)') 'events ', res%stats%events, ', final time ', res%t_final, ' s'
      select case (res%stats%settle_status)
      case (1)
         write (unit, '(a,i0,a,es12.5,a,i0,a)') 'settled: the state repeats after ', res%stats%settle_k, &
            ' period(s) to settle_tol; metrics from t = ', res%stats%t_metrics, ' s (', res%stats%settle_periods, &
            ' settle periods)'
      case (2)
         write (unit, '(a,i0,a)') 'NOT SETTLED: the state did not repeat to settle_tol within settle_max_time (', &
            res%stats%settle_periods, ' settle periods); the metrics below are of a transient'
      case (3)
         write (unit, '(a)') 'settled by settle_time: the state repeats from one settle period to the next to 1e-3'
      case (4)
         write (unit, '(a,i0,a)') 'NOT SETTLED by settle_time (', res%stats%settle_periods, ' settle periods): '// &
            'the state does not repeat from one period to the next to 1e-3; the metrics below are of a '// &
            'transient. Set &run settle_tol (e.g. 1e-5) to settle until periodic'
      end select
      if (model%run%track_energy) write (unit, '(a,es10.3,a,es10.3,a)') 'energy balance: max |residual| ', &
         res%energy_residual_max, ' (energy scale ', res%energy_scale, ' '//model%units%torque//')'
      write (unit, '(a)') 'element extremes (torque on the right node in '//model%units%torque// &
         '; displacement in the unit of its column; peak force in '//model%units%force// &
         ', approach velocity V_i in '//model%units%length//'/s):'
      write (unit, '(a'//we//',1x,a'//wt//',4a15,a7,a9,a13,a15,a8)') 'element', 'type', 'torque min', 'torque max', &
         'disp min', 'disp max', 'unit', 'impacts', 'max V_i', 'max peak F', 'open %'
      out%unit = unit
      allocate (du(size(model%elements)), units(0))
      do i = 1, size(model%elements)   ! '(aWE,1x,aWT,4es15.6,a7,i9,es13.4,es15.6,f8.2)'
         associate (e => model%elements(i)%e, m => res%el(i))
            du(i) = unit_index(units, disp_unit(model, e))
            call out%a(e%id, w)
            call out%x(1)
            call out%a(e%type_name, ns)
            call out%es(m%torque_min, 15, 6)
            call out%es(m%torque_max, 15, 6)
            call out%es(m%disp_min, 15, 6)
            call out%es(m%disp_max, 15, 6)
            call out%a(units(du(i))%s, 7)
            call out%i(m%impacts, 9)
            call out%es(m%max_approach_velocity, 13, 4)
            call out%es(m%max_peak_force, 15, 6)
            call out%f(100.0_wp*m%time_out_of_contact/max(res%t_final - res%stats%t_metrics, tiny(1.0_wp)), 8, 2)
            call out%end_line()
         end associate
      end do
      call out%a('peak-to-peak displacement after the settling (range max-min; mean swing between peaks):', 0)
      call out%end_line()
      do i = 1, size(model%elements)   ! '(aWE,2es15.6,a,i0,a)'
         associate (e => model%elements(i)%e, m => res%el(i))
            call out%a(e%id, w)
            call out%es(m%p2p_range, 15, 6)
            call out%es(m%p2p_mean, 15, 6)
            call out%x(1)   ! (piece by piece: no concatenated temporary a line)
            call out%a(units(du(i))%s, 0)
            call out%a('  (', 0)
            call out%i(m%p2p_swings, 0)
            call out%a(' swings)', 0)
            call out%end_line()
         end associate
      end do
      if (allocated(model%share_set)) then
         if (any(model%share_set > 0)) then
            call out%a('load-sharing factor of each planetary stage''s sun meshes and ring meshes (N max F / sum F):', 0)
            call out%end_line()
            do i = 1, size(model%elements)   ! '(aWE,f12.6)'
               if (model%share_set(i) == 0) cycle
               call out%a(model%elements(i)%e%id, w)
               call out%f(res%el(i)%load_sharing, 12, 6)
               call out%end_line()
            end do
         end if
      end if
      if (any(res%el%static_force /= 0.0_wp)) then
         call out%a('dynamic factor Kv (max dynamic / static mesh force) and the loaded static TE (mean, p-p):', 0)
         call out%end_line()
         do i = 1, size(model%elements)   ! '(aWE,f12.6,3es15.6)'
            if (res%el(i)%static_force == 0.0_wp) cycle
            call out%a(model%elements(i)%e%id, w)
            call out%f(res%el(i)%kv, 12, 6)
            call out%es(res%el(i)%static_force, 15, 6)
            call out%es(res%el(i)%static_te_mean, 15, 6)
            call out%es(res%el(i)%static_te_p2p, 15, 6)
            call out%x(1)
            call out%a(units(du(i))%s, 0)
            call out%end_line()
         end do
      end if
      if (allocated(res%kv_absent)) then   ! a gear mesh without its static reference (D-138)
         if (len(res%kv_absent) > 0) then
            call out%a('warning: no dynamic factor Kv or static TE: the static reference was not computed: '// &
                       res%kv_absent, 0)
            call out%end_line()
         end if
      end if
      call out%flush()
      wn = id_width(model, nodes=.true.)
      write (unit, '(a)') 'final state:'
      motors = .false.
      do i = 1, size(model%nodes)
         motors = motors .or. model%nodes(i)%n%nstates() > 2
      end do
      if (motors) then   ! a DC motor's third state is its armature current
         write (unit, '(4x,a'//str(wn)//',3a18)') 'node', 'angle (rad)', 'speed (rad/s)', 'current (A)'
      else
         write (unit, '(4x,a'//str(wn)//',2a18)') 'node', 'angle (rad)', 'speed (rad/s)'
      end if
      do i = 1, size(model%nodes)   ! '(4x,aWN,a)' and '(4x,aWN,3es18.9)'
         associate (nd => model%nodes(i)%n)
            ns = nd%nstates()
            if (ns > 3) then   ! a controlled motor: angle, speed, current (format reversion would
               call out%flush()  ! read its 4th state with the id's `a`: garbage bytes on stdout)
               write (unit, '(4x,a'//str(wn)//',3es18.9)') nd%id, res%y_final(nd%offset + 1:nd%offset + 3)
               cycle
            end if
            call out%x(4)
            call out%a(nd%id, wn)
            if (model%is_held(i) .or. ns == 0) then
               call out%a('  (held)', 0)
            else
               do j = 1, ns
                  call out%es(res%y_final(nd%offset + j), 18, 9)
               end do
            end if
            call out%end_line()
         end associate
      end do
      call out%flush()
   end subroutine print_summary

   !> u's index in units, appended if new (a string per element cost three
   !> allocations an element: startup7b).
   integer function unit_index(units, u) result(k)
      type(string_t), allocatable, intent(inout) :: units(:)
      character(len=*), intent(in) :: u
      type(string_t), allocatable :: grown(:)
      do k = size(units), 1, -1   ! (the last one met first: elements of a kind come in runs)
         if (len(units(k)%s) == len(u)) then
            if (units(k)%s == u) return
         end if
      end do
      allocate (grown(size(units) + 1))
      do k = 1, size(units)
         call move_alloc(units(k)%s, grown(k)%s)
      end do
      k = size(grown)
      grown(k)%s = u
      call move_alloc(grown, units)
   end function unit_index

   !> Natural frequencies and mode shapes.
   subroutine print_modes(model, modes, unit)
      type(model_t), intent(in) :: model
      type(modes_t), intent(in) :: modes
      integer, intent(in) :: unit
      integer :: i, j
      write (unit, '(a,i0,a)') 'linearised modes (', modes%n, ' free inertias; fixed and prescribed-speed nodes held)'
      if (modes%n_rows > 0) write (unit, '(a,i0,a,i0,a)') 'rigid connections and stuck elements: ', modes%n_rows, &
         ' constraint row(s); their nodes move together (', modes%nm, ' modes)'
      do j = 1, modes%nm
         if (modes%rigid(j)) then
            write (unit, '(a,i3,a)') 'mode', j, ':  rigid-body mode (0 Hz)'
         else
            write (unit, '(a,i3,a,f16.6,a)') 'mode', j, ':', modes%freq_hz(j), ' Hz'
         end if
         do i = 1, modes%n
            write (unit, '(8x,a'//str(id_width(model, nodes=.true.))//',f12.6)') model%nodes(modes%node(i))%n%id, modes%shape(i, j)
         end do
      end do
   end subroutine print_modes
end module trainsim_report
