!> Event location of RK4 (submodule of trainsim_int_rk4): the zero of a guard
!> that went negative in a step, on the step's dense output and then on the
!> RK4 step map, and the parts of a long train that one element's guards see
!> through a step (so the step map is evaluated on that part only).
submodule(trainsim_int_rk4) trainsim_rk4_events
   implicit none

   !> A guard on two angles on the dense output, its operands in locals (`angle_dense_of`)
   type :: angle_dense_t
      integer :: e = 0, k = 0, il = 0
      real(wp) :: h = 0.0_wp, l(5) = 0.0_wp, r(5) = 0.0_wp
   end type angle_dense_t

contains

   !> For each element with guards in a long train: the part of the train its
   !> guards see through one RK4 step (type part_t). Used when that part has
   !> fewer than half the nodes: the step map is then evaluated on the part
   !> only while an event is located, and stays bit for bit the full step's.
   module subroutine build_parts(self, model)
      type(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      integer :: nn, ne, e, i
      integer, allocatable :: first(:), list(:), fill(:)
      nn = size(model%nodes)
      ne = size(model%elements)
      allocate (self%part(ne))
      if (self%ng == 0) return
      ! node -> elements (compressed rows, elements in increasing order)
      allocate (first(nn + 1), fill(nn))
      first = 0
      do e = 1, ne
         first(model%elements(e)%e%left + 1) = first(model%elements(e)%e%left + 1) + 1
         first(model%elements(e)%e%right + 1) = first(model%elements(e)%e%right + 1) + 1
      end do
      first(1) = 1
      do i = 1, nn
         first(i + 1) = first(i + 1) + first(i)
      end do
      allocate (list(first(nn + 1) - 1))
      fill = first(1:nn)
      do e = 1, ne
         associate (l => model%elements(e)%e%left, r => model%elements(e)%e%right)
            list(fill(l)) = e; fill(l) = fill(l) + 1
            if (r /= l) then
               list(fill(r)) = e; fill(r) = fill(r) + 1
            end if
         end associate
      end do
      do e = 1, ne
         if (model%elements(e)%e%n_guards() == 0) cycle
         associate (p => self%part(e))
            p%d4 = unique([model%elements(e)%e%left, model%elements(e)%e%right])
            call grow(p%d4, p%e4, p%k4)
            p%d3 = p%k4
            call grow(p%d3, p%e3, p%k3)
            p%d2 = p%k3
            call grow(p%d2, p%e2, p%k2)
            p%used = 2*size(p%k2) < nn .and. .not. model%nport   ! (parts by left and right only: D-73)
            p%sk2 = states_of(p%k2)
            p%sk3 = states_of(p%k3)
            p%sk4 = states_of(p%k4)
            p%sd4 = states_of(p%d4)
         end associate
      end do
   contains

      !> The elements of nodes d (increasing) and d with their other ends.
      subroutine grow(d, els, k)
         integer, intent(in) :: d(:)
         integer, allocatable, intent(out) :: els(:), k(:)
         integer, allocatable :: all(:)
         integer :: a, q, m
         ! (sized first, filled in place: growing by concatenation cost ~14 000
         ! instructions a gear at 20 000 nodes; startup7b, D-157)
         m = 0
         do a = 1, size(d)
            m = m + first(d(a) + 1) - first(d(a))
         end do
         allocate (all(m))
         m = 0
         do a = 1, size(d)
            do q = first(d(a)), first(d(a) + 1) - 1
               m = m + 1
               all(m) = list(q)
            end do
         end do
         els = unique(all)
         deallocate (all)
         allocate (all(size(d) + 2*size(els)))
         all(1:size(d)) = d
         m = size(d)
         do a = 1, size(els)
            all(m + 1) = model%elements(els(a))%e%left
            all(m + 2) = model%elements(els(a))%e%right
            m = m + 2
         end do
         k = unique(all)
      end subroutine grow

      !> Sorted, without repeats. An insertion sort of the few indices, not a
      !> sweep over every node or element (that made the set-up O(N) per
      !> element with guards, O(N^2) in all: D-74).
      pure function unique(a) result(u)
         integer, intent(in) :: a(:)
         integer, allocatable :: u(:)
         integer :: q, p, v, m
         allocate (u(size(a)))
         m = 0
         do q = 1, size(a)
            v = a(q)
            p = m
            do while (p > 0)
               if (u(p) <= v) exit
               p = p - 1
            end do
            if (p > 0) then
               if (u(p) == v) cycle
            end if
            u(p + 2:m + 1) = u(p + 1:m)
            u(p + 1) = v
            m = m + 1
         end do
         u = u(1:m)
      end function unique

      !> State indices of the free nodes in nodes(:).
      function states_of(nodes) result(st)
         integer, intent(in) :: nodes(:)
         integer, allocatable :: st(:)
         integer :: a, o, q, m
         m = 0
         do a = 1, size(nodes)
            if (model%is_held(nodes(a))) cycle
            m = m + model%nodes(nodes(a))%n%nstates()
         end do
         allocate (st(m))
         m = 0
         do a = 1, size(nodes)
            if (model%is_held(nodes(a))) cycle
            o = model%nodes(nodes(a))%n%offset
            do q = 1, model%nodes(nodes(a))%n%nstates()
               m = m + 1
               st(m) = o + q
            end do
         end do
      end function states_of
   end subroutine build_parts

   !> The RK4 step of size s from (t_loc, y) on the part of element e only: ys
   !> on the states of e's nodes, bit for bit the full step's (k1 of the full
   !> step, the same torque sums per node). k2..k4 and ytmp are scratch.
   module subroutine rk4_step_part(self, model, y, e, s)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      integer, intent(in) :: e
      real(wp) :: hh, h6, t
      integer :: q, i
      t = self%t_loc
      hh = 0.5_wp*s
      associate (p => self%part(e))
         do q = 1, size(p%sk2)
            i = p%sk2(q)
            self%ytmp(i) = y(i) + hh*self%k1(i)
         end do
         call model%rhs_part(t + 0.5_wp*s, self%ytmp, self%k2, p%k2, p%e2, p%d2)
         do q = 1, size(p%sk3)
            i = p%sk3(q)
            self%ytmp(i) = y(i) + hh*self%k2(i)
         end do
         call model%rhs_part(t + 0.5_wp*s, self%ytmp, self%k3, p%k3, p%e3, p%d3)
         do q = 1, size(p%sk4)
            i = p%sk4(q)
            self%ytmp(i) = y(i) + s*self%k3(i)
         end do
         call model%rhs_part(t + s, self%ytmp, self%k4, p%k4, p%e4, p%d4)
         h6 = s/6.0_wp
         do q = 1, size(p%sd4)
            i = p%sd4(q)
            self%ys(i) = y(i) + h6*(self%k1(i) + 2.0_wp*(self%k2(i) + self%k3(i)) + self%k4(i))
         end do
      end associate
   end subroutine rk4_step_part

   !> A guard went negative inside [t, t+h]: locate the earliest zero and end
   !> the step there (t, y at the located point). The zero of each guard that
   !> fired is first found on the step's own dense output (no RHS evaluation);
   !> the earliest is then refined on the step map s -> g(RK4(y, s)), so the
   !> state at the event is a true RK4 step (see `refine`).
   module subroutine rk4_end_on_event(self, model, h, t, y)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: h
      real(wp), intent(inout) :: t, y(:)
      real(wp) :: s_ev, sj, gd
      real(wp), allocatable :: swap(:)
      integer :: j, jb, jl, pass
      self%dg_e = 0
      call model%guards(t, y, self%g0)
      ! keep the stages of this step (its dense output): swap, no copy
      call move_alloc(self%k2, swap); call move_alloc(self%d2, self%k2); call move_alloc(swap, self%d2)
      call move_alloc(self%k3, swap); call move_alloc(self%d3, self%k3); call move_alloc(swap, self%d3)
      call move_alloc(self%k4, swap); call move_alloc(self%d4, self%k4); call move_alloc(swap, self%d4)
      self%t_loc = t
      self%h_loc = h
      jb = 0
      s_ev = h
      do j = 1, self%ng
         if (self%g1(j) < 0.0_wp) then
            sj = rk4_dense_root(self, model, y, j, max(self%g0(j), 0.0_wp), h, self%g1(j))
            if (jb == 0 .or. sj < s_ev) then
               s_ev = sj
               jb = j
            end if
         end if
      end do
      s_ev = rk4_refine(self, model, y, jb, s_ev, max(self%g0(jb), 0.0_wp), h, self%g1(jb))
      ! another guard below zero there may have crossed earlier still (its zero
      ! on the dense output was later, within the dense output's error)
      do pass = 1, self%ng
         call model%guards(t + s_ev, self%ys, self%gs)
         jl = jb
         jb = 0
         do j = 1, self%ng
            if (j == jl .or. .not. self%gs(j) < 0.0_wp) cycle
            gd = rk4_dense_guard(self, model, y, j, s_ev)
            if (.not. gd < 0.0_wp) gd = self%gs(j)
            sj = rk4_dense_root(self, model, y, j, max(self%g0(j), 0.0_wp), s_ev, gd)
            if (sj < s_ev - self%event_tol) then
               jb = j
               exit
            end if
         end do
         if (jb == 0) exit
         s_ev = rk4_refine(self, model, y, jb, sj, max(self%g0(jb), 0.0_wp), s_ev, self%gs(jb))
      end do
      t = t + s_ev
      y = self%ys
      self%stats%root_returns = self%stats%root_returns + 1
      ! the RHS at the event's state in the modes before it, into the model's
      ! workspace for the observer, which then folds the instant as a plain
      ! step's end instead of evaluating the train itself (D-146; not counted:
      ! it stands for the observer's evaluation). k1 is free (k1_next is off:
      ! the next step's first stage is evaluated anew, in the new modes).
      call model%rhs_step_end(t, y, self%k1)
      model%ws_step_end = .true.
   end subroutine rk4_end_on_event

   !> Guard j at t_loc + s on the dense output of the step being located (the
   !> RK4 continuous extension, third order: b1 = s - 3s^2/2 + 2s^3/3,
   !> b2 = b3 = s^2 - 2s^3/3, b4 = -s^2/2 + 2s^3/3 in units of h), evaluated
   !> for the states of the guard's element only.
   real(wp) module function rk4_dense_guard(self, model, y, j, s) result(g)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      integer, intent(in) :: j
      real(wp) :: b1, b2, b4, h, c1, c2, c4
      integer :: e, k, i
      h = self%h_loc
      call dense_weights(s/h, b1, b2, b4)
      e = self%g_el(j)
      if (.not. self%mr_on) then
         ! guards that read only two plain inertias' angles (the model says which
         ! states): those two on the dense output, the guard from them
         if (e /= self%dg_e) then
            call model%guard_angles(e, self%dg_l, self%dg_r)
            self%dg_e = e
         end if
         if (self%dg_l > 0) then
            associate (il => self%dg_l, ir => self%dg_r)
               g = model%angle_guard(e, self%g_loc(j), &
                                     dense_at(y(il), self%k1(il), self%d2(il), self%d3(il), self%d4(il), h, b1, b2, b4), &
                                     dense_at(y(ir), self%k1(ir), self%d2(ir), self%d3(ir), self%d4(ir), h, b1, b2, b4))
            end associate
            return
         end if
      end if
      do k = 1, 3, 2
         if (self%mr_on) then
            if (.not. self%in_l(self%el_nodes((k + 1)/2, e))) then
               ! a node of B in a local event step: the unsplit step's dense output
               call dense_weights((self%t_loc + s - self%mt0)/self%mh, c1, c2, c4)
               do i = self%el_states(k, e), self%el_states(k + 1, e)
                  self%yi(i) = dense_at(self%my0(i), self%mk1(i), self%md2(i), self%md3(i), self%md4(i), self%mh, c1, c2, c4)
               end do
               cycle
            end if
         end if
         do i = self%el_states(k, e), self%el_states(k + 1, e)
            self%yi(i) = dense_at(y(i), self%k1(i), self%d2(i), self%d3(i), self%d4(i), h, b1, b2, b4)
         end do
      end do
      g = model%element_guard(e, self%g_loc(j), self%t_loc + s, self%yi)
   end function rk4_dense_guard

   !> The weights of the RK4 continuous extension at th = s/h (`rk4_dense_guard`):
   !> b1 = th - 3th^2/2 + 2th^3/3, b2 = b3 = th^2 - 2th^3/3, b4 = -th^2/2 + 2th^3/3.
   pure subroutine dense_weights(th, b1, b2, b4)
      real(wp), intent(in) :: th
      real(wp), intent(out) :: b1, b2, b4
      b1 = th*(1.0_wp - th*(1.5_wp - th*(2.0_wp/3.0_wp)))
      b2 = th*th*(1.0_wp - th*(2.0_wp/3.0_wp))
      b4 = th*th*(-0.5_wp + th*(2.0_wp/3.0_wp))
   end subroutine dense_weights

   !> A state on the dense output: y0 + h (b1 k1 + b2 (k2 + k3) + b4 k4).
   pure real(wp) function dense_at(y0, k1, k2, k3, k4, h, b1, b2, b4) result(v)
      real(wp), intent(in) :: y0, k1, k2, k3, k4, h, b1, b2, b4
      v = y0 + h*(b1*k1 + b2*(k2 + k3) + b4*k4)
   end function dense_at

   !> A guard that reads two plain inertias' angles (`rk4_dense_guard`'s first
   !> way, not in a local event step) in locals: its element, its index and the
   !> two angles' dense-output operands, read once for a root's iterations
   !> (il = 0: the guard is not such a guard; D-177).
   subroutine angle_dense_of(self, model, y, j, q)
      class(rk4_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: y(:)
      integer, intent(in) :: j
      type(angle_dense_t), intent(out) :: q
      integer :: il, ir
      il = 0
      ir = 0
      q%e = self%g_el(j)
      if (.not. self%mr_on) call model%guard_angles(q%e, il, ir)
      q%il = il
      if (il == 0) return
      q%k = self%g_loc(j)
      q%h = self%h_loc
      q%l = [y(il), self%k1(il), self%d2(il), self%d3(il), self%d4(il)]
      q%r = [y(ir), self%k1(ir), self%d2(ir), self%d3(ir), self%d4(ir)]
   end subroutine angle_dense_of

   !> That guard at t_loc + s on the dense output: `rk4_dense_guard`'s value.
   real(wp) function angle_dense_guard(model, q, s) result(g)
      type(model_t), intent(in) :: model
      type(angle_dense_t), intent(in) :: q
      real(wp), intent(in) :: s
      real(wp) :: b1, b2, b4
      call dense_weights(s/q%h, b1, b2, b4)
      g = model%angle_guard(q%e, q%k, dense_at(q%l(1), q%l(2), q%l(3), q%l(4), q%l(5), q%h, b1, b2, b4), &
                            dense_at(q%r(1), q%r(2), q%r(3), q%r(4), q%r(5), q%h, b1, b2, b4))
   end function angle_dense_guard

   !> Guard j at t_loc + s on the step map: ys = RK4(y, s), on the part of the
   !> train the guard sees (on_part) when that is small.
   real(wp) module function rk4_map_guard(self, model, y, j, s) result(g)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s
      integer, intent(in) :: j
      self%on_part = .false.
      if (self%mr_on) then
         ! a local event step: L's step map
         if (s == self%h_loc) then
            call self%end_copy()
         else if (self%n_comp > 1) then
            ! the guard's component of L alone (its states bit for bit those of
            ! L's step: the components do not see each other); refine then
            ! takes L's step to the located time
            call self%comp_step(model, y, self%g_el(j), s)
            self%on_part = .true.
         else
            call self%mr_step(model, y, s)
         end if
         ! (ys holds all of L's step unless on_part: refine may keep it)
      else if (s == self%h_loc) then
         self%ys = self%ynew
      else if (self%part(self%g_el(j))%used) then
         call self%step_part(model, y, self%g_el(j), s)
         self%on_part = .true.
      else
         call rk4_step(self, model, self%t_loc, y, s, self%ys, .false.)
      end if
      g = model%element_guard(self%g_el(j), self%g_loc(j), self%t_loc + s, self%ys)
   end function rk4_map_guard

   !> Zero of guard j on the dense output in [0, b0] (g = ga0 >= 0 at 0,
   !> gb0 < 0 at b0): Illinois false position to the event tolerance; returns
   !> the end of the final bracket where g < 0.
   real(wp) module function rk4_dense_root(self, model, y, j, ga0, b0, gb0) result(b)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), ga0, b0, gb0
      integer, intent(in) :: j
      real(wp) :: a, fa, fb, s, fs, tol
      type(angle_dense_t) :: q
      integer :: side, it
      a = 0.0_wp; b = b0; fa = ga0; fb = gb0; side = 0
      self%dg_e = 0
      tol = self%event_tol
      call angle_dense_of(self, model, y, j, q)
      do it = 1, 100
         if (b - a <= tol) exit
         s = (a*fb - b*fa)/(fb - fa)
         s = min(max(s, a + 0.01_wp*(b - a)), b - 0.01_wp*(b - a))
         if (q%il > 0) then
            fs = angle_dense_guard(model, q, s)
         else
            fs = rk4_dense_guard(self, model, y, j, s)
         end if
         if (fs < 0.0_wp) then
            b = s; fb = fs
            if (side == -1) fa = 0.5_wp*fa
            side = -1
         else
            a = s; fa = fs
            if (side == 1) fb = 0.5_wp*fb
            side = 1
         end if
      end do
   end function rk4_dense_root

   !> Zero of guard j on the step map in [0, b0] (g = ga0 >= 0 at 0, gb0 < 0 at
   !> b0), from the estimate s0 (its zero on the dense output). The first
   !> correction is a Newton step with the dense output's slope, the next ones
   !> secant steps through the last two step-map points; each is aimed
   !> event_tol/2 past the zero, so that the point evaluated ends the bracket.
   !> It stops when the bracket is within event_tol, or when a point where
   !> g < 0 has the Newton or secant zero within 0.75 event_tol (or the time
   !> resolution t_res |t|, if coarser) before it (the secant error is then of
   !> order (g''/g') (zero - s0) event_tol, far below event_tol). After max_secant points it falls back to Illinois false
   !> position on the bracket. Returns the end where g < 0, ys = RK4 to it.
   real(wp) module function rk4_refine(self, model, y, j, s0, ga0, b0, gb0) result(b)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), s0, ga0, b0, gb0
      integer, intent(in) :: j
      real(wp) :: a, fa, fb, sc, gc, sp, gp, r, dl, slope, tol, tol_acc
      real(wp), allocatable :: swap(:)
      type(angle_dense_t) :: q
      integer :: it, side
      logical :: have_b, have_r, b_full
      tol = self%event_tol
      self%dg_e = 0
      a = 0.0_wp; fa = ga0; b = b0; fb = gb0; side = 0
      sc = min(max(s0, a + 0.5_wp*tol), b)
      have_b = .false.   ! yb holds RK4(y, b) (all of it when b_full)
      b_full = .false.
      sp = 0.0_wp; gp = 0.0_wp; r = 0.0_wp
      do it = 1, 200
         gc = rk4_map_guard(self, model, y, j, sc)
         if (gc < 0.0_wp) then
            b = sc; fb = gc
            call move_alloc(self%ys, swap); call move_alloc(self%yb, self%ys); call move_alloc(swap, self%yb)
            have_b = .true.
            b_full = .not. self%on_part
            if (side == -1) fa = 0.5_wp*fa
            side = -1
         else
            a = sc; fa = gc
            if (side == 1) fb = 0.5_wp*fb
            side = 1
         end if
         if (b - a <= tol) exit
         have_r = .false.
         if (it <= max_secant) then
            if (it > 1) then
               if (gc /= gp) then
                  r = sc - gc*(sc - sp)/(gc - gp)                       ! secant on the step map
                  have_r = .true.
               end if
            else
               dl = 1.0e-3_wp*self%h_loc
               call angle_dense_of(self, model, y, j, q)
               if (q%il > 0) then
                  slope = (angle_dense_guard(model, q, sc + dl) - angle_dense_guard(model, q, sc - dl))/(2.0_wp*dl)
               else
                  slope = (rk4_dense_guard(self, model, y, j, sc + dl) - rk4_dense_guard(self, model, y, j, sc - dl))/(2.0_wp*dl)
               end if
               if (slope /= 0.0_wp) then
                  r = sc - gc/slope                                     ! Newton, dense-output slope
                  have_r = .true.
               end if
            end if
            ! the correction to a point where g < 0 is below the tolerance: done
            tol_acc = 0.75_wp*max(tol, t_res*abs(self%t_loc + b))
            if (have_r .and. gc < 0.0_wp) then
               if (r <= b .and. b - r <= tol_acc .and. r > a) exit
            end if
         end if
         sp = sc; gp = gc
         if (have_r) have_r = r > a .and. r < b
         if (have_r) then
            sc = min(r + 0.5_wp*tol, b - 0.25_wp*tol)
            if (sc <= a) sc = 0.5_wp*(a + b)
         else
            sc = (a*fb - b*fa)/(fb - fa)                                ! Illinois
            sc = min(max(sc, a + 0.01_wp*(b - a)), b - 0.01_wp*(b - a))
         end if
      end do
      if (have_b .and. b_full) then
         call move_alloc(self%ys, swap); call move_alloc(self%yb, self%ys); call move_alloc(swap, self%yb)
      else if (self%mr_on) then
         if (b == self%h_loc) then
            call self%end_copy()
         else
            call self%mr_step(model, y, b)
         end if
      else if (b == self%h_loc) then
         self%ys = self%ynew
      else
         ! the whole train to the located time (the part's states are bit for bit these)
         call rk4_step(self, model, self%t_loc, y, b, self%ys, .false.)
      end if
   end function rk4_refine
end submodule trainsim_rk4_events
