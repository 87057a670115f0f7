!> The generic HDF5 layer, part 1: the library, files, groups, links, strings and
!> attributes. Together with trainsim_h5_dsets (datasets) the only modules that call
!> HDF5; the run sink (trainsim_hdf5) and the sweep file (trainsim_sweep_file) are
!> written on top of them.
!>
!> Every call is checked. Errors are returned as `error_t` values (code `err_io`,
!> naming the object), or as an HDF5 status (< 0 failed) by the few calls the sweep
!> file accumulates into one status. HDF5's automatic error printing is switched off
!> (process-wide) by `h5_init`, so the library never prints.
!>
!> Strings are variable-length UTF-8 C strings (h5py reads attributes as str and
!> string datasets with `.asstr()`).
module trainsim_h5
   use, intrinsic :: iso_c_binding, only: c_int, c_char, c_null_char, c_ptr, c_loc, c_f_pointer, c_size_t, &
      c_associated
   use hdf5, only: hid_t, hsize_t, size_t, h5open_f, h5eset_auto_f, &
      h5fcreate_f, h5fopen_f, h5fclose_f, h5fflush_f, H5F_ACC_TRUNC_F, H5F_ACC_EXCL_F, H5F_ACC_RDWR_F, &
      H5F_CLOSE_STRONG_F, H5F_LIBVER_V18_F, H5F_SCOPE_GLOBAL_F, &
      h5pcreate_f, h5pclose_f, h5pset_fclose_degree_f, h5pset_libver_bounds_f, h5pset_cache_f, H5P_FILE_ACCESS_F, &
      h5zfilter_avail_f, H5Z_FILTER_DEFLATE_F, h5screate_simple_f, h5screate_f, h5sclose_f, H5S_SCALAR_F, &
      h5gcreate_f, h5gopen_f, h5gclose_f, h5acreate_f, h5awrite_f, h5aclose_f, h5aexists_f, h5aopen_f, h5aread_f, &
      h5tcopy_f, h5tset_strpad_f, h5tset_cset_f, h5tclose_f, h5dclose_f, &
      H5T_STRING, H5T_STR_NULLTERM_F, H5T_CSET_UTF8_F, H5T_NATIVE_DOUBLE, H5T_NATIVE_INTEGER, &
      h5kind_to_type, H5_INTEGER_KIND, h5lexists_f, h5lmove_f, h5ldelete_f, h5garbage_collect_f
   use trainsim_kinds, only: wp, i8
   use trainsim_error, only: error_t, fatal_error, err_io
   use trainsim_strings, only: string_t, str
   implicit none
   private

   !> Handles and sizes of HDF5 objects (what a caller keeps).
   public :: hid_t, hsize_t
   !> What a dataset holds: float64, the default integer, variable-length UTF-8 text.
   public :: h5_real, h5_int, h5_text, native_type
   public :: h5_init, hdf5_library_stuck, mark_hdf5_stuck, deflate_available
   public :: create_run_file, create_file_excl, open_file_rdwr, flush_file, close_file
   public :: make_group, new_group, open_group, close_group, end_group, close_dset, close_type
   public :: link_exists, link_move, link_delete, garbage_collect
   public :: make_string_type, vlen_pointers, c_text, list_text
   public :: put_str_attr, put_names_attr, put_list_attr, put_fixed_names_attr, put_index_attr, &
      put_real_attr, put_int_attr, put_i8_attr, get_str_attr, attr_exists

   integer, parameter :: h5_real = 1, h5_int = 2, h5_text = 3

   !> h5open_f has been called in this process.
   logical, save :: hdf5_ready = .false.
   !> HDF5 failed to close a file even after its space was freed: the library's own
   !> clean-up at exit would then crash (HDF5 1.10 closes the half-closed file again).
   logical, save :: hdf5_stuck = .false.

   interface
      pure function c_strlen(p) bind(C, name='strlen') result(n)
         import :: c_ptr, c_size_t
         type(c_ptr), value :: p
         integer(c_size_t) :: n
      end function c_strlen
      !> Frees what HDF5 allocated for a variable-length read.
      function c_h5free_memory(p) bind(C, name='H5free_memory') result(rc)
         import :: c_ptr, c_int
         type(c_ptr), value :: p
         integer(c_int) :: rc
      end function c_h5free_memory
   end interface

contains

   ! ------------------------------------------------------------------ library

   !> Open the library once per process (every h5open_f makes new copies of ~55
   !> datatypes) and switch its error printing off: errors are values here.
   subroutine h5_init(err)
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      if (.not. hdf5_ready) then
         call h5open_f(hdferr)
         if (hdferr < 0) then
            call fatal_error(err, 'cannot initialise the HDF5 library', err_io)
            return
         end if
         hdf5_ready = .true.
      end if
      call h5eset_auto_f(0, hdferr)
   end subroutine h5_init

   !> Record that HDF5 failed to close a file.
   subroutine mark_hdf5_stuck()
      hdf5_stuck = .true.
   end subroutine mark_hdf5_stuck

   !> True if HDF5 holds a file it could not close: the program must then end without
   !> the library's exit handler (after flushing its own output), or it crashes there.
   logical function hdf5_library_stuck()
      hdf5_library_stuck = hdf5_stuck
   end function hdf5_library_stuck

   !> The zlib (deflate) filter is there.
   logical function deflate_available()
      integer :: hdferr
      call h5zfilter_avail_f(H5Z_FILTER_DEFLATE_F, deflate_available, hdferr)
      if (hdferr < 0) deflate_available = .false.
   end function deflate_available

   !> The HDF5 type of a dataset kind (h5_real, h5_int; h5_text a new string type the
   !> caller closes with close_type).
   subroutine native_type(kind, dtype, err)
      integer, intent(in) :: kind
      integer(hid_t), intent(out) :: dtype
      type(error_t), allocatable, intent(out) :: err
      select case (kind)
      case (h5_real)
         dtype = H5T_NATIVE_DOUBLE
      case (h5_int)
         dtype = H5T_NATIVE_INTEGER
      case default
         call make_string_type(dtype, err)
      end select
   end subroutine native_type

   ! -------------------------------------------------------------------- files

   !> Create (truncate) a run file through a file-access list that closes it strongly
   !> (closing the file closes every object in it) and keeps the 1.8 format.
   subroutine create_run_file(path, file, err)
      character(len=*), intent(in) :: path
      integer(hid_t), intent(out) :: file
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr, hdferr2
      integer(hid_t) :: fapl
      file = -1
      call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, hdferr)
      if (hdferr < 0) then
         call fatal_error(err, 'H5Pcreate (file access) failed', err_io)
         return
      end if
      call h5pset_fclose_degree_f(fapl, H5F_CLOSE_STRONG_F, hdferr)
      ! 1.8 format: large attributes (the deck text) go to dense storage;
      ! files stay readable by HDF5 1.8 and later.
      if (hdferr >= 0) call h5pset_libver_bounds_f(fapl, H5F_LIBVER_V18_F, H5F_LIBVER_V18_F, hdferr)
      ! No raw-data chunk cache: every block is written as whole chunks, and a
      ! rewritten event row is one read-modify-write of its chunk. (HDF5's
      ! default, 1 MiB per dataset, made a run's memory grow with its length
      ! until every one of the 26 datasets had filled its cache.)
      if (hdferr >= 0) call h5pset_cache_f(fapl, 0, 0_size_t, 0_size_t, 0.75, hdferr)
      if (hdferr >= 0) then
         call h5fcreate_f(path, H5F_ACC_TRUNC_F, file, hdferr, access_prp=fapl)
         if (hdferr < 0) file = -1
      end if
      call h5pclose_f(fapl, hdferr2)
      if (hdferr < 0) call fatal_error(err, 'H5Fcreate failed for '''//path//'''', err_io)
   end subroutine create_run_file

   !> Create `path` only if absent (default property lists); h < 0 on failure.
   subroutine create_file_excl(path, file, h)
      character(len=*), intent(in) :: path
      integer(hid_t), intent(out) :: file
      integer, intent(out) :: h
      call h5fcreate_f(path, H5F_ACC_EXCL_F, file, h)
      if (h < 0) file = -1
   end subroutine create_file_excl

   !> Open an existing file for reading and writing; h < 0 on failure.
   subroutine open_file_rdwr(path, file, h)
      character(len=*), intent(in) :: path
      integer(hid_t), intent(out) :: file
      integer, intent(out) :: h
      call h5fopen_f(path, H5F_ACC_RDWR_F, file, h)
      if (h < 0) file = -1
   end subroutine open_file_rdwr

   !> Flush the whole file to disk; h < 0 on failure.
   subroutine flush_file(file, h)
      integer(hid_t), intent(in) :: file
      integer, intent(out) :: h
      call h5fflush_f(file, H5F_SCOPE_GLOBAL_F, h)
   end subroutine flush_file

   !> Close a file; a failure (a full disk) marks the library stuck (hdf5_library_stuck).
   subroutine close_file(file, ok)
      integer(hid_t), intent(inout) :: file
      logical, intent(out) :: ok
      integer :: hdferr
      call h5fclose_f(file, hdferr)
      ok = hdferr >= 0
      if (.not. ok) hdf5_stuck = .true.
      file = -1
   end subroutine close_file

   ! ------------------------------------------------------- groups and links

   subroutine make_group(loc, name, grp, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer(hid_t), intent(out) :: grp
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call new_group(loc, name, grp, hdferr)
      if (hdferr < 0) call fatal_error(err, "cannot create group '"//name//"'", err_io)
   end subroutine make_group

   !> Create group `name` of `loc`; h < 0 on failure.
   subroutine new_group(loc, name, grp, h)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer(hid_t), intent(out) :: grp
      integer, intent(out) :: h
      call h5gcreate_f(loc, name, grp, h)
      if (h < 0) grp = -1
   end subroutine new_group

   !> Open group `name` of `loc`; h < 0 on failure.
   subroutine open_group(loc, name, grp, h)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer(hid_t), intent(out) :: grp
      integer, intent(out) :: h
      call h5gopen_f(loc, name, grp, h)
      if (h < 0) grp = -1
   end subroutine open_group

   !> Close a group; keeps an earlier error, or reports a failed close.
   subroutine close_group(grp, err)
      integer(hid_t), intent(in) :: grp
      type(error_t), allocatable, intent(inout) :: err
      integer :: hdferr
      if (grp < 0) return
      call h5gclose_f(grp, hdferr)
      if (hdferr < 0 .and. .not. allocated(err)) call fatal_error(err, 'H5Gclose failed', err_io)
   end subroutine close_group

   !> Close a group, its status ignored (a file closed strongly closes it anyway).
   subroutine end_group(grp)
      integer(hid_t), intent(in) :: grp
      integer :: hdferr
      if (grp >= 0) call h5gclose_f(grp, hdferr)
   end subroutine end_group

   !> Close a dataset (nothing if id < 0); h < 0 if that failed, and id = -1.
   subroutine close_dset(id, h)
      integer(hid_t), intent(inout) :: id
      integer, intent(out), optional :: h
      integer :: hdferr
      hdferr = 0
      if (id >= 0) call h5dclose_f(id, hdferr)
      if (present(h)) h = hdferr
      id = -1
   end subroutine close_dset

   !> Close a datatype (nothing if id < 0), and id = -1.
   subroutine close_type(id)
      integer(hid_t), intent(inout) :: id
      integer :: hdferr
      if (id >= 0) call h5tclose_f(id, hdferr)
      id = -1
   end subroutine close_type

   !> Whether link `name` exists in `loc`; h < 0 if that cannot be told.
   subroutine link_exists(loc, name, exists, h)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      logical, intent(out) :: exists
      integer, intent(out) :: h
      call h5lexists_f(loc, name, exists, h)
   end subroutine link_exists

   subroutine link_move(loc, old, new, h)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: old, new
      integer, intent(out) :: h
      call h5lmove_f(loc, old, loc, new, h)
   end subroutine link_move

   subroutine link_delete(loc, name, h)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer, intent(out) :: h
      call h5ldelete_f(loc, name, h)
   end subroutine link_delete

   !> Give HDF5's free lists back to the system.
   subroutine garbage_collect()
      integer :: hdferr
      call h5garbage_collect_f(hdferr)
   end subroutine garbage_collect

   ! ------------------------------------------------------------------ strings

   !> Variable-length, UTF-8 C string type (h5py reads it as str). The deck reader
   !> accepts only UTF-8 text without NUL, so titles, ids and the deck are valid.
   subroutine make_string_type(stype, err)
      integer(hid_t), intent(out) :: stype
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr, hdferr2
      call h5tcopy_f(H5T_STRING, stype, hdferr)
      if (hdferr < 0) then
         stype = -1
         call fatal_error(err, 'H5Tcopy failed for a string type', err_io)
         return
      end if
      ! the Fortran H5T_STRING is already a variable-length C string (setting its
      ! size to H5T_VARIABLE again through h5tset_size_f breaks the VL writes)
      call h5tset_strpad_f(stype, H5T_STR_NULLTERM_F, hdferr)
      if (hdferr >= 0) call h5tset_cset_f(stype, H5T_CSET_UTF8_F, hdferr)
      if (hdferr < 0) then
         call h5tclose_f(stype, hdferr2)
         stype = -1
         call fatal_error(err, 'cannot set up a variable-length string type', err_io)
      end if
   end subroutine make_string_type

   !> One buffer holding every text NUL-terminated, and a pointer to each (the
   !> memory layout of an array of variable-length C strings).
   subroutine vlen_pointers(texts, pool, ptrs)
      type(string_t), intent(in) :: texts(:)
      character(kind=c_char), allocatable, target, intent(out) :: pool(:)
      type(c_ptr), allocatable, intent(out) :: ptrs(:)
      integer :: i, j, k, total
      total = 0
      do i = 1, size(texts)
         total = total + text_len(texts(i)) + 1
      end do
      allocate (pool(max(total, 1)), ptrs(size(texts)))
      k = 1
      do i = 1, size(texts)
         ptrs(i) = c_loc(pool(k))
         do j = 1, text_len(texts(i))
            pool(k) = texts(i)%s(j:j)
            k = k + 1
         end do
         pool(k) = c_null_char
         k = k + 1
      end do
   end subroutine vlen_pointers

   pure integer function text_len(t)
      type(string_t), intent(in) :: t
      text_len = 0
      if (allocated(t%s)) text_len = len(t%s)
   end function text_len

   !> The text of a C string that HDF5 allocated for a variable-length read; frees it.
   function c_text(p) result(text)
      type(c_ptr), intent(in) :: p
      character(len=:), allocatable :: text
      character(kind=c_char), pointer :: chars(:)
      integer :: i, n, rc
      text = ''
      if (.not. c_associated(p)) return
      n = int(c_strlen(p))
      call c_f_pointer(p, chars, [n])
      deallocate (text)
      allocate (character(len=n) :: text)
      do i = 1, n
         text(i:i) = chars(i)
      end do
      rc = c_h5free_memory(p)
   end function c_text

   !> Entry `i` of an optional list ('' when absent).
   pure function list_text(list, i) result(text)
      type(string_t), allocatable, intent(in) :: list(:)
      integer, intent(in) :: i
      character(len=:), allocatable :: text
      text = ''
      if (.not. allocated(list)) return
      if (i > size(list)) return
      if (allocated(list(i)%s)) text = list(i)%s
   end function list_text

   ! --------------------------------------------------------------- attributes

   !> Create attribute `name` of type `dtype` with `n` elements (scalar if n < 0).
   subroutine make_attr(loc, name, dtype, n, attr, err)
      integer(hid_t), intent(in) :: loc, dtype
      character(len=*), intent(in) :: name
      integer, intent(in) :: n
      integer(hid_t), intent(out) :: attr
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: space
      integer :: hdferr, hdferr2
      attr = -1
      if (n < 0) then
         call h5screate_f(H5S_SCALAR_F, space, hdferr)
      else
         call h5screate_simple_f(1, [int(n, hsize_t)], space, hdferr)
      end if
      if (hdferr < 0) then
         call fatal_error(err, 'H5Screate failed for attribute '//name, err_io)
         return
      end if
      call h5acreate_f(loc, name, dtype, space, attr, hdferr)
      if (hdferr < 0) then
         attr = -1
         call fatal_error(err, "cannot create attribute '"//name//"'", err_io)
      end if
      call h5sclose_f(space, hdferr2)
   end subroutine make_attr

   !> Close an attribute, reporting a failed write or close.
   subroutine finish_attr(attr, write_err, name, err)
      integer(hid_t), intent(in) :: attr
      integer, intent(in) :: write_err
      character(len=*), intent(in) :: name
      type(error_t), allocatable, intent(out) :: err
      integer :: hdferr
      call h5aclose_f(attr, hdferr)
      if (write_err < 0 .or. hdferr < 0) call fatal_error(err, "cannot write attribute '"//name//"'", err_io)
   end subroutine finish_attr

   !> Scalar string attribute (variable length, UTF-8; '' allowed).
   subroutine put_str_attr(loc, name, value, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name, value
      type(error_t), allocatable, intent(out) :: err
      type(string_t) :: one(1)
      one(1)%s = value
      call write_str_attr(loc, name, one, .true., err)
   end subroutine put_str_attr

   !> 1-D string attribute from a list of `n` names (unallocated list: `n` empty strings).
   subroutine put_names_attr(loc, name, list, n, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      type(string_t), allocatable, intent(in) :: list(:)
      integer, intent(in) :: n
      type(error_t), allocatable, intent(out) :: err
      type(string_t) :: texts(n)
      integer :: i
      if (allocated(list)) then
         if (size(list) /= n) then
            call fatal_error(err, 'run description: '//name//' has '//str(size(list))// &
                             ' entries, expected '//str(n), err_io)
            return
         end if
      end if
      do i = 1, n
         texts(i)%s = list_text(list, i)
      end do
      call write_str_attr(loc, name, texts, .false., err)
   end subroutine put_names_attr

   !> 1-D string attribute from a list.
   subroutine put_list_attr(loc, name, texts, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      type(string_t), intent(in) :: texts(:)
      type(error_t), allocatable, intent(out) :: err
      call write_str_attr(loc, name, texts, .false., err)
   end subroutine put_list_attr

   !> 1-D string attribute from a character array (trailing blanks dropped).
   subroutine put_fixed_names_attr(loc, name, names, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      character(len=*), contiguous, intent(in) :: names(:)
      type(error_t), allocatable, intent(out) :: err
      type(string_t) :: list(size(names))
      integer :: i
      do i = 1, size(names)
         list(i)%s = trim(names(i))
      end do
      call write_str_attr(loc, name, list, .false., err)
   end subroutine put_fixed_names_attr

   !> A variable-length string attribute: scalar (one text) or 1-D.
   subroutine write_str_attr(loc, name, texts, scalar, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      type(string_t), intent(in) :: texts(:)
      logical, intent(in) :: scalar
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: stype, attr
      integer :: hdferr, hdferr2
      character(kind=c_char), allocatable, target :: pool(:)
      type(c_ptr), allocatable, target :: ptrs(:)
      call make_string_type(stype, err)
      if (allocated(err)) return
      call make_attr(loc, name, stype, merge(-1, size(texts), scalar), attr, err)
      if (.not. allocated(err)) then
         hdferr = 0
         if (size(texts) > 0) then
            call vlen_pointers(texts, pool, ptrs)
            call h5awrite_f(attr, stype, c_loc(ptrs), hdferr)
         end if
         call finish_attr(attr, hdferr, name, err)
      end if
      call h5tclose_f(stype, hdferr2)
   end subroutine write_str_attr

   !> 1-D integer attribute of `n` node indices (the list must be allocated when n > 0).
   subroutine put_index_attr(loc, name, list, n, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer, allocatable, intent(in) :: list(:)
      integer, intent(in) :: n
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: attr
      integer :: hdferr
      integer :: buf(n)
      if (n > 0) then
         if (.not. allocated(list)) then
            call fatal_error(err, 'run description: element '//name//' nodes are missing', err_io)
            return
         end if
         if (size(list) /= n) then
            call fatal_error(err, 'run description: element '//name//' has '//str(size(list))// &
                             ' entries, expected '//str(n), err_io)
            return
         end if
         buf = list
      end if
      call make_attr(loc, name, H5T_NATIVE_INTEGER, n, attr, err)
      if (allocated(err)) return
      hdferr = 0
      if (n > 0) call h5awrite_f(attr, H5T_NATIVE_INTEGER, buf, [int(n, hsize_t)], hdferr)
      call finish_attr(attr, hdferr, name, err)
   end subroutine put_index_attr

   !> Scalar attribute of type `dtype`, its value at `buf`.
   subroutine put_scalar_attr(loc, name, dtype, buf, err)
      integer(hid_t), intent(in) :: loc, dtype
      character(len=*), intent(in) :: name
      type(c_ptr), intent(in) :: buf
      type(error_t), allocatable, intent(out) :: err
      integer(hid_t) :: attr
      integer :: hdferr
      call make_attr(loc, name, dtype, -1, attr, err)
      if (allocated(err)) return
      call h5awrite_f(attr, dtype, buf, hdferr)
      call finish_attr(attr, hdferr, name, err)
   end subroutine put_scalar_attr

   subroutine put_real_attr(loc, name, value, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      real(wp), target, intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      call put_scalar_attr(loc, name, H5T_NATIVE_DOUBLE, c_loc(value), err)
   end subroutine put_real_attr

   subroutine put_int_attr(loc, name, value, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer, target, intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      call put_scalar_attr(loc, name, H5T_NATIVE_INTEGER, c_loc(value), err)
   end subroutine put_int_attr

   subroutine put_i8_attr(loc, name, value, err)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer(i8), target, intent(in) :: value
      type(error_t), allocatable, intent(out) :: err
      call put_scalar_attr(loc, name, h5kind_to_type(i8, H5_INTEGER_KIND), c_loc(value), err)
   end subroutine put_i8_attr

   logical function attr_exists(loc, name)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      integer :: h
      call h5aexists_f(loc, name, attr_exists, h)
      if (h < 0) attr_exists = .false.
   end function attr_exists

   !> A scalar variable-length string attribute ('' and ok = .false. if absent).
   subroutine get_str_attr(loc, name, value, ok)
      integer(hid_t), intent(in) :: loc
      character(len=*), intent(in) :: name
      character(len=:), allocatable, intent(out) :: value
      logical, intent(out) :: ok
      integer(hid_t) :: t, a
      type(c_ptr), target :: p(1)
      type(c_ptr) :: buf
      type(error_t), allocatable :: err
      integer :: h
      value = ''
      call h5aopen_f(loc, name, a, h)
      ok = h >= 0
      if (.not. ok) return
      call make_string_type(t, err)
      ok = .not. allocated(err)
      if (ok) then
         buf = c_loc(p)
         call h5aread_f(a, t, buf, h)
         ok = h >= 0
         if (ok) value = c_text(p(1))
         call h5tclose_f(t, h)
      end if
      call h5aclose_f(a, h)
   end subroutine get_str_attr
end module trainsim_h5
