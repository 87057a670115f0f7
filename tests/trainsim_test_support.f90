!> Helpers for the test suites: build a model from a deck file or text and run
!> it in memory. A setup failure is a test-harness failure (error stop).
module trainsim_test_support
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_deck, only: deck_t, read_deck, parse_deck
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_simulate, only: simulate
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   implicit none
   private

   public :: load_model, load_model_text, run_model, nl, zero_crossings, jacobian_fd_error

   character(len=1), parameter :: nl = new_line('a')

contains

   !> Model from a deck file (paths relative to the repository root).
   subroutine load_model(path, model)
      character(len=*), intent(in) :: path
      type(model_t), intent(out) :: model
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      call read_deck(path, deck, err)
      if (.not. allocated(err)) call build_model(deck, model, err)
      if (allocated(err)) then
         write (*, '(a)') 'test setup failed: '//err%message
         error stop 2
      end if
      model%run%output = ''
   end subroutine load_model

   !> Model from deck text.
   subroutine load_model_text(text, model)
      character(len=*), intent(in) :: text
      type(model_t), intent(out) :: model
      type(deck_t) :: deck
      type(error_t), allocatable :: err
      call parse_deck(text, 'inline.nml', deck, err)
      if (.not. allocated(err)) call build_model(deck, model, err)
      if (allocated(err)) then
         write (*, '(a)') 'test setup failed: '//err%message
         error stop 2
      end if
      model%run%output = ''
   end subroutine load_model_text

   !> Run without output; keep the in-memory series and event table.
   subroutine run_model(model, res)
      type(model_t), intent(inout) :: model
      type(run_result_t), intent(out) :: res
      type(null_sink_t) :: none
      type(error_t), allocatable :: err
      model%run%keep_series = .true.
      model%run%keep_events = .true.
      call simulate(model, none, res, err)
      if (allocated(err)) then
         write (*, '(a)') 'run failed: '//err%message
         error stop 2
      end if
   end subroutine run_model
   !> The model's analytic Jacobian at its initial state and time t against central
   !> differences of its right-hand side (steps 1e-6 of each state, at least 1e-9):
   !> max |J_analytic - J_fd| / max |J_fd| (err), and max |J_fd| (scale, 0 if trivial).
   subroutine jacobian_fd_error(m, t, err, scale)
      type(model_t), intent(inout) :: m
      real(wp), intent(in) :: t
      real(wp), intent(out) :: err, scale
      real(wp), allocatable :: y(:), ja(:, :), jf(:, :), fp(:), fm(:), yp(:)
      real(wp) :: h
      integer :: n, j
      m%run%track_energy = .false.
      call m%finalize()
      call m%initial_state(y)
      call m%init_modes(t, y)
      n = size(y)
      allocate (ja(n, n), jf(n, n), fp(n), fm(n), yp(n))
      call m%jacobian(t, y, ja)
      do j = 1, n
         h = 1.0e-6_wp*max(1.0e-3_wp, abs(y(j)))
         yp = y; yp(j) = y(j) + h
         call m%rhs(t, yp, fp)
         yp(j) = y(j) - h
         call m%rhs(t, yp, fm)
         jf(:, j) = (fp - fm)/(2.0_wp*h)
      end do
      scale = maxval(abs(jf))
      err = maxval(abs(ja - jf))/max(scale, tiny(1.0_wp))
   end subroutine jacobian_fd_error

   !> Times of the zero crossings of x(t) (linear interpolation between samples).
   pure subroutine zero_crossings(t, x, tz, n)
      real(wp), intent(in) :: t(:), x(:)
      real(wp), intent(out) :: tz(:)
      integer, intent(out) :: n
      integer :: i
      n = 0
      do i = 1, size(x) - 1
         if ((x(i) > 0.0_wp .and. x(i + 1) <= 0.0_wp) .or. (x(i) < 0.0_wp .and. x(i + 1) >= 0.0_wp)) then
            if (n < size(tz)) then
               n = n + 1
               tz(n) = t(i) - x(i)*(t(i + 1) - t(i))/(x(i + 1) - x(i))
            end if
         end if
      end do
   end subroutine zero_crossings
end module trainsim_test_support
