!> The cold parts of a deck group: the messages about keys not read (the closest valid
!> key by edit distance, D-62) and the setting of a key after parsing (--set overrides,
!> generated groups).
submodule (trainsim_deck_group) trainsim_deck_group_keys
   implicit none

contains

   module procedure group_check_unused
      character(len=:), allocatable :: msg
      type(string_t), allocatable :: queried(:)
      integer :: k, best
      if (.not. allocated(self%entries)) return
      do k = 1, size(self%entries)
         if (self%entries(k)%used) cycle
         msg = "unknown key '"//self%key_of(k)//"'"
         if (present(context)) then
            if (len_trim(context) > 0) msg = msg//' for '//trim(context)
         end if
         queried = queried_keys(self)
         best = closest_key(self%key_of(k), queried)
         if (best > 0) msg = msg//"; did you mean '"//queried(best)%s//"'?"
         if (size(queried) > 0) then
            msg = msg//'; valid keys are: '//join(queried, ', ')
         else
            msg = msg//'; this group takes no keys'
         end if
         call fail(self, err, self%entries(k)%line, msg)
         return
      end do
   end procedure group_check_unused

   !> Set `key` (lower case) to `values` (quoted where `quoted`), given on `line`: the
   !> entry of that key is replaced, else one is added (an override, a generated group).
   module procedure group_set_entry
      type(deck_entry_t), allocatable :: grown(:)
      character(len=:), allocatable :: pool
      integer, allocatable :: vals(:, :)
      integer :: k, j, need, nv
      if (.not. allocated(self%entries)) allocate (self%entries(0))
      if (.not. allocated(self%pool)) allocate (character(len=0) :: self%pool)
      if (.not. allocated(self%vals)) allocate (self%vals(3, 0))
      need = self%pool_len + len(key)
      do j = 1, size(values)
         need = need + len(values(j)%s)
      end do
      if (need > len(self%pool)) then
         allocate (character(len=need) :: pool)
         pool(1:self%pool_len) = self%pool(1:self%pool_len)
         call move_alloc(pool, self%pool)
      end if
      nv = self%nvals + size(values)
      if (nv > size(self%vals, 2)) then
         allocate (vals(3, nv))
         vals(:, 1:self%nvals) = self%vals(:, 1:self%nvals)
         call move_alloc(vals, self%vals)
      end if
      do k = 1, size(self%entries)
         if (self%key_of(k) == key) exit
      end do
      if (k > size(self%entries)) then
         allocate (grown(k))
         grown(1:k - 1) = self%entries
         call move_alloc(grown, self%entries)
      end if
      associate (e => self%entries(k))
         e%key_at = self%pool_len + 1
         e%key_len = len(key)
         call put(key)
         e%first = self%nvals + 1
         e%n = size(values)
         do j = 1, size(values)
            self%vals(:, self%nvals + j) = [self%pool_len + 1, len(values(j)%s), merge(1, 0, quoted(j))]
            call put(values(j)%s)
         end do
         self%nvals = self%nvals + size(values)
         e%line = line
         e%used = .false.
      end associate
   contains
      subroutine put(t)
         character(len=*), intent(in) :: t
         self%pool(self%pool_len + 1:self%pool_len + len(t)) = t
         self%pool_len = self%pool_len + len(t)
      end subroutine put
   end procedure group_set_entry

   !> Index of the entry not yet read whose key is a likely misspelling of `key` (0: none):
   !> the closest by edit distance within the threshold of `is_near`, not itself a queried key.
   module procedure near_miss
      integer :: j, d, dbest
      logical :: asked
      best = 0
      dbest = huge(1)
      if (.not. allocated(self%entries)) return
      do j = 1, size(self%entries)
         if (self%entries(j)%used) cycle
         asked = was_queried(self, self%key_of(j))
         if (asked) cycle
         d = edit_distance(self%key_of(j), to_lower(key))
         if (is_near(d, to_lower(key)) .and. d < dbest) then
            best = j
            dbest = d
         end if
      end do
   end procedure near_miss

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

   !> `key` (any case) is one of the queried keys.
   logical function was_queried(self, key) result(yes)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: key
      character(len=:), allocatable :: t
      integer :: p, q
      yes = .false.
      t = queried_text(self)
      p = 1
      do while (p <= len(t))
         q = p   ! the key is t(p:q-1), t(q:q) its ','
         do while (t(q:q) /= ',')
            q = q + 1
         end do
         if (same_key(t(p:q - 1), key)) then
            yes = .true.
            return
         end if
         p = q + 1
      end do
   end function was_queried

   !> The queried keys each followed by ',', in order of query: the keys written in
   !> `queried` and the present keys asked (each by the order of its query, D-176).
   function queried_text(self) result(t)
      class(deck_group_t), intent(in) :: self
      character(len=:), allocatable :: t
      integer :: q, j, p, e
      t = ''
      p = 1   ! the next key written: queried(p:e-1), its ',' and its order in 4 bytes
      e = 0
      do q = 1, self%nasked
         if (e < p .and. p <= self%queried_len) then
            e = p + index(self%queried(p:self%queried_len), ',') - 1
         end if
         if (e >= p) then
            if (transfer(self%queried(e + 1:e + 4), q) == q) then
               t = t//self%queried(p:e)
               p = e + 5
               cycle
            end if
         end if
         if (.not. allocated(self%entries)) cycle
         do j = 1, size(self%entries)
            if (self%entries(j)%asked == q) t = t//self%key_of(j)//','
         end do
      end do
   end function queried_text

   !> Write `key` (lower case) into the queried keys with the order of its query (an
   !> absent key, or one padded with blanks: D-176).
   module procedure record_query
      character(len=:), allocatable :: tmp
      integer :: n, i, c
      n = self%queried_len + len(key) + 5
      if (.not. allocated(self%queried)) then
         allocate (character(len=max(64, n)) :: self%queried)
      else if (n > len(self%queried)) then
         allocate (character(len=max(2*len(self%queried), n)) :: tmp)
         tmp(1:self%queried_len) = self%queried(1:self%queried_len)
         call move_alloc(tmp, self%queried)
      end if
      do i = 1, len(key)   ! copied in lower case (to_lower's result is a temporary)
         c = iachar(key(i:i))
         if (c >= 65 .and. c <= 90) c = c + 32
         self%queried(self%queried_len + i:self%queried_len + i) = achar(c)
      end do
      self%nasked = self%nasked + 1
      self%queried(n - 4:n - 4) = ','
      self%queried(n - 3:n) = transfer(self%nasked, 'abcd')
      self%queried_len = n
   end procedure record_query

   !> The queried keys as a list, each once, in order of first query (for messages).
   function queried_keys(self) result(keys)
      class(deck_group_t), intent(in) :: self
      type(string_t), allocatable :: keys(:), all(:)
      integer :: p, q, n, j
      logical :: seen
      character(len=:), allocatable :: t
      t = queried_text(self)
      n = count_commas(t)
      allocate (all(n))
      p = 1
      do n = 1, size(all)
         q = p + index(t(p:), ',') - 2
         all(n)%s = t(p:q)
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

   !> "file:LINE: error: LABEL: text"
   module procedure fail
      call fatal_error(err, self%file//':'//str(line)//': error: '//self%label()//': '//text, err_input)
   end procedure fail

end submodule trainsim_deck_group_keys
