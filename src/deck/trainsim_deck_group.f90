!> One `&name ... /` group of a deck and its typed getters. A getter converts the raw
!> tokens of a key, checks them and records the key as valid, so that `check_unused`
!> can report a misspelt key with the closest valid one (D-62); every message names the
!> file, the line, the group and the key.
module trainsim_deck_group
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: string_t, to_lower, str, join, edit_distance
   use trainsim_deck_lexer, only: parse_real, parse_int, lower_in_place, digits
   implicit none
   private

   public :: deck_group_t, deck_entry_t, same_key

   !> One `key = value[, value ...]` item of a group.
   type :: deck_entry_t
      character(len=:), allocatable :: key          !< lower case
      type(string_t), allocatable :: values(:)      !< raw tokens; strings unquoted
      logical, allocatable :: quoted(:)             !< .true. where the token was a quoted string
      integer :: line = 0                           !< line of the key
      logical :: used = .false.                     !< set by the getters
   end type deck_entry_t

   !> One `&name ... /` group of a deck.
   type :: deck_group_t
      character(len=:), allocatable :: name         !< lower case, without '&'
      character(len=:), allocatable :: file         !< deck file name (for messages)
      integer :: line = 0                           !< line of '&name'
      integer :: ordinal = 0                        !< 1 for the first group of this name, 2 for the second...
      type(deck_entry_t), allocatable :: entries(:) !< in file order
      !> Keys asked for through has/get_*/count_values, in order of first query, each
      !> followed by ',' in one text (one allocation a group, not one a key: D-90).
      character(len=:), allocatable, private :: queried
      integer, private :: queried_len = 0
   contains
      procedure :: has => group_has
      procedure :: holds => group_holds
      procedure :: expect => group_expect
      procedure :: get_real => group_get_real
      procedure :: get_int => group_get_int
      procedure :: get_logical => group_get_logical
      procedure :: get_string => group_get_string
      procedure :: get_real_array => group_get_real_array
      procedure :: count_values => group_count_values
      procedure :: where => group_where
      procedure :: label => group_label
      procedure :: check_unused => group_check_unused
      procedure :: all_used => group_all_used
      procedure :: named => group_named
      procedure :: require_positive => group_require_positive
      procedure :: require_nonnegative => group_require_nonnegative
   end type deck_group_t

contains

   !> True if the group has an entry `key` (case-insensitive). Records `key` as a valid key.
   logical function group_has(self, key) result(yes)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      call record_query(self, key)
      yes = find(self, key) > 0
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
      integer :: j
      do j = 1, size(keys)
         call record_query(self, trim(keys(j)))
      end do
   end subroutine group_expect

   !> Number of values given for `key` (0 if absent). Records `key` as a valid key.
   integer function group_count_values(self, key) result(n)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      integer :: k
      call record_query(self, key)
      k = find(self, key)
      n = 0
      if (k > 0) n = size(self%entries(k)%values)
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
      if (k > 0) n = n + len(self%entries(k)%key) + 8
      allocate (character(len=n) :: s)
      p = 0
      call put(self%file)
      call put(':')
      call put(lt(1:nl))
      call put(': &')
      call put(self%name)
      call put(' #')
      call put(ot(1:no))
      if (k > 0) then
         call put(", key '")
         call put(self%entries(k)%key)
         call put("'")
      end if
   contains
      subroutine put(t)
         character(len=*), intent(in) :: t
         s(p + 1:p + len(t)) = t
         p = p + len(t)
      end subroutine put
   end function group_where

   !> "&element #2 (id 'g1')" if the group has an 'id' entry, else "&element #2".
   function group_label(self) result(s)
      class(deck_group_t), intent(in) :: self
      character(len=:), allocatable :: s
      integer :: k
      s = '&'//self%name//' #'//str(self%ordinal)
      k = find(self, 'id')
      if (k > 0) then
         if (size(self%entries(k)%values) > 0) s = s//" (id '"//self%entries(k)%values(1)%s//"')"
      end if
   end function group_label

   !> Error naming the first entry not read by a getter, listing the keys that were queried.
   !> `context` (e.g. "element type 'shaft'") says what the keys were checked against.
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

   subroutine group_check_unused(self, err, context)
      class(deck_group_t), intent(in) :: self
      type(error_t), allocatable, intent(out) :: err
      character(len=*), intent(in), optional :: context
      character(len=:), allocatable :: msg
      type(string_t), allocatable :: queried(:)
      integer :: k, best
      if (.not. allocated(self%entries)) return
      do k = 1, size(self%entries)
         if (self%entries(k)%used) cycle
         msg = "unknown key '"//self%entries(k)%key//"'"
         if (present(context)) then
            if (len_trim(context) > 0) msg = msg//' for '//trim(context)
         end if
         queried = queried_keys(self)
         best = closest_key(self%entries(k)%key, queried)
         if (best > 0) msg = msg//"; did you mean '"//queried(best)%s//"'?"
         if (size(queried) > 0) then
            msg = msg//'; valid keys are: '//join(queried, ', ')
         else
            msg = msg//'; this group takes no keys'
         end if
         call fail(self, err, self%entries(k)%line, msg)
         return
      end do
   end subroutine group_check_unused

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
      associate (e => self%entries(k))
         call check_unquoted(self, e, 1, 'a real number', err)
         if (allocated(err)) return
         call parse_real(e%values(1)%s, val, stat)
         if (stat /= 0) call bad_value(self, e, 1, 'a real number', err, stat == 2)
      end associate
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
      associate (e => self%entries(k))
         call check_unquoted(self, e, 1, 'an integer', err)
         if (allocated(err)) return
         call parse_int(e%values(1)%s, val, stat)
         if (stat /= 0) call bad_value(self, e, 1, 'an integer', err, stat == 2)
      end associate
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
      associate (e => self%entries(k))
         call check_unquoted(self, e, 1, 'a logical (.true. or .false.)', err)
         if (allocated(err)) return
         ok = .true.
         select case (to_lower(e%values(1)%s))
         case ('.true.', '.t.', 't', 'true')
            val = .true.
         case ('.false.', '.f.', 'f', 'false')
            val = .false.
         case default
            ok = .false.
         end select
         if (.not. ok) call bad_value(self, e, 1, 'a logical (.true. or .false.)', err)
      end associate
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
         val = ''
         if (present(default) .and. .not. allocated(err)) val = default
         return
      end if
      val = self%entries(k)%values(1)%s
   end subroutine group_get_string

   !> All values of `key` as reals. An absent key gives a size-0 array and no error.
   subroutine group_get_real_array(self, key, vals, err)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      real(wp), allocatable, intent(out) :: vals(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: k, j, stat
      call record_query(self, key)
      k = find(self, key)
      if (k == 0) then
         allocate (vals(0))
         return
      end if
      associate (e => self%entries(k))
         e%used = .true.
         allocate (vals(size(e%values)))
         vals = 0.0_wp
         do j = 1, size(e%values)
            call check_unquoted(self, e, j, 'a real number', err)
            if (allocated(err)) return
            call parse_real(e%values(j)%s, vals(j), stat)
            if (stat /= 0) then
               call bad_value(self, e, j, 'a real number', err, stat == 2)
               return
            end if
         end do
      end associate
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
      call record_query(self, key)
      k = find(self, key)
      if (k == 0) then
         if (.not. has_default) then
            ! a misspelt key is reported on its own line, before the key it stands for (D-62)
            j = near_miss(self, key)
            if (j > 0) then
               call fail(self, err, self%entries(j)%line, "unknown key '"//self%entries(j)%key// &
                         "'; did you mean '"//to_lower(key)//"'? (the required key '"//to_lower(key)// &
                         "' ("//what//') is missing)')
            else
               call fail(self, err, self%line, "missing required key '"//to_lower(key)//"' ("//what//')')
            end if
         end if
         return
      end if
      self%entries(k)%used = .true.
      if (size(self%entries(k)%values) /= 1) then
         call fail(self, err, self%entries(k)%line, "key '"//self%entries(k)%key// &
                   "': expected one value, got "//str(size(self%entries(k)%values)))
      end if
   end subroutine scalar_entry

   subroutine check_unquoted(self, e, j, what, err)
      class(deck_group_t), intent(in) :: self
      type(deck_entry_t), intent(in) :: e
      integer, intent(in) :: j
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      if (e%quoted(j)) then
         call fail(self, err, e%line, "key '"//e%key//"'"//value_no(e, j)//': expected '//what// &
                   ", got the quoted string '"//e%values(j)%s//"' (remove the quotes)")
      end if
   end subroutine check_unquoted

   subroutine bad_value(self, e, j, what, err, out_of_range)
      class(deck_group_t), intent(in) :: self
      type(deck_entry_t), intent(in) :: e
      integer, intent(in) :: j
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: out_of_range
      character(len=:), allocatable :: note
      note = ''
      if (present(out_of_range)) then
         if (out_of_range) note = ' (out of range)'
      end if
      call fail(self, err, e%line, "key '"//e%key//"'"//value_no(e, j)//': expected '//what// &
                ", got '"//e%values(j)%s//"'"//note)
   end subroutine bad_value

   !> ", value J" when the entry has several values, else ''.
   function value_no(e, j) result(s)
      type(deck_entry_t), intent(in) :: e
      integer, intent(in) :: j
      character(len=:), allocatable :: s
      s = ''
      if (size(e%values) > 1) s = ' (value '//str(j)//')'
   end function value_no

   !> "file:LINE: error: LABEL: text"
   subroutine fail(self, err, line, text)
      class(deck_group_t), intent(in) :: self
      type(error_t), allocatable, intent(out) :: err
      integer, intent(in) :: line
      character(len=*), intent(in) :: text
      call fatal_error(err, self%file//':'//str(line)//': error: '//self%label()//': '//text, err_input)
   end subroutine fail

   !> Index of entry `key` (case-insensitive), 0 if absent.
   !> A stored key never ends in a blank, so one of another length matches only a
   !> `key` padded with blanks: the others are passed over without a comparison.
   integer function find(self, key) result(k)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: key
      integer :: j, n
      logical :: padded
      k = 0
      if (.not. allocated(self%entries)) return
      n = len(key)
      padded = .false.
      if (n > 0) padded = iachar(key(n:n)) == 32
      do j = 1, size(self%entries)
         if (len(self%entries(j)%key) /= n .and. .not. padded) cycle
         if (same_key(self%entries(j)%key, key)) then
            k = j
            return
         end if
      end do
   end function find

   !> Index of the entry not yet read whose key is a likely misspelling of `key` (0: none):
   !> the closest by edit distance within the threshold of `is_near`, not itself a queried key.
   integer function near_miss(self, key) result(best)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: key
      integer :: j, d, dbest
      logical :: asked
      best = 0
      dbest = huge(1)
      if (.not. allocated(self%entries)) return
      do j = 1, size(self%entries)
         if (self%entries(j)%used) cycle
         asked = was_queried(self, self%entries(j)%key)
         if (asked) cycle
         d = edit_distance(self%entries(j)%key, to_lower(key))
         if (is_near(d, to_lower(key)) .and. d < dbest) then
            best = j
            dbest = d
         end if
      end do
   end function near_miss

   !> Index in `keys` of the closest key to `word` within the threshold of `is_near` (0: none).
   integer function closest_key(word, keys) result(best)
      character(len=*), intent(in) :: word
      type(string_t), intent(in) :: keys(:)
      integer :: j, d, dbest
      best = 0
      dbest = huge(1)
      do j = 1, size(keys)
         d = edit_distance(word, keys(j)%s)
         if (is_near(d, keys(j)%s) .and. d < dbest) then
            best = j
            dbest = d
         end if
      end do
   end function closest_key

   !> A distance `d` to `key` counts as a misspelling: 1 <= d <= 2 and d <= len(key)/3
   !> (so 'dt' does not suggest 't_end', but 'teeth_drivn' suggests 'teeth_driven').
   logical function is_near(d, key) result(yes)
      integer, intent(in) :: d
      character(len=*), intent(in) :: key
      yes = d >= 1 .and. d <= min(2, max(1, len(key)/3))
   end function is_near

   !> Add `key` (lower case) to the group's list of queried keys. Appended without
   !> a look for it first (that look was O(keys) a query: D-107); `queried_keys`
   !> lists each key once.
   subroutine record_query(self, key)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      character(len=:), allocatable :: tmp
      integer :: n
      n = self%queried_len + len(key) + 1
      if (.not. allocated(self%queried)) then
         allocate (character(len=max(64, n)) :: self%queried)
      else if (n > len(self%queried)) then
         allocate (character(len=max(2*len(self%queried), n)) :: tmp)
         tmp(1:self%queried_len) = self%queried(1:self%queried_len)
         call move_alloc(tmp, self%queried)
      end if
      self%queried(self%queried_len + 1:n - 1) = key
      call lower_in_place(self%queried(self%queried_len + 1:n - 1))   ! to_lower's result is a temporary
      self%queried(n:n) = ','
      self%queried_len = n
   end subroutine record_query

   !> `key` (any case) is one of the queried keys.
   logical function was_queried(self, key) result(yes)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: key
      integer :: p, q
      yes = .false.
      p = 1
      do while (p <= self%queried_len)
         q = p   ! the key is queried(p:q-1), queried(q:q) its ','
         do while (self%queried(q:q) /= ',')
            q = q + 1
         end do
         if (same_key(self%queried(p:q - 1), key)) then
            yes = .true.
            return
         end if
         p = q + 1
      end do
   end function was_queried

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

   !> The queried keys as a list, each once, in order of first query (for messages).
   function queried_keys(self) result(keys)
      class(deck_group_t), intent(in) :: self
      type(string_t), allocatable :: keys(:), all(:)
      integer :: p, q, n, j
      logical :: seen
      n = 0
      if (self%queried_len > 0) n = count_commas(self%queried(1:self%queried_len))
      allocate (all(n))
      p = 1
      do n = 1, size(all)
         q = p + index(self%queried(p:self%queried_len), ',') - 2
         all(n)%s = self%queried(p:q)
         p = q + 2
      end do
      allocate (keys(0))
      do n = 1, size(all)
         seen = .false.
         do j = 1, size(keys)
            if (keys(j)%s == all(n)%s) seen = .true.
         end do
         if (.not. seen) keys = [keys, all(n)]
      end do
   contains
      pure integer function count_commas(t) result(c)
         character(len=*), intent(in) :: t
         integer :: k
         c = 0
         do k = 1, len(t)
            if (t(k:k) == ',') c = c + 1
         end do
      end function count_commas
   end function queried_keys

end module trainsim_deck_group
