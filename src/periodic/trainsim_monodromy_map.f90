!> The monodromy matrix of a period map (trainsim_period_map) from the
!> variational equations with saltation matrices (trainsim_monodromy, D-102),
!> and the choice between it and central differences (issue 27; D-115).
!>
!> At t0 the reduced state is the state (D-99) and the reduced angles differ from
!> the absolute ones by W (t - t0), which does not depend on x(t0): dP/dx is the
!> flow's derivative itself. With `deck_grid` the variational pass steps on the
!> session's grid (t0 + i dt, the last step shortened) and with `exact_step` it
!> differentiates that discrete flow: Newton on P(x) - x then converges
!> quadratically, and the matrix equals the differences to their own error.
!> It needs the deck's integrator to be 'rk4' (the map's own steps) and no
!> friction stick-slip (a state space that changes); elsewhere the differences.
module trainsim_monodromy_map
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_model, only: model_t
   use trainsim_period_map, only: period_map_t
   use trainsim_monodromy, only: monodromy_saltation, flow_events, monodromy_stats_t
   implicit none
   private

   public :: monodromy_variational, monodromy_map_stats, flow_signature, saltation_supported
   public :: mono_auto, mono_saltation, mono_fd, monodromy_choice, monodromy_name, monodromy_code

   !> how the monodromy is taken: saltation where supported, else differences (auto);
   !> saltation (refused where unsupported); central differences
   integer, parameter :: mono_auto = 0, mono_saltation = 1, mono_fd = 2

contains

   !> procedure(monodromy_i) of trainsim_shooting: m = dP/dx at x by the variational
   !> equations with saltation matrices on the map's own steps.
   subroutine monodromy_variational(pm, x, px, m, err)
      class(period_map_t), intent(inout) :: pm
      real(wp), intent(in) :: x(:), px(:)
      real(wp), intent(out) :: m(:, :)
      type(error_t), allocatable, intent(out) :: err
      type(monodromy_stats_t) :: st
      associate (unused => px)
      end associate
      call monodromy_map_stats(pm, x, m, st, err)
   end subroutine monodromy_variational

   !> m = dP/dx at x and what the pass met (events, jumps, impacts, the slowest
   !> guard crossing): the contact sequence's signature for continuation.
   subroutine monodromy_map_stats(pm, x, m, st, err)
      class(period_map_t), intent(inout) :: pm
      real(wp), intent(in) :: x(:)
      real(wp), intent(out) :: m(:, :)
      type(monodromy_stats_t), intent(out) :: st
      type(error_t), allocatable, intent(out) :: err
      type(model_t) :: mm
      real(wp) :: y(size(x))
      real(wp), allocatable :: mv(:, :)
      mm = pm%model                     ! its t_start is t0 (moved by `rephase`)
      y = x                             ! at t0 the reduced state is the state (D-99)
      call pm%hold_memory(mm)           ! (a contact closed at t0 keeps the map's memory, D-150)
      call mm%init_modes(pm%t0, pm%full_state(x))
      call monodromy_saltation(mm, pm%t0, real(pm%k, wp)*pm%period, y, mv, err, exact_step=.true., &
                               deck_grid=.true., stats=st)
      if (.not. allocated(err)) m = mv  ! d(x_a - W kT)/dx = dy/dx: the same matrix
   end subroutine monodromy_map_stats

   !> The flow's event statistics over the k periods from x (no matrix): the
   !> signature of the contact sequence where the monodromy is by differences.
   subroutine flow_signature(pm, x, st, err)
      class(period_map_t), intent(inout) :: pm
      real(wp), intent(in) :: x(:)
      type(monodromy_stats_t), intent(out) :: st
      type(error_t), allocatable, intent(out) :: err
      type(model_t) :: mm
      real(wp) :: y(size(x))
      mm = pm%model
      y = x
      call pm%hold_memory(mm)
      call mm%init_modes(pm%t0, pm%full_state(x))
      call flow_events(mm, pm%t0, real(pm%k, wp)*pm%period, y, err, deck_grid=.true., stats=st)
   end subroutine flow_signature

   !> Whether the saltation monodromy is the derivative of the map: the deck's
   !> integrator is 'rk4' and no element constrains its nodes when it sticks.
   !> why: the reason when not.
   logical function saltation_supported(model, why) result(ok)
      type(model_t), intent(in) :: model
      character(len=:), allocatable, intent(out) :: why
      why = ''
      if (allocated(model%cn)) then
         if (size(model%cn%cand) > 0) why = "element '"//model%elements(model%cn%cand(1))%e%id// &
                                            "' constrains its nodes when it sticks (stick-slip)"
      end if
      if (len(why) == 0 .and. model%run%integrator /= 'rk4') &
         why = "the deck's integrator is '"//model%run%integrator//"' (the variational pass steps as 'rk4')"
      ok = len(why) == 0
   end function saltation_supported

   !> Resolve `choice` (mono_auto / mono_saltation / mono_fd) for `model`:
   !> use_saltation. err: saltation asked where it is not supported.
   subroutine monodromy_choice(choice, model, use_saltation, err)
      integer, intent(in) :: choice
      type(model_t), intent(in) :: model
      logical, intent(out) :: use_saltation
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: why
      use_saltation = .false.
      if (choice == mono_fd) return
      use_saltation = saltation_supported(model, why)
      if (choice == mono_saltation .and. .not. use_saltation) &
         call fatal_error(err, 'the saltation monodromy is not available: '//why//' (use --monodromy fd)', err_input)
   end subroutine monodromy_choice

   !> The code of a --monodromy value: auto, saltation, fd; -1 for another.
   integer function monodromy_code(text) result(mono)
      character(len=*), intent(in) :: text
      select case (text)
      case ('auto')
         mono = mono_auto
      case ('saltation')
         mono = mono_saltation
      case ('fd')
         mono = mono_fd
      case default
         mono = -1
      end select
   end function monodromy_code

   !> 'saltation matrices' or 'central differences'
   function monodromy_name(use_saltation) result(s)
      logical, intent(in) :: use_saltation
      character(len=:), allocatable :: s
      s = trim(merge('saltation matrices ', 'central differences', use_saltation))
   end function monodromy_name
end module trainsim_monodromy_map
