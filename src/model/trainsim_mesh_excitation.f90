!> What excites a gear mesh (issue 26): the mesh stiffness along the path of
!> contact and the static transmission error (TE), as pure functions of the
!> roll position u (in teeth: u = N (theta_driver + alpha)/(2 pi) + mesh_phase)
!> and of the teeth in contact (the zone's count m of teeth entered).
!>
!> Stiffness, relative to the deck's `stiffness` k (stiffness_model):
!>   zones    c = 1 or two_pair_factor by the zone (TRAIN, thesis 3.1.3, App. F)
!>   fourier  c(u) = 1 + sum_k a_k cos(2 pi k u + p_k)
!>   table    c(u) from (roll, factor) pairs over one tooth period, periodic
!>   iso6336  a pair's stiffness along its path x in [0, m_p] (base pitches):
!>            k_s(x) = c' b (1 - beta (2x/m_p - 1)^2), c' of ISO 6336-1 method B,
!>            beta such that the mean mesh stiffness is c_gamma_alpha b (D-100)
!> A pair's stiffness is its share (zones, fourier, table: c/pairs; iso6336:
!> k_s(x)) times fault_stiffness_factor on the faulted tooth.
!>
!> TE (length, along the line of action; positive: the driven gear lags):
!>   e(u) = sum_k e_k cos(2 pi k u + q_k)                 (te_harmonics, te_phases)
!>        + A1 cos(2 pi u/N1 + f1) + A2 cos(2 pi u/N2 + f2) (run-out, once a turn)
!>        + sum_j k_j d_j / sum_j k_j                     (the pairs in contact)
!> with a pair's deviation d_j = tip relief + pitch deviations of its two teeth
!> + their profile slope deviations. The stiffness-weighted mean is the loaded
!> TE of pairs that all carry load (F = sum k_j (delta - d_j)); the unloaded
!> static TE takes min_j d_j instead (the first pair to touch).
module trainsim_mesh_excitation
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, to_lower
   use trainsim_deck, only: deck_group_t
   implicit none
   private

   public :: mesh_excitation_t, sm_zones, sm_fourier, sm_table, sm_iso, iso_single_pair_stiffness, model_name

   integer, parameter :: sm_zones = 0, sm_fourier = 1, sm_table = 2, sm_iso = 3
   character(len=*), parameter :: model_names = 'zones, fourier, table, iso6336'

   type :: mesh_excitation_t
      integer :: model = sm_zones
      logical :: active = .false.     !< anything beyond TRAIN's two levels (the general path)
      logical :: has_te = .false.     !< a displacement excitation
      logical :: varies = .false.     !< the stiffness varies between zone events
      real(wp) :: teeth = 0.0_wp, teeth2 = 0.0_wp, mp = 1.0_wp, c2 = 1.8_wp, pb = 0.0_wp
      real(wp), allocatable :: ka(:), kp(:)          !< stiffness harmonics (relative) and phases
      real(wp), allocatable :: tu(:), tc(:)          !< stiffness table: roll in [0, 1], factors
      real(wp) :: iso_c = 1.0_wp, iso_beta = 0.0_wp  !< k_s(x)/k at mid path, its parabola's depth
      real(wp), allocatable :: ea(:), ep(:)          !< TE harmonics (length) and phases
      integer :: relief = 0                          !< 0 none, 1 linear, 2 parabolic
      real(wp) :: ca = 0.0_wp, la = 1.0_wp           !< tip relief amount (length), length (base pitches)
      real(wp), allocatable :: prof1(:), prof2(:), pitch1(:), pitch2(:)
      real(wp) :: ro1 = 0.0_wp, rp1 = 0.0_wp, ro2 = 0.0_wp, rp2 = 0.0_wp
      integer :: fault_tooth = 0, fault_gear = 1
      real(wp) :: fault_factor = 1.0_wp
      logical :: has_dev = .false.                   !< per-pair deviations (relief, profile, pitch)
      real(wp) :: cmin = 1.0_wp, cmax = 1.0_wp, cmean = 1.0_wp   !< over a tooth period (no fault)
      real(wp) :: rb1 = 0.0_wp, t1e = 0.0_wp         !< driver base radius, T1 to the end of contact (0: unknown)
   contains
      procedure :: configure => ex_configure
      procedure :: configure_te => ex_configure_te
      procedure :: at => ex_at
      procedure :: at_roll => ex_at_roll
      procedure :: unloaded_te => ex_unloaded_te
      procedure :: hunting_period => ex_hunting_period
      procedure, private :: pair
   end type mesh_excitation_t

contains

   !> The deck's word for stiffness_model code m.
   pure function model_name(m) result(w)
      integer, intent(in) :: m
      character(len=:), allocatable :: w
      select case (m)
      case (sm_fourier); w = 'fourier'
      case (sm_table); w = 'table'
      case (sm_iso); w = 'iso6336'
      case default; w = 'zones'
      end select
   end function model_name

   !> ISO 6336-1 (2006) method B, eqs. (69)-(72): the single pair stiffness c' and
   !> the mesh stiffness c_gamma_alpha, N/(mm um), of a solid spur pair on the
   !> standard basic rack (h_fP = 1.25 m, no profile shift): 1/q' with q' the
   !> polynomial in 1/z_n (x1 = x2 = 0), times C_M = 0.8, C_R = 1 and
   !> C_B = (1 + 0.5 (1.2 - 1.25))(1 - 0.02 (20 - alpha_n deg)). An internal
   !> pair takes z2 = infinity.
   pure subroutine iso_single_pair_stiffness(z1, z2, alpha_deg, eps_alpha, internal, cprime, cgamma)
      real(wp), intent(in) :: z1, z2, alpha_deg, eps_alpha
      logical, intent(in) :: internal
      real(wp), intent(out) :: cprime, cgamma
      real(wp) :: q, cb
      q = 0.04723_wp + 0.15551_wp/z1
      if (.not. internal) q = q + 0.25791_wp/z2
      cb = (1.0_wp + 0.5_wp*(1.2_wp - 1.25_wp))*(1.0_wp - 0.02_wp*(20.0_wp - alpha_deg))
      cprime = 0.8_wp*cb/q
      cgamma = cprime*(0.75_wp*eps_alpha + 0.25_wp)
   end subroutine iso_single_pair_stiffness

   !> Read the excitation keys of a spur gear group. teeth, teeth2 (0: unknown),
   !> mp, c2 and the base pitch pb (length) are the pair's; k_iso the ISO mesh
   !> stiffness factor inputs are given by the caller through `iso_ok`.
   subroutine ex_configure(self, grp, teeth, teeth2, mp, c2, pb, iso_ok, err)
      class(mesh_excitation_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      real(wp), intent(in) :: teeth, teeth2, mp, c2, pb
      logical, intent(in) :: iso_ok
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: word
      real(wp) :: lr, v
      self%teeth = teeth; self%teeth2 = teeth2; self%mp = mp; self%c2 = c2; self%pb = pb
      call grp%get_string('stiffness_model', word, err, default='zones'); if (allocated(err)) return
      select case (to_lower(word))
      case ('zones'); self%model = sm_zones
      case ('fourier'); self%model = sm_fourier
      case ('table'); self%model = sm_table
      case ('iso6336')
         self%model = sm_iso
         if (.not. iso_ok) then
            call fatal_error(err, grp%where('stiffness_model')//": error: stiffness_model = 'iso6336' needs the "// &
                             'geometry form (teeth_driver, teeth_driven, module or diametral_pitch, face_width) '// &
                             'and no explicit stiffness', err_input)
            return
         end if
      case default
         call fatal_error(err, grp%where('stiffness_model')//": error: unknown stiffness_model '"//word// &
                          "'; valid: "//model_names, err_input)
         return
      end select
      if (self%model == sm_fourier) then
         call read_harmonics(grp, 'stiffness_harmonics', 'stiffness_phases', self%ka, self%kp, .true., err)
         if (allocated(err)) return
         if (.not. sum(self%ka) < 1.0_wp) then
            call fatal_error(err, grp%where('stiffness_harmonics')//': error: the stiffness harmonics sum to '// &
                             str(sum(self%ka))//'; they must sum to < 1 so that the stiffness stays positive', err_input)
            return
         end if
      else if (self%model == sm_table) then
         call read_table(self, grp, err); if (allocated(err)) return
      end if
      call read_harmonics(grp, 'te_harmonics', 'te_phases', self%ea, self%ep, .false., err); if (allocated(err)) return
      ! tip relief (both gears alike): amount, length along the line of action, shape
      call grp%get_real('tip_relief', self%ca, err, default=0.0_wp); if (allocated(err)) return
      call grp%require_nonnegative('tip_relief', self%ca, err); if (allocated(err)) return
      if (self%ca > 0.0_wp) then
         if (grp%holds('tip_relief_start_roll')) then
            call relief_from_roll(self, grp, lr, err); if (allocated(err)) return
         else
            call grp%get_real('tip_relief_length', lr, err); if (allocated(err)) return
         end if
         call grp%require_positive('tip_relief_length', lr, err); if (allocated(err)) return
         if (.not. lr <= 0.5_wp*mp*pb) then
            call fatal_error(err, grp%where('tip_relief_length')//': error: tip_relief_length '//str(lr)// &
                             ' is longer than the tip half of the profile in contact: at most half the path of '// &
                             'contact, m_p p_b / 2 = '//str(0.5_wp*mp*pb), err_input)
            return
         end if
         self%la = lr/pb
         call grp%get_string('tip_relief_shape', word, err, default='linear'); if (allocated(err)) return
         select case (to_lower(word))
         case ('linear'); self%relief = 1
         case ('parabolic'); self%relief = 2
         case default
            call fatal_error(err, grp%where('tip_relief_shape')//": error: unknown tip_relief_shape '"//word// &
                             "'; valid: linear, parabolic", err_input)
            return
         end select
      end if
      call read_tooth_list(grp, 'profile_errors_driver', teeth, self%prof1, err); if (allocated(err)) return
      call read_tooth_list(grp, 'pitch_errors_driver', teeth, self%pitch1, err); if (allocated(err)) return
      call read_tooth_list(grp, 'profile_errors_driven', teeth2, self%prof2, err); if (allocated(err)) return
      call read_tooth_list(grp, 'pitch_errors_driven', teeth2, self%pitch2, err); if (allocated(err)) return
      call read_runout(self, grp, err); if (allocated(err)) return
      ! a fault: one tooth's stiffness times a factor over its mesh
      call grp%get_real('fault_tooth', v, err, default=0.0_wp); if (allocated(err)) return
      if (v /= 0.0_wp) then
         call grp%get_string('fault_gear', word, err, default='driver'); if (allocated(err)) return
         select case (to_lower(word))
         case ('driver'); self%fault_gear = 1
         case ('driven'); self%fault_gear = 2
         case default
            call fatal_error(err, grp%where('fault_gear')//": error: unknown fault_gear '"//word// &
                             "'; valid: driver, driven", err_input)
            return
         end select
         lr = merge(teeth, teeth2, self%fault_gear == 1)
         if (.not. (v >= 1.0_wp .and. v <= lr .and. v == aint(v))) then
            call fatal_error(err, grp%where('fault_tooth')//': error: fault_tooth must be a tooth number in [1, '// &
                             str(lr)//'] of the '//word//', got '//str(v), err_input)
            return
         end if
         self%fault_tooth = nint(v)
         call grp%get_real('fault_stiffness_factor', self%fault_factor, err); if (allocated(err)) return
         if (.not. (self%fault_factor > 0.0_wp .and. self%fault_factor <= 1.0_wp)) then
            call fatal_error(err, grp%where('fault_stiffness_factor')//': error: fault_stiffness_factor must be in '// &
                             '(0, 1] (a cracked or worn tooth is softer; a missing one: a small factor), got '// &
                             str(self%fault_factor), err_input)
            return
         end if
      end if
      self%has_dev = self%relief > 0 .or. allocated(self%prof1) .or. allocated(self%prof2) .or. &
                     allocated(self%pitch1) .or. allocated(self%pitch2)
      self%has_te = self%has_dev .or. size(self%ea) > 0 .or. self%ro1 > 0.0_wp .or. self%ro2 > 0.0_wp
      self%varies = self%model /= sm_zones
      self%active = self%varies .or. self%has_te .or. self%fault_tooth > 0
      if (self%model == sm_iso) call iso_shape(self)
      if (self%varies) call sample_period(self)   ! (TRAIN's zones: 1 and c2, no sampling at start-up)
   end subroutine ex_configure

   !> The displacement excitation alone (te_harmonics, te_phases, run-out): for a
   !> mesh whose stiffness is its own (the helical gear's eq. 6.1).
   subroutine ex_configure_te(self, grp, teeth, teeth2, err)
      class(mesh_excitation_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      real(wp), intent(in) :: teeth, teeth2
      type(error_t), allocatable, intent(out) :: err
      self%teeth = teeth; self%teeth2 = teeth2
      call read_harmonics(grp, 'te_harmonics', 'te_phases', self%ea, self%ep, .false., err); if (allocated(err)) return
      call read_runout(self, grp, err); if (allocated(err)) return
      self%has_te = size(self%ea) > 0 .or. self%ro1 > 0.0_wp .or. self%ro2 > 0.0_wp
      self%active = self%has_te
   end subroutine ex_configure_te

   !> tip_relief_start_roll xi_s (degrees, the driver's roll angle where the relief
   !> starts) as a relief length: L_a = T1E - r_b1 xi_s, T1E = r_b1 xi_a the roll to
   !> the driver's tip (the end of contact); 0 < L_a <= m_p p_b / 2.
   subroutine relief_from_roll(self, grp, lr, err)
      class(mesh_excitation_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      real(wp), intent(out) :: lr
      type(error_t), allocatable, intent(inout) :: err
      real(wp) :: xs, xa, xlo
      lr = 0.0_wp
      if (grp%holds('tip_relief_length')) then
         call fatal_error(err, grp%where('tip_relief_start_roll')//': error: give tip_relief_length or '// &
                          'tip_relief_start_roll, not both', err_input)
         return
      end if
      call grp%get_real('tip_relief_start_roll', xs, err); if (allocated(err)) return
      xa = self%t1e/self%rb1*180.0_wp/pi                  ! the tip's roll angle, degrees
      xlo = (self%t1e - 0.5_wp*self%mp*self%pb)/self%rb1*180.0_wp/pi
      if (.not. (xs >= xlo .and. xs < xa)) then
         call fatal_error(err, grp%where('tip_relief_start_roll')//': error: tip_relief_start_roll '//str(xs)// &
                          ' deg must lie between the roll angle of mid-path, '//str(xlo)//' deg, and that of '// &
                          'the driver''s tip, '//str(xa)//' deg (exclusive): a relief of at most half the '// &
                          'path of contact', err_input)
         return
      end if
      lr = self%t1e - self%rb1*xs*pi/180.0_wp
   end subroutine relief_from_roll

   !> runout_driver, runout_driven (>= 0) and their phases.
   subroutine read_runout(self, grp, err)
      class(mesh_excitation_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(error_t), allocatable, intent(inout) :: err
      call grp%get_real('runout_driver', self%ro1, err, default=0.0_wp); if (allocated(err)) return
      call grp%require_nonnegative('runout_driver', self%ro1, err); if (allocated(err)) return
      call grp%get_real('runout_driver_phase', self%rp1, err, default=0.0_wp); if (allocated(err)) return
      call grp%get_real('runout_driven', self%ro2, err, default=0.0_wp); if (allocated(err)) return
      call grp%require_nonnegative('runout_driven', self%ro2, err); if (allocated(err)) return
      call grp%get_real('runout_driven_phase', self%rp2, err, default=0.0_wp); if (allocated(err)) return
      if (self%ro2 > 0.0_wp .and. .not. self%teeth2 > 0.0_wp) then
         call fatal_error(err, grp%where('runout_driven')//': error: the driven gear''s tooth count is not known '// &
                          '(rb_driven/rb_driver * teeth is not a whole number): give the geometry form', err_input)
         return
      end if
   end subroutine read_runout

   !> Amplitudes (>= 0) and phases (rad) of the same length; phases default to 0.
   subroutine read_harmonics(grp, akey, pkey, a, p, required, err)
      type(deck_group_t), intent(inout) :: grp
      character(len=*), intent(in) :: akey, pkey
      real(wp), allocatable, intent(out) :: a(:), p(:)
      logical, intent(in) :: required
      type(error_t), allocatable, intent(inout) :: err
      integer :: j
      call grp%get_real_array(akey, a, err); if (allocated(err)) return
      call grp%get_real_array(pkey, p, err); if (allocated(err)) return
      if (required .and. size(a) == 0) then
         call fatal_error(err, grp%where('stiffness_model')//": error: stiffness_model = 'fourier' needs "// &
                          akey//' = a1, a2, ... (relative amplitudes of the mesh orders 1, 2, ...)', err_input)
         return
      end if
      if (size(p) == 0) then
         deallocate (p); allocate (p(size(a)), source=0.0_wp)
      else if (size(p) /= size(a)) then
         call fatal_error(err, grp%where(pkey)//': error: '//pkey//' has '//str(size(p))//' values and '// &
                          akey//' '//str(size(a))//'; give one phase per harmonic', err_input)
         return
      end if
      do j = 1, size(a)
         if (.not. (a(j) >= 0.0_wp .and. a(j) <= huge(1.0_wp))) then
            call fatal_error(err, grp%where(akey)//': error: '//akey//' value '//str(j)//' must be >= 0 (an '// &
                             'amplitude; a sign is a phase of pi), got '//str(a(j)), err_input)
            return
         end if
         if (.not. abs(p(j)) <= 1.0e6_wp) then
            call fatal_error(err, grp%where(pkey)//': error: '//pkey//' value '//str(j)//' must be a finite '// &
                             'phase in radians, got '//str(p(j)), err_input)
            return
         end if
      end do
   end subroutine read_harmonics

   !> stiffness_roll (0 ... 1, increasing) and stiffness_factors (> 0, first = last).
   subroutine read_table(self, grp, err)
      class(mesh_excitation_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(error_t), allocatable, intent(inout) :: err
      integer :: j, n
      call grp%get_real_array('stiffness_roll', self%tu, err); if (allocated(err)) return
      call grp%get_real_array('stiffness_factors', self%tc, err); if (allocated(err)) return
      n = size(self%tu)
      if (n < 2 .or. size(self%tc) /= n) then
         call fatal_error(err, grp%where('stiffness_factors')//": error: stiffness_model = 'table' needs "// &
                          'stiffness_roll (roll positions in teeth, 0 to 1) and stiffness_factors of the same '// &
                          'length >= 2, got '//str(n)//' and '//str(size(self%tc)), err_input)
         return
      end if
      if (.not. (self%tu(1) == 0.0_wp .and. self%tu(n) == 1.0_wp .and. all(self%tu(2:) > self%tu(:n - 1)))) then
         call fatal_error(err, grp%where('stiffness_roll')//': error: stiffness_roll must increase from 0 to 1 '// &
                          '(one tooth period)', err_input)
         return
      end if
      do j = 1, n
         if (.not. (self%tc(j) > 0.0_wp .and. self%tc(j) <= 1.0e6_wp)) then
            call fatal_error(err, grp%where('stiffness_factors')//': error: stiffness_factors value '//str(j)// &
                             ' must be in (0, 1e6], got '//str(self%tc(j)), err_input)
            return
         end if
      end do
      if (abs(self%tc(n) - self%tc(1)) > 1.0e-9_wp*self%tc(1)) then
         call fatal_error(err, grp%where('stiffness_factors')//': error: the stiffness table is not periodic: '// &
                          'its value at roll 1 ('//str(self%tc(n))//') differs from that at roll 0 ('// &
                          str(self%tc(1))//')', err_input)
         return
      end if
      self%tc(n) = self%tc(1)
   end subroutine read_table

   !> A per-tooth list: absent, or one value per tooth.
   subroutine read_tooth_list(grp, key, n, a, err)
      type(deck_group_t), intent(inout) :: grp
      type(error_t), allocatable, intent(inout) :: err
      character(len=*), intent(in) :: key
      real(wp), intent(in) :: n
      real(wp), allocatable, intent(out) :: a(:)
      real(wp), allocatable :: v(:)
      integer :: j
      call grp%get_real_array(key, v, err); if (allocated(err)) return
      if (size(v) == 0) return
      if (.not. n > 0.0_wp) then
         call fatal_error(err, grp%where(key)//': error: the driven gear''s tooth count is not known '// &
                          '(rb_driven/rb_driver * teeth is not a whole number): give the geometry form', err_input)
         return
      end if
      if (size(v) /= nint(n)) then
         call fatal_error(err, grp%where(key)//': error: '//key//' needs one value per tooth, '//str(nint(n))// &
                          ', got '//str(size(v)), err_input)
         return
      end if
      do j = 1, size(v)
         if (.not. abs(v(j)) <= huge(1.0_wp)) then
            call fatal_error(err, grp%where(key)//': error: '//key//' value '//str(j)//' is not finite', err_input)
            return
         end if
      end do
      call move_alloc(v, a)
   end subroutine read_tooth_list

   !> beta so that the mean of the sum of the pairs, the integral of k_s over
   !> one pair's path m_p, is c_gamma_alpha = c' (0.75 m_p + 0.25):
   !> m_p (1 - beta/3) = 0.75 m_p + 0.25. iso_c: k_s(mid)/k_mean.
   subroutine iso_shape(self)
      class(mesh_excitation_t), intent(inout) :: self
      self%iso_beta = 0.75_wp*(1.0_wp - 1.0_wp/self%mp)
      self%iso_c = 1.0_wp/(0.75_wp*self%mp + 0.25_wp)
   end subroutine iso_shape

   !> Extremes and mean of the stiffness factor over one tooth period (no fault).
   subroutine sample_period(self)
      class(mesh_excitation_t), intent(inout) :: self
      integer, parameter :: ns = 4096
      integer :: j, ft
      real(wp) :: c, e, s
      ft = self%fault_tooth
      self%fault_tooth = 0
      self%cmin = huge(1.0_wp); self%cmax = -huge(1.0_wp); s = 0.0_wp
      do j = 0, ns - 1
         call self%at_roll((j + 0.5_wp)/ns, c, e)
         self%cmin = min(self%cmin, c); self%cmax = max(self%cmax, c); s = s + c
      end do
      self%cmean = s/ns
      self%fault_tooth = ft
   end subroutine sample_period

   !> The stiffness share c_j (relative to k) of the pair that entered at count
   !> mj, at its path position x (base pitches), its derivative in u, and its
   !> deviation d_j (length) with its derivative.
   pure subroutine pair(self, u, mj, x, pairs, cj, dcj, dj, ddj)
      class(mesh_excitation_t), intent(in) :: self
      real(wp), intent(in) :: u, mj, x
      integer, intent(in) :: pairs
      real(wp), intent(out) :: cj, dcj, dj, ddj
      real(wp) :: s, xc, f
      integer :: i1, i2, k, n
      select case (self%model)
      case (sm_fourier)
         cj = 1.0_wp; dcj = 0.0_wp
         do k = 1, size(self%ka)
            cj = cj + self%ka(k)*cos(two_pi*k*u + self%kp(k))
            dcj = dcj - two_pi*k*self%ka(k)*sin(two_pi*k*u + self%kp(k))
         end do
         cj = cj/pairs; dcj = dcj/pairs
      case (sm_table)
         f = u - floor_r(u)
         n = size(self%tu)
         k = 1
         do while (k < n - 1 .and. self%tu(k + 1) <= f)
            k = k + 1
         end do
         dcj = (self%tc(k + 1) - self%tc(k))/(self%tu(k + 1) - self%tu(k))
         cj = (self%tc(k) + dcj*(f - self%tu(k)))/pairs
         dcj = dcj/pairs
      case (sm_iso)
         xc = max(0.0_wp, min(self%mp, x))
         s = 2.0_wp*xc/self%mp - 1.0_wp
         cj = self%iso_c*(1.0_wp - self%iso_beta*s**2)
         dcj = -self%iso_c*self%iso_beta*2.0_wp*s*(2.0_wp/self%mp)
      case default
         cj = merge(self%c2, 1.0_wp, pairs == 2)/pairs
         dcj = 0.0_wp
      end select
      dj = 0.0_wp; ddj = 0.0_wp
      i1 = 0; i2 = 0
      if (self%fault_tooth > 0 .or. self%has_dev) then
         i1 = tooth_of(mj, self%teeth)
         if (self%teeth2 > 0.0_wp) i2 = tooth_of(mj, self%teeth2)
      end if
      if (self%fault_tooth > 0) then
         if ((self%fault_gear == 1 .and. i1 == self%fault_tooth) .or. (self%fault_gear == 2 .and. i2 == self%fault_tooth)) then
            cj = cj*self%fault_factor; dcj = dcj*self%fault_factor
         end if
      end if
      if (.not. self%has_dev) return
      if (self%relief > 0) call relief(x, dj, ddj)
      if (allocated(self%pitch1)) dj = dj + self%pitch1(i1)
      if (allocated(self%pitch2)) dj = dj + self%pitch2(i2)
      if (allocated(self%prof1)) then   ! driver: root at x = 0, tip at x = m_p
         dj = dj + self%prof1(i1)*(x/self%mp - 0.5_wp); ddj = ddj + self%prof1(i1)/self%mp
      end if
      if (allocated(self%prof2)) then   ! driven: tip at x = 0
         dj = dj + self%prof2(i2)*(0.5_wp - x/self%mp); ddj = ddj - self%prof2(i2)/self%mp
      end if
   contains
      !> Tip relief of the driven tip (x < l_a) and the driver tip (x > m_p - l_a):
      !> C_a ((l_a - s)/l_a)^n, s the distance from the path's end, n = 1 or 2.
      pure subroutine relief(x, d, dd)
         real(wp), intent(in) :: x
         real(wp), intent(out) :: d, dd
         real(wp) :: r
         d = 0.0_wp; dd = 0.0_wp
         if (x < self%la) then
            r = (self%la - x)/self%la
            d = self%ca*r**self%relief
            dd = -self%ca*self%relief*r**(self%relief - 1)/self%la
         else if (x > self%mp - self%la) then
            r = (x - (self%mp - self%la))/self%la
            d = self%ca*r**self%relief
            dd = self%ca*self%relief*r**(self%relief - 1)/self%la
         end if
      end subroutine relief
   end subroutine pair

   !> Tooth number (1..n) of the tooth that entered at count m (tooth 1 at m = 0).
   pure integer function tooth_of(m, n) result(i)
      real(wp), intent(in) :: m, n
      i = nint(m - n*floor_r(m/n)) + 1
      if (i > nint(n)) i = 1
   end function tooth_of

   elemental real(wp) function floor_r(x) result(f)
      real(wp), intent(in) :: x
      f = aint(x)
      if (f > x) f = f - 1.0_wp
   end function floor_r

   !> The mesh at roll u with `pairs` pairs in contact, the newest having
   !> entered at count m: stiffness factor c and dc/du, loaded TE e and de/du.
   pure subroutine ex_at(self, u, m, pairs, c, dc, e, de)
      class(mesh_excitation_t), intent(in) :: self
      real(wp), intent(in) :: u, m
      integer, intent(in) :: pairs
      real(wp), intent(out) :: c, dc, e, de
      real(wp) :: cj(2), dcj(2), dj(2), ddj(2), x
      integer :: j
      x = u - m
      do j = 1, pairs
         call self%pair(u, m - (j - 1), x + (j - 1), pairs, cj(j), dcj(j), dj(j), ddj(j))
      end do
      c = sum(cj(1:pairs)); dc = sum(dcj(1:pairs))
      e = 0.0_wp; de = 0.0_wp
      if (.not. self%has_te) return
      if (self%has_dev .and. c > 0.0_wp) then   ! the stiffness-weighted mean deviation
         e = sum(cj(1:pairs)*dj(1:pairs))/c
         de = (sum(dcj(1:pairs)*dj(1:pairs) + cj(1:pairs)*ddj(1:pairs)) - e*dc)/c
      end if
      call add_harmonics(self, u, e, de)
   end subroutine ex_at

   !> TE harmonics and run-out at u, added to e and de/du.
   pure subroutine add_harmonics(self, u, e, de)
      class(mesh_excitation_t), intent(in) :: self
      real(wp), intent(in) :: u
      real(wp), intent(inout) :: e, de
      integer :: k
      do k = 1, size(self%ea)
         e = e + self%ea(k)*cos(two_pi*k*u + self%ep(k))
         de = de - two_pi*k*self%ea(k)*sin(two_pi*k*u + self%ep(k))
      end do
      if (self%ro1 > 0.0_wp) then
         e = e + self%ro1*cos(two_pi*u/self%teeth + self%rp1)
         de = de - two_pi/self%teeth*self%ro1*sin(two_pi*u/self%teeth + self%rp1)
      end if
      if (self%ro2 > 0.0_wp) then
         e = e + self%ro2*cos(two_pi*u/self%teeth2 + self%rp2)
         de = de - two_pi/self%teeth2*self%ro2*sin(two_pi*u/self%teeth2 + self%rp2)
      end if
   end subroutine add_harmonics

   !> The mesh at roll u from the geometry alone (the periodic zones of App. F):
   !> stiffness factor c and loaded TE e. For callers outside a run (the
   !> quasi-static TE, `trainsim gear`).
   pure subroutine ex_at_roll(self, u, c, e, pairs)
      class(mesh_excitation_t), intent(in) :: self
      real(wp), intent(in) :: u
      real(wp), intent(out) :: c, e
      integer, intent(out), optional :: pairs
      real(wp) :: m, dc, de
      integer :: np
      m = floor_r(u)
      np = merge(2, 1, u - m <= self%mp - 1.0_wp)
      call self%at(u, m, np, c, dc, e, de)
      if (present(pairs)) pairs = np
   end subroutine ex_at_roll

   !> Unloaded static TE at roll u: min_j d_j of the pairs in contact (the pair
   !> that touches first) plus the TE harmonics and run-out.
   pure real(wp) function ex_unloaded_te(self, u) result(e)
      class(mesh_excitation_t), intent(in) :: self
      real(wp), intent(in) :: u
      real(wp) :: m, cj, dcj, dj, ddj, de
      integer :: np, j
      m = floor_r(u)
      np = merge(2, 1, u - m <= self%mp - 1.0_wp)
      e = 0.0_wp
      if (self%has_dev) then
         e = huge(1.0_wp)
         do j = 1, np
            call self%pair(u, m - (j - 1), u - m + (j - 1), np, cj, dcj, dj, ddj)
            e = min(e, dj)
         end do
      end if
      de = 0.0_wp
      call add_harmonics(self, u, e, de)
   end function ex_unloaded_te

   !> Mesh cycles after which the excitation repeats: 1, the tooth count of a
   !> gear with per-tooth data or run-out, or the hunting period lcm(N1, N2).
   pure real(wp) function ex_hunting_period(self) result(p)
      class(mesh_excitation_t), intent(in) :: self
      logical :: one, two
      one = allocated(self%prof1) .or. allocated(self%pitch1) .or. self%ro1 > 0.0_wp .or. &
            (self%fault_tooth > 0 .and. self%fault_gear == 1)
      two = allocated(self%prof2) .or. allocated(self%pitch2) .or. self%ro2 > 0.0_wp .or. &
            (self%fault_tooth > 0 .and. self%fault_gear == 2)
      p = 1.0_wp
      if (one) p = self%teeth
      if (two) p = lcm(p, self%teeth2)
   contains
      pure real(wp) function lcm(a, b)
         real(wp), intent(in) :: a, b
         integer :: x, y, t
         x = nint(a); y = nint(b)
         do while (y /= 0)
            t = mod(x, y); x = y; y = t
         end do
         lcm = a*b/x
      end function lcm
   end function ex_hunting_period
end module trainsim_mesh_excitation
