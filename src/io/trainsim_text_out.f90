!> Lines of a table built field by field and written in blocks: the text of Fortran's
!> edit descriptors Aw, Iw, I0, ESw.d, Fw.d and nX without a formatted `write` per
!> field (gfortran's costs about 4 400 instructions a real; a table of 20 000 rows
!> took a third of a run's start-up: D-82). ESw.d and Fw.d take C's snprintf digits
!> (correctly rounded, as gfortran's own), and Fortran's write for what that form
!> does not cover; test_text_out checks every form against Fortran's write.
module trainsim_text_out
   use, intrinsic :: iso_c_binding, only: c_double, c_int, c_char
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use, intrinsic :: iso_fortran_env, only: int64
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: text_out_t

   integer, parameter :: block_chars = 65536   !< written when the buffer holds this much
   integer, parameter :: i16 = selected_int_kind(38)
   integer :: k_
   !> powers of ten looked up, not raised (an integer power of a variable is a library call)
   integer(i16), parameter :: ten16(0:38) = [(10_i16**k_, k_=0, 38)]
   integer(int64), parameter :: ten8(0:18) = [(10_int64**k_, k_=0, 18)]

   type :: text_out_t
      integer :: unit = 6
      character(len=:), allocatable :: buf
      integer :: n = 0                         !< characters in buf
      !> the last ESw.d digits es_exact wrote: x's bits, d, the text (a table repeats
      !> its values: each costs ~500 instructions; startup7b)
      integer(int64) :: memo_bits = 0
      integer :: memo_d = -1, memo_n = 0
      character(len=32) :: memo_t = ''
   contains
      procedure :: a => put_a
      procedure :: i => put_i
      procedure :: es => put_es
      procedure :: f => put_f
      procedure :: x => put_x
      procedure :: end_line
      procedure :: flush => flush_lines
   end type text_out_t

   interface
      integer(c_int) function c_fmt_e(x, d, buf, cap) bind(c, name='trainsim_fmt_e')
         import :: c_double, c_int, c_char
         real(c_double), value :: x
         integer(c_int), value :: d, cap
         character(kind=c_char), intent(out) :: buf(*)
      end function c_fmt_e
      integer(c_int) function c_fmt_f(x, d, buf, cap) bind(c, name='trainsim_fmt_f')
         import :: c_double, c_int, c_char
         real(c_double), value :: x
         integer(c_int), value :: d, cap
         character(kind=c_char), intent(out) :: buf(*)
      end function c_fmt_f
   end interface

contains

   !> Room for m more characters.
   subroutine reserve(self, m)
      class(text_out_t), intent(inout) :: self
      integer, intent(in) :: m
      if (.not. fits(self, m)) call grow(self, m)
   end subroutine reserve

   !> The buffer holds m more characters.
   pure logical function fits(self, m)
      class(text_out_t), intent(in) :: self
      integer, intent(in) :: m
      fits = .false.
      if (allocated(self%buf)) fits = self%n + m <= len(self%buf)
   end function fits

   subroutine grow(self, m)
      class(text_out_t), intent(inout) :: self
      integer, intent(in) :: m
      character(len=:), allocatable :: grown
      if (.not. allocated(self%buf)) allocate (character(len=max(2*block_chars, 2*m)) :: self%buf)
      if (self%n + m <= len(self%buf)) return
      allocate (character(len=max(2*len(self%buf), self%n + m)) :: grown)
      grown(1:self%n) = self%buf(1:self%n)
      call move_alloc(grown, self%buf)
   end subroutine grow

   !> Text s right-justified in w columns as Aw writes it (its first w characters
   !> if longer); w = 0: s as it is (A).
   subroutine put_a(self, s, w)
      class(text_out_t), intent(inout) :: self
      character(len=*), intent(in) :: s
      integer, intent(in) :: w
      integer :: m, n, k, j
      n = self%n
      m = len(s)
      k = m                        ! the field's width
      if (w > 0) then
         m = min(m, w)
         k = w
      end if
      if (.not. fits(self, k)) call grow(self, k)
      do j = n + 1, n + k - m      ! (a few blanks: no memset call)
         self%buf(j:j) = ' '
      end do
      self%buf(n + k - m + 1:n + k) = s(1:m)
      self%n = n + k
   end subroutine put_a

   !> n blanks (nX).
   subroutine put_x(self, n)
      class(text_out_t), intent(inout) :: self
      integer, intent(in) :: n
      call reserve(self, n)
      self%buf(self%n + 1:self%n + n) = ' '
      self%n = self%n + n
   end subroutine put_x

   !> An integer as Iw writes it (w = 0: I0).
   subroutine put_i(self, k, w)
      class(text_out_t), intent(inout) :: self
      integer, intent(in) :: k, w
      character(len=12) :: s
      integer(int64) :: v
      integer :: j
      v = abs(int(k, int64))   ! (in 64 bits: -huge(1) - 1 has no 32-bit absolute value)
      j = len(s) + 1
      do
         j = j - 1
         s(j:j) = achar(48 + int(mod(v, 10_int64)))
         v = v/10
         if (v == 0) exit
      end do
      if (k < 0) then
         j = j - 1
         s(j:j) = '-'
      end if
      if (w > 0 .and. len(s) - j + 1 > w) then
         call put_a(self, repeat('*', w), w)
      else
         call put_a(self, s(j:), w)
      end if
   end subroutine put_i

   !> A real as ESw.d writes it.
   subroutine put_es(self, x, w, d)
      class(text_out_t), intent(inout) :: self
      real(wp), intent(in) :: x
      integer, intent(in) :: w, d
      character(kind=c_char) :: c(48)
      integer :: m
      if (es_exact(self, x, w, d)) return
      m = 0
      if (ieee_is_finite(x) .and. d <= 30) m = c_fmt_e(real(x, c_double), d, c, 48)
      ! the form C and Fortran share: [-]d.ddddE+dd (two exponent digits)
      if (m >= d + 6 .and. m <= min(d + 7, w)) then
         if (c(m - 3) /= 'E') m = 0   ! a three-digit exponent (Fortran drops the E)
      else
         m = 0
      end if
      call put_c_or_fortran(self, c, m, x, 'es', w, d)
   end subroutine put_es

   !> ESw.d of a normal (or zero) x with a two-digit exponent and at most 17 digits,
   !> in 128-bit integers: x = m 2^e2 exactly, the d+1 digits q = x/10^s rounded to
   !> nearest, ties to even (as snprintf, which gfortran's ES calls, rounds).
   !> False (nothing written) where this does not apply; put_es then asks snprintf.
   logical function es_exact(self, x, w, d) result(done)
      class(text_out_t), intent(inout) :: self
      real(wp), intent(in) :: x
      integer, intent(in) :: w, d
      integer(i16) :: num, den, q, r, p10
      integer(int64) :: m, q8
      integer :: e2, ex, sc, pass, j, k, n
      character(len=32) :: t
      done = .false.
      if (d > 16 .or. d + 7 > w) return
      if (.not. ieee_is_finite(x)) return   ! (alone: a NaN in a comparison traps in Debug)
      if (x == 0.0_wp) then   ! 0.000E+00 (-0.000E+00 for -0) without the digit loop
         n = 0
         if (sign(1.0_wp, x) < 0.0_wp) then
            n = 1
            t(1:1) = '-'
         end if
         t(n + 1:n + d + 2) = '0.00000000000000000'   ! (truncated to d + 2 characters)
         t(n + d + 3:n + d + 6) = 'E+00'
         call put_a(self, t(1:n + d + 6), w)
         done = .true.
         return
      else
         if (abs(x) < tiny(x)) return
         if (d == self%memo_d .and. transfer(x, 0_int64) == self%memo_bits) then
            call put_a(self, self%memo_t(1:self%memo_n), w)
            done = .true.
            return
         end if
         m = int(scale(fraction(abs(x)), digits(x)), int64)   ! 2^52 <= m < 2^53
         e2 = exponent(x) - digits(x)
         ex = floor(log10(abs(x)))
         do pass = 1, 3
            sc = ex - d                                      ! q ~ |x| / 10^sc, d+1 digits
            if (max(e2, 0) + 4*max(-sc, 0) > 70 .or. max(-e2, 0) + 4*max(sc, 0) > 120) return
            num = shiftl(int(m, i16), max(e2, 0))*ten16(max(-sc, 0))
            den = shiftl(1_i16, max(-e2, 0))*ten16(max(sc, 0))
            q = num/den
            r = num - q*den
            if (2*r > den .or. (2*r == den .and. mod(q, 2_i16) == 1)) q = q + 1
            p10 = ten16(d)
            if (q >= 10*p10) then
               ex = ex + 1
            else if (q < p10) then
               ex = ex - 1
            else
               exit
            end if
         end do
         if (pass > 3 .or. abs(ex) > 99) return
      end if
      n = d + 6
      if (sign(1.0_wp, x) < 0.0_wp) n = n + 1
      k = n - 4                                              ! the last mantissa digit
      q8 = int(q, int64)                                     ! q < 10^17: the digits in 64 bits
      do j = k, k - d + 1, -1
         t(j:j) = achar(48 + int(mod(q8, 10_int64)))
         q8 = q8/10
      end do
      t(k - d:k - d) = '.'
      t(k - d - 1:k - d - 1) = achar(48 + int(q8))
      if (n == d + 7) t(1:1) = '-'
      t(k + 1:k + 1) = 'E'
      t(k + 2:k + 2) = merge('-', '+', ex < 0)
      t(k + 3:k + 3) = achar(48 + abs(ex)/10)
      t(k + 4:k + 4) = achar(48 + mod(abs(ex), 10))
      call put_a(self, t(1:n), w)
      self%memo_bits = transfer(x, 0_int64)
      self%memo_d = d
      self%memo_n = n
      self%memo_t(1:n) = t(1:n)
      done = .true.
   end function es_exact

   !> A real as Fw.d writes it.
   subroutine put_f(self, x, w, d)
      class(text_out_t), intent(inout) :: self
      real(wp), intent(in) :: x
      integer, intent(in) :: w, d
      character(kind=c_char) :: c(48)
      integer :: m
      if (f_exact(self, x, w, d)) return
      m = 0
      if (ieee_is_finite(x)) then
         if (abs(x) < 1.0e15_wp .and. d <= 20) m = c_fmt_f(real(x, c_double), d, c, 48)
      end if
      if (m > w) m = 0
      call put_c_or_fortran(self, c, m, x, 'f', w, d)
   end subroutine put_f

   !> Fw.d of x as C's %.*f writes it (what put_f takes when it fits) for |x| < 1e9
   !> and 1 <= d <= 9, in 128-bit integers as es_exact: q = |x| 10^d rounded to
   !> nearest, ties to even; the sign of a negative x (or -0) kept. False (nothing
   !> written) outside that range or wider than w: put_f then asks snprintf.
   logical function f_exact(self, x, w, d) result(done)
      class(text_out_t), intent(inout) :: self
      real(wp), intent(in) :: x
      integer, intent(in) :: w, d
      integer(i16) :: num, den, q, r
      integer(int64) :: ip, fp, p10, q8
      integer :: e2, n, j, k, s2
      character(len=32) :: t
      done = .false.
      if (d < 1 .or. d > 9) return
      if (.not. ieee_is_finite(x)) return
      if (.not. abs(x) < 1.0e9_wp) return
      q = 0
      if (abs(x) >= 1.0e-18_wp) then   ! (below: |x| 10^d < 1e-9 rounds to 0; above: 2^-e2 < 2^113)
         e2 = exponent(x) - digits(x)
         num = shiftl(int(scale(fraction(abs(x)), digits(x)), i16), max(e2, 0))*ten16(d)
         s2 = max(-e2, 0)                       ! den = 2^s2: the quotient by a shift
         den = shiftl(1_i16, s2)
         q = shiftr(num, s2)
         r = num - shiftl(q, s2)
         if (2*r > den .or. (2*r == den .and. iand(q, 1_i16) == 1)) q = q + 1
      end if
      p10 = ten8(d)
      q8 = int(q, int64)                        ! q < 10^18: split in 64 bits
      ip = q8/p10
      fp = q8 - ip*p10
      n = 0
      if (sign(1.0_wp, x) < 0.0_wp) then
         n = 1
         t(1:1) = '-'
      end if
      k = 1                                   ! digits of the integer part (at least one)
      do while (ip >= ten8(k))
         k = k + 1
      end do
      do j = n + k, n + 1, -1
         t(j:j) = achar(48 + int(mod(ip, 10_int64)))
         ip = ip/10
      end do
      n = n + k + 1
      t(n:n) = '.'
      do j = n + d, n + 1, -1
         t(j:j) = achar(48 + int(mod(fp, 10_int64)))
         fp = fp/10
      end do
      n = n + d
      if (n > w) return
      call put_a(self, t(1:n), w)
      done = .true.
   end function f_exact

   !> The m characters of c right-justified in w columns, or (m = 0) Fortran's own
   !> write of x with edit descriptor `letter`w.d (es or f).
   subroutine put_c_or_fortran(self, c, m, x, letter, w, d)
      class(text_out_t), intent(inout) :: self
      character(kind=c_char), intent(in) :: c(:)
      integer, intent(in) :: m, w, d
      real(wp), intent(in) :: x
      character(len=*), intent(in) :: letter
      character(len=64) :: t
      character(len=16) :: fmt
      integer :: j
      if (m <= 0) then
         write (fmt, '(2a,i0,a,i0,a)') '(', letter, w, '.', d, ')'
         write (t, fmt) x
         call put_a(self, t(1:w), w)
         return
      end if
      do j = 1, m
         t(j:j) = c(j)
      end do
      call put_a(self, t(1:m), w)
   end subroutine put_c_or_fortran

   !> Ends the line; the buffer goes out once it holds a block.
   subroutine end_line(self)
      class(text_out_t), intent(inout) :: self
      call reserve(self, 1)
      self%n = self%n + 1
      self%buf(self%n:self%n) = new_line('a')
      if (self%n >= block_chars) call self%flush()
   end subroutine end_line

   !> Writes the lines ended so far (and any started line with them).
   subroutine flush_lines(self)
      class(text_out_t), intent(inout) :: self
      if (self%n == 0) return
      if (self%buf(self%n:self%n) == new_line('a')) then
         write (self%unit, '(a)') self%buf(1:self%n - 1)
      else
         write (self%unit, '(a)') self%buf(1:self%n)
      end if
      self%n = 0
   end subroutine flush_lines
end module trainsim_text_out
