!> Overrides (--set) and derived parameters (mesh_frequency, settle/measure cycles):
!> an override changes exactly the value a deck edit would, its errors name the
!> override, and mesh_frequency reproduces the hand-computed speeds of the GHM deck.
program test_overrides
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t
   use trainsim_deck, only: deck_t, read_deck, parse_deck
   use trainsim_model, only: model_t
   use trainsim_overrides, only: override_t, parse_set_argument
   use trainsim_prepare, only: prepare_model
   use trainsim_derived, only: mesh_frequency_of
   use trainsim_param_list, only: param_list_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_deck, only: deck_group_t
   use trainsim_sweep_spec, only: sweep_spec_t, read_sweep_spec
   use trainsim, only: simulation_t
   implicit none

   character(len=*), parameter :: ghm = 'inputs/gregory_harris_munro.nml'

   call suite_begin('overrides and derived parameters')
   call test_set_equals_editing_the_deck()
   call test_set_errors_name_the_argument()
   call test_ghm_mesh_frequency_matches_hand_computed_speed()
   call test_mesh_frequency_carries_gear_ratio_to_every_node()
   call test_cycles_set_settle_time_and_t_end()
   call test_api_set_and_sweep_accept_what_set_accepts()
   call test_kept_params_are_params()
   call suite_end()

contains

   function sets(args) result(ovs)
      character(len=*), intent(in) :: args(:)
      type(override_t), allocatable :: ovs(:)
      type(error_t), allocatable :: err
      integer :: i
      allocate (ovs(size(args)))
      do i = 1, size(args)
         call parse_set_argument(trim(args(i)), ovs(i), err)
         if (allocated(err)) error stop 'test setup: '//err%message
      end do
   end function sets

   subroutine load(path, deck)
      character(len=*), intent(in) :: path
      type(deck_t), intent(out) :: deck
      type(error_t), allocatable :: err
      call read_deck(path, deck, err)
      if (allocated(err)) error stop 'test setup: '//err%message
   end subroutine load

   subroutine test_set_equals_editing_the_deck()
      type(deck_t) :: deck, edited
      type(model_t) :: a, b
      type(param_list_t) :: pa, pb
      type(error_t), allocatable :: err
      character(len=*), parameter :: text = "&run t_end = 0.1, dt = 1.0e-4 /"//new_line('a')// &
         "&node type = 'inertia', inertia = 5.0 /"//new_line('a')// &
         "&node id = 'b', type = 'inertia', inertia = 11.0 /"//new_line('a')// &
         "&element type = 'shaft', stiffness = 1.0e5 /"//new_line('a')// &
         "&load node = 'b', value = -3.0 /"
      character(len=*), parameter :: text_edited = "&run t_end = 0.2, dt = 1.0e-4 /"//new_line('a')// &
         "&node type = 'inertia', inertia = 5.0, damping = 0.5 /"//new_line('a')// &
         "&node id = 'b', type = 'inertia', inertia = 11.0 /"//new_line('a')// &
         "&element type = 'shaft', stiffness = 2.0e5 /"//new_line('a')// &
         "&load node = 'b', value = 4.0 /"
      call test_begin('set_equals_editing_the_deck')
      call parse_deck(text, 'a.nml', deck, err)
      call parse_deck(text_edited, 'b.nml', edited, err)
      ! replaced keys, an added key, default ids (n1, e1), run and GROUP#K targets
      call prepare_model(deck, sets([character(len=40) :: 'run.t_end=0.2', 'n1.damping=0.5', 'e1.stiffness=2e5', &
                                     'load#1.value=4.0']), a, err)
      call check('the overridden deck builds', .not. allocated(err))
      call prepare_model(edited, [override_t ::], b, err)
      call check('t_end as edited', a%run%t_end == b%run%t_end)
      pa = a%nodes(1)%n%params(); pb = b%nodes(1)%n%params()
      call check('added damping as edited', all(pa%values == pb%values))
      pa = a%elements(1)%e%params(); pb = b%elements(1)%e%params()
      call check('shaft stiffness as edited', all(pa%values == pb%values) .and. pa%values(1) == 2.0e5_wp)
      call check('load value as edited', a%loads(1)%torque%value(0.0_wp) == 4.0_wp)
      call check('the deck itself is unchanged', deck%groups(1)%value_of(1, 1) == '0.1')
   end subroutine test_set_equals_editing_the_deck

   subroutine test_set_errors_name_the_argument()
      type(deck_t) :: deck
      type(model_t) :: m
      type(error_t), allocatable :: err
      type(override_t) :: ov
      call test_begin('set_errors_name_the_argument')
      call load(ghm, deck)
      call prepare_model(deck, sets([character(len=40) :: 'run.t_end=0.1', 'mesh.half_backlash=abc']), m, err)
      call check('a bad value is an error', allocated(err))
      if (allocated(err)) call check('... naming the --set argument, key and value: '//err%message, &
         index(err%message, "--set mesh.half_backlash=abc: error: &element #2 (id 'mesh'): key 'half_backlash'"// &
               ": expected a real number, got 'abc'") == 1)
      call prepare_model(deck, sets([character(len=40) :: 'mesh.half_backlash=-1']), m, err)
      if (allocated(err)) call check('the plug-in''s own range check, naming the argument: '//err%message, &
         index(err%message, '--set mesh.half_backlash=-1:') == 1 .and. index(err%message, 'must be >= 0') > 0)
      call prepare_model(deck, sets([character(len=40) :: 'mesh.half_backlsh=1']), m, err)
      if (allocated(err)) call check('a misspelt key is an unknown key: '//err%message, &
         index(err%message, "unknown key 'half_backlsh' for element type 'spur_gear'") > 0)
      call prepare_model(deck, sets([character(len=40) :: 'nope.stiffness=1']), m, err)
      if (allocated(err)) call check('an unknown target lists the ids: '//err%message, &
         index(err%message, "no node or element with id 'nope'; ids are: n1, n2, n3, n4, shaft1, mesh, shaft3") > 0)
      call parse_set_argument('mesh.half_backlash', ov, err)
      call check('no = is an error', allocated(err))
      call prepare_model(deck, sets([character(len=40) :: 'mesh.mesh_frequency=0']), m, err)
      call check('mesh_frequency 0 is an error', allocated(err))
   end subroutine test_set_errors_name_the_argument

   !> Cook's own hand-computed speeds (§7.1: 260 and 640 teeth/s are 51.051 and 125.664
   !> rad/s) come back to their printed digits. The GHM deck's 95.2286 rad/s is a slip:
   !> 2 pi 485/32 = 95.22953 (the deck runs at 484.995 teeth/s).
   subroutine test_ghm_mesh_frequency_matches_hand_computed_speed()
      type(deck_t) :: deck
      type(model_t) :: hand, derived
      type(error_t), allocatable :: err
      integer :: i
      real(wp) :: w
      call test_begin('ghm_mesh_frequency_matches_hand_computed_speed')
      call load(ghm, deck)
      call prepare_model(deck, [override_t ::], hand, err)
      call prepare_model(deck, sets([character(len=40) :: 'mesh.mesh_frequency=485']), derived, err)
      call check('mesh_frequency=485 builds', .not. allocated(err))
      w = two_pi*485.0_wp/32.0_wp
      call check('prescribed speed of n1 = 2 pi 485/32', derived%speeds(1)%value(0.0_wp), w, 1.0e-15_wp)
      do i = 1, 4
         call check('initial speed of node '//char(48 + i)//' = the same (ratio 1 meshes, shafts)', &
                    derived%nodes(i)%n%omega0, w, 1.0e-15_wp)
      end do
      call check('initial angles untouched', derived%nodes(3)%n%theta0 == hand%nodes(3)%n%theta0)
      call check('mesh_frequency_of reads it back', mesh_frequency_of(derived, 2), 485.0_wp, 1.0e-14_wp)
      call check('the deck''s hand-computed 95.2286 rad/s is 485 teeth/s to 1e-5 only (484.995)', &
                 mesh_frequency_of(hand, 2), 484.9953_wp, 0.0_wp, 1.0e-4_wp)
      call prepare_model(deck, sets([character(len=40) :: 'mesh.mesh_frequency=260']), derived, err)
      call check('260 teeth/s: Cook''s 51.051 rad/s (sec. 7.1) to its printed digits', &
                 derived%speeds(1)%value(0.0_wp), 51.051_wp, 0.0_wp, 0.5e-3_wp)
      call prepare_model(deck, sets([character(len=40) :: 'mesh.mesh_frequency=640']), derived, err)
      call check('640 teeth/s: Cook''s 125.664 rad/s to its printed digits', &
                 derived%speeds(1)%value(0.0_wp), 125.664_wp, 0.0_wp, 0.5e-3_wp)
   end subroutine test_ghm_mesh_frequency_matches_hand_computed_speed

   !> The builder keeps each element's params() for the print-out and the static
   !> reference (D-175): after the build they are what params() gives, name for name and
   !> bit for bit (finalize and the plausibility checks change no element); a derived
   !> parameter set after the build keeps them so (D-183): it sets speeds and times, and
   !> the element it names is asked again.
   subroutine test_kept_params_are_params()
      type(deck_t) :: deck
      type(model_t) :: m
      type(error_t), allocatable :: err
      call test_begin('kept_params_are_params')
      call load(ghm, deck)
      call prepare_model(deck, [override_t ::], m, err)
      call check('the GHM deck builds', .not. allocated(err))
      call check('the builder''s lists are kept, one an element', allocated(m%element_params))
      if (.not. allocated(m%element_params)) return
      call check('one list an element', size(m%element_params) == size(m%elements))
      call check('kept parameters that differ from params()', real(n_differ(m), wp), 0.0_wp, abs_tol=0.0_wp)
      call prepare_model(deck, sets([character(len=40) :: 'mesh.mesh_frequency=485']), m, err)
      call check('mesh_frequency=485 builds', .not. allocated(err))
      call check('the kept lists after a derived parameter', allocated(m%element_params))
      if (.not. allocated(m%element_params)) return
      call check('kept parameters after mesh_frequency that differ from params()', real(n_differ(m), wp), 0.0_wp, &
                 abs_tol=0.0_wp)
   end subroutine test_kept_params_are_params

   !> Elements whose kept list differs from params() (a name, a value's bits, a word).
   integer function n_differ(m) result(n_bad)
      use, intrinsic :: iso_fortran_env, only: int64
      type(model_t), intent(in) :: m
      type(param_list_t) :: p
      integer :: i, j
      logical :: words_ok
      n_bad = 0
      do i = 1, size(m%elements)
         p = m%elements(i)%e%params()
         associate (q => m%element_params(i))
            if (size(q%names) /= size(p%names)) then
               n_bad = n_bad + 1
               cycle
            end if
            do j = 1, size(p%names)
               if (q%names(j)%s /= p%names(j)%s) n_bad = n_bad + 1
               if (transfer(q%values(j), 0_int64) /= transfer(p%values(j), 0_int64)) n_bad = n_bad + 1
            end do
            words_ok = allocated(q%words) .eqv. allocated(p%words)
            if (words_ok .and. allocated(p%words)) then
               do j = 1, size(p%words)
                  if (q%words(j)%s /= p%words(j)%s) words_ok = .false.
               end do
            end if
            if (.not. words_ok) n_bad = n_bad + 1
         end associate
      end do
   end function n_differ

   !> 28:56 spur pair behind a 1:3 ideal gear: speeds divide by the ratios, a torque-driven
   !> train (no prescribed speed) gets initial speeds only, the fixed node stays at 0.
   subroutine test_mesh_frequency_carries_gear_ratio_to_every_node()
      type(deck_t) :: deck
      type(model_t) :: m
      type(error_t), allocatable :: err
      real(wp) :: w
      character(len=*), parameter :: text = "&run t_end = 0.01, dt = 1.0e-6 /"//new_line('a')// &
         "&node id = 'motor', type = 'inertia', inertia = 0.1 /"//new_line('a')// &
         "&node id = 'p', type = 'inertia', inertia = 0.01 /"//new_line('a')// &
         "&node id = 'g', type = 'inertia', inertia = 0.04 /"//new_line('a')// &
         "&node id = 'out', type = 'inertia', inertia = 1.0 /"//new_line('a')// &
         "&node id = 'wall', type = 'fixed' /"//new_line('a')// &
         "&element id = 'in', type = 'ideal_gear', stiffness = 1e7, rb_driver = 1.0, rb_driven = 3.0 /"// &
         new_line('a')//"&element id = 'pair', type = 'spur_gear', teeth_driver = 28, teeth_driven = 56, "// &
         "diametral_pitch = 8.0, face_width = 0.7, backlash = 0.004 /"//new_line('a')// &
         "&element id = 's', type = 'shaft', stiffness = 1e4 /"//new_line('a')// &
         "&element id = 'd', type = 'damper', left = 'out', right = 'wall', damping = 1.0 /"//new_line('a')// &
         "&load node = 'motor', value = 1.0 /"
      call test_begin('mesh_frequency_carries_gear_ratio_to_every_node')
      call parse_deck(text, 'geared.nml', deck, err)
      call prepare_model(deck, sets([character(len=40) :: 'pair.mesh_frequency=700']), m, err)
      call check('builds', .not. allocated(err))
      if (allocated(err)) then
         print '(a)', err%message
         return
      end if
      w = two_pi*700.0_wp/28.0_wp
      call check('pinion p at 2 pi f / 28', m%nodes(2)%n%omega0, w, 1.0e-14_wp)
      call check('motor 3x the pinion (1:3 ideal gear)', m%nodes(1)%n%omega0, 3.0_wp*w, 1.0e-14_wp)
      call check('gear g at 28/56 of the pinion', m%nodes(3)%n%omega0, w*28.0_wp/56.0_wp, 1.0e-14_wp)
      call check('out on the shaft = gear', m%nodes(4)%n%omega0, w*0.5_wp, 1.0e-14_wp)
      call check('the fixed node stays at rest', m%nodes(5)%n%omega0 == 0.0_wp)
   end subroutine test_mesh_frequency_carries_gear_ratio_to_every_node

   subroutine test_cycles_set_settle_time_and_t_end()
      type(deck_t) :: deck
      type(model_t) :: m
      type(error_t), allocatable :: err
      call test_begin('cycles_set_settle_time_and_t_end')
      call load(ghm, deck)
      call prepare_model(deck, sets([character(len=40) :: 'mesh.measure_cycles=40', 'mesh.settle_cycles=100', &
                                     'mesh.mesh_frequency=400']), m, err)
      call check('builds', .not. allocated(err))
      call check('settle_time = 100 cycles at 400 teeth/s (cycles after mesh_frequency, in any order)', &
                 m%run%settle_time, 0.25_wp, 1.0e-14_wp)
      call check('t_end = settle + 40 cycles', m%run%t_end, 0.35_wp, 1.0e-14_wp)
   end subroutine test_cycles_set_settle_time_and_t_end
   !> One parser of parameter paths (issue 20 item 9): the library's `set`, the command
   !> line's `--set` and a `&sweep` group accept or refuse each path alike, and an
   !> accepted one builds the same model. The paths cover GROUP#K targets, default ids,
   !> `run`, derived keys (mesh_frequency, settle_cycles) and the ways a path goes wrong.
   subroutine test_api_set_and_sweep_accept_what_set_accepts()
      character(len=*), parameter :: nl = new_line('a')
      character(len=*), parameter :: text = "&run t_end = 0.02, dt = 8.0e-6 /"//nl// &
         "&node id = 'n1', type = 'inertia', inertia = 100.0 /"//nl// &
         "&node type = 'inertia', inertia = 0.987 /"//nl// &
         "&node id = 'n3', type = 'inertia', inertia = 0.987 /"//nl// &
         "&node id = 'n4', type = 'inertia', inertia = 100.0 /"//nl// &
         "&element id = 'shaft1', type = 'shaft', stiffness = 32000.0 /"//nl// &
         "&element id = 'mesh', type = 'spur_gear', stiffness = 234500.0, rb_driver = 3.7588, rb_driven = 3.7588,"// &
         " teeth = 32, contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = 0.005 /"//nl// &
         "&element type = 'shaft', stiffness = 32000.0 /"//nl// &
         "&load node = 'n1', quantity = 'speed', kind = 'constant', value = 95.2286 /"//nl// &
         "&load node = 'n4', kind = 'sine', offset = -798.8, amplitude = 10.0, frequency = 50.0 /"//nl// &
         "&initial node = 'all', speed = 95.2286 /"
      ! path, value, accepted
      character(len=24), parameter :: paths(*) = [character(len=24) :: &
         'load#2.amplitude', 'load#2.offset', 'LOAD#1.value', 'mesh.half_backlash', 'mesh.mesh_frequency', &
         'mesh.settle_cycles', 'mesh.measure_cycles', 'run.t_end', 'RUN.t_end', 'n2.inertia', 'e3.stiffness', &
         'element#2.stiffness', 'node#2.damping', 'run#1.dt', &
         'load#3.value', 'load#0.value', 'load#x.value', 'load#.value', 'nosuch.stiffness', 'mesh.nosuchkey', &
         'n1.mesh_frequency', 'load#1.mesh_frequency', 'shaft1.mesh_frequency', 'mesh', 'mesh.', '.stiffness', &
         'mesh.half backlash', 'mesh.2x', 'sweep#1.values', 'initial#1.speed', 'mesh.half_backlash.x']
      character(len=10), parameter :: values(*) = [character(len=10) :: &
         '20.0', '-700.0', '90.0', '0.004', '485.0', '2.0', '3.0', '0.01', '0.01', '1.5', '4.0e4', &
         '5.0e5', '0.5', '1.0e-5', &
         '1.0', '1.0', '1.0', '1.0', '1.0', '1.0', &
         '485.0', '485.0', '485.0', '1.0', '1.0', '1.0', &
         '1.0', '1.0', '1.0', '90.0', '1.0']
      logical, parameter :: expected(*) = [spread(.true., 1, 14), spread(.false., 1, 15), .true., .false.]
      type(deck_t) :: deck, with_sweep
      type(model_t) :: m_set, m_sweep, m_api
      type(override_t) :: ov
      type(override_t), allocatable :: ovs(:)
      type(deck_group_t), allocatable :: groups(:)
      type(sweep_spec_t) :: spec
      type(simulation_t) :: sim
      type(error_t), allocatable :: err
      logical :: ok_set, ok_sweep, ok_api
      integer :: k

      call test_begin('api_set_and_sweep_accept_what_set_accepts')
      call parse_deck(text, 'p.nml', deck, err)
      if (allocated(err)) error stop 'test setup: '//err%message
      do k = 1, size(paths)
         ! --set PATH=VALUE
         call parse_set_argument(trim(paths(k))//'='//trim(values(k)), ov, err)
         if (.not. allocated(err)) call prepare_model(deck, [ov], m_set, err)
         ok_set = .not. allocated(err)
         ! &sweep parameter = 'PATH', values = VALUE /
         call parse_deck(text//nl//"&sweep parameter = '"//trim(paths(k))//"', values = "//trim(values(k))//" /", &
                         'p.nml', with_sweep, err)
         if (allocated(err)) error stop 'test setup: '//err%message
         groups = [with_sweep%groups(size(with_sweep%groups))]
         with_sweep%groups = with_sweep%groups(1:size(with_sweep%groups) - 1)
         call read_sweep_spec(groups, spec, err)
         if (.not. allocated(err)) ovs = spec%overrides(1, err)
         if (.not. allocated(err)) call prepare_model(with_sweep, ovs, m_sweep, err)
         ok_sweep = .not. allocated(err)
         ! the library: sim%set(PATH, VALUE), then build
         call sim%read_text(text, err, name='p.nml')
         if (allocated(err)) error stop 'test setup: '//err%message
         call sim%set(trim(paths(k)), trim(values(k)), err)
         if (.not. allocated(err)) call sim%build(err)
         ok_api = .not. allocated(err)
         if (ok_api) call sim%get_model(m_api, err)
         call check(trim(paths(k))//'='//trim(values(k))//': '//trim(merge('accepted', 'refused ', expected(k)))// &
                    ' by --set, &sweep and the library alike', &
                    ok_set .eqv. expected(k) .and. ok_sweep .eqv. expected(k) .and. ok_api .eqv. expected(k))
         if (ok_set .and. ok_sweep .and. ok_api) then
            call check('  ... the three build the same model (t_end, settle_time, initial speed of n4)', &
                       m_set%run%t_end == m_sweep%run%t_end .and. m_set%run%t_end == m_api%run%t_end .and. &
                       m_set%run%settle_time == m_api%run%settle_time .and. &
                       m_set%nodes(4)%n%omega0 == m_api%nodes(4)%n%omega0 .and. &
                       m_set%nodes(4)%n%omega0 == m_sweep%nodes(4)%n%omega0)
         end if
      end do
   end subroutine test_api_set_and_sweep_accept_what_set_accepts
end program test_overrides
