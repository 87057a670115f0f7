!> Helpers for the test suites: build a model from a deck file or text and run
!> it in memory. A setup failure is a test-harness failure (error stop).
module trainsim_test_support
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, err_input
   use trainsim_deck, only: deck_t, read_deck, parse_deck
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_simulate, only: simulate
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_testing, only: check
   use trainsim_overrides, only: override_t, parse_set_argument
   use trainsim_prepare, only: prepare_model
   implicit none
   private

   public :: load_model, load_model_text, run_model, nl, zero_crossings, jacobian_fd_error
   public :: real_text, expect_build_error, loglog_slope, damped_rig_model, model_with_sets

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

   !> x written with every digit it has (a deck value that reads back to the same bits).
   function real_text(x) result(s)
      real(wp), intent(in) :: x
      character(len=:), allocatable :: s
      character(len=32) :: buf
      write (buf, '(es24.16e3)') x
      s = trim(adjustl(buf))
   end function real_text

   !> Checks that building the deck `text` (file name 'inline.nml') fails as bad input
   !> (exit 2) with a message that names `key`, and the file and the group when `where`.
   subroutine expect_build_error(text, key, where)
      character(len=*), intent(in) :: text, key
      logical, intent(in) :: where
      type(deck_t) :: deck
      type(model_t) :: m
      type(error_t), allocatable :: err
      logical :: named
      call parse_deck(text, 'inline.nml', deck, err)
      if (.not. allocated(err)) call build_model(deck, m, err)
      call check('rejected: '//text(index(text, '&element'):), allocated(err))
      if (.not. allocated(err)) return
      call check('  as bad input (exit 2)', err%code == err_input)
      if (where) then
         named = index(err%message, key) > 0 .and. index(err%message, 'inline.nml:') > 0 .and. &
                 index(err%message, '&element') > 0
         call check('  naming '//key//', file, group: '//err%message, named)
      else
         call check('  naming '//key//': '//err%message, index(err%message, key) > 0 .and. index(err%message, 'error') > 0)
      end if
   end subroutine expect_build_error

   !> The least-squares slope of log y against log x (an observed order of convergence
   !> over several steps rather than one ratio).
   pure real(wp) function loglog_slope(x, y) result(p)
      real(wp), intent(in) :: x(:), y(:)
      real(wp) :: lx(size(x)), ly(size(y))
      lx = log(x); ly = log(y)
      p = sum((lx - sum(lx)/size(lx))*(ly - sum(ly)/size(ly)))/sum((lx - sum(lx)/size(lx))**2)
   end function loglog_slope
   !> The Fig. 5.11 rig of `deck` (the sweep deck's run) with shafts 1 and 3 damped by
   !> 500 lb in s/rad, at lam teeth/s: the continuation tests' damped rig.
   subroutine damped_rig_model(deck, lam, model, err)
      type(deck_t), intent(in) :: deck
      real(wp), intent(in) :: lam
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      call model_with_sets(deck, [character(len=18) :: 'shaft1.damping=500', 'shaft3.damping=500'], &
                           'mesh.mesh_frequency', lam, model, err)
   end subroutine damped_rig_model

   !> The model of `deck` with the --set overrides `sets` and `key` set to lam (written
   !> to 17 digits, as the command line's --param does): a branch problem's model_at.
   subroutine model_with_sets(deck, sets, key, lam, model, err)
      type(deck_t), intent(in) :: deck
      character(len=*), intent(in) :: sets(:), key
      real(wp), intent(in) :: lam
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      type(override_t) :: ov(size(sets) + 1)
      character(len=32) :: buf
      integer :: i
      write (buf, '(es25.17)') lam
      do i = 1, size(sets)
         call parse_set_argument(trim(sets(i)), ov(i), err)
         if (allocated(err)) return
      end do
      call parse_set_argument(key//'='//trim(adjustl(buf)), ov(size(ov)), err)
      if (.not. allocated(err)) call prepare_model(deck, ov, model, err)
   end subroutine model_with_sets

end module trainsim_test_support
