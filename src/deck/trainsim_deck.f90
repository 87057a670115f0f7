!> Input decks in Fortran namelist syntax, parsed by hand so that every error names the file,
!> the line, the group, the key and the offending text, like a compiler would. A deck is a
!> sequence of groups `&name key = value[, value ...] /` (or `... &end`). Values are kept as
!> raw tokens; the typed getters of deck_group_t convert them and record which keys were
!> read, so that check_unused can report misspelt keys.
module trainsim_deck
   use, intrinsic :: iso_fortran_env, only: int64
   use trainsim_error, only: error_t, fatal_error, err_input, err_io
   use trainsim_strings, only: string_t, to_lower, str, join, has_cr
   use trainsim_deck_lexer, only: token_list_t, tk_group, tk_end, tk_eq, tk_comma, tk_word, tk_string, &
                                  check_text, tokenize, display, unquote_into, parse_real, is_repeat, &
                                  is_key, lower_in_place
   use trainsim_deck_group, only: deck_group_t, deck_entry_t, same_key
   implicit none
   private

   public :: deck_t, deck_group_t, deck_entry_t, read_deck, parse_deck, parse_real, canonical_deck

   !> A whole parsed deck.
   type :: deck_t
      character(len=:), allocatable :: file         !< path as given
      character(len=:), allocatable :: text         !< whole deck text, lines joined with new_line('a')
      type(deck_group_t), allocatable :: groups(:)  !< in file order
   contains
      procedure :: count_groups => deck_count_groups
      procedure :: check_group_names => deck_check_group_names
   end type deck_t

   !> Largest deck file read, in bytes: positions in the text are default integers.
   integer(int64), parameter :: max_deck_bytes = huge(1)

contains

   !> Read the deck file `path` and parse it. A missing, unreadable or directory path gives
   !> an error with code err_io; syntax errors give err_input. The file is read twice in
   !> blocks (to measure the text, to copy it), so that the deck text exists once in memory,
   !> without CRs of CR-LF line ends, a leading UTF-8 byte-order mark or one final line end.
   subroutine read_deck(path, deck, err)
      character(len=*), intent(in) :: path
      type(deck_t), intent(out) :: deck
      type(error_t), allocatable, intent(out) :: err
      integer, parameter :: block_len = 1048576
      character(len=:), allocatable :: text
      character(len=:), allocatable :: blk
      character(len=512) :: msg
      integer(int64) :: sz, pos, n, nlen
      integer :: u, ios, nb, i, skip
      logical :: pending_cr
      character(len=1) :: last

      msg = ''
      open (newunit=u, file=path, access='stream', form='unformatted', status='old', &
            action='read', iostat=ios, iomsg=msg)
      if (ios /= 0) then
         call fatal_error(err, "cannot open deck '"//path//"': "//trim(msg), err_io)
         return
      end if
      inquire (unit=u, size=sz, iostat=ios)
      if (ios /= 0 .or. sz < 0) then
         close (u, iostat=ios)
         call fatal_error(err, "cannot open deck '"//path//"': cannot determine its size", err_io)
         return
      end if
      if (sz > max_deck_bytes) then
         close (u, iostat=ios)
         call fatal_error(err, "cannot open deck '"//path//"': it has more than "//str(huge(1))// &
                          ' bytes (the largest deck trainsim reads)', err_io)
         return
      end if
      allocate (character(len=block_len) :: blk)
      ! A leading byte-order mark is no part of the text.
      skip = 0
      if (sz >= 3) then
         read (u, pos=1, iostat=ios, iomsg=msg) blk(1:3)
         if (ios /= 0) then
            call read_failed()
            return
         end if
         if (blk(1:3) == char(239)//char(187)//char(191)) skip = 3
      end if

      ! Pass 1: length of the text without CRs before LFs and without a final line end.
      nlen = 0
      last = ' '
      pending_cr = .false.
      pos = skip + 1
      do while (pos <= sz)
         nb = int(min(int(block_len, int64), sz - pos + 1))
         read (u, pos=pos, iostat=ios, iomsg=msg) blk(1:nb)
         if (ios /= 0) then
            call read_failed()
            return
         end if
         if (.not. (pending_cr .or. has_cr(blk(1:nb)))) then   ! no CR: every byte counts
            nlen = nlen + nb
            if (nb > 0) last = blk(nb:nb)
            pos = pos + nb
            cycle
         end if
         do i = 1, nb
            if (blk(i:i) == achar(13)) then
               if (pending_cr) nlen = nlen + 1   ! a CR not followed by LF is kept
               pending_cr = .true.
            else
               if (pending_cr .and. blk(i:i) /= new_line('a')) nlen = nlen + 1
               pending_cr = .false.
               nlen = nlen + 1
               last = blk(i:i)
            end if
         end do
         pos = pos + nb
      end do
      if (pending_cr) then
         nlen = nlen + 1
         last = achar(13)
      end if
      ! One final line end (LF, CR-LF or a lone CR) is no part of the text: pass 2 stops
      ! before it.
      if (nlen > 0 .and. (last == new_line('a') .or. last == achar(13))) nlen = nlen - 1
      ! Pass 2: copy, dropping the same characters.
      allocate (character(len=nlen) :: text)
      n = 0
      pending_cr = .false.
      pos = skip + 1
      do while (pos <= sz .and. n < nlen)
         nb = int(min(int(block_len, int64), sz - pos + 1))
         read (u, pos=pos, iostat=ios, iomsg=msg) blk(1:nb)
         if (ios /= 0) then
            call read_failed()
            return
         end if
         if (.not. (pending_cr .or. has_cr(blk(1:nb)))) then   ! no CR: the block as it is
            i = int(min(int(nb, int64), nlen - n))
            text(n + 1:n + i) = blk(1:i)
            n = n + i
            pos = pos + nb
            cycle
         end if
         do i = 1, nb
            if (blk(i:i) == achar(13)) then
               if (pending_cr) call put(achar(13))
               pending_cr = .true.
            else
               if (pending_cr .and. blk(i:i) /= new_line('a')) call put(achar(13))
               pending_cr = .false.
               call put(blk(i:i))
            end if
         end do
         pos = pos + nb
      end do
      if (pending_cr) call put(achar(13))
      close (u, iostat=ios)
      if (n < nlen) then
         call fatal_error(err, "cannot open deck '"//path//"': the file changed while it was read", err_io)
         return
      end if
      call move_alloc(text, deck%text)
      call parse_into(deck, path, err)

   contains

      subroutine put(c)
         character(len=1), intent(in) :: c
         if (n >= nlen) return
         n = n + 1
         text(n:n) = c
      end subroutine put

      subroutine read_failed()
         close (u, iostat=ios)
         call fatal_error(err, "cannot open deck '"//path//"': "//trim(msg), err_io)
      end subroutine read_failed

   end subroutine read_deck

   !> Parse deck `text` (lines separated by new_line('a')); `file` is used in messages.
   subroutine parse_deck(text, file, deck, err)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: file
      type(deck_t), intent(out) :: deck
      type(error_t), allocatable, intent(out) :: err
      deck%text = text
      call parse_into(deck, file, err)
   end subroutine parse_deck

   !> Check and parse `deck%text` into `deck%groups`.
   subroutine parse_into(deck, file, err)
      type(deck_t), intent(inout) :: deck
      character(len=*), intent(in) :: file
      type(error_t), allocatable, intent(out) :: err
      type(token_list_t) :: toks
      type(deck_group_t), allocatable :: groups(:)
      type(string_t), allocatable :: names(:)   ! distinct group names so far ...
      integer, allocatable :: counts(:)         ! ... and how many groups of each
      character(len=:), allocatable :: name
      integer :: ngroups, i, k

      deck%file = file
      allocate (deck%groups(0))
      call check_text(deck%text, file, err)
      if (allocated(err)) return
      call tokenize(deck%text, file, toks, err)
      if (allocated(err)) return

      ! as many groups as '&name' tokens: no growth, no copy of a group (D-74)
      allocate (groups(max(count(toks%kind(1:toks%n) == tk_group), 1)), names(0), counts(0))
      ngroups = 0
      i = 1
      do while (i <= toks%n)
         select case (toks%kind(i))
         case (tk_group)
            ngroups = ngroups + 1
            name = deck%text(toks%at(i):toks%at(i) + toks%nc(i) - 1)
            call lower_in_place(name)
            do k = 1, size(names)   ! (the length first: a name of another length is passed over)
               if (len(names(k)%s) /= len(name)) cycle
               if (same_key(names(k)%s, name)) exit
            end do
            if (k > size(names)) call add_name(name)
            counts(k) = counts(k) + 1
            call parse_group(deck%text, toks, i, file, counts(k), name, groups(ngroups), err)
            if (allocated(err)) return
         case (tk_end)
            if (toks%nc(i) == 0) then   ! '/' (nc = 4: '&end')
               call fatal_error(err, file//':'//str(toks%line(i))//": error: text outside a group: '/' "// &
                                "(a group is closed twice, or a value holds an unquoted '/')", err_input)
            else
               call fatal_error(err, file//':'//str(toks%line(i))// &
                                ": error: text outside a group: '&end' without an open group", err_input)
            end if
            return
         case default
            call fatal_error(err, file//':'//str(toks%line(i))//": error: text outside a group: '"// &
                             display(deck%text, toks, i)//"' (groups start with '&name')", err_input)
            return
         end select
      end do
      deallocate (deck%groups)
      if (ngroups < size(groups)) then
         deck%groups = groups(1:ngroups)
      else
         call move_alloc(groups, deck%groups)
      end if

   contains

      ! (not `names = [names, string_t(name)]`: gfortran 12 loses the deferred-length
      ! component in that constructor)
      subroutine add_name(name)
         character(len=*), intent(in) :: name
         type(string_t), allocatable :: tmp(:)
         allocate (tmp(size(names) + 1))
         tmp(1:size(names)) = names
         tmp(size(tmp))%s = name
         call move_alloc(tmp, names)
         counts = [counts, 0]
      end subroutine add_name

   end subroutine parse_into

   !> Parse one group starting at token `i` (a tk_group token, its name `name` in lower case,
   !> moved into the group); on return `i` is past its end. Its keys and values are copied into
   !> the group's pool, whose room and the entries are counted first and allocated once: three
   !> allocations a group, none a key or value (D-159).
   subroutine parse_group(text, toks, i, file, ordinal, name, g, err)
      character(len=*), intent(in) :: text
      type(token_list_t), intent(in) :: toks
      integer, intent(inout) :: i
      character(len=*), intent(in) :: file
      integer, intent(in) :: ordinal   !< 1 for the first group of its name, 2 for the second...
      character(len=:), allocatable, intent(inout) :: name
      type(deck_group_t), intent(inout) :: g
      type(error_t), allocatable, intent(out) :: err
      integer :: nent, k, nkeys, nchars, nvals, c

      call move_alloc(name, g%name)
      g%file = file
      g%line = toks%line(i)
      g%ordinal = ordinal
      call count_room(toks, i + 1, nkeys, nchars, nvals)
      allocate (g%entries(nkeys), g%vals(3, nvals))
      allocate (character(len=nchars) :: g%pool)
      nent = 0
      i = i + 1

      do
         if (i > toks%n) then
            call group_error(g, nent, file, g%line, 'group not closed before the end of the file '// &
                             "(missing '/' or '&end')", err)
            return
         end if
         select case (toks%kind(i))
         case (tk_end)
            i = i + 1
            exit
         case (tk_group)
            call group_error(g, nent, file, toks%line(i), "group not closed before '"//display(text, toks, i)// &
                             "' (missing '/' or '&end'; the group starts on line "//str(g%line)//')', err)
            return
         case (tk_comma)
            i = i + 1
            cycle
         case (tk_word)
            if (.not. is_key(text(toks%at(i):toks%at(i) + toks%nc(i) - 1))) then
               call group_error(g, nent, file, toks%line(i), "expected a key name, got '"// &
                                display(text, toks, i)//"'", err)
               return
            end if
            if (.not. next_is_eq(toks, i)) then
               call group_error(g, nent, file, toks%line(i), "missing '=' after key '"// &
                                to_lower(text(toks%at(i):toks%at(i) + toks%nc(i) - 1))//"'", err)
               return
            end if
         case default
            call group_error(g, nent, file, toks%line(i), "expected a key name, got '"// &
                             display(text, toks, i)//"'", err)
            return
         end select

         ! toks(i) is a key, toks(i+1) is '='.
         nent = nent + 1
         associate (e => g%entries(nent))
            e%key_at = g%pool_len + 1
            e%key_len = toks%nc(i)
            do k = 0, e%key_len - 1   ! copied in lower case in one pass (D-176)
               c = iachar(text(toks%at(i) + k:toks%at(i) + k))
               g%pool(e%key_at + k:e%key_at + k) = achar(merge(c + 32, c, c >= 65 .and. c <= 90))
            end do
            g%pool_len = g%pool_len + e%key_len
            e%line = toks%line(i)
            e%first = g%nvals + 1
            do k = 1, nent - 1
               if (g%entries(k)%key_len /= e%key_len) cycle
               if (same_key(g%pool(g%entries(k)%key_at:g%entries(k)%key_at + e%key_len - 1), &
                            g%pool(e%key_at:e%key_at + e%key_len - 1))) then
                  call group_error(g, nent, file, e%line, "duplicate key '"//g%key_of(nent)// &
                                   "' (first given on line "//str(g%entries(k)%line)//')', err)
                  return
               end if
            end do
         end associate
         i = i + 2
         call parse_values(text, toks, i, file, g, nent, err)
         if (allocated(err)) return
      end do
   end subroutine parse_group

   !> From token `j` to the group's end: the keys (words followed by '='), the characters
   !> of keys and values and the values: the room parse_group needs, exactly or more.
   subroutine count_room(toks, j, nkeys, nchars, nvals)
      type(token_list_t), intent(in) :: toks
      integer, intent(in) :: j
      integer, intent(out) :: nkeys, nchars, nvals
      integer :: k
      nkeys = 0
      nchars = 0
      nvals = 0
      do k = j, toks%n
         select case (toks%kind(k))
         case (tk_end, tk_group)
            exit
         case (tk_word)
            nchars = nchars + toks%nc(k)
            if (next_is_eq(toks, k)) then
               nkeys = nkeys + 1
            else
               nvals = nvals + 1
            end if
         case (tk_string)
            nchars = nchars + toks%nc(k)
            nvals = nvals + 1
         end select
      end do
   end subroutine count_room

   !> The values of entry `nent` (its key and '=' read), from token `i` to the next key, the
   !> group's end or a token that cannot be a value; on return `i` is at that token.
   subroutine parse_values(text, toks, i, file, g, nent, err)
      character(len=*), intent(in) :: text
      type(token_list_t), intent(in) :: toks
      integer, intent(inout) :: i
      character(len=*), intent(in) :: file
      type(deck_group_t), intent(inout) :: g
      integer, intent(in) :: nent
      type(error_t), allocatable, intent(out) :: err
      integer :: nval
      logical :: after_sep, prev_name_like

      associate (e => g%entries(nent))
         nval = 0
         prev_name_like = .false.
         after_sep = .true.
         values: do while (i <= toks%n)
            select case (toks%kind(i))
            case (tk_comma)
               if (after_sep) then
                  if (nval == 0) then
                     call fail(e%line, "key '"//g%key_of(nent)//"' has no value")
                  else
                     call fail(toks%line(i), "key '"//g%key_of(nent)//"': empty value between commas "// &
                               '(null values are not supported)')
                  end if
                  return
               end if
               after_sep = .true.
            case (tk_word)
               if (next_is_eq(toks, i)) exit values
               if (is_repeat(text(toks%at(i):toks%at(i) + toks%nc(i) - 1))) then
                  call fail(toks%line(i), "key '"//g%key_of(nent)//"': repeat counts are not supported "// &
                            "(got '"//word(i)//"'); write the values out")
                  return
               end if
               if (looks_like_lost_key(i)) then
                  call fail(toks%line(i), "missing '=' after key '"//to_lower(word(i))// &
                            "' (if '"//word(i)//"' is a value, quote it)")
                  return
               end if
               prev_name_like = name_like(i)
               call add_value(.false.)
            case (tk_string)
               prev_name_like = .false.
               call add_value(.true.)
            case (tk_eq)
               call fail(toks%line(i), "key '"//g%key_of(nent)//"': unexpected '=' after a value")
               return
            case default
               exit values
            end select
            i = i + 1
         end do values
         if (nval == 0) then
            call fail(e%line, "key '"//g%key_of(nent)//"' has no value")
            return
         end if
      end associate

   contains

      !> A bare word's text.
      function word(j) result(w)
         integer, intent(in) :: j
         character(len=toks%nc(j)) :: w
         w = text(toks%at(j):toks%at(j) + toks%nc(j) - 1)
      end function word

      !> A name-like bare value next to a number or quoted string, as in `id = 'n1' inertia 5.0`,
      !> is almost surely a key whose '=' was forgotten. Lists of bare names stay allowed.
      logical function looks_like_lost_key(j)
         integer, intent(in) :: j
         logical :: next_plain
         looks_like_lost_key = .false.
         if (.not. name_like(j)) return
         if (nval == 0) return   ! `type = inertia damping 0.0` is caught at 'damping'
         next_plain = .false.
         if (j < toks%n) then
            if (toks%kind(j + 1) == tk_string) then
               next_plain = .true.
            else if (toks%kind(j + 1) == tk_word) then
               next_plain = .not. name_like(j + 1) .and. .not. next_is_eq(toks, j + 1)
            end if
         end if
         looks_like_lost_key = .not. prev_name_like .or. next_plain
      end function looks_like_lost_key

      !> Token j is a bare word that could be a key (and is not a logical like T or F).
      logical function name_like(j)
         integer, intent(in) :: j
         name_like = .false.
         if (toks%kind(j) /= tk_word) return
         if (.not. is_key(text(toks%at(j):toks%at(j) + toks%nc(j) - 1))) return
         select case (to_lower(text(toks%at(j):toks%at(j) + toks%nc(j) - 1)))
         case ('t', 'f', 'true', 'false')
            return
         end select
         name_like = .true.
      end function name_like

      !> Token i's text copied into the group's pool (a string unquoted) as the entry's
      !> next value: the entry's values are the group's last ones.
      subroutine add_value(is_quoted)
         logical, intent(in) :: is_quoted
         integer :: p0
         p0 = g%pool_len
         if (is_quoted) then
            call unquote_into(text, toks%at(i), toks%nc(i), g%pool, g%pool_len)
         else
            g%pool(p0 + 1:p0 + toks%nc(i)) = text(toks%at(i):toks%at(i) + toks%nc(i) - 1)
            g%pool_len = p0 + toks%nc(i)
         end if
         g%nvals = g%nvals + 1
         g%vals(1, g%nvals) = p0 + 1
         g%vals(2, g%nvals) = g%pool_len - p0
         g%vals(3, g%nvals) = merge(1, 0, is_quoted)
         nval = nval + 1
         g%entries(nent)%n = nval
         after_sep = .false.
      end subroutine add_value

      !> The entry keeps the values read so far (for the group's label), then the error.
      subroutine fail(line, text)
         integer, value :: line   ! by value: e%line may be passed, and the entries shrink
         character(len=*), intent(in) :: text
         call group_error(g, nent, file, line, text, err)
      end subroutine fail

   end subroutine parse_values

   !> Token j is followed by '='.
   logical function next_is_eq(toks, j)
      type(token_list_t), intent(in) :: toks
      integer, intent(in) :: j
      next_is_eq = .false.
      if (j < toks%n) next_is_eq = toks%kind(j + 1) == tk_eq
   end function next_is_eq

   !> "file:LINE: error: LABEL: text", the group holding the entries read so far.
   subroutine group_error(g, nent, file, line, text, err)
      type(deck_group_t), intent(inout) :: g
      integer, intent(in) :: nent
      integer, value :: line   ! by value: an entry's line may be passed, and the entries shrink
      character(len=*), intent(in) :: file, text
      type(error_t), allocatable, intent(out) :: err
      if (nent < size(g%entries)) g%entries = g%entries(1:nent)
      call fatal_error(err, file//':'//str(line)//': error: '//g%label()//': '//text, err_input)
   end subroutine group_error

   !> Number of groups called `name` (case-insensitive, without '&').
   integer function deck_count_groups(self, name) result(n)
      class(deck_t), intent(in) :: self
      character(len=*), intent(in) :: name
      integer :: i, ln
      n = 0
      if (.not. allocated(self%groups)) return
      ln = len(name)   ! (a stored name ends in no blank: one of another length matches a padded `name`)
      if (ln > 0) ln = merge(-1, ln, iachar(name(ln:ln)) == 32)
      do i = 1, size(self%groups)
         if (len(self%groups(i)%name) /= ln .and. ln >= 0) cycle
         if (same_key(self%groups(i)%name, name)) n = n + 1
      end do
   end function deck_count_groups

   !> Error for the first group whose name is not in `allowed` (case-insensitive). `also`
   !> (e.g. "sweep (read by trainsim sweep)") names groups another reader takes out of the
   !> deck before this check; the message lists them with the others.
   subroutine deck_check_group_names(self, allowed, err, also)
      class(deck_t), intent(in) :: self
      type(string_t), intent(in) :: allowed(:)
      type(error_t), allocatable, intent(out) :: err
      character(len=*), intent(in), optional :: also
      integer :: i, k
      logical :: ok
      character(len=:), allocatable :: more
      more = ''
      if (present(also)) more = ', '//also
      if (.not. allocated(self%groups)) return
      do i = 1, size(self%groups)
         ok = .false.
         do k = 1, size(allowed)
            if (same_key(self%groups(i)%name, allowed(k)%s)) then
               ok = .true.
               exit
            end if
         end do
         if (.not. ok) then
            call fatal_error(err, self%groups(i)%file//':'//str(self%groups(i)%line)// &
                             ": error: unknown group '&"//self%groups(i)%name// &
                             "'; valid groups are: "//join(allowed, ', ')//more, err_input)
            return
         end if
      end do
   end subroutine deck_check_group_names

   !> The deck as parsed: "&group key=v1,v2 ... /" a line, strings quoted (what the fingerprint
   !> of a sweep file digests: comments and layout do not count).
   function canonical_deck(deck) result(t)
      type(deck_t), intent(in) :: deck
      character(len=:), allocatable :: t
      integer :: g, e, v
      t = ''
      if (.not. allocated(deck%groups)) return
      do g = 1, size(deck%groups)
         associate (grp => deck%groups(g))
            t = t//'&'//grp%name
            do e = 1, grp%nentries()
               t = t//' '//grp%key_of(e)//'='
               do v = 1, grp%nvalues(e)
                  if (v > 1) t = t//','
                  if (grp%quoted(e, v)) then
                     t = t//"'"//grp%value_of(e, v)//"'"
                  else
                     t = t//grp%value_of(e, v)
                  end if
               end do
            end do
            t = t//' /'//new_line('a')
         end associate
      end do
   end function canonical_deck

end module trainsim_deck
