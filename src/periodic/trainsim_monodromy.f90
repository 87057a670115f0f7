!> The monodromy matrix of a train over a window [t0, t0 + T]: the derivative
!> M = d x(t0 + T) / d x(t0) of its event-located flow, from the variational
!> equations with a saltation matrix at every mode change (D-102, docs/periodic.md
!> "The monodromy matrix with saltation matrices"). The flow is fixed-step RK4 on
!> the grid t0 + i T / ceil(T / dt), through the inputs' breakpoints, a guard's zero
!> located on the RK4 step map (trainsim's own run); Phi' = J Phi on the same
!> stages (J the model's analytic Jacobian); at an event guard g fires and
!>    S = I + (f+ - f-) n^T / (n^T f- + dg/dt),   n = dg/dx.
!> A contact closing with the yang_sun law fixes its damping D(V_i) (eq. 3.12)
!> until it opens: D's sensitivity to x(t0) is carried as a frozen state's.
!> The modes at t0 (faces, zones, a closed contact's D) are held. Friction
!> stick/slip (kinematic constraints, D-81) is refused.
!> Where the model's Jacobian J is constant between events (the model says so
!> and the four stage Jacobians of the mode's first full step agree bit for
!> bit), the RK4 step's tangent map is the mode's constant S = I + hJ + (hJ)^2/2
!> + (hJ)^3/6 + (hJ)^4/24, built once; every further full step is Phi <- S Phi (D-162).
module trainsim_monodromy
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input, err_numeric
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_model_families, only: jac_part_t
   use trainsim_event, only: event_t
   use trainsim_impact_memory, only: impact_gradient, damping_column
   use trainsim_contact_sequence, only: monodromy_stats_t, record_event
   use trainsim_guard_geometry, only: face_of, guard_gradient
   use trainsim_step_tangent, only: step_partials, nonzeros, split_pattern, gather, sparse_product, dense_product, &
                                    tangent_map
   implicit none
   private

   public :: monodromy_saltation, flow_events, monodromy_stats_t

   !> The work of one pass: the variational state and its scratch.
   type :: pass_t
      logical :: var = .false., salt = .true., memory = .true.
      logical :: exact = .false.            !< the step map's own derivative (`exact_step`)
      integer :: n = 0, ny = 0
      !> the tangent map of the current mode (D-162): lin, the model's Jacobian is
      !> constant between events in it; s_ok, smat holds S for steps of length
      !> ~h_grid (the grid's step; a step split at an event stays general)
      logical :: cache = .true., lin = .false., s_ok = .false.
      !> while the mode's first full step runs: its stage Jacobians, compared with
      !> the first (jac0); same_j, all agree so far
      logical :: watch = .false., same_j = .false.
      integer :: stage = 0
      real(wp) :: h_grid = 0.0_wp
      !> the mode's split J = the constant part ja + the varying elements' parts
      !> (D-170): split, every step of the rest of the mode takes it; try_split,
      !> while its first full step runs (ja held, the split agrees with J)
      logical :: split = .false., try_split = .false.
      !> pattern: jr, jc hold the places of the split J's nonzeros in this mode;
      !> jac_ja: jac holds ja but at the varying entries' places (D-186)
      logical :: pattern = .false., jac_ja = .false.
      type(jac_part_t) :: part
      real(wp), allocatable :: ja(:, :), jt(:, :)   !< (ny, ny) the constant part; scratch
      real(wp), allocatable :: smat(:, :), jac0(:, :)
      real(wp), allocatable :: phi(:, :)    !< (n, n) d x / d x(t0)
      real(wp), allocatable :: q(:, :)      !< (n, elements) d D_e / d x(t0), rows where has_q
      logical, allocatable :: has_q(:)      !< element e's impact damping depends on x(t0)
      real(wp), allocatable :: jac(:, :)    !< (ny, ny) the model's Jacobian
      real(wp), allocatable :: tau(:)       !< (n) d t / d x(t0) of the current time (exact_step: after an event)
      real(wp), allocatable :: rl(:), rt(:) !< (ny) d R / d l of the last step to an event, d R / d t (exact_step)
      real(wp), allocatable :: g(:), g0(:), gw(:)
      !> scratch of the steps (no allocation per step, D-148): the stages, a trial
      !> state, and the variational stages
      real(wp), allocatable :: k1(:), k2(:), k3(:), k4(:), xs(:), xt(:), xg(:)
      real(wp), allocatable :: p1(:, :), p2(:, :), p3(:, :), p4(:, :), ps(:, :), b(:)
      !> the Jacobian's nonzeros by rows (row starts jr, columns jc, values jv), for J Phi
      integer, allocatable :: jr(:), jc(:)
      real(wp), allocatable :: jv(:)
      type(event_t), allocatable :: events(:)
      type(monodromy_stats_t) :: st
   end type pass_t

contains

   !> The flow x(t0) -> x(t0 + period) and its monodromy matrix m (n_states x
   !> n_states; the energy-accounting states, if tracked, are carried but not
   !> differentiated). x: the model's state y (n_y, or n_states: the energy
   !> integrals then start from 0) at t0 in, at t0 + period out; the model's
   !> modes go along. dt: the step (default the deck's dt).
   !> saltation = .false. / memory = .false. leave out the jumps / the impact
   !> damping's sensitivity (for checking that they matter).
   subroutine monodromy_saltation(model, t0, period, x, m, err, dt, saltation, memory, exact_step, deck_grid, stats, &
                                  tangent_cache)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t0, period
      real(wp), intent(inout) :: x(:)
      real(wp), allocatable, intent(out) :: m(:, :)
      type(error_t), allocatable, intent(out) :: err
      real(wp), intent(in), optional :: dt
      logical, intent(in), optional :: saltation, memory
      !> .true.: the derivative of the discrete flow itself (the event times'
      !> dependence through the RK4 step map's d R / d l, no saltation matrix):
      !> equal to the flow's differences to rounding at any dt
      logical, intent(in), optional :: exact_step
      !> .true.: steps of dt from t0, the last one shortened to t0 + period (a
      !> session's grid, which a period map restarted at t0 takes); default: T / ceil(T / dt)
      logical, intent(in), optional :: deck_grid
      type(monodromy_stats_t), intent(out), optional :: stats
      !> .false.: every step through the stage Jacobians (the general pass), no
      !> mode's tangent map (D-162; for checking that they agree)
      logical, intent(in), optional :: tangent_cache
      type(pass_t) :: w
      w%var = .true.
      if (present(tangent_cache)) w%cache = tangent_cache
      if (present(saltation)) w%salt = saltation
      if (present(memory)) w%memory = memory
      if (present(exact_step)) w%exact = exact_step
      call advance(model, t0, period, x, w, err, dt, deck_grid)
      if (present(stats)) stats = w%st
      if (allocated(err)) return
      if (.not. all(abs(w%phi) <= huge(1.0_wp))) then
         call fatal_error(err, 'monodromy: the variational equations overflowed or gave NaN', err_numeric)
         return
      end if
      call move_alloc(w%phi, m)
   end subroutine monodromy_saltation

   !> The flow alone, x(t0) -> x(t0 + period): the same steps and event
   !> location as `monodromy_saltation` (for finite differences of the flow).
   subroutine flow_events(model, t0, period, x, err, dt, deck_grid, stats)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t0, period
      real(wp), intent(inout) :: x(:)
      type(error_t), allocatable, intent(out) :: err
      real(wp), intent(in), optional :: dt
      logical, intent(in), optional :: deck_grid
      type(monodromy_stats_t), intent(out), optional :: stats
      type(pass_t) :: w
      call advance(model, t0, period, x, w, err, dt, deck_grid)
      if (present(stats)) stats = w%st
   end subroutine flow_events

   !> One pass over [t0, t0 + period] on the step grid, through the breakpoints.
   subroutine advance(model, t0, period, x, w, err, dt, deck_grid)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t0, period
      real(wp), intent(inout) :: x(:)
      type(pass_t), intent(inout) :: w
      type(error_t), allocatable, intent(out) :: err
      real(wp), intent(in), optional :: dt
      logical, intent(in), optional :: deck_grid
      logical :: grid
      real(wp) :: h, t, t_grid, t_to
      real(wp), allocatable :: bp(:), y(:)
      integer :: nsteps, i, ib, k
      h = model%run%dt
      if (present(dt)) h = dt
      if (.not. (h > 0.0_wp .and. period > 0.0_wp)) then
         call fatal_error(err, 'monodromy: the step ('//str(h)//') and the period ('//str(period)//') must be > 0', err_input)
         return
      end if
      if (size(x) /= model%n_y .and. size(x) /= model%n_states) then
         call fatal_error(err, 'monodromy: the state has '//str(size(x))//' entries, the model '// &
                          str(model%n_states)//' (or '//str(model%n_y)//' with the energy integrals)', err_input)
         return
      end if
      if (allocated(model%cn)) then
         if (size(model%cn%cand) > 0) then
            call fatal_error(err, "monodromy: saltation for stick-slip not supported (element '"// &
                             model%elements(model%cn%cand(1))%e%id//"' constrains its nodes when it sticks)", &
                             err_input)
            return
         end if
      end if
      w%n = model%n_states
      w%ny = model%n_y
      allocate (w%g(model%n_guards), w%g0(model%n_guards), w%gw(model%n_guards), w%events(16))
      allocate (w%k1(model%n_y), w%k2(model%n_y), w%k3(model%n_y), w%k4(model%n_y), w%xs(model%n_y), &
                w%xt(model%n_y), w%xg(model%n_y))
      if (w%var) then
         allocate (w%p1(w%n, w%n), w%p2(w%n, w%n), w%p3(w%n, w%n), w%p4(w%n, w%n), w%ps(w%n, w%n), w%b(w%n))
         allocate (w%jr(w%n + 1), w%jc(w%n*w%n), w%jv(w%n*w%n))
         allocate (w%phi(w%n, w%n), w%q(w%n, size(model%elements)), w%jac(w%ny, w%ny))
         allocate (w%smat(w%n, w%n), w%jac0(w%n, w%n))
         allocate (w%has_q(size(model%elements)), w%tau(w%n), w%rl(w%ny), w%rt(w%ny), w%ja(w%ny, w%ny), w%jt(w%ny, w%ny))
         w%tau = 0.0_wp
         w%phi = 0.0_wp
         do k = 1, w%n
            w%phi(k, k) = 1.0_wp
         end do
         w%q = 0.0_wp
         w%has_q = .false.
      end if
      nsteps = max(1, ceiling(period/h*(1.0_wp - 1.0e-12_wp)))
      grid = .false.
      if (present(deck_grid)) grid = deck_grid
      if (.not. grid) h = period/nsteps
      w%h_grid = h
      w%lin = w%var .and. w%cache                      ! (the model is asked at the mode's first full step)
      call model%breakpoints(t0, t0 + period, bp)
      allocate (y(model%n_y), source=0.0_wp)              ! (energy integrals from 0 if x has none)
      y(1:size(x)) = x
      t = t0
      ib = 1
      do i = 1, nsteps
         t_grid = min(t0 + i*h, t0 + period)
         if (i == nsteps) t_grid = t0 + period
         do while (t < t_grid)
            t_to = t_grid
            do while (ib <= size(bp))
               if (bp(ib) > t) exit
               ib = ib + 1
            end do
            if (ib <= size(bp)) t_to = min(t_to, bp(ib))
            call step_to(model, t, t_to, y, w, err)
            if (allocated(err)) return
         end do
      end do
      x = y(1:size(x))
   end subroutine advance

   !> From (t, x) to t_to: one RK4 step, or, where a guard goes below zero in
   !> it, a step to the earliest such zero, the event, and the rest of the step.
   subroutine step_to(model, t, t_to, x, w, err)
      type(model_t), intent(inout) :: model
      real(wp), intent(inout) :: t, x(:)
      real(wp), intent(in) :: t_to
      type(pass_t), intent(inout) :: w
      type(error_t), allocatable, intent(inout) :: err
      real(wp) :: hs, s, s_min
      integer :: j, j_min, pass
      do pass = 1, 1000
         hs = t_to - t
         if (hs <= 0.0_wp) return
         call model%guards(t, x, w%g0)
         call rk4(model, t, hs, x, w%xt, w)
         call model%guards(t + hs, w%xt, w%g)
         j_min = 0
         s_min = hs
         do j = 1, size(w%g)
            if (.not. (w%g0(j) >= 0.0_wp .and. w%g(j) < 0.0_wp)) cycle
            s = guard_zero(model, t, hs, x, j, w)
            if (j_min == 0 .or. s < s_min) then
               j_min = j
               s_min = s
            end if
         end do
         if (j_min == 0) then
            call advance_exact(model, t, hs, x, w, .false.)
            t = t_to
            return
         end if
         call advance_exact(model, t, s_min, x, w, .true.)
         t = t + s_min
         if (s_min >= hs) t = t_to
         call event_at(model, t, x, j_min, w, err)
         if (allocated(err)) return
      end do
      call fatal_error(err, 'monodromy: more than 1000 events in one step at t = '//str(t)// &
                       ' (a guard chattering at zero)', err_numeric)
   end subroutine step_to

   !> `advance_state`, and with exact_step the step's start time moving with
   !> x(t0) (after an event): Phi += (dR/dt_a - dR/dl) tau^T, the step's end
   !> held; to_event: keep dR/dl (w%rl) for the event's time sensitivity.
   subroutine advance_exact(model, t, hs, x, w, to_event)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, hs
      real(wp), intent(inout) :: x(:)
      type(pass_t), intent(inout) :: w
      logical, intent(in) :: to_event
      logical :: moving
      integer :: j
      moving = .false.
      if (w%var .and. w%exact) then
         moving = any(w%tau /= 0.0_wp)
         if (moving .or. to_event) then
            call step_partials(model, t, hs, x, w%jac, w%rl, w%rt)
            w%jac_ja = .false.
         end if
      end if
      call advance_state(model, t, hs, x, w)
      if (moving) then
         w%rt(1:w%n) = w%rt(1:w%n) - w%rl(1:w%n)
         do j = 1, w%n
            w%phi(:, j) = w%phi(:, j) + w%rt(1:w%n)*w%tau(j)
         end do
         w%tau = 0.0_wp
      end if
   end subroutine advance_exact

   !> x (and Phi) advanced by one RK4 step of length hs from t.
   subroutine advance_state(model, t, hs, x, w)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, hs
      real(wp), intent(inout) :: x(:)
      type(pass_t), intent(inout) :: w
      w%st%steps = w%st%steps + 1
      if (w%var) then
         call rk4_var(model, t, hs, x, w)
      else
         call rk4(model, t, hs, x, w%xt, w)
         x = w%xt
      end if
   end subroutine advance_state

   !> The step length s in (0, hs] where guard j, >= 0 at the start and < 0
   !> after the full step, reaches zero on the RK4 step map: Illinois on s,
   !> then bisection, until the bracket is a few ulps wide; the end where the
   !> guard is below zero (or zero) is returned, so that it has fired.
   real(wp) function guard_zero(model, t, hs, x, j, w) result(s)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, hs, x(:)
      integer, intent(in) :: j
      type(pass_t), intent(inout) :: w
      real(wp) :: lo, hi, glo, ghi, gm, sm
      integer :: it, side
      lo = 0.0_wp
      hi = hs
      glo = w%g0(j)
      ghi = w%g(j)
      side = 0
      do it = 1, 200
         if (hi - lo <= 4.0_wp*spacing(hi) .or. ghi == 0.0_wp) exit
         if (it <= 60 .and. glo > ghi) then
            sm = lo + (hi - lo)*glo/(glo - ghi)
            if (.not. (sm > lo .and. sm < hi)) sm = 0.5_wp*(lo + hi)
         else
            sm = 0.5_wp*(lo + hi)
         end if
         call rk4(model, t, sm, x, w%xg, w)
         call model%guards(t + sm, w%xg, w%gw)
         gm = w%gw(j)
         if (gm > 0.0_wp) then
            lo = sm; glo = gm
            if (side == -1) ghi = 0.5_wp*ghi      ! Illinois: the stale end's value halved
            side = -1
         else
            hi = sm; ghi = gm
            if (side == 1) glo = 0.5_wp*glo
            side = 1
         end if
      end do
      s = hi
   end function guard_zero

   !> The event at (t, x) where guard j_min fired (with every other guard that
   !> crossed zero with it): the modes updated, Phi through the saltation
   !> matrix, the impact damping's sensitivity set for a contact that closed.
   subroutine event_at(model, t, x, j_min, w, err)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t
      real(wp), intent(inout) :: x(:)
      integer, intent(in) :: j_min
      type(pass_t), intent(inout) :: w
      type(error_t), allocatable, intent(inout) :: err
      logical :: fired(size(w%g))
      real(wp) :: fm(size(x)), fp(size(x)), nv(w%n), den, gt, nrm
      real(wp), allocatable :: row(:), dxe(:, :)
      integer :: j, nev, e
      integer :: mode_before(size(model%elements))
      call model%guards(t, x, w%g)
      fired = w%g <= 0.0_wp .and. w%g0 >= 0.0_wp
      fired(j_min) = .true.
      do j = 1, size(fired)
         if (fired(j)) call record_event(w%st, j, face_of(model, model%guard_element(j)))
      end do
      if (w%var) then
         call model%rhs(t, x, fm)
         if (w%exact) fm = w%rl                         ! the step map's d x_e / d t_e in place of f-
         call guard_gradient(model, t, x, j_min, nv, gt)
         den = dot_product(nv, fm(1:w%n)) + gt
         nrm = sqrt(dot_product(nv, nv))*sqrt(dot_product(fm(1:w%n), fm(1:w%n)))
         if (.not. (abs(den) > 1.0e-13_wp*nrm)) then
            e = max(1, model%guard_element(j_min))
            call fatal_error(err, 'monodromy: grazing event at t = '//str(t)//" (a guard of element '"// &
                             model%elements(e)%e%id//"' crossed tangentially, n^T f = "//str(den)// &
                             '): the saltation matrix is undefined', err_numeric)
            return
         end if
         if (abs(den)/norm2(nv) < w%st%min_rate) then
            w%st%min_rate = abs(den)/norm2(nv)
            w%st%min_rate_guard = j_min
         end if
         do e = 1, size(model%elements)
            mode_before(e) = face_of(model, e)
         end do
      end if
      nev = 0
      call model%apply_events(t, x, fired, w%events, nev)
      if (.not. w%var) return
      w%s_ok = .false.                                ! a new mode: its own tangent map or split, if any
      w%split = .false.
      w%pattern = .false.
      w%lin = w%cache
      call model%rhs(t, x, fp)
      row = matmul(nv, w%phi)/den                     ! n^T Phi- / (n^T f- + dg/dt) = -d t_e / d x(t0)
      ! the event state's sensitivity, d x_e / d x(t0) = Phi- - f- n^T Phi- / den
      dxe = w%phi - spread(fm(1:w%n), 2, w%n)*spread(row, 1, w%n)
      if (w%exact) then             ! x_e moves with t_e; the next step's start moves with it (advance_exact)
         w%phi = dxe
         w%tau = -row
      else
         if (maxval(abs(fp(1:w%n) - fm(1:w%n))) > 1.0e-10_wp*maxval(abs(fm(1:w%n)))) w%st%jumps = w%st%jumps + 1
         if (w%salt) w%phi = w%phi + spread(fp(1:w%n) - fm(1:w%n), 2, w%n)*spread(row, 1, w%n)
      end if
      do e = 1, size(model%elements)
         j = face_of(model, e)
         if (j == mode_before(e)) cycle
         w%has_q(e) = .false.
         w%q(:, e) = 0.0_wp
         if (mode_before(e) /= 0 .or. j == 0 .or. .not. w%memory) cycle
         call impact_sensitivity(model, e, t, x, dxe, w)
      end do
   end subroutine event_at

   !> Element e closed at (t, x): q_e = dD/dx dxe where its impact damping D
   !> depends on the approach velocity (yang_sun, `impact_gradient`).
   subroutine impact_sensitivity(model, e, t, x, dxe, w)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: e
      real(wp), intent(in) :: t, x(:), dxe(:, :)
      type(pass_t), intent(inout) :: w
      real(wp) :: dd_dv, gv(w%n)
      logical :: found
      call impact_gradient(model, e, t, x, dd_dv, gv, found)
      if (.not. found) return
      w%q(:, e) = dd_dv*matmul(gv, dxe)
      w%has_q(e) = .true.
      w%st%impacts = w%st%impacts + 1
   end subroutine impact_sensitivity

   !> One RK4 step of the state alone: x -> xn over hs from t.
   subroutine rk4(model, t, hs, x, xn, w)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, hs, x(:)
      real(wp), intent(out) :: xn(:)
      type(pass_t), intent(inout) :: w
      call model%rhs(t, x, w%k1)
      w%xs = x + 0.5_wp*hs*w%k1
      call model%rhs(t + 0.5_wp*hs, w%xs, w%k2)
      w%xs = x + 0.5_wp*hs*w%k2
      call model%rhs(t + 0.5_wp*hs, w%xs, w%k3)
      w%xs = x + hs*w%k3
      call model%rhs(t + hs, w%xs, w%k4)
      xn = x + hs/6.0_wp*(w%k1 + 2.0_wp*(w%k2 + w%k3) + w%k4)
   end subroutine rk4

   !> One RK4 step of the state and the variational equations together (the
   !> same stages: the derivative of the step map, for a step length held).
   subroutine rk4_var(model, t, hs, x, w)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, hs
      real(wp), intent(inout) :: x(:)
      type(pass_t), intent(inout) :: w
      logical :: full
      ! a full step of the grid (its length differs from h_grid by the rounding of t)
      full = abs(hs - w%h_grid) <= 8.0_wp*spacing(abs(t) + abs(hs))
      if (w%s_ok .and. full) then
         call rk4(model, t, hs, x, w%xt, w)
         x = w%xt
         call tangent_step(w)
         return
      end if
      w%watch = w%lin .and. full
      w%stage = 0
      if (w%split) w%st%split_steps = w%st%split_steps + 1
      call model%rhs(t, x, w%k1)
      call var_rhs(model, t, x, w%phi, w%p1, w)
      w%xs = x + 0.5_wp*hs*w%k1
      call model%rhs(t + 0.5_wp*hs, w%xs, w%k2)
      w%ps = w%phi + 0.5_wp*hs*w%p1
      call var_rhs(model, t + 0.5_wp*hs, w%xs, w%ps, w%p2, w)
      w%xs = x + 0.5_wp*hs*w%k2
      call model%rhs(t + 0.5_wp*hs, w%xs, w%k3)
      w%ps = w%phi + 0.5_wp*hs*w%p2
      call var_rhs(model, t + 0.5_wp*hs, w%xs, w%ps, w%p3, w)
      w%xs = x + hs*w%k3
      call model%rhs(t + hs, w%xs, w%k4)
      w%ps = w%phi + hs*w%p3
      call var_rhs(model, t + hs, w%xs, w%ps, w%p4, w)
      x = x + hs/6.0_wp*(w%k1 + 2.0_wp*(w%k2 + w%k3) + w%k4)
      w%phi = w%phi + hs/6.0_wp*(w%p1 + 2.0_wp*(w%p2 + w%p3) + w%p4)
      if (w%watch) then              ! the mode's first full step: its S (J constant), its split, or general
         w%watch = .false.
         w%lin = .false.
         if (w%same_j .and. .not. any(w%has_q)) call build_tangent(w, hs)
         w%split = w%try_split .and. (w%same_j .or. any(w%part%vary))
         w%pattern = .false.
         w%part%varying = .true.
      end if
   end subroutine rk4_var

   !> A stage of the mode's first full step: J, and whether it is constant (its
   !> four stage Jacobians one: D-162) or its constant part is (D-170): the part
   !> at the first stage and again at the last, bit for bit, and the split at the
   !> first stage equal to J to the rounding of the sums' order.
   subroutine watch_stage(model, t, x, w)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, x(:)
      type(pass_t), intent(inout) :: w
      w%stage = w%stage + 1
      if (w%stage == 1) then
         call model%jacobian(t, x, w%jac, constant=w%same_j)
         w%jac0 = w%jac(1:w%n, 1:w%n)
         w%part%varying = .false.
         call model%jacobian(t, x, w%ja, part=w%part)
         w%try_split = w%part%ok
         if (.not. (w%try_split .and. any(w%part%vary))) return
         w%jt = w%ja
         w%part%varying = .true.
         call model%jacobian(t, x, w%jt, part=w%part)
         w%try_split = all(abs(w%jt(1:w%n, 1:w%n) - w%jac(1:w%n, 1:w%n)) <= &
                           8.0_wp*epsilon(1.0_wp)*(abs(w%ja(1:w%n, 1:w%n)) + abs(w%jt(1:w%n, 1:w%n) - w%ja(1:w%n, 1:w%n))))
         return
      end if
      call model%jacobian(t, x, w%jac)
      if (w%same_j) w%same_j = all(w%jac(1:w%n, 1:w%n) == w%jac0)
      if (w%stage < 4 .or. .not. (w%try_split .and. any(w%part%vary))) return
      w%part%varying = .false.
      call model%jacobian(t, x, w%jt, part=w%part)
      w%try_split = w%part%ok .and. all(w%jt(1:w%n, 1:w%n) == w%ja(1:w%n, 1:w%n))
   end subroutine watch_stage

   !> S of the mode from its constant Jacobian (jac0) and the step hs.
   subroutine build_tangent(w, hs)
      type(pass_t), intent(inout) :: w
      real(wp), intent(in) :: hs
      call tangent_map(w%n, w%jac0, hs, w%smat)
      w%s_ok = .true.
      w%st%tangent_maps = w%st%tangent_maps + 1
   end subroutine build_tangent

   !> Phi <- S Phi: the variational part of a full step in a mode with S.
   subroutine tangent_step(w)
      type(pass_t), intent(inout) :: w
      call dense_product(w%n, w%smat, w%phi, w%p1)
      w%phi = w%p1
      w%st%tangent_steps = w%st%tangent_steps + 1
   end subroutine tangent_step

   !> Phi' = J(t, x) Phi + sum over the closed contacts with a sensitive
   !> damping of (df/dD_e) q_e^T.
   subroutine var_rhs(model, t, x, phi, dphi, w)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: t, x(:)
      real(wp), intent(in), contiguous :: phi(:, :)
      real(wp), intent(out), contiguous :: dphi(:, :)
      type(pass_t), intent(inout) :: w
      integer :: e, j
      if (w%split) then                 ! the constant part and the varying elements' parts (D-170)
         if (.not. w%jac_ja) w%jac = w%ja   ! (after, its varying entries are put back to ja's, D-186)
         w%jac_ja = .true.
         call model%jacobian(t, x, w%jac, part=w%part)
      else if (.not. w%watch) then
         w%jac_ja = .false.
         call model%jacobian(t, x, w%jac)
      else
         w%jac_ja = .false.
         call watch_stage(model, t, x, w)
      end if
      ! J Phi over J's nonzeros (a train's Jacobian is sparse: an element couples
      ! two nodes), each entry summed over k in order, as matmul does (D-148, D-170);
      ! in a split mode over the mode's pattern of them (D-186)
      if (w%split) then
         if (.not. w%pattern) call split_pattern(w%n, w%ny, w%ja, w%part%sc, w%part%nsc, w%jr, w%jc)
         w%pattern = .true.
         call gather(w%n, w%ny, w%jac, w%jr, w%jc, w%jv)
         do j = 1, w%part%nsc            ! jac = ja again, entry by entry
            w%jac(w%part%sc(2, j), w%part%sc(3:4, j)) = w%ja(w%part%sc(2, j), w%part%sc(3:4, j))
         end do
      else
         call nonzeros(w%n, w%ny, w%jac, w%jr, w%jc, w%jv)
      end if
      call sparse_product(w%n, w%jr, w%jc, w%jv, phi, dphi)
      do e = 1, size(w%has_q)
         if (.not. w%has_q(e)) cycle
         if (w%split) then               ! (the nodes' gains of the constant part; e's kinematics
            ! taken at (t, x) by its varying part if it has one, D-186)
            call damping_column(model, e, t, x, w%jt, w%b, w%part%dtq, &
                                current=any(w%part%sc(1, 1:w%part%nsc) == e))
         else
            call damping_column(model, e, t, x, w%jac, w%b)
         end if
         do j = 1, w%n
            dphi(:, j) = dphi(:, j) + w%b*w%q(j, e)
         end do
      end do
   end subroutine var_rhs
end module trainsim_monodromy
