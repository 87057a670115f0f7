!> EL3, ideal gear pair: constant mesh stiffness, no backlash, no damping
!> (Appendix H, eqs. H.15-H.16). Mesh deflection along the line of action
!>   delta = r1 x_l - r2 x_r,  F = k delta ;  left node gets -F r1, right node +F r2.
module trainsim_el_ideal_gear
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list, guarded_product, guarded_ratio, add_choice
   use trainsim_element, only: element_t
   use trainsim_gear_mesh, only: accept_mesh, check_internal_radii
   implicit none
   private

   public :: ideal_gear_t, new_ideal_gear

   !> Mesh stiffness k (force/length) and base radii of driver (left) and driven (right) gear.
   type, extends(element_t) :: ideal_gear_t
      real(wp) :: k = 0.0_wp, r1 = 0.0_wp, r2 = 0.0_wp
      logical :: internal = .false.   !< mesh = 'internal' (trainsim_gear_mesh)
   contains
      procedure :: configure => gear_configure
      procedure :: torques => gear_torques
      procedure :: displacement => gear_displacement
      procedure :: displacement_unit => gear_displacement_unit
      procedure :: stiffness_matrix => gear_stiffness
      procedure :: potential_energy => gear_potential
      procedure :: status => gear_status
      procedure :: params => gear_params
      procedure :: torque_jacobian => gear_jacobian
      procedure :: linear_spring => gear_linear_spring
   end type ideal_gear_t

contains

   !> Registry factory: a new, unconfigured ideal gear pair.
   subroutine new_ideal_gear(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (ideal_gear_t :: el)
   end subroutine new_ideal_gear

   subroutine gear_configure(self, grp, units, err)
      class(ideal_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      call accept_mesh(self, grp, self%internal, err)   ! external or internal, on an optional carrier (D-73)
      if (allocated(err)) return
      call grp%get_real('stiffness', self%k, err); if (allocated(err)) return
      call grp%expect([character(len=9) :: 'rb_driver', 'rb_driven'])   ! a step apart (D-62)
      call grp%get_real('rb_driver', self%r1, err); if (allocated(err)) return
      call grp%get_real('rb_driven', self%r2, err); if (allocated(err)) return
      if (.not. self%k > 0.0_wp) then
         call fatal_error(err, grp%where('stiffness')//': error: mesh stiffness must be > 0, got '//str(self%k), err_input)
      else if (.not. self%r1 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driver')//': error: base radius must be > 0, got '//str(self%r1), err_input)
      else if (.not. self%r2 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driven')//': error: base radius must be > 0, got '//str(self%r2), err_input)
      else
         call check_internal_radii(grp, self%internal, self%r1, self%r2, 'rb_driven', err)
      end if
   end subroutine gear_configure

   pure subroutine gear_torques(self, thl, wl, thr, wr, tl, tr)
      class(ideal_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      real(wp) :: f
      associate (u1 => wl, u2 => wr)
      end associate
      f = self%k*(self%r1*thl - self%r2*thr)   ! eqs. (H.15), (H.16)
      tl = -f*self%r1
      tr = f*self%r2
   end subroutine gear_torques

   !> A linear spring along the line of action, no damping (the model's fast path).
   pure subroutine gear_linear_spring(self, linear, k, c, r1, r2)
      class(ideal_gear_t), intent(in) :: self
      logical, intent(out) :: linear
      real(wp), intent(out) :: k, c, r1, r2
      k = self%k; c = 0.0_wp; r1 = self%r1; r2 = self%r2
      linear = .true.
   end subroutine gear_linear_spring

   pure real(wp) function gear_displacement(self, thl, thr) result(d)
      class(ideal_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      d = self%r1*thl - self%r2*thr
   end function gear_displacement

   pure function gear_displacement_unit(self) result(u)
      class(ideal_gear_t), intent(in) :: self
      character(len=:), allocatable :: u
      associate (unused => self)
      end associate
      u = 'length'
   end function gear_displacement_unit

   pure subroutine gear_stiffness(self, k)
      class(ideal_gear_t), intent(in) :: self
      real(wp), intent(out) :: k(2, 2)
      k(1, 1) = self%k*self%r1**2
      k(1, 2) = -self%k*self%r1*self%r2
      k(2, 1) = k(1, 2)
      k(2, 2) = self%k*self%r2**2
   end subroutine gear_stiffness

   pure real(wp) function gear_potential(self, thl, thr) result(e)
      class(ideal_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      e = 0.5_wp*self%k*(self%r1*thl - self%r2*thr)**2
   end function gear_potential

   pure subroutine gear_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(ideal_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      associate (u1 => wl, u2 => wr)
      end associate
      disp = self%r1*thl - self%r2*thr
      force = self%k*disp
      contact = 1
      pairs = 0
   end subroutine gear_status

   pure subroutine gear_jacobian(self, thl, wl, thr, wr, jt)
      class(ideal_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: jt(2, 4)
      associate (u1 => thl, u2 => wl, u3 => thr, u4 => wr)
      end associate
      jt(1, :) = [-self%k*self%r1**2, 0.0_wp, self%k*self%r1*self%r2, 0.0_wp]
      jt(2, :) = [self%k*self%r1*self%r2, 0.0_wp, -self%k*self%r2**2, 0.0_wp]
   end subroutine gear_jacobian

   function gear_params(self) result(p)
      class(ideal_gear_t), intent(in) :: self
      type(param_list_t) :: p
      ! derived: gear_ratio = omega_driver / omega_driven = r2 / r1
      p = make_param_list([character(len=40) :: 'stiffness', 'rb_driver', 'rb_driven', &
                       'gear_ratio'], &
                       [self%k, self%r1, self%r2, guarded_ratio(self%r2, self%r1)])
      if (self%internal) call add_choice(p, 'internal_mesh', 1.0_wp, 'internal')   ! (external pairs: as before)
   end function gear_params
end module trainsim_el_ideal_gear
