!> Planetary stages (issue 25): the internal mesh and a planet on a carrier are their
!> own physics in the carrier's frame (torques minus the gradient of the mesh energy,
!> the Jacobian the difference quotient of the torques), the &planetary group's
!> linearised modes against the closed form of a torsional planetary model (Kahraman
!> 1994; Lin and Parker 1999) to 1e-9 for N = 3, 4, 5, and its rigid-body mode against
!> the Willis equation for each held member.
program test_planetary
   use trainsim_kinds, only: wp, pi, two_pi
   use trainsim_model, only: model_t
   use trainsim_modes, only: modes_t, compute_modes
   use trainsim_error, only: error_t
   use trainsim_element, only: max_ports
   use trainsim_planetary_deck, only: planet_phases, assembles
   use trainsim_testing, only: suite_begin, suite_end, test_begin, check_true, check_close
   use trainsim_test_support, only: load_model_text, nl
   implicit none

   ! the stage of the modes test: z_s + z_r = 120, so 3, 4 and 5 planets assemble equally
   ! spaced (and 5 planets of 24 teeth fit around a sun of 36: 60 sin(36 deg) = 35 > 24 + 2)
   real(wp), parameter :: zs = 36.0_wp, zp = 24.0_wp, zr = 84.0_wp, modl = 2.0_wp
   real(wp), parameter :: ks = 5.0e6_wp, kr = 7.0e6_wp          ! lbf/in
   real(wp), parameter :: js = 0.01_wp, jr = 0.5_wp, jc = 0.2_wp, jp = 0.003_wp   ! lbf in s^2

   call suite_begin('planetary stages (internal mesh, &planetary, modes)')
   call test_planet_meshes_are_minus_the_energy_gradient()
   call test_planetary_modes_match_the_closed_form()
   call test_rigid_mode_is_willis_for_each_held_member()
   call test_mesh_phases_of_equally_spaced_planets()
   call suite_end()

contains

   !> A &planetary deck (ideal meshes) with N planets and the given member held.
   function stage_deck(n, held) result(text)
      integer, intent(in) :: n
      character(len=*), intent(in) :: held
      character(len=:), allocatable :: text
      character(len=32) :: buf
      write (buf, '(i0)') n
      text = "&run t_end = 1e-3, dt = 1e-6 /"//nl// &
             "&planetary id = 'ps', planets = "//trim(buf)//", teeth_sun = 36, teeth_planet = 24, teeth_ring = 84,"// &
             " module = 2.0, mesh = 'ideal', sun_mesh_stiffness = 5.0e6, ring_mesh_stiffness = 7.0e6,"// &
             " planet_inertia = 0.003, held = '"//held//"'"
      if (held /= 'sun') text = text//', sun_inertia = 0.01'
      if (held /= 'ring') text = text//', ring_inertia = 0.5'
      if (held /= 'carrier') text = text//', carrier_inertia = 0.2'
      text = text//' /'
   end function stage_deck

   !> Each mesh of a stage with one planet (spur meshes with backlash, closed: the
   !> planet pressed into both meshes) puts on its three ports (sun or planet, planet
   !> or ring, carrier) minus the gradient of its elastic energy, every member counted
   !> in the sun's sense; and turning the whole stage (all members by one angle)
   !> leaves every mesh's energy unchanged.
   subroutine test_planet_meshes_are_minus_the_energy_gradient()
      type(model_t) :: m
      real(wp) :: th(max_ports), w(max_ports), t(max_ports), tp(max_ports), e0, ep, em, h, scale
      integer :: ie, k, np
      call test_begin('planet_meshes_are_minus_the_energy_gradient')
      call load_model_text("&run t_end = 1e-3, dt = 1e-6 /"//nl// &
                           "&planetary id = 'ps', planets = 1, teeth_sun = 36, teeth_planet = 24, teeth_ring = 84,"// &
                           " module = 2.0, face_width = 1.0, sun_backlash = 0.002, ring_backlash = 0.003,"// &
                           " sun_inertia = 0.01, ring_inertia = 0.5, carrier_inertia = 0.2, planet_inertia = 0.003 /", m)
      call check_true('two meshes', size(m%elements) == 2)
      do ie = 1, 2
         associate (e => m%elements(ie)%e)
            np = e%n_ports()
            call check_true('three ports', np == 3)
            ! closed on the front face in the carrier's frame: sun +2e-3 rad, planet +1e-3 rad,
            ! ring +0.3e-3, carrier 0.1e-3 (the planet leads the ring, the sun the planet)
            th = 0.0_wp; w = 0.0_wp
            if (ie == 1) th(1:3) = [2.0e-3_wp, 1.0e-3_wp, 1.0e-4_wp]    ! sun, planet, carrier
            if (ie == 2) th(1:3) = [4.0e-3_wp, 3.0e-4_wp, 1.0e-4_wp]    ! planet, ring, carrier
            call e%port_init_mode(th(1:np), w(1:np))
            call e%port_torques(th(1:np), w(1:np), t(1:np))
            e0 = e%port_potential_energy(th(1:np))
            call check_true('energy stored (closed)', e0 > 0.0_wp)
            scale = maxval(abs(t(1:np)))
            call check_true('torques', scale > 0.0_wp)
            h = 1.0e-7_wp
            do k = 1, np
               tp = th; tp(k) = th(k) + h
               ep = e%port_potential_energy(tp(1:np))
               tp(k) = th(k) - h
               em = e%port_potential_energy(tp(1:np))
               ! central difference of a quadratic: exact but for roundoff (1e-7 of the torque)
               call check_close('t = -dV/dth', t(k), -(ep - em)/(2.0_wp*h), abs_tol=1.0e-6_wp*scale)
            end do
            tp = th + 0.37_wp
            call check_close('turning the stage stores nothing', e%port_potential_energy(tp(1:np)), e0, &
                             rel_tol=1.0e-9_wp)
            call check_close('torques balance', sum(t(1:np)), 0.0_wp, abs_tol=1.0e-12_wp*scale)
         end associate
      end do
   end subroutine test_planet_meshes_are_minus_the_energy_gradient

   !> The modes of the torsional stage (ring held) for N = 3, 4, 5 against the closed form.
   !>
   !> Coordinates: every angle in the sun's sense, th_s, th_c, th_n (planet n, absolute).
   !> Mesh deflections along the lines of action, in the carrier's frame (base radii r):
   !>   sun-planet n (external): d_sn = r_s (th_s - th_c) + r_p (th_n - th_c)
   !>   ring-planet n (internal): d_rn = r_p (th_n - th_c) - r_r (th_r - th_c), th_r = 0
   !> V = sum_n (k_s d_sn^2 + k_r d_rn^2)/2. Each planet enters the sun's and carrier's
   !> equations only through its own th_n, with the same coefficients for every planet
   !> (a torsional model: no planet position appears), so the motions split:
   !> (a) sum_n th_n = 0 with th_s = th_c = 0: no torque reaches sun or carrier, and each
   !>     planet obeys J_p th_n'' = -(k_s + k_r) r_p^2 th_n: one frequency of multiplicity
   !>     N - 1, w^2 = (k_s + k_r) r_p^2 / J_p;
   !> (b) th_n = q for every n: the reduced system in (th_s, th_c, q) with
   !>     M = diag(J_s, J_c, N J_p), K = N (k_s g_s g_s^T + k_r g_r g_r^T),
   !>     g_s = (r_s, -(r_s + r_p), r_p), g_r = (0, r_r - r_p, r_p) (d_s = g_s.x, d_r = g_r.x).
   !>     K has rank 2: one rigid-body mode (w = 0) and two modes whose w^2 are the roots of
   !>     l^2 - tr(A) l + e2(A) = 0, A = M^-1/2 K M^-1/2, e2 the sum of its 2x2 principal minors
   !>     (the characteristic polynomial of A divided by l, its third root being 0).
   subroutine test_planetary_modes_match_the_closed_form()
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      real(wp) :: rb, rs, rp, rrr, gs(3), gr(3), kk(3, 3), mm(3), a(3, 3), tr, e2, lam(2), wp2, worst
      real(wp), allocatable :: expect(:)
      integer :: n, i, j
      call test_begin('planetary_modes_match_the_closed_form')
      rb = 0.5_wp*(modl/25.4_wp)*cos(20.0_wp*pi/180.0_wp)   ! base radius per tooth, in
      rs = rb*zs; rp = rb*zp; rrr = rb*zr
      worst = 0.0_wp
      do n = 3, 5
         call load_model_text(stage_deck(n, 'ring'), m)
         call compute_modes(m, md, err, closed=.true.)
         call check_true('modes computed', .not. allocated(err))
         if (allocated(err)) return
         call check_true('N + 2 degrees of freedom', md%nm == n + 2)
         gs = [rs, -(rs + rp), rp]
         gr = [0.0_wp, rrr - rp, rp]
         mm = [js, jc, n*jp]
         do j = 1, 3
            do i = 1, 3
               kk(i, j) = n*(ks*gs(i)*gs(j) + kr*gr(i)*gr(j))
               a(i, j) = kk(i, j)/sqrt(mm(i)*mm(j))
            end do
         end do
         tr = a(1, 1) + a(2, 2) + a(3, 3)
         e2 = a(1, 1)*a(2, 2) - a(1, 2)**2 + a(1, 1)*a(3, 3) - a(1, 3)**2 + a(2, 2)*a(3, 3) - a(2, 3)**2
         lam = [(tr - sqrt(tr**2 - 4.0_wp*e2))/2.0_wp, (tr + sqrt(tr**2 - 4.0_wp*e2))/2.0_wp]
         wp2 = (ks + kr)*rp**2/jp
         expect = [0.0_wp, sqrt(lam(1))/two_pi, spread(sqrt(wp2)/two_pi, 1, n - 1), sqrt(lam(2))/two_pi]
         expect = sort(expect)
         call check_true('one rigid-body mode', md%rigid(1) .and. .not. any(md%rigid(2:md%nm)))
         do i = 2, n + 2
            call check_close('frequency', md%freq_hz(i), expect(i), rel_tol=1.0e-9_wp)
            worst = max(worst, abs(md%freq_hz(i) - expect(i))/expect(i))
         end do
      end do
      write (*, '(a, es9.2)') '    largest relative difference, N = 3..5: ', worst
   end subroutine test_planetary_modes_match_the_closed_form

   !> Ascending copy (insertion sort: a handful of values).
   pure function sort(x) result(y)
      real(wp), intent(in) :: x(:)
      real(wp) :: y(size(x)), v
      integer :: i, j
      y = x
      do i = 2, size(y)
         v = y(i)
         j = i - 1
         do while (j >= 1)
            if (y(j) <= v) exit
            y(j + 1) = y(j)
            j = j - 1
         end do
         y(j + 1) = v
      end do
   end function sort

   !> The rigid-body mode of the elastic stage is its kinematics: with one member
   !> held, the other two turn at Willis' ratio (w_s - w_c)/(w_r - w_c) = -z_r/z_s
   !> (ring held: w_c/w_s = z_s/(z_s + z_r); sun held: w_c/w_r = z_r/(z_s + z_r);
   !> carrier held: w_r/w_s = -z_s/z_r), and each planet at
   !> w_p - w_c = -(z_s/z_p)(w_s - w_c), counted in the sun's sense.
   subroutine test_rigid_mode_is_willis_for_each_held_member()
      character(len=7), parameter :: held(3) = ['ring   ', 'sun    ', 'carrier']
      type(model_t) :: m
      type(modes_t) :: md
      type(error_t), allocatable :: err
      real(wp) :: ws, wr, wc, wpl
      integer :: h, i
      call test_begin('rigid_mode_is_willis_for_each_held_member')
      do h = 1, 3
         call load_model_text(stage_deck(4, trim(held(h))), m)
         call compute_modes(m, md, err, closed=.true.)
         call check_true('modes computed', .not. allocated(err))
         if (allocated(err)) return
         call check_true('one rigid-body mode', md%rigid(1) .and. .not. md%rigid(2))
         ws = 0.0_wp; wr = 0.0_wp; wc = 0.0_wp; wpl = 0.0_wp
         do i = 1, md%n
            select case (m%nodes(md%node(i))%n%id)
            case ('ps_sun'); ws = md%shape(i, 1)
            case ('ps_ring'); wr = md%shape(i, 1)
            case ('ps_carrier'); wc = md%shape(i, 1)
            case ('ps_planet3'); wpl = md%shape(i, 1)
            end select
         end do
         ! Willis, scaled by the largest member speed (the mode shape's largest entry is 1)
         call check_close('Willis', (ws - wc)*zs + (wr - wc)*zr, 0.0_wp, abs_tol=1.0e-9_wp*zr)
         call check_close('planet', (wpl - wc)*zp + (ws - wc)*zs, 0.0_wp, abs_tol=1.0e-9_wp*zr)
         call check_true('the held member at rest', count([ws, wr, wc] == 0.0_wp) == 1)
      end do
   end subroutine test_rigid_mode_is_willis_for_each_held_member

   !> Equally spaced planets: planet n's sun mesh is -z_s (n - 1)/N teeth behind planet 1's,
   !> its ring mesh -z_r (n - 1)/N; where the stage assembles the two sum to whole teeth.
   subroutine test_mesh_phases_of_equally_spaced_planets()
      real(wp) :: ps(5), pr(5), psi(5)
      integer :: k
      call test_begin('mesh_phases_of_equally_spaced_planets')
      call check_true('36 + 84 assembles with 3, 4, 5 planets', assembles(zs, zr, 3) .and. assembles(zs, zr, 4) &
                      .and. assembles(zs, zr, 5))
      call check_true('21 + 81 does not with 4', .not. assembles(21.0_wp, 81.0_wp, 4))
      psi = [(72.0_wp*(k - 1), k=1, 5)]
      call planet_phases(zs, zr, psi, ps, pr)
      do k = 1, 5
         call check_close('sun mesh phase', ps(k), modulo(-zs*(k - 1)/5.0_wp, 1.0_wp), abs_tol=1.0e-12_wp)
         call check_close('sun + ring phases whole', modulo(ps(k) + pr(k) + 0.5_wp, 1.0_wp), 0.5_wp, abs_tol=1.0e-12_wp)
      end do
      call check_true('planet 1 at phase 0', ps(1) == 0.0_wp .and. pr(1) == 0.0_wp)
   end subroutine test_mesh_phases_of_equally_spaced_planets
end program test_planetary
