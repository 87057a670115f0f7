!> Plug-in conformance: every row of the node and element registries (so a
!> type added later is tested without editing this file) is built from its
!> example deck fragment into a small train and checked for what every plug-in
!> owes the rest of trainsim:
!>   - the analytic Jacobian matches central differences (elements: of `torques`
!>     in and out of contact; nodes: of `derivatives`; both: the assembled model
!>     Jacobian against differences of the right-hand side);
!>   - action and reaction: an element transmits no power through a motion that
!>     does not deform it (the null direction of its `displacement`);
!>   - the energy ledger closes over a short RK4 run, to RK4's order;
!>   - the parameters written to the HDF5 file read back equal to `params()`;
!>   - a bad value of each key of the example is rejected naming the key.
module test_conformance_checks
   use, intrinsic :: iso_c_binding, only: c_int
   use hdf5, only: hid_t, hsize_t, h5open_f, h5fopen_f, h5fclose_f, H5F_ACC_RDONLY_F, h5gopen_f, h5gclose_f, &
      h5aopen_by_name_f, h5aread_f, h5aclose_f, h5aget_num_attrs_f, h5eset_auto_f, H5T_NATIVE_DOUBLE
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: string_t, str
   use trainsim_deck, only: deck_t, parse_deck, deck_group_t
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_element, only: element_t
   use trainsim_el_lossy_gear, only: lossy_gear_t
   use trainsim_node, only: node_t
   use trainsim_param_list, only: param_list_t
   use trainsim_registry, only: element_row_t, node_row_t, element_registry, node_registry, make_element, &
      make_node, element_type_names, node_type_names
   use trainsim_observer, only: run_result_t
   use trainsim_simulate, only: simulate
   use trainsim_hdf5, only: hdf5_sink_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   implicit none
   private

   public :: run_conformance

   interface
      function c_getpid() bind(C, name='getpid') result(pid)
         import :: c_int
         integer(c_int) :: pid
      end function c_getpid
      subroutine dgeev(jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info)
         import :: wp
         character(len=1), intent(in) :: jobvl, jobvr
         integer, intent(in) :: n, lda, ldvl, ldvr, lwork
         real(wp), intent(inout) :: a(lda, *)
         real(wp), intent(out) :: wr(*), wi(*), vl(ldvl, *), vr(ldvr, *), work(*)
         integer, intent(out) :: info
      end subroutine dgeev
   end interface

   character(len=1), parameter :: nl = new_line('a')
   !> Central differences with h = eps^(1/3) |x| have truncation (h^2/6 T''') and
   !> rounding (eps T/h) errors both ~ eps^(2/3) = 4e-11 relative to |J|; 1e-6
   !> leaves four orders of magnitude for the curvature of the contact laws,
   !> while a wrong sign or factor in an analytic term is an O(1) error.
   real(wp), parameter :: h_rel = epsilon(1.0_wp)**(1.0_wp/3.0_wp)
   real(wp), parameter :: jac_tol = 1.0e-6_wp
   !> Energy runs: fixed-step RK4 at rho dt = 0.02 (rho: spectral radius of the
   !> linearised train) for n_steps steps.
   real(wp), parameter :: rho_dt = 0.02_wp
   integer, parameter :: n_steps = 1000
   character(len=:), allocatable :: tmp_prefix

contains

   !> The suite: the tables, then every element row, then every node row.
   subroutine run_conformance()
      type(element_row_t), allocatable :: erows(:)
      type(node_row_t), allocatable :: nrows(:)
      integer :: i, hdferr
      call suite_begin('plug-in conformance (every registry row)')
      call h5open_f(hdferr)
      call h5eset_auto_f(0, hdferr)
      tmp_prefix = temp_prefix()
      call test_registry_tables_are_consistent()
      allocate (erows, source=element_registry())   ! not `erows = ...`: gfortran 12 false -Wuninitialized
      do i = 1, size(erows)
         call element_conformance(erows(i))
      end do
      allocate (nrows, source=node_registry())
      do i = 1, size(nrows)
         call node_conformance(nrows(i))
      end do
      call suite_end()
   end subroutine run_conformance

   ! ------------------------------------------------------------ the tables

   subroutine test_registry_tables_are_consistent()
      type(element_row_t), allocatable :: er(:)
      type(node_row_t), allocatable :: nr(:)
      type(string_t), allocatable :: names(:)
      class(element_t), allocatable :: e1, e2
      class(node_t), allocatable :: n1, n2
      type(model_t) :: m
      type(error_t), allocatable :: err
      integer :: i, j
      logical :: ok

      call test_begin('registry: names, aliases and factories agree with make_* and the error messages')
      er = element_registry()
      nr = node_registry()
      allocate (names, source=element_type_names())
      ok = size(names) == size(er)
      do i = 1, min(size(names), size(er))
         ok = ok .and. names(i)%s == er(i)%name
      end do
      call check('element_type_names() is the table''s name column', ok)
      names = node_type_names()
      ok = size(names) == size(nr)
      do i = 1, min(size(names), size(nr))
         ok = ok .and. names(i)%s == nr(i)%name
      end do
      call check('node_type_names() is the table''s name column', ok)

      do i = 1, size(er)
         call check(er(i)%name//': has a summary and a factory', len(er(i)%summary) > 0 .and. associated(er(i)%make))
         call make_element(er(i)%name, e1)
         call check(er(i)%name//': make_element gives it, with its canonical type_name', allocated(e1))
         if (.not. allocated(e1)) cycle
         call check(er(i)%name//': type_name', e1%type_name == er(i)%name)
         call make_element(upper(er(i)%name), e2)
         call check(er(i)%name//': the name in upper case gives the same type', same_element_type(e1, e2))
         do j = 1, size(er(i)%aliases)
            call make_element(er(i)%aliases(j)%s, e2)
            call check(er(i)%name//': alias '//er(i)%aliases(j)%s//' gives the same type', same_element_type(e1, e2))
         end do
      end do
      do i = 1, size(nr)
         call check(nr(i)%name//': has a summary and a factory', len(nr(i)%summary) > 0 .and. associated(nr(i)%make))
         call make_node(nr(i)%name, n1)
         call check(nr(i)%name//': make_node gives it', allocated(n1))
         if (.not. allocated(n1)) cycle
         call check(nr(i)%name//': type_name', n1%type_name == nr(i)%name)
         do j = 1, size(nr(i)%aliases)
            call make_node(nr(i)%aliases(j)%s, n2)
            ok = allocated(n2)
            if (ok) ok = same_type_as(n1, n2)
            call check(nr(i)%name//': alias '//nr(i)%aliases(j)%s//' gives the same type', ok)
         end do
      end do
      call check('element names and aliases are lower case and unique', unique_lower(all_element_names(er)))
      call check('node names and aliases are lower case and unique', unique_lower(all_node_names(nr)))
      call make_element('no_such_type', e1)
      call check('an unknown element name gives nothing', .not. allocated(e1))
      call make_node('no_such_type', n1)
      call check('an unknown node name gives nothing', .not. allocated(n1))

      ! the deck error lists every row
      call try_build(element_deck('no_such_type', ''), m, err)
      ok = allocated(err)
      if (ok) then
         do i = 1, size(er)
            ok = ok .and. index(err%message, er(i)%name) > 0
         end do
      end if
      call check('"unknown element type" lists every element row', ok)
      call try_build(node_deck('no_such_type', ''), m, err)
      ok = allocated(err)
      if (ok) then
         do i = 1, size(nr)
            ok = ok .and. index(err%message, nr(i)%name) > 0
         end do
      end if
      call check('"unknown node type" lists every node row', ok)
   end subroutine test_registry_tables_are_consistent

   logical function same_element_type(a, b)
      class(element_t), allocatable, intent(in) :: a, b
      same_element_type = allocated(a) .and. allocated(b)
      if (same_element_type) same_element_type = same_type_as(a, b) .and. a%type_name == b%type_name
   end function same_element_type

   function all_element_names(rows) result(names)
      type(element_row_t), intent(in) :: rows(:)
      type(string_t), allocatable :: names(:)
      type(string_t) :: one
      integer :: i
      allocate (names(0))
      do i = 1, size(rows)
         one%s = rows(i)%name   ! (gfortran 12 loses string_t(rows(i)%name) in an array constructor)
         names = [names, one, rows(i)%aliases]
      end do
   end function all_element_names

   function all_node_names(rows) result(names)
      type(node_row_t), intent(in) :: rows(:)
      type(string_t), allocatable :: names(:)
      type(string_t) :: one
      integer :: i
      allocate (names(0))
      do i = 1, size(rows)
         one%s = rows(i)%name   ! (gfortran 12 loses string_t(rows(i)%name) in an array constructor)
         names = [names, one, rows(i)%aliases]
      end do
   end function all_node_names

   logical function unique_lower(names)
      type(string_t), intent(in) :: names(:)
      integer :: i, j
      unique_lower = .true.
      do i = 1, size(names)
         unique_lower = unique_lower .and. names(i)%s == lower(names(i)%s) .and. len(names(i)%s) > 0
         do j = i + 1, size(names)
            unique_lower = unique_lower .and. names(i)%s /= names(j)%s
         end do
      end do
   end function unique_lower

   ! --------------------------------------------------------------- elements

   !> The train of an element test: two disks (0.5 and 2.0) joined by it.
   function element_deck(name, fragment) result(text)
      character(len=*), intent(in) :: name, fragment
      character(len=:), allocatable :: text
      text = "&run t_end = 1.0, dt = 1.0e-3 /"//nl// &
             "&node id = 'left', type = 'inertia', inertia = 0.5 /"//nl// &
             "&node id = 'right', type = 'inertia', inertia = 2.0 /"//nl// &
             "&element id = 'dut', type = '"//name//"'"//with_comma(fragment)//" /"
   end function element_deck

   subroutine element_conformance(row)
      type(element_row_t), intent(in) :: row
      type(model_t) :: m
      type(error_t), allocatable :: err
      class(element_t), allocatable :: e
      real(wp) :: u(2), v(2), b_c
      real(wp), allocatable :: x(:, :)

      call test_begin(row%name//': the example builds and the type is documented')
      call try_build(element_deck(row%name, row%example), m, err)
      call check('example "'//row%example//'" builds'//message_of(err), .not. allocated(err))
      if (allocated(err)) return
      call check('type_name is the canonical name', m%elements(1)%e%type_name == row%name)
      call check('docs/elements.md and docs/deck.md have a section ### `'//row%name//'`', has_doc_section(row%name))
      allocate (e, source=m%elements(1)%e)
      call displacement_directions(e, u, v)
      call choose_states(row%name, e, u, v, x, b_c)
      if (size(x, 2) == 0) return

      call test_begin(row%name//': analytic torque Jacobian = central differences of torques ('// &
                      str(size(x, 2))//' states)')
      call check_torque_jacobian(e, x)

      call test_begin(row%name//': no power through a motion that does not deform it (tl v_l + tr v_r = 0; lossy: - its loss)')
      call check_rigid_motion_power(e, x, v)

      call test_begin(row%name//': assembled model Jacobian = central differences of the right-hand side')
      call check_model_jacobian(m, x)

      call test_begin(row%name//': the model (its family kernel, or the general path) = the type-bound procedures: '// &
                      'torques, guards, energies ('//str(size(x, 2))//' states, energy off and on)')
      call check_family_kernel(m, x)

      call test_begin(row%name//': energy ledger closes over an RK4 run; parameters round-trip through HDF5')
      call check_energy_and_file(m, 'element', x, u, v, b_c, m%elements(1)%e%n_guards() > 0 .and. &
                                 .not. m%elements(1)%e%con%on)

      call test_begin(row%name//': a bad value of each example key is rejected, naming the key')
      call check_bad_values('element', row%name, row%example, row%positive, row%nonnegative)
   end subroutine element_conformance

   !> The model's evaluation of its one element (the family kernel of its
   !> stage and step end when the element is in a family, else the general
   !> path) against the element's own type-bound procedures, at each state (its
   !> mode set there, as a run does) with energy tracking off and on: the
   !> element torques and the nodes' dy/dt (J = 0.5 and 2.0, no damping), the
   !> dissipated and input power, the stored energy (kinetic + the element's
   !> `potential_energy`), the guards. Tolerance 1e-12 relative: the tables take
   !> a plug-in's linear-spring claim when its procedures agree to that
   !> (`linear_element_agrees`); a hot form agrees bit for bit (D-35).
   subroutine check_family_kernel(m0, x)
      type(model_t), intent(in) :: m0
      real(wp), intent(in) :: x(:, :)
      type(model_t) :: m
      real(wp), allocatable :: y(:), dydt(:), dend(:), g(:), gref(:)
      real(wp) :: tl, tr, pw, pin, est, pot, worst, tl2, tr2
      integer :: c, ng, pass
      logical :: track, one_call
      worst = 0.0_wp
      one_call = .true.
      do pass = 1, 2
         track = pass == 2
         m = m0
         m%run%track_energy = track
         call m%finalize()
         do c = 1, size(x, 2)
            allocate (y(m%n_y), dydt(m%n_y), dend(m%n_y))
            y = 0.0_wp
            y(1:4) = x(:, c)
            call m%init_modes(0.0_wp, y)
            associate (e => m%elements(1)%e)
               call e%torques_dissipation(x(1, c), x(2, c), x(3, c), x(4, c), tl, tr, pw)
               ! (the general path makes the one call for both: D-178)
               call e%torques(x(1, c), x(2, c), x(3, c), x(4, c), tl2, tr2)
               one_call = one_call .and. tl2 == tl .and. tr2 == tr .and. &
                          e%dissipation_power(x(1, c), x(2, c), x(3, c), x(4, c)) == pw
               pin = 0.0_wp
               if (e%supplies_power) pin = e%input_power(x(1, c), x(2, c), x(3, c), x(4, c))
               call m%rhs_stage(0.0_wp, y, dydt)
               call worse(m%el_torque(1, 1), tl)
               call worse(m%el_torque(2, 1), tr)
               call worse(dydt(2), tl/0.5_wp)
               call worse(dydt(4), tr/2.0_wp)
               if (track) then
                  call worse(dydt(5), pw)
                  call worse(dydt(6), pin)
               end if
               call m%rhs_step_end(0.0_wp, y, dend)
               call check('state '//str(c)//merge(', energy on ', ', energy off', track)//': step end dy/dt = stage dy/dt', &
                          all(dend == dydt))
               call worse(m%el_torque(1, 1), tl)
               call worse(m%el_torque(2, 1), tr)
               call m%workspace_energy(y, est, pot)
               call worse(pot, e%potential_energy(x(1, c), x(3, c)))
               call worse(est, 0.25_wp*x(2, c)**2 + x(4, c)**2 + e%potential_energy(x(1, c), x(3, c)))
               ng = e%n_guards()
               if (ng > 0) then
                  allocate (g(m%n_guards), gref(ng))
                  call m%guards(0.0_wp, y, g)
                  call e%guards(x(1, c), x(2, c), x(3, c), x(4, c), gref)
                  call worse_all(g(1:ng), gref)
                  deallocate (g, gref)
               end if
            end associate
            deallocate (y, dydt, dend)
         end do
      end do
      call check('max relative mismatch (1e-12)', worst, 0.0_wp, abs_tol=1.0e-12_wp)
      call check('torques_dissipation = torques, dissipation_power bit for bit', one_call)
   contains
      subroutine worse(a, b)
         real(wp), intent(in) :: a, b
         if (a /= b) worst = max(worst, abs(a - b)/max(abs(a), abs(b), tiny(1.0_wp)))
      end subroutine worse
      subroutine worse_all(a, b)
         real(wp), intent(in) :: a(:), b(:)
         integer :: k
         do k = 1, size(a)
            call worse(a(k), b(k))
         end do
      end subroutine worse_all
   end subroutine check_family_kernel

   !> Gradient direction u (moving the nodes by s u changes the displacement by s)
   !> and null direction v (unit; moving along it does not deform the element).
   subroutine displacement_directions(e, u, v)
      class(element_t), intent(in) :: e
      real(wp), intent(out) :: u(2), v(2)
      real(wp) :: a, b
      ! the displacement is linear in the angles: unit differences are exact
      a = 0.5_wp*(e%displacement(1.0_wp, 0.0_wp) - e%displacement(-1.0_wp, 0.0_wp))
      b = 0.5_wp*(e%displacement(0.0_wp, 1.0_wp) - e%displacement(0.0_wp, -1.0_wp))
      u = [a, b]/(a**2 + b**2)
      v = [-b, a]/sqrt(a**2 + b**2)
      if (v(1) < 0.0_wp) v = -v
   end subroutine displacement_directions

   !> States (thl, wl, thr, wr) for the element checks, one per column. Smooth
   !> elements: two generic states. Elements with guards: the clearance is
   !> found along u from the centre (b_c: the displacement where contact
   !> begins), then one state open, one on the front face, one on the rear face.
   subroutine choose_states(name, e, u, v, x, b_c)
      character(len=*), intent(in) :: name
      class(element_t), intent(inout) :: e
      real(wp), intent(in) :: u(2), v(2)
      real(wp), allocatable, intent(out) :: x(:, :)
      real(wp), intent(out) :: b_c
      real(wp) :: lo, hi, mid, o(2)
      integer :: k
      b_c = 0.0_wp
      if (e%n_guards() == 0 .or. e%con%on) then
         x = reshape([0.013_wp, 3.0_wp, -0.002_wp, -1.0_wp, -0.4_wp, -0.5_wp, 0.25_wp, 2.0_wp], [4, 2])
         if (e%con%on) then
            ! an element that may stick (D-81): the states where it slips (its own torques
            ! are then all it puts on the nodes; stuck, the model adds the constraint torque)
            x = x(:, pack([1, 2], [(slips(x(:, k)), k=1, 2)]))
         end if
         return
      end if
      o = 0.02_wp*v   ! off the origin, where mesh-zone boundaries of gears may sit
      lo = 0.0_wp
      hi = 1.0e-9_wp
      do k = 1, 80
         if (contact_at(hi)) exit
         lo = hi
         hi = 2.0_wp*hi
      end do
      call check(name//': the clearance closes when the element is deformed (found at '//str(hi)//')', contact_at(hi))
      if (.not. contact_at(hi)) then
         allocate (x(4, 0))
         return
      end if
      do k = 1, 60
         mid = 0.5_wp*(lo + hi)
         if (contact_at(mid)) then
            hi = mid
         else
            lo = mid
         end if
      end do
      b_c = hi
      call check(name//': open at the centre of the clearance', .not. contact_at(0.0_wp))
      x = reshape([o(1), 3.0_wp, o(2), -1.0_wp, &
                   o(1) + 1.5_wp*b_c*u(1), 3.0_wp, o(2) + 1.5_wp*b_c*u(2), -1.0_wp, &
                   o(1) - 1.5_wp*b_c*u(1), 3.0_wp, o(2) - 1.5_wp*b_c*u(2), -1.0_wp], [4, 3])
   contains
      logical function contact_at(s)
         real(wp), intent(in) :: s
         call e%init_mode(o(1) + s*u(1), 0.0_wp, o(2) + s*u(2), 0.0_wp)
         contact_at = e%in_contact()
      end function contact_at
      logical function slips(xs)
         real(wp), intent(in) :: xs(4)
         call e%init_mode(xs(1), xs(2), xs(3), xs(4))
         slips = e%con%n == 0
      end function slips
   end subroutine choose_states

   subroutine check_torque_jacobian(e, x)
      class(element_t), intent(inout) :: e
      real(wp), intent(in) :: x(:, :)
      real(wp) :: ja(2, 4), jf(2, 4), xp(4), h, tlp, trp, tlm, trm, worst, scale
      real(wp), allocatable :: g(:)
      integer :: s, j
      logical :: inside
      worst = 0.0_wp
      scale = 0.0_wp
      inside = .true.
      allocate (g(e%n_guards()))
      do s = 1, size(x, 2)
         call e%init_mode(x(1, s), x(2, s), x(3, s), x(4, s))
         call e%torque_jacobian(x(1, s), x(2, s), x(3, s), x(4, s), ja)
         do j = 1, 4
            h = h_rel*max(abs(x(j, s)), 1.0e-2_wp)
            xp = x(:, s); xp(j) = x(j, s) + h
            call e%torques(xp(1), xp(2), xp(3), xp(4), tlp, trp)
            call e%guards(xp(1), xp(2), xp(3), xp(4), g)
            inside = inside .and. all(g > 0.0_wp)
            xp(j) = x(j, s) - h
            call e%torques(xp(1), xp(2), xp(3), xp(4), tlm, trm)
            call e%guards(xp(1), xp(2), xp(3), xp(4), g)
            inside = inside .and. all(g > 0.0_wp)
            jf(:, j) = [tlp - tlm, trp - trm]/(2.0_wp*h)
         end do
         worst = max(worst, maxval(abs(ja - jf)))
         scale = max(scale, maxval(abs(jf)))
      end do
      call check('difference stencils stay inside each state''s mode (all guards > 0)', inside)
      call check('the Jacobian is not identically zero', scale > 0.0_wp)
      if (scale > 0.0_wp) call check('max |J_analytic - J_fd| / max |J| (eps^(2/3) ~ 4e-11)', worst/scale, 0.0_wp, &
                                     abs_tol=jac_tol)
   end subroutine check_torque_jacobian

   subroutine check_rigid_motion_power(e, x, v)
      class(element_t), intent(inout) :: e
      real(wp), intent(in) :: x(:, :), v(2)
      real(wp) :: tl, tr, worst, ref, loss, d, fs
      integer :: s, loaded, contact, pairs
      worst = 0.0_wp
      loaded = 0
      do s = 1, size(x, 2)
         call e%init_mode(x(1, s), x(2, s), x(3, s), x(4, s))
         call e%torques(x(1, s), x(2, s), x(3, s), x(4, s), tl, tr)
         ref = abs(tl*v(1)) + abs(tr*v(2))
         loss = 0.0_wp
         select type (e)
         class is (lossy_gear_t)   ! a lossy mesh takes its loss (eta < 1) from the motion, no more
            call e%status(x(1, s), x(2, s), x(3, s), x(4, s), d, fs, contact, pairs)
            loss = e%mesh_loss(fs, v(1))
         end select
         if (ref > 0.0_wp) then
            loaded = loaded + 1
            worst = max(worst, abs(tl*v(1) + tr*v(2) + loss)/ref)
         end if
      end do
      write (*, '(a,2es12.4)') '    null direction of displacement (v_l, v_r):', v
      call check('some state transmits torque', loaded > 0)
      ! a few roundings of products of the same factors: a few eps
      call check('max |tl v_l + tr v_r| / (|tl v_l| + |tr v_r|)', worst, 0.0_wp, abs_tol=1.0e-13_wp)
   end subroutine check_rigid_motion_power

   ! ------------------------------------------------------------------ nodes

   !> The train of a node test: the node, a disk of 2.0, joined by a shaft.
   function node_deck(name, fragment) result(text)
      character(len=*), intent(in) :: name, fragment
      character(len=:), allocatable :: text
      text = "&run t_end = 1.0, dt = 1.0e-3 /"//nl// &
             "&node id = 'dut', type = '"//name//"'"//with_comma(fragment)//" /"//nl// &
             "&node id = 'other', type = 'inertia', inertia = 2.0 /"//nl// &
             "&element id = 'link', type = 'shaft', stiffness = 1.0e4, damping = 0.5, left = 'dut', right = 'other' /"
   end function node_deck

   subroutine node_conformance(row)
      type(node_row_t), intent(in) :: row
      type(model_t) :: m
      type(error_t), allocatable :: err
      real(wp), allocatable :: x(:, :)
      real(wp) :: u(2), v(2)
      integer :: n

      call test_begin(row%name//': the example builds and the type is documented')
      call try_build(node_deck(row%name, row%example), m, err)
      call check('example "'//row%example//'" builds'//message_of(err), .not. allocated(err))
      if (allocated(err)) return
      call check('type_name is the canonical name', m%nodes(1)%n%type_name == row%name)
      call check('docs/elements.md and docs/deck.md have a section ### `'//row%name//'`', has_doc_section(row%name))

      n = m%nodes(1)%n%nstates()
      if (n > 0) then
         call test_begin(row%name//': node Jacobian block = central differences of derivatives')
         call check_node_jacobian(m%nodes(1)%n)
      else
         write (*, '(a)') '    ('//row%name//' has no states: no node Jacobian to check)'
      end if

      ! the train's states: the node's own (angle, speed, extra states) then the disk's
      allocate (x(4, 1))
      x(:, 1) = [0.013_wp, 3.0_wp, -0.002_wp, -1.0_wp]
      call test_begin(row%name//': assembled model Jacobian = central differences of the right-hand side')
      call check_model_jacobian(m, x)

      u = [0.5_wp, -0.5_wp]
      v = [1.0_wp, 1.0_wp]/sqrt(2.0_wp)
      call test_begin(row%name//': energy ledger closes over an RK4 run; parameters round-trip through HDF5')
      call check_energy_and_file(m, 'node', x, u, v, 0.0_wp, .false.)

      call test_begin(row%name//': a bad value of each example key is rejected, naming the key')
      call check_bad_values('node', row%name, row%example, row%positive, row%nonnegative)
   end subroutine node_conformance

   subroutine check_node_jacobian(nd)
      class(node_t), intent(in) :: nd
      real(wp), allocatable :: y(:), yp(:), ja(:, :), jf(:, :), dtq(:), dtq_f(:), fp(:), fm(:)
      real(wp) :: t, torque, h, worst, scale
      integer :: n, j, o
      n = nd%nstates()
      o = nd%offset
      t = 0.05_wp
      torque = 3.0_wp
      allocate (y(o + n), ja(o + n, o + n), jf(n, n), dtq(n), dtq_f(n), fp(o + n), fm(o + n))
      y = [(0.3_wp + 0.7_wp*j, j=1, o + n)]
      ja = 0.0_wp
      call nd%jacobian(t, y, ja, dtq)
      do j = 1, n
         h = h_rel*max(abs(y(o + j)), 1.0e-2_wp)
         yp = y; yp(o + j) = y(o + j) + h
         fp = 0.0_wp; fm = 0.0_wp
         call nd%derivatives(t, yp, torque, fp)
         yp(o + j) = y(o + j) - h
         call nd%derivatives(t, yp, torque, fm)
         jf(:, j) = (fp(o + 1:o + n) - fm(o + 1:o + n))/(2.0_wp*h)
      end do
      h = h_rel*abs(torque)
      call nd%derivatives(t, y, torque + h, fp)
      call nd%derivatives(t, y, torque - h, fm)
      dtq_f = (fp(o + 1:o + n) - fm(o + 1:o + n))/(2.0_wp*h)
      scale = max(maxval(abs(jf)), maxval(abs(dtq_f)))
      worst = max(maxval(abs(ja(o + 1:o + n, o + 1:o + n) - jf)), maxval(abs(dtq - dtq_f)))
      call check('the block is not identically zero', scale > 0.0_wp)
      if (scale > 0.0_wp) call check('max |J_analytic - J_fd| / max |J|, states and net torque', worst/scale, 0.0_wp, &
                                     abs_tol=jac_tol)
   end subroutine check_node_jacobian

   ! ------------------------------------------------------------ both kinds

   !> The train's y from the two nodes' (angle, speed) in x (extra states: 0.1).
   function train_state(m, xs) result(y)
      type(model_t), intent(in) :: m
      real(wp), intent(in) :: xs(4)
      real(wp), allocatable :: y(:)
      integer :: i, o
      allocate (y(m%n_y))
      y = 0.1_wp
      if (m%n_y > m%n_states) y(m%n_states + 1:) = 0.0_wp
      do i = 1, 2
         o = m%nodes(i)%n%offset
         if (m%nodes(i)%n%nstates() >= 2) y(o + 1:o + 2) = xs(2*i - 1:2*i)
      end do
   end function train_state

   subroutine check_model_jacobian(m0, x)
      type(model_t), intent(in) :: m0
      real(wp), intent(in) :: x(:, :)
      type(model_t) :: m
      real(wp), allocatable :: y(:), yp(:), ja(:, :), fp(:), fm(:), jf(:, :)
      real(wp) :: t, h, worst, scale
      integer :: s, j, ns
      m = m0
      ns = m%n_states
      t = 0.0_wp
      worst = 0.0_wp
      scale = 0.0_wp
      allocate (ja(m%n_y, m%n_y), fp(m%n_y), fm(m%n_y), jf(ns, ns))
      do s = 1, size(x, 2)
         y = train_state(m, x(:, s))
         call m%init_modes(t, y)
         call m%jacobian(t, y, ja)
         do j = 1, ns
            h = h_rel*max(abs(y(j)), 1.0e-2_wp)
            yp = y; yp(j) = y(j) + h
            call m%rhs(t, yp, fp)
            yp(j) = y(j) - h
            call m%rhs(t, yp, fm)
            jf(:, j) = (fp(1:ns) - fm(1:ns))/(2.0_wp*h)
         end do
         worst = max(worst, maxval(abs(ja(1:ns, 1:ns) - jf)))
         scale = max(scale, maxval(abs(jf)))
      end do
      call check('the Jacobian is not identically zero', scale > 0.0_wp)
      if (scale > 0.0_wp) call check('max |J_model - J_fd| / max |J| (physical states)', worst/scale, 0.0_wp, &
                                     abs_tol=jac_tol)
   end subroutine check_model_jacobian

   !> Spectral radius of the linearised train (physical states) at y.
   real(wp) function spectral_radius(m, y) result(rho)
      type(model_t), intent(inout) :: m
      real(wp), intent(in) :: y(:)
      real(wp), allocatable :: ja(:, :), a(:, :), wr(:), wi(:), work(:)
      real(wp) :: vl(1, 1), vr(1, 1)
      integer :: ns, info
      ns = m%n_states
      allocate (ja(m%n_y, m%n_y), wr(ns), wi(ns), work(8*ns))
      call m%init_modes(0.0_wp, y)
      call m%jacobian(0.0_wp, y, ja)
      allocate (a, source=ja(1:ns, 1:ns))   ! not `a = ...`: gfortran 12 false -Wmaybe-uninitialized (Debug)
      call dgeev('N', 'N', ns, a, ns, wr, wi, vl, 1, vr, 1, work, size(work), info)
      rho = 0.0_wp
      if (info == 0) rho = maxval(hypot(wr, wi))
   end function spectral_radius

   !> A fixed-step RK4 run of the train with the energy ledger on, written to
   !> an HDF5 file: the ledger's residual against RK4's order, then the file's
   !> /<kind>s/dut parameters against params().
   !> The run starts undeformed (centre of any clearance) and deforms the
   !> element at line speed V along u, so a clearance closes a quarter of the
   !> way through, while the whole train turns along v.
   subroutine check_energy_and_file(m0, kind, x, u, v, b_c, closes)
      type(model_t), intent(in) :: m0
      character(len=*), intent(in) :: kind
      real(wp), intent(in) :: x(:, :), u(2), v(2), b_c
      logical, intent(in) :: closes
      type(model_t) :: m
      type(hdf5_sink_t) :: h5
      type(run_result_t) :: res
      type(error_t), allocatable :: err
      type(param_list_t) :: p
      real(wp) :: rho, dt, t_end, speed, w0, tol
      integer :: s, i
      m = m0
      rho = 0.0_wp
      do s = 1, size(x, 2)
         rho = max(rho, spectral_radius(m, train_state(m, x(:, s))))
      end do
      call check('the linearised train has a nonzero rate', rho > 0.0_wp)
      if (.not. rho > 0.0_wp) return
      dt = rho_dt/rho
      t_end = n_steps*dt
      m%run%integrator = 'rk4'
      m%run%t_start = 0.0_wp
      m%run%t_end = t_end
      m%run%dt = dt
      m%run%output_interval = 0.0_wp
      m%run%track_energy = .true.
      if (closes) then
         speed = b_c/(0.25_wp*t_end)
      else
         speed = 0.05_wp/t_end
      end if
      w0 = 0.3_wp/t_end
      do i = 1, 2
         associate (nd => m%nodes(i)%n)
            if (nd%is_fixed()) cycle
            nd%theta0 = 0.02_wp*v(i)
            nd%omega0 = speed*u(i) + w0*v(i)
         end associate
      end do
      call m%finalize()
      h5%path = tmp_prefix//'_'//kind//'.h5'
      call simulate(m, h5, res, err)
      call check('the run completes'//message_of(err), .not. allocated(err))
      if (allocated(err)) return
      write (*, '(a,es10.3,a,es10.3,a,i0,a)') '    rho = ', rho, ' 1/s, dt = ', dt, ' s, ', res%stats%events, ' events'
      if (closes) call check('the clearance closed during the run', res%stats%events >= 1)
      ! RK4's local error for y' = lambda y is (lambda dt)^5/120 |y|; the energy,
      ! quadratic, errs twice that; n_steps steps: n_steps (rho dt)^5 / 60 = 5e-8.
      ! Allowed: 10 times that for the nonlinear contact laws.
      tol = n_steps*rho_dt**5/6.0_wp
      call check('energy_scale > 0', res%energy_scale > 0.0_wp)
      if (res%energy_scale > 0.0_wp) call check('max |energy residual| / energy scale (RK4: n (rho dt)^5 / 6)', &
                                                 res%energy_residual_max/res%energy_scale, 0.0_wp, abs_tol=tol)
      if (kind == 'element') then
         p = m%elements(1)%e%params()
         call check_params_in_file(h5%path, '/elements/dut', p)
      else
         p = m%nodes(1)%n%params()
         call check_params_in_file(h5%path, '/nodes/dut', p)
      end if
      call remove_file(h5%path)
   end subroutine check_energy_and_file

   !> Every parameter is an attribute of `group` with the same value, bit for bit, and nothing else is.
   subroutine check_params_in_file(path, group, p)
      character(len=*), intent(in) :: path, group
      type(param_list_t), intent(in) :: p
      integer(hid_t) :: fid, gid, a
      integer :: hdferr, j, n_attr, n_same
      real(wp) :: value
      call h5fopen_f(path, H5F_ACC_RDONLY_F, fid, hdferr)
      call check('the HDF5 file opens', hdferr >= 0)
      if (hdferr < 0) return
      call h5gopen_f(fid, group, gid, hdferr)
      call check('group '//group//' exists', hdferr >= 0)
      if (hdferr >= 0) then
         call h5aget_num_attrs_f(gid, n_attr, hdferr)
         call check(group//' holds one attribute per parameter ('//str(size(p%values))//')', &
                    n_attr == size(p%values))
         n_same = 0
         do j = 1, size(p%values)
            call h5aopen_by_name_f(fid, group, p%names(j)%s, a, hdferr)
            if (hdferr < 0) cycle
            value = -huge(1.0_wp)
            call h5aread_f(a, H5T_NATIVE_DOUBLE, value, [1_hsize_t], hdferr)
            call h5aclose_f(a, hdferr)
            if (value == p%values(j)) then
               n_same = n_same + 1
            else
               write (*, '(a,2es24.16)') '    differs: '//p%names(j)%s, value, p%values(j)
            end if
         end do
         call check('every parameter reads back equal to params()', n_same == size(p%values))
         call h5gclose_f(gid, hdferr)
      end if
      call h5fclose_f(fid, hdferr)
   end subroutine check_params_in_file

   !> For each key of the example: `nan` is rejected naming the key; a key
   !> that must be > 0 is rejected at 0 and below; a key that must be >= 0 is
   !> rejected below 0 and accepted at 0.
   subroutine check_bad_values(kind, name, example, positive, nonnegative)
      character(len=*), intent(in) :: kind, name, example
      type(string_t), intent(in) :: positive(:), nonnegative(:)
      type(deck_t) :: frag
      type(error_t), allocatable :: err
      integer :: k, n_rejected, n_cases
      logical :: listed_ok
      character(len=:), allocatable :: key, value
      call parse_deck('&example '//example//' /', 'example', frag, err)
      call check('the example fragment parses'//message_of(err), .not. allocated(err))
      if (allocated(err)) return
      if (frag%groups(1)%nentries() == 0) then
         write (*, '(a)') '    (the example has no keys: nothing to corrupt)'
         return
      end if
      listed_ok = .true.
      do k = 1, size(positive)
         listed_ok = listed_ok .and. entry_index(frag%groups(1), positive(k)%s) > 0
      end do
      do k = 1, size(nonnegative)
         listed_ok = listed_ok .and. entry_index(frag%groups(1), nonnegative(k)%s) > 0
      end do
      call check('the row''s > 0 and >= 0 keys are keys of its example', listed_ok)
      n_rejected = 0
      n_cases = 0
      do k = 1, frag%groups(1)%nentries()
         key = frag%groups(1)%key_of(k)
         value = frag%groups(1)%value_of(k, 1)
         call expect_rejected(key, 'nan')
         if (in_list(key, positive)) then
            call expect_rejected(key, '0.0')
            call expect_rejected(key, negated(value))
         end if
         if (in_list(key, nonnegative)) then
            call expect_rejected(key, negated(value))
            call expect_accepted(key, '0.0')
         end if
      end do
      write (*, '(a,i0,a,i0,a)') '    ', n_rejected, ' of ', n_cases, ' bad values rejected naming their key'
      call check('every bad value is rejected with its key named', n_rejected == n_cases)
   contains
      subroutine expect_rejected(key, bad)
         character(len=*), intent(in) :: key, bad
         type(model_t) :: m
         type(error_t), allocatable :: e
         n_cases = n_cases + 1
         call try_build(deck_of(kind, name, with_value(frag%groups(1), key, bad)), m, e)
         if (.not. allocated(e)) then
            write (*, '(a)') '    accepted: '//key//' = '//bad
         else if (index(e%message, "key '"//key//"'") == 0) then
            write (*, '(a)') '    rejected without naming the key: '//key//' = '//bad//': '//e%message
         else
            n_rejected = n_rejected + 1
         end if
      end subroutine expect_rejected
      subroutine expect_accepted(key, good)
         character(len=*), intent(in) :: key, good
         type(model_t) :: m
         type(error_t), allocatable :: e
         call try_build(deck_of(kind, name, with_value(frag%groups(1), key, good)), m, e)
         call check(key//' = '//good//' (the rule''s boundary) is accepted'//message_of(e), .not. allocated(e))
      end subroutine expect_accepted
   end subroutine check_bad_values

   function deck_of(kind, name, fragment) result(text)
      character(len=*), intent(in) :: kind, name, fragment
      character(len=:), allocatable :: text
      if (kind == 'element') then
         text = element_deck(name, fragment)
      else
         text = node_deck(name, fragment)
      end if
   end function deck_of

   !> The fragment again, with `key`'s value replaced by the token `value`
   !> (quoted if the example's value was a quoted string).
   function with_value(g, key, value) result(text)
      type(deck_group_t), intent(in) :: g
      character(len=*), intent(in) :: key, value
      character(len=:), allocatable :: text, tok
      integer :: k
      text = ''
      do k = 1, g%nentries()
         tok = g%value_of(k, 1)
         if (g%key_of(k) == key) tok = value
         if (g%quoted(k, 1)) tok = "'"//tok//"'"
         if (k > 1) text = text//', '
         text = text//g%key_of(k)//' = '//tok
      end do
   end function with_value

   integer function entry_index(g, key) result(idx)
      type(deck_group_t), intent(in) :: g
      character(len=*), intent(in) :: key
      integer :: k
      idx = 0
      do k = 1, g%nentries()
         if (g%key_of(k) == key) idx = k
      end do
   end function entry_index

   logical function in_list(key, list)
      character(len=*), intent(in) :: key
      type(string_t), intent(in) :: list(:)
      integer :: k
      in_list = .false.
      do k = 1, size(list)
         in_list = in_list .or. list(k)%s == key
      end do
   end function in_list

   !> '-x' for 'x' (a negative value for a positive example value).
   function negated(token) result(s)
      character(len=*), intent(in) :: token
      character(len=:), allocatable :: s
      if (token(1:1) == '-') then
         s = '-1.0'
      else
         s = '-'//token
      end if
   end function negated

   ! ---------------------------------------------------------------- helpers

   subroutine try_build(text, m, err)
      character(len=*), intent(in) :: text
      type(model_t), intent(out) :: m
      type(error_t), allocatable, intent(out) :: err
      type(deck_t) :: deck
      call parse_deck(text, 'conformance.nml', deck, err)
      if (.not. allocated(err)) call build_model(deck, m, err)
      if (.not. allocated(err)) m%run%output = ''
   end subroutine try_build

   function message_of(err) result(s)
      type(error_t), allocatable, intent(in) :: err
      character(len=:), allocatable :: s
      s = ''
      if (allocated(err)) s = ' ('//err%message//')'
   end function message_of

   function with_comma(fragment) result(s)
      character(len=*), intent(in) :: fragment
      character(len=:), allocatable :: s
      s = ''
      if (len_trim(fragment) > 0) s = ', '//fragment
   end function with_comma

   !> Whether both reference pages, docs/elements.md (equations) and docs/deck.md
   !> (keys), have a heading "### `name`".
   logical function has_doc_section(name)
      character(len=*), intent(in) :: name
      has_doc_section = has_heading('docs/elements.md', name)
      if (has_doc_section) has_doc_section = has_heading('docs/deck.md', name)
   end function has_doc_section

   logical function has_heading(path, name)
      character(len=*), intent(in) :: path, name
      character(len=1024) :: line
      integer :: unit, ios
      has_heading = .false.
      open (newunit=unit, file=path, status='old', action='read', iostat=ios)
      if (ios /= 0) return
      do
         read (unit, '(a)', iostat=ios) line
         if (ios /= 0) exit
         if (index(line, '### `'//name//'`') == 1) has_heading = .true.
      end do
      close (unit)
   end function has_heading

   pure function lower(s) result(r)
      character(len=*), intent(in) :: s
      character(len=len(s)) :: r
      integer :: i
      r = s
      do i = 1, len(s)
         if (s(i:i) >= 'A' .and. s(i:i) <= 'Z') r(i:i) = achar(iachar(s(i:i)) + 32)
      end do
   end function lower

   pure function upper(s) result(r)
      character(len=*), intent(in) :: s
      character(len=len(s)) :: r
      integer :: i
      r = s
      do i = 1, len(s)
         if (s(i:i) >= 'a' .and. s(i:i) <= 'z') r(i:i) = achar(iachar(s(i:i)) - 32)
      end do
   end function upper

   function temp_prefix() result(prefix)
      character(len=:), allocatable :: prefix
      character(len=512) :: dir
      integer :: n, stat
      call get_environment_variable('TMPDIR', dir, n, stat)
      if (stat /= 0 .or. n == 0) dir = '/tmp'
      prefix = trim(dir)//'/trainsim_conformance_'//str(int(c_getpid()))
   end function temp_prefix

   subroutine remove_file(path)
      character(len=*), intent(in) :: path
      integer :: unit, ios
      open (newunit=unit, file=path, status='old', iostat=ios)
      if (ios == 0) close (unit, status='delete')
   end subroutine remove_file
end module test_conformance_checks

!> One CTest entry: the whole conformance suite.
program test_conformance
   use test_conformance_checks, only: run_conformance
   implicit none
   call run_conformance()
end program test_conformance
