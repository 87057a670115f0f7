!> An element may declare any number of guards: the model's buffer for one
!> element's guards is sized at finalize to the largest n_guards (it was a fixed
!> 4: event location wrote past it, and the constraint settle skipped such an
!> element, so a stuck one was never released). The test plug-in is a brake with
!> six guards, the sixth the brake's own, the other five always positive; its
!> physics is then the brake's closed forms (as test_friction):
!>  - an inertia J on it under a load T above its static limit from t = 0 slips at
!>    once: w = (T - Tc) t/J (the constraint settle at the start);
!>  - under a ramp a t it sticks until a t = Ts, then J w' = a t - Tc (event location
!>    on guard 6).
module many_guards_plugin
   use trainsim_kinds, only: wp
   use trainsim_el_brake, only: brake_t
   use trainsim_event, only: event_t
   implicit none
   private
   public :: many_guards_t

   integer, parameter, public :: n_many = 6

   type, extends(brake_t) :: many_guards_t
   contains
      procedure :: n_guards => many_n_guards
      procedure :: guards => many_guards
      procedure :: update_mode => many_update_mode
   end type many_guards_t

contains

   pure integer function many_n_guards(self) result(n)
      class(many_guards_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = n_many
   end function many_n_guards

   pure subroutine many_guards(self, thl, wl, thr, wr, g)
      class(many_guards_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      integer :: k
      g(1:n_many - 1) = [(1.0_wp + k, k=1, n_many - 1)]
      call self%brake_t%guards(thl, wl, thr, wr, g(n_many:n_many))
   end subroutine many_guards

   subroutine many_update_mode(self, t, thl, wl, thr, wr, fired, ev, nev)
      class(many_guards_t), intent(inout) :: self
      real(wp), intent(in) :: t, thl, wl, thr, wr
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      call self%brake_t%update_mode(t, thl, wl, thr, wr, fired(n_many:n_many), ev, nev)
   end subroutine many_update_mode
end module many_guards_plugin

program test_guard_buffer
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_event, only: ev_slip_forward
   use trainsim_el_brake, only: brake_t
   use many_guards_plugin, only: many_guards_t, n_many
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check, check_true
   use trainsim_test_support, only: load_model_text, run_model, nl
   implicit none

   character(len=*), parameter :: integrators(2) = [character(len=10) :: 'rk4', 'cvode-bdf']
   real(wp), parameter :: jd = 2.0_wp, ts = 5.0_wp, tc = 3.0_wp

   call suite_begin('an element with more guards than four (the guard buffer)')
   call test_six_guards_slip_at_the_start()
   call test_six_guards_break_away_on_a_ramp()
   call suite_end()

contains

   !> The deck's brake swapped for the six-guard plug-in, the model laid out again.
   subroutine load_six(load, integrator, m)
      character(len=*), intent(in) :: load, integrator
      type(model_t), intent(out) :: m
      type(many_guards_t), allocatable :: mg
      call load_model_text("&run t_end = 1.5, dt = 1.0e-3, output_interval = 1.0e-2, integrator = '"// &
                           trim(integrator)//"' /"//nl// &
                           "&node id = 'disk', type = 'inertia', inertia = 2.0 /"//nl// &
                           "&node id = 'ground', type = 'fixed' /"//nl// &
                           "&element id = 'brake', type = 'brake', left = 'disk', right = 'ground', "// &
                           "torque_sliding = 3.0, torque_static = 5.0 /"//nl//load, m)
      select type (b => m%elements(1)%e)
      type is (brake_t)
         allocate (mg)
         mg%brake_t = b
      end select
      call check_true('the deck''s element is a brake', allocated(mg))
      if (.not. allocated(mg)) error stop 1
      call move_alloc(mg, m%elements(1)%e)
      call m%finalize()
      call check('guards of the model', real(m%n_guards, wp), real(n_many, wp), abs_tol=0.0_wp)
   end subroutine load_six

   subroutine test_six_guards_slip_at_the_start()
      type(model_t) :: m
      type(run_result_t) :: r
      integer :: k
      call test_begin('six_guards_slip_at_the_start')
      do k = 1, size(integrators)
         call load_six("&load node = 'disk', kind = 'constant', value = 8.0 /", integrators(k), m)
         call run_model(m, r)
         ! RK4 on a linear speed is exact to roundoff; SUNDIALS to its tolerances (1e-6 relative)
         call check(trim(integrators(k))//': speed at t_end = (T - Tc) t/J (slipping from the start)', &
                    r%y_final(2), (8.0_wp - tc)*1.5_wp/jd, rel_tol=1.0e-6_wp)
      end do
   end subroutine test_six_guards_slip_at_the_start

   subroutine test_six_guards_break_away_on_a_ramp()
      real(wp), parameter :: a = 10.0_wp, t_end = 1.5_wp
      type(model_t) :: m
      type(run_result_t) :: r
      real(wp) :: t0, w_exact
      integer :: k, n_slip
      call test_begin('six_guards_break_away_on_a_ramp')
      do k = 1, size(integrators)
         call load_six("&load node = 'disk', kind = 'ramp', value0 = 0.0, value1 = 20.0, t0 = 0.0, t1 = 2.0 /", &
                       integrators(k), m)
         call run_model(m, r)
         t0 = ts/a
         w_exact = (0.5_wp*a*(t_end**2 - t0**2) - tc*(t_end - t0))/jd
         n_slip = count(r%events(:)%kind == ev_slip_forward)
         call check_true(trim(integrators(k))//': one break-away, forward', n_slip == 1 .and. size(r%events) == 1)
         if (n_slip /= 1) cycle
         ! event location to 1e-9 dt (RK4), CVODE's root finder: 1e-8 s as test_friction
         call check(trim(integrators(k))//': break-away at a t = Ts', r%events(1)%t, t0, abs_tol=1.0e-8_wp)
         call check(trim(integrators(k))//': speed at t_end, the closed form', r%y_final(2), w_exact, rel_tol=1.0e-6_wp)
      end do
   end subroutine test_six_guards_break_away_on_a_ramp
end program test_guard_buffer
