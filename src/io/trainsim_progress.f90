!> Progress of a long run on stderr (`trainsim run`): simulated time, events so
!> far, wall time and an estimate of the time left.
!>
!> Nothing is printed during the first `quiet_for` seconds of wall time, so a
!> short run prints nothing extra. On a terminal (stderr a tty) one line is
!> rewritten in place (carriage return) about twice a second and cleared at
!> the end; redirected, a whole line is printed every `interval` seconds (10 by
!> default; the environment variable TRAINSIM_PROGRESS_INTERVAL sets it).
!>
!> The driver calls `poll` once per output time or block of steps; it reads
!> the clock only every `stride` calls, a stride that adapts so that the clock
!> is read about every 20-100 ms: nothing is done per step.
module trainsim_progress
   use, intrinsic :: iso_fortran_env, only: error_unit
   use, intrinsic :: iso_c_binding, only: c_int
   use trainsim_kinds, only: wp, i8
   use trainsim_strings, only: str
   implicit none
   private

   public :: progress_t, stderr_is_terminal

   type :: progress_t
      logical :: on = .false.          !< print at all (set by `start`)
      logical :: tty = .false.         !< stderr is a terminal: one line rewritten in place
      real(wp) :: interval = 10.0_wp   !< s of wall time between lines when not a tty
      real(wp) :: quiet_for = 2.0_wp   !< s of wall time before the first report
      real(wp) :: t0 = 0.0_wp, t_end = 0.0_wp
      integer(i8) :: c0 = 0, c_last = 0, c_next = 0, rate = 1
      integer :: calls = 0, stride = 1
      integer :: shown = 0             !< length of the line on the terminal (0: none)
      integer :: lines = 0             !< lines printed
   contains
      procedure :: start => pr_start
      procedure :: poll => pr_poll
      procedure :: finish => pr_finish
   end type progress_t

   interface
      function c_isatty(fd) bind(C, name='isatty') result(r)
         import :: c_int
         integer(c_int), value :: fd
         integer(c_int) :: r
      end function c_isatty
   end interface

contains

   !> Whether stderr (file descriptor 2) is a terminal.
   logical function stderr_is_terminal()
      stderr_is_terminal = c_isatty(2_c_int) == 1
   end function stderr_is_terminal

   !> Begin timing a run from t0 to t_end. The interval between lines comes from
   !> TRAINSIM_PROGRESS_INTERVAL (seconds) if set to a positive number; with it
   !> set, the quiet start is that interval too (short for tests).
   subroutine pr_start(self, t0, t_end)
      class(progress_t), intent(inout) :: self
      real(wp), intent(in) :: t0, t_end
      character(len=64) :: text
      integer :: n, status, ios
      real(wp) :: v
      self%on = .true.
      self%t0 = t0; self%t_end = t_end
      self%tty = stderr_is_terminal()
      call get_environment_variable('TRAINSIM_PROGRESS_INTERVAL', text, n, status)
      if (status == 0 .and. n > 0) then
         read (text, *, iostat=ios) v
         if (ios == 0 .and. v > 0.0_wp .and. v < huge(1.0_wp)) then
            self%interval = v
            self%quiet_for = min(self%quiet_for, v)
         end if
      end if
      call system_clock(self%c0, self%rate)
      self%c_last = self%c0
      self%c_next = self%c0 + int(self%quiet_for*real(self%rate, wp), i8)
      self%calls = 0; self%stride = 1; self%shown = 0; self%lines = 0
   end subroutine pr_start

   !> The run has reached t with `events` events: report if it is time to.
   subroutine pr_poll(self, t, events)
      class(progress_t), intent(inout) :: self
      real(wp), intent(in) :: t
      integer, intent(in) :: events
      integer(i8) :: c
      real(wp) :: since
      self%calls = self%calls + 1
      if (self%calls < self%stride) return
      self%calls = 0
      call system_clock(c)
      since = real(c - self%c_last, wp)/real(self%rate, wp)
      self%c_last = c
      ! the clock about every 20-100 ms, whatever an output time costs
      if (since < 0.02_wp .and. self%stride < 2**20) then
         self%stride = 2*self%stride
      else if (since > 0.1_wp .and. self%stride > 1) then
         self%stride = self%stride/2
      end if
      if (c < self%c_next) return
      call report(self, t, events, c)
      if (self%tty) then
         self%c_next = c + int(0.5_wp*real(self%rate, wp), i8)
      else
         self%c_next = c + int(self%interval*real(self%rate, wp), i8)
      end if
   end subroutine pr_poll

   !> One report at wall clock c.
   subroutine report(self, t, events, c)
      type(progress_t), intent(inout) :: self
      real(wp), intent(in) :: t
      integer, intent(in) :: events
      integer(i8), intent(in) :: c
      character(len=:), allocatable :: line
      real(wp) :: wall, frac
      character(len=16) :: pct
      wall = real(c - self%c0, wp)/real(self%rate, wp)
      frac = 0.0_wp
      if (self%t_end > self%t0) frac = max(0.0_wp, min(1.0_wp, (t - self%t0)/(self%t_end - self%t0)))
      write (pct, '(f0.1)') 100.0_wp*frac
      if (pct(1:1) == '.') pct = '0'//trim(pct)
      line = 'trainsim: t = '//num(t)//' of '//num(self%t_end)//' s ('//trim(pct)//' %), '// &
             str(events)//' events, '//clock_text(wall)//' elapsed'
      if (frac > 0.0_wp) line = line//', about '//clock_text(wall*(1.0_wp - frac)/frac)//' left'
      if (self%tty) then
         write (error_unit, '(a)', advance='no') achar(13)//line//repeat(' ', max(0, self%shown - len(line)))
         self%shown = len(line)
      else
         write (error_unit, '(a)') line
      end if
      flush (error_unit)
      self%lines = self%lines + 1
   end subroutine report

   !> The run ended (or stopped): clear the terminal line.
   subroutine pr_finish(self)
      class(progress_t), intent(inout) :: self
      if (self%tty .and. self%shown > 0) then
         write (error_unit, '(a)', advance='no') achar(13)//repeat(' ', self%shown)//achar(13)
         flush (error_unit)
      end if
      self%shown = 0
      self%on = .false.
   end subroutine pr_finish

   !> A time for the line: 12.3050, 0.0200 (4 decimals below 1e5 s), else 1.234E+07.
   function num(x) result(text)
      real(wp), intent(in) :: x
      character(len=:), allocatable :: text
      character(len=32) :: buf
      if (abs(x) < 1.0e5_wp) then
         write (buf, '(f0.4)') x
         text = trim(adjustl(buf))
         if (text(1:1) == '.') text = '0'//text
         if (text(1:min(2, len(text))) == '-.') text = '-0'//text(2:)
      else
         write (buf, '(es10.3)') x
         text = trim(adjustl(buf))
      end if
   end function num

   !> "4.2 s", "3 min 05 s", "2 h 07 min".
   function clock_text(s) result(text)
      real(wp), intent(in) :: s
      character(len=:), allocatable :: text
      character(len=32) :: buf
      integer(i8) :: n
      n = int(min(max(s, 0.0_wp), 9.0e15_wp), i8)
      if (n < 60) then
         write (buf, '(f0.1,a)') max(s, 0.0_wp), ' s'
         if (buf(1:1) == '.') buf = '0'//trim(buf)
      else if (n < 3600) then
         write (buf, '(i0,a,i2.2,a)') n/60, ' min ', mod(n, 60_i8), ' s'
      else
         write (buf, '(i0,a,i2.2,a)') n/3600, ' h ', mod(n/60, 60_i8), ' min'
      end if
      text = trim(buf)
   end function clock_text
end module trainsim_progress
