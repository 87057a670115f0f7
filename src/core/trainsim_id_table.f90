!> A string -> integer table (open addressing, linear probing) for look-ups by id
!> while a deck is read: insert and look-up take constant time on average, so
!> checking n ids for duplicates and resolving n references costs O(n), not O(n^2).
!>
!> Keys compare like Fortran's `==` (trailing blanks do not count), so the table
!> answers exactly as a linear search with `==` would.
module trainsim_id_table
   use, intrinsic :: iso_fortran_env, only: int64
   use trainsim_strings, only: string_t
   implicit none
   private

   public :: id_table_t

   !> Table of ids with one positive integer value each (typically an index).
   type :: id_table_t
      private
      integer :: n = 0                           ! entries stored
      type(string_t), allocatable :: keys(:)     ! slot -> key (trailing blanks dropped)
      integer, allocatable :: vals(:)            ! slot -> value; 0: empty slot
   contains
      procedure :: insert => table_insert
      procedure :: get => table_get
      procedure :: count => table_count
      procedure :: reserve => table_reserve
   end type id_table_t

contains

   !> Store `key` -> `val` (val > 0) unless `key` is present. `previous` is the value
   !> already stored under `key` (0 when the key was new and has been stored).
   subroutine table_insert(self, key, val, previous)
      class(id_table_t), intent(inout) :: self
      character(len=*), intent(in) :: key
      integer, intent(in) :: val
      integer, intent(out) :: previous
      integer :: slot
      if (.not. allocated(self%vals)) call rehash(self, 64)
      if (2*(self%n + 1) > size(self%vals)) call rehash(self, 2*size(self%vals))
      call probe(self, key, slot, previous)
      if (previous /= 0) return
      self%keys(slot)%s = key(1:len_trim(key))
      self%vals(slot) = val
      self%n = self%n + 1
   end subroutine table_insert

   !> Value stored under `key`, 0 if absent.
   integer function table_get(self, key) result(val)
      class(id_table_t), intent(in) :: self
      character(len=*), intent(in) :: key
      integer :: slot
      val = 0
      if (.not. allocated(self%vals)) return
      call probe(self, key, slot, val)
   end function table_get

   !> Room for `n` keys without a rehash as they go in (a table about to take
   !> every node's or element's id: D-114).
   subroutine table_reserve(self, n)
      class(id_table_t), intent(inout) :: self
      integer, intent(in) :: n
      integer :: cap
      cap = 64
      do while (cap < 2*n + 2)
         cap = 2*cap
      end do
      if (allocated(self%vals)) then
         if (size(self%vals) >= cap) return
      end if
      call rehash(self, cap)
   end subroutine table_reserve

   !> Number of keys stored.
   pure integer function table_count(self) result(n)
      class(id_table_t), intent(in) :: self
      n = self%n
   end function table_count

   !> Slot holding `key` (val > 0 there), or the empty slot where it would go (val = 0).
   !> The table is never more than half full, so an empty slot is always found.
   subroutine probe(self, key, slot, val)
      type(id_table_t), intent(in) :: self
      character(len=*), intent(in) :: key
      integer, intent(out) :: slot, val
      integer :: mask
      mask = size(self%vals) - 1
      slot = spread_bits(hash(key(1:len_trim(key))), size(self%vals)) + 1
      do
         val = self%vals(slot)
         if (val == 0) return
         if (self%keys(slot)%s == key) return
         slot = iand(slot, mask) + 1
      end do
   end subroutine probe

   !> Grow to `capacity` slots (a power of two) and re-insert every entry.
   subroutine rehash(self, capacity)
      type(id_table_t), intent(inout) :: self
      integer, intent(in) :: capacity
      type(string_t), allocatable :: old_keys(:)
      integer, allocatable :: old_vals(:)
      integer :: i, slot, found
      if (allocated(self%vals)) then
         call move_alloc(self%keys, old_keys)
         call move_alloc(self%vals, old_vals)
      else
         allocate (old_keys(0), old_vals(0))
      end if
      allocate (self%keys(capacity), self%vals(capacity))
      self%vals = 0
      do i = 1, size(old_vals)
         if (old_vals(i) == 0) cycle
         call probe(self, old_keys(i)%s, slot, found)
         call move_alloc(old_keys(i)%s, self%keys(slot)%s)
         self%vals(slot) = old_vals(i)
      end do
   end subroutine rehash

   !> Slot in [0, capacity) for hash `h` (capacity a power of two <= 2**31): the top
   !> bits of the low 32 bits of h * floor(2**32/golden ratio) (Knuth's multiplicative
   !> hashing), so that keys differing only in their last characters spread out.
   pure integer function spread_bits(h, capacity) result(slot)
      integer, intent(in) :: h, capacity
      integer(int64) :: x
      integer :: bits
      bits = trailz(capacity)   ! capacity = 2**bits
      x = iand(int(h, int64)*2654435769_int64, 4294967295_int64)   ! h < 2**31: no overflow
      slot = int(shiftr(x, 32 - bits))
   end function spread_bits

   !> FNV-1a hash of the bytes of `s` in 32 bits, its low 31 bits (no division a
   !> byte, as a polynomial modulo a prime took; nothing overflows in 64 bits).
   pure integer function hash(s) result(h)
      character(len=*), intent(in) :: s
      integer(int64), parameter :: mask32 = 4294967295_int64
      integer(int64) :: x
      integer :: i
      x = 2166136261_int64
      do i = 1, len(s)
         x = iand(ieor(x, int(iachar(s(i:i)), int64))*16777619_int64, mask32)
      end do
      h = int(iand(x, 2147483647_int64))
   end function hash
end module trainsim_id_table
