!> Natural frequencies and mode shapes of the linearised train: the
!> generalised symmetric eigenproblem K phi = omega^2 M phi (LAPACK dsygv)
!> over the free node angles; fixed and prescribed-speed nodes are held.
!> Elements with clearances are linearised in their current contact state.
module trainsim_modes
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t, fatal_error, err_numeric, err_input
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_clearance_element, only: clearance_element_t
   implicit none
   private

   public :: modes_t, compute_modes, rk4_stability_limit

   !> |lambda h| on the imaginary axis inside which classical RK4 is stable (2 sqrt 2).
   real(wp), parameter :: rk4_stability_limit = 2.0_wp*sqrt(2.0_wp)

   type :: modes_t
      integer :: n = 0
      integer, allocatable :: node(:)         !< model node index of each degree of freedom
      real(wp), allocatable :: freq_hz(:)     !< ascending
      real(wp), allocatable :: shape(:, :)    !< (dof, mode), largest component +1
      logical, allocatable :: rigid(:)        !< rigid-body (zero-frequency) mode
      real(wp) :: omega_max = 0.0_wp          !< highest circular frequency, rad/s
   end type modes_t

   interface
      subroutine dsygv(itype, jobz, uplo, n, a, lda, b, ldb, w, work, lwork, info)
         import :: wp
         integer, intent(in) :: itype, n, lda, ldb, lwork
         character, intent(in) :: jobz, uplo
         real(wp), intent(inout) :: a(lda, *), b(ldb, *)
         real(wp), intent(out) :: w(*), work(*)
         integer, intent(out) :: info
      end subroutine dsygv
   end interface

contains

   !> Linearised modes of `model` about its initial state. With `closed`, every
   !> clearance open at the start is linearised as closed (its contact stiffness
   !> counts: the highest frequency a contact can excite); the modes of the
   !> model are restored to the initial state afterwards.
   subroutine compute_modes(model, modes, err, closed)
      type(model_t), intent(inout) :: model
      type(modes_t), intent(out) :: modes
      type(error_t), allocatable, intent(out) :: err
      logical, intent(in), optional :: closed
      integer, allocatable :: dof(:)
      real(wp), allocatable :: k(:, :), m(:, :), w(:), work(:), y(:)
      real(wp) :: ke(2, 2), lam_max, big
      integer :: i, n, info, il, ir, a, b, j, imax

      allocate (dof(size(model%nodes)))
      dof = 0
      n = 0
      do i = 1, size(model%nodes)
         if (model%is_held(i) .or. model%nodes(i)%n%is_fixed()) cycle
         if (.not. model%nodes(i)%n%inertia() > 0.0_wp) cycle
         n = n + 1
         dof(i) = n
      end do
      modes%n = n
      allocate (modes%node(n), modes%freq_hz(n), modes%shape(n, n), modes%rigid(n))
      if (n == 0) then
         call fatal_error(err, 'the train has no free inertia: every node is fixed or has a prescribed speed', err_input)
         return
      end if
      do i = 1, size(model%nodes)
         if (dof(i) > 0) modes%node(dof(i)) = i
      end do
      ! clearance elements are linearised in the contact state they start in
      call model%initial_state(y)
      call model%init_modes(model%run%t_start, y)
      if (present(closed)) then
         if (closed) then
            do j = 1, size(model%elements)
               select type (e => model%elements(j)%e)
               class is (clearance_element_t)
                  if (e%cl%mode == 0) e%cl%mode = 1
               end select
            end do
         end if
      end if
      allocate (k(n, n), m(n, n), w(n), work(max(1, 3*n*n)))
      k = 0.0_wp; m = 0.0_wp
      do i = 1, n
         m(i, i) = model%nodes(modes%node(i))%n%inertia()
      end do
      do j = 1, size(model%elements)
         call model%elements(j)%e%stiffness_matrix(ke)
         il = dof(model%elements(j)%e%left)
         ir = dof(model%elements(j)%e%right)
         do a = 1, 2
            do b = 1, 2
               if (a == 1) then
                  i = il
               else
                  i = ir
               end if
               if (b == 1) then
                  info = il
               else
                  info = ir
               end if
               if (i > 0 .and. info > 0) k(i, info) = k(i, info) + ke(a, b)
            end do
         end do
      end do
      call dsygv(1, 'V', 'U', n, k, n, m, n, w, work, size(work), info)
      if (present(closed)) then
         if (closed) call model%init_modes(model%run%t_start, y)
      end if
      if (info /= 0) then
         call fatal_error(err, 'the eigenvalue solver (LAPACK dsygv) failed with info = '//str(info), err_numeric)
         return
      end if
      lam_max = max(maxval(abs(w)), tiny(1.0_wp))
      do i = 1, n
         modes%rigid(i) = abs(w(i)) <= 1.0e-9_wp*lam_max
         if (modes%rigid(i)) then
            modes%freq_hz(i) = 0.0_wp
         else
            modes%freq_hz(i) = sqrt(max(w(i), 0.0_wp))/two_pi
         end if
         imax = maxloc(abs(k(:, i)), 1)
         big = k(imax, i)
         modes%shape(:, i) = k(:, i)/big
      end do
      modes%omega_max = two_pi*maxval(modes%freq_hz)
   end subroutine compute_modes
end module trainsim_modes
