!> The words of a deck: its text split into tokens (group names, keys, '=', ',', values,
!> quoted strings; comments and white space dropped), with file:line messages for text
!> that is not a deck, and the strict syntax of its numbers (`parse_real`, `parse_int`).
module trainsim_deck_lexer
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char
   use, intrinsic :: iso_fortran_env, only: int64, int8
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, invalid_text_byte
   implicit none
   private

   public :: token_list_t, tk_group, tk_end, tk_eq, tk_comma, tk_word, tk_string
   public :: check_text, tokenize, display, token_text, unquote_into, parse_real, parse_int, is_repeat, is_key, lower_in_place, digits

   ! Token kinds produced by the lexer.
   integer, parameter :: tk_group = 1   ! '&name' (text = lower-case name)
   integer, parameter :: tk_end = 2     ! '/' or '&end'
   integer, parameter :: tk_eq = 3      ! '='
   integer, parameter :: tk_comma = 4   ! ','
   integer, parameter :: tk_word = 5    ! bare token
   integer, parameter :: tk_string = 6  ! quoted string (text = contents, unquoted)

   !> The tokens of a deck text, in order: kind (tk_*), line and place of each in the text:
   !> text(at:at+nc-1) is a group's name (after '&'), a word, or a quoted string's inside
   !> (its doubled quotes still doubled: `token_text` gives the string); nc = 0 for '=',
   !> ',' and '/', nc = 4 for '&end'. No allocation a token (D-159).
   type :: token_list_t
      integer :: n = 0
      integer, allocatable :: kind(:), line(:), at(:), nc(:)
   end type token_list_t

   !> The class of each byte for `tokenize` (D-176): a table look-up a character of the
   !> deck instead of a chain of tests. 0: a word's, 1: line end, 2: blank (space, tab,
   !> CR), 3: '!', 4: '=', ',' or '/', 5: '&', 6: a quote.
   integer, parameter :: c_lf = 1, c_blank = 2, c_bang = 3, c_punct = 4, c_amp = 5, c_quote = 6
   integer :: tk_i_
   integer(int8), parameter :: byte_class(0:255) = int([(merge(c_lf, 0, tk_i_ == 10) + &
      merge(c_blank, 0, tk_i_ == 32 .or. tk_i_ == 9 .or. tk_i_ == 13) + merge(c_bang, 0, tk_i_ == 33) + &
      merge(c_punct, 0, tk_i_ == 61 .or. tk_i_ == 44 .or. tk_i_ == 47) + merge(c_amp, 0, tk_i_ == 38) + &
      merge(c_quote, 0, tk_i_ == 39 .or. tk_i_ == 34), tk_i_ = 0, 255)], int8)

   !> 10^0 .. 10^22: every one exact in double precision (parse_real's fast path)
   real(wp), parameter :: pow10(0:22) = [1.0e0_wp, 1.0e1_wp, 1.0e2_wp, 1.0e3_wp, 1.0e4_wp, 1.0e5_wp, 1.0e6_wp, &
      1.0e7_wp, 1.0e8_wp, 1.0e9_wp, 1.0e10_wp, 1.0e11_wp, 1.0e12_wp, 1.0e13_wp, 1.0e14_wp, 1.0e15_wp, 1.0e16_wp, &
      1.0e17_wp, 1.0e18_wp, 1.0e19_wp, 1.0e20_wp, 1.0e21_wp, 1.0e22_wp]

   interface
      !> strtod of the n characters s (trainsim_textfmt.c); ok = 0 if too long for it.
      real(c_double) function c_strtod(s, n, ok) bind(c, name='trainsim_strtod')
         import :: c_int, c_double, c_char
         character(kind=c_char), intent(in) :: s(*)
         integer(c_int), value :: n
         integer(c_int), intent(out) :: ok
      end function c_strtod
   end interface

contains

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
      character(len=1) :: c, q
      integer :: i, j, n, line, nt, kind, at, nc

      n = len(text)
      ! room for the most tokens a text can hold, one a character: never grown, and the
      ! pages not written are never touched (D-159)
      allocate (toks%kind(max(1, n)), toks%line(max(1, n)), toks%at(max(1, n)), toks%nc(max(1, n)))
      nt = 0
      line = 1
      i = 1
      do while (i <= n)
         kind = 0   ! a token found: its kind, at and nc, appended below
         select case (byte_class(iachar(text(i:i))))
         case (c_lf)
            line = line + 1
            i = i + 1
         case (c_blank)
            i = i + 1
         case (c_bang)
            do while (i <= n)
               if (text(i:i) == new_line('a')) exit
               i = i + 1
            end do
         case (c_punct)
            c = text(i:i)
            kind = tk_end
            if (c == '=') kind = tk_eq
            if (c == ',') kind = tk_comma
            at = i
            nc = 0
            i = i + 1
         case (c_amp)
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
            if (is_end(text(i + 1:j - 1))) then
               kind = tk_end
               at = i
               nc = 4
            else
               kind = tk_group
               at = i + 1
               nc = j - i - 1
            end if
            i = j
         case (c_quote)
            ! Find the closing quote; a doubled quote stands for one (kept doubled here).
            q = text(i:i)
            j = i + 1
            do
               if (j > n) exit
               if (text(j:j) == new_line('a')) exit
               if (text(j:j) == q) then
                  if (j < n) then
                     if (text(j + 1:j + 1) == q) then
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
            kind = tk_string
            at = i + 1
            nc = j - i - 1
            i = j + 1
         case default   ! a word: to a blank, line end, ',', '=', '/', '!' or quote ('&' is a word's)
            j = i + 1
            do while (j <= n)
               if (byte_class(iachar(text(j:j))) > 0) then
                  if (byte_class(iachar(text(j:j))) /= c_amp) exit
               end if
               j = j + 1
            end do
            kind = tk_word
            at = i
            nc = j - i
            i = j
         end select
         if (kind /= 0) then
            nt = nt + 1
            toks%kind(nt) = kind
            toks%line(nt) = line
            toks%at(nt) = at
            toks%nc(nt) = nc
         end if
      end do
      toks%n = nt

   contains

      subroutine unterminated(fragment)
         character(len=*), intent(in) :: fragment
         call fatal_error(err, file//':'//str(line)//': error: unterminated string '//fragment// &
                          ' (strings must close on the line where they start)', err_input)
      end subroutine unterminated

   end subroutine tokenize

   !> Token i's text: a string's contents (doubled quotes as one), a group's name as
   !> written, a word.
   function token_text(text, toks, i) result(s)
      character(len=*), intent(in) :: text
      type(token_list_t), intent(in) :: toks
      integer, intent(in) :: i
      character(len=:), allocatable :: s
      integer :: n
      allocate (character(len=toks%nc(i)) :: s)
      n = 0
      if (toks%kind(i) == tk_string) then
         call unquote_into(text, toks%at(i), toks%nc(i), s, n)
         s = s(1:n)
      else
         s = text(toks%at(i):toks%at(i) + toks%nc(i) - 1)
      end if
   end function token_text

   !> A quoted string's inside text(at:at+nc-1) (its quote is text(at-1:at-1)) appended
   !> to buf after buf(1:n), each doubled quote as one; n is then the end of buf's text.
   pure subroutine unquote_into(text, at, nc, buf, n)
      character(len=*), intent(in) :: text
      integer, intent(in) :: at, nc
      character(len=*), intent(inout) :: buf
      integer, intent(inout) :: n
      integer :: k, q
      if (nc == 0) return
      q = iachar(text(at - 1:at - 1))
      k = at
      do while (k < at + nc)   ! (by codes, no index(): a library call a value)
         n = n + 1
         buf(n:n) = text(k:k)
         if (iachar(text(k:k)) == q) k = k + 1
         k = k + 1
      end do
   end subroutine unquote_into

   !> Token text as written (strings re-quoted), for messages.
   function display(text, toks, i) result(s)
      character(len=*), intent(in) :: text
      type(token_list_t), intent(in) :: toks
      integer, intent(in) :: i
      character(len=:), allocatable :: s
      select case (toks%kind(i))
      case (tk_eq)
         s = '='
      case (tk_comma)
         s = ','
      case (tk_end)
         s = '/'
         if (toks%nc(i) > 0) s = '&end'
      case (tk_string)
         s = '"'//token_text(text, toks, i)//'"'
      case (tk_group)
         s = '&'//token_text(text, toks, i)
         call lower_in_place(s)
      case default
         s = token_text(text, toks, i)
      end select
   end function display

   !> Strict real syntax: [sign] digits [. digits] [(e|d) [sign] digits], at least one mantissa
   !> digit. Values beyond the range of real(wp) are rejected before conversion, so no FP trap
   !> can fire. stat: 0 ok, 1 bad syntax, 2 out of range.
   subroutine parse_real(s, val, stat)
      character(len=*), intent(in) :: s
      real(wp), intent(out) :: val
      integer, intent(out) :: stat
      character(len=len(s)) :: buf
      integer :: i, n, nint_dig, nfrac_dig, first_pow, expo, expsign, nexp_dig, ios, nsig, e10
      integer(c_int) :: ok
      integer(int64) :: mant
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
      mant = 0   ! the digits as an integer while they are at most 15 from the first non-zero
      nsig = 0
      ! Mantissa. For the first non-zero digit remember its index; its power of ten follows.
      do while (i <= n)
         if (is_digit(s(i:i))) then
            if (seen_dot) then
               nfrac_dig = nfrac_dig + 1
            else
               nint_dig = nint_dig + 1
            end if
            if (nsig < 16) mant = 10*mant + (iachar(s(i:i)) - iachar('0'))
            if (mant > 0) nsig = nsig + 1
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
      ! Clinger's fast path (D-175): at most 15 digits (an integer below 2^53, exact) and
      ! a power of ten 10^|e10| <= 1e22 (exact): one IEEE product or quotient of two exact
      ! values, correctly rounded as strtod rounds, without strtod's ~450 instructions
      e10 = expo - nfrac_dig
      if (nsig <= 15 .and. abs(e10) <= 22) then
         if (e10 >= 0) then
            val = real(mant, wp)*pow10(e10)
         else
            val = real(mant, wp)/pow10(-e10)
         end if
         if (s(1:1) == '-') val = -val
         stat = 0
         return
      end if
      val = c_strtod(buf, n, ok)   ! the value list-directed `read (buf, *)` gives (D-82), without its cost
      ios = 0
      if (ok == 0) read (buf, *, iostat=ios) val
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

   !> Repeat count such as `3*0.0` or `3*`: digits and then '*' (by codes, not index()
   !> and verify(): library calls a value of the deck, D-176).
   pure logical function is_repeat(s)
      character(len=*), intent(in) :: s
      integer :: p, c
      is_repeat = .false.
      do p = 1, len(s)
         c = iachar(s(p:p))
         if (c == 42) exit   ! '*'
         if (c < 48 .or. c > 57) return
      end do
      is_repeat = p > 1 .and. p <= len(s)
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

   !> t in lower case (ASCII letters), without a temporary.
   pure subroutine lower_in_place(t)
      character(len=*), intent(inout) :: t
      integer :: k, c
      do k = 1, len(t)
         c = iachar(t(k:k))
         if (c >= iachar('A') .and. c <= iachar('Z')) t(k:k) = achar(c + 32)
      end do
   end subroutine lower_in_place

   !> Decimal digits of i (a line or ordinal; as str(i) writes them, -1 too) in buf(1:n).
   pure subroutine digits(i, buf, n)
      integer, intent(in) :: i
      character(len=12), intent(out) :: buf
      integer, intent(out) :: n
      integer :: v, m
      v = abs(i)
      m = 12
      do
         buf(m:m) = achar(iachar('0') + mod(v, 10))
         v = v/10
         if (v == 0) exit
         m = m - 1
      end do
      if (i < 0) then
         m = m - 1
         buf(m:m) = '-'
      end if
      n = 13 - m
      buf(1:n) = buf(m:12)
   end subroutine digits

   !> The group name `t` is 'end' in any case (without a lowered copy: D-90).
   pure logical function is_end(t)
      character(len=*), intent(in) :: t
      integer :: b
      is_end = .false.
      if (len(t) /= 3) return
      b = ior(iachar(t(1:1)), 32)
      if (b /= iachar('e')) return
      b = ior(iachar(t(2:2)), 32)
      if (b /= iachar('n')) return
      is_end = ior(iachar(t(3:3)), 32) == iachar('d')
   end function is_end

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

end module trainsim_deck_lexer
