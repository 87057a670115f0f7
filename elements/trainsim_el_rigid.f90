!> Rigid connections (issue 23 item 2; D-81's constraints): `rigid_gear`, an
!> ideal gear pair without compliance, r1 wl = r2 wr (row (r1, -r2)), and
!> `rigid_join`, two nodes one rigid body, wl = wr (row (1, -1)). Each is a
!> permanent constraint: no torque of its own, no states, no guards; the
!> model's constraint solve puts g_p lam on its ports. A stiff gear needs no
!> artificial mesh mode (a stiff `ideal_gear` caps RK4's step).
module trainsim_el_rigid
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_group_t
   use trainsim_param_list, only: param_list_t, make_param_list, guarded_ratio
   use trainsim_element, only: element_t
   use trainsim_gear_mesh, only: accept_mesh, check_internal_radii
   implicit none
   private

   public :: rigid_gear_t, rigid_join_t, new_rigid_gear, new_rigid_join

   !> Lever arms r1, r2: the constraint r1 wl - r2 wr = 0 (1, 1 for a join).
   type, extends(element_t) :: rigid_gear_t
      real(wp) :: r1 = 1.0_wp, r2 = 1.0_wp
      logical :: internal = .false.   !< mesh = 'internal' (trainsim_gear_mesh; rigid_gear only)
   contains
      procedure :: configure => rigid_gear_configure
      procedure :: torques => rigid_torques
      procedure :: displacement => rigid_displacement
      procedure :: displacement_unit => rigid_displacement_unit
      procedure :: status => rigid_status
      procedure :: params => rigid_params
   end type rigid_gear_t

   type, extends(rigid_gear_t) :: rigid_join_t
   contains
      procedure :: configure => rigid_join_configure
      procedure :: displacement_unit => join_displacement_unit
      procedure :: params => join_params
   end type rigid_join_t

contains

   !> Registry factory: a new, unconfigured rigid gear pair.
   subroutine new_rigid_gear(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (rigid_gear_t :: el)
   end subroutine new_rigid_gear

   !> Registry factory: a new, unconfigured rigid join.
   subroutine new_rigid_join(el)
      class(element_t), allocatable, intent(out) :: el
      allocate (rigid_join_t :: el)
   end subroutine new_rigid_join

   subroutine rigid_gear_configure(self, grp, units, err)
      class(rigid_gear_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      call accept_mesh(self, grp, self%internal, err); if (allocated(err)) return   ! on a carrier: D-73, D-92
      call grp%get_real('rb_driver', self%r1, err); if (allocated(err)) return
      call grp%get_real('rb_driven', self%r2, err); if (allocated(err)) return
      if (.not. self%r1 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driver')//': error: base radius must be > 0, got '//str(self%r1), err_input)
      else if (.not. self%r2 > 0.0_wp) then
         call fatal_error(err, grp%where('rb_driven')//': error: base radius must be > 0, got '//str(self%r2), err_input)
      else
         call check_internal_radii(grp, self%internal, self%r1, self%r2, 'rb_driven', err)
      end if
      call set_row(self)
   end subroutine rigid_gear_configure

   subroutine rigid_join_configure(self, grp, units, err)
      class(rigid_join_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units, u2 => grp)
      end associate
      self%r1 = 1.0_wp
      self%r2 = 1.0_wp
      call set_row(self)
   end subroutine rigid_join_configure

   !> No torque of its own: the constraint torque is the model's.
   pure subroutine rigid_torques(self, thl, wl, thr, wr, tl, tr)
      class(rigid_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      associate (u1 => self, u2 => thl, u3 => wl, u4 => thr, u5 => wr)
      end associate
      tl = 0.0_wp
      tr = 0.0_wp
   end subroutine rigid_torques

   !> r1 thl - r2 thr: constant while the constraint holds (its drift is the check).
   pure real(wp) function rigid_displacement(self, thl, thr) result(d)
      class(rigid_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, thr
      d = self%r1*thl - self%r2*thr
   end function rigid_displacement

   pure function rigid_displacement_unit(self) result(u)
      class(rigid_gear_t), intent(in) :: self
      character(len=:), allocatable :: u
      associate (unused => self)
      end associate
      u = 'length'
   end function rigid_displacement_unit

   pure function join_displacement_unit(self) result(u)
      class(rigid_join_t), intent(in) :: self
      character(len=:), allocatable :: u
      associate (unused => self)
      end associate
      u = 'rad'
   end function join_displacement_unit

   !> displacement as above; force: the mesh force along the line F = -lam
   !> (ideal_gear's sign: tl = -F r1, tr = F r2), for a join the torque on the
   !> right node -lam; contact 1, pairs 0.
   pure subroutine rigid_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(rigid_gear_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      associate (u1 => wl, u2 => wr)
      end associate
      disp = self%r1*thl - self%r2*thr
      force = -self%con%lam(1)
      contact = 1
      pairs = 0
   end subroutine rigid_status

   !> The one row, always in force: r1 wl - r2 wr = 0; on a carrier (port 3) the
   !> same in its frame, r1 (wl - wc) - r2 (a wr - s wc) = 0 (D-73, D-92).
   subroutine set_row(self)
      class(rigid_gear_t), intent(inout) :: self
      self%con%on = .true.
      self%con%rigid = .true.                  ! (merged in the RK4 step advice: D-86)
      self%con%n = 1
      self%con%g(1, 1:2) = [self%r1, -self%r2]
      if (allocated(self%port_keys)) then
         if (size(self%port_keys) > 0) self%con%g(1, 1:3) = [self%r1, -self%right_sign*self%r2, &
                                                             -self%r1 + self%carrier_sense*self%r2]
      end if
   end subroutine set_row

   function rigid_params(self) result(p)
      class(rigid_gear_t), intent(in) :: self
      type(param_list_t) :: p
      p = make_param_list([character(len=40) :: 'rb_driver', 'rb_driven', 'gear_ratio'], &
                          [self%r1, self%r2, guarded_ratio(self%r2, self%r1)])
   end function rigid_params

   function join_params(self) result(p)
      class(rigid_join_t), intent(in) :: self
      type(param_list_t) :: p
      associate (unused => self)
      end associate
      p = make_param_list([character(len=40) :: 'gear_ratio'], [1.0_wp])
   end function join_params
end module trainsim_el_rigid
