!> The generic HDF5 layer, part 3: slot datasets, one slot per run, allocated at once
!> with a fill value and written and read one slot at a time (the sweep file's runs),
!> and 2-D tables written and read whole. With trainsim_h5 and trainsim_h5_dsets the
!> only modules that call HDF5. Errors are HDF5 statuses (< 0 failed), which the sweep
!> file accumulates with `min` into one status per step.
!>
!> Fortran (n, n_runs) arrays appear in h5py as (n_runs, n).
module trainsim_h5_slots
   use, intrinsic :: iso_c_binding, only: c_char, c_ptr, c_loc, c_null_ptr
   use hdf5, only: hid_t, hsize_t, h5screate_simple_f, h5sclose_f, h5sselect_hyperslab_f, &
      h5sget_simple_extent_dims_f, H5S_SELECT_SET_F, h5pcreate_f, h5pclose_f, h5pset_alloc_time_f, &
      h5pset_fill_value_f, h5pset_obj_track_times_f, H5P_DATASET_CREATE_F, H5D_ALLOC_TIME_EARLY_F, &
      h5dcreate_f, h5dopen_f, h5dclose_f, h5dget_space_f, h5dwrite_f, h5dread_f, H5T_NATIVE_DOUBLE, H5T_NATIVE_INTEGER
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: string_t
   use trainsim_h5, only: h5_real, h5_int, h5_text, native_type, close_type, vlen_pointers, c_text, garbage_collect
   implicit none
   private

   public :: new_slots, open_dset, open_dsets, put_slot_r, put_slot_i, put_slot_text, get_slot_r, get_slot_text, &
      put_matrix, get_matrix

contains

   !> A dataset of `kind` with one slot per run (the last dimension): contiguous,
   !> allocated now, filled with NaN (reals) or `ifill` (integers); no time stamps
   !> (metadata stays fixed). Created only if hs == 0; hs = min(hs, its status).
   subroutine new_slots(loc, name, dims, kind, d, hs, ifill)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer, intent(in) :: dims(:), kind
      integer(hid_t), intent(out) :: d
      integer, intent(inout) :: hs
      integer, intent(in), optional :: ifill
      integer(hid_t) :: sp, pl, t
      integer :: h
      real(wp) :: nan
      type(error_t), allocatable :: err
      d = -1
      call native_type(kind, t, err)
      if (allocated(err)) then
         hs = -1
         return
      end if
      call h5screate_simple_f(size(dims), int(dims, hsize_t), sp, h)
      call h5pcreate_f(H5P_DATASET_CREATE_F, pl, h)
      call h5pset_alloc_time_f(pl, H5D_ALLOC_TIME_EARLY_F, h)
      call h5pset_obj_track_times_f(pl, .false., h)
      if (kind == h5_real) then
         nan = transfer(int(z'7FF8000000000000', kind=8), nan)
         call h5pset_fill_value_f(pl, H5T_NATIVE_DOUBLE, nan, h)
      else if (kind == h5_int .and. present(ifill)) then
         call h5pset_fill_value_f(pl, H5T_NATIVE_INTEGER, ifill, h)
      end if
      if (hs == 0) then
         call h5dcreate_f(loc, name, t, sp, d, h, dcpl_id=pl)
         hs = min(hs, h)
         if (h < 0) d = -1
         call garbage_collect()   ! its fill buffer (sized by the runs) back to the system
      end if
      call h5pclose_f(pl, h)
      call h5sclose_f(sp, h)
      if (kind == h5_text) call close_type(t)
   end subroutine new_slots

   !> Open dataset `name` of `loc` into d (-1 on failure); hs lowered to the
   !> HDF5 status (< 0 on failure), so that a run of opens is checked once.
   subroutine open_dset(loc, name, d, hs)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer(hid_t), intent(out) :: d
      integer, intent(inout) :: hs
      integer :: h
      call h5dopen_f(loc, name, d, h)
      if (h < 0) d = -1
      hs = min(hs, h)
   end subroutine open_dset

   !> open_dset of group//'/'//names(k) into d(k) for every k.
   subroutine open_dsets(loc, group, names, d, hs)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: group
      character(len=*), intent(in) :: names(:)
      integer(hid_t), intent(out) :: d(:)
      integer, intent(inout) :: hs
      integer :: k
      do k = 1, size(names)
         call open_dset(loc, group//'/'//trim(names(k)), d(k), hs)
      end do
   end subroutine open_dsets

   !> File and memory spaces for the slot of run irun (n values).
   subroutine select_slot(d, irun, n, fs, ms)
      integer(hid_t), intent(in) :: d
      integer, intent(in) :: irun, n
      integer(hid_t), intent(out) :: fs, ms
      integer(hsize_t) :: dims(2), maxd(2)
      integer :: h, rank
      call h5dget_space_f(d, fs, h)
      call h5sget_simple_extent_dims_f(fs, dims, maxd, rank)
      if (rank == 1) then
         call h5sselect_hyperslab_f(fs, H5S_SELECT_SET_F, [int(irun - 1, hsize_t)], [1_hsize_t], h)
      else
         call h5sselect_hyperslab_f(fs, H5S_SELECT_SET_F, [0_hsize_t, int(irun - 1, hsize_t)], &
                                    [int(n, hsize_t), 1_hsize_t], h)
      end if
      call h5screate_simple_f(1, [int(n, hsize_t)], ms, h)
   end subroutine select_slot

   subroutine close_spaces(fs, ms)
      integer(hid_t), intent(in) :: fs, ms
      integer :: h
      call h5sclose_f(ms, h)
      call h5sclose_f(fs, h)
   end subroutine close_spaces

   !> Write (or read) the n values of type `dtype` at `buf` of one run: a column
   !> (:, irun), or element irun of a 1-D dataset.
   subroutine slot_io(d, irun, n, dtype, buf, write, h)
      integer(hid_t), intent(in) :: d, dtype
      integer, intent(in) :: irun, n
      type(c_ptr), intent(in) :: buf
      logical, intent(in) :: write
      integer, intent(out) :: h
      integer(hid_t) :: fs, ms
      type(c_ptr) :: p   ! (HDF5's read takes its buffer's address intent(inout))
      call select_slot(d, irun, n, fs, ms)
      p = buf
      if (write) then
         call h5dwrite_f(d, dtype, p, h, mem_space_id=ms, file_space_id=fs)
      else
         call h5dread_f(d, dtype, p, h, mem_space_id=ms, file_space_id=fs)
      end if
      call close_spaces(fs, ms)
   end subroutine slot_io

   subroutine put_slot_r(d, irun, v, h)
      integer(hid_t), intent(in) :: d
      integer, intent(in) :: irun
      real(wp), contiguous, target, intent(in) :: v(:)
      integer, intent(out) :: h
      call slot_io(d, irun, size(v), H5T_NATIVE_DOUBLE, c_loc(v), .true., h)
   end subroutine put_slot_r

   subroutine put_slot_i(d, irun, v, h)
      integer(hid_t), intent(in) :: d
      integer, intent(in) :: irun
      integer, contiguous, target, intent(in) :: v(:)
      integer, intent(out) :: h
      call slot_io(d, irun, size(v), H5T_NATIVE_INTEGER, c_loc(v), .true., h)
   end subroutine put_slot_i

   subroutine get_slot_r(d, irun, v, h)
      integer(hid_t), intent(in) :: d
      integer, intent(in) :: irun
      real(wp), contiguous, target, intent(out) :: v(:)
      integer, intent(out) :: h
      call slot_io(d, irun, size(v), H5T_NATIVE_DOUBLE, c_loc(v), .false., h)
   end subroutine get_slot_r

   !> The text of run irun in a 1-D text dataset (variable length; `stype` a string type).
   subroutine put_slot_text(d, stype, irun, text, h)
      integer(hid_t), intent(in) :: d, stype
      integer, intent(in) :: irun
      character(len=*), intent(in) :: text
      integer, intent(out) :: h
      type(string_t) :: one(1)
      character(kind=c_char), allocatable, target :: pool(:)
      type(c_ptr), allocatable, target :: ptrs(:)
      one(1)%s = text
      call vlen_pointers(one, pool, ptrs)
      call slot_io(d, irun, 1, stype, c_loc(ptrs), .true., h)
   end subroutine put_slot_text

   !> The text of run irun ('' for the fill value); ok = .false. if it cannot be read.
   subroutine get_slot_text(d, stype, irun, text, ok)
      integer(hid_t), intent(in) :: d, stype
      integer, intent(in) :: irun
      character(len=:), allocatable, intent(out) :: text
      logical, intent(out) :: ok
      integer :: h
      type(c_ptr), target :: p(1)
      type(c_ptr) :: buf
      text = ''
      p(1) = c_null_ptr
      buf = c_loc(p)
      call slot_io(d, irun, 1, stype, buf, .false., h)
      ok = h >= 0
      if (ok) text = c_text(p(1))
   end subroutine get_slot_text

   !> A 2-D float64 dataset written whole; hs < 0 on failure.
   subroutine put_matrix(loc, name, v, hs)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      real(wp), intent(in) :: v(:, :)
      integer, intent(out) :: hs
      integer(hid_t) :: sp, d
      integer :: h
      call h5screate_simple_f(2, int(shape(v), hsize_t), sp, h)
      call h5dcreate_f(loc, name, H5T_NATIVE_DOUBLE, sp, d, hs)
      if (hs == 0) then
         call h5dwrite_f(d, H5T_NATIVE_DOUBLE, v, int(shape(v), hsize_t), hs)
         call h5dclose_f(d, h)
      end if
      call h5sclose_f(sp, h)
   end subroutine put_matrix

   !> Read a 2-D float64 dataset of v's shape (ok = .false. if absent or of another shape).
   subroutine get_matrix(loc, name, v, ok)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      real(wp), intent(inout) :: v(:, :)
      logical, intent(out) :: ok
      integer(hid_t) :: d, sp
      integer(hsize_t) :: dims(2), maxd(2)
      integer :: h, rank
      call h5dopen_f(loc, name, d, h)
      ok = h >= 0
      if (.not. ok) return
      call h5dget_space_f(d, sp, h)
      call h5sget_simple_extent_dims_f(sp, dims, maxd, rank)
      ok = rank == 2 .and. all(dims == int(shape(v), hsize_t))
      if (ok) then
         call h5dread_f(d, H5T_NATIVE_DOUBLE, v, dims, h)
         ok = h >= 0
      end if
      call h5sclose_f(sp, h); call h5dclose_f(d, h)
   end subroutine get_matrix
end module trainsim_h5_slots
