!> The hot-path tables of the model's families (plain-inertia and held nodes,
!> linear springs, clearances in their hot form, guard rows, loads), built from
!> the nodes' and elements' own answers and checked against their procedures
!> at probe states; the elements' modes and their refresh.
!> Each `module procedure` here is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_tables
   use trainsim_node, only: node_t
   use trainsim_element, only: element_t, hf_none, hf_open, hf_yang_sun, hf_linear, hg_none, hg_faces, hg_faces_zone
   use trainsim_model_families, only: nk_plain, nk_held, lf_general, lf_undamped, lf_unit, lf_open, lf_yang_sun, &
                                      lf_cl_linear, fast_element_t, table_t, spring_ni, spring_nr, contact_ni, &
                                      contact_nr, free_ni, free_nr, held_ni, held_nr, load_ni, load_nr, row_ends, &
                                      build_chain, chain_laws
   use trainsim_model_kernels, only: hot_probe
   use trainsim_ports, only: port_init_at
   implicit none

contains

   module procedure model_build_fast_path
      integer :: i, ne
      ne = size(self%elements)
      if (allocated(self%modes_at)) deallocate (self%modes_at)   ! (init_modes must follow a rebuild)
      call node_table(self)
      if (allocated(self%fe)) deallocate (self%fe, self%fh, self%gr)
      allocate (self%fe(ne), self%fh(ne), self%gr(ne))
      self%n_norow = 0   ! (each element with guards counted in element_table, then by refresh_hot)
      ! (refresh_hot keeps ws_status, el_contact, n_cold and the families only once they exist: below)
      if (allocated(self%ws_status)) deallocate (self%ws_status)
      if (allocated(self%el_contact)) deallocate (self%el_contact)
      if (allocated(self%fam%contact_row)) deallocate (self%fam%contact_row)
      call element_table(self)
      call load_table(self)
      self%simple = all(self%fn(:)%kind == nk_plain .or. (self%fn(:)%kind == nk_held .and. self%fn(:)%const_speed)) &
                    .and. all(self%fl(:)%const) .and. .not. self%any_needs_loads .and. size(self%dyn_loads) == 0 &
                    .and. .not. self%nport .and. .not. any([(self%elements(i)%e%con%on, i=1, ne)])
      ! elements whose recorded status the observer may take from the workspace
      if (allocated(self%status_in_ws)) deallocate (self%status_in_ws)
      allocate (self%status_in_ws(ne))
      do i = 1, ne
         self%status_in_ws(i) = self%simple .and. self%fe(i)%form >= lf_general .and. self%fe(i)%form <= lf_unit
         if (self%status_in_ws(i)) self%status_in_ws(i) = status_agrees(self%elements(i)%e, self%fe(i))
      end do
      allocate (self%ws_status(ne), self%el_contact(ne))
      self%ws_status = .false.
      self%el_contact = 0
      self%n_cold = 0
      do i = 1, ne
         self%fe(i)%cold = .false.   ! (counted by ws_flags)
         call ws_flags(self, i)
      end do
      call build_families(self)
      self%ws_step_end = .false.
      self%ws_energy = .false.
      call constraints_setup(self)
   end procedure model_build_fast_path

   !> The node table: held nodes, and plain inertias whose own procedures agree
   !> at two probe states. The probe vectors are allocated and cleared once;
   !> each probe sets and clears only its node's own states (a node's
   !> procedures read only those), so the table is built in O(N).
   subroutine node_table(self)
      type(model_t), intent(inout) :: self
      integer :: i, nn
      real(wp) :: j, d
      logical :: plain
      real(wp), allocatable :: y(:), dydt(:)
      nn = size(self%nodes)
      if (allocated(self%fn)) deallocate (self%fn)
      allocate (self%fn(nn))
      allocate (y(max(self%n_y, 1)), dydt(max(self%n_y, 1)))
      y = 0.0_wp
      dydt = 0.0_wp
      do i = 1, nn
         self%fn(i)%off = self%nodes(i)%n%offset
         if (self%speed_of(i) /= 0) then
            self%fn(i)%kind = nk_held
            self%fn(i)%const_speed = self%speeds(self%speed_of(i))%is_constant()
            self%fn(i)%w = self%speeds(self%speed_of(i))%value(0.0_wp)
            self%fn(i)%theta0 = self%nodes(i)%n%theta0
            self%fn(i)%j = self%nodes(i)%n%inertia()
         else
            call self%nodes(i)%n%plain_inertia(plain, j, d)
            if (plain) plain = plain_node_agrees(self%nodes(i)%n, j, d, y, dydt)
            if (plain) then
               self%fn(i)%kind = nk_plain
               self%fn(i)%j = j
               self%fn(i)%d = d
            end if
         end if
      end do
   end subroutine node_table

   !> The element table: each element's nodes, its guards, and whether it is a
   !> linear spring whose own procedures agree (its form); its hot form (refresh_hot).
   subroutine element_table(self)
      type(model_t), intent(inout) :: self
      integer :: i
      real(wp) :: k, c, r1, r2
      logical :: lin
      do i = 1, size(self%elements)
         associate (e => self%elements(i)%e)
            self%fe(i)%l = e%left
            self%fe(i)%r = e%right
            self%fe(i)%ng = e%n_guards()
            if (self%fe(i)%ng > 0) self%n_norow = self%n_norow + 1   ! its row: not yet (form 0)
            call e%linear_spring(lin, k, c, r1, r2)
            if (lin) lin = linear_element_agrees(e, k, c, r1, r2) .and. e%n_ports() == 2
            self%fe(i)%linear = lin
            self%fe(i)%form = 0
            if (lin) then
               self%fe(i)%k = k; self%fe(i)%c = c; self%fe(i)%r1 = r1; self%fe(i)%r2 = r2
               self%fe(i)%form = lf_general
               if (c == 0.0_wp) self%fe(i)%form = lf_undamped
               if (c == 0.0_wp .and. r1 == 1.0_wp .and. r2 == 1.0_wp) self%fe(i)%form = lf_unit
            end if
            self%fe(i)%yl = 0
            self%fe(i)%yr = 0
            if (self%fn(e%left)%kind == nk_plain) self%fe(i)%yl = self%fn(e%left)%off + 1
            if (self%fn(e%right)%kind == nk_plain) self%fe(i)%yr = self%fn(e%right)%off + 1
         end associate
         call refresh_hot(self, i)
      end do
      self%guard_els = pack([(i, i=1, size(self%elements))], self%fe(:)%ng > 0)
   end subroutine element_table

   !> The load table: each load's node and, when constant, its value; a node
   !> whose loads are all constant starts each RHS from their sum (in load
   !> order, as summing them at t would); the loads on a node with a varying
   !> load are summed at t (dyn_loads); a load with a speed law (spd_loads) is
   !> summed at t and its node's speed, after them.
   subroutine load_table(self)
      type(model_t), intent(inout) :: self
      integer :: i, nl
      logical, allocatable :: varying(:)
      nl = size(self%loads)
      if (allocated(self%fl)) deallocate (self%fl)
      allocate (self%fl(nl), varying(size(self%nodes)))
      varying = .false.
      do i = 1, nl
         self%fl(i)%node = self%loads(i)%node
         self%fl(i)%const = self%loads(i)%torque%is_constant() .and. self%loads(i)%law%kind == law_none
         self%fl(i)%v = self%loads(i)%torque%value(0.0_wp)
         if (.not. self%fl(i)%const) varying(self%fl(i)%node) = .true.
      end do
      do i = 1, nl
         associate (nd => self%fn(self%fl(i)%node))
            if (.not. varying(self%fl(i)%node)) nd%load0 = nd%load0 + self%fl(i)%v
         end associate
      end do
      self%dyn_loads = pack([(i, i=1, nl)], [(varying(self%fl(i)%node) .and. self%loads(i)%law%kind == law_none, &
                                              i=1, nl)])
      self%spd_loads = pack([(i, i=1, nl)], [(self%loads(i)%law%kind /= law_none, i=1, nl)])
      self%loads_vary = size(self%dyn_loads) > 0 .or. size(self%spd_loads) > 0
   end subroutine load_table

   !> The families of the model (trainsim_model_families) from the node, element
   !> and load tables, in O(N): the kernels of a simple model evaluate them.
   !> Redone when an element leaves or joins the clearance family (its hot form
   !> appears or goes, refresh_hot).
   subroutine build_families(self)
      type(model_t), intent(inout) :: self
      integer :: i, q, nn, ne, ni, nr, inc0, nh2
      integer, allocatable :: sp(:), sd(:), ct(:), gen(:), free(:), held(:), ld(:), dmp(:), first(:), cnt(:)
      logical, allocatable :: two(:), one(:)
      logical, allocatable :: contact(:)
      nn = size(self%fn)
      ne = size(self%fe)
      allocate (contact(ne), cnt(nn), first(nn + 1))
      contact = .not. self%fe(:)%linear .and. self%fe(:)%form >= lf_open
      cnt = 0
      do i = 1, ne
         cnt(self%fe(i)%l) = cnt(self%fe(i)%l) + 1
         cnt(self%fe(i)%r) = cnt(self%fe(i)%r) + 1
      end do
      sp = pack([(i, i=1, ne)], self%fe(:)%linear .and. self%fe(:)%c == 0.0_wp)
      sd = pack([(i, i=1, ne)], self%fe(:)%linear .and. self%fe(:)%c /= 0.0_wp)
      ct = pack([(i, i=1, ne)], contact)
      gen = pack([(i, i=1, ne)], .not. (self%fe(:)%linear .or. contact))
      ! the undamped plain inertias with one, two element torques, then the others
      allocate (one(nn), two(nn))
      one = self%fn(:)%kind == nk_plain .and. self%fn(:)%d == 0.0_wp .and. cnt == 1
      two = self%fn(:)%kind == nk_plain .and. self%fn(:)%d == 0.0_wp .and. cnt == 2
      free = [pack([(i, i=1, nn)], one), pack([(i, i=1, nn)], two), &
              pack([(i, i=1, nn)], self%fn(:)%kind == nk_plain .and. .not. (one .or. two))]
      dmp = pack([(i, i=1, nn)], self%fn(:)%kind == nk_plain .and. self%fn(:)%d /= 0.0_wp)
      held = pack([(i, i=1, nn)], self%fn(:)%kind == nk_held .and. self%fn(:)%const_speed)
      ! in node order (their drive powers are summed in it): those with at most two
      ! element torques first if they come first, else all through their incidences
      nh2 = count(cnt(held) <= 2)
      if (.not. all(cnt(held(1:nh2)) <= 2)) nh2 = 0
      ld = pack([(i, i=1, size(self%fl))], [(self%fn(self%fl(i)%node)%kind /= nk_held, i=1, size(self%fl))])
      associate (f => self%fam)
         f%nn = nn
         f%ne = ne
         f%ns = self%n_states
         ! the tables one after another in iw and rw
         ni = 0
         nr = 0
         call place(f%springs, size(sp), spring_ni, spring_nr)
         call place(f%dampers, size(sd), spring_ni, spring_nr)
         call place(f%contacts, size(ct), contact_ni, contact_nr)
         f%c_open = table_t(size(ct), f%contacts%i0, f%contacts%r0)   ! (until set_contact_row moves them)
         f%c_ys = table_t(0, f%contacts%i0 + contact_ni*size(ct), f%contacts%r0 + contact_nr*size(ct))
         f%c_lin = f%c_ys
         call place(f%general, size(gen), 1, 0)
         call place(f%free, size(free), free_ni, free_nr)
         f%free2 = table_t(count(one) + count(two), f%free%i0, f%free%r0)
         f%free_n = table_t(f%free%n - f%free2%n, f%free%i0 + free_ni*f%free2%n, f%free%r0 + free_nr*f%free2%n)
         call place(f%damped, size(dmp), 1, 1)
         call place(f%held, size(held), held_ni, held_nr)
         f%held2 = table_t(nh2, f%held%i0, f%held%r0)
         f%held_n = table_t(f%held%n - f%held2%n, f%held%i0 + held_ni*f%held2%n, f%held%r0 + held_nr*f%held2%n)
         call place(f%loads, size(ld), load_ni, load_nr)
         inc0 = ni
         f%jn = nr
         if (allocated(f%iw)) deallocate (f%iw, f%rw)
         allocate (f%iw(ni + 2*ne), f%rw(nr + nn))
         f%rw(f%jn + 1:f%jn + nn) = self%fn(:)%j
         call spring_rows(f%springs, sp)
         call spring_rows(f%dampers, sd)
         f%contact_row = unpack([(q, q=1, size(ct))], contact, 0)
         f%iw(f%contacts%i0 + 1:f%contacts%i0 + contact_ni*size(ct)) = 0
         f%rw(f%contacts%r0 + 1:f%contacts%r0 + contact_nr*size(ct)) = 0.0_wp
         f%iw(f%contacts%i0 + 1:f%contacts%i0 + contact_ni*size(ct):contact_ni) = ct
         do q = 1, size(ct)
            call set_contact_row(self, ct(q))
         end do
         f%iw(f%general%i0 + 1:f%general%i0 + size(gen)) = gen
         do q = 1, size(ld)
            f%iw(f%loads%i0 + q) = self%fl(ld(q))%node
            f%rw(f%loads%r0 + q) = self%fl(ld(q))%v
         end do
         f%iw(f%damped%i0 + 1:f%damped%i0 + size(dmp)) = self%fn(dmp)%off
         f%rw(f%damped%r0 + 1:f%damped%r0 + size(dmp)) = self%fn(dmp)%d
         f%mixed = count([size(sd) > 0, size(ct) > 0, size(gen) > 0]) > 1 .or. size(ct) > 1
         ! the incidences: per node, its element torques in element order (left side first)
         first(1) = inc0 + 1
         do i = 1, nn
            first(i + 1) = first(i) + cnt(i)
         end do
         cnt = first(1:nn)
         do i = 1, ne
            f%iw(cnt(self%fe(i)%l)) = 2*i - 1
            cnt(self%fe(i)%l) = cnt(self%fe(i)%l) + 1
            f%iw(cnt(self%fe(i)%r)) = 2*i
            cnt(self%fe(i)%r) = cnt(self%fe(i)%r) + 1
         end do
         do q = 1, size(free)
            i = free(q)
            f%iw(f%free%i0 + free_ni*(q - 1) + 1:f%free%i0 + free_ni*q) = &
               [i, self%fn(i)%off, row_ends(f%iw, first(i), first(i + 1) - 1, ne, one(i) .or. two(i))]
            f%rw(f%free%r0 + free_nr*(q - 1) + 1:f%free%r0 + free_nr*q) = [self%fn(i)%j, self%fn(i)%d, self%fn(i)%load0]
         end do
         do q = 1, size(held)
            i = held(q)
            f%iw(f%held%i0 + held_ni*(q - 1) + 1:f%held%i0 + held_ni*q) = &
               [i, row_ends(f%iw, first(i), first(i + 1) - 1, ne, q <= f%held2%n)]
            f%rw(f%held%r0 + held_nr*(q - 1) + 1:f%held%r0 + held_nr*q) = [self%fn(i)%theta0, self%fn(i)%w, &
                                                                            self%fn(i)%load0]
         end do
         if (allocated(f%th)) deallocate (f%th, f%w, f%pw)
         allocate (f%th(nn), f%w(nn), f%pw(ne))
         f%th = 0.0_wp; f%w = 0.0_wp; f%pw = 0.0_wp
         call build_chain(f, self%fn, self%fe, self%simple)   ! (a serial chain's table, D-106)
      end associate
   contains

      !> The rows of the linear springs els.
      subroutine spring_rows(tab, els)
         type(table_t), intent(in) :: tab
         integer, intent(in) :: els(:)
         integer :: e
         do q = 1, size(els)
            e = els(q)
            self%fam%iw(tab%i0 + spring_ni*(q - 1) + 1:tab%i0 + spring_ni*q) = [e, self%fe(e)%l, self%fe(e)%r]
            self%fam%rw(tab%r0 + spring_nr*(q - 1) + 1:tab%r0 + spring_nr*q) = &
               [self%fe(e)%k, self%fe(e)%c, self%fe(e)%r1, self%fe(e)%r2]
         end do
      end subroutine spring_rows

      !> A table of n rows of ni integers and nr reals after those placed so far.
      subroutine place(tab, n, nic, nrc)
         type(table_t), intent(out) :: tab
         integer, intent(in) :: n, nic, nrc
         tab%n = n
         tab%i0 = ni
         tab%r0 = nr
         ni = ni + n*nic
         nr = nr + n*nrc
      end subroutine place
   end subroutine build_families

   !> Element i's row of the clearance family from its hot form (D-35), in the table of its
   !> law (open, closed yang_sun, closed linear: one after another in `contacts`). A row
   !> whose law changed moves there by swaps at the tables' borders, one at a time (D-75).
   subroutine set_contact_row(self, i)
      type(model_t), intent(inout) :: self
      integer, intent(in) :: i
      integer :: a, b, law, cur, p, n(3)
      logical :: closed
      associate (f => self%fam, h => self%fh(i))
         closed = h%kind /= hf_open
         law = 1
         if (h%kind == hf_yang_sun) law = 2
         if (h%kind == hf_linear) law = 3
         n = [f%c_open%n, f%c_ys%n, f%c_lin%n]
         p = f%contact_row(i)
         cur = 1
         if (p > n(1)) cur = 2
         if (p > n(1) + n(2)) cur = 3
         do while (cur < law)          ! to the next table: swap with the last row of this one
            call swap_rows(p, sum(n(1:cur)))
            n(cur) = n(cur) - 1
            n(cur + 1) = n(cur + 1) + 1
            cur = cur + 1
         end do
         do while (cur > law)          ! to the one before: swap with the first row of this one
            call swap_rows(p, sum(n(1:cur - 1)) + 1)
            n(cur) = n(cur) - 1
            n(cur - 1) = n(cur - 1) + 1
            cur = cur - 1
         end do
         f%c_open%n = n(1)
         f%c_ys = table_t(n(2), f%contacts%i0 + contact_ni*n(1), f%contacts%r0 + contact_nr*n(1))
         f%c_lin = table_t(n(3), f%c_ys%i0 + contact_ni*n(2), f%c_ys%r0 + contact_nr*n(2))
         a = f%contacts%i0 + contact_ni*(p - 1)
         b = f%contacts%r0 + contact_nr*(p - 1)
         f%iw(a + 1:a + contact_ni) = [i, self%fe(i)%l, self%fe(i)%r, merge(1, 0, h%no_tension .and. closed)]
         ! an open row: no force, and no stale parameter in the arithmetic (k = dmp = b = 0)
         f%rw(b + 1:b + contact_nr) = [h%s, h%c, merge(h%k, 0.0_wp, closed), merge(h%dmp, 0.0_wp, closed), &
                                       merge(h%b, 0.0_wp, closed), h%r1, h%r2]
      end associate
   contains

      !> Rows p and p2 of the clearance family exchanged (p follows its row).
      subroutine swap_rows(p, p2)
         integer, intent(inout) :: p
         integer, intent(in) :: p2
         integer :: a1, a2, b1, b2, iv(contact_ni)
         real(wp) :: rv(contact_nr)
         if (p == p2) return
         associate (f => self%fam)
            a1 = f%contacts%i0 + contact_ni*(p - 1)
            a2 = f%contacts%i0 + contact_ni*(p2 - 1)
            b1 = f%contacts%r0 + contact_nr*(p - 1)
            b2 = f%contacts%r0 + contact_nr*(p2 - 1)
            iv = f%iw(a1 + 1:a1 + contact_ni)
            f%iw(a1 + 1:a1 + contact_ni) = f%iw(a2 + 1:a2 + contact_ni)
            f%iw(a2 + 1:a2 + contact_ni) = iv
            rv = f%rw(b1 + 1:b1 + contact_nr)
            f%rw(b1 + 1:b1 + contact_nr) = f%rw(b2 + 1:b2 + contact_nr)
            f%rw(b2 + 1:b2 + contact_nr) = rv
            f%contact_row(f%iw(a1 + 1)) = p
            f%contact_row(f%iw(a2 + 1)) = p2
            p = p2
         end associate
      end subroutine swap_rows
   end subroutine set_contact_row

   !> The element's own `status` gives, bit for bit at two probe points, the
   !> displacement and force `rhs_simple` computes for its form of linear
   !> spring, contact 1 and pairs 0 (an element that records something else,
   !> e.g. a gear pair's force without its damping, is asked as before).
   logical function status_agrees(e, q) result(ok)
      class(element_t), intent(in) :: e
      type(fast_element_t), intent(in) :: q
      real(wp) :: x(4), disp, force, d, f
      integer :: p, contact, pairs
      ok = .true.
      do p = 1, 2
         x = [0.37_wp*p, -1.3_wp/p, -0.52_wp*p*p, 2.1_wp*p]   ! (times p**[1, -1, 2, 1]: p = 1, 2 scale exactly)
         call e%status(x(1), x(2), x(3), x(4), disp, force, contact, pairs)
         select case (q%form)
         case (lf_unit)
            d = x(1) - x(3)
            f = q%k*d
         case (lf_undamped)
            d = q%r1*x(1) - q%r2*x(3)
            f = q%k*d
         case default
            d = q%r1*x(1) - q%r2*x(3)
            f = q%k*d + q%c*(q%r1*x(2) - q%r2*x(4))
         end select
         ok = ok .and. disp == d .and. force == f .and. contact == 1 .and. pairs == 0
      end do
   end function status_agrees

   !> The node's own procedures give what a plain inertia (J, d) would, at
   !> two probe states in y (zero but for the node's own states, which are
   !> cleared again after each probe, as are its entries of dydt).
   logical function plain_node_agrees(nd, jj, dd, y, dydt) result(ok)
      class(node_t), intent(in) :: nd
      real(wp), intent(in) :: jj, dd
      real(wp), intent(inout) :: y(:), dydt(:)
      real(wp) :: th, om, w
      integer :: p, o
      ok = nd%nstates() == 2 .and. jj > 0.0_wp .and. dd >= 0.0_wp
      if (.not. ok) return
      o = nd%offset
      do p = 1, 2
         y(o + 1) = 0.37_wp*p
         y(o + 2) = -1.3_wp/p
         w = y(o + 2)
         call nd%derivatives(0.25_wp*p, y, 2.5_wp*p, dydt)
         call nd%kinematics(y, th, om)
         ok = ok .and. th == y(o + 1) .and. om == w .and. dydt(o + 1) == w &
              .and. close_to(dydt(o + 2), (2.5_wp*p - dd*w)/jj) &
              .and. close_to(nd%stored_energy(y), 0.5_wp*jj*w**2) &
              .and. close_to(nd%dissipation_power(y), dd*w**2) &
              .and. nd%input_power(0.25_wp*p, y) == 0.0_wp
         y(o + 1:o + 2) = 0.0_wp
         dydt(o + 1:o + 2) = 0.0_wp
      end do
   end function plain_node_agrees

   !> The element's own procedures give what a linear spring (k, c, r1, r2) would.
   logical function linear_element_agrees(e, kk, cc, rr1, rr2) result(ok)
      class(element_t), intent(in) :: e
      real(wp), intent(in) :: kk, cc, rr1, rr2
      real(wp) :: x(4), tl, tr, dl, dv, f
      integer :: p
      ok = e%n_guards() == 0 .and. .not. e%needs_loads .and. .not. e%supplies_power
      do p = 1, 2
         if (.not. ok) return
         x = [0.37_wp*p, -1.3_wp/p, -0.52_wp*p*p, 2.1_wp*p]   ! (times p**[1, -1, 2, 1]: p = 1, 2 scale exactly)
         call e%torques(x(1), x(2), x(3), x(4), tl, tr)
         dl = rr1*x(1) - rr2*x(3)
         dv = rr1*x(2) - rr2*x(4)
         f = kk*dl + cc*dv
         ok = close_to(tl, -rr1*f) .and. close_to(tr, rr2*f) &
              .and. close_to(e%potential_energy(x(1), x(3)), 0.5_wp*kk*dl**2) &
              .and. close_to(e%dissipation_power(x(1), x(2), x(3), x(4)), cc*dv**2)
      end do
   end function linear_element_agrees

   !> Equal to rounding (the claim and the procedure may order operations differently).
   pure logical function close_to(a, b)
      real(wp), intent(in) :: a, b
      close_to = abs(a - b) <= 1.0e-12_wp*max(abs(a), abs(b)) + tiny(1.0_wp)
   end function close_to

   module procedure model_init_modes
      integer :: i, l, r
      logical :: rebuild
      real(wp) :: dstored, yc(size(y))
      type(event_t), allocatable :: evs(:)
      integer :: nev
      rebuild = .true.
      if (present(tables)) rebuild = tables
      if (rebuild) call self%build_fast_path()   ! a copy may have been re-parameterised since finalize
      self%fe(:)%vouched = .false.   ! (each element's record probed again: D-167)
      call self%kinematics(t, y)
      do i = 1, size(self%elements)
         l = self%elements(i)%e%left
         r = self%elements(i)%e%right
         if (self%elements(i)%e%n_ports() > 2) then         ! an n-port element (D-73)
            call port_init_at(self%elements(i)%e, self%theta, self%omega)
         else
            call self%elements(i)%e%init_mode(self%theta(l), self%omega(l), self%theta(r), self%omega(r))
         end if
         call refresh_hot(self, i)
      end do
      if (self%n_cand > 0) then   ! the constraints of the initial modes, limits checked (D-81)
         yc = y; nev = 0
         allocate (evs(4))
         call constraints_settle(self, t, yc, evs, nev, dstored, .false.)
      end if
      self%energy0 = self%stored_energy(t, y)
      if (allocated(self%modes_at)) then   ! [t, y] (a constructor [t, y] costs 11 instructions an entry)
         if (size(self%modes_at) /= size(y) + 1) deallocate (self%modes_at)
      end if
      if (.not. allocated(self%modes_at)) allocate (self%modes_at(size(y) + 1))
      self%modes_at(1) = t
      self%modes_at(2:) = y
   end procedure model_init_modes

   module procedure model_preload_mode
      if (allocated(self%modes_at)) deallocate (self%modes_at)
      call self%elements(j)%e%preload_mode(face, thl, wl, thr, wr)
      call refresh_hot(self, j)
   end procedure model_preload_mode

   module procedure model_hot_kinds
      kind = self%fh(i)%kind
      guards = self%fe(i)%gform
      if (present(chain)) chain = self%fam%chain%n
   end procedure model_hot_kinds

   module procedure refresh_hot
      type(hot_form_t) :: h
      integer :: p, ng
      logical :: pe_ok, st_ok, in_family
      ! hot_pe is read only with energy tracking (ws_energy needs run%track_energy,
      ! which every run's init_modes refreshes with): without, it stays false
      pe_ok = self%run%track_energy
      st_ok = .true.
      associate (e => self%elements(i)%e, q => self%fe(i))
         call e%hot_form(h)
         if (q%linear .or. e%needs_loads .or. e%supplies_power) h%kind = hf_none
         if (self%nport) then
            if (e%n_ports() > 2) then                      ! the hot forms have two ports (D-73)
               h%kind = hf_none
               h%guards = hg_none
            end if
         end if
         ng = q%ng
         if (.not. ((h%guards == hg_faces .and. ng == 2) .or. (h%guards == hg_faces_zone .and. ng == 4))) &
            h%guards = hg_none
         ! the element's procedures against its record at three probe states, unless
         ! it vouches for its record in every mode and passed them before (D-167)
         if (h%exact .and. q%vouched .and. h%kind /= hf_none .and. h%guards /= hg_none) then
            st_ok = .true.
         else
            call hot_probe(e, h, ng, pe_ok, st_ok, q%vouched)
         end if
         self%fh(i) = h
         q%gform = h%guards
         q%hot_pe = pe_ok .and. h%kind /= hf_none
         q%hot_status = st_ok .and. h%kind /= hf_none
         if (.not. q%linear) then
            select case (h%kind)
            case (hf_open); q%form = lf_open
            case (hf_yang_sun); q%form = lf_yang_sun
            case (hf_linear); q%form = lf_cl_linear
            case default; q%form = 0
            end select
         end if
      end associate
      associate (q => self%gr(i), f => self%fe(i), h => self%fh(i))
         if (f%ng > 0 .and. q%form == 0) self%n_norow = self%n_norow - 1
         q%form = 0
         if (f%yl > 0 .and. f%yr > 0) then
            if (f%gform == hg_faces) q%form = 1
            if (f%gform == hg_faces_zone) q%form = 2
         end if
         if (f%ng > 0 .and. q%form == 0) self%n_norow = self%n_norow + 1
         q%o = 0
         if (allocated(self%guard_offset)) q%o = self%guard_offset(i)
         q%yl = f%yl; q%yr = f%yr; q%mode = h%mode; q%lo_open = h%lo_open
         q%r1 = h%r1; q%r2 = h%r2; q%b = h%b; q%th_lo = h%th_lo; q%th_hi = h%th_hi
      end associate
      if (allocated(self%ws_status)) call ws_flags(self, i)
      ! its row of the clearance family, in place (the family anew if it joins or leaves it)
      if (allocated(self%fam%contact_row)) then
         in_family = .not. self%fe(i)%linear .and. self%fe(i)%form >= lf_open
         if (in_family .neqv. self%fam%contact_row(i) > 0) then
            call build_families(self)
         else if (in_family) then
            p = self%fam%contact_row(i)   ! (its row before: another element's after a swap)
            call set_contact_row(self, i)
            call chain_laws(self%fam, i, p)
         end if
      end if
   end procedure refresh_hot

   !> Element i's entries of ws_status and el_contact, and whether its elastic
   !> energy is cold (kept in n_cold), from its current form (D-36).
   subroutine ws_flags(self, i)
      type(model_t), intent(inout) :: self
      integer, intent(in) :: i
      logical :: cold
      if (self%fe(i)%linear) then
         self%ws_status(i) = self%status_in_ws(i)
         self%el_contact(i) = 1
         cold = .false.
      else if (self%fe(i)%form >= lf_open) then
         self%ws_status(i) = self%simple .and. self%fe(i)%hot_status
         self%el_contact(i) = self%fh(i)%mode
         cold = .not. self%fe(i)%hot_pe
      else
         self%ws_status(i) = .false.
         self%el_contact(i) = 0
         cold = .true.
      end if
      if (cold .neqv. self%fe(i)%cold) then
         if (cold) then
            self%n_cold = self%n_cold + 1
         else
            self%n_cold = self%n_cold - 1
         end if
         self%fe(i)%cold = cold
      end if
   end subroutine ws_flags
end submodule trainsim_model_tables
