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
!> Not computed (every figure 0, `note` says why): no gear mesh; more than
!> max_static_nodes nodes (the preload's dense Newton would cost more than the run
!> is worth); the preload fails (an element with more than two ports, a train held by
!> nothing). With a gear mesh, `kv_absent` gives that reason for the print-out's
!> warning and the output file's attribute `kv_absent` (D-138). Not the hot
!> path: called once before a run.
module trainsim_quasi_static
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t, rigid_speeds
   use trainsim_preload, only: preload_info_t, apply_preload
   use trainsim_param_list, only: param_list_t
   use trainsim_strings, only: str
   implicit none
   private

   public :: static_ref_t, static_reference, mesh_period_angle, static_positions, max_static_nodes, max_static_cycles
   public :: kv_absent

   !> Driver positions per mesh cycle (a two-level stiffness has two static values;
   !> 24 places at least 7 in the shorter zone of any contact ratio in [1.3, 1.7]).
   integer, parameter :: static_positions = 24
   !> Largest train (nodes) whose static reference is computed.
   integer, parameter :: max_static_nodes = 400
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
      a = param_value(model, i, 'mesh_period_angle', 0.0_wp)
      if (.not. a > 0.0_wp) a = 0.0_wp
   end function mesh_period_angle

   !> Element i's parameter `name`, or `default` if it has none.
   real(wp) function param_value(model, i, name, default) result(a)
      type(model_t), intent(in) :: model
      integer, intent(in) :: i
      character(len=*), intent(in) :: name
      real(wp), intent(in) :: default
      type(param_list_t) :: p
      integer :: k
      a = default
      p = model%elements(i)%e%params()
      if (.not. allocated(p%names)) return
      do k = 1, size(p%names)
         if (p%names(k)%s == name) a = p%values(k)
      end do
   end function param_value

   !> Mesh cycles the static reference of element i spans: its hunting period (per-tooth
   !> errors, run-out, a fault: the excitation repeats after lcm(N1, N2) cycles or a gear's
   !> turn), at most max_static_cycles; 1 without such data.
   integer function static_cycles(model, i) result(nc)
      type(model_t), intent(in) :: model
      integer, intent(in) :: i
      real(wp) :: h
      h = param_value(model, i, 'hunting_period', 1.0_wp)
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

   !> The static reference of every gear mesh of `model` (see the module note).
   subroutine static_reference(model, ref)
      type(model_t), intent(inout) :: model
      type(static_ref_t), intent(out) :: ref
      real(wp), allocatable :: theta_saved(:), kappa(:), y(:)
      logical, allocatable :: known(:)
      type(preload_info_t) :: info
      type(error_t), allocatable :: err
      real(wp) :: d, f, fmag
      integer :: ne, nn, i, j, n, l, r, c, p, loop_el, npos
      ne = size(model%elements); nn = size(model%nodes)
      allocate (ref%force(ne), ref%te_min(ne), ref%te_max(ne), ref%te_mean(ne), ref%mesh(ne), ref%period(ne))
      ref%force = 0.0_wp; ref%te_min = 0.0_wp; ref%te_max = 0.0_wp; ref%te_mean = 0.0_wp
      ref%note = ''
      do i = 1, ne
         ref%period(i) = mesh_period_angle(model, i)
      end do
      ref%mesh = ref%period > 0.0_wp
      if (.not. any(ref%mesh)) then
         ref%note = 'no gear mesh'
         return
      end if
      if (nn > max_static_nodes) then
         ref%note = 'the train has '//str(nn)//' nodes, more than '//str(max_static_nodes)// &
                    ' (the static solve is dense: max_static_nodes)'
         return
      end if
      theta_saved = [(model%nodes(n)%n%theta0, n=1, nn)]
      mesh_loop: do i = 1, ne
         if (.not. ref%mesh(i)) cycle
         l = model%elements(i)%e%left; r = model%elements(i)%e%right
         call rigid_speeds(model, l, 1.0_wp, kappa, known, loop_el)
         fmag = -1.0_wp
         npos = static_positions*static_cycles(model, i)
         do j = 0, npos - 1
            do n = 1, nn
               model%nodes(n)%n%theta0 = theta_saved(n)
               if (known(n) .and. .not. model%nodes(n)%n%is_fixed()) &
                  model%nodes(n)%n%theta0 = theta_saved(n) + kappa(n)*ref%period(i)*real(j, wp)/real(static_positions, wp)
            end do
            call apply_preload(model, info, err, rounding_floor=npos > static_positions)
            if (allocated(err)) then
               ref%note = err%message
               exit mesh_loop
            end if
            call model%initial_state(y)
            call model%kinematics(model%run%t_start, y)
            call model%elements(i)%e%status(model%theta(l), model%omega(l), model%theta(r), model%omega(r), d, f, c, p)
            if (j == 0) then
               ref%te_min(i) = d; ref%te_max(i) = d
            end if
            ref%te_min(i) = min(ref%te_min(i), d); ref%te_max(i) = max(ref%te_max(i), d)
            ref%te_mean(i) = ref%te_mean(i) + d/real(npos, wp)
            if (abs(f) > fmag) then
               fmag = abs(f); ref%force(i) = f
            end if
         end do
      end do mesh_loop
      do n = 1, nn
         model%nodes(n)%n%theta0 = theta_saved(n)
      end do
      call model%build_fast_path()   ! (held nodes' angles in the tables: the run's init_modes rebuilds them too)
      ref%computed = len(ref%note) == 0
      if (.not. ref%computed) then
         ref%force = 0.0_wp; ref%te_min = 0.0_wp; ref%te_max = 0.0_wp; ref%te_mean = 0.0_wp
      end if
   end subroutine static_reference
end module trainsim_quasi_static
