!> The `&planetary` group (issue 25, D-93): a planetary stage written as one group
!> and expanded, before the nodes and elements are read, into ordinary `&node` and
!> `&element` groups appended to the deck, so every metric, event, plot and `--set`
!> of a node or element works per member and per mesh.
!>
!> A stage `id` has a sun, a ring and a carrier (each a new inertia `<id>_sun` ... from
!> `sun_inertia` ..., an existing node named by `sun = '<node>'` ..., or a fixed node
!> with `held = 'sun'` ...), N planets `<id>_planet<n>` (planet_inertia) and, per planet,
!> two meshes with the carrier as their third port (D-73): `<id>_sun_planet<n>` (sun left,
!> planet right, external, the planet counted in the sun's sense: driven_sense =
!> 'driver') and `<id>_ring_planet<n>` (planet left, ring right, internal). Every member's
!> angle is counted in one sense (the sun's); a planet's node is its absolute angle, its
!> meshes see it relative to the carrier. mesh = 'spur' (spur_gear elements in the
!> geometry form, each with its own backlash and mesh phase) or 'ideal' (ideal_gear).
module trainsim_planetary_deck
   use trainsim_kinds, only: wp, pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: string_t, str, to_lower
   use trainsim_units, only: units_t
   use trainsim_deck, only: deck_t, deck_group_t, parse_deck
   use trainsim_model, only: model_t
   implicit none
   private

   public :: expand_planetary, mark_share_sets, planet_phases, assembles, max_planets

   !> Most planets on one carrier (more is a typing error: 2 pi / 64 is under 6 degrees).
   integer, parameter :: max_planets = 64
   character(len=*), parameter :: members(3) = ['sun    ', 'ring   ', 'carrier']

   !> One stage as read from its group.
   type :: stage_t
      character(len=:), allocatable :: id
      integer :: n = 0
      real(wp) :: zs = 0.0_wp, zp = 0.0_wp, zr = 0.0_wp
      real(wp), allocatable :: psi_deg(:)          !< planet angles on the carrier, degrees
      logical :: equal = .true.                    !< equally spaced (no planet_angles)
      type(string_t) :: node(3)                    !< sun, ring, carrier: the node id used
      character(len=:), allocatable :: new_nodes   !< the &node groups' text
      real(wp) :: jp = 0.0_wp
      logical :: ideal = .false.
      logical :: rigid = .false.                   !< mesh = 'rigid': rigid_gear meshes (constraint rows)
      real(wp) :: ks = 0.0_wp, kr = 0.0_wp         !< 0: spur's default stiffness
      real(wp), allocatable :: bs(:), br(:)        !< backlash per planet (spur)
      real(wp) :: m = 0.0_wp, phi = 20.0_wp        !< module in deck length units, pressure angle (deg)
      character(len=:), allocatable :: pitch_key   !< 'module' or 'diametral_pitch', as given
      real(wp) :: pitch_value = 0.0_wp
      real(wp) :: face = 0.0_wp, ring_phase = 0.0_wp
      real(wp) :: c2 = 0.0_wp                      !< two_pair_factor of the spur meshes (if has_c2)
      logical :: has_c2 = .false.
   end type stage_t

contains

   !> Expand every &planetary group of `deck` into &node and &element groups appended to it.
   subroutine expand_planetary(deck, units, err)
      type(deck_t), intent(inout) :: deck
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      type(stage_t) :: st
      type(deck_t) :: gen
      type(deck_group_t), allocatable :: all(:)
      type(string_t), allocatable :: role(:)       ! per generated group: what it is in its stage
      integer, allocatable :: owner(:)             ! per generated group: its planetary group
      character(len=:), allocatable :: text
      integer :: i, j, ng
      if (deck%count_groups('planetary') == 0) return
      text = ''
      allocate (role(0), owner(0))
      do i = 1, size(deck%groups)
         if (.not. deck%groups(i)%named('planetary')) cycle
         call read_stage(deck%groups(i), units, st, err); if (allocated(err)) return
         call deck%groups(i)%check_unused(err, 'the &planetary group'); if (allocated(err)) return
         call stage_text(st, text, role, owner, i)
      end do
      call parse_deck(text, deck%file, gen, err)
      if (allocated(err)) then   ! cannot happen: the text is ours
         err%message = 'internal error: the expansion of &planetary does not parse: '//err%message
         return
      end if
      ! the generated groups point at their &planetary group's lines and follow the deck's ordinals
      do j = 1, size(gen%groups)
         associate (g => gen%groups(j), p => deck%groups(owner(j)))
            g%file = deck%file
            g%line = p%line
            g%ordinal = g%ordinal + deck%count_groups(g%name)
            do i = 1, g%nentries()
               g%entries(i)%line = key_line(p, source_key(g%key_of(i), role(j)%s))
            end do
         end associate
      end do
      ng = size(deck%groups)
      allocate (all(ng + size(gen%groups)))
      do j = 1, ng
         call move_group(deck%groups(j), all(j))
      end do
      do j = 1, size(gen%groups)
         call move_group(gen%groups(j), all(ng + j))
      end do
      call move_alloc(all, deck%groups)
   end subroutine expand_planetary

   !> model%share_set: per element, its set of planet meshes (D-96): stage s's sun meshes
   !> are set 2s - 1, its ring meshes set 2s (elastic stages only: a rigid stage's
   !> sharing is statically indeterminate, D-94); 0 for every other element. After
   !> `expand_planetary` (whose checks the groups passed) and `read_elements`.
   subroutine mark_share_sets(deck, model)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(inout) :: model
      type(error_t), allocatable :: err
      character(len=:), allocatable :: id, mesh
      integer :: i, j, n, s
      allocate (model%share_set(size(model%elements)), source=0)
      s = 0
      do i = 1, size(deck%groups)
         if (.not. deck%groups(i)%named('planetary')) cycle
         associate (g => deck%groups(i))
            call g%get_string('id', id, err, default='planetary'//str(g%ordinal)); if (allocated(err)) return
            call g%get_string('mesh', mesh, err, default='spur'); if (allocated(err)) return
            call g%get_int('planets', n, err); if (allocated(err)) return
         end associate
         s = s + 1
         if (to_lower(mesh) == 'rigid') cycle
         do j = 1, size(model%elements)
            if (is_mesh(model%elements(j)%e%id, id//'_sun_planet')) model%share_set(j) = 2*s - 1
            if (is_mesh(model%elements(j)%e%id, id//'_ring_planet')) model%share_set(j) = 2*s
         end do
      end do
   contains
      !> `eid` is `<stem><k>`, k in 1..n (the stage's planets).
      logical function is_mesh(eid, stem)
         character(len=*), intent(in) :: eid, stem
         integer :: k
         is_mesh = .false.
         if (len(eid) <= len(stem)) return
         if (eid(1:len(stem)) /= stem) return
         do k = 1, n
            if (eid(len(stem) + 1:) == str(k)) is_mesh = .true.
         end do
      end function is_mesh
   end subroutine mark_share_sets

   !> Read and check one &planetary group.
   subroutine read_stage(g, units, st, err)
      type(deck_group_t), intent(inout) :: g
      type(units_t), intent(in) :: units
      type(stage_t), intent(out) :: st
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: mesh
      integer :: n
      call g%get_string('id', st%id, err, default='planetary'//str(g%ordinal)); if (allocated(err)) return
      call g%get_int('planets', st%n, err); if (allocated(err)) return
      if (st%n < 1 .or. st%n > max_planets) then
         call fatal_error(err, g%where('planets')//': error: planets must be in [1, '//str(max_planets)//'], got '// &
                          str(st%n), err_input)
         return
      end if
      n = st%n
      call read_teeth(g, 'teeth_sun', st%zs, err); if (allocated(err)) return
      call read_teeth(g, 'teeth_planet', st%zp, err); if (allocated(err)) return
      call read_teeth(g, 'teeth_ring', st%zr, err); if (allocated(err)) return
      call check_geometry(g, st, err); if (allocated(err)) return
      call read_members(g, st, err); if (allocated(err)) return
      call g%get_real('planet_inertia', st%jp, err); if (allocated(err)) return
      call g%require_positive('planet_inertia', st%jp, err); if (allocated(err)) return
      call read_pitch(g, units, st, err); if (allocated(err)) return
      call g%get_string('mesh', mesh, err, default='spur'); if (allocated(err)) return
      select case (to_lower(mesh))
      case ('spur'); st%ideal = .false.
      case ('ideal'); st%ideal = .true.
      case ('rigid'); st%ideal = .true.; st%rigid = .true.
      case default
         call fatal_error(err, g%where('mesh')//": error: unknown mesh '"//mesh//"'; valid: spur, ideal, rigid", &
                          err_input)
         return
      end select
      if (st%rigid) then
         continue   ! no stiffness: constraint rows (D-81)
      else if (st%ideal) then
         call g%get_real('sun_mesh_stiffness', st%ks, err); if (allocated(err)) return
         call g%get_real('ring_mesh_stiffness', st%kr, err); if (allocated(err)) return
         call g%require_positive('sun_mesh_stiffness', st%ks, err); if (allocated(err)) return
         call g%require_positive('ring_mesh_stiffness', st%kr, err); if (allocated(err)) return
      else
         call g%get_real('sun_mesh_stiffness', st%ks, err, default=0.0_wp); if (allocated(err)) return
         call g%get_real('ring_mesh_stiffness', st%kr, err, default=0.0_wp); if (allocated(err)) return
         call g%require_nonnegative('sun_mesh_stiffness', st%ks, err); if (allocated(err)) return
         call g%require_nonnegative('ring_mesh_stiffness', st%kr, err); if (allocated(err)) return
         call g%get_real('face_width', st%face, err); if (allocated(err)) return
         call g%require_positive('face_width', st%face, err); if (allocated(err)) return
         call per_planet(g, 'sun_backlash', n, st%bs, err); if (allocated(err)) return
         call per_planet(g, 'ring_backlash', n, st%br, err); if (allocated(err)) return
         call g%get_real('sun_ring_phase', st%ring_phase, err, default=0.0_wp); if (allocated(err)) return
         st%has_c2 = g%has('two_pair_factor')
         call g%get_real('two_pair_factor', st%c2, err, default=0.0_wp); if (allocated(err)) return
         if (.not. (st%ring_phase >= 0.0_wp .and. st%ring_phase < 1.0_wp)) then
            call fatal_error(err, g%where('sun_ring_phase')//': error: sun_ring_phase (a fraction of a tooth) must '// &
                             'be in [0, 1), got '//str(st%ring_phase), err_input)
            return
         end if
      end if
   end subroutine read_stage

   !> A whole tooth count >= 1 (at most 10 000, as a gear pair's).
   subroutine read_teeth(g, key, z, err)
      type(deck_group_t), intent(inout) :: g
      character(len=*), intent(in) :: key
      real(wp), intent(out) :: z
      type(error_t), allocatable, intent(out) :: err
      call g%get_real(key, z, err); if (allocated(err)) return
      if (.not. (z >= 1.0_wp .and. z <= 1.0e4_wp .and. z == aint(z))) then
         call fatal_error(err, g%where(key)//': error: '//key//' must be a whole number of teeth in [1, 10000], got '// &
                          str(z), err_input)
      end if
   end subroutine read_teeth

   !> The stage's geometry: the ring as large as the sun and two planets, the planets'
   !> positions and the assembly condition ((z_s + z_r) psi / 360 deg a whole number).
   subroutine check_geometry(g, st, err)
      type(deck_group_t), intent(inout) :: g
      type(stage_t), intent(inout) :: st
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: x
      integer :: k
      if (st%zr /= st%zs + 2.0_wp*st%zp) then
         call fatal_error(err, g%where('teeth_ring')//': error: teeth_ring must be teeth_sun + 2 teeth_planet = '// &
                          str(st%zs + 2.0_wp*st%zp)//' (standard gears: the ring''s pitch circle holds the sun''s '// &
                          'and two planets''), got '//str(st%zr), err_input)
         return
      end if
      call g%get_real_array('planet_angles', st%psi_deg, err); if (allocated(err)) return
      st%equal = size(st%psi_deg) == 0
      if (st%equal) then
         if (mod(nint(st%zs + st%zr), st%n) /= 0) then
            call fatal_error(err, g%where('planets')//': error: '//str(st%n)//' equally spaced planets cannot be '// &
                             'assembled: (teeth_sun + teeth_ring)/planets = ('//str(st%zs)//' + '//str(st%zr)//')/'// &
                             str(st%n)//' is not a whole number (give planet_angles, or other tooth counts)', err_input)
            return
         end if
         st%psi_deg = [(360.0_wp*k/st%n, k=0, st%n - 1)]
         return
      end if
      if (size(st%psi_deg) /= st%n) then
         call fatal_error(err, g%where('planet_angles')//': error: planet_angles needs one angle per planet ('// &
                          str(st%n)//'), got '//str(size(st%psi_deg)), err_input)
         return
      end if
      do k = 1, st%n
         x = (st%zs + st%zr)*st%psi_deg(k)/360.0_wp
         if (.not. (st%psi_deg(k) >= 0.0_wp .and. st%psi_deg(k) < 360.0_wp) .or. &
             abs(x - anint(x)) > 1.0e-9_wp*max(1.0_wp, abs(x))) then
            call fatal_error(err, g%where('planet_angles')//': error: planet angle '//str(k)//' = '// &
                             str(st%psi_deg(k))//' deg cannot be assembled: it must be in [0, 360) and a whole '// &
                             'multiple of 360/(teeth_sun + teeth_ring) = '//str(360.0_wp/(st%zs + st%zr))//' deg', &
                             err_input)
            return
         end if
         if (k > 1) then
            if (any(st%psi_deg(1:k - 1) == st%psi_deg(k))) then
               call fatal_error(err, g%where('planet_angles')//': error: two planets at '//str(st%psi_deg(k))// &
                                ' deg', err_input)
               return
            end if
         end if
      end do
   end subroutine check_geometry

   !> Sun, ring and carrier: each an existing node (`sun = 'n2'`), a new inertia
   !> (`sun_inertia`) or held (`held = 'sun'`, a new fixed node), exactly one of them.
   subroutine read_members(g, st, err)
      type(deck_group_t), intent(inout) :: g
      type(stage_t), intent(inout) :: st
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: held, m, nid
      real(wp) :: j
      integer :: k, given
      call g%get_string('held', held, err, default=''); if (allocated(err)) return
      held = to_lower(held)
      if (len(held) > 0 .and. all(members /= held)) then
         call fatal_error(err, g%where('held')//": error: unknown member '"//held//"'; valid: sun, ring, carrier", &
                          err_input)
         return
      end if
      st%new_nodes = ''
      do k = 1, 3
         m = trim(members(k))
         given = count([g%has(m), g%has(m//'_inertia'), held == m])
         if (given /= 1) then
            call fatal_error(err, g%where()//': error: the '//m//' needs exactly one of '//m//" = '<node>' (an "// &
                             'existing node), '//m//'_inertia (a new one) or held = '''//m//''' (a fixed one); '// &
                             'this group gives '//str(given), err_input)
            return
         end if
         if (g%has(m)) then
            call g%get_string(m, nid, err); if (allocated(err)) return
            st%node(k)%s = nid
         else if (held == m) then
            st%node(k)%s = st%id//'_'//m
            st%new_nodes = st%new_nodes//"&node id = '"//st%node(k)%s//"', type = 'fixed' /"//new_line('a')
         else
            call g%get_real(m//'_inertia', j, err); if (allocated(err)) return
            call g%require_positive(m//'_inertia', j, err); if (allocated(err)) return
            st%node(k)%s = st%id//'_'//m
            st%new_nodes = st%new_nodes//"&node id = '"//st%node(k)%s//"', type = 'inertia', inertia = "//str(j)// &
                           ' /'//new_line('a')
         end if
      end do
   end subroutine read_members

   !> module (mm) or diametral_pitch (1/in), as a gear pair's geometry form reads them,
   !> and the pressure angle (deg, default 20).
   subroutine read_pitch(g, units, st, err)
      type(deck_group_t), intent(inout) :: g
      type(units_t), intent(in) :: units
      type(stage_t), intent(inout) :: st
      type(error_t), allocatable, intent(out) :: err
      if (g%has('module') .eqv. g%has('diametral_pitch')) then
         call fatal_error(err, g%where('module')//': error: give module (mm) or diametral_pitch (1/in), one of them', &
                          err_input)
         return
      end if
      st%pitch_key = merge('module         ', 'diametral_pitch', g%has('module'))
      st%pitch_key = trim(st%pitch_key)
      call g%get_real(st%pitch_key, st%pitch_value, err); if (allocated(err)) return
      call g%require_positive(st%pitch_key, st%pitch_value, err); if (allocated(err)) return
      if (st%pitch_key == 'module') then
         st%m = st%pitch_value/25.4_wp/units%to_inch
      else
         st%m = 1.0_wp/st%pitch_value/units%to_inch
      end if
      call g%get_real('pressure_angle', st%phi, err, default=20.0_wp); if (allocated(err)) return
      if (.not. (st%phi > 0.0_wp .and. st%phi < 45.0_wp)) then
         call fatal_error(err, g%where('pressure_angle')//': error: pressure_angle must be in (0, 45) degrees, got '// &
                          str(st%phi), err_input)
      end if
   end subroutine read_pitch

   !> A value per planet: one value for every planet, or one each (>= 0).
   subroutine per_planet(g, key, n, v, err)
      type(deck_group_t), intent(inout) :: g
      character(len=*), intent(in) :: key
      integer, intent(in) :: n
      real(wp), allocatable, intent(out) :: v(:)
      type(error_t), allocatable, intent(out) :: err
      call g%get_real_array(key, v, err); if (allocated(err)) return
      if (size(v) == 0) v = [0.0_wp]
      if (size(v) == 1) v = spread(v(1), 1, n)
      if (size(v) /= n) then
         call fatal_error(err, g%where(key)//': error: '//key//' needs one value or one per planet ('//str(n)// &
                          '), got '//str(size(v)), err_input)
      else if (.not. all(v >= 0.0_wp)) then
         call fatal_error(err, g%where(key)//': error: '//key//' must be >= 0 (the total backlash along the line '// &
                          'of action)', err_input)
      end if
   end subroutine per_planet

   !> The mesh phases (fractions of a tooth, in [0, 1)) of each planet's sun mesh (ps)
   !> and ring mesh (pr) relative to planet 1's (Parker and Lin 2004): the sun mesh of a
   !> planet at psi meets the sun's teeth psi later in the sun's angle, the ring mesh
   !> the ring's: ps = -z_s psi/360, pr = -z_r psi/360 (mod 1), psi in degrees.
   pure subroutine planet_phases(zs, zr, psi_deg, ps, pr)
      real(wp), intent(in) :: zs, zr, psi_deg(:)
      real(wp), intent(out) :: ps(:), pr(:)
      ps = modulo(-zs*psi_deg/360.0_wp, 1.0_wp)
      pr = modulo(-zr*psi_deg/360.0_wp, 1.0_wp)
      where (abs(ps - anint(ps)) < 1.0e-12_wp) ps = modulo(anint(ps), 1.0_wp)   ! whole teeth: exactly 0
      where (abs(pr - anint(pr)) < 1.0e-12_wp) pr = modulo(anint(pr), 1.0_wp)
   end subroutine planet_phases

   !> The assembly condition of n equally spaced planets: (z_s + z_r)/n whole.
   pure logical function assembles(zs, zr, n) result(ok)
      real(wp), intent(in) :: zs, zr
      integer, intent(in) :: n
      ok = n >= 1 .and. mod(nint(zs + zr), n) == 0
   end function assembles

   !> The groups of one stage as deck text; for each generated group its role (a
   !> member, 'planet', 'sun_mesh' or 'ring_mesh') and its &planetary group ig (owner).
   subroutine stage_text(st, text, role, owner, ig)
      type(stage_t), intent(in) :: st
      character(len=:), allocatable, intent(inout) :: text
      type(string_t), allocatable, intent(inout) :: role(:)
      integer, allocatable, intent(inout) :: owner(:)
      integer, intent(in) :: ig
      real(wp) :: ps(st%n), pr(st%n), c
      integer :: k
      character(len=:), allocatable :: pn, common, kind
      character(len=*), parameter :: nl = new_line('a')
      kind = merge('rigid_gear', 'ideal_gear', st%rigid)
      text = text//st%new_nodes
      do k = 1, 3
         if (index(st%new_nodes, "'"//st%id//'_'//trim(members(k))//"'") > 0) call note(trim(members(k)))
      end do
      do k = 1, st%n
         text = text//"&node id = '"//st%id//'_planet'//str(k)//"', type = 'inertia', inertia = "//str(st%jp)//' /'//nl
         call note('planet')
      end do
      call planet_phases(st%zs, st%zr, st%psi_deg, ps, pr)
      c = cos(st%phi*pi/180.0_wp)*0.5_wp*st%m   ! base radius per tooth
      do k = 1, st%n
         pn = st%id//'_planet'//str(k)
         common = ", carrier = '"//st%node(3)%s//"'"
         if (st%ideal) then
            text = text//"&element id = '"//st%id//'_sun_planet'//str(k)//"', type = '"//kind//"', left = '"// &
                   st%node(1)%s//"', right = '"//pn//"'"//common//", driven_sense = 'driver'"//stiff(st%ks)// &
                   ', rb_driver = '//str(c*st%zs)//', rb_driven = '//str(c*st%zp)//' /'//nl
            call note('sun_mesh')
            text = text//"&element id = '"//st%id//'_ring_planet'//str(k)//"', type = '"//kind//"', left = '"// &
                   pn//"', right = '"//st%node(2)%s//"'"//common//", mesh = 'internal'"//stiff(st%kr)// &
                   ', rb_driver = '//str(c*st%zp)//', rb_driven = '//str(c*st%zr)//' /'//nl
            call note('ring_mesh')
         else
            common = common//', '//st%pitch_key//' = '//str(st%pitch_value)//', pressure_angle = '//str(st%phi)// &
                     ', face_width = '//str(st%face)
            if (st%has_c2) common = common//', two_pair_factor = '//str(st%c2)   ! (checked by the gear)
            text = text//"&element id = '"//st%id//'_sun_planet'//str(k)//"', type = 'spur_gear', left = '"// &
                   st%node(1)%s//"', right = '"//pn//"'"//common//", driven_sense = 'driver', teeth_driver = "// &
                   str(st%zs)//', teeth_driven = '//str(st%zp)//', backlash = '//str(st%bs(k))// &
                   ', mesh_phase = '//str(ps(k))//stiffness_text(st%ks)
            call note('sun_mesh')
            text = text//"&element id = '"//st%id//'_ring_planet'//str(k)//"', type = 'spur_gear', left = '"// &
                   pn//"', right = '"//st%node(2)%s//"'"//common//", mesh = 'internal', teeth_driver = "// &
                   str(st%zp)//', teeth_driven = '//str(st%zr)//', backlash = '//str(st%br(k))// &
                   ', mesh_phase = '//str(modulo(pr(k) + st%ring_phase, 1.0_wp))//stiffness_text(st%kr)
            call note('ring_mesh')
         end if
      end do
   contains

      !> The role of the group just written (its owner: the &planetary group ig).
      subroutine note(r)
         character(len=*), intent(in) :: r
         type(string_t), allocatable :: tmp(:)
         allocate (tmp(size(role) + 1))
         tmp(1:size(role)) = role
         tmp(size(tmp))%s = r
         call move_alloc(tmp, role)
         owner = [owner, ig]
      end subroutine note

      !> An ideal mesh's stiffness (none for a rigid one).
      function stiff(k) result(t)
         real(wp), intent(in) :: k
         character(len=:), allocatable :: t
         t = ''
         if (.not. st%rigid) t = ', stiffness = '//str(k)
      end function stiff

      !> A spur mesh's stiffness if given (0: the gear's default), and the group's end.
      function stiffness_text(k) result(t)
         real(wp), intent(in) :: k
         character(len=:), allocatable :: t
         t = ' /'//nl
         if (k > 0.0_wp) t = ', stiffness = '//str(k)//t
      end function stiffness_text
   end subroutine stage_text

   !> The &planetary key behind the key `key` of a generated group of role `r`: the
   !> message about a generated group names the line of the key a user wrote.
   pure function source_key(key, r) result(sk)
      character(len=*), intent(in) :: key, r
      character(len=:), allocatable :: sk
      character(len=:), allocatable :: drv, drn
      sk = key
      if (r == 'sun_mesh' .or. r == 'ring_mesh') then
         drv = merge('teeth_sun   ', 'teeth_planet', r == 'sun_mesh'); drv = trim(drv)
         drn = merge('teeth_planet', 'teeth_ring  ', r == 'sun_mesh'); drn = trim(drn)
         select case (key)
         case ('stiffness'); sk = r//'_stiffness'
         case ('backlash'); sk = r(1:index(r, '_'))//'backlash'
         case ('teeth_driver', 'rb_driver'); sk = drv
         case ('teeth_driven', 'rb_driven'); sk = drn
         case ('mesh_phase'); sk = 'planet_angles'
         case ('id', 'left', 'right'); sk = 'planets'
         end select
      else if (key == 'inertia') then
         sk = r//'_inertia'
      else if (key == 'type' .and. r /= 'planet') then
         sk = 'held'
      end if
   end function source_key

   !> The line of `key` in group g (the group's line if the key is not given).
   integer function key_line(g, key) result(line)
      type(deck_group_t), intent(in) :: g
      character(len=*), intent(in) :: key
      integer :: j
      line = g%line
      do j = 1, g%nentries()
         if (g%key_of(j) == key) line = g%entries(j)%line
      end do
   end function key_line

   !> Move a group (its allocatable parts) from a to b.
   subroutine move_group(a, b)
      type(deck_group_t), intent(inout) :: a
      type(deck_group_t), intent(out) :: b
      b = a   ! (deck_group_t has a private component: a whole copy, then a's parts released)
      deallocate (a%entries)
   end subroutine move_group
end module trainsim_planetary_deck
