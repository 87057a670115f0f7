!> The period map of a train under periodic forcing (issue 27): from a state x0
!> at the forcing phase t0, integrate k forcing periods T with the deck's own
!> integrator, events located and modes updated as in a run (a session,
!> trainsim_session), and return the state there.
!>
!> The state of a rotating train is not periodic in its absolute angles: the
!> map works on the reduced state (D-99, shoot27). x has the layout of the
!> model's physical states y(1:n_states) (the energy integrals are left out);
!> each free node's angle is taken relative to the rigid rotation of the
!> train,
!>     x_a(t) = theta_i(t) - W_i (t - t0),
!> where W_i is node i's speed when the train turns rigidly at the mean speed
!> of its first node with a prescribed motion over the k periods (the
!> elements' closed speed ratios, `rigid_speeds`); with no such node, or for a
!> node it does not reach, W_i = 0 (absolute angles). Speeds and every other
!> state (a motor's current) are taken as they are. At t0 the reduced state is
!> the state itself, so a fixed point x* of the map is a point of the periodic
!> orbit at t0; a gear's mesh position advances by a whole pitch per mesh
!> period at the rigid speed, so the forcing it sees repeats.
!>
!> Element memory (D-150): the yang_sun law's damping D (with e and V_i) is
!> fixed by the impact that closed a contact and kept while it lasts: state
!> outside y (`clearance_element_t%get_memory`). The map carries it as a
!> parameter `mem` given with x at t0: every integration from a state at t0
!> holds it on the session's model before the modes are chosen, so a contact
!> closed at t0 goes on with it (not with the law's start, D-13). Where every
!> such contact opens within the period, t0 is moved into an open stretch
!> (`rephase`) and the map does not depend on mem; a contact that never opens
!> keeps its D over the whole orbit, which is then one of a family of orbits
!> (one per D, a multiplier at 1 if D were an unknown): mem is the family's
!> parameter, taken from the start state (the transient's end: `map` with
!> `carry` hands the memory on as a continuous run does).
module trainsim_period_map
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_model, only: model_t, rigid_speeds, run_settings_t
   use trainsim_session, only: session_t, session_state_t
   use trainsim_derived, only: mesh_frequency_of
   use trainsim_clearance_element, only: clearance_element_t
   implicit none
   private

   public :: period_map_t, forcing_period

   real(wp), parameter :: two_pi = 6.283185307179586476925286766559_wp

   type :: period_map_t
      real(wp) :: t0 = 0.0_wp          !< the forcing phase (the deck's t_start)
      real(wp) :: period = 0.0_wp      !< the forcing period T (s)
      integer :: k = 1                 !< periods per map
      integer :: n = 0                 !< size of the reduced state
      integer, allocatable :: ang(:)   !< the state indices of the free nodes' angles
      integer, allocatable :: spd(:)   !< and of their speeds
      integer, allocatable :: ang_node(:)   !< the node of each angle
      real(wp), allocatable :: w(:)    !< per angle: the rigid speed W_i (rad/s)
      real(wp), allocatable :: y0(:)   !< the deck's initial state (the energy integrals' start)
      integer :: n_evals = 0           !< maps evaluated (periods integrated: n_periods)
      integer :: n_periods = 0
      type(session_t), allocatable :: s
      type(session_state_t) :: p0      !< the session's point at t0
      type(model_t) :: model           !< the deck's model (a new t0: set up again)
      !> the clearances whose contact law remembers its impact (yang_sun: e and D
      !> from the approach velocity), which must be open at t0 (D-99)
      integer, allocatable :: memory(:)
      !> their memory at t0 (D-150), element after element (`get_memory`'s layout),
      !> and at the end of the last map (the flow's own)
      real(wp), allocatable :: mem(:), mem_end(:)
      !> per element of `memory`: its memory is held at t0 (a contact that never opens,
      !> or not yet known: the transient); false for one that opens in the period (t0
      !> is then moved into an open stretch, and a contact that drifts onto t0 along a
      !> branch starts as a run's does, D-99, until the next `rephase`)
      logical, allocatable :: kept(:)
      logical :: lost = .false.   !< the last map changed a kept memory (`memory_lost`)
      !> multiple shooting (set_segments): the boundaries in s after t0 (0 and kT the
      !> ends), the session's point at each, and the flow's reduced states there
      real(wp), allocatable :: seg_tau(:)
      type(session_state_t), allocatable :: seg_p(:)
      real(wp), allocatable :: seg_x(:, :)
      real(wp), allocatable :: seg_mem(:, :)   !< and the memory at each boundary
   contains
      procedure :: setup => pm_setup
      procedure :: map => pm_map
      procedure :: initial => pm_initial
      procedure :: scale => pm_scale
      procedure :: full_state => pm_full_state
      procedure :: finish => pm_finish
      procedure :: flow => pm_flow
      procedure :: rephase => pm_rephase
      procedure :: open_samples => pm_open_samples
      procedure :: set_segments => pm_set_segments
      procedure :: segment => pm_segment
      procedure :: hold_memory => pm_hold_memory
      procedure :: memory_of => pm_memory_of
      procedure :: memory_lost => pm_memory_lost
   end type period_map_t

contains

   !> The forcing period of a deck: &run settle_period if given, else the mesh
   !> period at t_start of the first gear pair with teeth (as settling takes
   !> it, D-44), else the period of the first sine load. err_input if none.
   subroutine forcing_period(model, period, err)
      type(model_t), intent(in) :: model
      real(wp), intent(out) :: period
      type(error_t), allocatable, intent(out) :: err
      integer :: ie, l
      real(wp) :: f
      period = model%run%settle_period
      if (period > 0.0_wp) return
      do ie = 1, size(model%elements)
         f = mesh_frequency_of(model, ie)
         if (f > 0.0_wp) then
            period = 1.0_wp/f
            return
         end if
      end do
      do l = 1, size(model%loads)
         if (model%loads(l)%torque%omega > 0.0_wp) then   ! (a sine: the only signal with a frequency)
            period = two_pi/model%loads(l)%torque%omega
            return
         end if
      end do
      call fatal_error(err, 'no forcing period: give &run settle_period (s), or a gear pair with teeth turning at '// &
                       't_start (its mesh period), or a sine load (its period)', err_input)
   end subroutine forcing_period

   !> Set the map up for `model` (prepared as for a run), forcing period `period`, k
   !> periods per map: the reduced state's layout, the rigid speeds, a session at t0;
   !> the memory the deck's start (the law's), or with `keep_memory` the map's own
   !> (a new t0 or parameter of the same orbit or branch, D-150). `step_checked`: the
   !> caller vouches that the fixed-step check passed on a model that differs from
   !> this one in nothing it reads (D-163); the session then skips it.
   subroutine pm_setup(self, model, period, k, err, keep_memory, step_checked)
      class(period_map_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: period
      integer, intent(in) :: k
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: keep_memory, step_checked
      logical :: keep
      type(run_settings_t) :: deck_run
      real(wp), allocatable :: w(:)
      logical, allocatable :: known(:)
      integer :: i, na, loop_el, ref, s
      real(wp) :: w_ref
      if (.not. (period > 0.0_wp .and. k >= 1)) then
         call fatal_error(err, 'the forcing period must be > 0 s and the period count >= 1 (got '//str(period)// &
                          ' s, '//str(k)//')', err_input)
         return
      end if
      self%period = period
      self%k = k
      if (allocated(self%s)) call self%finish()
      if (allocated(self%ang)) deallocate (self%ang, self%spd, self%ang_node, self%w)
      self%model = model
      self%memory = memory_elements(model)
      ! the session's run: to t0 + kT, nothing kept (set on the map's own copy while the
      ! session starts, then the deck's run back: one model copy fewer a set-up, D-163)
      associate (m => self%model)
      deck_run = m%run
      self%t0 = m%run%t_start
      m%run%t_end = self%t0 + real(k, wp)*period*(1.0_wp + 1.0e-9_wp)
      m%run%keep_events = .false.
      m%run%keep_series = .false.
      m%run%settle_tol = 0.0_wp
      m%run%output = ''
      self%n = m%n_states
      ! the free nodes' angles and speeds
      na = 0
      do i = 1, size(m%nodes)
         if (m%speed_of(i) == 0 .and. m%nodes(i)%n%nstates() >= 2) na = na + 1
      end do
      allocate (self%ang(na), self%spd(na), self%ang_node(na), self%w(na))
      na = 0
      do i = 1, size(m%nodes)
         if (m%speed_of(i) == 0 .and. m%nodes(i)%n%nstates() >= 2) then
            na = na + 1
            self%ang(na) = m%nodes(i)%n%offset + 1
            self%spd(na) = m%nodes(i)%n%offset + 2
            self%ang_node(na) = i
         end if
      end do
      ! the rigid rotation: from the first node with a prescribed motion, at its mean speed
      self%w = 0.0_wp
      ref = 0
      do i = 1, size(m%nodes)
         if (m%speed_of(i) /= 0) then
            ref = i
            exit
         end if
      end do
      if (ref > 0) then
         s = m%speed_of(ref)
         w_ref = (m%speeds(s)%integral(self%t0 + real(k, wp)*period) - m%speeds(s)%integral(self%t0))/ &
                 (real(k, wp)*period)
         call rigid_speeds(m, ref, w_ref, w, known, loop_el)
         do i = 1, na
            if (known(self%ang_node(i))) self%w(i) = w(self%ang_node(i))
         end do
      end if
      call m%initial_state(self%y0)
      allocate (self%s)
      ! (the map reads states only: no static reference, D-131)
      call self%s%start(m, err, reference=.false., step_checked=step_checked)
      m%run = deck_run
      end associate
      if (allocated(err)) return
      call self%s%save(self%p0, err, defer=.true.)   ! (every use restores it first, D-186)
      ! the memory: kept across a new t0 or parameter (rephase, a branch's next lambda), else the deck's start
      keep = .false.
      if (present(keep_memory)) keep = keep_memory
      if (keep) keep = allocated(self%mem) .and. allocated(self%kept) .and. allocated(self%mem_end)
      if (keep) keep = size(self%mem) == size(self%memory_of(self%s%model)) .and. size(self%kept) == size(self%memory)
      if (.not. keep) then
         self%mem = self%memory_of(self%s%model)
         self%kept = spread(.true., 1, size(self%memory))
         self%mem_end = self%mem
         self%lost = .false.
      end if
   end subroutine pm_setup

   !> The deck's initial state, reduced (at t0: the state itself).
   function pm_initial(self) result(x)
      class(period_map_t), intent(in) :: self
      real(wp) :: x(self%n)
      x = self%y0(1:self%n)
   end function pm_initial

   !> The full state y at t0 of the reduced state x (the energy integrals as at the start).
   function pm_full_state(self, x) result(y)
      class(period_map_t), intent(in) :: self
      real(wp), intent(in) :: x(:)
      real(wp) :: y(size(self%y0))
      y = self%y0
      y(1:self%n) = x
   end function pm_full_state

   !> x1 = P^j(x0): the reduced state `periods` forcing periods (default k) after the
   !> reduced state x0 at t0 with the memory mem; mem_end the memory there. With
   !> `carry` mem becomes mem_end (a transient: the memory goes on as in a run).
   subroutine pm_map(self, x0, x1, err, periods, carry)
      class(period_map_t), intent(inout) :: self
      real(wp), intent(in) :: x0(:)
      real(wp), intent(out) :: x1(:)
      type(error_t), allocatable, intent(out) :: err
      integer, intent(in), optional :: periods
      logical, intent(in), optional :: carry
      integer :: j, np
      real(wp) :: t1
      np = self%k
      if (present(periods)) np = periods
      x1 = x0
      self%mem_end = self%mem
      do j = 1, np, self%k
         ! a chunk of k periods from t0 (the forcing repeats): restore, set, advance
         call self%s%restore(self%p0, err, defer=.true.)   ! (set_state starts the integrator, D-186)
         if (allocated(err)) return
         call self%hold_memory(self%s%model, self%mem_end)   ! (the memory the last chunk ended with)
         call self%s%set_state(self%full_state(x1), err)
         if (allocated(err)) return
         t1 = self%t0 + real(min(self%k, np - j + 1), wp)*self%period
         call self%s%advance(t1, err)
         if (allocated(err)) return
         x1 = self%s%y(1:self%n)
         x1(self%ang) = x1(self%ang) - self%w*(t1 - self%t0)
         self%mem_end = self%memory_of(self%s%model)
         self%n_periods = self%n_periods + min(self%k, np - j + 1)
      end do
      self%lost = changed(self)
      if (present(carry)) then
         if (carry) self%mem = self%mem_end
      end if
      self%n_evals = self%n_evals + 1
   contains
      logical function changed(pm)
         class(period_map_t), intent(in) :: pm
         integer :: i
         changed = .false.
         do i = 1, size(pm%memory)   ! (3 values an element: memory_size of yang_sun)
            if (pm%kept(i)) changed = changed .or. any(pm%mem_end(3*i - 2:3*i) /= pm%mem(3*i - 2:3*i))
         end do
      end function changed
   end subroutine pm_map

   !> The scale of each component of the reduced state x (D-99): one for every speed,
   !> the largest |speed| of x (at least the largest |W|); one for every angle, that
   !> speed scale times T/(2 pi) (the angle a speed of that size turns per radian of
   !> the forcing phase; a harmonic motion's amplitude from its speed amplitude);
   !> every other state its own magnitude (at least 1e-12 of the speed scale). At rest
   !> (every speed of x and every W zero) the speed scale is 2 pi/(kT), so that the
   !> angles' is one radian (a scale of zero would divide by zero).
   function pm_scale(self, x) result(sc)
      class(period_map_t), intent(in) :: self
      real(wp), intent(in) :: x(:)
      real(wp) :: sc(self%n)
      real(wp) :: sw
      sw = 0.0_wp
      if (size(self%spd) > 0) sw = max(maxval(abs(x(self%spd))), maxval(abs(self%w)))
      if (.not. sw > 0.0_wp) sw = two_pi/(real(self%k, wp)*self%period)
      sc = max(abs(x), 1.0e-12_wp*sw, tiny(1.0_wp))
      sc(self%spd) = sw
      sc(self%ang) = sw*real(self%k, wp)*self%period/two_pi
   end function pm_scale

   !> The elements with a memory (D-150): of the registry's elements only the
   !> clearance elements' yang_sun law keeps state outside y that the motion
   !> depends on (`memory_size` > 0); the other modes (faces, zones, stick or
   !> slip, a lossy gear's power flow) follow from the state at t0.
   function memory_elements(model) result(list)
      type(model_t), intent(in) :: model
      integer, allocatable :: list(:)
      integer :: e
      allocate (list(0))
      do e = 1, size(model%elements)
         select type (el => model%elements(e)%e)
         class is (clearance_element_t)
            if (el%memory_size() > 0) list = [list, e]
         end select
      end do
   end function memory_elements

   !> The memory of the elements `memory` of `model`, one after another.
   function pm_memory_of(self, model) result(mem)
      class(period_map_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(wp), allocatable :: mem(:)
      real(wp) :: one(3)
      integer :: i, n
      allocate (mem(0))
      do i = 1, size(self%memory)
         select type (el => model%elements(self%memory(i))%e)
         class is (clearance_element_t)
            n = el%memory_size()
            call el%get_memory(one(1:n))
            mem = [mem, one(1:n)]
         end select
      end do
   end function pm_memory_of

   !> Whether the last map ended with another memory than it held for a contact
   !> taken to stay closed (`kept`): that contact opened and closed again within the
   !> period (an impact set its D), so the orbit is no longer one of the family at
   !> mem, and t0 must move into an open stretch (`rephase`, which then stops holding it).
   logical function pm_memory_lost(self) result(lost)
      class(period_map_t), intent(in) :: self
      lost = self%lost
   end function pm_memory_lost

   !> Hold `mem` (default the map's) on the elements of `model` that keep it (`kept`,
   !> set_memory): a contact closed when its modes are next chosen from a state goes
   !> on with it.
   subroutine pm_hold_memory(self, model, mem)
      class(period_map_t), intent(in) :: self
      type(model_t), intent(inout) :: model
      real(wp), intent(in), optional :: mem(:)
      integer :: i, n, at
      at = 0
      do i = 1, size(self%memory)
         select type (el => model%elements(self%memory(i))%e)
         class is (clearance_element_t)
            n = el%memory_size()
            if (.not. self%kept(i)) then
               at = at + n
               cycle
            end if
            if (present(mem)) then
               call el%set_memory(mem(at + 1:at + n))
            else
               call el%set_memory(self%mem(at + 1:at + n))
            end if
            at = at + n
         end select
      end do
   end subroutine pm_hold_memory

   !> The full state y at t0 + tau (0 <= tau <= k T) from the reduced state x at t0.
   subroutine pm_flow(self, x, tau, y, err)
      class(period_map_t), intent(inout) :: self
      real(wp), intent(in) :: x(:), tau
      real(wp), intent(out) :: y(:)
      type(error_t), allocatable, intent(out) :: err
      call self%s%restore(self%p0, err, defer=.true.)
      if (allocated(err)) return
      call self%hold_memory(self%s%model)
      call self%s%set_state(self%full_state(x), err)
      if (allocated(err)) return
      call self%s%advance(self%t0 + tau, err)
      if (.not. allocated(err)) y = self%s%y
   end subroutine pm_flow

   !> A new forcing phase t0 for the state x (the map restarts there): the middle of
   !> the longest stretch of the k periods from x in which every clearance with a
   !> memory (`memory`) that opens is open, so that no contact with a memory is in
   !> progress at t0 (its law's damping comes from its impact, which a state at t0
   !> does not hold; D-99). x and the memory become those at the new t0 and the map
   !> is set up there. Nothing changes without such clearances, or when they never
   !> open (then a contact closed at t0 keeps the memory mem over the orbit, D-150).
   subroutine pm_rephase(self, x, err)
      class(period_map_t), intent(inout) :: self
      real(wp), intent(inout) :: x(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: y(:)
      logical, allocatable :: open(:)
      integer :: n, i, best, run, best_end
      real(wp) :: span, tau
      type(model_t) :: m
      if (size(self%memory) == 0) return
      span = real(self%k, wp)*self%period
      call self%open_samples(x, open, err)
      if (allocated(err)) return
      self%lost = .false.   ! (`kept` is the flow's from x now)
      n = size(open)
      open = [open, open]   ! the orbit repeats: a stretch may wrap around
      best = 0
      best_end = -1
      run = 0
      do i = 1, 2*n
         run = merge(run + 1, 0, open(i))
         if (run > best .and. run <= n) then
            best = run
            best_end = i - 1
         end if
      end do
      if (best == 0 .or. best == n) return   ! never open, or never closed: any t0 is as good
      tau = span*real(modulo(best_end - (best - 1)/2, n), wp)/real(n, wp)
      allocate (y(size(self%y0)))
      call self%flow(x, tau, y, err)
      if (allocated(err)) return
      x = y(1:self%n)
      self%mem = self%memory_of(self%s%model)   ! (the memory moves with the state)
      m = self%model
      m%run%t_start = self%t0 + tau
      call self%setup(m, self%period, self%k, err, keep_memory=.true.)
   end subroutine pm_rephase

   !> Whether every clearance with a memory that opens at all is open at
   !> t0 + i kT/n, i = 0 .. n - 1 (open(i + 1)), on the flow from x at t0 with the
   !> map's memory; n = max(64, min(2048, kT/dt)). A contact closed at every
   !> sample keeps its memory over the orbit (a parameter, D-150): it does not
   !> count, and only such contacts' memory is held from now on (`kept`). All false
   !> when none opens.
   subroutine pm_open_samples(self, x, open, err)
      class(period_map_t), intent(inout) :: self
      real(wp), intent(in) :: x(:)
      logical, allocatable, intent(out) :: open(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: disp(:), force(:)
      integer, allocatable :: contact(:)
      logical, allocatable :: closed(:, :), opens(:)
      integer :: n, i, ne
      real(wp) :: span
      span = real(self%k, wp)*self%period
      n = max(64, min(2048, nint(span/self%model%run%dt)))
      ne = size(self%model%elements)
      allocate (disp(ne), force(ne), contact(ne), open(n), closed(size(self%memory), n))
      call self%s%restore(self%p0, err, defer=.true.)
      if (allocated(err)) return
      call self%hold_memory(self%s%model)
      call self%s%set_state(self%full_state(x), err)
      if (allocated(err)) return
      do i = 0, n - 1
         if (i > 0) call self%s%advance(self%t0 + span*real(i, wp)/real(n, wp), err)
         if (allocated(err)) return
         call self%s%element_status(disp, force, contact)
         closed(:, i + 1) = contact(self%memory) /= 0
      end do
      opens = .not. all(closed, dim=2)
      self%kept = .not. opens   ! (the memory of a contact that never opens is held, D-150)
      do i = 1, n
         open(i) = any(opens) .and. .not. any(closed(:, i) .and. opens)
      end do
   end subroutine pm_open_samples

   !> Multiple shooting: up to m segments of the k periods, boundaries near t0 + j kT/m
   !> (j = 1 .. m - 1) moved to the nearest instant at which every clearance with a
   !> memory that opens is open on the flow from x (within kT/2m; else the boundary is
   !> dropped; `open_samples`),
   !> and the session's point saved at each. seg_tau(0:ns) are the boundaries (0 and kT
   !> the ends), seg_x(:, j) the flow's reduced state at boundary j.
   subroutine pm_set_segments(self, m, x, err)
      class(period_map_t), intent(inout) :: self
      integer, intent(in) :: m
      real(wp), intent(in) :: x(:)
      type(error_t), allocatable, intent(out) :: err
      logical, allocatable :: open(:)
      real(wp), allocatable :: tau(:)
      real(wp) :: span, best, t
      integer :: j, i, n
      logical :: restricted
      span = real(self%k, wp)*self%period
      allocate (tau(0))
      restricted = size(self%memory) > 0
      if (restricted) then
         call self%open_samples(x, open, err)
         if (allocated(err)) return
         n = size(open)
         restricted = any(open)   ! (contacts that never open: their memory is constant, seg_mem)
      end if
      do j = 1, m - 1
         t = span*real(j, wp)/real(m, wp)
         if (restricted) then
            best = huge(1.0_wp)
            do i = 1, n
               if (open(i) .and. abs(span*real(i - 1, wp)/real(n, wp) - t) < abs(best - t)) &
                  best = span*real(i - 1, wp)/real(n, wp)
            end do
            if (.not. abs(best - t) <= 0.5_wp*span/real(m, wp)) cycle
            t = best
         end if
         if (t > 0.0_wp .and. t < span) then
            if (size(tau) == 0) then
               tau = [t]
            else if (t > tau(size(tau))) then
               tau = [tau, t]
            end if
         end if
      end do
      if (allocated(self%seg_tau)) deallocate (self%seg_tau)
      allocate (self%seg_tau(0:size(tau) + 1))   ! (0-based: boundary j is seg_tau(j))
      self%seg_tau(0) = 0.0_wp
      self%seg_tau(1:size(tau)) = tau
      self%seg_tau(size(tau) + 1) = span
      if (allocated(self%seg_p)) deallocate (self%seg_p, self%seg_x, self%seg_mem)
      allocate (self%seg_p(0:size(self%seg_tau) - 2), self%seg_x(self%n, 0:size(self%seg_tau) - 2), &
                self%seg_mem(size(self%mem), 0:size(self%seg_tau) - 2))
      self%seg_p(0) = self%p0
      self%seg_x(:, 0) = x
      self%seg_mem(:, 0) = self%mem
      call self%s%restore(self%p0, err, defer=.true.)
      if (allocated(err)) return
      call self%hold_memory(self%s%model)
      call self%s%set_state(self%full_state(x), err)
      if (allocated(err)) return
      do j = 1, size(self%seg_tau) - 2
         call self%s%advance(self%t0 + self%seg_tau(j), err)
         if (allocated(err)) return
         self%seg_x(:, j) = self%s%y(1:self%n)
         self%seg_x(self%ang, j) = self%seg_x(self%ang, j) - self%w*self%seg_tau(j)
         self%seg_mem(:, j) = self%memory_of(self%s%model)
         call self%s%save(self%seg_p(j), err)
         if (allocated(err)) return
      end do
   end subroutine pm_set_segments

   !> Segment j's map: the reduced state at boundary j + 1 from xj at boundary j
   !> (reduced: angles less W (t - t0)).
   subroutine pm_segment(self, j, xj, x1, err)
      class(period_map_t), intent(inout) :: self
      integer, intent(in) :: j
      real(wp), intent(in) :: xj(:)
      real(wp), intent(out) :: x1(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: y(size(self%y0))
      call self%s%restore(self%seg_p(j), err, defer=.true.)
      if (allocated(err)) return
      y = self%full_state(xj)
      y(self%ang) = y(self%ang) + self%w*self%seg_tau(j)
      call self%hold_memory(self%s%model, self%seg_mem(:, j))
      call self%s%set_state(y, err)
      if (allocated(err)) return
      call self%s%advance(self%t0 + self%seg_tau(j + 1), err)
      if (allocated(err)) return
      x1 = self%s%y(1:self%n)
      x1(self%ang) = x1(self%ang) - self%w*self%seg_tau(j + 1)
      self%n_evals = self%n_evals + 1
   end subroutine pm_segment

   subroutine pm_finish(self)
      class(period_map_t), intent(inout) :: self
      if (allocated(self%s)) then
         call self%s%finish()
         deallocate (self%s)
      end if
   end subroutine pm_finish
end module trainsim_period_map
