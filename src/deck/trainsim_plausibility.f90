!> Plausibility of a built model (docs/deck.md, "Plausibility checks"): the rules of the calculators
!> `trainsim gear` and `trainsim key` (trainsim_gear_calc) applied to the deck: no unit slip simulated.
!>
!> Each rule compares a value with the unit system or with the geometry the deck
!> itself implies (a backlash with the base pitch, an inertia with the train's largest
!> radius), never with a fixed number of the deck's units. A value no machine can have
!> (a gear whose base radius is below 1 mm, a backlash wider than half a tooth space,
!> a motor whose torque and back-EMF constants disagree by more than 1.5x) is an
!> error; a value that is only implausible is a warning naming the group, key, value
!> and the likely slip. The topology: a node joined to nothing, or a train in pieces.
!>
!> Warnings are returned as text ("FILE:LINE: &group #n, key 'k': warning: ...");
!> `--strict` (app/main.f90) makes them errors.
module trainsim_plausibility
   use trainsim_kinds, only: wp, pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: string_t, str
   use trainsim_deck, only: deck_t
   use trainsim_model, only: model_t
   use trainsim_param_list, only: param_list_t
   use trainsim_id_table, only: id_table_t
   use trainsim_units, only: units_t
   implicit none
   private

   public :: check_plausibility

   !> Steel as App. E.1 takes it (trainsim_gear_calc): pi rho / 2 = 1.148e-3 lbf s^2/in^4.
   real(wp), parameter :: half_pi_rho_steel_ips = 1.148e-3_wp
   !> A node may be this many times a steel disk of the train's largest radius R and
   !> thickness R (a flywheel of 4 R); heavier is most likely a unit or digit slip.
   real(wp), parameter :: max_inertia_ratio = 1.0e3_wp
   !> A node carrying a gear may be this fraction of the gear's pitch disk (a thin rim).
   real(wp), parameter :: min_gear_disk_fraction = 1.0e-2_wp
   !> k_t / k_e (in consistent units) is 1 for an ideal machine; datasheets round.
   real(wp), parameter :: motor_ratio_warn = 1.1_wp, motor_ratio_error = 1.5_wp

   !> What the rules share while they run: the deck group of each node and element, the
   !> connected piece of each node and the largest radius of each piece, per node the
   !> steel base-circle disk of its widest gear (gear_of: that gear, 0: none), the
   !> length unit in metres, and the warnings so far.
   type :: ctx_t
      integer, allocatable :: node_group(:), element_group(:), piece(:)
      real(wp), allocatable :: radius(:), gear_disk(:)
      integer, allocatable :: gear_of(:)
      real(wp) :: to_m = 0.0_wp
      type(string_t), allocatable :: warnings(:)
      !> Each element's and node's params(), asked once (D-90)
      type(param_list_t), allocatable :: ep(:), np(:)
   end type ctx_t

contains

   !> Check `model` (built from `deck`): the first impossible value is `err`; the
   !> implausible ones are appended to `warnings`.
   subroutine check_plausibility(deck, model, warnings, err, ep, np)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(in) :: model
      type(string_t), allocatable, intent(inout) :: warnings(:)
      type(error_t), allocatable, intent(out) :: err
      !> the first elements' and nodes' params() as the builder asked them (moved in; the rest, an element
      !> added after them, asked here: D-114); ep on return: every element's (moved out)
      type(param_list_t), allocatable, intent(inout), optional :: ep(:), np(:)
      type(ctx_t) :: c

      if (.not. allocated(warnings)) allocate (warnings(0))
      call move_alloc(warnings, c%warnings)
      if (present(ep)) then
         if (allocated(ep)) call move_alloc(ep, c%ep)
      end if
      if (present(np)) then
         if (allocated(np)) call move_alloc(np, c%np)
      end if
      call run_checks(deck, model, c, err)
      call move_alloc(c%warnings, warnings)
      if (present(ep)) call move_alloc(c%ep, ep)   ! (every element's, for the model to keep: D-175)
   end subroutine check_plausibility

   !> c%ep and c%np for every element and node: those the builder gave kept (moved,
   !> not copied), params() asked for the others.
   subroutine complete_params(model, c)
      type(model_t), intent(in) :: model
      type(ctx_t), intent(inout) :: c
      integer :: i, n0
      call keep_first(c%ep, size(model%elements), n0)
      do i = n0 + 1, size(model%elements)
         c%ep(i) = model%elements(i)%e%params()
      end do
      call keep_first(c%np, size(model%nodes), n0)
      do i = n0 + 1, size(model%nodes)
         c%np(i) = model%nodes(i)%n%params()
      end do
   contains
      !> `lists` of size n, its first n0 entries those it held (moved).
      subroutine keep_first(lists, n, n0)
         type(param_list_t), allocatable, intent(inout) :: lists(:)
         integer, intent(in) :: n
         integer, intent(out) :: n0
         type(param_list_t), allocatable :: p(:)
         integer :: j
         n0 = 0
         if (allocated(lists)) then
            n0 = min(size(lists), n)
            if (size(lists) == n) return
         end if
         allocate (p(n))
         do j = 1, n0
            if (allocated(lists(j)%names)) call move_alloc(lists(j)%names, p(j)%names)
            if (allocated(lists(j)%values)) call move_alloc(lists(j)%values, p(j)%values)
            if (allocated(lists(j)%words)) call move_alloc(lists(j)%words, p(j)%words)
         end do
         call move_alloc(p, lists)
      end subroutine keep_first
   end subroutine complete_params

   !> The rules in order: each element, each motor, each node's inertia, the topology.
   subroutine run_checks(deck, model, c, err)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(in) :: model
      type(ctx_t), intent(inout) :: c
      type(error_t), allocatable, intent(out) :: err
      integer :: i

      c%to_m = model%units%to_inch*0.0254_wp
      call group_indices(deck, 'node', size(model%nodes), c%node_group)
      call group_indices(deck, 'element', size(model%elements), c%element_group)
      call complete_params(model, c)
      do i = 1, size(model%elements)
         call check_element(deck, model, c, i, c%ep(i), err); if (allocated(err)) return
      end do
      do i = 1, size(model%nodes)
         call check_motor(deck, model, c, i, c%np(i), err); if (allocated(err)) return
      end do
      call pieces(model, c%piece)
      allocate (c%radius(maxval([c%piece, 0])))
      c%radius = 0.0_wp
      do i = 1, size(model%elements)
         associate (e => model%elements(i)%e)
            c%radius(c%piece(e%left)) = max(c%radius(c%piece(e%left)), element_radius(c%ep(i)))
         end associate
      end do
      ! the heaviest steel pitch disk of a gear with a face width on each node
      allocate (c%gear_disk(size(model%nodes)), c%gear_of(size(model%nodes)))
      c%gear_disk = 0.0_wp
      c%gear_of = 0
      do i = 1, size(model%elements)
         call note_gear_disk(model, c, i, c%ep(i))
      end do
      do i = 1, size(model%nodes)
         call check_inertia(deck, model, c, i, c%np(i))
      end do
      call check_topology(deck, model, c, err)
   end subroutine run_checks


   !> Value of parameter `name` in p (found = .false. if it has none).
   real(wp) function pv(p, name, found) result(v)
      type(param_list_t), intent(in) :: p
      character(len=*), intent(in) :: name
      logical, intent(out) :: found
      integer :: j, n
      v = 0.0_wp
      found = .false.
      if (.not. allocated(p%names)) return
      n = len_trim(name)
      do j = 1, size(p%names)
         ! a shorter name is not it: no string comparison for most (80 000 calls at 20 000 nodes)
         if (len(p%names(j)%s) < n) cycle
         if (p%names(j)%s == name) then
            v = p%values(j)
            found = .true.
            return
         end if
      end do
   end function pv

   subroutine warn(c, deck, ig, key, text)
      type(ctx_t), intent(inout) :: c
      type(deck_t), intent(in) :: deck
      integer, intent(in) :: ig
      character(len=*), intent(in) :: key, text
      c%warnings = [c%warnings, string_t(deck%groups(ig)%where(key)//': warning: '//text)]
   end subroutine warn

   subroutine fail(deck, ig, key, text, e)
      type(deck_t), intent(in) :: deck
      integer, intent(in) :: ig
      character(len=*), intent(in) :: key, text
      type(error_t), allocatable, intent(out) :: e
      call fatal_error(e, deck%groups(ig)%where(key)//': error: '//text, err_input)
   end subroutine fail

   !> "0.03 in (0.762 mm)"
   function len_text(u, x) result(s)
      type(units_t), intent(in) :: u
      real(wp), intent(in) :: x
      character(len=:), allocatable :: s
      s = str(x, 4)//' '//u%length//' ('//str(x*(u%to_inch*0.0254_wp)*1000.0_wp, 4)//' mm)'
   end function len_text

   !> The likely slip behind a length that is too small or too large (`big`).
   function other_units_hint(u, x, big) result(s)
      type(units_t), intent(in) :: u
      real(wp), intent(in) :: x
      logical, intent(in), optional :: big
      character(len=:), allocatable :: s
      logical :: large
      large = .false.
      if (present(big)) large = big
      if (large .and. u%name == 'si') then
         s = '; given in mm? then it is '//str(x/1000.0_wp, 4)//' m; in inches? then '//str(x*0.0254_wp, 4)//' m'
      else if (large) then
         s = '; given in mm? then it is '//str(x/25.4_wp, 4)//' in'
      else if (u%name == 'si') then
         s = '; if it is in inches, that is '//str(x*25.4_wp, 4)//" mm: is the deck in in-lbf-s (units = 'si' "// &
             'by mistake)?'
      else
         s = '; in SI it would be '//str(x*1000.0_wp, 4)//" mm: is the deck in SI (units = 'si' missing)?"
      end if
   end function other_units_hint

   subroutine check_element(deck, model, c, ie, p, e)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(in) :: model
      type(ctx_t), intent(inout) :: c
      integer, intent(in) :: ie
      type(param_list_t), intent(in) :: p   !< element ie's params() (c%ep(ie), never changed here)
      type(error_t), allocatable, intent(out) :: e
      integer :: ig
      logical :: geom, f1, f2, f3, f4
      real(wp) :: rb1, rb2, teeth, b, pb, m_mm, face, rp, d, lk, mlen
      character(len=:), allocatable :: kr, kb, km
      ig = c%element_group(ie)
      ! a type name shorter than 'spur_gear' is none of the cases: no string selection
      ! (a shaft chain's 20 000 elements, 6 M instructions, startup8b)
      if (len(model%elements(ie)%e%type_name) < len('spur_gear')) return
      select case (model%elements(ie)%e%type_name)
      case ('spur_gear', 'helical_gear', 'ideal_gear')
         rb1 = pv(p, 'rb_driver', f1)
         rb2 = pv(p, 'rb_driven', f2)
         mlen = pv(p, 'module_length', geom)
         kr = trim(merge('module   ', 'rb_driver', geom))
         if (geom .and. deck%groups(ig)%has('diametral_pitch')) kr = 'diametral_pitch'
         teeth = pv(p, 'teeth', f3)
         if (geom) then   ! module (mm) as gear_calc check_pitch
            m_mm = mlen*model%units%to_inch*25.4_wp
            km = 'module'
            if (deck%groups(ig)%has('diametral_pitch')) km = 'diametral_pitch'
            if (m_mm < 0.05_wp) then
               call fail(deck, ig, km, 'a module of '//str(m_mm, 4)//' mm is finer than any gear: the module is in mm '// &
                         'and the diametral pitch in teeth per inch, whatever the unit system (a module in '// &
                         'metres? then '//str(m_mm*1000.0_wp, 4)//')', e)
               return
            else if (m_mm > 100.0_wp) then
               call fail(deck, ig, km, 'a module of '//str(m_mm, 4)//' mm is coarser than any gear: the module is in '// &
                         'mm (micrometres given? a pitch diameter?)', e)
               return
            end if
         end if
         ! geometry against the unit system (gear_calc check_size): base radii of 1 mm to 20 m
         if (min(rb1, rb2)*c%to_m < 1.0e-3_wp) then
            call fail(deck, ig, kr, 'a base c%radius of '//len_text(model%units, min(rb1, rb2))//' is smaller than any power gear''s '// &
                      '(1 mm)'//other_units_hint(model%units, min(rb1, rb2)), e)
            return
         end if
         if (max(rb1, rb2)*c%to_m > 20.0_wp) then
            if (.not. geom .and. rb2 > rb1) kr = 'rb_driven'
            call fail(deck, ig, kr, 'a base c%radius of '// &
                      str(max(rb1, rb2), 4)//' '//model%units%length//' ('//str(max(rb1, rb2)*c%to_m, 3)// &
                      ' m) is larger than any gear (20 m)'//other_units_hint(model%units, max(rb1, rb2), .true.), e)
            return
         end if
         if (model%elements(ie)%e%type_name == 'ideal_gear') return
         ! backlash against the base pitch: more than half of it and the teeth do not mesh
         b = pv(p, 'half_backlash', f4)
         pb = pv(p, 'base_pitch', f1)
         if (.not. f1) pb = pv(p, 'transverse_base_pitch', f1)
         if (.not. f1 .and. f3) pb = 2.0_wp*pi*rb1/teeth
         kb = trim(merge('backlash     ', 'half_backlash', geom))
         if (f4 .and. pb > 0.0_wp) then
            if (2.0_wp*b > 0.5_wp*pb) then
               call fail(deck, ig, kb, 'the total backlash '//len_text(model%units, 2.0_wp*b)//' is more than half the base pitch '// &
                         len_text(model%units, pb)//': the teeth would not mesh. Is it in the unit system''s length ('// &
                         model%units%length//')?', e)
               return
            else if (2.0_wp*b > 0.1_wp*pb) then
               call warn(c, deck, ig, kb, 'the total backlash '//len_text(model%units, 2.0_wp*b)//' is '//str(2.0_wp*b/pb, 3)// &
                         ' of the base pitch '//len_text(model%units, pb)//'; cut gears have 0.01 to 0.05: check its unit')
            end if
         end if
         ! face width (gear_calc check_size): against the unit system and the pitch c%radius
         face = pv(p, 'face_width', f1)
         if (f1 .and. face > 0.0_wp) then
            rp = rb1
            if (geom) rp = 0.5_wp*teeth*mlen
            if (face*c%to_m > 5.0_wp .or. face > 20.0_wp*rp .or. face < 0.002_wp*rp) then
               call fail(deck, ig, 'face_width', 'face width '//len_text(model%units, face)//' with a pitch c%radius of '// &
                         len_text(model%units, rp)//': is the face width in the unit system''s length ('// &
                         model%units%length//')'//other_units_hint(model%units, face, face > 20.0_wp*rp)//'', e)
               return
            end if
            if (face > 6.0_wp*rp) call warn(c, deck, ig, 'face_width', 'face width '//len_text(model%units, face)// &
                                                ' is more than 3 x the driver''s pitch diameter: check its unit')
            if (pb > 0.0_wp .and. face < pb/pi) call warn(c, deck, ig, 'face_width', 'face width '//len_text(model%units, face)// &
               ' is narrower than one module ('//len_text(model%units, pb/pi)//'): gears are 3 to 20 modules wide'// &
               other_units_hint(model%units, face))
         end if
      case ('keyed_joint')   ! gear_calc key_calc
         d = pv(p, 'diameter', f1)
         if (.not. f1 .or. d <= 0.0_wp) return
         if (d*c%to_m < 1.0e-3_wp .or. d*c%to_m > 2.0_wp) then
            call fail(deck, ig, 'diameter', 'shaft diameter '//len_text(model%units, d)//' is outside 1 mm to 2 m, the shafts '// &
                      'that carry keys'//other_units_hint(model%units, d, d*c%to_m > 2.0_wp), e)
            return
         end if
         lk = pv(p, 'key_length', f2)
         if (f2) then
            if (lk > 10.0_wp*d .or. lk < 0.05_wp*d) &
               call warn(c, deck, ig, 'key_length', 'key length '//len_text(model%units, lk)//' on a shaft of '//len_text(model%units, d)// &
                         ' (keys are 0.05 to 10 diameters long): is it in '//model%units%length//'?')
            if (d*model%units%to_inch < 0.75_wp .or. d*model%units%to_inch > 2.0_wp) &
               call warn(c, deck, ig, 'diameter', 'the stiffness fits of eqs. 4.35-4.37 were made for shafts of 0.750 '// &
                         'to 2.000 in (FEM, Ch. IV); '//str(d*model%units%to_inch, 4)//' in is outside')
         end if
         b = pv(p, 'half_clearance', f3)
         if (f3 .and. 2.0_wp*b > 0.05_wp*d) &
            call warn(c, deck, ig, 'half_clearance', 'the total clearance '//len_text(model%units, 2.0_wp*b)//' is more than 5 % of '// &
                      'the shaft diameter '//len_text(model%units, d)//' (a key fit is a few thousandths of an inch): '// &
                      'is it in '//model%units%length//'?')
      end select
   end subroutine check_element

   !> k_t = k_e in consistent units (an ideal machine's power balance): in SI
   !> N*m/A = V*s/rad; in in-lbf-s k_t [lbf*in/A] = 8.8507 k_e [V*s/rad].
   subroutine check_motor(deck, model, c, in, p, e)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(in) :: model
      type(ctx_t), intent(inout) :: c
      integer, intent(in) :: in
      type(error_t), allocatable, intent(out) :: e
      type(param_list_t), intent(in) :: p   !< node in's params()
      logical :: f1, f2
      real(wp) :: kt, ke, r, other
      character(len=:), allocatable :: slip, rule
      kt = pv(p, 'torque_constant', f1)
      ke = pv(p, 'back_emf_constant', f2)
      if (.not. (f1 .and. f2)) return
      if (.not. (kt > 0.0_wp .and. ke > 0.0_wp)) return
      r = kt/(ke*model%units%power_per_watt)
      if (r <= motor_ratio_warn .and. r >= 1.0_wp/motor_ratio_warn) return
      ! the ratio the other unit system's constants would give read in this one
      ! SI constants (k_t = k_e) in an in-lbf-s deck give r = 1/8.8507 (N*m per lbf*in);
      ! in-lbf-s constants in an SI deck give r = 8.8507
      other = 4.4482216152605_wp*0.0254_wp
      if (model%units%name == 'si') other = 1.0_wp/other
      slip = ''
      if (abs(r/other - 1.0_wp) < 0.1_wp) then
         if (model%units%name == 'si') then
            slip = ': the torque constant looks like lbf*in/A (in-lbf-s); is the deck in in-lbf-s (units = ''si'' '// &
                   'by mistake)?'
         else
            slip = ": k_t = k_e holds in SI (N*m/A = V*s/rad); is the deck in SI (units = 'si' missing)?"
         end if
      else if (r > 20.0_wp .or. r < 0.05_wp) then
         slip = ': a unit or digit slip in one of them?'
      end if
      rule = 'in-lbf-s: k_t [lbf*in/A] = 8.8507 k_e [V*s/rad]'
      if (model%units%name == 'si') rule = 'SI: k_t [N*m/A] = k_e [V*s/rad]'
      associate (why => 'torque_constant = '//str(kt, 4)//' '//model%units%torque//'/A and back_emf_constant = '// &
                 str(ke, 4)//' V*s/rad give k_t/k_e = '//str(r, 4)//' in consistent units; an ideal DC machine '// &
                 'has 1 ('//rule//')')
         if (r > motor_ratio_error .or. r < 1.0_wp/motor_ratio_error) then
            call fatal_error(e, deck%groups(c%node_group(in))%where('back_emf_constant')//': error: '//why// &
                             ', else the motor makes or destroys energy'//slip, err_input)
         else
            call warn(c, deck, c%node_group(in), 'back_emf_constant', why//slip)
         end if
      end associate
   end subroutine check_motor

   !> Inertia against the geometry: at most max_inertia_ratio steel disks of the
   !> c%piece's largest c%radius R (thickness R); a gear's node at least a fraction of
   !> its pitch disk.
   subroutine check_inertia(deck, model, c, in, p)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(in) :: model
      type(ctx_t), intent(inout) :: c
      integer, intent(in) :: in
      type(param_list_t), intent(in) :: p   !< node in's params()
      logical :: found
      real(wp) :: j, r, jref, rho_half_pi
      if (model%nodes(in)%n%is_fixed()) return
      j = pv(p, 'inertia', found)
      if (.not. found .or. .not. j > 0.0_wp) return
      rho_half_pi = half_pi_rho_steel_ips*model%units%to_inch**4/model%units%to_lbf
      r = c%radius(c%piece(in))
      if (r > 0.0_wp) then
         jref = rho_half_pi*r**5
         if (j > max_inertia_ratio*jref) then
            call warn(c, deck, c%node_group(in), 'inertia', 'inertia '//str(j, 4)//' '//model%units%inertia//' is '// &
                      str(j/jref, 3)//' x a steel disk of the train''s largest c%radius, '//len_text(model%units, r)//', as thick '// &
                      'as wide ('//str(jref, 3)//' '//model%units%inertia//'): a flywheel of more than 4 x that '// &
                      'c%radius. Is it in '//model%units%inertia//' (a digit or unit slip)?')
            return
         end if
      end if
      if (c%gear_of(in) > 0) then
         if (j < min_gear_disk_fraction*c%gear_disk(in)) then
            call warn(c, deck, c%node_group(in), 'inertia', 'inertia '//str(j, 4)//' '//model%units%inertia//' is '// &
                      str(j/c%gear_disk(in), 3)//' x the steel base-circle disk of gear '''// &
                      model%elements(c%gear_of(in))%e%id//''' on it ('//str(c%gear_disk(in), 3)//' '// &
                      model%units%inertia//'): lighter than the gear itself. Is it in '//model%units%inertia//'?')
         end if
      end if
   end subroutine check_inertia

   !> Record element ie's steel base-circle disks (pi rho r_b^4 F / 2) on its nodes.
   subroutine note_gear_disk(model, c, ie, p)
      type(model_t), intent(in) :: model
      type(ctx_t), intent(inout) :: c
      integer, intent(in) :: ie
      type(param_list_t), intent(in) :: p   !< element ie's params()
      logical :: found, f1, f2
      real(wp) :: face, r1, r2, w
      associate (e => model%elements(ie)%e)
         face = pv(p, 'face_width', found)
         if (.not. found) return
         r1 = pv(p, 'rb_driver', f1)
         r2 = pv(p, 'rb_driven', f2)
         w = half_pi_rho_steel_ips*model%units%to_inch**4/model%units%to_lbf*face
         if (w*r1**4 > c%gear_disk(e%left)) then
            c%gear_disk(e%left) = w*r1**4
            c%gear_of(e%left) = ie
         end if
         if (w*r2**4 > c%gear_disk(e%right)) then
            c%gear_disk(e%right) = w*r2**4
            c%gear_of(e%right) = ie
         end if
      end associate
   end subroutine note_gear_disk

   !> A node joined to nothing, or a train in several pieces. A c%piece that nothing
   !> drives (no load, prescribed speed or voltage, every initial speed and angle 0)
   !> stays at rest: an error. Pieces that are each driven are two trains run side by
   !> side, possible on purpose: a warning.
   subroutine check_topology(deck, model, c, e)
      type(deck_t), intent(inout) :: deck
      type(model_t), intent(in) :: model
      type(ctx_t), intent(inout) :: c
      type(error_t), allocatable, intent(out) :: e
      logical, allocatable :: driven(:)
      type(id_table_t) :: node_ids
      integer :: np, n_el(size(model%nodes)), jp, ig, k
      character(len=:), allocatable :: nid
      np = maxval([c%piece, 0])
      if (np <= 1) return
      allocate (driven(np))
      driven = .false.
      n_el = 0
      do k = 1, size(model%elements)
         n_el(model%elements(k)%e%left) = n_el(model%elements(k)%e%left) + 1
         n_el(model%elements(k)%e%right) = n_el(model%elements(k)%e%right) + 1
      end do
      do k = 1, size(model%nodes)
         if (model%speed_of(k) /= 0) driven(c%piece(k)) = .true.
         if (model%nodes(k)%n%omega0 /= 0.0_wp .or. model%nodes(k)%n%theta0 /= 0.0_wp) driven(c%piece(k)) = .true.
      end do
      do k = 1, size(model%loads)
         driven(c%piece(model%loads(k)%node)) = .true.
      end do
      do k = 1, size(model%nodes)
         call node_ids%insert(model%nodes(k)%n%id, k, jp)
      end do
      do ig = 1, size(deck%groups)   ! voltages (and any other &load) name their node
         if (.not. deck%groups(ig)%named('load')) cycle
         call deck%groups(ig)%get_string('node', nid, e)
         if (allocated(e)) return
         k = node_ids%get(nid)
         if (k > 0) driven(c%piece(k)) = .true.
      end do
      do jp = 1, np
         do k = 1, size(model%nodes)
            if (c%piece(k) == jp) exit
         end do
         if (.not. driven(jp)) then
            if (n_el(k) == 0) then
               call fatal_error(e, deck%groups(c%node_group(k))%where()//": error: node '"//model%nodes(k)%n%id// &
                                "' is joined to no element and nothing drives it (no load, prescribed speed or "// &
                                'initial motion): a missing element, or a node left over?', err_input)
            else
               call fatal_error(e, deck%groups(c%node_group(k))%where()//": error: the part of the train with node '"// &
                                model%nodes(k)%n%id//"' ("//piece_ids(model, c%piece, jp)//') is joined to the rest by no '// &
                                'element and nothing drives it: it stays at rest. A missing element (check the '// &
                                'left/right of the elements near it)?', err_input)
            end if
            return
         end if
      end do
      do jp = 2, np
         do k = 1, size(model%nodes)
            if (c%piece(k) == jp) exit
         end do
         call warn(c, deck, c%node_group(k), 'id', 'the train is in '//str(np)//' unconnected parts; node '''// &
                   model%nodes(k)%n%id//''' is in the part ('//piece_ids(model, c%piece, jp)//') that no element joins to node '''// &
                   model%nodes(1)%n%id//''' (two trains run side by side, or a missing element?)')
      end do
   end subroutine check_topology

   !> "'a', 'b', 'c'" (the first five nodes of c%piece jp).
   function piece_ids(model, piece, jp) result(s)
      type(model_t), intent(in) :: model
      integer, intent(in) :: piece(:)
      integer, intent(in) :: jp
      character(len=:), allocatable :: s
      integer :: m, n
      s = ''
      n = 0
      do m = 1, size(model%nodes)
         if (piece(m) /= jp) cycle
         n = n + 1
         if (n > 5) then
            s = s//', ...'
            exit
         end if
         if (n > 1) s = s//', '
         s = s//"'"//model%nodes(m)%n%id//"'"
      end do
   end function piece_ids

   !> Index in deck%groups of each of the n groups named `name`, in order.
   subroutine group_indices(deck, name, n, idx)
      type(deck_t), intent(in) :: deck
      character(len=*), intent(in) :: name
      integer, intent(in) :: n
      integer, allocatable, intent(out) :: idx(:)
      integer :: i, k
      allocate (idx(n))
      idx = 1
      k = 0
      do i = 1, size(deck%groups)
         if (.not. deck%groups(i)%named(name)) cycle
         k = k + 1
         if (k <= n) idx(k) = i
      end do
   end subroutine group_indices

   !> The connected pieces of the train: piece(node) in 1..n_pieces, numbered in node order.
   subroutine pieces(model, piece)
      type(model_t), intent(in) :: model
      integer, allocatable, intent(out) :: piece(:)
      integer, allocatable :: parent(:)
      integer :: i, a, b, np, k
      allocate (parent(size(model%nodes)), piece(size(model%nodes)))
      parent = [(i, i=1, size(model%nodes))]
      do i = 1, size(model%elements)
         do k = 2, model%elements(i)%e%n_ports()        ! every port joins port 1's piece (D-73)
            a = root(model%elements(i)%e%left)
            b = root(model%elements(i)%e%port(k))
            if (a /= b) parent(max(a, b)) = min(a, b)
         end do
      end do
      np = 0
      piece = 0
      do i = 1, size(model%nodes)
         a = root(i)
         if (piece(a) == 0) then
            np = np + 1
            piece(a) = np
         end if
         piece(i) = piece(a)
      end do
   contains
      integer function root(n) result(r)
         integer, intent(in) :: n
         r = n
         do while (parent(r) /= r)
            r = parent(r)
         end do
      end function root
   end subroutine pieces

   !> The largest radius an element implies: gear pitch (or base) radii, half a keyed
   !> shaft's diameter, a load or coupling radius (0 if none).
   real(wp) function element_radius(p) result(r)
      type(param_list_t), intent(in) :: p
      integer :: j
      r = 0.0_wp
      if (.not. allocated(p%names)) return
      do j = 1, size(p%names)
         if (len(p%names(j)%s) < 6) cycle   ! (none of the names below: 6 to 11 letters,
         if (scan(p%names(j)%s(1:1), 'rld') == 0) cycle   ! starting r, l or d)
         select case (p%names(j)%s)
         case ('rb_driver', 'rb_driven', 'load_radius', 'radius')
            r = max(r, abs(p%values(j)))
         case ('diameter')
            r = max(r, 0.5_wp*abs(p%values(j)))
         end select
      end do
   end function element_radius
end module trainsim_plausibility
