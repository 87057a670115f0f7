!> Input decks in Fortran namelist syntax, parsed by hand so that every error names the
!> file, the line, the group, the key and the offending text, like a compiler would.
!>
!> A deck is a sequence of groups `&name key = value[, value ...] /` (or `... &end`).
!> Values are kept as raw tokens; the typed getters of deck_group_t convert them and
!> record which keys were read, so that check_unused can report misspelt keys.
module trainsim_deck
   use, intrinsic :: iso_fortran_env, only: int64
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input, err_io
   use trainsim_strings, only: string_t, to_lower, str, join, invalid_text_byte
   implicit none
   private

   public :: deck_t, deck_group_t, deck_entry_t, read_deck, parse_deck, parse_real

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
      !> Keys asked for through has/get_*/count_values, in order of first query.
      type(string_t), allocatable, private :: queried(:)
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
      procedure :: require_positive => group_require_positive
      procedure :: require_nonnegative => group_require_nonnegative
   end type deck_group_t

   !> A whole parsed deck.
   type :: deck_t
      character(len=:), allocatable :: file         !< path as given
      character(len=:), allocatable :: text         !< whole deck text, lines joined with new_line('a')
      type(deck_group_t), allocatable :: groups(:)  !< in file order
   contains
      procedure :: count_groups => deck_count_groups
      procedure :: check_group_names => deck_check_group_names
   end type deck_t

   ! Token kinds produced by the lexer.
   integer, parameter :: tk_group = 1   ! '&name' (text = lower-case name)
   integer, parameter :: tk_end = 2     ! '/' or '&end'
   integer, parameter :: tk_eq = 3      ! '='
   integer, parameter :: tk_comma = 4   ! ','
   integer, parameter :: tk_word = 5    ! bare token
   integer, parameter :: tk_string = 6  ! quoted string (text = contents, unquoted)

   !> Largest deck file read, in bytes: positions in the text are default integers.
   integer(int64), parameter :: max_deck_bytes = huge(1)

   type :: token_list_t
      integer :: n = 0
      integer, allocatable :: kind(:), line(:)
      type(string_t), allocatable :: text(:)
   end type token_list_t

contains

   ! ------------------------------------------------------------------------------------------
   ! Reading and parsing
   ! ------------------------------------------------------------------------------------------

   !> Read the deck file `path` and parse it. A missing, unreadable or directory path gives
   !> an error with code err_io; syntax errors give err_input.
   !>
   !> The file is read twice in blocks (once to measure the text, once to copy it), so
   !> that the deck text exists once in memory, without CRs of CR-LF line ends, a
   !> leading UTF-8 byte-order mark or one final line end.
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
      integer :: ngroups, i, k

      deck%file = file
      allocate (deck%groups(0))
      call check_text(deck%text, file, err)
      if (allocated(err)) return
      call tokenize(deck%text, file, toks, err)
      if (allocated(err)) return

      allocate (groups(8), names(0), counts(0))
      ngroups = 0
      i = 1
      do while (i <= toks%n)
         select case (toks%kind(i))
         case (tk_group)
            if (ngroups == size(groups)) call grow_groups(groups)
            ngroups = ngroups + 1
            do k = 1, size(names)
               if (names(k)%s == toks%text(i)%s) exit
            end do
            if (k > size(names)) call add_name(toks%text(i)%s)
            counts(k) = counts(k) + 1
            call parse_group(toks, i, file, counts(k), groups(ngroups), err)
            if (allocated(err)) return
         case (tk_end)
            if (toks%text(i)%s == '/') then
               call fatal_error(err, file//':'//str(toks%line(i))//": error: text outside a group: '/' "// &
                                "(a group is closed twice, or a value holds an unquoted '/')", err_input)
            else
               call fatal_error(err, file//':'//str(toks%line(i))// &
                                ": error: text outside a group: '&end' without an open group", err_input)
            end if
            return
         case default
            call fatal_error(err, file//':'//str(toks%line(i))//": error: text outside a group: '"// &
                             display(toks, i)//"' (groups start with '&name')", err_input)
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

   !> Deck text must be UTF-8 without NUL bytes: anything else is not a text file (or is
   !> in another encoding) and would end up in the output file's strings.
   subroutine check_text(text, file, err)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: file
      type(error_t), allocatable, intent(out) :: err
      integer :: pos, line, col0
      character(len=2) :: hex

      pos = invalid_text_byte(text)
      if (pos == 0) return
      line = 1 + count_newlines(text(1:pos - 1))
      col0 = index(text(1:pos - 1), new_line('a'), back=.true.)
      if (iachar(text(pos:pos)) == 0) then
         call fatal_error(err, file//':'//str(line)//': error: NUL byte at column '//str(pos - col0)// &
                          ' (a deck is a text file; is this a binary file?)', err_input)
      else
         write (hex, '(z2.2)') iachar(text(pos:pos))
         call fatal_error(err, file//':'//str(line)//': error: invalid UTF-8 at column '//str(pos - col0)// &
                          ' (byte 0x'//hex//'); decks must be UTF-8 (or ASCII) text', err_input)
      end if
   contains
      pure integer function count_newlines(t) result(c)
         character(len=*), intent(in) :: t
         integer :: k
         c = 0
         do k = 1, len(t)
            if (t(k:k) == new_line('a')) c = c + 1
         end do
      end function count_newlines
   end subroutine check_text

   !> Split `text` into tokens, dropping comments and white space.
   subroutine tokenize(text, file, toks, err)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: file
      type(token_list_t), intent(out) :: toks
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: buf
      character(len=1) :: c, q
      integer :: i, j, k, n, line, nb
      logical :: doubled

      allocate (toks%kind(64), toks%line(64), toks%text(64))
      n = len(text)
      line = 1
      i = 1
      do while (i <= n)
         c = text(i:i)
         if (c == new_line('a')) then
            line = line + 1
            i = i + 1
         else if (is_blank(c)) then
            i = i + 1
         else if (c == '!') then
            do while (i <= n)
               if (text(i:i) == new_line('a')) exit
               i = i + 1
            end do
         else if (c == '=') then
            call push(toks, tk_eq, '=', line)
            i = i + 1
         else if (c == ',') then
            call push(toks, tk_comma, ',', line)
            i = i + 1
         else if (c == '/') then
            call push(toks, tk_end, '/', line)
            i = i + 1
         else if (c == '&') then
            j = i + 1
            do while (j <= n)
               if (.not. is_name_char(text(j:j))) exit
               j = j + 1
            end do
            if (j == i + 1) then
               call fatal_error(err, file//':'//str(line)//": error: expected a group name right after '&'", &
                                err_input)
               return
            end if
            if (.not. is_letter(text(i + 1:i + 1))) then
               call fatal_error(err, file//':'//str(line)//": error: invalid group name '&"// &
                                text(i + 1:j - 1)//"' (it must start with a letter)", err_input)
               return
            end if
            if (to_lower(text(i + 1:j - 1)) == 'end') then
               call push(toks, tk_end, '&end', line)
            else
               call push(toks, tk_group, to_lower(text(i + 1:j - 1)), line)
            end if
            i = j
         else if (c == "'" .or. c == '"') then
            ! Find the closing quote; a doubled quote stands for one.
            q = c
            doubled = .false.
            j = i + 1
            do
               if (j > n) exit
               if (text(j:j) == new_line('a')) exit
               if (text(j:j) == q) then
                  if (j < n) then
                     if (text(j + 1:j + 1) == q) then
                        doubled = .true.
                        j = j + 2
                        cycle
                     end if
                  end if
                  exit
               end if
               j = j + 1
            end do
            if (j > n) then
               call unterminated(text(i:j - 1))
               return
            else if (text(j:j) /= q) then
               call unterminated(text(i:j - 1))
               return
            end if
            if (doubled) then
               allocate (character(len=j - i - 1) :: buf)
               nb = 0
               k = i + 1
               do while (k < j)
                  nb = nb + 1
                  buf(nb:nb) = text(k:k)
                  if (text(k:k) == q) k = k + 1
                  k = k + 1
               end do
               call push(toks, tk_string, buf(1:nb), line)
               deallocate (buf)
            else
               call push(toks, tk_string, text(i + 1:j - 1), line)
            end if
            i = j + 1
         else
            j = i
            do while (j <= n)
               if (ends_word(text(j:j))) exit
               j = j + 1
            end do
            call push(toks, tk_word, text(i:j - 1), line)
            i = j
         end if
      end do

   contains

      subroutine unterminated(fragment)
         character(len=*), intent(in) :: fragment
         call fatal_error(err, file//':'//str(line)//': error: unterminated string '//fragment// &
                          ' (strings must close on the line where they start)', err_input)
      end subroutine unterminated

   end subroutine tokenize

   !> Parse one group starting at token `i` (a tk_group token); on return `i` is past its end.
   subroutine parse_group(toks, i, file, ordinal, g, err)
      type(token_list_t), intent(in) :: toks
      integer, intent(inout) :: i
      character(len=*), intent(in) :: file
      integer, intent(in) :: ordinal   !< 1 for the first group of its name, 2 for the second...
      type(deck_group_t), intent(inout) :: g
      type(error_t), allocatable, intent(out) :: err
      type(deck_entry_t), allocatable :: entries(:)
      integer :: nent, k, nval, prev_value
      logical :: after_sep

      g%name = toks%text(i)%s
      g%file = file
      g%line = toks%line(i)
      g%ordinal = ordinal
      allocate (g%entries(0), g%queried(0))
      allocate (entries(8))
      nent = 0
      i = i + 1

      do
         if (i > toks%n) then
            call group_error(g%line, 'group not closed before the end of the file '// &
                             "(missing '/' or '&end')")
            return
         end if
         select case (toks%kind(i))
         case (tk_end)
            i = i + 1
            exit
         case (tk_group)
            call group_error(toks%line(i), "group not closed before '&"//toks%text(i)%s// &
                             "' (missing '/' or '&end'; the group starts on line "//str(g%line)//')')
            return
         case (tk_comma)
            i = i + 1
            cycle
         case (tk_word)
            if (.not. is_key(toks%text(i)%s)) then
               call group_error(toks%line(i), "expected a key name, got '"//display(toks, i)//"'")
               return
            end if
            if (.not. next_is_eq(i)) then
               call group_error(toks%line(i), "missing '=' after key '"//to_lower(toks%text(i)%s)//"'")
               return
            end if
         case default
            call group_error(toks%line(i), "expected a key name, got '"//display(toks, i)//"'")
            return
         end select

         ! toks(i) is a key, toks(i+1) is '='.
         if (nent == size(entries)) call grow_entries(entries)
         nent = nent + 1
         associate (e => entries(nent))
            e%key = to_lower(toks%text(i)%s)
            e%line = toks%line(i)
            allocate (e%values(4), e%quoted(4))
            do k = 1, nent - 1
               if (entries(k)%key == e%key) then
                  call group_error(e%line, "duplicate key '"//e%key//"' (first given on line "// &
                                   str(entries(k)%line)//')')
                  return
               end if
            end do
            i = i + 2
            nval = 0
            prev_value = 0
            after_sep = .true.
            values: do while (i <= toks%n)
               select case (toks%kind(i))
               case (tk_comma)
                  if (after_sep) then
                     if (nval == 0) then
                        call group_error(e%line, "key '"//e%key//"' has no value")
                     else
                        call group_error(toks%line(i), "key '"//e%key//"': empty value between commas "// &
                                         '(null values are not supported)')
                     end if
                     return
                  end if
                  after_sep = .true.
               case (tk_word)
                  if (next_is_eq(i)) exit values
                  if (is_repeat(toks%text(i)%s)) then
                     call group_error(toks%line(i), "key '"//e%key//"': repeat counts are not supported "// &
                                      "(got '"//toks%text(i)%s//"'); write the values out")
                     return
                  end if
                  if (looks_like_lost_key(i)) then
                     call group_error(toks%line(i), "missing '=' after key '"//to_lower(toks%text(i)%s)// &
                                      "' (if '"//toks%text(i)%s//"' is a value, quote it)")
                     return
                  end if
                  call add_value(.false.)
                  prev_value = i
               case (tk_string)
                  call add_value(.true.)
                  prev_value = i
               case (tk_eq)
                  call group_error(toks%line(i), "key '"//e%key//"': unexpected '=' after a value")
                  return
               case default
                  exit values
               end select
               i = i + 1
            end do values
            if (nval == 0) then
               call group_error(e%line, "key '"//e%key//"' has no value")
               return
            end if
            e%values = e%values(1:nval)
            e%quoted = e%quoted(1:nval)
         end associate
      end do
      g%entries = entries(1:nent)

   contains

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
               next_plain = .not. name_like(j + 1) .and. .not. next_is_eq(j + 1)
            end if
         end if
         looks_like_lost_key = .not. name_like(prev_value) .or. next_plain
      end function looks_like_lost_key

      !> Token j is a bare word that could be a key (and is not a logical like T or F).
      logical function name_like(j)
         integer, intent(in) :: j
         name_like = .false.
         if (toks%kind(j) /= tk_word) return
         if (.not. is_key(toks%text(j)%s)) return
         select case (to_lower(toks%text(j)%s))
         case ('t', 'f', 'true', 'false')
            return
         end select
         name_like = .true.
      end function name_like

      logical function next_is_eq(j)
         integer, intent(in) :: j
         next_is_eq = .false.
         if (j < toks%n) next_is_eq = toks%kind(j + 1) == tk_eq
      end function next_is_eq

      subroutine add_value(is_quoted)
         logical, intent(in) :: is_quoted
         type(string_t), allocatable :: tv(:)
         logical, allocatable :: tq(:)
         associate (e => entries(nent))
            if (nval == size(e%values)) then
               allocate (tv(2*nval), tq(2*nval))
               tv(1:nval) = e%values
               tq(1:nval) = e%quoted
               call move_alloc(tv, e%values)
               call move_alloc(tq, e%quoted)
            end if
            nval = nval + 1
            e%values(nval)%s = toks%text(i)%s
            e%quoted(nval) = is_quoted
         end associate
         after_sep = .false.
      end subroutine add_value

      subroutine group_error(line, text)
         integer, intent(in) :: line
         character(len=*), intent(in) :: text
         g%entries = entries(1:nent)
         call fatal_error(err, file//':'//str(line)//': error: '//g%label()//': '//text, err_input)
      end subroutine group_error

   end subroutine parse_group

   ! ------------------------------------------------------------------------------------------
   ! deck_t
   ! ------------------------------------------------------------------------------------------

   !> Number of groups called `name` (case-insensitive, without '&').
   integer function deck_count_groups(self, name) result(n)
      class(deck_t), intent(in) :: self
      character(len=*), intent(in) :: name
      integer :: i
      n = 0
      if (.not. allocated(self%groups)) return
      do i = 1, size(self%groups)
         if (self%groups(i)%name == to_lower(name)) n = n + 1
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
            if (self%groups(i)%name == to_lower(allowed(k)%s)) then
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

   ! ------------------------------------------------------------------------------------------
   ! deck_group_t: queries
   ! ------------------------------------------------------------------------------------------

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
   !> if `key` is present in the group; otherwise the group's line.
   function group_where(self, key) result(s)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in), optional :: key
      character(len=:), allocatable :: s
      integer :: k
      k = 0
      if (present(key)) k = find(self, key)
      if (k > 0) then
         s = self%file//':'//str(self%entries(k)%line)//': &'//self%name//' #'//str(self%ordinal)// &
             ", key '"//self%entries(k)%key//"'"
      else
         s = self%file//':'//str(self%line)//': &'//self%name//' #'//str(self%ordinal)
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

   subroutine group_check_unused(self, err, context)
      class(deck_group_t), intent(in) :: self
      type(error_t), allocatable, intent(out) :: err
      character(len=*), intent(in), optional :: context
      character(len=:), allocatable :: msg
      integer :: k, best
      if (.not. allocated(self%entries)) return
      do k = 1, size(self%entries)
         if (self%entries(k)%used) cycle
         msg = "unknown key '"//self%entries(k)%key//"'"
         if (present(context)) then
            if (len_trim(context) > 0) msg = msg//' for '//trim(context)
         end if
         if (allocated(self%queried)) then
            best = closest_key(self%entries(k)%key, self%queried)
            if (best > 0) msg = msg//"; did you mean '"//self%queried(best)%s//"'?"
         end if
         if (allocated(self%queried)) then
            if (size(self%queried) > 0) then
               msg = msg//'; valid keys are: '//join(self%queried, ', ')
            else
               msg = msg//'; this group takes no keys'
            end if
         else
            msg = msg//'; this group takes no keys'
         end if
         call fail(self, err, self%entries(k)%line, msg)
         return
      end do
   end subroutine group_check_unused

   ! ------------------------------------------------------------------------------------------
   ! deck_group_t: typed getters
   ! ------------------------------------------------------------------------------------------

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
      val = ''
      call scalar_entry(self, key, 'a string', present(default), k, err)
      if (allocated(err)) return
      if (k == 0) then
         if (present(default)) val = default
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

   ! ------------------------------------------------------------------------------------------
   ! Private helpers
   ! ------------------------------------------------------------------------------------------

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
   integer function find(self, key) result(k)
      class(deck_group_t), intent(in) :: self
      character(len=*), intent(in) :: key
      integer :: j
      k = 0
      if (.not. allocated(self%entries)) return
      do j = 1, size(self%entries)
         if (self%entries(j)%key == to_lower(key)) then
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
         asked = .false.
         if (allocated(self%queried)) asked = any_is(self%queried, self%entries(j)%key)
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

   logical function any_is(list, word) result(yes)
      type(string_t), intent(in) :: list(:)
      character(len=*), intent(in) :: word
      integer :: j
      yes = .false.
      do j = 1, size(list)
         if (list(j)%s == word) then
            yes = .true.
            return
         end if
      end do
   end function any_is

   !> Optimal-string-alignment distance (Damerau-Levenshtein without repeated edits of a
   !> substring): insertions, deletions, substitutions and swaps of neighbours cost 1.
   integer function edit_distance(a, b) result(dist)
      character(len=*), intent(in) :: a, b
      integer, allocatable :: d(:, :)
      integer :: i, j, m, n, cost
      m = len(a)
      n = len(b)
      allocate (d(0:m, 0:n))
      do i = 0, m
         d(i, 0) = i
      end do
      do j = 0, n
         d(0, j) = j
      end do
      do j = 1, n
         do i = 1, m
            cost = merge(0, 1, a(i:i) == b(j:j))
            d(i, j) = min(d(i - 1, j) + 1, d(i, j - 1) + 1, d(i - 1, j - 1) + cost)
            if (i > 1 .and. j > 1) then
               if (a(i:i) == b(j - 1:j - 1) .and. a(i - 1:i - 1) == b(j:j)) d(i, j) = min(d(i, j), d(i - 2, j - 2) + 1)
            end if
         end do
      end do
      dist = d(m, n)
   end function edit_distance

   !> Add `key` (lower case) to the group's list of queried keys, once.
   subroutine record_query(self, key)
      class(deck_group_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      type(string_t), allocatable :: tmp(:)
      integer :: j, n
      if (.not. allocated(self%queried)) allocate (self%queried(0))
      n = size(self%queried)
      do j = 1, n
         if (self%queried(j)%s == to_lower(key)) return
      end do
      allocate (tmp(n + 1))
      tmp(1:n) = self%queried
      tmp(n + 1)%s = to_lower(key)
      call move_alloc(tmp, self%queried)
   end subroutine record_query

   !> Strict real syntax: [sign] digits [. digits] [(e|d) [sign] digits], at least one mantissa
   !> digit. Values beyond the range of real(wp) are rejected before conversion, so no FP trap
   !> can fire. stat: 0 ok, 1 bad syntax, 2 out of range.
   subroutine parse_real(s, val, stat)
      character(len=*), intent(in) :: s
      real(wp), intent(out) :: val
      integer, intent(out) :: stat
      character(len=len(s)) :: buf
      integer :: i, n, nint_dig, nfrac_dig, first_pow, expo, expsign, nexp_dig, ios
      logical :: seen_dot, nonzero

      val = 0.0_wp
      stat = 1
      n = len(s)
      if (n == 0) return
      buf = s
      i = 1
      if (s(1:1) == '+' .or. s(1:1) == '-') i = 2
      nint_dig = 0
      nfrac_dig = 0
      seen_dot = .false.
      nonzero = .false.
      first_pow = 0
      ! Mantissa. For the first non-zero digit remember its index; its power of ten follows.
      do while (i <= n)
         if (is_digit(s(i:i))) then
            if (seen_dot) then
               nfrac_dig = nfrac_dig + 1
            else
               nint_dig = nint_dig + 1
            end if
            if (s(i:i) /= '0' .and. .not. nonzero) then
               nonzero = .true.
               if (seen_dot) then
                  first_pow = -nfrac_dig
               else
                  first_pow = nint_dig     ! index in the integer part; fixed up below
               end if
            end if
         else if (s(i:i) == '.' .and. .not. seen_dot) then
            seen_dot = .true.
         else
            exit
         end if
         i = i + 1
      end do
      if (nint_dig + nfrac_dig == 0) return
      if (nonzero .and. first_pow > 0) first_pow = nint_dig - first_pow
      expo = 0
      if (i <= n) then
         if (index('eEdD', s(i:i)) == 0) return
         buf(i:i) = 'e'
         i = i + 1
         expsign = 1
         if (i <= n) then
            if (s(i:i) == '+' .or. s(i:i) == '-') then
               if (s(i:i) == '-') expsign = -1
               i = i + 1
            end if
         end if
         nexp_dig = 0
         do while (i <= n)
            if (.not. is_digit(s(i:i))) return
            if (expo < 100000) expo = 10*expo + (iachar(s(i:i)) - iachar('0'))
            nexp_dig = nexp_dig + 1
            i = i + 1
         end do
         if (nexp_dig == 0) return
         expo = expsign*expo
      end if
      if (nonzero) then
         stat = 2
         if (first_pow + expo > range(val) .or. first_pow + expo < -range(val) - 1) return
      end if
      read (buf, *, iostat=ios) val
      if (ios /= 0) then
         val = 0.0_wp
         stat = 1
         return
      end if
      if (.not. ieee_is_finite(val)) then   ! cannot happen after the checks above; never pass it on
         val = 0.0_wp
         stat = 2
         return
      end if
      stat = 0
   end subroutine parse_real

   !> Strict integer syntax: [sign] digits, within the range of default integer.
   !> stat: 0 ok, 1 bad syntax, 2 out of range.
   subroutine parse_int(s, val, stat)
      character(len=*), intent(in) :: s
      integer, intent(out) :: val
      integer, intent(out) :: stat
      integer :: i, i0, ios
      val = 0
      stat = 1
      if (len(s) == 0) return
      i0 = 1
      if (s(1:1) == '+' .or. s(1:1) == '-') i0 = 2
      if (i0 > len(s)) return
      do i = i0, len(s)
         if (.not. is_digit(s(i:i))) return
      end do
      stat = 2
      read (s, *, iostat=ios) val
      if (ios /= 0) then
         val = 0
         return
      end if
      stat = 0
   end subroutine parse_int

   !> Token text as written (strings re-quoted), for messages.
   function display(toks, i) result(s)
      type(token_list_t), intent(in) :: toks
      integer, intent(in) :: i
      character(len=:), allocatable :: s
      if (toks%kind(i) == tk_string) then
         s = '"'//toks%text(i)%s//'"'
      else if (toks%kind(i) == tk_group) then
         s = '&'//toks%text(i)%s
      else
         s = toks%text(i)%s
      end if
   end function display

   subroutine push(toks, kind, text, line)
      type(token_list_t), intent(inout) :: toks
      integer, intent(in) :: kind, line
      character(len=*), intent(in) :: text
      integer, allocatable :: ti(:)
      type(string_t), allocatable :: ts(:)
      integer :: n
      n = toks%n
      if (n == size(toks%kind)) then
         allocate (ti(2*n))
         ti(1:n) = toks%kind
         call move_alloc(ti, toks%kind)
         allocate (ti(2*n))
         ti(1:n) = toks%line
         call move_alloc(ti, toks%line)
         allocate (ts(2*n))
         ts(1:n) = toks%text
         call move_alloc(ts, toks%text)
      end if
      n = n + 1
      toks%kind(n) = kind
      toks%line(n) = line
      toks%text(n)%s = text
      toks%n = n
   end subroutine push

   subroutine grow_groups(groups)
      type(deck_group_t), allocatable, intent(inout) :: groups(:)
      type(deck_group_t), allocatable :: tmp(:)
      allocate (tmp(2*size(groups)))
      tmp(1:size(groups)) = groups
      call move_alloc(tmp, groups)
   end subroutine grow_groups

   subroutine grow_entries(entries)
      type(deck_entry_t), allocatable, intent(inout) :: entries(:)
      type(deck_entry_t), allocatable :: tmp(:)
      allocate (tmp(2*size(entries)))
      tmp(1:size(entries)) = entries
      call move_alloc(tmp, entries)
   end subroutine grow_entries

   !> Repeat count such as `3*0.0` or `3*`.
   pure logical function is_repeat(s)
      character(len=*), intent(in) :: s
      integer :: p
      p = index(s, '*')
      is_repeat = .false.
      if (p <= 1) return
      is_repeat = verify(s(1:p - 1), '0123456789') == 0
   end function is_repeat

   !> Key names: a letter followed by letters, digits and '_'.
   pure logical function is_key(s)
      character(len=*), intent(in) :: s
      integer :: i
      is_key = .false.
      if (len(s) == 0) return
      if (.not. is_letter(s(1:1))) return
      do i = 2, len(s)
         if (.not. is_name_char(s(i:i))) return
      end do
      is_key = .true.
   end function is_key

   pure logical function is_blank(c)
      character(len=1), intent(in) :: c
      is_blank = c == ' ' .or. c == achar(9) .or. c == achar(13)
   end function is_blank

   pure logical function ends_word(c)
      character(len=1), intent(in) :: c
      ends_word = is_blank(c) .or. c == new_line('a') .or. index(",=/!'""", c) > 0
   end function ends_word

   pure logical function is_letter(c)
      character(len=1), intent(in) :: c
      is_letter = (c >= 'a' .and. c <= 'z') .or. (c >= 'A' .and. c <= 'Z')
   end function is_letter

   pure logical function is_digit(c)
      character(len=1), intent(in) :: c
      is_digit = c >= '0' .and. c <= '9'
   end function is_digit

   pure logical function is_name_char(c)
      character(len=1), intent(in) :: c
      is_name_char = is_letter(c) .or. is_digit(c) .or. c == '_'
   end function is_name_char

end module trainsim_deck
