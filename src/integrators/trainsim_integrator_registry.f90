!> The integrator registry: one table row per method (name, summary, order,
!> fixed step or adaptive, factory). The deck's valid names, the error
!> messages and docs/integrators.md's table come from it; the conformance
!> suite iterates it. Adding an integrator = its file + one row here.
module trainsim_integrator_registry
   use trainsim_strings, only: string_t, to_lower
   use trainsim_integrator, only: integrator_t
   use trainsim_int_rk4, only: new_rk4
   use trainsim_int_rk4_thesis, only: new_rk4_thesis
   use trainsim_int_euler, only: new_euler
   use trainsim_int_cvode, only: new_cvode_bdf, new_cvode_adams
   use trainsim_int_arkode, only: new_arkode_dp, new_arkode_verner
   implicit none
   private

   public :: integrator_entry_t, integrator_registry, make_integrator, integrator_names

   abstract interface
      !> Allocate a new integrator of one kind.
      subroutine new_integrator_i(integ)
         import :: integrator_t
         class(integrator_t), allocatable, intent(out) :: integ
      end subroutine new_integrator_i
   end interface

   !> One row of the table.
   type :: integrator_entry_t
      character(len=:), allocatable :: name     !< as written in the deck (&run integrator = ...)
      character(len=:), allocatable :: summary  !< one line, for --help and the docs
      integer :: order = 0                      !< nominal order of accuracy
      logical :: fixed_step = .true.            !< on the dt grid (else adaptive: rtol, atol)
      logical :: locates_events = .true.        !< events at the located crossing (else at the next step)
      procedure(new_integrator_i), pointer, nopass :: make => null()
   end type integrator_entry_t

contains

   !> The table.
   !> (Built once: gfortran 12 leaks the strings of this array constructor, and every
   !> model build and run reads the table.)
   function integrator_registry() result(rows)
      type(integrator_entry_t), allocatable :: rows(:)
      type(integrator_entry_t), allocatable, save :: table(:)
      if (allocated(table)) then
         rows = table
         return
      end if
      table = [ &
             integrator_entry_t('rk4', 'classical RK4 on the dt grid with located events (default)', 4, .true., .true., new_rk4), &
             integrator_entry_t('rk4-thesis', 'the thesis''s RK4 (App. F): modes frozen per step, dt/10 in contact', &
                                4, .true., .false., new_rk4_thesis), &
             integrator_entry_t('cvode-bdf', 'SUNDIALS CVODE, variable-order BDF with Newton (stiff trains)', &
                                5, .false., .true., new_cvode_bdf), &
             integrator_entry_t('cvode-adams', 'SUNDIALS CVODE, variable-order Adams-Moulton (non-stiff)', &
                                12, .false., .true., new_cvode_adams), &
             integrator_entry_t('arkode-dp', 'SUNDIALS ARKODE ERKStep, Dormand-Prince 5(4)', 5, .false., .true., new_arkode_dp), &
             integrator_entry_t('arkode-verner', 'SUNDIALS ARKODE ERKStep, Verner 6(5)', 6, .false., .true., new_arkode_verner), &
             integrator_entry_t('euler', 'explicit Euler with located events (first order; tests and teaching)', &
                                1, .true., .true., new_euler)]
      rows = table
   end function integrator_registry

   !> Allocate the integrator called `name`; unallocated if the name is unknown.
   subroutine make_integrator(name, integ)
      character(len=*), intent(in) :: name
      class(integrator_t), allocatable, intent(out) :: integ
      type(integrator_entry_t), allocatable :: rows(:)
      integer :: i
      allocate (rows, source=integrator_registry())   ! not `rows = ...`: gfortran 12 false -Wuninitialized
      do i = 1, size(rows)
         if (rows(i)%name == to_lower(name)) then
            call rows(i)%make(integ)
            return
         end if
      end do
   end subroutine make_integrator

   !> The valid names, in table order.
   function integrator_names() result(names)
      type(string_t), allocatable :: names(:)
      type(integrator_entry_t), allocatable :: rows(:)
      integer :: i
      allocate (rows, source=integrator_registry())   ! not `rows = ...`: gfortran 12 false -Wuninitialized
      allocate (names(size(rows)))
      do i = 1, size(rows)
         names(i)%s = rows(i)%name
      end do
   end function integrator_names
end module trainsim_integrator_registry
