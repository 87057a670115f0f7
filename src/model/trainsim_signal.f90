!> Functions of time for loads, prescribed speeds and motor voltages:
!> constant, step, ramp, sine, piecewise-linear table (inline or from a file)
!> and the start-stop duty cycle (accelerate, cruise, decelerate, dwell, n times).
!> Each gives its value, its time integral from t = 0 (the angle of a
!> prescribed-speed node), its second integral (a prescribed acceleration's
!> angle) and its first and second derivatives (a prescribed speed's or angle's
!> acceleration).
module trainsim_signal
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input, err_io
   use trainsim_strings, only: to_lower, str, invalid_text_byte
   use trainsim_deck, only: deck_group_t, parse_real
   use trainsim_limits, only: in_range, check_magnitude
   implicit none
   private

   public :: signal_t, signal_from_group, constant_signal, ramp_signal, max_cycles, table_from_group

   !> Most cycles of a start-stop profile (a year of 30 s cycles); more is a typing error.
   integer, parameter :: max_cycles = 1000000

   integer, parameter :: sig_constant = 0, sig_table = 1, sig_sine = 2

   !> A function of time. Tables are stored with the cumulative integral at the knots.
   type :: signal_t
      integer :: kind = sig_constant
      character(len=:), allocatable :: label      !< 'constant', 'step', ... (for output)
      real(wp) :: value0 = 0.0_wp                 !< constant value / sine offset
      real(wp) :: amplitude = 0.0_wp, omega = 0.0_wp, phase = 0.0_wp
      real(wp), allocatable :: times(:), values(:), cum(:)
      !> a table's second cumulative integral at the knots (zero at the first)
      real(wp), allocatable :: cum2(:)
      real(wp) :: integral_at_zero = 0.0_wp
      real(wp) :: integral2_at_zero = 0.0_wp   !< the antiderivative of the integral at t = 0
      !> A table read from a file: the path as the deck wrote it, the path opened,
      !> and the file's text, so the output can embed it beside the deck.
      character(len=:), allocatable :: source_key, source_file, source_text
   contains
      procedure :: value => signal_value
      procedure :: integral => signal_integral
      procedure :: derivative => signal_derivative
      procedure :: derivative2 => signal_derivative2
      procedure :: integral2 => signal_integral2
      procedure :: breakpoints => signal_breakpoints
      procedure :: is_constant => signal_is_constant
   end type signal_t

contains

   !> A constant signal.
   pure function constant_signal(v) result(s)
      real(wp), intent(in) :: v
      type(signal_t) :: s
      s%kind = sig_constant
      s%value0 = v
      s%label = 'constant'
   end function constant_signal

   !> A ramp: v0 until t0, linear to v1 at t1 (> t0), then v1 (the deck's kind = 'ramp').
   pure function ramp_signal(t0, t1, v0, v1) result(s)
      real(wp), intent(in) :: t0, t1, v0, v1
      type(signal_t) :: s
      call set_table(s, [t0, t1], [v0, v1])
      s%label = 'ramp'
   end function ramp_signal

   !> Read a signal from a deck group: key `kind` selects the shape, the
   !> other keys give its parameters (see docs/deck.md, "Time functions").
   subroutine signal_from_group(grp, sig, err)
      type(deck_group_t), intent(inout) :: grp
      type(signal_t), intent(out) :: sig
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: kind
      real(wp) :: v0, v1, t0, t1, ta, tc, td, tw, vc
      real(wp), allocatable :: tt(:), vv(:)
      integer :: cycles, i, k

      call grp%get_string('kind', kind, err, default='constant')
      if (allocated(err)) return
      kind = to_lower(kind)
      sig%label = kind
      select case (kind)
      case ('constant')
         call grp%get_real('value', v0, err); if (allocated(err)) return
         call check_magnitude(grp, 'value', v0, err); if (allocated(err)) return
         sig = constant_signal(v0)
      case ('step')
         call grp%get_real('value0', v0, err, default=0.0_wp); if (allocated(err)) return
         call grp%get_real('value1', v1, err); if (allocated(err)) return
         call grp%get_real('t_step', t0, err); if (allocated(err)) return
         call check_magnitude(grp, 'value0', v0, err)
         call check_magnitude(grp, 'value1', v1, err)
         call check_magnitude(grp, 't_step', t0, err); if (allocated(err)) return
         call set_table(sig, [t0, t0], [v0, v1])
      case ('ramp')
         call grp%get_real('value0', v0, err, default=0.0_wp); if (allocated(err)) return
         call grp%get_real('value1', v1, err); if (allocated(err)) return
         call grp%get_real('t0', t0, err, default=0.0_wp); if (allocated(err)) return
         call grp%get_real('t1', t1, err); if (allocated(err)) return
         call check_magnitude(grp, 'value0', v0, err)
         call check_magnitude(grp, 'value1', v1, err)
         call check_magnitude(grp, 't0', t0, err)
         call check_magnitude(grp, 't1', t1, err); if (allocated(err)) return
         if (.not. t1 > t0) then
            call fatal_error(err, grp%where('t1')//': error: ramp end t1 must be later than its start t0 (got t0 = '// &
                             str(t0)//', t1 = '//str(t1)//')', err_input)
            return
         end if
         call set_table(sig, [t0, t1], [v0, v1])
      case ('sine')
         sig%kind = sig_sine
         call grp%get_real('offset', sig%value0, err, default=0.0_wp); if (allocated(err)) return
         call grp%get_real('amplitude', sig%amplitude, err); if (allocated(err)) return
         call grp%get_real('frequency', v1, err); if (allocated(err)) return
         call grp%get_real('phase', sig%phase, err, default=0.0_wp); if (allocated(err)) return
         call check_magnitude(grp, 'offset', sig%value0, err)
         call check_magnitude(grp, 'amplitude', sig%amplitude, err)
         call check_magnitude(grp, 'frequency', v1, err)
         call check_magnitude(grp, 'phase', sig%phase, err); if (allocated(err)) return
         if (.not. v1 > 0.0_wp) then
            call fatal_error(err, grp%where('frequency')//': error: sine frequency must be > 0 Hz, got '//str(v1), err_input)
            return
         end if
         sig%omega = two_pi*v1
         sig%integral_at_zero = -sig%amplitude/sig%omega*cos(sig%phase)
      case ('table')
         call table_from_group(grp, 'times', 'values', 'table_file', sig, err); if (allocated(err)) return
      case ('start_stop')
         call grp%get_real('value', vc, err); if (allocated(err)) return
         call grp%expect([character(len=7) :: 't_accel', 't_decel'])   ! a step apart (D-62)
         call grp%get_real('t_accel', ta, err); if (allocated(err)) return
         call grp%get_real('t_cruise', tc, err); if (allocated(err)) return
         call grp%get_real('t_decel', td, err); if (allocated(err)) return
         call grp%get_real('t_dwell', tw, err, default=0.0_wp); if (allocated(err)) return
         call grp%get_real('t_start', t0, err, default=0.0_wp); if (allocated(err)) return
         call grp%get_int('cycles', cycles, err, default=1); if (allocated(err)) return
         call check_magnitude(grp, 'value', vc, err)
         call check_magnitude(grp, 't_accel', ta, err)
         call check_magnitude(grp, 't_cruise', tc, err)
         call check_magnitude(grp, 't_decel', td, err)
         call check_magnitude(grp, 't_dwell', tw, err)
         call check_magnitude(grp, 't_start', t0, err); if (allocated(err)) return
         if (.not. (ta > 0.0_wp .and. td > 0.0_wp .and. tc >= 0.0_wp .and. tw >= 0.0_wp .and. t0 >= 0.0_wp)) then
            call fatal_error(err, grp%where('t_accel')//': error: start_stop needs t_accel > 0, t_decel > 0 and '// &
                             't_cruise, t_dwell, t_start >= 0', err_input)
            return
         end if
         if (cycles < 1 .or. cycles > max_cycles) then
            call fatal_error(err, grp%where('cycles')//': error: cycles must be >= 1 and <= '//str(max_cycles)//', got '// &
                             str(cycles), err_input)
            return
         end if
         allocate (tt(4*cycles + 1), vv(4*cycles + 1))
         tt(1) = t0; vv(1) = 0.0_wp
         k = 1
         do i = 1, cycles
            tt(k + 1) = tt(k) + ta; vv(k + 1) = vc
            tt(k + 2) = tt(k + 1) + tc; vv(k + 2) = vc
            tt(k + 3) = tt(k + 2) + td; vv(k + 3) = 0.0_wp
            tt(k + 4) = tt(k + 3) + tw; vv(k + 4) = 0.0_wp
            k = k + 4
         end do
         call set_table(sig, tt, vv)
      case default
         call fatal_error(err, grp%where('kind')//": error: unknown time function kind '"//kind// &
                          "'; valid kinds are: constant, step, ramp, sine, table, start_stop", err_input)
         return
      end select
      sig%label = kind
   end subroutine signal_from_group

   !> A piecewise-linear table from a deck group: the lists `xkey` and `ykey`
   !> ('times', 'values' for a time function; 'speeds', 'torques' for a load's
   !> torque against speed) or the two-column file named by `filekey`.
   subroutine table_from_group(grp, xkey, ykey, filekey, sig, err)
      type(deck_group_t), intent(inout) :: grp
      character(len=*), intent(in) :: xkey, ykey, filekey
      type(signal_t), intent(inout) :: sig
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: path
      real(wp), allocatable :: tt(:), vv(:)
      integer, allocatable :: rows(:)   ! line of each point of a table file
      integer :: i
      if (grp%has(filekey)) then
         call grp%get_string(filekey, path, err); if (allocated(err)) return
         sig%source_key = path
         path = relative_to_deck(path, grp%file)
         call read_table_file(path, tt, vv, sig%source_text, err, rows)
         if (allocated(err)) then
            err%message = grp%where(filekey)//': error: '//err%message
            return
         end if
         sig%source_file = path
      else
         call grp%get_real_array(xkey, tt, err); if (allocated(err)) return
         call grp%get_real_array(ykey, vv, err); if (allocated(err)) return
         if (size(tt) == 0) then
            call fatal_error(err, grp%where(xkey)//": error: kind = 'table' needs '"//xkey//"' and '"//ykey// &
                             "' (or '"//filekey//"')", err_input)
            return
         end if
         if (size(tt) /= size(vv)) then
            call fatal_error(err, grp%where(ykey)//': error: table has '//str(size(tt))//' '//xkey//' but '// &
                             str(size(vv))//' '//ykey, err_input)
            return
         end if
      end if
      do i = 1, size(tt)
         if (.not. (in_range(tt(i)) .and. in_range(vv(i)))) then
            call fatal_error(err, grp%where(trim(merge(filekey//repeat(' ', len(xkey)), xkey//repeat(' ', len(filekey)), &
                                                       grp%has(filekey))))// &
                             ': error: table point '//str(i)//' ('//xkey(1:len(xkey) - 1)//' '//str(tt(i))//', '// &
                             ykey(1:len(ykey) - 1)//' '//str(vv(i))// &
                             ') is out of range: trainsim accepts 0 or a magnitude in [1e-20, 1e20]', err_input)
            return
         end if
      end do
      do i = 2, size(tt)
         if (tt(i) < tt(i - 1)) then
            if (allocated(rows)) then
               call fatal_error(err, grp%where(filekey)//': error: '//sig%source_file//':'//str(rows(i))// &
                                ': table '//xkey//' must not decrease ('//str(tt(i))//' after '//str(tt(i - 1))// &
                                ' on line '//str(rows(i - 1))//')', err_input)
            else
               call fatal_error(err, grp%where(xkey)//': error: table '//xkey//' must not decrease (entry '// &
                                str(i)//': '//str(tt(i))//' after '//str(tt(i - 1))//')', err_input)
            end if
            return
         end if
      end do
      call set_table(sig, tt, vv)
   end subroutine table_from_group

   !> Store a piecewise-linear table and its cumulative integral.
   pure subroutine set_table(sig, tt, vv)
      type(signal_t), intent(inout) :: sig
      real(wp), intent(in) :: tt(:), vv(:)
      integer :: i
      sig%kind = sig_table
      sig%times = tt
      sig%values = vv
      allocate (sig%cum(size(tt)), sig%cum2(size(tt)))
      sig%cum(1) = 0.0_wp
      sig%cum2(1) = 0.0_wp
      do i = 2, size(tt)
         sig%cum(i) = sig%cum(i - 1) + 0.5_wp*(vv(i) + vv(i - 1))*(tt(i) - tt(i - 1))
         sig%cum2(i) = sig%cum2(i - 1) + sig%cum(i - 1)*(tt(i) - tt(i - 1)) + &
                       (2.0_wp*vv(i - 1) + vv(i))*(tt(i) - tt(i - 1))**2/6.0_wp
      end do
      sig%integral_at_zero = 0.0_wp
      sig%integral_at_zero = table_antiderivative(sig, 0.0_wp)
      sig%integral2_at_zero = table_antiderivative2(sig, 0.0_wp)
   end subroutine set_table

   !> Index of the last knot with times(i) <= t (0 if before the first).
   pure integer function locate(times, t) result(i)
      real(wp), intent(in) :: times(:), t
      integer :: lo, hi, mid
      if (t < times(1)) then
         i = 0; return
      end if
      lo = 1; hi = size(times)
      do while (hi > lo)
         mid = (lo + hi + 1)/2
         if (times(mid) <= t) then
            lo = mid
         else
            hi = mid - 1
         end if
      end do
      i = lo
   end function locate

   !> Value at time t.
   pure real(wp) function signal_value(self, t) result(v)
      class(signal_t), intent(in) :: self
      real(wp), intent(in) :: t
      integer :: i, n
      select case (self%kind)
      case (sig_constant)
         v = self%value0
      case (sig_sine)
         v = self%value0 + self%amplitude*sin(self%omega*t + self%phase)
      case default
         n = size(self%times)
         i = locate(self%times, t)
         if (i == 0) then
            v = self%values(1)
         else if (i == n) then
            v = self%values(n)
         else
            v = self%values(i) + (self%values(i + 1) - self%values(i))*(t - self%times(i)) &
                /(self%times(i + 1) - self%times(i))
         end if
      end select
   end function signal_value

   !> Antiderivative of a table, zero at the first knot.
   pure real(wp) function table_antiderivative(self, t) result(f)
      type(signal_t), intent(in) :: self
      real(wp), intent(in) :: t
      integer :: i, n
      real(wp) :: v
      n = size(self%times)
      i = locate(self%times, t)
      if (i == 0) then
         f = self%values(1)*(t - self%times(1))
      else if (i == n) then
         f = self%cum(n) + self%values(n)*(t - self%times(n))
      else
         v = self%values(i) + (self%values(i + 1) - self%values(i))*(t - self%times(i)) &
             /(self%times(i + 1) - self%times(i))
         f = self%cum(i) + 0.5_wp*(self%values(i) + v)*(t - self%times(i))
      end if
   end function table_antiderivative

   !> Antiderivative of `table_antiderivative`, zero at the first knot (a piecewise cubic).
   pure real(wp) function table_antiderivative2(self, t) result(g)
      type(signal_t), intent(in) :: self
      real(wp), intent(in) :: t
      integer :: i, n
      real(wp) :: h, s
      n = size(self%times)
      i = locate(self%times, t)
      if (i == 0) then
         g = 0.5_wp*self%values(1)*(t - self%times(1))**2
      else if (i == n) then
         h = t - self%times(n)
         g = self%cum2(n) + self%cum(n)*h + 0.5_wp*self%values(n)*h**2
      else
         h = t - self%times(i)
         s = (self%values(i + 1) - self%values(i))/(self%times(i + 1) - self%times(i))
         g = self%cum2(i) + self%cum(i)*h + 0.5_wp*self%values(i)*h**2 + s*h**3/6.0_wp
      end if
   end function table_antiderivative2

   !> Second integral of the signal from 0 to t: the integral from 0 to t of `integral`.
   pure real(wp) function signal_integral2(self, t) result(f)
      class(signal_t), intent(in) :: self
      real(wp), intent(in) :: t
      select case (self%kind)
      case (sig_constant)
         f = 0.5_wp*self%value0*t**2
      case (sig_sine)
         f = 0.5_wp*self%value0*t**2 - self%amplitude/self%omega**2*(sin(self%omega*t + self%phase) - sin(self%phase)) &
             - self%integral_at_zero*t
      case default
         f = table_antiderivative2(self, t) - self%integral2_at_zero - self%integral_at_zero*t
      end select
   end function signal_integral2

   !> Second time derivative at t (0 on the pieces of a table).
   pure real(wp) function signal_derivative2(self, t) result(d)
      class(signal_t), intent(in) :: self
      real(wp), intent(in) :: t
      if (self%kind == sig_sine) then
         d = -self%amplitude*self%omega**2*sin(self%omega*t + self%phase)
      else
         d = 0.0_wp
      end if
   end function signal_derivative2

   !> Integral of the signal from 0 to t.
   pure real(wp) function signal_integral(self, t) result(f)
      class(signal_t), intent(in) :: self
      real(wp), intent(in) :: t
      select case (self%kind)
      case (sig_constant)
         f = self%value0*t
      case (sig_sine)
         f = self%value0*t - self%amplitude/self%omega*cos(self%omega*t + self%phase) - self%integral_at_zero
      case default
         f = table_antiderivative(self, t) - self%integral_at_zero
      end select
   end function signal_integral

   !> Whether the signal is the same at every t (value0; integral value0 t).
   pure logical function signal_is_constant(self) result(c)
      class(signal_t), intent(in) :: self
      c = self%kind == sig_constant
   end function signal_is_constant

   !> Time derivative at t (right derivative at table knots).
   pure real(wp) function signal_derivative(self, t) result(d)
      class(signal_t), intent(in) :: self
      real(wp), intent(in) :: t
      integer :: i
      select case (self%kind)
      case (sig_constant)
         d = 0.0_wp
      case (sig_sine)
         d = self%amplitude*self%omega*cos(self%omega*t + self%phase)
      case default
         i = locate(self%times, t)
         if (i == 0 .or. i == size(self%times)) then
            d = 0.0_wp
         else
            d = (self%values(i + 1) - self%values(i))/(self%times(i + 1) - self%times(i))
         end if
      end select
   end function signal_derivative

   !> Times where the signal or its slope jumps (for integrators to stop at).
   pure subroutine signal_breakpoints(self, bp)
      class(signal_t), intent(in) :: self
      real(wp), allocatable, intent(out) :: bp(:)
      if (self%kind == sig_table) then
         bp = self%times
      else
         allocate (bp(0))
      end if
   end subroutine signal_breakpoints

   !> A relative path is taken relative to the folder of the deck file.
   pure function relative_to_deck(path, deck_file) result(full)
      character(len=*), intent(in) :: path, deck_file
      character(len=:), allocatable :: full
      integer :: k
      full = path
      if (len(path) == 0) return
      if (path(1:1) == '/') return
      k = index(deck_file, '/', back=.true.)
      if (k > 0) full = deck_file(1:k)//path
   end function relative_to_deck

   !> Read a two-column (time, value) text table (docs/deck.md, "Table files"): each
   !> data line holds exactly two numbers, separated by blanks, tabs or one comma; lines
   !> that are blank (blanks, tabs) or start with '#' or '!' are skipped; anything else is
   !> an error naming the file and line. Numbers are checked as text before conversion
   !> (trainsim_deck's parse_real), so `1e999` is refused, never converted.
   !> `text` receives the file's bytes as read (embedded in the output).
   subroutine read_table_file(path, tt, vv, text, err, rows)
      character(len=*), intent(in) :: path
      real(wp), allocatable, intent(out) :: tt(:), vv(:)
      character(len=:), allocatable, intent(out) :: text
      type(error_t), allocatable, intent(out) :: err
      integer, allocatable, intent(out) :: rows(:)   !< the line of each point
      integer :: u, ios, n, lineno, first, last, nbytes, k
      character(len=512) :: msg
      character(len=:), allocatable :: line, why
      real(wp) :: a, b
      real(wp), allocatable :: tmp_t(:), tmp_v(:)
      integer, allocatable :: tmp_r(:)
      open (newunit=u, file=path, status='old', action='read', access='stream', form='unformatted', &
            iostat=ios, iomsg=msg)
      if (ios /= 0) then
         call fatal_error(err, "cannot open table file '"//path//"': "//trim(msg), err_io)
         return
      end if
      inquire (unit=u, size=nbytes)
      allocate (character(len=max(nbytes, 0)) :: text)
      if (nbytes > 0) read (u, iostat=ios, iomsg=msg) text
      close (u)
      if (nbytes < 0 .or. ios /= 0) then
         call fatal_error(err, "cannot read table file '"//path//"': "//trim(msg), err_io)
         return
      end if
      n = invalid_text_byte(text)   ! the text is embedded in the output: it must be text
      if (n > 0) then
         write (msg, '(z2.2)') iachar(text(n:n))
         call fatal_error(err, path//':'//str(1 + count([(text(k:k) == new_line('a'), k=1, n - 1)]))// &
                          ': not UTF-8 text (byte 0x'//trim(msg)//' at offset '//str(n)// &
                          '); a table file must be UTF-8 or ASCII text', err_input)
         return
      end if
      allocate (tt(64), vv(64), rows(64))
      n = 0; lineno = 0; first = 1
      do while (first <= len(text))
         last = index(text(first:), new_line('a'))
         if (last == 0) then
            last = len(text)
         else
            last = first + last - 2
         end if
         line = text(first:last)
         first = last + 2
         lineno = lineno + 1
         if (len(line) > 0) then
            if (line(len(line):len(line)) == achar(13)) line = line(1:len(line) - 1)   ! CRLF
         end if
         call table_line(line, a, b, why)
         if (why == 'skip') cycle
         if (len(why) > 0) then
            call fatal_error(err, path//':'//str(lineno)//': '//why, err_input)
            return
         end if
         n = n + 1
         if (n > size(tt)) then
            allocate (tmp_t(2*size(tt)), tmp_v(2*size(tt)), tmp_r(2*size(tt)))
            tmp_t(1:n - 1) = tt(1:n - 1); tmp_v(1:n - 1) = vv(1:n - 1); tmp_r(1:n - 1) = rows(1:n - 1)
            call move_alloc(tmp_t, tt); call move_alloc(tmp_v, vv); call move_alloc(tmp_r, rows)
         end if
         tt(n) = a; vv(n) = b; rows(n) = lineno
      end do
      if (n == 0) then
         call fatal_error(err, path//": holds no data rows (expected lines of two numbers: time value)", err_input)
         return
      end if
      tt = tt(1:n); vv = vv(1:n); rows = rows(1:n)
   end subroutine read_table_file

   !> One line of a table file: `why` is '' for a data line (a, b set), 'skip' for a
   !> blank or comment line, else what is wrong with it.
   subroutine table_line(line, a, b, why)
      character(len=*), intent(in) :: line
      real(wp), intent(out) :: a, b
      character(len=:), allocatable, intent(out) :: why
      character(len=*), parameter :: blanks = ' '//achar(9)
      integer :: i, j, n, stat(2), ntok, p(2, 3)
      logical :: comma
      a = 0.0_wp; b = 0.0_wp
      n = len(line)
      i = verify(line, blanks)
      if (i == 0) then
         why = 'skip'
         return
      end if
      if (line(i:i) == '#' .or. line(i:i) == '!') then
         why = 'skip'
         return
      end if
      ! tokens: runs of characters other than blanks, tabs and commas; at most one comma
      ! between the two numbers, none before or after
      ntok = 0
      comma = .false.
      do while (i <= n)
         if (index(blanks, line(i:i)) > 0) then
            i = i + 1
            cycle
         end if
         if (line(i:i) == ',') then
            if (ntok /= 1 .or. comma) then
               ntok = 3
               exit
            end if
            comma = .true.
            i = i + 1
            cycle
         end if
         j = scan(line(i:), blanks//',')
         if (j == 0) then
            j = n
         else
            j = i + j - 2
         end if
         ntok = ntok + 1
         if (ntok > 2) exit
         p(:, ntok) = [i, j]
         i = j + 1
      end do
      if (ntok /= 2) then
         why = "expected two numbers (time value, separated by blanks, tabs or a comma), got '"// &
               trim(line)//"'"
         return
      end if
      call parse_real(line(p(1, 1):p(2, 1)), a, stat(1))
      call parse_real(line(p(1, 2):p(2, 2)), b, stat(2))
      if (any(stat == 1)) then
         why = "expected two numbers (time value, separated by blanks, tabs or a comma), got '"// &
               trim(line)//"'"
      else if (any(stat == 2) .or. .not. (in_range(a) .and. in_range(b))) then
         why = "'"//trim(line)//"' is out of range: trainsim accepts 0 or a magnitude in [1e-20, 1e20]"
      else
         why = ''
      end if
   end subroutine table_line
end module trainsim_signal
