!> Parameter overrides on a parsed deck: `--set TARGET.KEY=VALUE` on the command line
!> and the per-run values of a sweep. An override sets (or adds) the key's entry in one
!> group of the parsed deck before the model is built, so every plug-in reads and checks
!> it with its own rules and messages. TARGET is a node or element id, `run`, or
!> `GROUP#K` (the K-th &GROUP, e.g. `load#2`).
!>
!> Messages: an overridden entry carries the line number -k (k = its index in the
!> override list), and `localize_error` replaces "deck.nml:-k:" in a message by the
!> override's origin ("--set mesh.half_backlash=abc"), so the user sees what they typed.
!>
!> Keys that are not deck keys but derived parameters (`mesh_frequency`,
!> `settle_cycles`, `measure_cycles` of a gear element) are kept aside here and applied
!> to the built model by trainsim_derived.
module trainsim_overrides
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: string_t, to_lower, str, join
   use trainsim_deck, only: deck_t, deck_group_t, parse_deck
   implicit none
   private

   public :: override_t, parse_set_argument, make_override, apply_overrides, localize_error, localize_text, &
             describe_overrides
   public :: split_sweep_groups, derived_keys, is_derived_key, resolve_target, check_override

   !> The derived parameters (applied to the model, not to a deck group).
   character(len=*), parameter :: derived_keys(4) = [character(len=17) :: 'mesh_frequency', 'settle_cycles', &
                                                     'measure_cycles', 'settle_max_cycles']

   !> One `TARGET.KEY = VALUE[, VALUE ...]`.
   type :: override_t
      character(len=:), allocatable :: target     !< id, 'run' or 'group#k', as written
      character(len=:), allocatable :: key        !< lower case
      type(string_t), allocatable :: values(:)    !< raw tokens, strings unquoted
      logical, allocatable :: quoted(:)
      !> What a message names instead of "file:line", e.g. "--set mesh.half_backlash=abc"
      character(len=:), allocatable :: origin
      logical :: derived = .false.                !< a derived parameter (trainsim_derived)
   end type override_t

contains

   !> True for the keys of derived parameters.
   pure logical function is_derived_key(key)
      character(len=*), intent(in) :: key
      integer :: i
      is_derived_key = .false.
      do i = 1, size(derived_keys)
         if (to_lower(key) == trim(derived_keys(i))) is_derived_key = .true.
      end do
   end function is_derived_key

   !> Parse a `--set` argument `TARGET.KEY=VALUE`. VALUE is read with the deck's own
   !> lexer (quotes, lists, comments), so `--set "n4.value=-798.8"` and
   !> `--set "load#1.times=0, 0.1"` read as they would in a deck.
   subroutine parse_set_argument(arg, ov, err)
      character(len=*), intent(in) :: arg
      type(override_t), intent(out) :: ov
      type(error_t), allocatable, intent(out) :: err
      integer :: peq
      character(len=:), allocatable :: lhs, origin

      origin = '--set '//arg
      peq = index(arg, '=')
      if (peq == 0) then
         call fatal_error(err, origin//": error: expected TARGET.KEY=VALUE (e.g. mesh.half_backlash=2e-4), "// &
                          "found no '='", err_input)
         return
      end if
      lhs = trim(adjustl(arg(1:peq - 1)))
      call make_override(lhs, arg(peq + 1:), origin, ov, err)
   end subroutine parse_set_argument

   !> An override of `name` (TARGET.KEY) with the value text `value`; `origin` names it in messages.
   subroutine make_override(name, value, origin, ov, err)
      character(len=*), intent(in) :: name, value, origin
      type(override_t), intent(out) :: ov
      type(error_t), allocatable, intent(out) :: err
      type(deck_t) :: tmp
      integer :: pdot, p, v
      character(len=:), allocatable :: msg

      ov%origin = origin
      pdot = index(name, '.', back=.true.)
      if (pdot <= 1 .or. pdot == len(name)) then
         call fatal_error(err, origin//": error: expected TARGET.KEY=VALUE, where TARGET is a node or element id, "// &
                          "'run', or GROUP#K (e.g. load#2), got '"//name//"'", err_input)
         return
      end if
      ov%target = name(1:pdot - 1)
      ov%key = to_lower(name(pdot + 1:))
      if (len_trim(value) == 0) then
         call fatal_error(err, origin//": error: key '"//ov%key//"' has no value", err_input)
         return
      end if
      ! The value is lexed exactly as in a deck: one group, one entry.
      call parse_deck('&set '//ov%key//' = '//value//new_line('a')//'/', origin, tmp, err)
      if (allocated(err)) then
         msg = err%message
         p = index(msg, ': error: ')
         if (p > 0) msg = msg(p + 9:)
         p = index(msg, '&set #1: ')
         if (p == 1) msg = msg(10:)
         err%message = origin//': error: '//msg
         return
      end if
      if (size(tmp%groups) /= 1) then
         call fatal_error(err, origin//": error: the value holds an unquoted '/' (quote it)", err_input)
         return
      end if
      if (tmp%groups(1)%nentries() /= 1) then
         call fatal_error(err, origin//": error: expected one key, got "//str(tmp%groups(1)%nentries())// &
                          " (give one --set per key)", err_input)
         return
      end if
      if (tmp%groups(1)%key_of(1) /= ov%key) then
         call fatal_error(err, origin//": error: '"//ov%key//"' is not a key name (a letter, then letters, "// &
                          "digits and '_')", err_input)
         return
      end if
      allocate (ov%values(tmp%groups(1)%nvalues(1)), ov%quoted(tmp%groups(1)%nvalues(1)))
      do v = 1, size(ov%values)
         ov%values(v)%s = tmp%groups(1)%value_of(1, v)
         ov%quoted(v) = tmp%groups(1)%quoted(1, v)
      end do
      ov%derived = is_derived_key(ov%key)
   end subroutine make_override

   !> Set every non-derived override in its deck group (replacing the key's value, or
   !> adding the key). Later overrides of the same key win.
   subroutine apply_overrides(deck, ovs, err)
      type(deck_t), intent(inout) :: deck
      type(override_t), intent(in) :: ovs(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: k, ig

      do k = 1, size(ovs)
         call check_override(deck, ovs(k), ig, err)
         if (allocated(err)) return
         if (ovs(k)%derived) cycle
         call deck%groups(ig)%set_entry(ovs(k)%key, ovs(k)%values, ovs(k)%quoted, -k)
      end do
   end subroutine apply_overrides

   !> The group `ov` sets (its index `ig` in deck%groups), or an error if the deck has
   !> no such group or a derived key names a group that is not an element. The one
   !> check of a parameter path against a deck for --set, &sweep and the library's set.
   subroutine check_override(deck, ov, ig, err)
      type(deck_t), intent(in) :: deck
      type(override_t), intent(in) :: ov
      integer, intent(out) :: ig
      type(error_t), allocatable, intent(out) :: err
      call resolve_target(deck, ov, ig, err)
      if (allocated(err)) return
      if (ov%derived .and. .not. deck%groups(ig)%named('element')) then
         call fatal_error(err, ov%origin//": error: '"//ov%key//"' is a parameter of a gear "// &
                          "element, and '"//ov%target//"' is a &"//deck%groups(ig)%name//' group', err_input)
      end if
   end subroutine check_override

   !> Index in deck%groups of the group `ov%target` names.
   subroutine resolve_target(deck, ov, ig, err)
      type(deck_t), intent(in) :: deck
      type(override_t), intent(in) :: ov
      integer, intent(out) :: ig
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: gname, tgt, gid
      type(string_t), allocatable :: ids(:)
      integer :: p, k, i, ios, n_match, ord(2)
      character(len=*), parameter :: kinds(2) = ['node   ', 'element']

      ig = 0
      tgt = ov%target
      p = index(tgt, '#')
      if (to_lower(tgt) == 'run') then
         gname = 'run'
         k = 1
         if (deck%count_groups('run') /= 1) then
            call fatal_error(err, ov%origin//': error: the deck must have exactly one &run group, found '// &
                             str(deck%count_groups('run')), err_input)
            return
         end if
      else if (p > 1) then
         gname = to_lower(tgt(1:p - 1))
         read (tgt(p + 1:), *, iostat=ios) k
         if (ios /= 0 .or. verify(tgt(p + 1:), '0123456789') /= 0 .or. len(tgt) == p) k = 0
         if (k < 1 .or. k > deck%count_groups(gname)) then
            call fatal_error(err, ov%origin//": error: no group '"//tgt//"': the deck has "// &
                             str(deck%count_groups(gname))//' &'//gname//' group(s)', err_input)
            return
         end if
      else
         ! a node or element id (given or default: n<k>, e<k>)
         allocate (ids(0))
         n_match = 0
         do i = 1, size(deck%groups)
            associate (g => deck%groups(i))
               if (.not. g%named('node') .and. .not. g%named('element')) cycle
               gid = group_id(g)
               if (gid == tgt) then
                  n_match = n_match + 1
                  ig = i
                  ord(min(n_match, 2)) = i
               end if
               call append(ids, gid)
            end associate
         end do
         if (n_match == 1) return
         if (n_match == 0) then
            call fatal_error(err, ov%origin//": error: no node or element with id '"//tgt//"'; ids are: "// &
                             join(ids, ', ')//"; or use 'run' or GROUP#K (e.g. load#1)", err_input)
         else
            call fatal_error(err, ov%origin//": error: '"//tgt//"' is the id of a "// &
                             trim(kinds(merge(1, 2, deck%groups(ord(1))%named('node'))))//' and of an '// &
                             trim(kinds(merge(1, 2, deck%groups(ord(2))%named('node'))))// &
                             '; name the group as node#K or element#K', err_input)
         end if
         ig = 0
         return
      end if
      n_match = 0
      do i = 1, size(deck%groups)
         if (deck%groups(i)%name /= gname) cycle
         n_match = n_match + 1
         if (n_match == k) then
            ig = i
            return
         end if
      end do
   end subroutine resolve_target

   subroutine append(list, item)
      type(string_t), allocatable, intent(inout) :: list(:)
      character(len=*), intent(in) :: item
      type(string_t), allocatable :: tmp(:)
      allocate (tmp(size(list) + 1))
      tmp(1:size(list)) = list
      tmp(size(tmp))%s = item
      call move_alloc(tmp, list)
   end subroutine append

   !> The id of a &node or &element group: its `id` value, else n<k> / e<k>.
   function group_id(g) result(id)
      type(deck_group_t), intent(in) :: g
      character(len=:), allocatable :: id
      integer :: j
      do j = 1, g%nentries()
         if (g%key_of(j) == 'id') then
            if (g%nvalues(j) > 0) then
               id = g%value_of(j, 1)
               return
            end if
         end if
      end do
      id = g%name(1:1)//str(g%ordinal)
   end function group_id

   !> Replace "FILE:-k:" in an error (or a message's text) by the origin of override k.
   subroutine localize_error(err, file, ovs)
      type(error_t), intent(inout) :: err
      character(len=*), intent(in) :: file
      type(override_t), intent(in) :: ovs(:)
      call localize_text(err%message, file, ovs)
   end subroutine localize_error

   !> Replace "FILE:-k:" in `text` (a warning) by the origin of override k.
   subroutine localize_text(text, file, ovs)
      character(len=:), allocatable, intent(inout) :: text
      character(len=*), intent(in) :: file
      type(override_t), intent(in) :: ovs(:)
      character(len=:), allocatable :: marker
      integer :: k, p
      do k = 1, size(ovs)
         marker = file//':-'//str(k)//':'
         p = index(text, marker)
         if (p > 0) text = text(1:p - 1)//ovs(k)%origin//':'//text(p + len(marker):)
      end do
   end subroutine localize_text

   !> Move the &sweep groups out of `deck` into `sweeps`, and drop its &runup group (read by
   !> trainsim runup before this, D-109): the builder knows neither.
   subroutine split_sweep_groups(deck, sweeps)
      type(deck_t), intent(inout) :: deck
      type(deck_group_t), allocatable, intent(out) :: sweeps(:)
      logical, allocatable :: is_sweep(:), other(:)
      integer :: i
      allocate (is_sweep(size(deck%groups)), other(size(deck%groups)))
      do i = 1, size(deck%groups)
         is_sweep(i) = deck%groups(i)%named('sweep')
         other(i) = deck%groups(i)%named('runup')   ! (trainsim runup's, D-109: read there, dropped here)
      end do
      if (.not. any(is_sweep .or. other)) then   ! no copy of the deck's groups (D-74)
         allocate (sweeps(0))
         return
      end if
      sweeps = pack(deck%groups, is_sweep)
      deck%groups = pack(deck%groups, .not. (is_sweep .or. other))
   end subroutine split_sweep_groups
   !> The overrides as `--set` would write them, separated by blanks, e.g.
   !> "mesh.half_backlash=2e-4 run.integrator='cvode-bdf'" ('' for none): what a run
   !> file records beside the deck, so deck + overrides reproduce the run.
   function describe_overrides(ovs) result(text)
      type(override_t), intent(in) :: ovs(:)
      character(len=:), allocatable :: text
      integer :: i, j
      text = ''
      do i = 1, size(ovs)
         if (i > 1) text = text//' '
         text = text//ovs(i)%target//'.'//ovs(i)%key//'='
         do j = 1, size(ovs(i)%values)
            if (j > 1) text = text//','
            if (ovs(i)%quoted(j)) then
               text = text//"'"//ovs(i)%values(j)%s//"'"
            else
               text = text//ovs(i)%values(j)%s
            end if
         end do
      end do
   end function describe_overrides
end module trainsim_overrides
