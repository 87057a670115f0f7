!> The mesh keys a gear pair shares (D-92). `mesh = 'external'` (default) or
!> `'internal'`: a pinion (left, the driver) inside a ring gear (right). TRAIN counts each
!> gear's angle in its own sense of rotation, so the deflection along the line of action
!> is d = r1 thl - r2 thr for both kinds; what differs is the sense of the ring relative to
!> the pinion's carrier: an internal pair's gears turn the same way (s = +1, D-73), an
!> external pair's against each other (s = -1). On a carrier, `driven_sense = 'driver'`
!> counts the driven node's angle in the driver's sense (as a planetary's members are all
!> counted); 'own' (default) is TRAIN's. For an internal pair the two senses coincide.
module trainsim_gear_mesh
   use trainsim_kinds, only: wp, pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, to_lower
   use trainsim_deck, only: deck_group_t
   use trainsim_element, only: element_t, accept_carrier
   implicit none
   private

   public :: accept_mesh, check_internal_radii, internal_contact_ratio

contains

   !> Read `mesh`, `carrier` and `driven_sense` of a gear pair (in `configure`).
   subroutine accept_mesh(self, grp, internal, err)
      class(element_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      logical, intent(out) :: internal
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: mesh, sense
      internal = .false.
      call grp%get_string('mesh', mesh, err, default='external'); if (allocated(err)) return
      select case (to_lower(mesh))
      case ('external'); internal = .false.
      case ('internal'); internal = .true.
      case default
         call fatal_error(err, grp%where('mesh')//": error: unknown mesh '"//mesh//"'; valid: external, internal", &
                          err_input)
         return
      end select
      call accept_carrier(self, grp, merge(1.0_wp, -1.0_wp, internal))
      call grp%get_string('driven_sense', sense, err, default='own'); if (allocated(err)) return
      select case (to_lower(sense))
      case ('own')
         self%right_sign = 1.0_wp
      case ('driver')
         if (size(self%port_keys) == 0) then
            call fatal_error(err, grp%where('driven_sense')//": error: driven_sense = 'driver' needs a carrier "// &
                             "(give carrier = '<node>'): without one the driven node is counted in its own sense", &
                             err_input)
            return
         end if
         self%right_sign = merge(1.0_wp, -1.0_wp, internal)   ! an internal pair's senses coincide
      case default
         call fatal_error(err, grp%where('driven_sense')//": error: unknown driven_sense '"//sense// &
                          "'; valid: own, driver", err_input)
      end select
   end subroutine accept_mesh

   !> An internal pair's ring (right) must be larger than its pinion (left): r2 > r1,
   !> blamed on `key` (the ring's radius or tooth count).
   subroutine check_internal_radii(grp, internal, r1, r2, key, err)
      type(deck_group_t), intent(in) :: grp
      logical, intent(in) :: internal
      real(wp), intent(in) :: r1, r2
      character(len=*), intent(in) :: key
      type(error_t), allocatable, intent(out) :: err
      if (internal .and. .not. r2 > r1) then
         call fatal_error(err, grp%where(key)//': error: an internal mesh needs a ring gear (right) larger than '// &
                          'its pinion (left): '//key//' gives '//str(r2)//' against the pinion''s '//str(r1), err_input)
      end if
   end subroutine check_internal_radii

   !> Contact ratio of a standard full-depth internal pair: pinion pitch radius r1, ring
   !> pitch radius r2 > r1, addendum a, pressure angle phi. The ring's tip circle is
   !> r2 - a (its teeth point inwards); the path of contact is
   !> sqrt(ro1^2 - rb1^2) - sqrt(ro2^2 - rb2^2) + (r2 - r1) sin(phi), over the base
   !> pitch pi a cos(phi) (module a). 0 when the ring's tip circle lies inside its base
   !> circle (too few ring teeth for this pressure angle: no involute there).
   pure real(wp) function internal_contact_ratio(phi, r1, r2, a) result(mp)
      real(wp), intent(in) :: phi, r1, r2, a
      real(wp) :: ro1, ro2, rb1, rb2
      ro1 = r1 + a; ro2 = r2 - a
      rb1 = r1*cos(phi); rb2 = r2*cos(phi)
      mp = 0.0_wp
      if (.not. ro2 > rb2) return
      mp = (sqrt(ro1**2 - rb1**2) - sqrt(ro2**2 - rb2**2) + (r2 - r1)*sin(phi))/(pi*a*cos(phi))
   end function internal_contact_ratio
end module trainsim_gear_mesh
