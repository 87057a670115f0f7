!> The runs of a sweep, from the deck's &sweep groups:
!>
!>     &sweep parameter = 'mesh.mesh_frequency', from = 385, to = 645, count = 27 /
!>     &sweep parameter = 'mesh.half_backlash', values = 0.002, 0.005 /
!>     &sweep parameter = 'run.t_end', values = 0.3, 0.2, mode = 'zip' /
!>
!> Each group gives one parameter (TARGET.KEY, as for --set) and its values: a list
!> (`values`), or `from`, `to`, `count` spaced linearly or with `scale = 'log'`.
!> A group with `mode = 'zip'` runs in step with the group before it (same count); the
!> others are the axes of a full grid. Runs are numbered with the first axis slowest.
module trainsim_sweep_spec
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: string_t, str, to_lower
   use trainsim_deck, only: deck_group_t
   use trainsim_overrides, only: override_t, make_override
   implicit none
   private

   public :: sweep_spec_t, read_sweep_spec, max_runs

   !> More runs than this is almost surely a mistake in the deck.
   integer, parameter :: max_runs = 10000000

   !> The runs of a sweep: one row of parameter values per run.
   type :: sweep_spec_t
      type(string_t), allocatable :: names(:)      !< 'mesh.mesh_frequency', ... (one per &sweep group)
      type(string_t), allocatable :: where(:)      !< "deck.nml:30: &sweep #1" per parameter
      integer, allocatable :: axis(:)              !< grid axis of each parameter
      real(wp), allocatable :: values(:, :)        !< (parameter, run)
      integer :: n_runs = 1
      !> Continuation (`continuation = 'up'|'down'|'both'` on one group): per run, its
      !> branch (0 fixed start, 1 up, 2 down) and the run whose end state it starts
      !> from (0: the deck's initial state). Without continuation all 0.
      integer, allocatable :: branch(:), prev(:)
   contains
      procedure :: overrides => spec_overrides
   end type sweep_spec_t

contains

   !> Read the &sweep groups. No group gives one run with no parameters.
   subroutine read_sweep_spec(groups, spec, err)
      type(deck_group_t), intent(inout) :: groups(:)
      type(sweep_spec_t), intent(out) :: spec
      type(error_t), allocatable, intent(out) :: err
      type(string_t), allocatable :: mode_s(:), cont_s(:)
      real(wp), allocatable :: vals(:, :), v(:)
      integer, allocatable :: counts(:), axis_len(:)
      integer :: np, i, j, k, n_axes, irun, rem, idx
      real(wp) :: total

      np = size(groups)
      allocate (spec%names(np), spec%where(np), spec%axis(np), counts(np), mode_s(np), cont_s(np))
      allocate (vals(1, np))
      n_axes = 0
      do i = 1, np
         call read_group(groups(i), spec%names(i)%s, mode_s(i)%s, cont_s(i)%s, v, err)
         if (allocated(err)) return
         spec%where(i)%s = groups(i)%where()
         do j = 1, i - 1
            if (to_lower(spec%names(j)%s) == to_lower(spec%names(i)%s)) then
               call fatal_error(err, groups(i)%where('parameter')//": error: parameter '"//spec%names(i)%s// &
                                "' is already swept by "//spec%where(j)%s, err_input)
               return
            end if
         end do
         counts(i) = size(v)
         if (mode_s(i)%s == 'zip') then
            if (i == 1) then
               call fatal_error(err, groups(i)%where('mode')//": error: mode = 'zip' runs this group in step with "// &
                                'the &sweep group before it, and this is the first', err_input)
               return
            end if
            if (counts(i) /= counts(i - 1)) then
               call fatal_error(err, groups(i)%where('mode')//": error: mode = 'zip' runs this group in step with "// &
                                'the one before it, which has '//str(counts(i - 1))//' values; this one has '// &
                                str(counts(i)), err_input)
               return
            end if
         else
            n_axes = n_axes + 1
         end if
         spec%axis(i) = n_axes
         if (size(vals, 1) < counts(i)) call grow(vals, counts(i))
         vals(1:counts(i), i) = v
      end do

      allocate (axis_len(n_axes))
      total = 1.0_wp
      do i = 1, np
         axis_len(spec%axis(i)) = counts(i)
      end do
      do k = 1, n_axes
         total = total*axis_len(k)
      end do
      if (total > max_runs) then
         call fatal_error(err, spec%where(1)%s//': error: the &sweep groups make '//str(total, 3)// &
                          ' runs (more than '//str(max_runs)//')', err_input)
         return
      end if
      spec%n_runs = nint(total)
      allocate (spec%values(np, spec%n_runs))
      do irun = 1, spec%n_runs
         rem = irun - 1
         do k = n_axes, 1, -1          ! the last axis varies fastest
            idx = mod(rem, axis_len(k)) + 1
            rem = rem/axis_len(k)
            do i = 1, np
               if (spec%axis(i) == k) spec%values(i, irun) = vals(idx, i)
            end do
         end do
      end do
      allocate (spec%branch(spec%n_runs), spec%prev(spec%n_runs))
      spec%branch = 0
      spec%prev = 0
      call continuation_order(groups, spec, cont_s, axis_len, err)
   end subroutine read_sweep_spec

   subroutine grow(a, n)
      real(wp), allocatable, intent(inout) :: a(:, :)
      integer, intent(in) :: n
      real(wp), allocatable :: tmp(:, :)
      allocate (tmp(n, size(a, 2)))
      tmp = 0.0_wp
      tmp(1:size(a, 1), :) = a
      call move_alloc(tmp, a)
   end subroutine grow

   !> One &sweep group: its parameter, mode and values.
   !> With `continuation` on group ic: the runs in ascending (up), descending (down) or
   !> ascending-then-descending (both) order of its values, each run after the first of
   !> its branch starting from the one before it. The group must be the sweep's only
   !> axis with more than one value (the others constants or zipped with it).
   subroutine continuation_order(groups, spec, cont_s, axis_len, err)
      type(deck_group_t), intent(in) :: groups(:)
      type(sweep_spec_t), intent(inout) :: spec
      type(string_t), intent(in) :: cont_s(:)
      integer, intent(in) :: axis_len(:)
      type(error_t), allocatable, intent(out) :: err
      integer, allocatable :: up(:), order(:), br(:)
      integer :: ic, i, j, n, t
      ic = 0
      do i = 1, size(cont_s)
         if (cont_s(i)%s == 'none') cycle
         if (ic > 0) then
            call fatal_error(err, groups(i)%where('continuation')//': error: only one &sweep group can set '// &
                             'continuation; '//spec%where(ic)%s//' does already', err_input)
            return
         end if
         ic = i
      end do
      if (ic == 0) return
      if (mode_is_zip(ic)) then
         call fatal_error(err, groups(ic)%where('continuation')//": error: continuation needs a grid axis "// &
                          "(mode = 'grid'), not a zipped group", err_input)
         return
      end if
      do i = 1, size(axis_len)
         if (i /= spec%axis(ic) .and. axis_len(i) > 1) then
            call fatal_error(err, groups(ic)%where('continuation')//': error: continuation sweeps one axis; '// &
                             'another &sweep group has '//str(axis_len(i))//' values on an axis of its own '// &
                             "(give it one value, or mode = 'zip')", err_input)
            return
         end if
      end do
      n = spec%n_runs
      up = [(i, i=1, n)]
      do i = 2, n                  ! insertion sort of the runs by the continued value
         t = up(i)
         j = i - 1
         do while (j >= 1)
            if (spec%values(ic, up(j)) <= spec%values(ic, t)) exit
            up(j + 1) = up(j)
            j = j - 1
         end do
         up(j + 1) = t
      end do
      select case (cont_s(ic)%s)
      case ('up')
         order = up; br = [(1, i=1, n)]
      case ('down')
         order = up(n:1:-1); br = [(2, i=1, n)]
      case default
         order = [up, up(n:1:-1)]; br = [[(1, i=1, n)], [(2, i=1, n)]]
      end select
      spec%values = spec%values(:, order)
      spec%n_runs = size(order)
      spec%branch = br
      spec%prev = [(merge(0, i - 1, i == 1 .or. br(max(i - 1, 1)) /= br(i)), i=1, size(order))]
   contains
      logical function mode_is_zip(k)
         integer, intent(in) :: k
         mode_is_zip = k > 1 .and. spec%axis(k) == spec%axis(max(k - 1, 1))
      end function mode_is_zip
   end subroutine continuation_order

   subroutine read_group(g, name, mode, cont, v, err)
      type(deck_group_t), intent(inout) :: g
      character(len=:), allocatable, intent(out) :: name, mode, cont
      real(wp), allocatable, intent(out) :: v(:)
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: scale
      real(wp) :: a, b
      integer :: n, i
      type(override_t) :: probe
      logical :: has_range(4)

      call g%get_string('parameter', name, err); if (allocated(err)) return
      call make_override(name, '0', g%where('parameter'), probe, err)
      if (allocated(err)) return
      call g%get_string('mode', mode, err, default='grid'); if (allocated(err)) return
      mode = to_lower(mode)
      if (mode /= 'grid' .and. mode /= 'zip') then
         call fatal_error(err, g%where('mode')//": error: unknown mode '"//mode//"'; valid: grid (default), zip", &
                          err_input)
         return
      end if
      ! ask for every key (has() records the valid keys for the unknown-key message)
      call g%get_string('continuation', cont, err, default='none'); if (allocated(err)) return
      cont = to_lower(cont)
      if (cont /= 'none' .and. cont /= 'up' .and. cont /= 'down' .and. cont /= 'both') then
         call fatal_error(err, g%where('continuation')//": error: unknown continuation '"//cont// &
                          "'; valid: none (default), up, down, both", err_input)
         return
      end if
      has_range(1) = g%has('from'); has_range(2) = g%has('to')
      has_range(3) = g%has('count'); has_range(4) = g%has('scale')
      if (g%has('values')) then
         if (any(has_range)) then
            call fatal_error(err, g%where('values')//': error: give values, or from, to and count, not both', &
                             err_input)
            return
         end if
         call g%get_real_array('values', v, err); if (allocated(err)) return
      else
         call g%get_real('from', a, err); if (allocated(err)) return
         call g%get_real('to', b, err); if (allocated(err)) return
         call g%get_int('count', n, err); if (allocated(err)) return
         call g%get_string('scale', scale, err, default='linear'); if (allocated(err)) return
         scale = to_lower(scale)
         if (n < 1) then
            call fatal_error(err, g%where('count')//': error: count must be >= 1, got '//str(n), err_input)
            return
         end if
         if (n > max_runs) then
            call fatal_error(err, g%where('count')//': error: count must be <= '//str(max_runs)//', got '//str(n), &
                             err_input)
            return
         end if
         if (n == 1 .and. a /= b) then
            call fatal_error(err, g%where('count')//': error: count = 1 needs from = to', err_input)
            return
         end if
         allocate (v(n))
         select case (scale)
         case ('linear', 'lin')
            do i = 1, n
               if (n > 1) v(i) = a + (b - a)*real(i - 1, wp)/real(n - 1, wp)
            end do
         case ('log')
            if (.not. (a > 0.0_wp .and. b > 0.0_wp)) then
               call fatal_error(err, g%where('scale')//": error: scale = 'log' needs from > 0 and to > 0", err_input)
               return
            end if
            do i = 1, n
               if (n > 1) v(i) = exp(log(a) + (log(b) - log(a))*real(i - 1, wp)/real(n - 1, wp))
            end do
         case default
            call fatal_error(err, g%where('scale')//": error: unknown scale '"//scale//"'; valid: linear, log", &
                             err_input)
            return
         end select
         v(1) = a
         v(n) = b
      end if
      if (size(v) == 0) then
         call fatal_error(err, g%where('values')//': error: a &sweep group needs at least one value', err_input)
         return
      end if
      call g%check_unused(err, 'a &sweep group')
   end subroutine read_group

   !> The overrides of run `irun` (1-based), each naming its &sweep group and value.
   function spec_overrides(self, irun, err) result(ovs)
      class(sweep_spec_t), intent(in) :: self
      integer, intent(in) :: irun
      type(error_t), allocatable, intent(out) :: err
      type(override_t), allocatable :: ovs(:)
      integer :: i
      allocate (ovs(size(self%names)))
      do i = 1, size(self%names)
         call make_override(self%names(i)%s, str(self%values(i, irun)), self%where(i)%s//' (run '//str(irun)// &
                            ': '//self%names(i)%s//' = '//str(self%values(i, irun))//')', ovs(i), err)
         if (allocated(err)) return
      end do
   end function spec_overrides
end module trainsim_sweep_spec
