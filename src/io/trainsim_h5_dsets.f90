!> The generic HDF5 layer, part 2: datasets that grow or are written whole. Extendable
!> series (rows appended in blocks, a row rewritten in place, a dimension scale) and
!> fixed columns with their units. With trainsim_h5 and trainsim_h5_slots the only
!> modules that call HDF5. Errors are `error_t` values (code err_io, naming the dataset).
!>
!> Fortran (n, rows) arrays appear in h5py as (rows, n).
module trainsim_h5_dsets
   use, intrinsic :: iso_c_binding, only: c_char, c_ptr, c_loc, c_null_ptr
   use hdf5, only: hid_t, hsize_t, h5screate_simple_f, h5sclose_f, h5sselect_hyperslab_f, &
      h5sget_simple_extent_dims_f, H5S_UNLIMITED_F, H5S_SELECT_SET_F, &
      h5pcreate_f, h5pclose_f, h5pset_chunk_f, h5pset_deflate_f, h5pset_alloc_time_f, h5pset_fill_value_f, &
      h5pset_obj_track_times_f, H5P_DATASET_CREATE_F, H5D_ALLOC_TIME_EARLY_F, &
      h5dcreate_f, h5dopen_f, h5dclose_f, h5dset_extent_f, h5dget_space_f, h5dwrite_f, h5dread_f, &
      H5T_NATIVE_DOUBLE, H5T_NATIVE_INTEGER
   use h5ds, only: h5dsset_scale_f, h5dsattach_scale_f
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_io
   use trainsim_strings, only: string_t
   use trainsim_h5, only: h5_real, h5_int, h5_text, native_type, close_type, make_string_type, vlen_pointers, &
      c_text, put_str_attr, put_list_attr, garbage_collect
   implicit none
   private

   public :: make_series, append_r1, append_r2, append_i1, append_i2, append_s1, write_r_at, read_i1
   public :: make_time_scale
   public :: put_column_s, put_column_r, put_column_i, put_entry_units

contains

   ! ------------------------------------------------------------------- series
   !> Extendible chunked dataset of `kind` (h5_real, h5_int, h5_text): (n) when
   !> rank == 1, else (nvar x n) in Fortran order. A zero-sized variable dimension is
   !> made unlimited too (chunk sizes must be > 0). `level`: zlib level, 0 none.
   subroutine make_series(loc, name, rank, nvar, rows, kind, level, dset, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer, intent(in) :: rank, nvar, rows, kind, level
      integer(hid_t), intent(out) :: dset
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: space, dcpl, dtype
      integer(hsize_t) :: dims(2), maxdims(2), chunk(2)
      integer :: hdferr, hdferr2
      dset = -1
      if (rank == 1) then
         dims(1) = 0; maxdims(1) = H5S_UNLIMITED_F; chunk(1) = int(rows, hsize_t)
      else
         dims = [int(nvar, hsize_t), 0_hsize_t]
         maxdims = [int(nvar, hsize_t), H5S_UNLIMITED_F]
         if (nvar == 0) maxdims(1) = H5S_UNLIMITED_F
         chunk = [int(max(nvar, 1), hsize_t), int(rows, hsize_t)]
      end if
      call native_type(kind, dtype, err)
      if (allocated(err)) return
      call h5screate_simple_f(rank, dims(1:rank), space, hdferr, maxdims(1:rank))
      if (hdferr < 0) then
         call fatal_error(err, 'H5Screate failed for dataset '//name, err_io)
      else
         call h5pcreate_f(H5P_DATASET_CREATE_F, dcpl, hdferr)
         if (hdferr >= 0) then
            call h5pset_chunk_f(dcpl, rank, chunk(1:rank), hdferr)
            if (hdferr >= 0 .and. level > 0) call h5pset_deflate_f(dcpl, level, hdferr)
            if (hdferr >= 0) then
               call h5dcreate_f(loc, name, dtype, space, dset, hdferr, dcpl_id=dcpl)
               if (hdferr < 0) dset = -1
            end if
            call h5pclose_f(dcpl, hdferr2)
         end if
         call h5sclose_f(space, hdferr2)
         if (hdferr < 0) call fatal_error(err, 'cannot create dataset '//name, err_io)
      end if
      if (kind == h5_text) call close_type(dtype)
   end subroutine make_series

   !> Extend `dset` to row0+nb rows and select the new rows; also a memory space.
   subroutine begin_append(dset, rank, nvar, row0, nb, fspace, mspace, what, err)
      integer(hid_t), intent(in) :: dset
      integer, intent(in) :: rank, nvar, nb
      integer(hsize_t), intent(in) :: row0
      integer(hid_t), intent(out) :: fspace, mspace
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hsize_t) :: dims(2), start(2), cnt(2)
      integer :: hdferr, hdferr2
      fspace = -1
      mspace = -1
      if (rank == 1) then
         dims(1) = row0 + int(nb, hsize_t); start(1) = row0; cnt(1) = int(nb, hsize_t)
      else
         dims = [int(nvar, hsize_t), row0 + int(nb, hsize_t)]
         start = [0_hsize_t, row0]
         cnt = [int(nvar, hsize_t), int(nb, hsize_t)]
      end if
      call h5dset_extent_f(dset, dims(1:rank), hdferr)
      if (hdferr < 0) then
         call fatal_error(err, 'H5Dset_extent failed for '//what, err_io)
         return
      end if
      call h5dget_space_f(dset, fspace, hdferr)
      if (hdferr < 0) then
         fspace = -1
         call fatal_error(err, 'H5Dget_space failed for '//what, err_io)
         return
      end if
      call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, start(1:rank), cnt(1:rank), hdferr)
      if (hdferr >= 0) then
         call h5screate_simple_f(rank, cnt(1:rank), mspace, hdferr)
         if (hdferr < 0) mspace = -1
      end if
      if (hdferr < 0) then
         call h5sclose_f(fspace, hdferr2)
         fspace = -1
         call fatal_error(err, 'cannot select rows of '//what, err_io)
      end if
   end subroutine begin_append

   !> Close the two spaces of an append and turn a failed write into an error.
   subroutine end_append(fspace, mspace, write_err, what, err)
      integer(hid_t), intent(in) :: fspace, mspace
      integer, intent(in) :: write_err
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call h5sclose_f(mspace, hdferr)
      call h5sclose_f(fspace, hdferr)
      if (write_err < 0) call fatal_error(err, 'H5Dwrite failed for '//what//' (disk full?)', err_io)
   end subroutine end_append

   !> A 2-d dataset with no columns (e.g. no elements): only its row count grows.
   subroutine extend_empty(dset, n_rows, what, err)
      integer(hid_t), intent(in) :: dset
      integer(hsize_t), intent(in) :: n_rows
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call h5dset_extent_f(dset, [0_hsize_t, n_rows], hdferr)
      if (hdferr < 0) call fatal_error(err, 'H5Dset_extent failed for '//what, err_io)
   end subroutine extend_empty

   !> Append nb rows of nvar values (rank 1: nvar unused) of type `dtype` at `buf`.
   subroutine append_rows(dset, rank, nvar, nb, dtype, buf, row0, what, err)
      integer(hid_t), intent(in) :: dset, dtype
      integer, intent(in) :: rank, nvar, nb
      type(c_ptr), intent(in) :: buf
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fspace, mspace
      integer :: hdferr
      call begin_append(dset, rank, nvar, row0, nb, fspace, mspace, what, err)
      if (allocated(err)) return
      call h5dwrite_f(dset, dtype, buf, hdferr, mem_space_id=mspace, file_space_id=fspace)
      call end_append(fspace, mspace, hdferr, what, err)
   end subroutine append_rows

   subroutine append_r1(dset, buf, row0, what, err)
      integer(hid_t), intent(in) :: dset
      real(wp), contiguous, target, intent(in) :: buf(:)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      call append_rows(dset, 1, 0, size(buf), H5T_NATIVE_DOUBLE, c_loc(buf), row0, what, err)
   end subroutine append_r1

   subroutine append_r2(dset, buf, row0, what, err)
      integer(hid_t), intent(in) :: dset
      real(wp), contiguous, target, intent(in) :: buf(:, :)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      if (size(buf, 1) == 0) then   ! nothing to store, but keep the row count right
         call extend_empty(dset, row0 + int(size(buf, 2), hsize_t), what, err)
         return
      end if
      call append_rows(dset, 2, size(buf, 1), size(buf, 2), H5T_NATIVE_DOUBLE, c_loc(buf), row0, what, err)
   end subroutine append_r2

   subroutine append_i1(dset, buf, row0, what, err)
      integer(hid_t), intent(in) :: dset
      integer, contiguous, target, intent(in) :: buf(:)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      call append_rows(dset, 1, 0, size(buf), H5T_NATIVE_INTEGER, c_loc(buf), row0, what, err)
   end subroutine append_i1

   subroutine append_i2(dset, buf, row0, what, err)
      integer(hid_t), intent(in) :: dset
      integer, contiguous, target, intent(in) :: buf(:, :)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      if (size(buf, 1) == 0) then   ! nothing to store, but keep the row count right
         call extend_empty(dset, row0 + int(size(buf, 2), hsize_t), what, err)
         return
      end if
      call append_rows(dset, 2, size(buf, 1), size(buf, 2), H5T_NATIVE_INTEGER, c_loc(buf), row0, what, err)
   end subroutine append_i2

   !> Append variable-length UTF-8 strings.
   subroutine append_s1(dset, texts, row0, what, err)
      integer(hid_t), intent(in) :: dset
      type(string_t), intent(in) :: texts(:)
      integer(hsize_t), intent(in) :: row0
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fspace, mspace, stype
      integer :: hdferr
      character(kind=c_char), allocatable, target :: pool(:)
      type(c_ptr), allocatable, target :: ptrs(:)
      call make_string_type(stype, err)
      if (allocated(err)) return
      call begin_append(dset, 1, 0, row0, size(texts), fspace, mspace, what, err)
      if (.not. allocated(err)) then
         call vlen_pointers(texts, pool, ptrs)
         call h5dwrite_f(dset, stype, c_loc(ptrs), hdferr, mem_space_id=mspace, file_space_id=fspace)
         call end_append(fspace, mspace, hdferr, what, err)
      end if
      call close_type(stype)
   end subroutine append_s1

   !> Rewrite entry `row` (1-based) of a 1-D float64 dataset.
   subroutine write_r_at(dset, value, row, what, err)
      integer(hid_t), intent(in) :: dset
      real(wp), intent(in) :: value
      integer, intent(in) :: row
      character(len=*), intent(in) :: what
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: fspace, mspace
      integer :: hdferr, hdferr2
      real(wp) :: v(1)
      v(1) = value
      call h5dget_space_f(dset, fspace, hdferr)
      if (hdferr < 0) then
         call fatal_error(err, 'H5Dget_space failed for '//what, err_io)
         return
      end if
      call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, [int(row - 1, hsize_t)], [1_hsize_t], hdferr)
      if (hdferr >= 0) then
         call h5screate_simple_f(1, [1_hsize_t], mspace, hdferr)
         if (hdferr >= 0) then
            call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, v, [1_hsize_t], hdferr, mem_space_id=mspace, file_space_id=fspace)
            call h5sclose_f(mspace, hdferr2)
         end if
      end if
      call h5sclose_f(fspace, hdferr2)
      if (hdferr < 0) call fatal_error(err, 'cannot rewrite a row of '//what//' (disk full?)', err_io)
   end subroutine write_r_at

   !> Read a whole 1-D integer dataset of size(v) entries; h < 0 on failure.
   subroutine read_i1(dset, v, h)
      integer(hid_t), intent(in) :: dset
      integer, intent(out) :: v(:)
      integer, intent(out) :: h
      call h5dread_f(dset, H5T_NATIVE_INTEGER, v, [int(size(v), hsize_t)], h)
   end subroutine read_i1

   !> Make `scale` (named `name`) the dimension scale of the rows of every dataset in `dsets`.
   subroutine make_time_scale(scale, name, dsets, err)
      integer(hid_t), intent(in) :: scale
      character(len=*), intent(in) :: name
      integer(hid_t), intent(in) :: dsets(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr, i
      call h5dsset_scale_f(scale, hdferr, name)
      if (hdferr < 0) then
         call fatal_error(err, 'cannot make /'//name//' a dimension scale', err_io)
         return
      end if
      do i = 1, size(dsets)
         ! idx 1: the first C dimension (the rows, h5py's axis 0); the Fortran
         ! wrapper of HDF5 1.10 passes idx - 1 unchanged (tests/check_h5_layout.py checks it)
         call h5dsattach_scale_f(dsets(i), scale, 1, hdferr)
         if (hdferr < 0) then
            call fatal_error(err, 'cannot attach the /'//name//' dimension scale', err_io)
            return
         end if
      end do
   end subroutine make_time_scale

   ! ------------------------------------------------------------------ columns
   !> Fixed-size 1-D dataset (contiguous; may have zero length).
   subroutine make_column(loc, name, dtype, n, dset, err)
      integer(hid_t), intent(in) :: loc, dtype
      character(len=*), intent(in) :: name
      integer, intent(in) :: n
      integer(hid_t), intent(out) :: dset
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: space
      integer :: hdferr, hdferr2
      dset = -1
      call h5screate_simple_f(1, [int(n, hsize_t)], space, hdferr)
      if (hdferr < 0) then
         call fatal_error(err, 'H5Screate failed for events/'//name, err_io)
         return
      end if
      call h5dcreate_f(loc, name, dtype, space, dset, hdferr)
      if (hdferr < 0) then
         dset = -1
         call fatal_error(err, 'cannot create dataset events/'//name, err_io)
      end if
      call h5sclose_f(space, hdferr2)
   end subroutine make_column

   !> Close a column dataset, reporting a failed write or close.
   subroutine finish_column(dset, write_err, name, err)
      integer(hid_t), intent(in) :: dset
      integer, intent(in) :: write_err
      character(len=*), intent(in) :: name
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call h5dclose_f(dset, hdferr)
      if (write_err < 0 .or. hdferr < 0) call fatal_error(err, 'cannot write events/'//name, err_io)
   end subroutine finish_column

   !> Column of variable-length UTF-8 strings (units '1').
   subroutine put_column_s(loc, name, texts, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      type(string_t), intent(in) :: texts(:)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: dset, stype
      integer :: hdferr
      character(kind=c_char), allocatable, target :: pool(:)
      type(c_ptr), allocatable, target :: ptrs(:)
      call make_string_type(stype, err)
      if (allocated(err)) return
      call make_column(loc, name, stype, size(texts), dset, err)
      if (.not. allocated(err)) then
         hdferr = 0
         if (size(texts) > 0) then
            call vlen_pointers(texts, pool, ptrs)
            call h5dwrite_f(dset, stype, c_loc(ptrs), hdferr)
         end if
         if (hdferr >= 0) call put_str_attr(dset, 'units', '1', err)
         if (allocated(err)) hdferr = -1
         call finish_column(dset, hdferr, name, err)
      end if
      call close_type(stype)
   end subroutine put_column_s

   !> 1-D column of n values of type `dtype` at `buf`, with its `units` (the common unit
   !> of `entry_units`, or `mixed`) and, when the entries differ, one unit per entry in
   !> `entry_units`.
   subroutine put_column(loc, name, dtype, n, buf, entry_units, err)
      integer(hid_t), intent(in) :: loc, dtype
      character(len=*), intent(in) :: name
      integer, intent(in) :: n
      type(c_ptr), intent(in) :: buf
      type(string_t), intent(in) :: entry_units(:)
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: dset
      integer :: hdferr
      call make_column(loc, name, dtype, n, dset, err)
      if (allocated(err)) return
      hdferr = 0
      if (n > 0) call h5dwrite_f(dset, dtype, buf, hdferr)
      if (hdferr >= 0) call put_entry_units(dset, entry_units, err)
      if (allocated(err)) hdferr = -1
      call finish_column(dset, hdferr, name, err)
   end subroutine put_column

   subroutine put_column_r(loc, name, values, err, entry_units)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      real(wp), contiguous, target, intent(in) :: values(:)
      type(error_t), allocatable, intent(out) :: err
      type(string_t), intent(in) :: entry_units(:)
      real(wp), target :: none(1)
      if (size(values) == 0) then
         call put_column(loc, name, H5T_NATIVE_DOUBLE, 0, c_loc(none), entry_units, err)
      else
         call put_column(loc, name, H5T_NATIVE_DOUBLE, size(values), c_loc(values), entry_units, err)
      end if
   end subroutine put_column_r

   subroutine put_column_i(loc, name, values, err, entry_units)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer, contiguous, target, intent(in) :: values(:)
      type(error_t), allocatable, intent(out) :: err
      type(string_t), intent(in) :: entry_units(:)
      integer, target :: none(1)
      if (size(values) == 0) then
         call put_column(loc, name, H5T_NATIVE_INTEGER, 0, c_loc(none), entry_units, err)
      else
         call put_column(loc, name, H5T_NATIVE_INTEGER, size(values), c_loc(values), entry_units, err)
      end if
   end subroutine put_column_i

   !> `units` = the entries' common unit ('mixed: see entry_units' when they differ,
   !> with `entry_units` then listing them; '1' for an empty column).
   subroutine put_entry_units(dset, units, err)
      integer(hid_t), intent(in) :: dset
      type(string_t), intent(in) :: units(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: i
      logical :: same
      same = .true.
      do i = 2, size(units)
         if (units(i)%s /= units(1)%s) same = .false.
      end do
      if (size(units) == 0) then
         call put_str_attr(dset, 'units', '1', err)
      else if (same) then
         call put_str_attr(dset, 'units', units(1)%s, err)
      else
         call put_str_attr(dset, 'units', 'mixed: see entry_units', err)
         if (.not. allocated(err)) call put_list_attr(dset, 'entry_units', units, err)
      end if
   end subroutine put_entry_units
end module trainsim_h5_dsets
