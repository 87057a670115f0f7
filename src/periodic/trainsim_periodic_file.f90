!> The periodic orbit in its run file: `trainsim periodic -o FILE` writes the
!> orbit's k periods as a run history (the run's own layout) and adds the
!> group /periodic (docs/periodic.md):
!>   attributes  converged (1/0), status, message, period (s), period_count,
!>               t0 (s), residual, newton_steps, period_maps, transient_periods,
!>               newton_starts, stable (1/0),
!>               stability (stable, marginal, unstable),
!>               max_abs_multiplier, grazing_gap, grazing_element
!>   datasets    state (the reduced state at t0, one entry per state, with its
!>               label), scale, multipliers_re, multipliers_im, multipliers_abs,
!>               rigid_speed (per state: W_i of an angle, 0 else)
module trainsim_periodic_file
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_io
   use trainsim_strings, only: string_t
   use trainsim_model, only: model_t
   use trainsim_h5, only: hid_t, open_file_rdwr, close_file, make_group, close_group, put_str_attr, put_real_attr, &
                          put_int_attr, put_list_attr
   use trainsim_h5_dsets, only: put_column_r, write_r_at
   use hdf5, only: h5dopen_f, h5dclose_f
   use trainsim_period_map, only: period_map_t
   use trainsim_shooting, only: shoot_result_t, shoot_converged
   use trainsim_floquet, only: stability_of
   implicit none
   private

   public :: write_periodic_group, write_orbit_p2p

contains

   !> Add /periodic to the run file `path` (written and closed by the orbit's run).
   subroutine write_periodic_group(path, model, pm, res, mu, gap, worst, err)
      character(len=*), intent(in) :: path
      type(model_t), intent(in) :: model
      type(period_map_t), intent(in) :: pm
      type(shoot_result_t), intent(in) :: res
      complex(wp), intent(in) :: mu(:)
      real(wp), intent(in) :: gap
      integer, intent(in) :: worst
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: file, grp
      integer :: h, i
      logical :: ok
      real(wp) :: w(pm%n)
      type(string_t) :: labels(pm%n), none(0)
      call open_file_rdwr(path, file, h)
      if (h < 0) then
         call fatal_error(err, "cannot open '"//path//"' to add the periodic orbit's group", err_io)
         return
      end if
      call make_group(file, 'periodic', grp, err)
      if (.not. allocated(err)) then
         w = 0.0_wp
         w(pm%ang) = pm%w
         do i = 1, pm%n
            labels(i)%s = model%state_label(i)
         end do
         call put_int_attr(grp, 'converged', merge(1, 0, res%status == shoot_converged), err)
         if (.not. allocated(err)) call put_int_attr(grp, 'status', res%status, err)
         if (.not. allocated(err)) call put_str_attr(grp, 'message', res%message, err)
         if (.not. allocated(err)) call put_real_attr(grp, 'period', pm%period, err)
         if (.not. allocated(err)) call put_int_attr(grp, 'period_count', pm%k, err)
         if (.not. allocated(err)) call put_real_attr(grp, 't0', pm%t0, err)
         if (.not. allocated(err)) call put_real_attr(grp, 'residual', res%residual, err)
         if (.not. allocated(err)) call put_int_attr(grp, 'newton_steps', res%newton, err)
         if (.not. allocated(err)) call put_int_attr(grp, 'period_maps', res%maps, err)
         if (.not. allocated(err)) call put_int_attr(grp, 'transient_periods', res%transient, err)
         if (.not. allocated(err)) call put_int_attr(grp, 'newton_starts', res%attempts, err)
         if (.not. allocated(err) .and. size(mu) > 0) then
            call put_int_attr(grp, 'stable', merge(1, 0, stability_of(mu) == 'stable'), err)
            if (.not. allocated(err)) call put_str_attr(grp, 'stability', stability_of(mu), err)
            if (.not. allocated(err)) call put_real_attr(grp, 'max_abs_multiplier', abs(mu(1)), err)
         end if
         if (.not. allocated(err)) call put_real_attr(grp, 'grazing_gap', gap, err)
         if (.not. allocated(err)) call put_int_attr(grp, 'grazing_element', worst, err)
         if (.not. allocated(err)) call put_column_r(grp, 'state', res%x, err, none)
         if (.not. allocated(err)) call put_list_attr_of(grp, labels, err)
         if (.not. allocated(err)) call put_column_r(grp, 'scale', res%scale, err, none)
         if (.not. allocated(err) .and. size(pm%mem) > 0) call put_column_r(grp, 'memory', pm%mem, err, none)
         if (.not. allocated(err)) call put_column_r(grp, 'rigid_speed', w, err, [string_t('rad/s')])
         if (.not. allocated(err)) call put_column_r(grp, 'multipliers_re', real(mu), err, none)
         if (.not. allocated(err)) call put_column_r(grp, 'multipliers_im', aimag(mu), err, none)
         if (.not. allocated(err)) call put_column_r(grp, 'multipliers_abs', abs(mu), err, none)
         call close_group(grp, err)
      end if
      call close_file(file, ok)
      if (.not. ok .and. .not. allocated(err)) call fatal_error(err, "cannot close '"//path//"'", err_io)
   end subroutine write_periodic_group

   !> Rewrite /metrics/p2p_range of the orbit's run file `path` with p2p (per element):
   !> the range across the seam t0 = t0 + kT, which the run's own window cannot see
   !> (orbit_run, D-143), so the file says what the printout and the branch file say.
   subroutine write_orbit_p2p(path, p2p, err)
      character(len=*), intent(in) :: path
      real(wp), intent(in) :: p2p(:)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: file, dset
      integer :: h, i
      logical :: ok
      call open_file_rdwr(path, file, h)
      if (h < 0) then
         call fatal_error(err, "cannot open '"//path//"' to write the orbit's p2p_range", err_io)
         return
      end if
      call h5dopen_f(file, 'metrics/p2p_range', dset, h)
      if (h < 0) then
         call fatal_error(err, "'"//path//"' has no dataset /metrics/p2p_range", err_io)
      else
         do i = 1, size(p2p)
            call write_r_at(dset, p2p(i), i, "'"//path//"' /metrics/p2p_range", err)
            if (allocated(err)) exit
         end do
         call h5dclose_f(dset, h)
      end if
      call close_file(file, ok)
      if (.not. ok .and. .not. allocated(err)) call fatal_error(err, "cannot close '"//path//"'", err_io)
   end subroutine write_orbit_p2p

   !> The state labels as the group's attribute `state_labels`.
   subroutine put_list_attr_of(grp, labels, err)
      integer(hid_t), intent(in) :: grp
      type(string_t), intent(in) :: labels(:)
      type(error_t), allocatable, intent(out) :: err
      call put_list_attr(grp, 'state_labels', labels, err)
   end subroutine put_list_attr_of
end module trainsim_periodic_file
