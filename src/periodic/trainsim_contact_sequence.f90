!> What a flow pass over an orbit met (trainsim_monodromy's passes): its event
!> counts and its contact sequence, each guard that fired in order, coded with the
!> face its element was on before the event (issue 27; D-115, D-121). Two orbits
!> with the same sequence up to a rotation (t0 moved along the branch, D-99) are on
!> the same smooth piece of the period map; a change is a grazing, a corner (two
!> events swapping order) or a contact that came or went.
module trainsim_contact_sequence
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: monodromy_stats_t, record_event, same_sequence, max_sequence

   !> the events kept in order; beyond it only the counts and a running code
   integer, parameter :: max_sequence = 256

   !> What one pass over the window did.
   type :: monodromy_stats_t
      integer :: steps = 0          !< RK4 steps (including the parts of a step split at an event)
      integer :: events = 0         !< events located (guards that fired)
      integer :: jumps = 0          !< events where f jumps (|f+ - f-| > 1e-10 |f-|)
      integer :: impacts = 0        !< contact onsets whose damping sensitivity was set
      !> steps whose variational part was their mode's tangent map (Phi <- S Phi),
      !> and the tangent maps built (one per mode stretch whose Jacobian is constant, D-162)
      integer :: tangent_steps = 0, tangent_maps = 0
      !> steps whose stage Jacobians were the mode's constant part plus the varying elements' parts (D-170)
      integer :: split_steps = 0
      !> smallest rate at which a guard crossed, |n^T f- + dg/dt| / |n| (the
      !> guard's units per second: a length or an angle), and that guard: a
      !> near-grazing contact shows here (the saltation grows as 1 / rate)
      real(wp) :: min_rate = huge(1.0_wp)
      integer :: min_rate_guard = 0
      !> the fired guards in order, 3 j + face + 1 (face -1, 0, +1 of the guard's
      !> element before the event), the first max_sequence of them
      integer :: seq(max_sequence) = 0
   end type monodromy_stats_t

contains

   !> Append guard j, fired while its element was on `face`, to st's sequence.
   pure subroutine record_event(st, j, face)
      type(monodromy_stats_t), intent(inout) :: st
      integer, intent(in) :: j, face
      st%events = st%events + 1
      if (st%events <= max_sequence) st%seq(st%events) = 3*j + face + 1
   end subroutine record_event

   !> Whether two passes met the same contact sequence: as many events, jumps and
   !> impacts, and the same guards in the same cyclic order (any rotation: where
   !> the orbit starts is t0's choice, not the orbit's).
   pure logical function same_sequence(a, b) result(same)
      type(monodromy_stats_t), intent(in) :: a, b
      integer :: n, r
      same = a%events == b%events .and. a%jumps == b%jumps .and. a%impacts == b%impacts
      if (.not. same) return
      n = min(a%events, max_sequence)
      if (n == 0) return
      if (a%events > max_sequence) then      ! (too long to rotate: compared as stored)
         same = all(a%seq == b%seq)
         return
      end if
      do r = 0, n - 1
         if (all(a%seq(1:n) == cshift(b%seq(1:n), r))) return
      end do
      same = .false.
   end function same_sequence
end module trainsim_contact_sequence
