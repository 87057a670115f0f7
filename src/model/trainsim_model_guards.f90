!> The model's guards (switching functions) and events: guard rows of the
!> clearance family on plain arrays, the general path, and the mode updates.
!> Each `module procedure` here is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_guards
   use trainsim_element, only: hg_none, max_ports
   use trainsim_event, only: max_update_events
   use trainsim_model_kernels, only: hot_guards
   use trainsim_ports, only: port_update_at
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf
   implicit none

contains

   module procedure model_guards
      logical :: below
      if (self%n_guards == 0) return
      ! only the elements with guards (a long train has few of them); when each
      ! has a guard row (the element's hot form on two plain inertias, D-39), on
      ! plain arrays; else the general loop
      if (self%n_norow == 0 .and. is_contiguous(y) .and. is_contiguous(g)) then
         below = self%guards_below(t, y, g)   ! (guard_rows; whether one is below zero unused)
      else
         call guards_general(self, t, y, g)
      end if
   end procedure model_guards

   module procedure model_guards_below
      integer :: j
      below = .false.
      if (self%n_guards == 0) return
      if (self%n_norow == 0) then
         below = guard_rows(size(self%guard_els), self%guard_els, self%gr, y, g)
         return
      end if
      call guards_general(self, t, y, g)
      do j = 1, self%n_guards
         if (g(j) < 0.0_wp) below = .true.
      end do
   contains

      !> The guards of the elements els(1:n), each with a guard row (rows(els(k))%form
      !> > 0), at the state y into g, and whether one of them is below zero (tested
      !> on the values as they are written: no second pass over g; NaN is not below
      !> zero, as in `g(j) < 0`): hot_guards written out, the angles straight from
      !> y (plain arrays: no descriptor, no stride).
      logical function guard_rows(n, els, rows, y, g) result(below)
         integer, intent(in) :: n, els(n)
         type(guard_row_t), intent(in) :: rows(*)
         real(wp), intent(in) :: y(*)
         real(wp), intent(inout) :: g(*)
         integer :: k, o
         real(wp) :: d, g1, g2, g3, g4
         below = .false.
         do k = 1, n
            associate (q => rows(els(k)))
               o = q%o
               d = q%r1*y(q%yl) - q%r2*y(q%yr)
               select case (q%mode)
               case (1)
                  g1 = d - q%b; g2 = 1.0_wp
               case (-1)
                  g1 = 1.0_wp; g2 = -d - q%b
               case default
                  g1 = q%b - d; g2 = d + q%b
               end select
               g(o + 1) = g1; g(o + 2) = g2
               if (g1 < 0.0_wp .or. g2 < 0.0_wp) below = .true.
               if (q%form == 2) then
                  if (q%lo_open) then
                     g3 = 1.0_wp
                  else
                     g3 = y(q%yl) - q%th_lo
                  end if
                  g4 = q%th_hi - y(q%yl)
                  g(o + 3) = g3; g(o + 4) = g4
                  if (g3 < 0.0_wp .or. g4 < 0.0_wp) below = .true.
               end if
            end associate
         end do
      end function guard_rows
   end procedure model_guards_below

   !> `guards_below`'s test as windows (D-145): guard row k (in guard_els' order)
   !> has a guard below zero exactly when d = w(1,k) y(iw(1,k)) - w(2,k) y(iw(2,k))
   !> is outside [w(3,k), w(4,k)] or y(iw(1,k)) is outside [w(5,k), w(6,k)]: the
   !> comparisons of guard_rows on the same d, rewritten (d - b < 0 exactly when
   !> d < b: the difference of two finite numbers is zero only when they are
   !> equal; a guard that is 1 or absent gets an infinite bound; NaN is inside).
   !> n rows; n = -1 when an element has guards but no row (ask `guards_below`).
   !> Valid until the modes change (`apply_events`, `init_modes`).
   module procedure model_guard_windows
      integer :: k
      real(wp) :: inf
      n = -1
      if (self%n_norow > 0) return
      n = size(self%guard_els)
      inf = ieee_value(1.0_wp, ieee_positive_inf)
      do k = 1, n
         associate (q => self%gr(self%guard_els(k)))
            iw(1, k) = q%yl; iw(2, k) = q%yr
            w(1, k) = q%r1; w(2, k) = q%r2
            select case (q%mode)
            case (1)      ! g1 = d - b, g2 = 1
               w(3, k) = q%b; w(4, k) = inf
            case (-1)     ! g1 = 1, g2 = -d - b
               w(3, k) = -inf; w(4, k) = -q%b
            case default  ! g1 = b - d, g2 = d + b
               w(3, k) = -q%b; w(4, k) = q%b
            end select
            w(5, k) = -inf; w(6, k) = inf
            if (q%form == 2) then   ! g3 = y(yl) - th_lo (1 if lo_open), g4 = th_hi - y(yl)
               if (.not. q%lo_open) w(5, k) = q%th_lo
               w(6, k) = q%th_hi
            end if
         end associate
      end do
   end procedure model_guard_windows

   !> `model_guards` element by element: a guard row by row_guard, any other
   !> element by guards_other (its nodes' kinematics, its hot form or `guards`).
   subroutine guards_general(self, t, y, g)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: g(:)
      integer :: k, i, j
      if (self%cn%m > 0 .or. self%cn%acc_wanted) call constraints_at(self, t, y)   ! lam, acc at (t, y) (D-81)
      do k = 1, size(self%guard_els)
         i = self%guard_els(k)
         if (self%gr(i)%form == 0) then
            call guards_other(self, i, t, y, g, self%guard_offset(i))
         else
            associate (q => self%gr(i))
               do j = 1, self%fe(i)%ng
                  g(q%o + j) = row_guard(q, j, y(q%yl), y(q%yr))
               end do
            end associate
         end if
      end do
   end subroutine guards_general

   !> The guards of element i at (t, y) into g(o + 1 : o + ng) (`model_guards` for
   !> an element without a guard row, `element_guards`): the kinematics of its two
   !> nodes (a plain inertia's straight from y), then its hot guard form or its
   !> own `guards`.
   subroutine guards_other(self, i, t, y, g, o)
      class(model_t), intent(inout) :: self
      integer, intent(in) :: i, o
      real(wp), intent(in) :: t, y(:)
      real(wp), intent(inout) :: g(:)
      integer :: n, k, np
      real(wp) :: thl, wl, thr, wr, gh(4), th(max_ports), w(max_ports)
      n = self%fe(i)%ng
      if (self%nport) then
         np = self%elements(i)%e%n_ports()
         if (np > 2) then                                   ! an n-port element (D-73): every port from y
            do k = 1, np
               call node_kinematics(self, self%elements(i)%e%port(k), t, y, th(k), w(k))
            end do
            call self%elements(i)%e%port_guards(th(1:np), w(1:np), g(o + 1:o + n))
            return
         end if
      end if
      ! a plain inertia's angle and speed straight from y (no call on every step)
      if (self%fe(i)%yl > 0) then
         thl = y(self%fe(i)%yl)
         wl = y(self%fe(i)%yl + 1)
      else
         call node_kinematics(self, self%fe(i)%l, t, y, thl, wl)
      end if
      if (self%fe(i)%yr > 0) then
         thr = y(self%fe(i)%yr)
         wr = y(self%fe(i)%yr + 1)
      else
         call node_kinematics(self, self%fe(i)%r, t, y, thr, wr)
      end if
      if (self%fe(i)%gform /= hg_none) then             ! the element's hot form (D-35)
         call hot_guards(self%fh(i), thl, thr, gh)
         g(o + 1:o + n) = gh(1:n)
      else
         call self%elements(i)%e%guards(thl, wl, thr, wr, g(o + 1:o + n))
      end if
   end subroutine guards_other

   module procedure model_element_guards
      if (self%elements(i)%e%con%on) call constraints_at(self, t, y)   ! (D-81)
      call guards_other(self, i, t, y, g, 0)
   end procedure model_element_guards

   module procedure model_element_guard
      if (self%gr(i)%form > 0) then
         gk = row_guard(self%gr(i), k, y(self%gr(i)%yl), y(self%gr(i)%yr))
         return
      end if
      call model_element_guards(self, i, t, y, self%g_el(1:self%fe(i)%ng))   ! (sized by finalize)
      gk = self%g_el(k)
   end procedure model_element_guard

   module procedure model_guard_angles
      yl = 0
      yr = 0
      if (self%gr(i)%form == 0) return
      yl = self%gr(i)%yl
      yr = self%gr(i)%yr
   end procedure model_guard_angles

   module procedure model_angle_guard
      gk = row_guard(self%gr(i), k, thl, thr)
   end procedure model_angle_guard

   module procedure model_guard_floor
      real(wp), parameter :: rel = 1.0e-12_wp   ! far above a few ulps
      real(wp) :: d, dr, al, slack
      gmin = -huge(1.0_wp)
      if (self%gr(i)%form == 0) return
      associate (q => self%gr(i))
         al = abs(thl) + rl
         slack = rel*(abs(q%r1)*al + abs(q%r2)*(abs(thr) + rr) + q%b)
         d = q%r1*thl - q%r2*thr
         dr = abs(q%r1)*rl + abs(q%r2)*rr + slack
         select case (q%mode)
         case (1)
            gmin = min(1.0_wp, d - dr - q%b)
         case (-1)
            gmin = min(1.0_wp, -d - dr - q%b)
         case default
            gmin = min(q%b - d - dr, d - dr + q%b)
         end select
         if (q%form == 2) then
            slack = rel*(al + abs(q%th_lo) + abs(q%th_hi))
            if (.not. q%lo_open) gmin = min(gmin, thl - rl - q%th_lo - slack)
            gmin = min(gmin, q%th_hi - thl - rl - slack)
         end if
      end associate
   end procedure model_guard_floor

   !> Guard k of a guard row at the angles thl, thr: `model_guards`' arithmetic
   !> (hot_guards') for that guard alone.
   pure real(wp) function row_guard(q, k, thl, thr) result(gk)
      type(guard_row_t), intent(in) :: q
      integer, intent(in) :: k
      real(wp), intent(in) :: thl, thr
      real(wp) :: d
      select case (k)
      case (1, 2)
         d = q%r1*thl - q%r2*thr
         select case (q%mode)
         case (1)
            gk = 1.0_wp
            if (k == 1) gk = d - q%b
         case (-1)
            gk = 1.0_wp
            if (k == 2) gk = -d - q%b
         case default
            if (k == 1) then
               gk = q%b - d
            else
               gk = d + q%b
            end if
         end select
      case (3)
         gk = 1.0_wp
         if (.not. q%lo_open) gk = thl - q%th_lo
      case default
         gk = q%th_hi - thl
      end select
   end function row_guard

   !> By bisection: guard_els is in element order and guard_offset grows with it, so the
   !> owner is the last element in guard_els whose first guard is at most j (a scan of
   !> guard_els made RK4's set-up O(guards x elements with guards): startup7b, D-157).
   module procedure model_guard_element
      integer :: lo, hi, mid, i
      owner = 0
      lo = 0   ! guard_offset(guard_els(lo)) < j (lo = 0: none yet)
      hi = size(self%guard_els) + 1   ! guard_offset(guard_els(hi)) >= j
      do while (hi - lo > 1)
         mid = (lo + hi)/2
         if (self%guard_offset(self%guard_els(mid)) < j) then
            lo = mid
         else
            hi = mid
         end if
      end do
      if (lo == 0) return
      i = self%guard_els(lo)
      if (j <= self%guard_offset(i) + self%fe(i)%ng) owner = i
   end procedure model_guard_element

   module procedure model_apply_events
      integer :: i, l, r, o, n, k, m, q, nq
      type(event_t) :: local(max_update_events)
      type(event_t), allocatable :: grown(:)
      real(wp) :: e_before, de
      e_before = 0.0_wp   ! read below only if track_energy; set so -Wmaybe-uninitialized need not prove that
      if (allocated(self%modes_at)) deallocate (self%modes_at)   ! (the modes init_modes set: D-183)
      ! the stuck clusters' speeds exactly as the constraints say (an integrator's
      ! interpolation to the event leaves roundoff in them; D-81), before modes change
      de = 0.0_wp
      if (size(self%cn%cand) > 0) then
         call constraints_settle(self, t, y, events, nev, de, .true.)
         if (self%run%track_energy) y(self%n_states + 1) = y(self%n_states + 1) - de
      end if
      if (present(els)) then
         self%ws_step_end = .false.
         do q = 1, size(els)
            i = els(q)
            call self%kinematics_part(t, y, [self%fe(i)%l, self%fe(i)%r])
         end do
         if (self%run%track_energy) e_before = els_energy()
         nq = size(els)
      else
         if (self%run%track_energy) e_before = self%stored_energy(t, y)
         call kinematics_all(self, t, y)
         nq = size(self%elements)
      end if
      do q = 1, nq
         i = q
         if (present(els)) i = els(q)
         n = self%fe(i)%ng                  ! the element's n_guards (build_fast_path)
         if (n == 0) cycle
         o = self%guard_offset(i)
         if (.not. any(fired(o + 1:o + n))) cycle
         l = self%fe(i)%l
         r = self%fe(i)%r
         k = 2
         if (self%nport) k = self%elements(i)%e%n_ports()
         if (k > 2) then                                     ! an n-port element (D-73; every node's
            call port_update_at(self%elements(i)%e, t, self%theta, self%omega, fired(o + 1:o + n), local, m)
         else                                                ! kinematics known: no local steps with one)
            call self%elements(i)%e%update_mode(t, self%theta(l), self%omega(l), self%theta(r), self%omega(r), &
                                                fired(o + 1:o + n), local, m)
         end if
         call refresh_hot(self, i)
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
      if (size(self%cn%cand) > 0) call constraints_settle(self, t, y, events, nev, de, .false.)   ! (D-81)
      if (.not. self%run%track_energy) return
      ! the kinetic energy a stick event removes is dissipated in the element that stuck
      y(self%n_states + 1) = y(self%n_states + 1) - de
      e_before = e_before + de
      if (present(els)) then
         y(self%n_states + 2) = y(self%n_states + 2) + (els_energy() - e_before)
      else
         y(self%n_states + 2) = y(self%n_states + 2) + self%stored_energy(t, y) - e_before
      end if
   contains
      !> The elastic energy of the elements els at the kinematics in the workspace.
      real(wp) function els_energy() result(e)
         integer :: p, ll, rr
         e = 0.0_wp
         do p = 1, size(els)
            ll = self%fe(els(p))%l
            rr = self%fe(els(p))%r
            e = e + self%elements(els(p))%e%potential_energy(self%theta(ll), self%theta(rr))
         end do
      end function els_energy
   end procedure model_apply_events

   !> A full RHS at (t, y) before a constraining element's guards (D-81): its
   !> lam and t_now are then those of (t, y).
   subroutine constraints_at(self, t, y)
      class(model_t), intent(inout) :: self
      real(wp), intent(in) :: t, y(:)
      real(wp), allocatable :: dydt(:)
      call move_alloc(self%cn%scratch, dydt)              ! (no allocation: the buffer lent)
      call self%rhs(t, y, dydt)
      call move_alloc(dydt, self%cn%scratch)
   end subroutine constraints_at

   module procedure model_any_contact
      integer :: i
      c = .false.
      do i = 1, size(self%elements)
         if (self%elements(i)%e%in_contact()) then
            c = .true.
            return
         end if
      end do
   end procedure model_any_contact
end submodule trainsim_model_guards
