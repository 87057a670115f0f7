!> The static preload's banded solve (D-152) against the dense LU it replaced:
!> a reverse Cuthill-McKee-numbered band solve of a branched train's stiffness against
!> a dense Gaussian elimination, and the whole preload (Newton, contact faces, mesh zones) of a
!> random-ish branched train with gears and clearances, held and free, banded against
!> dense. Both solve the same equations by LU with partial pivoting; they differ by the
!> order of the eliminations only, so by round-off: a few eps times the condition number
!> (< 1e4 here), below 1e-12 relative. And the static reference of a 1 000-node chain
!> against its closed form.
program test_band_preload
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_model, only: model_t
   use trainsim_preload, only: preload_info_t, apply_preload
   use trainsim_band_solve, only: band_plan_t, band_plan, band_zero, band_add, band_solve
   use trainsim_strings, only: str
   use trainsim_quasi_static, only: static_ref_t, static_reference
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text
   implicit none


   !> Round-off of two LU orders on a matrix of condition number < 1e4: 1e4 * 100 eps.
   real(wp), parameter :: lu_tol = 1.0e-12_wp
   integer :: seed = 12345

   call suite_begin('banded static solve against the dense one (D-152)')
   call test_band_solve_equals_dense_on_a_tree()
   call test_preload_banded_equals_dense_held_train()
   call test_preload_banded_equals_dense_free_train()
   call test_static_force_of_every_mesh_of_a_long_chain()
   call suite_end()

contains

   !> A number in [0, 1) from a fixed linear congruential sequence (the same train each run).
   real(wp) function uniform()
      seed = modulo(seed*1103515245 + 12345, 2147483647)
      uniform = real(seed, wp)/2147483647.0_wp
   end function uniform

   !> Parent of node k (>= 2) in a random tree: any earlier node, so the tree branches
   !> everywhere and its deck numbering is wide (the band solve renumbers it).
   integer function parent_of(k)
      integer, intent(in) :: k
      parent_of = min(k - 1, 1 + int(real(k - 1, wp)*uniform()))
   end function parent_of

   !> x of a x = b by Gaussian elimination with partial pivoting on the full matrix (the
   !> dense reference, written here; a and b overwritten, x in b).
   subroutine gauss(a, b)
      real(wp), intent(inout) :: a(:, :), b(:)
      integer :: k, p, i, n
      real(wp) :: f
      n = size(b)
      do k = 1, n
         p = k - 1 + maxloc(abs(a(k:n, k)), 1)
         a([k, p], :) = a([p, k], :); b([k, p]) = b([p, k])
         do i = k + 1, n
            f = a(i, k)/a(k, k)
            a(i, k:n) = a(i, k:n) - f*a(k, k:n); b(i) = b(i) - f*b(k)
         end do
      end do
      do k = n, 1, -1
         b(k) = (b(k) - dot_product(a(k, k + 1:n), b(k + 1:n)))/a(k, k)
      end do
   end subroutine gauss

   subroutine test_band_solve_equals_dense_on_a_tree()
      integer, parameter :: n = 80
      type(band_plan_t) :: plan
      integer :: ea(n - 1), eb(n - 1), k, info
      real(wp) :: a(n, n), b(n, 1), x(n, 1), kk
      call test_begin('band_solve_equals_dense_on_a_tree')
      a = 0.0_wp
      do k = 2, n   ! stiffness of a tree of springs, node 1 tied to ground
         ea(k - 1) = parent_of(k); eb(k - 1) = k
         kk = 10.0_wp**(2.0_wp + 2.0_wp*uniform())
         a(k, k) = a(k, k) + kk; a(ea(k - 1), ea(k - 1)) = a(ea(k - 1), ea(k - 1)) + kk
         a(k, ea(k - 1)) = a(k, ea(k - 1)) - kk; a(ea(k - 1), k) = a(ea(k - 1), k) - kk
      end do
      a(1, 1) = a(1, 1) + 1.0e3_wp
      call band_plan(n, ea, eb, plan)
      call check('the tree is renumbered (bandwidth '//str(plan%kl)//' < n - 1)', &
                 plan%kl < n - 1 .and. any(plan%new /= [(k, k=1, n)]))
      call band_zero(plan)
      do k = 1, n
         call band_add(plan, k, k, a(k, k))
         b(k, 1) = uniform() - 0.5_wp
      end do
      do k = 1, n - 1
         call band_add(plan, eb(k), ea(k), a(eb(k), ea(k)))
         call band_add(plan, ea(k), eb(k), a(ea(k), eb(k)))
      end do
      x = b
      call band_solve(plan, x, info)
      call check('band_solve info 0', info == 0)
      call gauss(a, b(:, 1))
      call check('banded = dense solution (max |dx| / max |x|)', maxval(abs(x - b))/maxval(abs(b)), 0.0_wp, &
                 abs_tol=lu_tol)
   end subroutine test_band_solve_equals_dense_on_a_tree

   !> A random-ish branched train of n nodes: shafts, and every 5th element a spur gear with
   !> backlash and a random ratio; torque loads on a few nodes; `held`: node 1 at a speed.
   function branched_deck(n, held) result(text)
      integer, intent(in) :: n
      logical, intent(in) :: held
      character(len=:), allocatable :: text
      character(len=*), parameter :: nl = achar(10)
      integer :: k
      character(len=32) :: a, b
      text = "&run t_end = 1e-3, dt = 1e-5, integrator = 'rk4' /"//nl
      do k = 1, n
         write (a, '(es12.5)') 0.5_wp + uniform()
         text = text//"&node id = 'n"//str(k)//"', type = 'inertia', inertia = "//trim(a)//" /"//nl
      end do
      do k = 2, n
         write (a, '(es12.5)') 10.0_wp**(3.0_wp + 2.0_wp*uniform())
         if (modulo(k, 5) == 0) then
            write (b, '(es12.5)') 0.5_wp + uniform()
            text = text//"&element id = 'e"//str(k)//"', type = 'spur_gear', left = 'n"//str(parent_of(k))// &
                   "', right = 'n"//str(k)//"', stiffness = "//trim(a)//", rb_driver = 1.0, rb_driven = "// &
                   trim(b)//", teeth = 30, contact_ratio = 1.6, approach_angle = 0.1, half_backlash = 1e-3 /"//nl
         else
            text = text//"&element id = 'e"//str(k)//"', type = 'shaft', left = 'n"//str(parent_of(k))// &
                   "', right = 'n"//str(k)//"', stiffness = "//trim(a)//" /"//nl
         end if
      end do
      do k = 3, n, 7
         write (a, '(f8.3)') 200.0_wp*(uniform() - 0.3_wp)
         text = text//"&load node = 'n"//str(k)//"', value = "//trim(a)//" /"//nl
      end do
      if (held) text = text//"&load node = 'n1', kind = 'constant', quantity = 'speed', value = 1.0 /"//nl
      text = text//"&initial node = 'n1', speed = 1.0 /"//nl
   end function branched_deck

   !> The preload of `text` banded and dense: the wind-ups (and a free train's
   !> acceleration) agree to lu_tol of the largest.
   subroutine compare_preloads(text, what)
      character(len=*), intent(in) :: text, what
      type(model_t) :: mb, md
      type(preload_info_t) :: ib, id
      real(wp), allocatable :: wb(:), wd(:)
      type(error_t), allocatable :: eb, ed
      integer :: i
      call load_model_text(text, mb); call load_model_text(text, md)
      call apply_preload(mb, ib, eb)
      call apply_preload(md, id, ed, dense=.true.)
      call check(what//': both preloads solve', .not. (allocated(eb) .or. allocated(ed)))
      if (allocated(eb) .or. allocated(ed)) return
      wb = [(mb%nodes(i)%n%theta0 - ib%theta_deck(i), i=1, size(mb%nodes))]
      wd = [(md%nodes(i)%n%theta0 - id%theta_deck(i), i=1, size(md%nodes))]
      call check(what//': the train winds up (max |wind-up| > 1e-4 rad)', maxval(abs(wd)) > 1.0e-4_wp)
      call check(what//': same mode passes', ib%passes == id%passes)
      call check(what//': banded = dense wind-up (max diff / max wind-up)', maxval(abs(wb - wd))/maxval(abs(wd)), &
                 0.0_wp, abs_tol=lu_tol)
      call check(what//': banded = dense acceleration', abs(ib%acceleration - id%acceleration), 0.0_wp, &
                 abs_tol=lu_tol*max(1.0_wp, abs(id%acceleration)))
      call check(what//': banded residual within Newton tolerance', ib%residual <= 1.0e-11_wp*ib%torque_scale)
   end subroutine compare_preloads

   subroutine test_preload_banded_equals_dense_held_train()
      call test_begin('preload_banded_equals_dense_held_train')
      call compare_preloads(branched_deck(120, .true.), 'held at node 1')
   end subroutine test_preload_banded_equals_dense_held_train

   subroutine test_preload_banded_equals_dense_free_train()
      call test_begin('preload_banded_equals_dense_free_train')
      call compare_preloads(branched_deck(120, .false.), 'free train')
   end subroutine test_preload_banded_equals_dense_free_train

   !> A 1 000-node chain held at one end and loaded at the other, every 100th element a spur
   !> gear of equal wheels with backlash (9 meshes, whose positions share two sets of static
   !> solves: D-152): each mesh carries the load torque over the base radius, T / r_b = 100,
   !> whatever the shafts' stiffness (a statically determinate chain); the Newton solve stops
   !> at 1e-11 of the torque scale. (Each mesh's wind-up moves the next one's zone, so the
   !> preload needs about one mode pass per mesh in series: at most 20, D-152.)
   subroutine test_static_force_of_every_mesh_of_a_long_chain()
      integer, parameter :: n = 1000
      character(len=*), parameter :: nl = achar(10)
      character(len=:), allocatable :: text
      type(model_t) :: m
      type(static_ref_t) :: ref
      integer :: k
      call test_begin('static_force_of_every_mesh_of_a_long_chain')
      text = "&run t_end = 1e-3, dt = 1e-5, integrator = 'rk4' /"//nl
      do k = 1, n
         text = text//"&node id = 'n"//str(k)//"', type = 'inertia', inertia = 1.0 /"//nl
      end do
      do k = 1, n - 1
         if (modulo(k, 100) == 0) then
            text = text//"&element id = 'e"//str(k)//"', type = 'spur_gear', left = 'n"//str(k)//"', right = 'n"// &
                   str(k + 1)//"', stiffness = 1e4, rb_driver = 1.0, rb_driven = 1.0, teeth = 32, "// &
                   "contact_ratio = 1.6, approach_angle = 0.1, half_backlash = 1e-3 /"//nl
         else
            text = text//"&element id = 'e"//str(k)//"', type = 'shaft', left = 'n"//str(k)//"', right = 'n"// &
                   str(k + 1)//"', stiffness = 1e4 /"//nl
         end if
      end do
      text = text//"&load node = 'n1', kind = 'constant', quantity = 'speed', value = 1.0 /"//nl// &
             "&load node = 'n"//str(n)//"', value = -100.0 /"//nl//"&initial node = 'n1', speed = 1.0 /"//nl
      call load_model_text(text, m)
      call static_reference(m, ref)
      call check('computed (no 400-node limit): '//ref%note, ref%computed)
      if (.not. ref%computed) return
      call check('9 meshes', count(ref%mesh) == 9)
      call check('every mesh: static force = T / r_b (max |F - 100| / 100)', &
                 maxval(abs(ref%force - 100.0_wp), mask=ref%mesh)/100.0_wp, 0.0_wp, abs_tol=1.0e-10_wp)
      call check('every mesh: the static TE varies over the cycle (two zones)', &
                 minval(ref%te_max - ref%te_min, mask=ref%mesh) > 0.0_wp)
   end subroutine test_static_force_of_every_mesh_of_a_long_chain
end program test_band_preload
