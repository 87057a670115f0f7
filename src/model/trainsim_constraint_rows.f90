!> What an element declares about kinematic constraints, and what the model
!> hands back (D-81, docs/plugins.md "Constraints"): a component `con` of every
!> element. An element that may join its ports rigidly in some mode (a stuck
!> clutch, a held brake, a rigid gear) sets `on` in `configure` and keeps `n`
!> and the rows g(1:n, 1:n_ports) current with its mode (sum_p g(k, p) w_p = 0,
!> and the same on accelerations). The model sets `t_now` (the time of the
!> evaluation) before the element's `torques` and `guards`, and after every RHS
!> leaves the torque of row k in lam(k): port p gets g(k, p) lam(k). An element
!> whose guards in its current mode read its ports' accelerations sets
!> `want_acc`; the model then evaluates a RHS before its guards and leaves each
!> port's acceleration at (t, y) in acc(p) (a side that stops or starts, D-91).
!> A lossy row (the rigid lossy gear, D-97) scales the torque on its ports:
!> port p gets c(k, p) g(k, p) lam(k) (c = 1: an ideal row, the default).
module trainsim_constraint_rows
   use trainsim_kinds, only: wp
   implicit none
   private

   public :: constraint_rows_t, max_constraints, max_con_ports

   !> Most rows one element declares at once; most ports a row spans (max_ports).
   integer, parameter :: max_constraints = 2, max_con_ports = 4

   !> An element's constraints (see above).
   type :: constraint_rows_t
      logical :: on = .false.                                  !< the element may constrain (any mode)
      logical :: rigid = .false.                               !< its rows hold in every mode (rigid gear, join)
      integer :: n = 0                                         !< rows active in the current mode
      real(wp) :: g(max_constraints, max_con_ports) = 0.0_wp   !< g(k, p): row k over the ports
      real(wp) :: t_now = 0.0_wp                               !< time of the model's evaluation
      real(wp) :: lam(max_constraints) = 0.0_wp                !< row k's constraint torque
      real(wp) :: c(max_constraints, max_con_ports) = 1.0_wp   !< c(k, p): torque scale of a lossy row (D-97)
      logical :: want_acc = .false.                            !< the guards read acc (this mode)
      real(wp) :: acc(max_con_ports) = 0.0_wp                  !< port p's acceleration (want_acc)
   end type constraint_rows_t
end module trainsim_constraint_rows
