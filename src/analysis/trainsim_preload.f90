!> Static preload: the wound-up state of the train under its loads at t_start,
!> found by Newton's method on the model's own torques (the elements' `torques`
!> and `torque_jacobian`, the nodes' own terms through `derivatives`), instead of
!> hand-computed initial angles (docs/decisions.md D-30).
!>
!> "Equilibrium" of a running train is steady rigid rotation: every node turns with
!> the kinematic speed ratio kappa_i of the train (1 across a shaft, r1/r2 across a
!> gear pair) and the same reference acceleration a, so node i needs the net torque
!> J_i kappa_i a. Then
!> - a node held at a prescribed speed (or a fixed node) is the reference: a is its
!>   acceleration at t_start (0 for a constant speed: the thesis decks), and the held
!>   drive supplies whatever torque balances the loads;
!> - with no held or fixed node the train turns freely: the reference is its first
!>   free node, whose angle is kept, and a is one more unknown (the loads accelerate
!>   the whole train; the wind-up is the one that accelerates every inertia alike).
!> The residual of free node i is R_i = J_i (dw_i/dt - kappa_i a), with dw_i/dt from
!> `model_rhs` at the initial speeds (damping at those speeds counts).
!>
!> Discrete modes: every clearance is closed, first on its front face; a spur mesh
!> takes the zone of its driver's angle. After each converged solve the guards are
!> checked: a zone left is re-set from the new angles, a clearance in tension is
!> closed on its other face, and the solve is repeated until the modes agree with
!> the angles.
module trainsim_preload
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input, err_numeric
   use trainsim_strings, only: str
   use trainsim_model, only: model_t, rigid_speeds
   use trainsim_band_solve, only: band_plan_t, band_plan, band_zero, band_add, band_solve
   implicit none
   private

   public :: preload_info_t, apply_preload, preload_residual, preload_plan_t, preload_prepare, preload_solve

   !> How the preload was found.
   type :: preload_info_t
      integer :: reference = 0            !< node whose angle is kept
      logical :: free_train = .false.     !< no held or fixed node: a is solved for
      real(wp) :: acceleration = 0.0_wp   !< reference acceleration a (rad/s^2)
      real(wp) :: residual = 0.0_wp       !< max |R_i| at the solution (torque units)
      real(wp) :: torque_scale = 0.0_wp   !< largest load or element torque at the solution
      integer :: iterations = 0           !< Newton iterations, all passes
      integer :: passes = 0               !< mode passes (solves)
      integer, allocatable :: face(:)     !< per element: +1 front, -1 rear, 0 no clearance
      real(wp), allocatable :: theta_deck(:)   !< per node: the initial angle before the preload
      real(wp) :: deck_residual = 0.0_wp  !< max |R_i| at the deck's angles (modes from those angles)
   end type preload_info_t

   !> What a preload needs that the initial angles do not change (preload_prepare).
   type :: preload_plan_t
      integer :: reference = 0
      logical :: free_train = .false.
      real(wp) :: acceleration = 0.0_wp
      real(wp), allocatable :: kappa(:)   !< kinematic ratios from the reference
      integer, allocatable :: dof(:)      !< per node: its unknown (0: none)
      integer, allocatable :: row(:)      !< per node: its residual row (0: none)
      integer :: n = 0                    !< unknowns (a free train's a the last)
      type(band_plan_t) :: band           !< the angles' banded solve (a free train: its reference held)
   end type preload_plan_t

   integer, parameter :: max_newton = 50, max_passes = 20
   !> Newton stops when max |R| <= tol_residual * torque scale (round-off of the
   !> torque sums is about 1e-16 of the scale, times the stiffness ratio of the train).
   real(wp), parameter :: tol_residual = 1.0e-11_wp

   interface
      subroutine dgesv(n, nrhs, a, lda, ipiv, b, ldb, info)
         import :: wp
         integer, intent(in) :: n, nrhs, lda, ldb
         real(wp), intent(inout) :: a(lda, *), b(ldb, *)
         integer, intent(out) :: ipiv(*), info
      end subroutine dgesv
   end interface

contains

   !> Replace the initial angles of the free nodes of `model` by the static preload
   !> (held and fixed nodes, the reference of a free train, all speeds kept).
   subroutine apply_preload(model, info, err, rounding_floor, dense)
      type(model_t), intent(inout) :: model
      type(preload_info_t), intent(out) :: info
      type(error_t), allocatable, intent(out) :: err
      !> accept a residual at the angles' rounding, 16 eps max|theta| max|J| (angles of many
      !> turns: the quasi-static reference over a hunting period, D-118); default off
      logical, intent(in), optional :: rounding_floor
      !> solve Newton's steps with the dense LU (dgesv) instead of the banded one (tests)
      logical, intent(in), optional :: dense
      type(preload_plan_t) :: plan
      call preload_prepare(model, plan, err); if (allocated(err)) return
      call preload_solve(model, plan, info, err, rounding_floor, dense)
   end subroutine apply_preload

   !> What the preload of `model` needs that its angles do not change: the reference,
   !> the kinematic ratios, the unknowns and the banded solve's numbering (D-152).
   subroutine preload_prepare(model, plan, err)
      type(model_t), intent(inout) :: model
      type(preload_plan_t), intent(out) :: plan
      type(error_t), allocatable, intent(out) :: err
      type(preload_info_t) :: info
      integer, allocatable :: ea(:), eb(:)
      integer :: n, k, i, ne
      ne = size(model%elements)
      do i = 1, ne
         if (model%elements(i)%e%n_ports() == 2) cycle
         call fatal_error(err, model%elements(i)%e%origin//": error: the static preload (initial_state = 'preload', "// &
                          "modes --preload) does not yet take an element with more than two ports: element '"// &
                          model%elements(i)%e%id//"' has a "//model%elements(i)%e%port_keys(1)%s//' (D-73)', err_input)
         return
      end do
      call reference_node(model, info)
      if (info%reference == 0) then
         call fatal_error(err, 'static preload: the train has no node with an inertia, a prescribed speed or '// &
                          'a fixed angle to refer the wind-up to', err_input)
         return
      end if
      plan%reference = info%reference; plan%free_train = info%free_train; plan%acceleration = info%acceleration
      call kinematic_ratios(model, info%reference, plan%kappa, err); if (allocated(err)) return
      ! unknowns: the angles of the free nodes (not the reference of a free train), then a;
      ! residual rows: every free node (the reference of a free train too)
      allocate (plan%dof(size(model%nodes)), plan%row(size(model%nodes)))
      plan%dof = 0; plan%row = 0
      n = 0; k = 0
      do i = 1, size(model%nodes)
         if (.not. is_free(model, i)) cycle
         k = k + 1
         plan%row(i) = k
         if (info%free_train .and. i == info%reference) cycle
         n = n + 1
         plan%dof(i) = n
      end do
      plan%n = n
      if (info%free_train) plan%n = n + 1
      allocate (ea(ne), eb(ne))
      do i = 1, ne
         ea(i) = plan%dof(model%elements(i)%e%left); eb(i) = plan%dof(model%elements(i)%e%right)
      end do
      call band_plan(n, ea, eb, plan%band)
   end subroutine preload_prepare

   !> The preload of `model` from its present initial angles, with a plan of preload_prepare.
   !> tables = .false.: the model's fast-path tables are not rebuilt when the modes are set
   !> from the angles (init_modes; they hold the held nodes' angles: the caller rebuilds
   !> them when it turns a held node; the quasi-static reference's many solves).
   subroutine preload_solve(model, plan, info, err, rounding_floor, dense, tables)
      type(model_t), intent(inout) :: model
      type(preload_plan_t), intent(inout) :: plan
      type(preload_info_t), intent(out) :: info
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: rounding_floor, dense, tables
      real(wp), allocatable :: y(:)
      integer :: i, pass
      logical :: changed
      info%reference = plan%reference; info%free_train = plan%free_train; info%acceleration = plan%acceleration
      info%theta_deck = [(model%nodes(i)%n%theta0, i=1, size(model%nodes))]
      call preload_residual(model, info%deck_residual, info%torque_scale, info%acceleration, plan%kappa, &
                            info%reference, tables)
      call model%initial_state(y)
      allocate (info%face(size(model%elements)))
      info%face = 1
      do pass = 1, max_passes
         info%passes = pass
         call set_modes(model, y, info%face)
         call newton(model, y, plan, info, err, rounding_floor, dense); if (allocated(err)) return
         call check_modes(model, y, info%face, changed)
         if (.not. changed) exit
         if (pass == max_passes) then
            call fatal_error(err, 'static preload: the contact faces and mesh zones do not settle after '// &
                             str(max_passes)//' solves (the wound-up state lies on a zone boundary?)', err_numeric)
            return
         end if
      end do
      do i = 1, size(model%nodes)
         if (plan%dof(i) > 0) model%nodes(i)%n%theta0 = y(model%nodes(i)%n%offset + 1)
      end do
      call preload_residual(model, info%residual, info%torque_scale, info%acceleration, plan%kappa, info%reference, &
                            tables)
   end subroutine preload_solve

   !> Max |J_i (dw_i/dt - kappa_i a)| over the free nodes at the model's initial state
   !> (its modes as `init_modes` sets them), and the torque scale (the largest load or
   !> element torque). `kappa`/`ref` default to the train's own kinematic ratios from
   !> the reference node; `a` to the reference's own acceleration.
   subroutine preload_residual(model, residual, scale, a, kappa, ref, tables)
      type(model_t), intent(inout) :: model
      real(wp), intent(out) :: residual, scale
      real(wp), intent(in), optional :: a
      real(wp), intent(in), optional :: kappa(:)
      integer, intent(in), optional :: ref
      logical, intent(in), optional :: tables   !< rebuild the fast-path tables (default)
      real(wp), allocatable :: y(:), k(:), r(:)
      type(preload_info_t) :: info
      type(error_t), allocatable :: err
      real(wp) :: acc
      call model%initial_state(y)
      call model%init_modes(model%run%t_start, y, tables)
      if (present(kappa)) then
         k = kappa
         info%reference = ref
      else
         call reference_node(model, info)
         call kinematic_ratios(model, info%reference, k, err)
         if (allocated(err)) k = spread(1.0_wp, 1, size(model%nodes))
      end if
      acc = info%acceleration
      if (present(a)) acc = a
      call node_residuals(model, y, k, acc, r, scale)
      residual = 0.0_wp
      if (size(r) > 0) residual = maxval(abs(r))
   end subroutine preload_residual

   ! ------------------------------------------------------------------------------------------

   logical function is_free(model, i)
      type(model_t), intent(in) :: model
      integer, intent(in) :: i
      is_free = .not. (model%is_held(i) .or. model%nodes(i)%n%is_fixed()) .and. &
                model%nodes(i)%n%nstates() >= 2 .and. model%nodes(i)%n%inertia() > 0.0_wp
   end function is_free

   !> The first held node (its acceleration at t_start), else the first fixed node
   !> (a = 0), else the first free node of a free train.
   subroutine reference_node(model, info)
      type(model_t), intent(in) :: model
      type(preload_info_t), intent(inout) :: info
      integer :: i
      info%reference = 0
      info%free_train = .false.
      info%acceleration = 0.0_wp
      do i = 1, size(model%nodes)
         if (model%is_held(i)) then
            info%reference = i
            info%acceleration = model%speeds(model%speed_of(i))%derivative(model%run%t_start)
            return
         end if
      end do
      do i = 1, size(model%nodes)
         if (model%nodes(i)%n%is_fixed()) then
            info%reference = i
            return
         end if
      end do
      do i = 1, size(model%nodes)
         if (is_free(model, i)) then
            info%reference = i
            info%free_train = .true.
            return
         end if
      end do
   end subroutine reference_node

   !> Speed of each node per unit speed of node `ref` when the train turns rigidly,
   !> carried along the elements' closed-contact speed ratios (trainsim_model's
   !> rigid_speeds, as mesh_frequency). Fixed nodes and parts not joined: 0.
   subroutine kinematic_ratios(model, ref, kappa, err)
      type(model_t), intent(in) :: model
      integer, intent(in) :: ref
      real(wp), allocatable, intent(out) :: kappa(:)
      type(error_t), allocatable, intent(out) :: err
      logical, allocatable :: known(:)
      integer :: loop_el
      if (model%nodes(ref)%n%is_fixed()) then
         allocate (kappa(size(model%nodes)))
         kappa = 0.0_wp
         return
      end if
      call rigid_speeds(model, ref, 1.0_wp, kappa, known, loop_el)   ! (a loop that disagrees: as carried)
      associate (unused => err)
      end associate
   end subroutine kinematic_ratios

   !> Every element's preload mode at the angles of y: faces as given, zones from the angles.
   subroutine set_modes(model, y, face)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:)
      integer, intent(inout) :: face(:)
      integer :: j, l, r
      call model%kinematics(model%run%t_start, y)
      do j = 1, size(model%elements)
         l = model%elements(j)%e%left
         r = model%elements(j)%e%right
         call model%preload_mode(j, face(j), model%theta(l), model%omega(l), model%theta(r), model%omega(r))
         if (.not. model%elements(j)%e%in_contact()) face(j) = 0   ! no clearance
      end do
   end subroutine set_modes

   !> After a solve: elements whose guards went negative get their zones re-set
   !> from the angles; if a guard is still negative the clearance is in tension and
   !> is closed on its other face. `changed` if any mode changed.
   subroutine check_modes(model, y, face, changed)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:)
      integer, intent(inout) :: face(:)
      logical, intent(out) :: changed
      real(wp), allocatable :: g(:)
      real(wp) :: tol
      integer :: j, o, n, l, r
      changed = .false.
      if (model%n_guards == 0) return
      allocate (g(model%n_guards))
      tol = 1.0e-12_wp*max(1.0_wp, maxval(abs(y(1:model%n_states))))
      call model%guards(model%run%t_start, y, g)
      do j = 1, size(model%elements)
         n = model%elements(j)%e%n_guards()
         o = model%guard_offset(j)
         if (n == 0) cycle
         if (minval(g(o + 1:o + n)) >= -tol) cycle
         changed = .true.
         l = model%elements(j)%e%left
         r = model%elements(j)%e%right
         call model%preload_mode(j, face(j), model%theta(l), model%omega(l), model%theta(r), model%omega(r))
         call model%elements(j)%e%guards(model%theta(l), model%omega(l), model%theta(r), model%omega(r), g(o + 1:o + n))
         if (minval(g(o + 1:o + n)) < -tol .and. face(j) /= 0) face(j) = -face(j)
      end do
   end subroutine check_modes

   !> Net-torque residuals R_i = J_i (dw_i/dt - kappa_i a) of the free nodes at y,
   !> in node order, and the torque scale.
   subroutine node_residuals(model, y, kappa, a, res, scale)
      type(model_t), intent(inout) :: model
      real(wp), intent(in) :: y(:), kappa(:), a
      real(wp), allocatable, intent(out) :: res(:)
      real(wp), intent(out) :: scale
      real(wp), allocatable :: dydt(:)
      real(wp) :: tl, tr
      integer :: i, j, l, r, k
      allocate (dydt(size(y)))
      dydt = 0.0_wp
      scale = 0.0_wp
      call model%apply_loads(model%run%t_start)
      scale = maxval([0.0_wp, abs(model%torque)])
      call model%kinematics(model%run%t_start, y)   ! (once: the elements' torques change no angle)
      do j = 1, size(model%elements)
         l = model%elements(j)%e%left
         r = model%elements(j)%e%right
         call model%elements(j)%e%torques(model%theta(l), model%omega(l), model%theta(r), model%omega(r), tl, tr)
         scale = max(scale, abs(tl), abs(tr))
      end do
      call model%rhs(model%run%t_start, y, dydt)
      k = 0
      do i = 1, size(model%nodes)
         if (is_free(model, i)) k = k + 1
      end do
      allocate (res(k))
      k = 0
      do i = 1, size(model%nodes)
         if (.not. is_free(model, i)) cycle
         k = k + 1
         res(k) = model%nodes(i)%n%inertia()*(dydt(model%nodes(i)%n%offset + 2) - kappa(i)*a)
      end do
   end subroutine node_residuals

   !> Newton's method on R(theta, a) = 0 in the current modes.
   subroutine newton(model, y, plan, info, err, rounding_floor, dense)
      type(model_t), intent(inout) :: model
      real(wp), intent(inout) :: y(:)
      type(preload_plan_t), intent(inout) :: plan
      type(preload_info_t), intent(inout) :: info
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: rounding_floor, dense
      real(wp) :: r_floor, jmax
      real(wp), allocatable :: res(:), step(:)
      real(wp) :: scale, rmax, rprev, r_stall
      integer :: it, i, info_la, n, stalls
      logical :: use_dense
      use_dense = .false.
      if (present(dense)) use_dense = dense
      n = plan%n
      if (count(plan%row > 0) /= n) then
         call fatal_error(err, 'static preload: internal error: '//str(count(plan%row > 0))//' equations for '// &
                          str(n)//' unknowns', err_numeric)
         return
      end if
      if (n == 0) return
      allocate (step(n))
      r_floor = 0.0_wp
      rprev = huge(1.0_wp); stalls = 0; jmax = 0.0_wp
      do it = 0, max_newton
         call node_residuals(model, y, plan%kappa, info%acceleration, res, scale)
         rmax = maxval(abs(res))
         if (rmax <= max(tol_residual*max(scale, tiny(1.0_wp)), r_floor)) return
         if (it == max_newton) exit
         ! stalled: twice no smaller, and at the angles' rounding (a train that carries no
         ! torque: its torques at the solution are round-off, never 1e-11 of themselves)
         r_stall = 16.0_wp*epsilon(1.0_wp)*maxval(abs(model%theta))*jmax
         stalls = merge(stalls + 1, 0, rmax >= rprev .and. rmax <= r_stall)
         if (it >= 1 .and. scale <= r_stall) stalls = 2   ! every torque round-off after a step: nothing to converge to
         rprev = rmax
         if (stalls == 2) then
            call fatal_error(err, 'static preload: Newton stalled after '//str(it)//' iterations (residual '// &
                             str(rmax)//' against a torque scale '//str(scale)//', within the rounding of the '// &
                             'angles, 16 eps max|theta| max|J| = '//str(r_stall)//')', err_numeric)
            return
         end if
         info%iterations = info%iterations + 1
         call model%kinematics(model%run%t_start, y)
         if (use_dense) then
            info_la = dense_step(model, plan, res, step, jmax)
         else
            call band_step(model, plan, res, step, jmax, info_la)
         end if
         call set_floor(model, jmax, rounding_floor, r_floor)
         if (info_la /= 0) then
            call fatal_error(err, 'static preload: the stiffness matrix is singular (a part of the train is held '// &
                             'by nothing: no element, load or fixed node ties it; LAPACK info = '// &
                             str(info_la)//')', err_numeric)
            return
         end if
         do i = 1, size(model%nodes)
            if (plan%dof(i) > 0) y(model%nodes(i)%n%offset + 1) = y(model%nodes(i)%n%offset + 1) + step(plan%dof(i))
         end do
         if (info%free_train) info%acceleration = info%acceleration + step(n)
      end do
      call fatal_error(err, 'static preload: Newton did not converge in '//str(max_newton)//' iterations '// &
                       '(residual '//str(rmax)//' against a torque scale '//str(scale)//')', err_numeric)
   end subroutine newton

   !> The elements' stiffness -dR/dtheta into the dense jac (rows: residual rows) or into the
   !> plan's band (rows: unknowns; a free train's reference row into d), in the same order
   !> of sums, so either matrix holds the same entries.
   subroutine assemble(model, plan, use_dense, jac, d)
      type(model_t), intent(inout) :: model
      type(preload_plan_t), intent(inout) :: plan
      logical, intent(in) :: use_dense
      real(wp), intent(inout) :: jac(:, :), d(:)
      real(wp) :: jt(2, 4)
      integer :: j, a, b, na, nb, ends(2)
      do j = 1, size(model%elements)
         associate (e => model%elements(j)%e)
            ends = [e%left, e%right]
            call e%torque_jacobian(model%theta(e%left), model%omega(e%left), model%theta(e%right), &
                                   model%omega(e%right), jt)
         end associate
         do a = 1, 2
            na = ends(a)
            if (plan%row(na) == 0) cycle
            do b = 1, 2
               nb = ends(b)
               if (plan%dof(nb) == 0) cycle
               if (use_dense) then
                  jac(plan%row(na), plan%dof(nb)) = jac(plan%row(na), plan%dof(nb)) + jt(a, 2*b - 1)
               else if (plan%dof(na) == 0) then
                  d(plan%dof(nb)) = d(plan%dof(nb)) + jt(a, 2*b - 1)
               else
                  call band_add(plan%band, plan%dof(na), plan%dof(nb), jt(a, 2*b - 1))
               end if
            end do
         end do
      end do
   end subroutine assemble

   !> The rounding floor of the residual (see apply_preload) from the largest stiffness jmax.
   subroutine set_floor(model, jmax, rounding_floor, r_floor)
      type(model_t), intent(in) :: model
      real(wp), intent(in) :: jmax
      logical, intent(in), optional :: rounding_floor
      real(wp), intent(inout) :: r_floor
      if (present(rounding_floor)) then
         if (rounding_floor) r_floor = 16.0_wp*epsilon(1.0_wp)*maxval(abs(model%theta))*jmax
      end if
   end subroutine set_floor

   !> Newton's step from the dense Jacobian (LAPACK dgesv, O(n^3)): the reference solve.
   !> LAPACK's info returned.
   integer function dense_step(model, plan, res, step, jmax) result(info_la)
      type(model_t), intent(inout) :: model
      type(preload_plan_t), intent(inout) :: plan
      real(wp), intent(in) :: res(:)
      real(wp), intent(out) :: step(:), jmax   !< Newton's step; the largest |entry| of the Jacobian
      real(wp), allocatable :: jac(:, :), rhs(:, :), d(:)
      integer, allocatable :: ipiv(:)
      integer :: i, n
      n = plan%n
      allocate (jac(n, n), rhs(n, 1), ipiv(n), d(0))
      jac = 0.0_wp
      call assemble(model, plan, .true., jac, d)
      if (plan%free_train) then
         do i = 1, size(model%nodes)
            if (plan%row(i) > 0) jac(plan%row(i), n) = -model%nodes(i)%n%inertia()*plan%kappa(i)
         end do
      end if
      jmax = maxval(abs(jac))
      rhs(:, 1) = -res
      call dgesv(n, 1, jac, n, ipiv, rhs, n, info_la)
      step = rhs(:, 1)
   end function dense_step

   !> Newton's step from the banded Jacobian (D-152): the angles' block B by
   !> band_solve; a free train's a by bordering, with its reference row d and the column c
   !> of a: B y = r1, B z = c, a = (r2 - d.y) / (e - d.z), angles y - a z.
   subroutine band_step(model, plan, res, step, jmax, info_la)
      type(model_t), intent(inout) :: model
      type(preload_plan_t), intent(inout) :: plan
      real(wp), intent(in) :: res(:)
      real(wp), intent(out) :: step(:), jmax   !< Newton's step; the largest |entry| of the Jacobian
      integer, intent(out) :: info_la
      real(wp), allocatable :: jac(:, :), b(:, :), d(:)
      real(wp) :: e, r2, den
      integer :: i, m
      m = plan%band%n
      allocate (jac(0, 0), b(m, merge(2, 1, plan%free_train)), d(m))
      d = 0.0_wp; b = 0.0_wp; e = 0.0_wp; r2 = 0.0_wp
      call band_zero(plan%band)
      call assemble(model, plan, .false., jac, d)
      do i = 1, size(model%nodes)
         if (plan%row(i) == 0) cycle
         if (plan%dof(i) > 0) then
            b(plan%dof(i), 1) = -res(plan%row(i))
            if (plan%free_train) b(plan%dof(i), 2) = -model%nodes(i)%n%inertia()*plan%kappa(i)
         else
            r2 = -res(plan%row(i)); e = -model%nodes(i)%n%inertia()*plan%kappa(i)
         end if
      end do
      jmax = max(maxval([0.0_wp, abs(plan%band%ab)]), maxval([0.0_wp, abs(d), abs(e)]))
      if (plan%free_train) jmax = max(jmax, maxval([0.0_wp, abs(b(:, 2))]))
      call band_solve(plan%band, b, info_la)
      if (info_la /= 0) return
      if (.not. plan%free_train) then
         step = b(:, 1)
         return
      end if
      den = e - dot_product(d, b(:, 2))
      if (den == 0.0_wp) then
         info_la = plan%n
         return
      end if
      step(plan%n) = (r2 - dot_product(d, b(:, 1)))/den
      step(1:m) = b(:, 1) - step(plan%n)*b(:, 2)
   end subroutine band_step
end module trainsim_preload
