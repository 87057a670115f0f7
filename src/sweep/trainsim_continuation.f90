!> Continuation sweeps (`&sweep ... continuation = 'up'|'down'|'both'`): each run of a
!> branch starts from the end state of the run before it, as a rig whose speed is
!> raised or lowered step by step (the thesis's §5.2.5 experiment), so that a jump
!> hysteresis can show; a fixed-start run cannot show one.
!>
!> The next run keeps the angles and moves the speeds from the previous run's nominal
!> operating point to its own (D-43): node i starts at
!>     w_end,i + (W_new,i - W_old,i),
!> where W is a run's nominal speed of the node (its initial speed as the deck and the
!> run's `mesh_frequency` set it, or its prescribed speed at t_start), W_old that of the
!> run before (computed again from the deck and that run's values, so a resumed branch
!> needs only the end state the sweep file keeps). The nominal speeds turn the train
!> rigidly (W_l = kappa W_r across every element), so the shift changes no speed across
!> any element: the deformations and their rates, the vibration, are carried over
!> unchanged and only the rigid rotation moves to the new operating point. A nominal
!> speed of 0, or the same nominal in every run, carries the end speeds as they are.
!> A held node continues its angle (its prescribed speed is the new run's); a fixed
!> node stays. Motor currents and the contact law's memory are those of a fresh start
!> (a contact closed at the start has D = 0 unless initial_contact_velocity, D-13).
module trainsim_continuation
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   implicit none
   private

   public :: chain_state_t, save_end_state, start_from, nominal_speeds

   !> The end state of a run, kept by the rank that made it.
   type :: chain_state_t
      integer :: irun = 0                       !< the run it ends (0: none)
      real(wp), allocatable :: theta(:), omega(:), omega0(:)   !< per node (omega0: the run's start speeds)
   end type chain_state_t

contains

   !> The end state of run irun: node angles and speeds at t_final (y_final), and the
   !> run's own initial speeds.
   subroutine save_end_state(model, t_final, y_final, irun, st)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t_final, y_final(:)
      integer, intent(in) :: irun
      type(chain_state_t), intent(out) :: st
      integer :: i
      call model%kinematics(t_final, y_final)
      st%irun = irun
      st%theta = model%theta
      st%omega = model%omega
      st%omega0 = [(model%nodes(i)%n%omega0, i=1, size(model%nodes))]
   end subroutine save_end_state

   !> The nominal speed of every node of a prepared model (before any start_from): a
   !> held node's prescribed speed at t_start, a fixed node's 0, else its initial speed.
   function nominal_speeds(model) result(w)
      type(model_t), intent(in) :: model
      real(wp) :: w(size(model%nodes))
      integer :: i, s
      do i = 1, size(model%nodes)
         s = model%speed_of(i)
         if (model%nodes(i)%n%is_fixed()) then
            w(i) = 0.0_wp
         else if (s /= 0) then
            w(i) = model%speeds(s)%value(model%run%t_start)
         else
            w(i) = model%nodes(i)%n%omega0
         end if
      end do
   end function nominal_speeds

   !> Start `model` (prepared for the next run) from the end state `st` of the run
   !> before it, whose nominal speeds were `w_old` (nominal_speeds of its model).
   subroutine start_from(model, st, w_old)
      type(model_t), intent(inout) :: model
      type(chain_state_t), intent(in) :: st
      real(wp), intent(in) :: w_old(:)
      real(wp) :: w_new(size(model%nodes))
      integer :: i, s
      w_new = nominal_speeds(model)
      do i = 1, size(model%nodes)
         associate (nd => model%nodes(i)%n)
            if (nd%is_fixed()) cycle
            s = model%speed_of(i)
            if (s /= 0) then
               nd%theta0 = st%theta(i) - model%speeds(s)%integral(model%run%t_start)
               cycle
            end if
            nd%theta0 = st%theta(i)
            nd%omega0 = st%omega(i) + (w_new(i) - w_old(i))
         end associate
      end do
   end subroutine start_from
end module trainsim_continuation
