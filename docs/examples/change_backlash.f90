!> Example of the trainsim API: the Gregory, Harris & Munro gear rig with half its
!> mesh backlash. Reads the bundled deck, runs it as it is and with the mesh's
!> `half_backlash` halved, and prints how the mesh's metrics moved.
!>
!>     change_backlash [DECK]     (default: inputs/gregory_harris_munro.nml)
!>
!> Build it against an installed trainsim (docs/examples/CMakeLists.txt):
!>     find_package(trainsim REQUIRED)
!>     target_link_libraries(change_backlash PRIVATE trainsim::trainsim)
program change_backlash
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim, only: simulation_t, error_t, wp, event_t, ev_name
   implicit none

   type(simulation_t) :: sim
   type(error_t), allocatable :: err
   type(event_t), allocatable :: events(:)
   character(len=:), allocatable :: deck
   real(wp) :: b0, te0, te1, f0, f1, n0, n1
   integer :: n

   deck = 'inputs/gregory_harris_munro.nml'
   if (command_argument_count() >= 1) then
      call get_command_argument(1, length=n)
      deallocate (deck)
      allocate (character(len=n) :: deck)
      call get_command_argument(1, deck)
   end if

   call sim%read_file(deck, err); call check()
   call sim%run(err); call check()                     ! as in the deck (b = 0.005 in)
   call sim%metric('mesh', 'p2p_mean', te0, err); call check()
   call sim%metric('mesh', 'max_peak_force', f0, err); call check()
   call sim%metric('mesh', 'impacts', n0, err); call check()

   b0 = 0.005_wp
   call sim%set('mesh.half_backlash', b0/2, err); call check()
   call sim%run(err); call check()                     ! rebuilt: the spur gear checks the value
   call sim%metric('mesh', 'p2p_mean', te1, err); call check()
   call sim%metric('mesh', 'max_peak_force', f1, err); call check()
   call sim%metric('mesh', 'impacts', n1, err); call check()
   call sim%events(events, err); call check()

   write (output_unit, '(a)') 'mesh of '//deck//', half backlash 0.005 in -> 0.0025 in:'
   write (output_unit, '(a, 2es14.6)') '  mean peak-to-peak transmission error [in]:', te0, te1
   write (output_unit, '(a, 2es14.6)') '  largest contact force at impact [lbf]:    ', f0, f1
   write (output_unit, '(a, 2f14.0)') '  impacts:                                  ', n0, n1
   if (size(events) > 0) write (output_unit, '(a, es12.5, a)') '  first event with b = 0.0025 in: '// &
      ev_name(events(1)%kind)//' of '//sim%event_element_id(events(1))//' at t =', events(1)%t, ' s'
   if (te1 == te0 .and. f1 == f0 .and. n1 == n0) then
      write (error_unit, '(a)') 'change_backlash: error: no metric of the mesh moved with its backlash'
      stop 1
   end if
   write (output_unit, '(a)') 'change_backlash: the mesh metrics moved with the backlash'

contains

   !> Print the error (file, line, key, ...) and stop with exit status 2.
   subroutine check()
      if (.not. allocated(err)) return
      write (error_unit, '(a)') 'change_backlash: '//err%message
      stop 2
   end subroutine check
end program change_backlash
