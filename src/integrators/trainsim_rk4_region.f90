!> The region of a local event step of RK4 on a long train (submodule of
!> trainsim_int_rk4, docs/decisions.md D-32): the node graph, built once
!> (`build_graph`); at a step whose guards fired, the region L around the
!> elements that fired, its boundary B, its components and their lists, and
!> the unsplit step kept for `mr_continue` (submodule trainsim_rk4_local).
submodule(trainsim_int_rk4) trainsim_rk4_region
   implicit none

contains

   !> The node graph for local event steps: node -> elements (compressed rows),
   !> each element's nodes, which elements have guards; the marks and lists of
   !> a region, sized once.
   module subroutine build_graph(self, model)
      type(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      integer :: nn, ne, n, e, i, side, nd
      integer, allocatable :: fill(:)
      nn = size(model%nodes)
      ne = size(model%elements)
      n = size(self%k1)
      allocate (self%adj_first(nn + 1), self%el_nodes(2, ne), self%has_guards(ne), fill(nn))
      self%adj_first = 0
      do e = 1, ne
         self%el_nodes(1, e) = model%elements(e)%e%left
         self%el_nodes(2, e) = model%elements(e)%e%right
         self%has_guards(e) = model%elements(e)%e%n_guards() > 0
         do side = 1, 2
            nd = self%el_nodes(side, e)
            if (side == 2 .and. nd == self%el_nodes(1, e)) cycle
            self%adj_first(nd + 1) = self%adj_first(nd + 1) + 1
         end do
      end do
      self%adj_first(1) = 1
      do i = 1, nn
         self%adj_first(i + 1) = self%adj_first(i + 1) + self%adj_first(i)
      end do
      allocate (self%adj_list(self%adj_first(nn + 1) - 1))
      fill = self%adj_first(1:nn)
      do e = 1, ne
         do side = 1, 2
            nd = self%el_nodes(side, e)
            if (side == 2 .and. nd == self%el_nodes(1, e)) cycle
            self%adj_list(fill(nd)) = e
            fill(nd) = fill(nd) + 1
         end do
      end do
      allocate (self%in_l(nn), self%in_kin(nn), self%el_in(ne), self%gel_in(ne), self%depth(nn))
      self%in_l = .false.; self%in_kin = .false.; self%el_in = .false.; self%gel_in = .false.
      self%depth = huge(1)
      allocate (self%stack(4*nn + 4), self%l_nodes(nn), self%b_nodes(nn), self%kin(nn), self%els(ne), self%gels(ne), &
                self%in_els(ne))
      allocate (self%sl(n), self%sb(n), self%far(ne))
      allocate (self%comp(nn), self%ns_range(2, nn), self%mark(nn), self%cn(nn), self%ce(ne), self%ck(nn), &
                self%csl(n), self%csb(n))
      self%comp = 0; self%mark = 0; self%stamp = 0; self%n_comp = 0; self%cur_c = 0
      do i = 1, nn
         self%ns_range(1, i) = 1   ! (1:0): a held node has no states
         self%ns_range(2, i) = 0
         if (model%is_held(i)) cycle
         self%ns_range(1, i) = model%nodes(i)%n%offset + 1
         self%ns_range(2, i) = model%nodes(i)%n%offset + model%nodes(i)%n%nstates()
      end do
      self%n_far = 0
      self%far_done = .false.
      allocate (self%my0(n), self%mk1(n), self%md2(n), self%md3(n), self%md4(n), self%mynew(n), self%yc(n))
      self%n_l = 0; self%n_b = 0; self%n_kin = 0; self%n_els = 0; self%n_gels = 0; self%n_sl = 0; self%n_sb = 0
      self%n_in = 0
      self%at_local = .false.
      self%y_partial = .false.
      self%mr_steps = 0; self%mr_events = 0; self%mr_collapses = 0; self%mr_node_rhs = 0
   end subroutine build_graph

   !> Start a local event step, or say that this step is not one (ok false:
   !> the whole train's step is split as before). The guards g1 at the end of
   !> the unsplit step (ynew, stages k1..k4) fired. The region L holds the nodes
   !> within mr_depth elements of the nodes of every element whose guard fired,
   !> and, so that every event in L has its whole reach in L, of every element
   !> with guards that has a node in L (repeated until no such element is
   !> left). Only a region that with its boundary B (the nodes next to L) holds
   !> at most 1/mr_small of the train is used. The unsplit step is kept (its
   !> start, stages and end): every node outside L ends the step at its unsplit
   !> value, which does not depend on any element of L that has guards (see
   !> mr_depth); L alone is integrated again through its events (`mr_continue`),
   !> with the states of B from the unsplit step's dense output.
   module subroutine rk4_mr_begin(self, model, t, y, h, t_grid, ok)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:), h, t_grid
      logical, intent(out) :: ok
      integer :: nn
      ok = .false.
      nn = size(model%nodes)
      if (.not. self%multirate .or. model%nport .or. size(model%cn%cand) > 0 .or. nn < mr_min_nodes .or. &
          mr_small*(2*mr_depth + 4) > nn) return   ! (not with constraints: they couple the whole train, D-81)
      call mr_clear(self)
      if (.not. mr_grow(self, nn)) return
      if (.not. mr_border(self, nn)) return
      call mr_components(self)
      ok = .true.
      call mr_keep(self, model, t, y, h, t_grid)
   end subroutine rk4_mr_begin

   !> Clear the marks and lists of the last region.
   subroutine mr_clear(self)
      class(rk4_t), intent(inout) :: self
      integer :: k
      do k = 1, self%n_l
         self%in_l(self%l_nodes(k)) = .false.
         self%depth(self%l_nodes(k)) = huge(1)
      end do
      do k = 1, self%n_kin
         self%in_kin(self%kin(k)) = .false.
      end do
      do k = 1, self%n_els
         self%el_in(self%els(k)) = .false.
      end do
      do k = 1, self%n_gels
         self%gel_in(self%gels(k)) = .false.
      end do
      self%n_l = 0; self%n_b = 0; self%n_kin = 0; self%n_els = 0; self%n_gels = 0
   end subroutine mr_clear

   !> The region L: the nodes within mr_depth of the seeds, the nodes of the
   !> elements whose guards fired and of every element with guards that has a
   !> node in L (a stack; a node is pushed again when a shorter path to it is
   !> found). False as soon as L holds more than 1/mr_small of the nn nodes.
   logical function mr_grow(self, nn) result(small)
      class(rk4_t), intent(inout) :: self
      integer, intent(in) :: nn
      integer :: j, q, nd, e2, other, top, next_seed
      small = .false.
      do j = 1, self%ng
         if (self%g1(j) < 0.0_wp) call add_seed(self%g_el(j))
      end do
      top = 0
      next_seed = 1
      do
         if (top > 0) then
            nd = self%stack(top)
            top = top - 1
            do q = self%adj_first(nd), self%adj_first(nd + 1) - 1
               e2 = self%adj_list(q)
               other = self%el_nodes(1, e2)
               if (other == nd) other = self%el_nodes(2, e2)
               call relax(other, self%depth(nd) + 1)
            end do
         else if (next_seed <= self%n_gels) then
            call relax(self%el_nodes(1, self%gels(next_seed)), 0)
            call relax(self%el_nodes(2, self%gels(next_seed)), 0)
            next_seed = next_seed + 1
         else
            exit
         end if
         if (mr_small*self%n_l > nn) return
      end do
      small = .true.
   contains

      subroutine add_seed(e)
         integer, intent(in) :: e
         if (self%gel_in(e)) return
         self%gel_in(e) = .true.
         self%n_gels = self%n_gels + 1
         self%gels(self%n_gels) = e
      end subroutine add_seed

      subroutine relax(nd, d)
         integer, intent(in) :: nd, d
         integer :: qq
         if (d >= self%depth(nd)) return
         if (.not. self%in_l(nd)) then
            self%in_l(nd) = .true.
            self%n_l = self%n_l + 1
            self%l_nodes(self%n_l) = nd
            do qq = self%adj_first(nd), self%adj_first(nd + 1) - 1
               if (self%has_guards(self%adj_list(qq))) call add_seed(self%adj_list(qq))
            end do
         end if
         self%depth(nd) = d
         if (d < mr_depth) then
            top = top + 1
            self%stack(top) = nd
         end if
      end subroutine relax
   end function mr_grow

   !> L's boundary B, the elements with a node in L (els) and those with both
   !> (in_els), the nodes whose kinematics L's RHS reads (kin), all sorted, and
   !> the states of L (sl) and B (sb). False when L and B hold more than
   !> 1/mr_small of the nn nodes.
   logical function mr_border(self, nn) result(small)
      class(rk4_t), intent(inout) :: self
      integer, intent(in) :: nn
      integer :: k, q, nd, e2, other
      small = .false.
      do k = 1, self%n_l
         nd = self%l_nodes(k)
         self%in_kin(nd) = .true.
         self%n_kin = self%n_kin + 1
         self%kin(self%n_kin) = nd
      end do
      do k = 1, self%n_l
         nd = self%l_nodes(k)
         do q = self%adj_first(nd), self%adj_first(nd + 1) - 1
            e2 = self%adj_list(q)
            if (.not. self%el_in(e2)) then
               self%el_in(e2) = .true.
               self%n_els = self%n_els + 1
               self%els(self%n_els) = e2
            end if
            other = self%el_nodes(1, e2)
            if (other == nd) other = self%el_nodes(2, e2)
            if (.not. self%in_kin(other)) then
               self%in_kin(other) = .true.
               self%n_kin = self%n_kin + 1
               self%kin(self%n_kin) = other
               self%n_b = self%n_b + 1
               self%b_nodes(self%n_b) = other
            end if
         end do
      end do
      if (mr_small*self%n_kin > nn) return
      small = .true.
      call sort_int(self%l_nodes(1:self%n_l))
      call sort_int(self%b_nodes(1:self%n_b))
      call sort_int(self%kin(1:self%n_kin))
      call sort_int(self%els(1:self%n_els))
      self%n_in = 0
      do k = 1, self%n_els
         if (self%in_l(self%el_nodes(1, self%els(k))) .and. self%in_l(self%el_nodes(2, self%els(k)))) then
            self%n_in = self%n_in + 1
            self%in_els(self%n_in) = self%els(k)
         end if
      end do
      call states(self%l_nodes(1:self%n_l), self%sl, self%n_sl)
      call states(self%b_nodes(1:self%n_b), self%sb, self%n_sb)
   contains

      subroutine states(nodes, st, ns)
         integer, intent(in) :: nodes(:)
         integer, intent(inout) :: st(:)
         integer, intent(out) :: ns
         integer :: a, b
         ns = 0
         do a = 1, size(nodes)
            do b = self%ns_range(1, nodes(a)), self%ns_range(2, nodes(a))   ! (none for a held node)
               ns = ns + 1
               st(ns) = b
            end do
         end do
      end subroutine states

      !> Insertion sort (short lists).
      pure subroutine sort_int(a)
         integer, intent(inout) :: a(:)
         integer :: i, j, x
         do i = 2, size(a)
            x = a(i)
            j = i - 1
            do while (j >= 1)
               if (a(j) <= x) exit
               a(j + 1) = a(j)
               j = j - 1
            end do
            a(j + 1) = x
         end do
      end subroutine sort_int
   end function mr_border

   !> The connected parts (components) of L, joined by elements with both nodes
   !> in L: comp(node) for the nodes of L, n_comp.
   subroutine mr_components(self)
      class(rk4_t), intent(inout) :: self
      integer :: k, q, nd, e2, other, top
      do k = 1, self%n_l
         self%comp(self%l_nodes(k)) = 0
      end do
      self%n_comp = 0
      self%cur_c = 0
      do k = 1, self%n_l
         if (self%comp(self%l_nodes(k)) /= 0) cycle
         self%n_comp = self%n_comp + 1
         self%comp(self%l_nodes(k)) = self%n_comp
         top = 1
         self%stack(1) = self%l_nodes(k)
         do while (top > 0)
            nd = self%stack(top)
            top = top - 1
            do q = self%adj_first(nd), self%adj_first(nd + 1) - 1
               e2 = self%adj_list(q)
               other = self%el_nodes(1, e2)
               if (other == nd) other = self%el_nodes(2, e2)
               if (.not. self%in_l(other)) cycle
               if (self%comp(other) /= 0) cycle
               self%comp(other) = self%n_comp
               top = top + 1
               self%stack(top) = other
            end do
         end do
      end do
   end subroutine mr_components

   !> Keep the unsplit step from (t, y) by h: its start, stages (swapped, not
   !> copied) and end; with energy tracking, the energy rates of L's terms
   !> (elements with a node in L, nodes of L, their loads) at its four stages,
   !> to be replaced by L's own.
   subroutine mr_keep(self, model, t, y, h, t_grid)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, y(:), h, t_grid
      real(wp), allocatable :: swap(:)
      real(wp) :: ts
      integer :: k, q, st
      self%mr_on = .true.
      self%mt0 = t; self%mh = h; self%mt1 = t + h; self%mt_grid = t_grid; self%mt_c = t
      self%my0 = y
      call move_alloc(self%k1, swap); call move_alloc(self%mk1, self%k1); call move_alloc(swap, self%mk1)
      call move_alloc(self%k2, swap); call move_alloc(self%md2, self%k2); call move_alloc(swap, self%md2)
      call move_alloc(self%k3, swap); call move_alloc(self%md3, self%k3); call move_alloc(swap, self%md3)
      call move_alloc(self%k4, swap); call move_alloc(self%md4, self%k4); call move_alloc(swap, self%md4)
      call move_alloc(self%ynew, swap); call move_alloc(self%mynew, self%ynew); call move_alloc(swap, self%mynew)
      self%e_acc = 0.0_wp; self%e_book = 0.0_wp; self%pr = 0.0_wp
      self%mr_steps = self%mr_steps + 1
      self%far_done = .false.
      if (.not. model%run%track_energy) return
      do k = 1, 4
         ts = t
         if (k == 2 .or. k == 3) ts = t + 0.5_wp*h
         if (k == 4) ts = t + h
         do q = 1, self%n_sl + self%n_sb
            if (q <= self%n_sl) then
               st = self%sl(q)
            else
               st = self%sb(q - self%n_sl)
            end if
            select case (k)
            case (1)
               self%ytmp(st) = y(st)
            case (2)
               self%ytmp(st) = y(st) + 0.5_wp*h*self%mk1(st)
            case (3)
               self%ytmp(st) = y(st) + 0.5_wp*h*self%md2(st)
            case (4)
               self%ytmp(st) = y(st) + h*self%md3(st)
            end select
         end do
         call self%mr_rhs(model, ts, self%ytmp, self%k4, self%pr(:, k))
      end do
   end subroutine mr_keep
end submodule trainsim_rk4_region
