!> Tests of the namelist-syntax deck reader (trainsim_deck).
program test_deck
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, err_input, err_io
   use trainsim_strings, only: string_t, str, invalid_text_byte
   use trainsim_deck, only: deck_t, deck_group_t, read_deck, parse_deck, parse_real
   use trainsim_testing, only: suite_begin, test_begin, check, suite_end
   implicit none

   character(len=1), parameter :: nl = new_line('a')

   call suite_begin('deck')
   call test_example_structure()
   call test_example_values()
   call test_example_getters()
   call test_amp_end_and_empty_group()
   call test_error_text_outside_group()
   call test_error_key_without_value()
   call test_error_missing_equals()
   call test_error_unterminated_string()
   call test_error_group_not_closed()
   call test_error_repeat_count()
   call test_error_duplicate_key()
   call test_error_misc_syntax()
   call test_check_unused()
   call test_queried_keys_in_order_of_first_query()
   call test_check_group_names()
   call test_read_deck_missing_and_directory()
   call test_read_deck_file()
   call test_read_deck_large_file_line_ends()
   call test_text_must_be_utf8_without_nul()
   call test_utf8_check_at_every_position()
   call test_group_named_and_key_lengths()
   call test_getter_missing_and_default()
   call test_getter_wrong_type()
   call test_getter_two_values_and_quoted()
   call test_getter_int_logical_string()
   call test_getter_real_array()
   call test_str_int_as_i0()
   call test_parse_real_reads_as_fortran()
   call suite_end()

contains

   !> The deck of the module documentation.
   function example() result(text)
      character(len=:), allocatable :: text
      text = '! comment'//nl// &                                                   ! 1
             "&run  title = 'Table 5.1, three disks'   ! trailing comment"//nl// & ! 2
             '      t_end = 0.0508, dt = 2.0e-4, integrator = "rk4"'//nl// &       ! 3
             "      output = 'out.h5' /"//nl// &                                   ! 4
             "&node id = 'n1', type = 'inertia', inertia = 5.0 /"//nl// &          ! 5
             "&node id='n2' type='inertia' inertia=11.0 damping=0.0 /"//nl// &     ! 6
             "&element id = 'e1', type = 'shaft', left = 'n1', right = 'n2',"//nl// & ! 7
             '         stiffness = 1.0e5 /'//nl// &                                ! 8
             "&load node = 'n3', kind = 'table', times = 0.0, 0.1, 0.2,"//nl// &   ! 9
             '      values = 0.0 100.0 100.0 /'//nl// &                            ! 10
             '&run2 flag = .true., other = T, x = 1.0d-3 /'                        ! 11
   end function example

   function contains_text(haystack, needle) result(yes)
      character(len=*), intent(in) :: haystack, needle
      logical :: yes
      yes = index(haystack, needle) > 0
   end function contains_text

   !> Parse `text` as 'bad.nml' and check the error names the file, `line` and each fragment.
   subroutine expect_parse_error(text, line, frag1, frag2)
      character(len=*), intent(in) :: text
      integer, intent(in) :: line
      character(len=*), intent(in) :: frag1
      character(len=*), intent(in), optional :: frag2
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      character(len=16) :: loc
      call parse_deck(text, 'bad.nml', deck, err)
      call check('an error is returned', allocated(err))
      if (.not. allocated(err)) return
      write (loc, '(a,i0,a)') 'bad.nml:', line, ':'
      call check('message starts with '//trim(loc)//' : '//err%message, &
                 index(err%message, trim(loc)//' error: ') == 1)
      call check('message mentions "'//frag1//'": '//err%message, contains_text(err%message, frag1))
      if (present(frag2)) call check('message mentions "'//frag2//'": '//err%message, &
                                     contains_text(err%message, frag2))
      call check('error code is err_input', err%code == err_input)
   end subroutine expect_parse_error

   !> Parse `text` as 'g.nml', expecting success; return the deck.
   subroutine parse_ok(text, deck)
      character(len=*), intent(in) :: text
      type(deck_t), intent(out) :: deck
      type(error_t), allocatable :: err
      call parse_deck(text, 'g.nml', deck, err)
      call check('parses without error', .not. allocated(err))
      if (allocated(err)) write (*, '(a)') '    unexpected error: '//err%message
   end subroutine parse_ok

   ! ----------------------------------------------------------------------------------------

   subroutine test_example_structure()
      type(deck_t) :: deck
      call test_begin('example deck: groups, lower-case names, ordinals, lines')
      call parse_ok(example(), deck)
      if (.not. allocated(deck%groups)) return
      call check('6 groups', size(deck%groups) == 6)
      if (size(deck%groups) /= 6) return
      call check('file kept', deck%file == 'g.nml')
      call check('text kept verbatim', deck%text == example())
      call check('names', deck%groups(1)%name == 'run' .and. deck%groups(2)%name == 'node' .and. &
                 deck%groups(3)%name == 'node' .and. deck%groups(4)%name == 'element' .and. &
                 deck%groups(5)%name == 'load' .and. deck%groups(6)%name == 'run2')
      call check('ordinals', deck%groups(1)%ordinal == 1 .and. deck%groups(2)%ordinal == 1 .and. &
                 deck%groups(3)%ordinal == 2 .and. deck%groups(4)%ordinal == 1)
      call check('group lines', deck%groups(1)%line == 2 .and. deck%groups(2)%line == 5 .and. &
                 deck%groups(4)%line == 7 .and. deck%groups(6)%line == 11)
      call check('group file', deck%groups(4)%file == 'g.nml')
      call check('count_groups node', deck%count_groups('node') == 2)
      call check('count_groups is case-insensitive', deck%count_groups('NODE') == 2)
      call check('count_groups absent', deck%count_groups('gear') == 0)
      call check('run has 5 entries', deck%groups(1)%nentries() == 5)
      call check('element has 5 entries', deck%groups(4)%nentries() == 5)
      call check('line of t_end', deck%groups(1)%entries(2)%line == 3)
      call check('line of output', deck%groups(1)%entries(5)%line == 4)
      call check('line of stiffness', deck%groups(4)%key_of(5) == 'stiffness' .and. &
                 deck%groups(4)%entries(5)%line == 8)
      call check('line of values', deck%groups(5)%key_of(4) == 'values' .and. &
                 deck%groups(5)%entries(4)%line == 10)
      call check('where with key', deck%groups(4)%where('stiffness') == "g.nml:8: &element #1, key 'stiffness'")
      call check('where without key', deck%groups(3)%where() == 'g.nml:6: &node #2')
      call check('where with absent key', deck%groups(3)%where('gear_ratio') == 'g.nml:6: &node #2')
      call check('label with id', deck%groups(3)%label() == "&node #2 (id 'n2')")
      call check('label without id', deck%groups(1)%label() == '&run #1')
   end subroutine test_example_structure

   subroutine test_example_values()
      type(deck_t) :: deck
      call test_begin('example deck: raw values, quoted flags, multi-value items')
      call parse_ok(example(), deck)
      if (.not. allocated(deck%groups)) return
      if (size(deck%groups) /= 6) return
      associate (run => deck%groups(1), n2 => deck%groups(3), ld => deck%groups(5), r2 => deck%groups(6))
         call check('title key', run%key_of(1) == 'title')
         call check('title unquoted with comma inside', run%value_of(1, 1) == 'Table 5.1, three disks')
         call check('title quoted flag', run%quoted(1, 1))
         call check('t_end raw', run%value_of(2, 1) == '0.0508')
         call check('t_end not quoted', .not. run%quoted(2, 1))
         call check('double-quoted integrator', run%value_of(4, 1) == 'rk4' .and. &
                    run%quoted(4, 1))
         call check('whitespace-separated items', n2%nentries() == 4 .and. n2%key_of(4) == 'damping')
         call check('times: 3 comma-separated values', ld%nvalues(3) == 3)
         call check('times raw', ld%value_of(3, 2) == '0.1')
         call check('values: 3 blank-separated values', ld%nvalues(4) == 3)
         call check('values raw', ld%value_of(4, 3) == '100.0')
         call check('d-exponent token kept raw', r2%value_of(3, 1) == '1.0d-3')
         call check('logical token raw', r2%value_of(1, 1) == '.true.' .and. &
                    r2%value_of(2, 1) == 'T')
         call check('entries start unused', .not. any(r2%entries(:)%used))
      end associate
   end subroutine test_example_values

   subroutine test_example_getters()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      real(wp) :: x
      logical :: flag
      character(len=:), allocatable :: s
      real(wp), allocatable :: v(:)
      call test_begin('example deck: typed getters incl. d exponent and T logical')
      call parse_ok(example(), deck)
      if (.not. allocated(deck%groups)) return
      if (size(deck%groups) /= 6) return
      call deck%groups(6)%get_real('x', x, err)
      call check('get_real 1.0d-3 ok', .not. allocated(err))
      call check('get_real 1.0d-3', x, 1.0e-3_wp, rel_tol=1.0e-15_wp)
      call deck%groups(6)%get_logical('FLAG', flag, err)
      call check('get_logical .true. (key case-insensitive)', .not. allocated(err) .and. flag)
      call deck%groups(6)%get_logical('other', flag, err)
      call check('get_logical T', .not. allocated(err) .and. flag)
      call check('getters mark used', deck%groups(6)%entries(1)%used .and. deck%groups(6)%entries(3)%used)
      call deck%groups(1)%get_string('title', s, err)
      call check('get_string title', .not. allocated(err) .and. s == 'Table 5.1, three disks')
      call deck%groups(1)%get_real('dt', x, err)
      call check('get_real dt', x, 2.0e-4_wp, rel_tol=1.0e-15_wp)
      call deck%groups(4)%get_real('stiffness', x, err)
      call check('get_real stiffness', x, 1.0e5_wp, rel_tol=1.0e-15_wp)
      call deck%groups(5)%get_real_array('values', v, err)
      call check('get_real_array values', .not. allocated(err) .and. size(v) == 3)
      if (size(v) == 3) call check('values(2)', v(2), 100.0_wp, abs_tol=0.0_wp)
      call check('count_values times', deck%groups(5)%count_values('times') == 3)
      call check('count_values absent', deck%groups(5)%count_values('nothing') == 0)
   end subroutine test_example_getters

   subroutine test_amp_end_and_empty_group()
      type(deck_t) :: deck
      call test_begin('&end closes a group; empty groups, empty deck, CR-LF and tabs accepted')
      call parse_ok('&RUN T_End=1.0'//achar(13)//nl//achar(9)//'dt=0.1 &END'//nl//'&run /'//nl//'&Node/', deck)
      if (.not. allocated(deck%groups)) return
      call check('3 groups', size(deck%groups) == 3)
      if (size(deck%groups) /= 3) return
      call check('upper-case group and key lowered', deck%groups(1)%name == 'run' .and. &
                 deck%groups(1)%key_of(1) == 't_end')
      call check('CR is white space', deck%groups(1)%value_of(1, 1) == '1.0')
      call check('tab-separated dt on line 2', deck%groups(1)%entries(2)%line == 2)
      call check('empty group has 0 entries', deck%groups(2)%nentries() == 0)
      call check('second run ordinal 2', deck%groups(2)%ordinal == 2)
      call check('&Node/ ok', deck%groups(3)%name == 'node' .and. deck%groups(3)%nentries() == 0)
      call parse_ok('&list names = shaft gear shaft, flags = 1 T /', deck)
      if (size(deck%groups) == 1) call check('list of bare names allowed', &
                                             deck%groups(1)%nvalues(1) == 3 .and. &
                                             deck%groups(1)%nvalues(2) == 2)
      call parse_ok(nl//'! only a comment'//nl, deck)
      call check('empty deck has 0 groups', size(deck%groups) == 0)
      call parse_ok("&s a = 'it''s', b = ""say """"hi"""""", c = '!' /", deck)
      if (size(deck%groups) == 1) then
         call check('doubled single quote', deck%groups(1)%value_of(1, 1) == "it's")
         call check('doubled double quote', deck%groups(1)%value_of(2, 1) == 'say "hi"')
         call check('! inside quotes is text', deck%groups(1)%value_of(3, 1) == '!')
      end if
   end subroutine test_amp_end_and_empty_group

   subroutine test_error_text_outside_group()
      call test_begin('error: text outside a group')
      call expect_parse_error('! ok'//nl//'&run a = 1 /'//nl//'stray = 2', 3, 'text outside a group', "'stray'")
      call expect_parse_error('&run a = 1 / /', 1, 'text outside a group', "'/'")
      call expect_parse_error(nl//'&end', 2, 'text outside a group', '&end')
   end subroutine test_error_text_outside_group

   subroutine test_error_key_without_value()
      call test_begin('error: key with no values')
      call expect_parse_error('&run'//nl//'  t_end = /', 2, "key 't_end' has no value", '&run #1')
      call expect_parse_error('&run a = 1,'//nl//'  b = '//nl//' c = 2 /', 2, "key 'b' has no value")
      call expect_parse_error('&run a = , 1 /', 1, "key 'a' has no value")
   end subroutine test_error_key_without_value

   subroutine test_error_missing_equals()
      call test_begin('error: missing =')
      call expect_parse_error('&node id = ''n1'','//nl//'  inertia 5.0 /', 2, "missing '=' after key 'inertia'", &
                              "&node #1 (id 'n1')")
      call expect_parse_error('&run t_end = 0.05'//nl//'  dt 2.0e-4 /', 2, "missing '=' after key 'dt'")
      call expect_parse_error('&node type = inertia'//nl//' damping 0.0 /', 2, "missing '=' after key 'damping'")
      call expect_parse_error('&node 5.0 = 1 /', 1, "expected a key name, got '5.0'")
      call expect_parse_error('&node = 1 /', 1, "expected a key name, got '='")
   end subroutine test_error_missing_equals

   subroutine test_error_unterminated_string()
      call test_begin('error: unterminated string, incl. one spanning lines')
      call expect_parse_error('&run'//nl//"  title = 'abc /", 2, 'unterminated string', "'abc /")
      call expect_parse_error('&run title = "two'//nl//'lines" /', 1, 'unterminated string', '"two')
   end subroutine test_error_unterminated_string

   subroutine test_error_group_not_closed()
      call test_begin('error: group not closed (EOF, or another group starts)')
      call expect_parse_error('&run a = 1'//nl//'&node b = 2 /', 2, "not closed before '&node'", '&run #1')
      call expect_parse_error('! x'//nl//'&load a = 1'//nl//'  b = 2', 2, 'not closed before the end of the file', &
                              '&load #1')
   end subroutine test_error_group_not_closed

   subroutine test_error_repeat_count()
      call test_begin('error: repeat counts rejected clearly')
      call expect_parse_error('&load'//nl//'  values = 3*0.0 /', 2, 'repeat counts are not supported', "'3*0.0'")
      call expect_parse_error("&load names = 2*'a' /", 1, 'repeat counts are not supported', "'2*'")
   end subroutine test_error_repeat_count

   subroutine test_error_duplicate_key()
      call test_begin('error: duplicated key within one group')
      call expect_parse_error("&node id = 'n1', inertia = 1.0,"//nl//'  INERTIA = 2.0 /', 2, &
                              "duplicate key 'inertia'", 'first given on line 1')
   end subroutine test_error_duplicate_key

   subroutine test_error_misc_syntax()
      call test_begin('error: empty value between commas, stray =, bad group names')
      call expect_parse_error('&run a = 1,, 2 /', 1, 'empty value between commas')
      call expect_parse_error("&run a = 'x' = 2 /", 1, "unexpected '='")
      call expect_parse_error(nl//'& run /', 2, "group name right after '&'")
      call expect_parse_error('&1run /', 1, "invalid group name '&1run'")
      call expect_parse_error('&run x(1) = 2 /', 1, "expected a key name, got 'x(1)'")
   end subroutine test_error_misc_syntax

   subroutine test_check_unused()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      real(wp) :: x
      character(len=:), allocatable :: s
      call test_begin('check_unused names the misspelt key and lists queried keys')
      call parse_ok('&element id = ''e1'' type = ''shaft'''//nl//' stifness = 1.0e5 left=1 /', deck)
      if (size(deck%groups) /= 1) return
      associate (g => deck%groups(1))
         call g%get_string('id', s, err)
         call g%get_string('type', s, err)
         call g%get_real('stiffness', x, err, default=1.0_wp)
         call check('absent key with default: no error', .not. allocated(err))
         call check('damping queried via has', .not. g%has('damping'))
         call check('left present', g%has('left'))
         call g%check_unused(err, "element type 'shaft'")
         call check('error returned', allocated(err))
         if (.not. allocated(err)) return
         call check('exact message: '//err%message, err%message == &
                    "g.nml:2: error: &element #1 (id 'e1'): unknown key 'stifness' for element type 'shaft'; "// &
                    "did you mean 'stiffness'?; valid keys are: id, type, stiffness, damping, left")
         ! required and absent, with a near miss in the group: the near miss on its own line (D-62)
         call g%get_real('stiffness', x, err)
         call check('required key misspelt: reported on its line', allocated(err))
         if (.not. allocated(err)) return
         call check('exact message: '//err%message, err%message == &
                    "g.nml:2: error: &element #1 (id 'e1'): unknown key 'stifness'; did you mean 'stiffness'? "// &
                    "(the required key 'stiffness' (a real number) is missing)")
         call g%get_real('damping', x, err)
         call check('required key, no near miss: missing at the group line', allocated(err))
         if (.not. allocated(err)) return
         call check('exact message: '//err%message, err%message == &
                    "g.nml:1: error: &element #1 (id 'e1'): missing required key 'damping' (a real number)")
         call check('has does not mark used', .not. g%entries(4)%used)
         call g%get_real('stifness', x, err)
         call g%get_real('left', x, err)
         call g%check_unused(err, 'x')
         call check('all used: no error', .not. allocated(err))
      end associate
   end subroutine test_check_unused

   !> The valid keys a message lists are in order of first query, present and absent keys
   !> interleaved, each once, whatever its case (present keys are marked in their entry,
   !> absent ones written: D-176); a queried entry is no near miss.
   subroutine test_queried_keys_in_order_of_first_query()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      real(wp) :: x
      logical :: yes
      call test_begin('queried keys listed in order of first query, present and absent interleaved')
      call parse_ok('&g Alpha = 1, beta = 2, gama = 3 /', deck)
      if (size(deck%groups) /= 1) return
      associate (g => deck%groups(1))
         call g%get_real('BETA', x, err)
         call g%get_real('zeta', x, err, default=0.0_wp)
         call g%get_real('alpha', x, err)
         yes = g%has('beta')
         yes = g%has('Zeta')
         call g%expect([character(len=5) :: 'delta', 'alpha'])
         call g%check_unused(err, 'g')
         call check('error returned', allocated(err))
         if (.not. allocated(err)) return
         call check('exact message: '//err%message, err%message == &
                    "g.nml:1: error: &g #1: unknown key 'gama' for g; valid keys are: beta, zeta, alpha, delta")
         call g%get_real('gamma', x, err)
         call check('near miss not queried', allocated(err))
         if (.not. allocated(err)) return
         call check('exact message: '//err%message, err%message == &
                    "g.nml:1: error: &g #1: unknown key 'gama'; did you mean 'gamma'? "// &
                    "(the required key 'gamma' (a real number) is missing)")
         yes = g%has('gama')
         call g%get_real('gamma', x, err)
         call check('queried entry is no near miss', allocated(err))
         if (.not. allocated(err)) return
         call check('exact message: '//err%message, err%message == &
                    "g.nml:1: error: &g #1: missing required key 'gamma' (a real number)")
      end associate
   end subroutine test_queried_keys_in_order_of_first_query

   subroutine test_check_group_names()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      type(string_t) :: allowed(4)
      call test_begin('check_group_names reports the first unknown group')
      allowed(1)%s = 'run'
      allowed(2)%s = 'node'
      allowed(3)%s = 'gear'
      allowed(4)%s = 'FOO'
      call parse_ok('&run /'//nl//'&node /'//nl//'&gear /'//nl//'&foo /', deck)
      call deck%check_group_names(allowed(1:3), err)
      call check('error returned', allocated(err))
      if (.not. allocated(err)) return
      call check('exact message: '//err%message, err%message == &
                 "g.nml:4: error: unknown group '&foo'; valid groups are: run, node, gear")
      call deck%check_group_names(allowed, err)
      call check('all known (case-insensitive): no error', .not. allocated(err))
   end subroutine test_check_group_names

   subroutine test_read_deck_missing_and_directory()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      call test_begin('read_deck: missing file and directory give err_io')
      call read_deck('no/such/deck.nml', deck, err)
      call check('missing: error', allocated(err))
      if (.not. allocated(err)) return
      call check('missing: err_io', err%code == err_io)
      call check('missing: message: '//err%message, &
                 index(err%message, "cannot open deck 'no/such/deck.nml': ") == 1)
      call read_deck('.', deck, err)
      call check('directory: error', allocated(err))
      if (.not. allocated(err)) return
      call check('directory: err_io', err%code == err_io)
      call check('directory: message: '//err%message, index(err%message, "cannot open deck '.': ") == 1)
   end subroutine test_read_deck_missing_and_directory

   subroutine test_read_deck_file()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      character(len=:), allocatable :: path
      character(len=512) :: tmpdir
      integer :: u, ios, stat
      real(wp) :: x
      call test_begin('read_deck: reads a CR-LF file, text recorded, errors name the path')
      call get_environment_variable('TMPDIR', tmpdir, status=stat)
      if (stat /= 0 .or. len_trim(tmpdir) == 0) tmpdir = '/tmp'
      path = trim(tmpdir)//'/trainsim_test_deck.nml'
      open (newunit=u, file=path, access='stream', form='unformatted', status='replace', iostat=ios)
      call check('temporary file opened', ios == 0)
      if (ios /= 0) return
      write (u) '&run'//achar(13)//nl//' t_end = 2.5 /'//achar(13)//nl//'&node inertia = x /'//achar(13)//nl
      close (u)
      call read_deck(path, deck, err)
      call check('no error', .not. allocated(err))
      call check('file recorded', deck%file == path)
      call check('text without CRs or final newline', &
                 deck%text == '&run'//nl//' t_end = 2.5 /'//nl//'&node inertia = x /')
      if (size(deck%groups) == 2) then
         call deck%groups(1)%get_real('t_end', x, err)
         call check('t_end', x, 2.5_wp, abs_tol=0.0_wp)
         call deck%groups(2)%get_real('inertia', x, err)
         call check('error names path and line 3', allocated(err))
         if (allocated(err)) call check('message: '//err%message, index(err%message, path//':3: error: ') == 1)
      end if
      open (newunit=u, file=path, status='old', iostat=ios)
      if (ios == 0) close (u, status='delete')
   end subroutine test_read_deck_file

   !> A file of more than one read block (1 MiB), with a CR-LF split across the block
   !> boundary, a lone CR, a byte-order mark and a CR-LF at the end: the text is the file
   !> without the BOM, without the CRs of CR-LF and without the final line end.
   subroutine test_read_deck_large_file_line_ends()
      integer, parameter :: block = 1048576
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      character(len=:), allocatable :: path, body, expected
      character(len=512) :: tmpdir
      character(len=3), parameter :: bom = char(239)//char(187)//char(191)
      integer :: u, ios, stat, pad
      call test_begin('read_deck: blocks, CR-LF across a block boundary, lone CR, BOM')
      call get_environment_variable('TMPDIR', tmpdir, status=stat)
      if (stat /= 0 .or. len_trim(tmpdir) == 0) tmpdir = '/tmp'
      path = trim(tmpdir)//'/trainsim_test_deck_big.nml'
      ! the file: BOM, '&run t_end = 1 /', CR LF, a comment up to byte `block`, whose
      ! last byte is a CR, the LF opening the next block, then a lone CR inside a line
      body = '&run t_end = 1 /'//achar(13)//nl//'!'
      pad = block - len(bom) - len(body) - 1
      body = body//repeat('x', pad)//achar(13)//nl//'&node a = 1'//achar(13)//'b = 2 /'//achar(13)//nl
      expected = '&run t_end = 1 /'//nl//'!'//repeat('x', pad)//nl//'&node a = 1'//achar(13)//'b = 2 /'
      open (newunit=u, file=path, access='stream', form='unformatted', status='replace', iostat=ios)
      call check('temporary file opened', ios == 0)
      if (ios /= 0) return
      write (u) bom//body
      close (u)
      call read_deck(path, deck, err)
      open (newunit=u, file=path, status='old', iostat=ios)
      if (ios == 0) close (u, status='delete')
      call check('no error', .not. allocated(err))
      if (allocated(err)) return
      call check('length of the text', len(deck%text) == len(expected))
      call check('text as expected', deck%text == expected)
      call check('two groups', size(deck%groups) == 2)
   end subroutine test_read_deck_large_file_line_ends

   subroutine test_text_must_be_utf8_without_nul()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      call test_begin('deck text: NUL and invalid UTF-8 rejected with line and column; UTF-8 accepted')
      call parse_deck('&run'//nl//"  title = 'ok'"//achar(0)//' /', 'x.nml', deck, err)
      call check('NUL rejected', allocated(err))
      if (allocated(err)) call check('NUL: '//err%message, &
                                     index(err%message, 'x.nml:2: error: NUL byte at column 15') == 1)
      call parse_deck("&run title = 'M"//char(252)//"ller' /", 'x.nml', deck, err)   ! Latin-1 u-umlaut
      call check('Latin-1 rejected', allocated(err))
      if (allocated(err)) call check('Latin-1: '//err%message, &
                                     index(err%message, 'x.nml:1: error: invalid UTF-8 at column 16 (byte 0xFC)') == 1)
      call parse_deck("&run title = 'M"//char(195)//char(188)//"ller' /", 'x.nml', deck, err)   ! UTF-8 u-umlaut
      call check('UTF-8 accepted', .not. allocated(err))
      call parse_deck("&run title = '"//char(240)//char(159)//char(154)//char(151)//"' /", 'x.nml', deck, err)
      call check('4-byte UTF-8 accepted', .not. allocated(err))
      call parse_deck("&run title = '"//char(240)//char(159)//char(154)//"' /", 'x.nml', deck, err)
      call check('truncated 4-byte sequence rejected', allocated(err))
   end subroutine test_text_must_be_utf8_without_nul

   !> The check skips a run of plain ASCII eight bytes at a time (D-151): a NUL or a
   !> byte >= 128 is found at every position of a word and past it, and a valid
   !> sequence across a word's end is accepted.
   subroutine test_utf8_check_at_every_position()
      character(len=:), allocatable :: t
      integer :: p
      logical :: ok_nul, ok_high, ok_seq, ok_low
      call test_begin('deck text: the UTF-8 check finds a NUL or a bad byte at every position 1..24')
      ok_nul = .true.; ok_high = .true.; ok_seq = .true.; ok_low = .true.
      do p = 1, 24
         t = repeat('a', p - 1)//achar(0)//repeat('b', 9)
         ok_nul = ok_nul .and. invalid_text_byte(t) == p
         t = repeat('a', p - 1)//char(252)//repeat('b', 9)
         ok_high = ok_high .and. invalid_text_byte(t) == p
         t = repeat('a', p - 1)//char(195)//char(188)//repeat('b', 9)   ! u-umlaut, valid
         ok_seq = ok_seq .and. invalid_text_byte(t) == 0
         t = repeat('a', p - 1)//achar(1)//achar(127)//repeat('b', 9)   ! lowest and highest ASCII
         ok_low = ok_low .and. invalid_text_byte(t) == 0
      end do
      call check('NUL at its position', ok_nul)
      call check('byte 0xFC at its position', ok_high)
      call check('a 2-byte sequence anywhere accepted', ok_seq)
      call check('bytes 1 and 127 accepted', ok_low)
      call check('empty text valid', invalid_text_byte('') == 0)
   end subroutine test_utf8_check_at_every_position

   !> `named` is the exact lower-case group name; a key of another length is found
   !> only when the asked key is padded with blanks (D-151); all_used after every read.
   subroutine test_group_named_and_key_lengths()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      real(wp) :: x
      call test_begin('deck group: named(), keys of other lengths, padded and upper-case keys, all_used')
      call parse_deck("&Run t_end = 1.0, dt = 0.5 /", 'x.nml', deck, err)
      call check('parsed', .not. allocated(err))
      if (allocated(err)) return
      associate (g => deck%groups(1))
         call check('named run', g%named('run'))
         call check('not named ru', .not. g%named('ru'))
         call check('not named runs', .not. g%named('runs'))
         call check('not named Run (names are lower case)', .not. g%named('Run'))
         call check('has T_END (upper case)', g%has('T_END'))
         call check('has padded t_end', g%has('t_end   '))
         call check('has no t_en', .not. g%has('t_en'))
         call check('has no t_end_', .not. g%has('t_end_'))
         call check('not all used before reading', .not. g%all_used())
         call g%get_real('t_end', x, err)
         call check('t_end read', .not. allocated(err) .and. x == 1.0_wp)
         call check('not all used with dt unread', .not. g%all_used())
         call g%get_real('dt', x, err)
         call check('all used', g%all_used())
      end associate
   end subroutine test_group_named_and_key_lengths

   subroutine test_getter_missing_and_default()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      real(wp) :: x
      integer :: n
      logical :: b
      character(len=:), allocatable :: s
      call test_begin('getters: missing required key, defaults used')
      call parse_ok('! c'//nl//"&node id = 'n7'"//nl//' type = inertia /', deck)
      if (size(deck%groups) /= 1) return
      associate (g => deck%groups(1))
         call g%get_real('inertia', x, err)
         call check('missing real: error', allocated(err))
         if (allocated(err)) call check('message: '//err%message, err%message == "g.nml:2: error: "// &
                                        "&node #1 (id 'n7'): missing required key 'inertia' (a real number)")
         call g%get_real('Damping', x, err, default=0.25_wp)
         call check('default real: no error', .not. allocated(err))
         call check('default real', x, 0.25_wp, abs_tol=0.0_wp)
         call g%get_int('n', n, err, default=7)
         call check('default int', .not. allocated(err) .and. n == 7)
         call g%get_int('n', n, err)
         call check('missing int mentions an integer', allocated(err))
         if (allocated(err)) call check('int message', &
                                        contains_text(err%message, "missing required key 'n' (an integer)"))
         call g%get_logical('fixed', b, err, default=.true.)
         call check('default logical', .not. allocated(err) .and. b)
         call g%get_string('label', s, err, default='none')
         call check('default string', .not. allocated(err) .and. s == 'none')
         call g%get_string('type', s, err)
         call check('bare string token', .not. allocated(err) .and. s == 'inertia')
      end associate
   end subroutine test_getter_missing_and_default

   subroutine test_getter_wrong_type()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      real(wp) :: x
      integer :: n
      logical :: b
      call test_begin('getters: wrong type, nan/inf/junk/out-of-range rejected')
      call parse_ok("&node id='n1'"//nl//' inertia = abc'//nl//' a = nan b = Inf c = 1.0x d = 1e999 e = 1.5 '// &
                    'f = yes g = 1.0e g2 = . h = -1.5D+2 i = +.5 j = 2147483648 k = 0e999 /', deck)
      if (size(deck%groups) /= 1) return
      associate (g => deck%groups(1))
         call g%get_real('inertia', x, err)
         call check('abc rejected', allocated(err))
         if (allocated(err)) call check('message: '//err%message, err%message == "g.nml:2: error: "// &
                                        "&node #1 (id 'n1'): key 'inertia': expected a real number, got 'abc'")
         call g%get_real('a', x, err)
         call check('nan rejected', allocated(err))
         call g%get_real('b', x, err)
         call check('Inf rejected', allocated(err))
         call g%get_real('c', x, err)
         call check('trailing junk rejected', allocated(err))
         call g%get_real('d', x, err)
         call check('1e999 rejected without FP trap', allocated(err))
         if (allocated(err)) call check('out of range said', contains_text(err%message, 'out of range'))
         call g%get_real('g', x, err)
         call check('exponent without digits rejected', allocated(err))
         call g%get_real('g2', x, err)
         call check('lone dot rejected', allocated(err))
         call g%get_real('h', x, err)
         call check('-1.5D+2 accepted', .not. allocated(err))
         call check('-1.5D+2', x, -150.0_wp, abs_tol=0.0_wp)
         call g%get_real('i', x, err)
         call check('+.5', x, 0.5_wp, abs_tol=0.0_wp)
         call g%get_real('k', x, err)
         call check('0e999 accepted', .not. allocated(err))
         call check('0e999 is zero', x, 0.0_wp, abs_tol=0.0_wp)
         call g%get_int('e', n, err)
         call check('int rejects 1.5', allocated(err))
         if (allocated(err)) call check('int message', &
                                        contains_text(err%message, "key 'e': expected an integer, got '1.5'"))
         call g%get_int('j', n, err)
         call check('int overflow rejected', allocated(err))
         call g%get_logical('f', b, err)
         call check('logical rejects yes', allocated(err))
         if (allocated(err)) call check('logical message', contains_text(err%message, "got 'yes'"))
      end associate
   end subroutine test_getter_wrong_type

   subroutine test_getter_two_values_and_quoted()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      real(wp) :: x
      integer :: n
      logical :: b
      character(len=:), allocatable :: s
      call test_begin('getters: two values for a scalar; quoted number rejected')
      call parse_ok('&run'//nl//'  t_end = 1.0, 2.0'//nl//"  dt = '0.1' n = '3' f = '.true.' s = a b /", deck)
      if (size(deck%groups) /= 1) return
      associate (g => deck%groups(1))
         call g%get_real('t_end', x, err)
         call check('two values: error', allocated(err))
         if (allocated(err)) call check('message: '//err%message, err%message == &
                                        "g.nml:2: error: &run #1: key 't_end': expected one value, got 2")
         call g%get_real('dt', x, err)
         call check('quoted real: error', allocated(err))
         if (allocated(err)) call check('message: '//err%message, index(err%message, 'g.nml:3: error: ') == 1 &
                                        .and. contains_text(err%message, "quoted string '0.1'"))
         call g%get_int('n', n, err)
         call check('quoted int rejected', allocated(err))
         call g%get_logical('f', b, err)
         call check('quoted logical rejected', allocated(err))
         call g%get_string('s', s, err)
         call check('two values for a string rejected', allocated(err))
      end associate
   end subroutine test_getter_two_values_and_quoted

   subroutine test_getter_int_logical_string()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      integer :: n
      logical :: b
      character(len=:), allocatable :: s
      call test_begin('getters: integers, all logical spellings, strings keep case')
      call parse_ok("&x n = -42 m = +7 a=.TRUE. b=.f. c=t d=False e=.false. s = 'MiXeD' /", deck)
      if (size(deck%groups) /= 1) return
      associate (g => deck%groups(1))
         call g%get_int('n', n, err)
         call check('-42', .not. allocated(err) .and. n == -42)
         call g%get_int('m', n, err)
         call check('+7', .not. allocated(err) .and. n == 7)
         call g%get_logical('a', b, err)
         call check('.TRUE.', .not. allocated(err) .and. b)
         call g%get_logical('b', b, err)
         call check('.f.', .not. allocated(err) .and. .not. b)
         call g%get_logical('c', b, err)
         call check('t', .not. allocated(err) .and. b)
         call g%get_logical('d', b, err)
         call check('False', .not. allocated(err) .and. .not. b)
         call g%get_logical('e', b, err)
         call check('.false.', .not. allocated(err) .and. .not. b)
         call g%get_string('s', s, err)
         call check('case kept', .not. allocated(err) .and. s == 'MiXeD')
      end associate
   end subroutine test_getter_int_logical_string

   subroutine test_getter_real_array()
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      real(wp), allocatable :: v(:)
      call test_begin('get_real_array: absent gives size 0, bad element named')
      call parse_ok('&load times = 0.0, 1d0,'//nl//' 2.5 bad = 1.0 2..0 3.0 q = "1.0" /', deck)
      if (size(deck%groups) /= 1) return
      associate (g => deck%groups(1))
         call g%get_real_array('values', v, err)
         call check('absent: no error, size 0', .not. allocated(err) .and. allocated(v))
         if (allocated(v)) call check('absent: size 0', size(v) == 0)
         call g%get_real_array('times', v, err)
         call check('times ok', .not. allocated(err) .and. size(v) == 3)
         if (size(v) == 3) call check('times(3)', v(3), 2.5_wp, abs_tol=0.0_wp)
         call check('times marked used', g%entries(1)%used)
         call g%get_real_array('bad', v, err)
         call check('bad element: error', allocated(err))
         if (allocated(err)) call check('message: '//err%message, index(err%message, 'g.nml:2: error: ') == 1 &
                                        .and. contains_text(err%message, &
                                                            "key 'bad' (value 2): expected a real number, got '2..0'"))
         call g%get_real_array('q', v, err)
         call check('quoted element rejected', allocated(err))
      end associate
   end subroutine test_getter_real_array

   !> str(i) writes what Fortran's own `(i0)` edit descriptor writes (it builds the
   !> digits itself, D-74): zero, signs, every length of digits, both extremes.
   subroutine test_str_int_as_i0()
      integer :: vals(12), k
      character(len=32) :: ref
      call test_begin('str(integer) equals the (i0) edit descriptor')
      vals = [0, 1, -1, 9, 10, -10, 99999, 123456789, -2147483647, huge(1), -huge(1) - 1, 1000000000]
      do k = 1, size(vals)
         write (ref, '(i0)') vals(k)
         call check('str('//trim(ref)//') = '//str(vals(k)), str(vals(k)) == trim(ref))
      end do
   end subroutine test_str_int_as_i0

   !> parse_real converts with C's strtod (D-82): every number the deck syntax
   !> allows must read bit for bit as Fortran's list-directed read gives it (signs,
   !> no digits before or after the point, leading zeros, e/E/d/D exponents, 20+
   !> digits, subnormals, the range's edges, a mantissa longer than strtod's buffer).
   subroutine test_parse_real_reads_as_fortran()
      use, intrinsic :: iso_fortran_env, only: int64
      character(len=*), parameter :: expo_letters = 'eEdD'
      character(len=:), allocatable :: t
      character(len=40), parameter :: fixed(14) = [character(len=40) :: '1', '-0', '+.5', '7.', '-0.0e0', &
         '4.9406564584124654e-324', '2.4703282292062328D-324', '1.7976931348623157e308', '2.2250738585072011e-308', &
         '0.1', '1e-310', '123456789012345678901234567890', '9.999999999999999999e307', '.000000000000000000001D+5']
      character(len=24), parameter :: edges(12) = [character(len=24) :: '999999999999999e22', '9007199254740993', &
         '123456789012345e-22', '0.1e-22', '1e23', '-0.0', '0e-30', '8.98846567431158e307', '4.9e-324', &
         '900719925474099.1', '1.7976931348623157e308', '.000000000000001e22']
      integer(int64) :: st64
      integer :: k, j, n_bad, n_read
      call test_begin('parse_real_reads_as_fortran')
      n_bad = 0
      n_read = 0
      st64 = 2463534242_int64
      do k = 1, 60014
         if (k <= size(fixed)) then
            t = trim(fixed(k))
         else if (k == size(fixed) + 1) then
            t = '0.'//repeat('3', 150)//'e1'
         else
            t = ''
            if (next_rand(st64, 3) == 1) t = '-'
            if (next_rand(st64, 5) == 1) t = t//'+'
            do j = 1, next_rand(st64, 22) - 1
               t = t//achar(47 + next_rand(st64, 10))
            end do
            if (next_rand(st64, 4) > 1) t = t//'.'
            do j = 1, next_rand(st64, 22) - 1
               t = t//achar(47 + next_rand(st64, 10))
            end do
            if (next_rand(st64, 3) > 1) then
               j = next_rand(st64, 4)
               t = t//expo_letters(j:j)
               j = next_rand(st64, 3)
               if (j == 1) t = t//'-'
               if (j == 2) t = t//'+'
               t = t//str(next_rand(st64, 340) - 1)
            end if
         end if
         call read_both(t, n_read, n_bad)
      end do
      call check('numbers read (of 60 014 texts, some refused)', n_read > 20000)
      call check('numbers that read differently from Fortran''s read', real(n_bad, wp), 0.0_wp, abs_tol=0.0_wp)
      ! the fast path's own range (D-175): 1 to 17 digits (15 and fewer take it), the point
      ! anywhere, exponents -30..30 (|digits' power| <= 22 takes it), and its edges
      n_bad = 0
      n_read = 0
      do k = 1, 60000
         if (k <= size(edges)) then
            t = trim(edges(k))
         else
            t = ''
            if (next_rand(st64, 4) == 1) t = '-'
            do j = 1, next_rand(st64, 17)
               t = t//achar(47 + next_rand(st64, 10))
            end do
            j = next_rand(st64, len(t) + 1)
            if (next_rand(st64, 3) > 1) t = t(1:j - 1)//'.'//t(j:)
            if (next_rand(st64, 2) == 1) t = t//'e'//str(next_rand(st64, 61) - 31)
         end if
         call read_both(t, n_read, n_bad)
      end do
      call check('short numbers read (of 60 000 texts)', n_read > 50000)
      call check('short numbers that read differently from Fortran''s read', real(n_bad, wp), 0.0_wp, abs_tol=0.0_wp)
   end subroutine test_parse_real_reads_as_fortran

   !> t by parse_real and by Fortran's read: counted as read when parse_real takes it, bad when they differ
   subroutine read_both(t, n_read, n_bad)
      use, intrinsic :: iso_fortran_env, only: int64
      character(len=*), intent(in) :: t
      integer, intent(inout) :: n_read, n_bad
      real(wp) :: v, ref
      integer :: stat, ios
      call parse_real(t, v, stat)
      if (stat /= 0) return
      n_read = n_read + 1
      read (t, *, iostat=ios) ref
      if (ios /= 0 .or. transfer(v, 0_int64) /= transfer(ref, 0_int64)) then
         n_bad = n_bad + 1
         if (n_bad <= 5) write (*, '(4x,3a,2es26.17)') 'differs: "', t, '"', v, ref
      end if
   end subroutine read_both

   !> 1..m from the xorshift sequence st.
   integer function next_rand(st, m)
      use, intrinsic :: iso_fortran_env, only: int64
      integer(int64), intent(inout) :: st
      integer, intent(in) :: m
      st = ieor(st, ishft(st, 13)); st = ieor(st, ishft(st, -7)); st = ieor(st, ishft(st, 17))
      next_rand = 1 + int(modulo(st, int(m, int64)))
   end function next_rand

end program test_deck
