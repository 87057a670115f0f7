!> The model's side of the elements' kinematic constraints (D-81): which nodes
!> the active rows touch and what the solve of trainsim_constraints needs of
!> them (inertias; held and fixed nodes take no acceleration), the call sites
!> in the RHS and the guards, and the stick events (speeds made consistent,
!> limits checked until the modes agree). Each `module procedure` here is
!> declared, with its arguments, in trainsim_model; their docs are here:
!>   constraints_setup: size the buffers for the model's candidate elements
!>     (`constrains`), at every `build_fast_path`;
!>   constraints_rhs: in the RHS before the elements' torques (t_now), their
!>     t_now; after the elements' torques, the constraint
!>     torques (added to self%torque and el_torque, handed to the elements as
!>     lam; a lossy row's dissipation into cn%loss, D-97); with dydt, after
!>     the nodes' derivatives, the exact accelerations of the clustered nodes
!>     into dydt;
!>   constraints_settle: at an event (and at the run start), with `project`
!>     the speeds of the current stuck clusters made exact (before the modes
!>     change); else the rows rebuilt from the new modes, speeds made
!>     consistent (the stick), lam solved and every stuck element whose guard
!>     is then below zero updated (it slips), until none is; the events that
!>     makes are appended. dstored: the kinetic energy that changed (<= 0,
!>     dissipated at the stick).
submodule (trainsim_model) trainsim_model_constraints
   use trainsim_constraints, only: cn_setup, cn_gather, cn_factor, cn_solve, cn_project
   use trainsim_model_families, only: nk_plain, nk_held
   use trainsim_event, only: max_update_events
   implicit none

   !> Most passes of `constraints_settle` (each lets at least one element slip).
   integer, parameter :: max_settle = 16

contains

   module procedure constraints_setup
      if (.not. allocated(self%cn)) allocate (self%cn)
      call cn_setup(self%cn, self%elements, size(self%nodes), self%n_y)
      self%n_cand = size(self%cn%cand)
   end procedure constraints_setup

   !> The active rows from the elements' modes; when they changed (or `force`),
   !> the clusters and the factor anew and the node speeds in y made to satisfy
   !> them. dstored: the change of the kinetic energy that made.
   subroutine rebuild(self, t, y, force, dstored)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t
      real(wp), intent(inout) :: y(:)
      logical, intent(in) :: force
      real(wp), intent(out) :: dstored
      logical :: changed
      integer :: s, nd, o
      real(wp) :: e0, e1
      dstored = 0.0_wp
      if (size(self%cn%cand) == 0) return
      call cn_gather(self%cn, self%elements, changed)
      if (.not. (changed .or. force)) return
      do s = 1, self%cn%nc
         nd = self%cn%node(s)
         self%cn%jn(s) = self%nodes(nd)%n%inertia()
         self%cn%inv_j(s) = 0.0_wp
         if (self%fn(nd)%kind /= nk_held .and. self%nodes(nd)%n%nstates() > 0) then
            self%cn%inv_j(s) = 1.0_wp/self%cn%jn(s)
         end if
      end do
      call cn_factor(self%cn)
      if (self%cn%m == 0) return
      ! the speeds made to satisfy the constraints (the stick event): kinetic energy before and after
      e0 = 0.0_wp
      e1 = 0.0_wp
      do s = 1, self%cn%nc
         nd = self%cn%node(s)
         call node_kinematics(self, nd, t, y, self%theta(nd), self%cn%w(s))
         if (self%cn%inv_j(s) /= 0.0_wp) e0 = e0 + 0.5_wp*self%cn%jn(s)*self%cn%w(s)**2
      end do
      call cn_project(self%cn)
      do s = 1, self%cn%nc
         if (self%cn%inv_j(s) == 0.0_wp) cycle
         nd = self%cn%node(s)
         o = self%nodes(nd)%n%offset
         y(o + 2) = self%cn%w(s)
         e1 = e1 + 0.5_wp*self%cn%jn(s)*self%cn%w(s)**2
      end do
      dstored = e1 - e0
   end subroutine rebuild

   module procedure constraints_rhs
      integer :: s, nd, r, p, i, k, o
      real(wp) :: tc
      if (present(t_now)) then                             ! before the elements' torques
         do k = 1, size(self%cn%cand)
            self%elements(self%cn%cand(k))%e%con%t_now = t
         end do
         return
      end if
      if (present(dydt)) then                              ! the exact accelerations
         if (self%cn%m > 0) then
            do s = 1, self%cn%nc
               if (self%cn%inv_j(s) == 0.0_wp) cycle
               dydt(self%nodes(self%cn%node(s))%n%offset + 2) = self%cn%acc(s)
            end do
         end if
         if (self%cn%acc_wanted) call port_accelerations(self, t, dydt)
         return
      end if
      if (self%cn%m == 0) return
      do s = 1, self%cn%nc
         nd = self%cn%node(s)
         associate (f => self%fn(nd))
            if (self%cn%inv_j(s) == 0.0_wp) then
               self%cn%afree(s) = 0.0_wp                     ! fixed, or held at a constant speed
               if (f%kind == nk_held .and. .not. f%const_speed) then
                  self%cn%afree(s) = self%speeds(self%speed_of(nd))%derivative(t)
               end if
            else if (f%kind == nk_plain) then
               self%cn%afree(s) = (self%torque(nd) - f%d*self%omega(nd))/f%j
            else                                             ! a node with states of its own (a motor)
               o = self%nodes(nd)%n%offset
               call self%nodes(nd)%n%derivatives(t, y, self%torque(nd), self%cn%node_dydt)
               self%cn%afree(s) = self%cn%node_dydt(o + 2)
            end if
         end associate
      end do
      call cn_solve(self%cn)
      self%cn%loss = 0.0_wp
      do r = 1, self%cn%m
         i = self%cn%row_el(r)
         k = self%cn%row_k(r)
         self%elements(i)%e%con%lam(k) = self%cn%lam(r)
         do p = 1, self%cn%row_np(r)
            tc = self%cn%row_g(p, r)*self%cn%lam(r)
            nd = self%cn%node(self%cn%row_slot(p, r))
            if (self%cn%lossy) then                          ! a lossy row's scale and work (D-97)
               self%cn%loss = self%cn%loss - (self%cn%row_c(p, r) - 1.0_wp)*tc*self%omega(nd)
               tc = self%cn%row_c(p, r)*tc
            end if
            self%torque(nd) = self%torque(nd) + tc
            if (p <= 2) self%el_torque(p, i) = self%el_torque(p, i) + tc
         end do
      end do
   end procedure constraints_rhs

   !> Into con%acc of every candidate that asks (`want_acc`): its ports'
   !> accelerations in dydt (a held node's prescribed one, a fixed node's 0).
   subroutine port_accelerations(self, t, dydt)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, dydt(:)
      integer :: k, p, nd
      real(wp) :: a
      do k = 1, size(self%cn%cand)
         associate (e => self%elements(self%cn%cand(k))%e)
            if (.not. e%con%want_acc) cycle
            do p = 1, min(e%n_ports(), size(e%con%acc))
               nd = e%port(p)
               a = 0.0_wp
               if (self%fn(nd)%kind == nk_held) then
                  if (.not. self%fn(nd)%const_speed) a = self%speeds(self%speed_of(nd))%derivative(t)
               else if (self%nodes(nd)%n%nstates() > 0) then
                  a = dydt(self%nodes(nd)%n%offset + 2)
               end if
               e%con%acc(p) = a
            end do
         end associate
      end do
   end subroutine port_accelerations

   !> A full RHS at (t, y), so that the elements' lam and t_now are those of (t, y).
   subroutine constraints_at(self, t, y)
      type(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), allocatable :: dydt(:)
      call move_alloc(self%cn%scratch, dydt)              ! (no allocation: the buffer lent)
      call self%rhs(t, y, dydt)
      call move_alloc(dydt, self%cn%scratch)
   end subroutine constraints_at

   module procedure constraints_settle
      type(event_t) :: local(max_update_events)
      type(event_t), allocatable :: grown(:)
      real(wp) :: ds
      integer :: pass, q, i, n, l, r, m, k
      logical :: any_slip
      dstored = 0.0_wp
      if (size(self%cn%cand) == 0) return
      if (project) then
         call rebuild(self, t, y, .true., dstored)
         return
      end if
      do pass = 1, max_settle
         call rebuild(self, t, y, .false., ds)
         dstored = dstored + ds
         if (self%cn%m == 0) return
         call constraints_at(self, t, y)
         any_slip = .false.
         do q = 1, size(self%cn%cand)
            i = self%cn%cand(q)
            n = self%fe(i)%ng
            if (n == 0 .or. self%elements(i)%e%con%n == 0) cycle
            l = self%fe(i)%l
            r = self%fe(i)%r
            associate (e => self%elements(i)%e, g => self%g_el(1:n), fired => self%fired_el(1:n))   ! (sized by finalize)
               call e%guards(self%theta(l), self%omega(l), self%theta(r), self%omega(r), g)
               fired = g < 0.0_wp
               if (.not. any(fired)) cycle
               call e%update_mode(t, self%theta(l), self%omega(l), self%theta(r), self%omega(r), fired, local, m)
            end associate
            call refresh_hot(self, i)
            any_slip = .true.
            if (nev + m > size(events)) then
               allocate (grown(max(2*size(events), nev + m, 16)))
               grown(1:nev) = events(1:nev)
               call move_alloc(grown, events)
            end if
            do k = 1, m
               nev = nev + 1
               events(nev) = local(k)
               events(nev)%t = t
               events(nev)%element = i
            end do
         end do
         if (.not. any_slip) return
      end do
   end procedure constraints_settle
end submodule trainsim_model_constraints
