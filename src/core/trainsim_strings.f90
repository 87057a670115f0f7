!> Small string utilities shared by the deck reader, the registry and the output.
module trainsim_strings
   use, intrinsic :: iso_c_binding, only: c_ptr, c_char, c_int, c_size_t, c_associated
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: string_t, to_lower, str, join, invalid_text_byte, edit_distance, has_cr

   !> A variable-length string, for arrays of names.
   type :: string_t
      character(len=:), allocatable :: s
   end type string_t

   interface str
      module procedure str_int, str_real
   end interface str

   interface
      !> C's memchr: a deck's CRs are looked for at memory speed (gfortran's index
      !> takes ~10 instructions a byte, 2.5 % of a 5 000-node start-up).
      pure type(c_ptr) function c_memchr(s, c, n) bind(c, name='memchr')
         import :: c_ptr, c_char, c_int, c_size_t
         character(kind=c_char), intent(in) :: s(*)
         integer(c_int), value :: c
         integer(c_size_t), value :: n
      end function c_memchr
      !> Leading bytes of s(1:n) in 1..127 (trainsim_textfmt.c): the UTF-8 check's
      !> walk starts after them (~1 instruction a byte against ~9).
      pure integer(c_size_t) function c_ascii_prefix(s, n) bind(c, name='trainsim_ascii_prefix')
         import :: c_char, c_size_t
         character(kind=c_char), intent(in) :: s(*)
         integer(c_size_t), value :: n
      end function c_ascii_prefix
   end interface

contains

   !> Lower-case copy of `text` (ASCII).
   pure function to_lower(text) result(low)
      character(len=*), intent(in) :: text
      character(len=len(text)) :: low
      integer :: i, c
      low = text
      do i = 1, len(text)
         c = iachar(text(i:i))
         if (c >= iachar('A') .and. c <= iachar('Z')) low(i:i) = achar(c + 32)
      end do
   end function to_lower

   !> Integer as trimmed text (as `(i0)` writes it; digit by digit, not by an
   !> internal write: this is called per node and element at start-up, where
   !> gfortran's formatted I/O cost 5 000 instructions a call, D-74).
   pure function str_int(i) result(s)
      integer, intent(in) :: i
      character(len=:), allocatable :: s
      integer, parameter :: i8 = selected_int_kind(18)
      character(len=24) :: buf
      integer(i8) :: v
      integer :: p
      v = abs(int(i, i8))
      p = len(buf) + 1
      do
         p = p - 1
         buf(p:p) = achar(iachar('0') + int(mod(v, 10_i8)))
         v = v/10_i8
         if (v == 0_i8) exit
      end do
      if (i < 0) then
         p = p - 1
         buf(p:p) = '-'
      end if
      s = buf(p:)
   end function str_int

   !> Real as the shortest text that reads back to the same value
   !> (fixed notation between 1e-4 and 1e7, else scientific); with `sig`, in
   !> scientific notation with that many significant digits (for messages).
   pure function str_real(x, sig) result(s)
      real(wp), intent(in) :: x
      integer, intent(in), optional :: sig   !< significant digits for display (default: round trip)
      character(len=:), allocatable :: s
      character(len=48) :: buf
      character(len=16) :: fmt
      real(wp) :: back
      integer :: d, ios
      logical :: fixed
      if (x /= x) then
         s = 'NaN'
         return
      end if
      if (present(sig)) then
         write (fmt, '(a,i0,a)') '(es0.', max(sig - 1, 1), ')'
         write (buf, fmt) x
         s = trim(adjustl(buf))
         return
      end if
      fixed = x == 0.0_wp .or. (abs(x) >= 1.0e-4_wp .and. abs(x) < 1.0e7_wp)
      do d = 0, 17
         if (fixed) then
            write (fmt, '(a,i0,a)') '(f0.', d, ')'
         else   ! es0.0 means "all digits" to gfortran: start at one decimal
            write (fmt, '(a,i0,a)') '(es0.', max(d, 1), ')'
         end if
         write (buf, fmt) x
         read (buf, *, iostat=ios) back
         if (ios == 0 .and. back == x) exit
      end do
      s = trim(adjustl(buf))
      if (fixed .and. s(len(s):len(s)) == '.') s = s(1:len(s) - 1)
      if (s(1:1) == '.') s = '0'//s
      if (len(s) > 1) then
         if (s(1:2) == '-.') s = '-0'//s(2:)
      end if
   end function str_real

   !> Join names with a separator: ["a","b"] -> "a, b".
   pure function join(items, sep) result(s)
      type(string_t), intent(in) :: items(:)
      character(len=*), intent(in) :: sep
      character(len=:), allocatable :: s
      integer :: i
      s = ''
      do i = 1, size(items)
         if (i > 1) s = s//sep
         s = s//items(i)%s
      end do
   end function join
   !> Index of the first byte of `text` that makes it not UTF-8 text: a NUL byte, or a
   !> byte that does not start or continue a valid UTF-8 sequence (overlong forms,
   !> surrogates U+D800-DFFF and code points above U+10FFFF are invalid). 0 if valid.
   pure function invalid_text_byte(text) result(pos)
      character(len=*), intent(in) :: text
      integer :: pos
      integer :: i, n, b, b2, nfollow, k
      n = len(text)
      pos = 0
      i = 1
      if (n > 0) i = 1 + int(c_ascii_prefix(text, int(n, c_size_t)))
      do while (i <= n)
         b = iachar(text(i:i))
         if (b < 128) then
            if (b == 0) then
               pos = i
               return
            end if
            i = i + 1
            cycle
         end if
         if (b >= 194 .and. b <= 223) then
            nfollow = 1
         else if (b >= 224 .and. b <= 239) then
            nfollow = 2
         else if (b >= 240 .and. b <= 244) then
            nfollow = 3
         else
            nfollow = -1
         end if
         if (nfollow > 0) then
            if (i + nfollow > n) then
               nfollow = -1
            else
               do k = 1, nfollow
                  b2 = iachar(text(i + k:i + k))
                  if (b2 < 128 .or. b2 > 191) nfollow = -1
               end do
            end if
         end if
         if (nfollow > 0) then
            b2 = iachar(text(i + 1:i + 1))
            if ((b == 224 .and. b2 < 160) .or. (b == 237 .and. b2 > 159) .or. &
                (b == 240 .and. b2 < 144) .or. (b == 244 .and. b2 > 143)) nfollow = -1
         end if
         if (nfollow < 0) then
            pos = i
            return
         end if
         i = i + nfollow + 1
      end do
   end function invalid_text_byte

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

   !> s holds a CR.
   pure logical function has_cr(s)
      character(len=*), intent(in) :: s
      has_cr = .false.
      if (len(s) > 0) has_cr = c_associated(c_memchr(s, 13_c_int, int(len(s), c_size_t)))
   end function has_cr
end module trainsim_strings
