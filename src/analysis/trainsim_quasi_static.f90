!> The quasi-static reference of each gear mesh (issue 26 item 5, D-103): the static
!> mesh force and the loaded static transmission error at the run's loads, from the
!> static equilibrium (trainsim_preload) at `static_positions` driver positions
!> spread evenly over one mesh cycle, for the dynamic factor Kv = max dynamic /
!> max static mesh force (trainsim_observer, obs_finish). With per-tooth errors,
!> run-out or a fault (the element's `hunting_period` H > 1) the positions span the
!> whole hunting period, 24 per mesh cycle over H cycles (at most max_static_cycles), so
!> every pair of teeth is met (D-118).
!>
!> A gear mesh is an element with the parameter `mesh_period_angle` (2 pi / N of its
!> driver, the left node): spur_gear, helical_gear. For position j the whole train
!> is turned rigidly from the run's initial angles by kappa_n (j/M) (2 pi / N) (kappa:
!> each node's speed per unit speed of the mesh's driver, along the elements'
!> closed-contact ratios, trainsim_model's rigid_speeds), and the preload solver
!> finds the wind-up there: the held nodes (or the reference of a free train) keep
!> the turned angle, every free node is solved for, every clearance closed on the
!> face the loads press it to and every mesh zone taken from the angles. The
!> element's `status` at the solution gives the static mesh force and TE. The
!> model's initial angles are restored afterwards (the run's `init_modes` then sets
!> every mode afresh), so the run itself is unchanged.
!>
!> The solves are linear in the train's size (D-152): the preload's plan (its
!> unknowns and banded numbering) is made once, its Newton steps are banded solves, and
!> meshes whose positions turn the train alike share the solves (a chain of equal gears:
!> two sets of positions, one per sense of rotation, for any number of meshes).
!>
!> Not computed (every figure 0, `note` says why): no gear mesh; the preload fails (an
!> element with more than two ports, a train held by nothing). With a gear mesh,
!> `kv_absent` gives that reason for the print-out's warning and the output file's
!> attribute `kv_absent` (D-138). Not the hot path: called once before a run.
module trainsim_quasi_static
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t, closed_speed_ratio
   use trainsim_preload, only: preload_info_t, preload_plan_t, preload_prepare, preload_solve
   use trainsim_param_list, only: param_list_t, param_of
   implicit none
   private

   public :: static_ref_t, static_reference, mesh_period_angle, static_positions, max_static_cycles
   public :: kv_absent

   !> Driver positions per mesh cycle (a two-level stiffness has two static values;
   !> 24 places at least 7 in the shorter zone of any contact ratio in [1.3, 1.7]).
   integer, parameter :: static_positions = 24
   !> Most mesh cycles of a hunting period the static reference spans (24 positions each;
   !> a longer period is cut here: 48 000 static solves).
   integer, parameter :: max_static_cycles = 2000

   !> Per element (0 for an element that is no gear mesh, or when not computed).
   type :: static_ref_t
      logical :: computed = .false.
      character(len=:), allocatable :: note      !< why not computed ('' if computed)
      real(wp), allocatable :: force(:)          !< the static mesh force of largest magnitude (signed: its face)
      real(wp), allocatable :: te_min(:), te_max(:), te_mean(:)   !< loaded static TE over the cycle
      logical, allocatable :: mesh(:)            !< the element is a gear mesh
      real(wp), allocatable :: period(:)         !< its driver's angle of one tooth, 2 pi / N (0: no mesh)
   end type static_ref_t

contains

   !> 2 pi / N of a gear mesh's driver (its parameter mesh_period_angle), 0 for any other element.
   real(wp) function mesh_period_angle(model, i) result(a)
      type(model_t), intent(in) :: model
      integer, intent(in) :: i
      a = period_of(model%elements(i)%e%params())
   end function mesh_period_angle

   !> mesh_period_angle from an element's parameter list.
   pure real(wp) function period_of(p) result(a)
      type(param_list_t), intent(in) :: p
      a = param_of(p, 'mesh_period_angle', 0.0_wp)
      if (.not. a > 0.0_wp) a = 0.0_wp
   end function period_of

   !> Mesh cycles the static reference of element i spans: its hunting period (per-tooth
   !> errors, run-out, a fault: the excitation repeats after lcm(N1, N2) cycles or a gear's
   !> turn), at most max_static_cycles; 1 without such data.
   pure integer function static_cycles(p) result(nc)
      type(param_list_t), intent(in) :: p
      real(wp) :: h
      h = param_of(p, 'hunting_period', 1.0_wp)
      nc = 1
      if (h >= 1.0_wp) nc = nint(min(h, real(max_static_cycles, wp)))
   end function static_cycles

   !> Why the gear meshes of `ref` have no static reference, so no Kv or static TE
   !> ('' when it was computed, or when there is no gear mesh).
   function kv_absent(ref) result(why)
      type(static_ref_t), intent(in) :: ref
      character(len=:), allocatable :: why
      why = ''
      if (ref%computed .or. .not. allocated(ref%mesh) .or. .not. allocated(ref%note)) return
      if (any(ref%mesh)) why = ref%note
   end function kv_absent

   !> The static reference of every gear mesh of `model` (see the module note). Meshes whose
   !> positions turn the train alike (the same driver angle per cycle, seen from the first
   !> mesh's driver, and as many positions) share their static solves (D-152).
   subroutine static_reference(model, ref)
      type(model_t), intent(inout) :: model
      type(static_ref_t), intent(out) :: ref
      real(wp), allocatable :: theta_saved(:), kappa(:)
      integer, allocatable :: npos(:), group(:)
      logical, allocatable :: known(:)
      type(preload_plan_t) :: plan
      type(param_list_t) :: p
      type(error_t), allocatable :: err
      integer :: ne, nn, i, k, n
      logical :: turned, turns_held, kept
      ne = size(model%elements); nn = size(model%nodes)
      turned = .false.
      allocate (ref%force(ne), ref%te_min(ne), ref%te_max(ne), ref%te_mean(ne), ref%mesh(ne), ref%period(ne))
      allocate (npos(ne), group(ne))
      ref%force = 0.0_wp; ref%te_min = 0.0_wp; ref%te_max = 0.0_wp; ref%te_mean = 0.0_wp
      ref%note = ''
      npos = 0
      kept = .false.   ! the builder's lists, not asked again (D-175)
      if (allocated(model%element_params)) kept = size(model%element_params) == ne
      do i = 1, ne
         if (kept) then
            ref%period(i) = period_of(model%element_params(i))
            if (ref%period(i) > 0.0_wp) npos(i) = static_positions*static_cycles(model%element_params(i))
         else
            p = model%elements(i)%e%params()
            ref%period(i) = period_of(p)
            if (ref%period(i) > 0.0_wp) npos(i) = static_positions*static_cycles(p)
         end if
      end do
      ref%mesh = ref%period > 0.0_wp
      if (.not. any(ref%mesh)) then
         ref%note = 'no gear mesh'
         return
      end if
      theta_saved = [(model%nodes(n)%n%theta0, n=1, nn)]
      call preload_prepare(model, plan, err)
      group = 0
      do i = 1, ne
         if (allocated(err)) exit
         if (.not. ref%mesh(i) .or. group(i) /= 0) cycle
         call rigid_ratios(model, model%elements(i)%e%left, kappa, known)
         do k = i, ne   ! the meshes this one's positions serve
            if (group(k) /= 0 .or. .not. ref%mesh(k) .or. npos(k) /= npos(i)) cycle
            if (.not. known(model%elements(k)%e%left)) cycle
            if (ref%period(k)/kappa(model%elements(k)%e%left) == ref%period(i)) group(k) = i
         end do
         call group_solves(model, plan, ref, i, group, npos(i), theta_saved, kappa, known, turns_held, err)
         turned = turned .or. turns_held
      end do
      if (allocated(err)) ref%note = err%message
      do n = 1, nn
         model%nodes(n)%n%theta0 = theta_saved(n)
      end do
      ! The tables hold held nodes' angles: rebuilt when a solve turned one. Otherwise the
      ! run's init_modes refreshes every element's mode-dependent row as it does after a
      ! rebuild, unless constraints may have engaged in the solves (80 M instructions at
      ! 20 000 nodes; startup7b, D-158).
      if (turned .or. model%n_cand > 0) call model%build_fast_path()
      ref%computed = len(ref%note) == 0
      if (.not. ref%computed) then
         ref%force = 0.0_wp; ref%te_min = 0.0_wp; ref%te_max = 0.0_wp; ref%te_mean = 0.0_wp
      end if
   end subroutine static_reference

   !> The static solves at the npos positions of mesh g (the train turned rigidly by kappa
   !> per unit angle of g's driver), and the static force and TE of every mesh of g's group.
   subroutine group_solves(model, plan, ref, g, group, npos, theta_saved, kappa, known, turns_held, err)
      type(model_t), intent(inout) :: model
      type(preload_plan_t), intent(inout) :: plan
      type(static_ref_t), intent(inout) :: ref
      integer, intent(in) :: g, group(:), npos
      real(wp), intent(in) :: theta_saved(:), kappa(:)
      logical, intent(in) :: known(:)
      logical, intent(out) :: turns_held   !< a held node turned (the tables were rebuilt)
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: y(:), fmag(:)
      type(preload_info_t) :: info
      real(wp) :: d, f
      integer :: j, n, m, l, r, c, pp
      allocate (fmag(size(group)))
      fmag = -1.0_wp
      turns_held = .false.   ! (a held node's angle is in the fast-path tables)
      do n = 1, size(model%nodes)
         if (known(n) .and. model%is_held(n) .and. .not. model%nodes(n)%n%is_fixed()) turns_held = .true.
      end do
      do j = 0, npos - 1
         do n = 1, size(model%nodes)
            model%nodes(n)%n%theta0 = theta_saved(n)
            if (known(n) .and. .not. model%nodes(n)%n%is_fixed()) &
               model%nodes(n)%n%theta0 = theta_saved(n) + kappa(n)*ref%period(g)*real(j, wp)/real(static_positions, wp)
         end do
         if (turns_held) call model%build_fast_path()
         call preload_solve(model, plan, info, err, rounding_floor=npos > static_positions, tables=.false.)
         if (allocated(err)) return
         call model%initial_state(y)
         call model%kinematics(model%run%t_start, y)
         do m = g, size(group)
            if (group(m) /= g) cycle
            l = model%elements(m)%e%left; r = model%elements(m)%e%right
            call model%elements(m)%e%status(model%theta(l), model%omega(l), model%theta(r), model%omega(r), d, f, c, pp)
            if (j == 0) then
               ref%te_min(m) = d; ref%te_max(m) = d
            end if
            ref%te_min(m) = min(ref%te_min(m), d); ref%te_max(m) = max(ref%te_max(m), d)
            ref%te_mean(m) = ref%te_mean(m) + d/real(npos, wp)
            if (abs(f) > fmag(m)) then
               fmag(m) = abs(f); ref%force(m) = f
            end if
         end do
      end do
   end subroutine group_solves

   !> Speed of each node per unit speed of node `ref` when the train turns rigidly, carried
   !> breadth-first along the elements' closed-contact speed ratios (as trainsim_model's
   !> rigid_speeds, whose passes over the element list cost O(n^2) from a driver in the
   !> middle of a chain; the same products along a tree's paths). Elements touching a
   !> fixed node carry nothing. known: reached from ref.
   subroutine rigid_ratios(model, ref, w, known)
      type(model_t), intent(in) :: model
      integer, intent(in) :: ref
      real(wp), allocatable, intent(out) :: w(:)
      logical, allocatable, intent(out) :: known(:)
      integer, allocatable :: first(:), adj(:), fill(:), queue(:)
      integer :: nn, ne, j, l, r, v, head, tail, k
      real(wp) :: rho
      nn = size(model%nodes); ne = size(model%elements)
      allocate (w(nn), known(nn), first(nn + 1), fill(nn), adj(2*ne), queue(nn))
      w = 0.0_wp; known = .false.
      first = 0
      do j = 1, ne
         l = model%elements(j)%e%left; r = model%elements(j)%e%right
         first(l + 1) = first(l + 1) + 1; first(r + 1) = first(r + 1) + 1
      end do
      first(1) = 1
      do v = 1, nn
         first(v + 1) = first(v + 1) + first(v)
      end do
      fill = first(1:nn)
      do j = 1, ne   ! each node's elements, in element order
         l = model%elements(j)%e%left; r = model%elements(j)%e%right
         adj(fill(l)) = j; fill(l) = fill(l) + 1
         adj(fill(r)) = j; fill(r) = fill(r) + 1
      end do
      w(ref) = 1.0_wp; known(ref) = .true.
      head = 1; tail = 1; queue(1) = ref
      do while (head <= tail)
         v = queue(head); head = head + 1
         do k = first(v), first(v + 1) - 1
            j = adj(k)
            l = model%elements(j)%e%left; r = model%elements(j)%e%right
            if (model%nodes(l)%n%is_fixed() .or. model%nodes(r)%n%is_fixed()) cycle
            if (known(l) .and. known(r)) cycle
            rho = closed_speed_ratio(model, j)
            if (rho == 0.0_wp) cycle
            if (known(l)) then
               w(r) = rho*w(l); known(r) = .true.
               tail = tail + 1; queue(tail) = r
            else
               w(l) = w(r)/rho; known(l) = .true.
               tail = tail + 1; queue(tail) = l
            end if
         end do
      end do
   end subroutine rigid_ratios
end module trainsim_quasi_static
