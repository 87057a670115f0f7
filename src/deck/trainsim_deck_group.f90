!> One `&name ... /` group of a deck and its typed getters. A getter converts the raw
!> tokens of a key, checks them and records the key as valid, so that `check_unused`
!> can report a misspelt key with the closest valid one (D-62); every message names the
!> file, the line, the group and the key.
module trainsim_deck_group
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: string_t, to_lower, str, join, edit_distance
   use trainsim_deck_lexer, only: parse_real, parse_int, digits
   implicit none
   private

   public :: deck_group_t, deck_entry_t, same_key

   !> One `key = value[, value ...]` item of a group. Its key and values are places in
   !> the group's `pool`, not a heap string each (D-159): read them through
   !> the group, `g%key_of(k)`, `g%nvalues(k)`, `g%value_of(k, j)`, `g%quoted(k, j)`.
   type :: deck_entry_t
      integer :: key_at = 0, key_len = 0            !< key = pool(key_at:key_at+key_len-1), lower case
      integer :: first = 0                          !< its values are the group's vals(:, first:first+n-1)
      integer :: n = 0                              !< number of values
      integer :: line = 0                           !< line of the key
      logical :: used = .false.                     !< set by the getters
      integer :: asked = 0                          !< order of the key's first query (0: never asked)
   end type deck_entry_t

   !> One `&name ... /` group of a deck.
   type :: deck_group_t
      character(len=:), allocatable :: name         !< lower case, without '&'
      character(len=:), allocatable :: file         !< deck file name (for messages)
      integer :: line = 0                           !< line of '&name'
      integer :: ordinal = 0                        !< 1 for the first group of this name, 2 for the second...
      type(deck_entry_t), allocatable :: entries(:) !< in file order
      !> The entries' keys and values end to end (raw tokens; strings unquoted), and
      !> each value's place in it: vals(1, v) its start, vals(2, v) its length,
      !> vals(3, v) 1 where it was a quoted string. Filled by the parser and `set_entry`.
      character(len=:), allocatable :: pool
      integer :: pool_len = 0
      integer, allocatable :: vals(:, :)
      integer :: nvals = 0
      !> Keys asked for through has/get_*/count_values (D-62): a key present by the order
      !> of its first query in its entry's `asked`, without a copy of its text; an absent
      !> one here, followed by ',' and the order of its query in 4 bytes, in one text (one
      !> allocation a group, not one a key: D-90, D-176). nasked: the queries so far.
      character(len=:), allocatable, private :: queried
      integer, private :: queried_len = 0
      integer, private :: nasked = 0
   contains
      procedure :: has => group_has
      procedure :: holds => group_holds
      procedure :: expect => group_expect
      procedure :: get_real => group_get_real
      procedure :: get_int => group_get_int
      procedure :: get_logical => group_get_logical
      procedure :: get_string => group_get_string
      procedure :: get_optional_string => group_get_optional_string
      procedure :: get_real_array => group_get_real_array
      procedure :: count_values => group_count_values
      procedure :: where => group_where
      procedure :: label => group_label
      procedure :: check_unused => group_check_unused
      procedure :: all_used => group_all_used
      procedure :: named => group_named
      procedure :: nentries => group_nentries
      procedure :: key_of => group_key_of
      procedure :: nvalues => group_nvalues
      procedure :: value_of => group_value_of
      procedure :: quoted => group_quoted
      procedure :: set_entry => group_set_entry
      procedure :: require_positive => group_require_positive
      procedure :: require_nonnegative => group_require_nonnegative
   end type deck_group_t

   interface
      !> Error naming the first entry not read by a getter, listing the keys that were queried.
      !> `context` (e.g. "element type 'shaft'") says what the keys were checked against.
      module subroutine group_check_unused(self, err, context)
         class(deck_group_t), intent(in) :: self
         type(error_t), allocatable, intent(out) :: err
         character(len=*), intent(in), optional :: context
      end subroutine group_check_unused

      !> Set `key` (lower case) to `values` (quoted where `quoted`), given on `line`: the
      !> entry of that key is replaced, else one is added (an override, a generated group).
      module subroutine group_set_entry(self, key, values, quoted, line)
         class(deck_group_t), intent(inout) :: self
         character(len=*), intent(in) :: key
         type(string_t), intent(in) :: values(:)
         logical, intent(in) :: quoted(:)
         integer, intent(in) :: line
      end subroutine group_set_entry

      !> Write `key` (lower case) into the queried keys with the order of its query (an
      !> absent key, or one padded with blanks: D-176).
      module subroutine record_query(self, key)
         class(deck_group_t), intent(inout) :: self
         character(len=*), intent(in) :: key
      end subroutine record_query

      !> Index of the entry not yet read whose key is a likely misspelling of `key` (0: none).
      module integer function near_miss(self, key) result(best)
         class(deck_group_t), intent(in) :: self
         character(len=*), intent(in) :: key
      end function near_miss

      !> "file:LINE: error: LABEL: text"
      module subroutine fail(self, err, line, text)
         class(deck_group_t), intent(in) :: self
         type(error_t), allocatable, intent(out) :: err
         integer, intent(in) :: line
         character(len=*), intent(in) :: text
      end subroutine fail
   end interface

contains

   !> True if the group has an entry `key` (case-insensitive). Records `key` as a valid key.
   logical function group_has(self, key) result(yes)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      yes = query(self, key) > 0
   end function group_has

   !> True if the group has an entry `key`, WITHOUT recording `key` as a valid key (for a
   !> key of another form of the group, to explain it: D-62).
   logical function group_holds(self, key) result(yes)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: key
      yes = find(self, key) > 0
   end function group_holds

   !> Record `keys` as valid before reading them: keys a step apart (rb_driver, rb_driven)
   !> are then never taken for a misspelling of one another when one is missing (D-62).
   subroutine group_expect(self, keys)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: keys(:)
      integer :: j, k
      do j = 1, size(keys)
         k = query(self, trim(keys(j)))
      end do
   end subroutine group_expect

   !> Number of values given for `key` (0 if absent). Records `key` as a valid key.
   integer function group_count_values(self, key) result(n)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      integer :: k
      k = query(self, key)
      n = 0
      if (k > 0) n = self%entries(k)%n
   end function group_count_values

   !> Location for messages: "file:LINE: &name #ordinal", plus ", key 'k'" (and the key's line)
   !> if `key` is present in the group; otherwise the group's line. Built in one allocation
   !> (it is every node's and element's origin, D-90).
   function group_where(self, key) result(s)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in), optional :: key
      character(len=:), allocatable :: s
      character(len=12) :: lt, ot
      integer :: k, nl, no, n, p
      k = 0
      if (present(key)) k = find(self, key)
      if (k > 0) then
         call digits(self%entries(k)%line, lt, nl)
      else
         call digits(self%line, lt, nl)
      end if
      call digits(self%ordinal, ot, no)
      n = len(self%file) + nl + len(self%name) + no + 6
      if (k > 0) n = n + self%entries(k)%key_len + 8
      allocate (character(len=n) :: s)   ! (pieces placed in turn: an internal `put` was a call each)
      p = len(self%file)
      s(1:p) = self%file
      s(p + 1:p + 1) = ':'
      s(p + 2:p + 1 + nl) = lt(1:nl)
      p = p + 1 + nl
      s(p + 1:p + 3) = ': &'
      s(p + 4:p + 3 + len(self%name)) = self%name
      p = p + 3 + len(self%name)
      s(p + 1:p + 2) = ' #'
      s(p + 3:p + 2 + no) = ot(1:no)
      p = p + 2 + no
      if (k > 0) then
         associate (e => self%entries(k))
            s(p + 1:p + 7) = ", key '"
            s(p + 8:p + 7 + e%key_len) = self%pool(e%key_at:e%key_at + e%key_len - 1)
            s(p + 8 + e%key_len:p + 8 + e%key_len) = "'"
         end associate
      end if
   end function group_where

   !> "&element #2 (id 'g1')" if the group has an 'id' entry, else "&element #2".
   function group_label(self) result(s)
      class(deck_group_t), intent(in) :: self
      character(len=:), allocatable :: s
      integer :: k
      s = '&'//self%name//' #'//str(self%ordinal)
      k = find(self, 'id')
      if (k > 0) then
         if (self%entries(k)%n > 0) s = s//" (id '"//self%value_of(k, 1)//"')"
      end if
   end function group_label

   !> Error naming the key and its value unless value > 0 (NaN fails too).
   subroutine group_require_positive(self, key, value, err)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: key
      real(wp), intent(in) :: value
      type(error_t), allocatable, intent(inout) :: err
      if (allocated(err)) return
      if (.not. value > 0.0_wp) call fatal_error(err, self%where(key)//': error: '//key//' must be > 0, got '// &
                                                 str(value), err_input)
   end subroutine group_require_positive

   !> Error naming the key and its value unless value >= 0 (NaN fails too).
   subroutine group_require_nonnegative(self, key, value, err)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: key
      real(wp), intent(in) :: value
      type(error_t), allocatable, intent(inout) :: err
      if (allocated(err)) return
      if (.not. value >= 0.0_wp) call fatal_error(err, self%where(key)//': error: '//key//' must be >= 0, got '// &
                                                  str(value), err_input)
   end subroutine group_require_nonnegative

   !> Number of entries (0 before the group is parsed).
   pure integer function group_nentries(self) result(n)
      class(deck_group_t), intent(in) :: self
      n = 0
      if (allocated(self%entries)) n = size(self%entries)
   end function group_nentries

   !> Key of entry k, lower case.
   function group_key_of(self, k) result(s)
      class(deck_group_t), intent(in) :: self
      integer, intent(in) :: k
      character(len=:), allocatable :: s
      s = self%pool(self%entries(k)%key_at:self%entries(k)%key_at + self%entries(k)%key_len - 1)
   end function group_key_of

   !> Number of values of entry k.
   pure integer function group_nvalues(self, k) result(n)
      class(deck_group_t), intent(in) :: self
      integer, intent(in) :: k
      n = self%entries(k)%n
   end function group_nvalues

   !> Value j of entry k as written (a string's contents without its quotes).
   function group_value_of(self, k, j) result(s)
      class(deck_group_t), intent(in) :: self
      integer, intent(in) :: k, j
      character(len=:), allocatable :: s
      associate (v => self%vals(:, self%entries(k)%first + j - 1))
         s = self%pool(v(1):v(1) + v(2) - 1)
      end associate
   end function group_value_of

   !> Value j of entry k was a quoted string.
   pure logical function group_quoted(self, k, j) result(yes)
      class(deck_group_t), intent(in) :: self
      integer, intent(in) :: k, j
      yes = self%vals(3, self%entries(k)%first + j - 1) /= 0
   end function group_quoted

   !> The group is `&name` (`name` in lower case), compared by character codes: a
   !> string comparison is a library call, and every reader walks all the groups (D-151).
   pure logical function group_named(self, name) result(yes)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: name
      integer :: i
      yes = .false.
      if (.not. allocated(self%name)) return
      if (len(self%name) /= len(name)) return
      do i = 1, len(name)
         if (iachar(self%name(i:i)) /= iachar(name(i:i))) return
      end do
      yes = .true.
   end function group_named

   !> Every entry was read by a getter (check_unused has nothing to say; its
   !> context, built by the caller, is then not needed: D-151).
   pure logical function group_all_used(self) result(yes)
      class(deck_group_t), intent(in) :: self
      yes = .true.
      if (allocated(self%entries)) yes = all(self%entries(:)%used)
   end function group_all_used

   !> Real value of `key`. If absent: `default` if given, else an error. Exactly one unquoted
   !> value is required; d/D exponents are accepted, nan/inf and trailing text are not.
   subroutine group_get_real(self, key, val, err, default)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      real(wp), intent(out) :: val
      type(error_t), allocatable, intent(out) :: err
      real(wp), intent(in), optional :: default
      integer :: k
      integer :: stat
      val = 0.0_wp
      call scalar_entry(self, key, 'a real number', present(default), k, err)
      if (allocated(err)) return
      if (k == 0) then
         if (present(default)) val = default
         return
      end if
      call check_unquoted(self, k, 1, 'a real number', err)
      if (allocated(err)) return
      associate (v => self%vals(:, self%entries(k)%first))
         call parse_real(self%pool(v(1):v(1) + v(2) - 1), val, stat)
      end associate
      if (stat /= 0) call bad_value(self, k, 1, 'a real number', err, stat == 2)
   end subroutine group_get_real

   !> Integer value of `key` (same rules as get_real; `1.5` and `1.0` are rejected).
   subroutine group_get_int(self, key, val, err, default)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      integer, intent(out) :: val
      type(error_t), allocatable, intent(out) :: err
      integer, intent(in), optional :: default
      integer :: k, stat
      val = 0
      call scalar_entry(self, key, 'an integer', present(default), k, err)
      if (allocated(err)) return
      if (k == 0) then
         if (present(default)) val = default
         return
      end if
      call check_unquoted(self, k, 1, 'an integer', err)
      if (allocated(err)) return
      associate (v => self%vals(:, self%entries(k)%first))
         call parse_int(self%pool(v(1):v(1) + v(2) - 1), val, stat)
      end associate
      if (stat /= 0) call bad_value(self, k, 1, 'an integer', err, stat == 2)
   end subroutine group_get_int

   !> Logical value of `key`: .true./.false./T/F/.t./.f./true/false, any case, unquoted.
   subroutine group_get_logical(self, key, val, err, default)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      logical, intent(out) :: val
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: default
      integer :: k
      logical :: ok
      val = .false.
      call scalar_entry(self, key, 'a logical', present(default), k, err)
      if (allocated(err)) return
      if (k == 0) then
         if (present(default)) val = default
         return
      end if
      call check_unquoted(self, k, 1, 'a logical (.true. or .false.)', err)
      if (allocated(err)) return
      ok = .true.
      select case (to_lower(self%value_of(k, 1)))
      case ('.true.', '.t.', 't', 'true')
         val = .true.
      case ('.false.', '.f.', 'f', 'false')
         val = .false.
      case default
         ok = .false.
      end select
      if (.not. ok) call bad_value(self, k, 1, 'a logical (.true. or .false.)', err)
   end subroutine group_get_logical

   !> String value of `key`, quoted or bare, as written (no case change).
   subroutine group_get_string(self, key, val, err, default)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      character(len=:), allocatable, intent(out) :: val
      type(error_t), allocatable, intent(out) :: err
      character(len=*), intent(in), optional :: default
      integer :: k
      call scalar_entry(self, key, 'a string', present(default), k, err)
      if (k == 0 .or. allocated(err)) then   ! (val allocated once: '' or the default)
         if (present(default) .and. .not. allocated(err)) then
            val = default
         else
            val = ''
         end if
         return
      end if
      call entry_string(self, k, val)
   end subroutine group_get_string

   !> The string of entry k (its first value, in the pool).
   subroutine entry_string(self, k, val)
      class(deck_group_t), intent(in) :: self
      integer, intent(in) :: k
      character(len=:), allocatable, intent(inout) :: val
      associate (v => self%vals(:, self%entries(k)%first))
         val = self%pool(v(1):v(1) + v(2) - 1)
      end associate
   end subroutine entry_string

   !> String value of `key` (found), else '': as get_string with default '', but `val`
   !> kept when it holds '' already (no '' allocated and freed an absent key: D-175).
   subroutine group_get_optional_string(self, key, val, found, err)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      character(len=:), allocatable, intent(inout) :: val
      logical, intent(out) :: found
      type(error_t), allocatable, intent(out) :: err
      integer :: k
      call scalar_entry(self, key, 'a string', .true., k, err)
      found = k > 0 .and. .not. allocated(err)
      if (.not. found) then
         if (.not. allocated(val)) then
            val = ''
         else if (len(val) > 0) then
            val = ''
         end if
         return
      end if
      call entry_string(self, k, val)
   end subroutine group_get_optional_string

   !> All values of `key` as reals. An absent key gives a size-0 array and no error.
   subroutine group_get_real_array(self, key, vals, err)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      real(wp), allocatable, intent(out) :: vals(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: k, j, stat
      k = query(self, key)
      if (k == 0) then
         allocate (vals(0))
         return
      end if
      self%entries(k)%used = .true.
      allocate (vals(self%entries(k)%n))
      vals = 0.0_wp
      do j = 1, size(vals)
         call check_unquoted(self, k, j, 'a real number', err)
         if (allocated(err)) return
         associate (v => self%vals(:, self%entries(k)%first + j - 1))
            call parse_real(self%pool(v(1):v(1) + v(2) - 1), vals(j), stat)
         end associate
         if (stat /= 0) then
            call bad_value(self, k, j, 'a real number', err, stat == 2)
            return
         end if
      end do
   end subroutine group_get_real_array

   !> Common part of the scalar getters: record the query, find the entry (k = 0 if absent),
   !> mark it used, and check that it has exactly one value.
   subroutine scalar_entry(self, key, what, has_default, k, err)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key, what
      logical, intent(in) :: has_default
      integer, intent(out) :: k
      type(error_t), allocatable, intent(out) :: err
      integer :: j
      k = query(self, key)
      if (k == 0) then
         if (.not. has_default) then
            ! a misspelt key is reported on its own line, before the key it stands for (D-62)
            j = near_miss(self, key)
            if (j > 0) then
               call fail(self, err, self%entries(j)%line, "unknown key '"//self%key_of(j)// &
                         "'; did you mean '"//to_lower(key)//"'? (the required key '"//to_lower(key)// &
                         "' ("//what//') is missing)')
            else
               call fail(self, err, self%line, "missing required key '"//to_lower(key)//"' ("//what//')')
            end if
         end if
         return
      end if
      self%entries(k)%used = .true.
      if (self%entries(k)%n /= 1) then
         call fail(self, err, self%entries(k)%line, "key '"//self%key_of(k)// &
                   "': expected one value, got "//str(self%entries(k)%n))
      end if
   end subroutine scalar_entry

   subroutine check_unquoted(self, k, j, what, err)
      class(deck_group_t), intent(in) :: self
      integer, intent(in) :: k, j
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      if (self%vals(3, self%entries(k)%first + j - 1) /= 0) then
         call fail(self, err, self%entries(k)%line, "key '"//self%key_of(k)//"'"//value_no(self, k, j)// &
                   ': expected '//what//", got the quoted string '"//self%value_of(k, j)//"' (remove the quotes)")
      end if
   end subroutine check_unquoted

   subroutine bad_value(self, k, j, what, err, out_of_range)
      class(deck_group_t), intent(in) :: self
      integer, intent(in) :: k, j
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: out_of_range
      character(len=:), allocatable :: note
      note = ''
      if (present(out_of_range)) then
         if (out_of_range) note = ' (out of range)'
      end if
      call fail(self, err, self%entries(k)%line, "key '"//self%key_of(k)//"'"//value_no(self, k, j)// &
                ': expected '//what//", got '"//self%value_of(k, j)//"'"//note)
   end subroutine bad_value

   !> ", value J" when the entry has several values, else ''.
   function value_no(self, k, j) result(s)
      class(deck_group_t), intent(in) :: self
      integer, intent(in) :: k, j
      character(len=:), allocatable :: s
      s = ''
      if (self%entries(k)%n > 1) s = ' (value '//str(j)//')'
   end function value_no

   !> Index of entry `key` (case-insensitive), 0 if absent.
   !> A stored key never ends in a blank, so one of another length matches only a
   !> `key` padded with blanks: the others are passed over without a comparison.
   integer function find(self, key) result(k)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: key
      integer :: j, n, i, c, at
      logical :: padded
      k = 0
      if (.not. allocated(self%entries)) return
      n = len(key)
      padded = .false.
      if (n > 0) padded = iachar(key(n:n)) == 32
      do j = 1, size(self%entries)
         at = self%entries(j)%key_at
         if (self%entries(j)%key_len /= n) then
            if (.not. padded) cycle
            if (same_key(self%pool(at:at + self%entries(j)%key_len - 1), key)) then
               k = j
               return
            end if
            cycle
         end if
         do i = 1, n   ! the same length: by codes, `key` folded to lower case (same_key inline)
            c = iachar(key(i:i))
            if (c >= 65 .and. c <= 90) c = c + 32
            if (iachar(self%pool(at + i - 1:at + i - 1)) /= c) exit
         end do
         if (i > n) then
            k = j
            return
         end if
      end do
   end function find

   !> Index of entry `key` as `find`, the query recorded: a key present by the order of
   !> its first query in its entry (no copy of its text, D-176), another in `queried`.
   integer function query(self, key) result(k)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      k = find(self, key)
      if (k > 0) then
         if (self%entries(k)%key_len == len(key)) then   ! (not padded: the key as stored)
            if (self%entries(k)%asked == 0) then
               self%nasked = self%nasked + 1
               self%entries(k)%asked = self%nasked
            end if
            return
         end if
      end if
      call record_query(self, key)
   end function query

   !> `stored` (lower case) == `key` in lower case, blank-padded as Fortran compares,
   !> without a lowered copy of `key` (an allocation a look-up, D-90). By character
   !> codes: gfortran compares a character with a blank through len_trim (D-151).
   pure logical function same_key(stored, key) result(yes)
      character(len=*), intent(in) :: stored, key
      integer :: i, c, n
      yes = .false.
      n = min(len(stored), len(key))
      do i = 1, n
         c = iachar(key(i:i))
         if (c >= 65 .and. c <= 90) c = c + 32
         if (iachar(stored(i:i)) /= c) return
      end do
      do i = n + 1, len(stored)   ! the longer one's rest: blanks
         if (iachar(stored(i:i)) /= 32) return
      end do
      do i = n + 1, len(key)
         if (iachar(key(i:i)) /= 32) return
      end do
      yes = .true.
   end function same_key

end module trainsim_deck_group
