!> The element that owns each guard (`model_t%guard_element`, D-157), which
!> RK4's set-up asks for every guard: found by bisection over the elements
!> with guards. Checked against the definition, element by element: guard j
!> belongs to element i when guard_offset(i) < j <= guard_offset(i) + n_guards()
!> of i, and to none outside 1..n_guards. The train mixes elements without
!> guards (shafts), with four (spur gears with backlash) and with those of a
!> clearance coupling, in runs of different lengths, first and last elements
!> included, so every branch of the bisection is walked (an owner at either
!> end, owners with neighbours of no guards).
program test_guard_owner
   use trainsim_model, only: model_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model_text
   implicit none

   type(model_t) :: m
   character(len=:), allocatable :: text
   character(len=*), parameter :: nl = new_line('a')
   character(len=*), parameter :: kinds = 'gsscgggsscsssgcgc'   ! g gear, s shaft, c coupling
   integer :: i, j, n, owner, wrong, n_owned

   call suite_begin('owner of each guard (D-157)')
   n = len(kinds)
   text = "&run t_end = 1.0e-3, dt = 1.0e-5, integrator = 'rk4' /"//nl
   do i = 1, n + 1
      text = text//"&node id = 'n"//num(i)//"', type = 'inertia', inertia = 1.0 /"//nl
   end do
   do i = 1, n
      select case (kinds(i:i))
      case ('g')
         text = text//"&element id = 'e"//num(i)//"', type = 'spur_gear', stiffness = 1.0e4, rb_driver = 1.0, "// &
                "rb_driven = 1.0, teeth = 32, contact_ratio = 1.6, approach_angle = 0.1, half_backlash = 1.0e-3 /"//nl
      case ('c')
         text = text//"&element id = 'e"//num(i)//"', type = 'clearance_coupling', clearance = 0.02, "// &
                "stiffness = 5.0e3, contact_damping = 2.0 /"//nl
      case default
         text = text//"&element id = 'e"//num(i)//"', type = 'shaft', stiffness = 1.0e4 /"//nl
      end select
   end do
   call load_model_text(text, m)

   call test_begin('every guard: the element whose range holds it')
   call check('the train has guards', m%n_guards > 0)
   wrong = 0
   n_owned = 0
   do j = 1, m%n_guards
      owner = 0
      do i = 1, size(m%elements)   ! the definition, element by element
         if (j > m%guard_offset(i) .and. j <= m%guard_offset(i) + m%elements(i)%e%n_guards()) owner = i
      end do
      if (owner /= 0) n_owned = n_owned + 1
      if (m%guard_element(j) /= owner) wrong = wrong + 1
   end do
   call check('guard_element agrees with the ranges for every guard', wrong == 0)
   call check('every guard has an owner', n_owned == m%n_guards)
   call check('the first guard is the first element''s (a gear)', m%guard_element(1) == 1)
   call check('the last guard is the last element''s (a coupling)', m%guard_element(m%n_guards) == n)

   call test_begin('outside the guards: no owner')
   call check('guard 0', m%guard_element(0) == 0)
   call check('guard n_guards + 1', m%guard_element(m%n_guards + 1) == 0)
   call suite_end()
contains
   function num(k) result(s)
      integer, intent(in) :: k
      character(len=:), allocatable :: s
      character(len=12) :: b
      write (b, '(i0)') k
      s = trim(b)
   end function num
end program test_guard_owner
