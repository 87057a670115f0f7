!> Local event steps of RK4 on a long train (submodule of trainsim_int_rk4,
!> docs/decisions.md D-32): when a guard fires in a step of a long train, the
!> step of the whole train stays unsplit and only the region L around the
!> event's element (`mr_begin`, submodule trainsim_rk4_region) is integrated
!> again through its events, with the states of its boundary B from the
!> unsplit step's dense output: `mr_continue` steps L to its next event
!> (`mr_locate`) or to the step's end.
submodule(trainsim_int_rk4) trainsim_rk4_local
   implicit none

contains

   !> A local event instant (see integrator_t%local_instant): the event just
   !> returned is inside a local event step that goes on (L's states are
   !> integration points at t, every other state an interpolation of the
   !> unsplit step; no guard outside L's guard elements is below zero there).
   logical module function rk4_local_instant(self, nodes, states, els, gels) result(local)
      class(rk4_t), intent(in), target :: self
      integer, pointer, contiguous, intent(out) :: nodes(:), states(:), els(:), gels(:)
      local = self%at_local .and. self%mr_on
      if (local) then
         nodes => self%l_nodes(1:self%n_l)
         states => self%sl(1:self%n_sl)
         els => self%in_els(1:self%n_in)
         gels => self%gels(1:self%n_gels)
      else
         nodes => null(); states => null(); els => null(); gels => null()
      end if
   end function rk4_local_instant

   !> The guard elements outside L whose guards may be below zero somewhere on
   !> the unsplit step's dense output, into far(1:n_far): all but those whose
   !> guards read two angles (`guard_angles`) and stay above zero for any
   !> angles within the dense output's reach over the whole step
   !> (`guard_floor`). The dense output of a state is y0 + h (b1 k1 + b2 (d2 +
   !> d3) + b4 d4) with 0 <= b1 <= 5/24, 0 <= b2 <= 1/3, -1/24 <= b4 <= 1/6 on
   !> [0, 1]: within y0 +- h (0.21 |k1| + 0.34 (|d2| + |d3|) + 0.17 |d4|). The
   !> check at an instant is then that of every outside element, as the skipped
   !> ones cannot be below zero there.
   subroutine mr_far_list(self, model)
      type(rk4_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      integer :: j, ne, il, ir
      real(wp) :: rl, rr
      self%n_far = 0
      self%far_done = .true.
      do j = 1, self%ng
         ne = self%g_el(j)
         if (self%gel_in(ne) .or. self%g_loc(j) /= 1) cycle
         call model%guard_angles(ne, il, ir)
         if (il > 0) then
            rl = self%mh*(0.21_wp*abs(self%mk1(il)) + 0.34_wp*(abs(self%md2(il)) + abs(self%md3(il))) + &
                          0.17_wp*abs(self%md4(il)))
            rr = self%mh*(0.21_wp*abs(self%mk1(ir)) + 0.34_wp*(abs(self%md2(ir)) + abs(self%md3(ir))) + &
                          0.17_wp*abs(self%md4(ir)))
            if (model%guard_floor(ne, self%my0(il), rl, self%my0(ir), rr) > 0.0_wp) cycle
         end if
         self%n_far = self%n_far + 1
         self%far(self%n_far) = ne
      end do
   end subroutine mr_far_list

   !> Inside a local event step (t = mt_c, L's states in y at t): step L to
   !> the end of the unsplit step, or to L's next event. At an event, (t, y)
   !> is the located time with L's states from its own steps and every other
   !> state from the unsplit step's dense output (for the driver's use at the
   !> instant: the observer, the mode update; the step still ends with the
   !> unsplit values outside L). At the end, y is the unsplit step's end
   !> outside L and L's own inside; the energy states are the unsplit step's
   !> with L's terms replaced by L's own (and the driver's bookings at the
   !> events added). done is false (and the local step dropped) when the
   !> driver asks for something else than the rest of this step.
   module subroutine rk4_mr_continue(self, model, t_goal, t, y, status, done)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t_goal
      real(wp), intent(inout) :: t, y(:)
      integer, intent(out) :: status
      logical, intent(out) :: done
      integer :: q, nst
      logical :: track, far_fired
      done = .false.
      status = adv_step
      nst = model%n_states
      if (abs(t - self%mt_c) > self%tiny_t .or. t_goal < self%mt1 - self%tiny_t) then
         self%mr_on = .false.
         self%mr_collapses = self%mr_collapses + 1
         if (self%y_partial) call mr_shown(self, y, nst, self%mt_c)   ! the state shown at the last event becomes the state
         self%y_partial = .false.
         return
      end if
      self%y_partial = .false.
      done = .true.
      track = model%run%track_energy
      if (track .and. self%mt_c > self%mt0) self%e_book = self%e_book + (y(nst + 1:nst + 2) - self%e_shown)
      self%pw_full = 0.0_wp
      if (self%mt1 - self%mt_c > self%tiny_t) then
         call mr_rest(self, model, y, far_fired)
         if (far_fired) then
            ! an event of L inside the rest of the step
            call mr_event(self, model, t, y, track)
            status = adv_event
            return
         end if
      else
         do q = 1, self%n_sl
            self%ynew(self%sl(q)) = y(self%sl(q))
         end do
      end if
      call mr_end(self, model, t, y, track)
      status = adv_step
      if (t >= t_goal - self%tiny_t) status = adv_reached
   end subroutine rk4_mr_continue

   !> L's step from mt_c to the end of the unsplit step (its dense output: k1,
   !> d2..d4; its end in ynew), and the guards of L's guard elements at its end
   !> (in g1): fired when one is below zero.
   subroutine mr_rest(self, model, y, fired)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:)
      logical, intent(out) :: fired
      real(wp), allocatable :: swap(:)
      integer :: q, k, j, ne
      self%t_loc = self%mt_c
      self%h_loc = self%mt1 - self%mt_c
      do q = 1, self%n_sl
         self%yc(self%sl(q)) = y(self%sl(q))
      end do
      call self%mr_bnd(self%yc, self%mt_c)
      if (self%mt_c == self%mt0) then
         ! at the start of the step: L's part of the unsplit step's k1 (the same
         ! state, modes and sums: bit for bit) and of its energy rates
         do q = 1, self%n_sl
            self%k1(self%sl(q)) = self%mk1(self%sl(q))
         end do
         self%pk1 = self%pr(:, 1)
      else
         call self%mr_rhs(model, self%mt_c, self%yc, self%k1, self%pk1)
      end if
      call self%mr_step(model, y, self%h_loc)
      self%pw_full = self%pw_step
      call move_alloc(self%ys, swap); call move_alloc(self%ynew, self%ys); call move_alloc(swap, self%ynew)
      call move_alloc(self%k2, swap); call move_alloc(self%d2, self%k2); call move_alloc(swap, self%d2)
      call move_alloc(self%k3, swap); call move_alloc(self%d3, self%k3); call move_alloc(swap, self%d3)
      call move_alloc(self%k4, swap); call move_alloc(self%d4, self%k4); call move_alloc(swap, self%d4)
      fired = .false.
      do k = 1, self%n_gels
         ne = self%gels(k)
         call model%element_guards(ne, self%mt1, self%ynew, self%ge)
         do j = 1, model%elements(ne)%e%n_guards()
            self%g1(model%guard_offset(ne) + j) = self%ge(j)
            if (self%ge(j) < 0.0_wp) fired = .true.
         end do
      end do
   end subroutine mr_rest

   !> An event of L in the rest of the step: locate it, and show the state at
   !> the instant (t, y): L's own states, the rest from the unsplit step's
   !> dense output (with region_instants only the energy states; the rest when
   !> the step ends), the energy states with L's terms replaced by L's own. A
   !> guard outside L below zero there (it dips inside the step) ends the local
   !> step: the state shown becomes the state.
   subroutine mr_event(self, model, t, y, track)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(inout) :: t, y(:)
      logical, intent(in) :: track
      real(wp) :: s_ev, th, b1, b2, b4, hh
      integer :: q, i, k, j, ne, nst
      nst = model%n_states
      s_ev = self%mr_locate(model, y)
      if (track) call self%mr_step(model, y, s_ev)   ! its energy integral (ys unchanged: the same step)
      t = self%mt_c + s_ev
      ! the state at the instant: the unsplit step's dense output, L's own
      th = (t - self%mt0)/self%mh
      b1 = th*(1.0_wp - th*(1.5_wp - th*(2.0_wp/3.0_wp)))
      b2 = th*th*(1.0_wp - th*(2.0_wp/3.0_wp))
      b4 = th*th*(-0.5_wp + th*(2.0_wp/3.0_wp))
      hh = self%mh
      if (self%region_instants) then
         ! L's states (and the energy states); the rest when the step ends
         do i = nst + 1, size(y)
            y(i) = self%my0(i) + hh*(b1*self%mk1(i) + b2*(self%md2(i) + self%md3(i)) + b4*self%md4(i))
         end do
         self%y_partial = .true.
      else
         do i = 1, size(y)
            y(i) = self%my0(i) + hh*(b1*self%mk1(i) + b2*(self%md2(i) + self%md3(i)) + b4*self%md4(i))
         end do
      end if
      do q = 1, self%n_sl
         y(self%sl(q)) = self%ys(self%sl(q))
      end do
      if (track) then
         y(nst + 1:nst + 2) = y(nst + 1:nst + 2) - hh*(b1*self%pr(:, 1) + b2*(self%pr(:, 2) + self%pr(:, 3)) + &
                              b4*self%pr(:, 4)) + self%e_acc + self%pw_step + self%e_book
         self%e_acc = self%e_acc + self%pw_step
         self%e_shown = y(nst + 1:nst + 2)
      end if
      self%mt_c = t
      self%mr_events = self%mr_events + 1
      self%stats%root_returns = self%stats%root_returns + 1
      ! a guard outside L below zero on the dense output (it dips inside the
      ! step): the state shown becomes the state, the local step ends here
      if (self%y_partial) then
         ! the guard elements outside L (none has a node in L) that may be
         ! below zero on the dense output: their nodes' states there, their guards
         if (.not. self%far_done) call mr_far_list(self, model)
         do j = 1, self%n_far
            ne = self%far(j)
            do k = 1, 3, 2
               do i = self%el_states(k, ne), self%el_states(k + 1, ne)
                  y(i) = self%my0(i) + hh*(b1*self%mk1(i) + b2*(self%md2(i) + self%md3(i)) + b4*self%md4(i))
               end do
            end do
            call model%element_guards(ne, t, y, self%ge)
            if (any(self%ge(1:model%elements(ne)%e%n_guards()) < 0.0_wp)) then
               self%mr_on = .false.
               self%mr_collapses = self%mr_collapses + 1
               call mr_shown(self, y, nst, t)
               self%y_partial = .false.
               exit
            end if
         end do
      else
         call model%guards(t, y, self%gs)
         do j = 1, self%ng
            if (self%gs(j) < 0.0_wp .and. .not. self%gel_in(self%g_el(j))) then
               self%mr_on = .false.
               self%mr_collapses = self%mr_collapses + 1
               exit
            end if
         end do
      end if
      self%at_local = self%mr_on
   end subroutine mr_event

   !> The end of the local event step (t, y): outside L the unsplit step's, L
   !> its own (assembled in mynew, which then becomes ynew: the step's end, as
   !> after a plain step), and the RHS there.
   subroutine mr_end(self, model, t, y, track)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(inout) :: t, y(:)
      logical, intent(in) :: track
      real(wp), allocatable :: swap(:)
      integer :: q, nst
      nst = model%n_states
      do q = 1, self%n_sl
         self%mynew(self%sl(q)) = self%ynew(self%sl(q))
      end do
      if (track) self%mynew(nst + 1:nst + 2) = self%mynew(nst + 1:nst + 2) - (self%mh/6.0_wp)*(self%pr(:, 1) + &
                                               2.0_wp*(self%pr(:, 2) + self%pr(:, 3)) + self%pr(:, 4)) + self%e_acc + &
                                               self%pw_full + self%e_book
      y = self%mynew
      call move_alloc(self%ynew, swap); call move_alloc(self%mynew, self%ynew); call move_alloc(swap, self%mynew)
      self%mr_on = .false.
      t = self%mt1
      if (t >= self%mt_grid - self%tiny_t) then
         t = self%mt_grid
         call self%count_grid_step()
      end if
      ! the RHS at the step's end, as after a plain step (`advance`): the next
      ! step's first stage, and the workspace the observer reads (its short way)
      call model%rhs_step_end(t, y, self%k1)
      self%stats%rhs_evals = self%stats%rhs_evals + 1
      model%ws_step_end = .true.
      self%k1_next = .true.
      self%t_k1 = t
   end subroutine mr_end

   !> The states outside L at tt (in the unsplit step) into y, from the
   !> unsplit step's dense output: the whole state shown at a local event
   !> instant (L's states and the energy states, after nst, are kept).
   subroutine mr_shown(self, y, nst, tt)
      class(rk4_t), intent(inout) :: self
      real(wp), intent(inout) :: y(:)
      integer, intent(in) :: nst
      real(wp), intent(in) :: tt
      real(wp) :: c1, c2, c4, w
      integer :: p
      do p = 1, self%n_sl
         self%yc(self%sl(p)) = y(self%sl(p))
      end do
      w = (tt - self%mt0)/self%mh
      c1 = w*(1.0_wp - w*(1.5_wp - w*(2.0_wp/3.0_wp)))
      c2 = w*w*(1.0_wp - w*(2.0_wp/3.0_wp))
      c4 = w*w*(-0.5_wp + w*(2.0_wp/3.0_wp))
      do p = 1, nst
         y(p) = self%my0(p) + self%mh*(c1*self%mk1(p) + c2*(self%md2(p) + self%md3(p)) + c4*self%md4(p))
      end do
      do p = 1, self%n_sl
         y(self%sl(p)) = self%yc(self%sl(p))
      end do
   end subroutine mr_shown

   !> L's earliest event in its step from (t_loc, y) (guards g1 at its end):
   !> as `end_on_event`, on L's step map and dense output, for L's guard
   !> elements. Returns the step to it; ys = L's step to it.
   real(wp) module function rk4_mr_locate(self, model, y) result(s_ev)
      class(rk4_t), intent(inout) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:)
      real(wp) :: sj, gd, h
      integer :: k, j, jb, jl, pass, ne, jj, o
      h = self%h_loc
      ! the guards at t_loc (L's state, B's from the unsplit step: in yc)
      do k = 1, self%n_gels
         ne = self%gels(k)
         o = model%guard_offset(ne)
         call model%element_guards(ne, self%t_loc, self%yc, self%ge)
         self%g0(o + 1:o + model%elements(ne)%e%n_guards()) = self%ge(1:model%elements(ne)%e%n_guards())
      end do
      jb = 0
      s_ev = h
      do k = 1, self%n_gels
         ne = self%gels(k)
         o = model%guard_offset(ne)
         do jj = 1, model%elements(ne)%e%n_guards()
            j = o + jj
            if (.not. self%g1(j) < 0.0_wp) cycle
            sj = self%dense_root(model, y, j, max(self%g0(j), 0.0_wp), h, self%g1(j))
            if (jb == 0 .or. sj < s_ev) then
               s_ev = sj
               jb = j
            end if
         end do
      end do
      s_ev = self%refine(model, y, jb, s_ev, max(self%g0(jb), 0.0_wp), h, self%g1(jb))
      ! another guard of L below zero there may have crossed earlier still
      do pass = 1, self%ng
         jl = jb
         jb = 0
         outer: do k = 1, self%n_gels
            ne = self%gels(k)
            o = model%guard_offset(ne)
            call model%element_guards(ne, self%t_loc + s_ev, self%ys, self%ge)
            do jj = 1, model%elements(ne)%e%n_guards()
               j = o + jj
               self%gs(j) = self%ge(jj)
               if (j == jl .or. .not. self%gs(j) < 0.0_wp) cycle
               gd = self%dense_guard(model, y, j, s_ev)
               if (.not. gd < 0.0_wp) gd = self%gs(j)
               sj = self%dense_root(model, y, j, max(self%g0(j), 0.0_wp), s_ev, gd)
               if (sj < s_ev - self%event_tol) then
                  jb = j
                  exit outer
               end if
            end do
         end do outer
         if (jb == 0) exit
         s_ev = self%refine(model, y, jb, sj, max(self%g0(jb), 0.0_wp), s_ev, self%gs(jb))
      end do
   end function rk4_mr_locate
end submodule trainsim_rk4_local
