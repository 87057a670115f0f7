!> Continuation sweeps (`&sweep ... continuation = 'up'|'down'|'both'`): each run of a
!> branch starts from the end state of the run before it, as a rig whose speed is
!> raised or lowered step by step (the thesis's §5.2.5 experiment), so that a jump
!> hysteresis can show; a fixed-start run cannot show one.
!>
!> The next run keeps the angles and re-scales the speeds to its operating point: node
!> i starts at w_end,i * w0_new,i / w0_old,i, where w0_new is the speed `mesh_frequency`
!> sets for the new run and w0_old the speed the run before it started from (itself
!> re-scaled, if that run continued one: the sweep file keeps it as
!> /nodes/start_speed, so a killed branch resumes with the same bits), so the vibration
!> rides on the new speed in the same proportion; where w0_old,i = 0 the offset
!> w_end,i - w0_old,i is kept instead.
!> A held node continues its angle (its prescribed speed is the new run's); a fixed
!> node stays. Motor currents and the contact law's memory are those of a fresh start
!> (a contact closed at the start has D = 0 unless initial_contact_velocity, D-13).
module trainsim_continuation
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   implicit none
   private

   public :: chain_state_t, save_end_state, start_from

   !> The end state of a run, kept by the rank that made it.
   type :: chain_state_t
      integer :: irun = 0                       !< the run it ends (0: none)
      real(wp), allocatable :: theta(:), omega(:), omega0(:)   !< per node
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

   !> Start `model` (prepared for the next run) from the end state `st`.
   subroutine start_from(model, st)
      type(model_t), intent(inout) :: model
      type(chain_state_t), intent(in) :: st
      integer :: i, s
      real(wp) :: w0
      do i = 1, size(model%nodes)
         associate (nd => model%nodes(i)%n)
            if (nd%is_fixed()) cycle
            s = model%speed_of(i)
            if (s /= 0) then
               nd%theta0 = st%theta(i) - model%speeds(s)%integral(model%run%t_start)
               cycle
            end if
            nd%theta0 = st%theta(i)
            w0 = nd%omega0
            if (st%omega0(i) /= 0.0_wp) then
               nd%omega0 = st%omega(i)*(w0/st%omega0(i))
            else
               nd%omega0 = w0 + (st%omega(i) - st%omega0(i))
            end if
         end associate
      end do
   end subroutine start_from
end module trainsim_continuation
