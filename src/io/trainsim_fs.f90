!> The file system as output files need it: the C library's rename, remove, truncate
!> and getpid, and the helpers of src/io/trainsim_fs.c (the kind of a path without
!> following a link, the sweep file's writer lock, errno and its text, free space).
!> Shared by the run sink (trainsim_hdf5) and the sweep file (trainsim_sweep_file),
!> which also share here why a path cannot be an output file (`path_refusal`).
module trainsim_fs
   use, intrinsic :: iso_c_binding, only: c_int, c_long, c_long_long, c_char, c_null_char
   use trainsim_strings, only: str
   implicit none
   private

   public :: pk_absent, pk_regular, pk_directory, pk_symlink, pk_other
   public :: path_kind, path_refusal, io_reason, os_text, os_reason
   public :: fs_rename, fs_remove, fs_truncate, process_id, lock_file, unlock_file, remove_stale_parts, &
      trim_memory

   !> Kinds of path returned by trainsim_path_kind (src/io/trainsim_fs.c).
   integer, parameter :: pk_absent = 0, pk_regular = 1, pk_directory = 2, pk_symlink = 3, pk_other = 4

   interface
      !> C stdio rename(3).
      function c_rename(old, new) bind(C, name='rename') result(rc)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: old(*), new(*)
         integer(c_int) :: rc
      end function c_rename
      !> C stdio remove(3).
      function c_remove(path) bind(C, name='remove') result(rc)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: rc
      end function c_remove
      !> POSIX truncate(2) (off_t is a C long on the 64-bit Linux trainsim targets).
      function c_truncate(path, length) bind(C, name='truncate') result(rc)
         import :: c_int, c_long, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_long), value :: length
         integer(c_int) :: rc
      end function c_truncate
      !> POSIX getpid(2).
      function c_getpid() bind(C, name='getpid') result(pid)
         import :: c_int
         integer(c_int) :: pid
      end function c_getpid
      !> Kind of a path, not following a final symbolic link (pk_*).
      function c_path_kind(path) bind(C, name='trainsim_path_kind') result(kind)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: kind
      end function c_path_kind
      function c_lock(path, info) bind(C, name='trainsim_lock') result(fd)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int), intent(out) :: info
         integer(c_int) :: fd
      end function c_lock
      subroutine c_unlock(fd, path) bind(C, name='trainsim_unlock')
         import :: c_int, c_char
         integer(c_int), value :: fd
         character(kind=c_char), intent(in) :: path(*)
      end subroutine c_unlock
      subroutine c_strerror(e, buf, n) bind(C, name='trainsim_strerror')
         import :: c_int, c_char
         integer(c_int), value :: e, n
         character(kind=c_char), intent(out) :: buf(*)
      end subroutine c_strerror
      function c_errno() bind(C, name='trainsim_errno') result(e)
         import :: c_int
         integer(c_int) :: e
      end function c_errno
      function c_free_bytes(path) bind(C, name='trainsim_free_bytes') result(n)
         import :: c_char, c_long_long
         character(kind=c_char), intent(in) :: path(*)
         integer(c_long_long) :: n
      end function c_free_bytes
      function c_remove_stale_parts(path) bind(C, name='trainsim_remove_stale_parts') result(n)
         import :: c_int, c_char
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: n
      end function c_remove_stale_parts
      subroutine c_trim_memory() bind(C, name='trainsim_trim_memory')
      end subroutine c_trim_memory
   end interface

contains

   !> Kind of `path` (pk_*; -1 cannot tell), not following a final symbolic link.
   integer function path_kind(path)
      character(len=*), intent(in) :: path
      path_kind = int(c_path_kind(path//c_null_char))
   end function path_kind

   !> Why `path` cannot be an output file ('' if it can: absent or a regular file).
   !> `other_hint` ends the sentence about a device, pipe or socket (what to do instead).
   function path_refusal(path, other_hint) result(reason)
      character(len=*), intent(in) :: path, other_hint
      character(len=:), allocatable :: reason
      select case (path_kind(path))
      case (pk_directory)
         reason = 'it is a directory'
      case (pk_symlink)
         reason = 'it is a symbolic link (trainsim replaces only regular files; give the path of the link''s '// &
                  'target, or remove the link)'
      case (pk_other)
         reason = 'it is not a regular file (a device, pipe or socket)'//other_hint
      case default
         reason = ''
      end select
   end function path_refusal

   !> ": <the operating system's reason>" after a failed write to `path` ('' if unknown):
   !> errno if it names a full disk, else "no space left" if the file system has none.
   function io_reason(path) result(r)
      character(len=*), intent(in) :: path
      character(len=:), allocatable :: r
      integer(c_int) :: e
      integer(c_long_long) :: free
      character(len=:), allocatable :: dir
      integer :: i
      integer(c_int), parameter :: enospc = 28, edquot = 122
      e = c_errno()
      r = ''
      if (e == enospc .or. e == edquot) then
         r = ': '//os_text(int(e))
         return
      end if
      i = index(path, '/', back=.true.)
      dir = '.'
      if (i > 0) dir = path(1:max(i - 1, 1))
      free = c_free_bytes(dir//c_null_char)
      if (free >= 0 .and. free < 65536_c_long_long) r = ': '//os_text(int(enospc))//' ('//str(int(free))//' bytes free)'
   end function io_reason

   !> The text of errno `e` (strerror).
   function os_text(e) result(t)
      integer, intent(in) :: e
      character(len=:), allocatable :: t
      character(kind=c_char) :: buf(256)
      integer :: i
      call c_strerror(int(e, c_int), buf, 256_c_int)
      t = ''
      do i = 1, 255
         if (buf(i) == c_null_char) exit
         t = t//buf(i)
      end do
   end function os_text

   !> The operating-system part of a gfortran OPEN message ("Cannot open file 'x': reason").
   pure function os_reason(msg) result(reason)
      character(len=*), intent(in) :: msg
      character(len=:), allocatable :: reason
      integer :: k
      k = index(msg, ': ', back=.true.)
      if (k > 0) then
         reason = trim(msg(k + 2:))
      else
         reason = trim(msg)
      end if
      if (len(reason) == 0) reason = 'cannot create file'
   end function os_reason

   !> rename(3): true on success.
   logical function fs_rename(old, new)
      character(len=*), intent(in) :: old, new
      fs_rename = c_rename(old//c_null_char, new//c_null_char) == 0
   end function fs_rename

   !> remove(3), its failure ignored (the file may not exist).
   subroutine fs_remove(path)
      character(len=*), intent(in) :: path
      integer(c_int) :: rc
      rc = c_remove(path//c_null_char)
   end subroutine fs_remove

   !> truncate(2) to length 0, its failure ignored (frees a discarded file's space).
   subroutine fs_truncate(path)
      character(len=*), intent(in) :: path
      integer(c_int) :: rc
      rc = c_truncate(path//c_null_char, 0_c_long)
   end subroutine fs_truncate

   integer function process_id()
      process_id = int(c_getpid())
   end function process_id

   !> flock `path` (created if absent): the descriptor, -1 held by another process
   !> (`info` its pid when known), < -1 cannot create it (`info` the errno).
   integer function lock_file(path, info) result(fd)
      character(len=*), intent(in) :: path
      integer, intent(out) :: info
      integer(c_int) :: ci
      fd = int(c_lock(path//c_null_char, ci))
      info = int(ci)
   end function lock_file

   subroutine unlock_file(fd, path)
      integer, intent(in) :: fd
      character(len=*), intent(in) :: path
      call c_unlock(int(fd, c_int), path//c_null_char)
   end subroutine unlock_file

   !> Remove the temporaries `path.<digits>.part` (the caller holds path's lock); how many.
   integer function remove_stale_parts(path)
      character(len=*), intent(in) :: path
      remove_stale_parts = int(c_remove_stale_parts(path//c_null_char))
   end function remove_stale_parts

   !> Give memory freed since the last call back to the system (malloc_trim).
   subroutine trim_memory()
      call c_trim_memory()
   end subroutine trim_memory
end module trainsim_fs
