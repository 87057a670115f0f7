!> Terminal output: the end-of-run summary and the modes table.
module trainsim_report
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_observer, only: run_result_t
   use trainsim_modes, only: modes_t
   use trainsim_sink, only: param_list_t
   implicit none
   private

   public :: print_summary, print_modes, print_parameters

contains

   !> Element parameters as used (derived values included).
   subroutine print_parameters(model, unit)
      type(model_t), intent(in) :: model
      integer, intent(in) :: unit
      integer :: i, j
      type(param_list_t) :: p
      do i = 1, size(model%elements)
         p = model%elements(i)%e%params()
         if (size(p%names) == 0) cycle
         write (unit, '(a)') 'element '//model%elements(i)%e%id//' ('//model%elements(i)%e%type_name//'):'
         do j = 1, size(p%names)
            write (unit, '(4x,a24,1x,es15.7)') p%names(j)%s, p%values(j)
         end do
      end do
   end subroutine print_parameters

   !> What an engineer reads after a run.
   subroutine print_summary(model, res, unit)
      type(model_t), intent(in) :: model
      type(run_result_t), intent(in) :: res
      integer, intent(in) :: unit
      integer :: i, k
      write (unit, '(a)') '--- run summary ---'
      write (unit, '(a,i0,a,i0,a,f0.3,a)') 'steps ', res%stats%steps, ', RHS evaluations ', res%stats%rhs_evals, &
         ', wall time ', res%stats%wall_time, ' s'
      write (unit, '(a,i0,a,es12.5,a)') 'events ', res%stats%events, ', final time ', res%t_final, ' s'
      select case (res%stats%settle_status)
      case (1)
         write (unit, '(a,i0,a,es12.5,a,i0,a)') 'settled: the state repeats after ', res%stats%settle_k, &
            ' period(s) to settle_tol; metrics from t = ', res%stats%t_metrics, ' s (', res%stats%settle_periods, &
            ' settle periods)'
      case (2)
         write (unit, '(a,i0,a)') 'NOT SETTLED: the state did not repeat to settle_tol within settle_max_time (', &
            res%stats%settle_periods, ' settle periods); the metrics below are of a transient'
      case (3)
         write (unit, '(a)') 'settled by settle_time: the state repeats from one settle period to the next to 1e-3'
      case (4)
         write (unit, '(a,i0,a)') 'NOT SETTLED by settle_time (', res%stats%settle_periods, ' settle periods): '// &
            'the state does not repeat from one period to the next to 1e-3; the metrics below are of a '// &
            'transient. Set &run settle_tol (e.g. 1e-5) to settle until periodic'
      end select
      if (model%run%track_energy) write (unit, '(a,es10.3,a,es10.3,a)') 'energy balance: max |residual| ', &
         res%energy_residual_max, ' (energy scale ', res%energy_scale, ')'
      write (unit, '(a)') 'element extremes (torque on the right node, torque units; displacement, its own unit):'
      write (unit, '(a16,1x,a19,4a15,a9,a13,a15,a8)') 'element', 'type', 'torque min', 'torque max', 'disp min', &
         'disp max', 'impacts', 'max V_i', 'max peak F', 'open %'
      do i = 1, size(model%elements)
         associate (e => model%elements(i)%e, m => res%el(i))
            write (unit, '(a16,1x,a19,4es15.6,i9,es13.4,es15.6,f8.2)') e%id, e%type_name, m%torque_min, m%torque_max, &
               m%disp_min, m%disp_max, m%impacts, m%max_approach_velocity, m%max_peak_force, &
               100.0_wp*m%time_out_of_contact/max(res%t_final - res%stats%t_metrics, tiny(1.0_wp))
         end associate
      end do
      write (unit, '(a)') 'peak-to-peak displacement after the settling (range max-min; mean swing between peaks):'
      do i = 1, size(model%elements)
         associate (e => model%elements(i)%e, m => res%el(i))
            write (unit, '(a16,2es15.6,a,i0,a)') e%id, m%p2p_range, m%p2p_mean, '  (', m%p2p_swings, ' swings)'
         end associate
      end do
      write (unit, '(a)') 'final state:'
      k = 0
      do i = 1, size(model%nodes)
         associate (nd => model%nodes(i)%n)
            if (model%is_held(i) .or. nd%nstates() == 0) then
               write (unit, '(4x,a12,a)') nd%id, '  (held)'
            else
               write (unit, '(4x,a12,3es18.9)') nd%id, res%y_final(nd%offset + 1:nd%offset + nd%nstates())
            end if
         end associate
      end do
   end subroutine print_summary

   !> Natural frequencies and mode shapes.
   subroutine print_modes(model, modes, unit)
      type(model_t), intent(in) :: model
      type(modes_t), intent(in) :: modes
      integer, intent(in) :: unit
      integer :: i, j
      write (unit, '(a,i0,a)') 'linearised modes (', modes%n, ' free inertias; fixed and prescribed-speed nodes held)'
      do j = 1, modes%n
         if (modes%rigid(j)) then
            write (unit, '(a,i3,a)') 'mode', j, ':  rigid-body mode (0 Hz)'
         else
            write (unit, '(a,i3,a,f16.6,a)') 'mode', j, ':', modes%freq_hz(j), ' Hz'
         end if
         do i = 1, modes%n
            write (unit, '(8x,a12,f12.6)') model%nodes(modes%node(i))%n%id, modes%shape(i, j)
         end do
      end do
   end subroutine print_modes
end module trainsim_report
