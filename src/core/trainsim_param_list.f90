!> Named real parameters of a node or element, as used (derived values
!> included): printed before a run and written to the output file.
module trainsim_param_list
   use trainsim_kinds, only: wp
   use trainsim_strings, only: string_t
   implicit none
   private

   public :: param_list_t, guarded_product, guarded_ratio, make_param_list, append_params, add_choice, param_of

   !> Named real parameters of one element or node (derived values included).
   !> A choice key (a word in the deck) is stored by its code in `values` (the file's
   !> real attribute) and, for the print-out, by its word in `words` (same index; an
   !> empty word or unallocated `words`: print the number).
   type :: param_list_t
      type(string_t), allocatable :: names(:)
      real(wp), allocatable :: values(:)
      type(string_t), allocatable :: words(:)
   end type param_list_t
contains

   !> The list of `names` (blank-padded) and `values`. (Not an array constructor of
   !> string_t structure constructors: gfortran 12 leaks their strings, and params() is
   !> called several times per model build, so a 10^5-run sweep grew without bound.)
   pure function make_param_list(names, values) result(p)
      character(len=*), intent(in) :: names(:)
      real(wp), intent(in) :: values(:)
      type(param_list_t) :: p
      integer :: i
      allocate (p%names(size(names)))
      do i = 1, size(names)
         p%names(i)%s = names(i)(1:len_trim(names(i)))   ! (not trim(): no temporary)
      end do
      p%values = values
   end function make_param_list

   !> The value of parameter `name` in p (the last of that name), `default` if p has none.
   pure real(wp) function param_of(p, name, default) result(a)
      type(param_list_t), intent(in) :: p
      character(len=*), intent(in) :: name
      real(wp), intent(in) :: default
      integer :: k
      a = default
      if (.not. allocated(p%names)) return
      do k = 1, size(p%names)
         if (p%names(k)%s == name) a = p%values(k)
      end do
   end function param_of

   !> Append `names` and `values` to p (as make_param_list; their words, if p has
   !> words, are empty).
   pure subroutine append_params(p, names, values)
      type(param_list_t), intent(inout) :: p
      character(len=*), intent(in) :: names(:)
      real(wp), intent(in) :: values(:)
      integer :: i
      do i = 1, size(names)
         call append_one(p, trim(names(i)), values(i), '')
      end do
   end subroutine append_params

   !> Append the choice key `name`, stored as `code`, printed as `word`.
   pure subroutine add_choice(p, name, code, word)
      type(param_list_t), intent(inout) :: p
      character(len=*), intent(in) :: name, word
      real(wp), intent(in) :: code
      integer :: j
      if (.not. allocated(p%words)) then
         allocate (p%words(size(p%names)))
         do j = 1, size(p%words)
            p%words(j)%s = ''
         end do
      end if
      call append_one(p, name, code, word)
   end subroutine add_choice

   !> One more entry (strings moved, not copied through string_t(...) constructors).
   pure subroutine append_one(p, name, value, word)
      type(param_list_t), intent(inout) :: p
      character(len=*), intent(in) :: name, word
      real(wp), intent(in) :: value
      type(string_t), allocatable :: grown(:)
      integer :: i, m
      m = size(p%names)
      allocate (grown(m + 1))
      do i = 1, m
         call move_alloc(p%names(i)%s, grown(i)%s)
      end do
      grown(m + 1)%s = name
      call move_alloc(grown, p%names)
      p%values = [p%values, value]
      if (allocated(p%words)) then
         allocate (grown(m + 1))
         do i = 1, m
            call move_alloc(p%words(i)%s, grown(i)%s)
         end do
         grown(m + 1)%s = word
         call move_alloc(grown, p%words)
      end if
   end subroutine append_one

   !> a*b for a derived parameter, or huge when that would overflow: a deck value
   !> beyond the accepted range (D-28) must reach the range check that names its
   !> key, not trap in the arithmetic of params() first.
   pure real(wp) function guarded_product(a, b) result(c)
      real(wp), intent(in) :: a, b
      c = huge(1.0_wp)
      if (abs(a) <= 1.0e150_wp .and. abs(b) <= 1.0e150_wp) c = a*b
   end function guarded_product

   !> a/b for a derived parameter, or huge when that would overflow (see guarded_product).
   pure real(wp) function guarded_ratio(a, b) result(c)
      real(wp), intent(in) :: a, b
      c = huge(1.0_wp)
      if (abs(a) <= 1.0e150_wp .and. abs(b) >= 1.0e-150_wp) c = a/b
   end function guarded_ratio
end module trainsim_param_list
