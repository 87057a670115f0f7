!> The assembled analytic Jacobian (model%jacobian from the nodes' blocks and
!> the elements' torque partials) matches central differences of the
!> right-hand side on whole decks (chains, prescribed speeds, a motor) and on
!> contact-law variants that the registry's example fragments do not reach;
!> and CVODE BDF with it gives the run of the difference-quotient Jacobian
!> with fewer RHS evaluations. Every node and element type's own Jacobian, in
!> and out of contact, is checked by test_conformance, which iterates the
!> registry (so no type list is kept here).
program test_jacobian
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check
   use trainsim_test_support, only: load_model, load_model_text, run_model, nl, jacobian_fd_error
   implicit none

   character(len=*), parameter :: pair = "&run t_end = 1e-3, dt = 1e-6, track_energy = .false. /"//nl// &
                                         "&node type='inertia', inertia=0.5, damping=0.3 /"//nl// &
                                         "&node type='inertia', inertia=2.0 /"//nl
   ! both disks turned so that the clearance (b = 0.01 in the line's units) is closed by 0.004
   character(len=*), parameter :: closed = nl//"&initial node='n1', angle=0.014, speed=3.0 /"//nl// &
                                         "&initial node='n2', angle=0.0, speed=-1.0 /"

   call suite_begin('analytic Jacobian (issues 3, 4)')
   call jac_case('chain of shafts (Table 5.1)', '', 'verification/table5_1/table5_1.nml')
   call jac_case('keyed joint, load-dependent fit', pair//"&element type='keyed_joint', diameter=2.0,"// &
                 " half_clearance=0.01, stiffness_fit='tight', key_length=2.0, initial_contact_velocity=1.0 /"// &
                 closed, '')
   call jac_case('coupling, elasto-backlash', pair//"&element type='clearance_coupling', clearance=0.02,"// &
                 " stiffness=1e4, contact_law='elasto_backlash', contact_damping=3.0 /"//closed, '')
   call jac_case('keyed joint out of contact, bore friction', pair//"&element type='keyed_joint', diameter=2.0,"// &
                 " half_clearance=0.1, stiffness=1e6, friction=0.3, load_radius=3.0, phi=0.35 /"//nl// &
                 "&load node='n2', kind='constant', value=50.0 /"//nl//"&initial node='n1', speed=1.0005 /"//nl// &
                 "&initial node='n2', speed=1.0 /", '')
   call jac_case('DC motor and geometry gear', '', 'inputs/dc_motor_geared_load.nml')
   call jac_case('prescribed speed and loads (Table 5.5)', '', 'inputs/gregory_harris_munro.nml')
   call test_cvode_bdf_same_run_with_fewer_rhs()
   call suite_end()

contains

   subroutine jac_case(name, text, path)
      character(len=*), intent(in) :: name, text, path
      type(model_t) :: m
      real(wp) :: worst, scale
      call test_begin('analytic Jacobian = central differences: '//name)
      if (len(path) > 0) then
         call load_model(path, m)
      else
         call load_model_text(text, m)
      end if
      call jacobian_fd_error(m, m%run%t_start, worst, scale)
      call check('max |J_analytic - J_fd| / max |J| (central differences: ~1e-8)', worst, 0.0_wp, &
                 abs_tol=1.0e-6_wp)
      call check('Jacobian is not trivially zero', scale > 0.0_wp)
   end subroutine jac_case

   subroutine test_cvode_bdf_same_run_with_fewer_rhs()
      type(model_t) :: ma, md
      type(run_result_t) :: ra, rd
      integer :: i
      real(wp) :: dt_max
      call test_begin('cvode_bdf_same_run_with_fewer_rhs')
      call load_model('verification/chapter3/case1.nml', ma)
      ma%run%t_end = 0.01_wp
      ma%run%integrator = 'cvode-bdf'
      ma%run%rtol = 1.0e-8_wp
      md = ma
      md%run%analytic_jacobian = .false.
      call run_model(ma, ra)
      call run_model(md, rd)
      call check('same events', size(ra%events) == size(rd%events))
      dt_max = 0.0_wp
      do i = 1, min(size(ra%events), size(rd%events))
         dt_max = max(dt_max, abs(ra%events(i)%t - rd%events(i)%t)/rd%events(i)%t)
      end do
      call check('event times agree to 100 rtol', dt_max, 0.0_wp, abs_tol=1.0e-6_wp)
      write (*, '(a,i0,a,i0)') '    RHS evaluations: analytic ', ra%stats%rhs_evals, ', difference quotients ', &
         rd%stats%rhs_evals
      call check('fewer RHS evaluations with the analytic Jacobian', ra%stats%rhs_evals < rd%stats%rhs_evals)
   end subroutine test_cvode_bdf_same_run_with_fewer_rhs
end program test_jacobian
