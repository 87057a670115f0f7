!> Hand-specialised reference for the RK4 benchmark: the Table 5.5 rig (node 1
!> held at 80 rad/s, shaft - gear pair - shaft, 798.8 lb-in load on node 4)
!> written as one plain loop over a 6-element state array, with the same
!> equations, the same dt grid and the same RK4 arithmetic as trainsim, no
!> derived types, no calls through objects, no observer. Two gear pairs:
!> - ideal gear (EL3, eqs. H.15-H.16);
!> - spur gear with backlash (EL4: half backlash 0.005 in, yang_sun contact
!>   with goldsmith restitution, single/two-pair zones with factor 1.8), its
!>   events located as trainsim's 'rk4' does: root of the guard on the step's
!>   own dense output (the RK4 continuous extension), refined on the step map
!>   by secant steps to the event tolerance 1e-9 dt, then the step to there.
!> `bench_rk4_throughput` times it against `simulate` and compares the final
!> states, which shows that the two integrate the same equations.
module bench_reference
   use trainsim_kinds, only: wp, i8, two_pi
   implicit none
   private

   public :: ref_result_t, ref_rig

   !> Final state and counters of a reference run.
   type :: ref_result_t
      real(wp) :: y(6) = 0.0_wp        !< th2, w2, th3, w3, th4, w4
      real(wp) :: t = 0.0_wp
      integer(i8) :: steps = 0, rhs_evals = 0, events = 0, located = 0
   end type ref_result_t

   ! the rig (bench_rk4_throughput's rig_deck)
   real(wp), parameter :: jn(4) = [100.0_wp, 0.987_wp, 0.987_wp, 100.0_wp]
   real(wp), parameter :: th0(4) = [-0.187847_wp, -0.212810_wp, -0.214283_wp, -0.239246_wp]
   real(wp), parameter :: w0 = 80.0_wp, load4 = -798.8_wp
   real(wp), parameter :: ks = 32000.0_wp, kg = 234500.0_wp, rb = 3.7588_wp
   ! the spur gear (TRAIN's constants of Table 5.5)
   real(wp), parameter :: teeth = 32.0_wp, mp = 1.6676_wp, alpha = 0.1637_wp, bh = 0.005_wp, c2 = 1.8_wp
   real(wp), parameter :: v_min = 1.0e-3_wp   !< in/s, the default floor of eq. (3.12)
   real(wp), parameter :: t_res = 64.0_wp*epsilon(1.0_wp)   !< as trainsim_int_rk4

contains

   !> Integrate the rig from 0 to t_end with step dt; `backlash` selects the spur gear.
   subroutine ref_rig(backlash, t_end, dt, res)
      logical, intent(in) :: backlash
      real(wp), intent(in) :: t_end, dt
      type(ref_result_t), intent(out) :: res
      real(wp) :: y(6), yn(6), ys(6), k1(6), k2(6), k3(6), k4(6), d2(6), d3(6), d4(6)
      real(wp) :: g0(4), g1(4), t, t_grid, h, tol, s
      integer(i8) :: istep
      ! mode of the spur gear: contact face, zone factor, zone bounds, damping coefficient
      integer :: mode, pairs
      real(wp) :: cf, th_lo, th_hi, dcoef

      y = [th0(2), w0, th0(3), w0, th0(4), w0]
      t = 0.0_wp
      tol = 1.0e-9_wp*dt
      istep = 1
      mode = 0; pairs = 1; cf = 1.0_wp; th_lo = 0.0_wp; th_hi = 0.0_wp; dcoef = 0.0_wp
      if (backlash) call init_modes()
      do
         t_grid = min(real(istep, wp)*dt, t_end)
         h = t_grid - t
         call f(t, y, k1)
         call step(t, y, h, yn)
         res%rhs_evals = res%rhs_evals + 4
         if (backlash) then
            call guards(t + h, yn, g1)
            if (any(g1 < 0.0_wp)) then
               call guards(t, y, g0)
               d2 = k2; d3 = k3; d4 = k4
               call locate(s)
               t = t + s
               y = ys
               call settle()
               if (t < t_grid - 1.0e-12_wp*dt) cycle
            else
               y = yn
               t = t_grid
            end if
         else
            y = yn
            t = t_grid
         end if
         res%steps = res%steps + 1
         if (t_grid >= t_end) exit
         istep = istep + 1
      end do
      res%y = y
      res%t = t

   contains

      !> dy/dt: shaft (H.1), gear pair, shaft; node 1 held, load on node 4.
      subroutine f(tt, x, dx)
         real(wp), intent(in) :: tt, x(6)
         real(wp), intent(out) :: dx(6)
         real(wp) :: th1, tq2, tq3, tq4, tr, fg, d, dd
         th1 = th0(1) + w0*tt
         tq2 = 0.0_wp; tq3 = 0.0_wp; tq4 = load4
         tr = ks*(th1 - x(1))
         tq2 = tq2 + tr
         if (backlash) then
            if (mode == 0) then
               fg = 0.0_wp
            else
               d = rb*x(1) - rb*x(3)
               dd = rb*x(2) - rb*x(4)
               if (mode == 1) then
                  fg = cf*(kg*(d - bh) + dcoef*(d - bh)*dd)                ! eqs. (3.18)-(3.19)
               else
                  fg = -(cf*(kg*(-d - bh) + dcoef*(-d - bh)*(-dd)))
               end if
            end if
         else
            fg = kg*(rb*x(1) - rb*x(3))                                     ! eq. (H.15)
         end if
         tq2 = tq2 + (-(fg*rb))
         tq3 = tq3 + fg*rb
         tr = ks*(x(3) - x(5))
         tq3 = tq3 + (-tr)
         tq4 = tq4 + tr
         dx(1) = x(2); dx(2) = tq2/jn(2)
         dx(3) = x(4); dx(4) = tq3/jn(3)
         dx(5) = x(6); dx(6) = tq4/jn(4)
      end subroutine f

      !> Classical RK4 from (tt, x) with k1 given: stages into k2..k4, end into xn.
      subroutine step(tt, x, hh, xn)
         real(wp), intent(in) :: tt, x(6), hh
         real(wp), intent(out) :: xn(6)
         real(wp) :: xt(6)
         xt = x + 0.5_wp*hh*k1
         call f(tt + 0.5_wp*hh, xt, k2)
         xt = x + 0.5_wp*hh*k2
         call f(tt + 0.5_wp*hh, xt, k3)
         xt = x + hh*k3
         call f(tt + hh, xt, k4)
         xn = x + (hh/6.0_wp)*(k1 + 2.0_wp*(k2 + k3) + k4)
      end subroutine step

      !> Guards of the spur gear: faces (1-2), driver angle inside its zone (3-4).
      subroutine guards(tt, x, g)
         real(wp), intent(in) :: tt, x(6)
         real(wp), intent(out) :: g(4)
         real(wp) :: d
         associate (unused => tt)
         end associate
         d = rb*x(1) - rb*x(3)
         select case (mode)
         case (1)
            g(1) = d - bh; g(2) = 1.0_wp
         case (-1)
            g(1) = 1.0_wp; g(2) = -d - bh
         case default
            g(1) = bh - d; g(2) = d + bh
         end select
         g(3) = x(1) - th_lo
         g(4) = th_hi - x(1)
      end subroutine guards

      !> The zone of driver angle th (periodic zone function).
      subroutine set_zone(th)
         real(wp), intent(in) :: th
         real(wp) :: u, m, u_lo, u_hi
         u = (th + alpha)*(teeth/two_pi)
         m = aint(u)
         if (m > u) m = m - 1.0_wp
         if (u - m <= mp - 1.0_wp) then
            pairs = 2; u_lo = m; u_hi = m + mp - 1.0_wp
         else
            pairs = 1; u_lo = m + mp - 1.0_wp; u_hi = m + 1.0_wp
         end if
         th_lo = u_lo*(two_pi/teeth) - alpha
         th_hi = u_hi*(two_pi/teeth) - alpha
         cf = merge(c2, 1.0_wp, pairs == 2)
      end subroutine set_zone

      !> A contact begins at approach velocity v: e (goldsmith) and D, eq. (3.12).
      subroutine begin_contact(v)
         real(wp), intent(in) :: v
         real(wp) :: vv, e
         vv = max(abs(v), v_min)
         e = min(max(1.0_wp - 0.019_wp*vv**0.48_wp, 0.0_wp), 1.0_wp)
         dcoef = 6.0_wp*(1.0_wp - e)*kg/(((2.0_wp*e - 1.0_wp)**2 + 3.0_wp)*vv)
      end subroutine begin_contact

      subroutine init_modes()
         real(wp) :: d
         call set_zone(y(1))
         d = rb*y(1) - rb*y(3)
         mode = 0
         if (d >= bh) mode = 1
         if (d <= -bh) mode = -1
         dcoef = 0.0_wp          ! closed at t_start: undamped (no approach velocity)
      end subroutine init_modes

      !> Update the modes at (t, y) while a guard is below zero.
      subroutine settle()
         real(wp) :: g(4), lo, hi, dd
         integer :: pass
         do pass = 1, 16
            call guards(t, y, g)
            if (.not. any(g < 0.0_wp)) return
            res%events = res%events + 1
            if (g(3) < 0.0_wp .or. g(4) < 0.0_wp) then
               lo = th_lo; hi = th_hi
               call set_zone(y(1))
               if (g(4) < 0.0_wp .and. th_hi <= hi) then
                  call set_zone(hi + 1.0e-12_wp*max(1.0_wp, abs(hi)))
               else if (g(3) < 0.0_wp .and. th_lo >= lo) then
                  call set_zone(lo - 1.0e-12_wp*max(1.0_wp, abs(lo)))
               end if
            end if
            dd = rb*y(2) - rb*y(4)
            select case (mode)
            case (0)
               if (g(1) < 0.0_wp) then
                  mode = 1; call begin_contact(dd)
               else if (g(2) < 0.0_wp) then
                  mode = -1; call begin_contact(-dd)
               end if
            case (1)
               if (g(1) < 0.0_wp) mode = 0
            case (-1)
               if (g(2) < 0.0_wp) mode = 0
            end select
         end do
      end subroutine settle

      !> Dense output of the step (RK4 continuous extension) at s in [0, h].
      subroutine dense(ss, x)
         real(wp), intent(in) :: ss
         real(wp), intent(out) :: x(6)
         real(wp) :: th, b1, b2, b4
         th = ss/h
         b1 = th*(1.0_wp - th*(1.5_wp - th*(2.0_wp/3.0_wp)))
         b2 = th*th*(1.0_wp - th*(2.0_wp/3.0_wp))
         b4 = th*th*(-0.5_wp + th*(2.0_wp/3.0_wp))
         x = y + h*(b1*k1 + b2*(d2 + d3) + b4*d4)
      end subroutine dense

      !> Guard j on the dense output at s.
      real(wp) function g_dense(j, ss) result(gv)
         integer, intent(in) :: j
         real(wp), intent(in) :: ss
         real(wp) :: x(6), g(4)
         call dense(ss, x)
         call guards(t + ss, x, g)
         gv = g(j)
      end function g_dense

      !> Guard j on the step map at s (the state into ys).
      real(wp) function g_map(j, ss) result(gv)
         integer, intent(in) :: j
         real(wp), intent(in) :: ss
         real(wp) :: g(4)
         if (ss == h) then
            ys = yn
         else
            call step(t, y, ss, ys)
            res%rhs_evals = res%rhs_evals + 3
            res%located = res%located + 3
         end if
         call guards(t + ss, ys, g)
         gv = g(j)
      end function g_map

      !> The earliest zero in (0, h] of the guards negative at the end of the
      !> step, to within tol; ys = RK4 step to it.
      subroutine locate(s_ev)
         real(wp), intent(out) :: s_ev
         real(wp) :: sj, s_best, g(4), gd
         integer :: j, jb, jl, pass
         s_best = h; jb = 0
         do j = 1, 4
            if (g1(j) < 0.0_wp) then
               sj = dense_root(j, max(g0(j), 0.0_wp), h, g1(j))
               if (sj < s_best .or. jb == 0) then
                  s_best = sj; jb = j
               end if
            end if
         end do
         s_ev = refine(jb, s_best, max(g0(jb), 0.0_wp), h, g1(jb))
         ! another guard below zero there may have crossed first
         do pass = 1, 4
            call guards(t + s_ev, ys, g)
            jl = jb
            jb = 0
            do j = 1, 4
               if (j == jl .or. .not. g(j) < 0.0_wp) cycle
               gd = g_dense(j, s_ev)
               if (.not. gd < 0.0_wp) gd = g(j)
               sj = dense_root(j, max(g0(j), 0.0_wp), s_ev, gd)
               if (sj < s_ev - tol) then
                  jb = j
                  exit
               end if
            end do
            if (jb == 0) exit
            s_ev = refine(jb, sj, max(g0(jb), 0.0_wp), s_ev, g(jb))
         end do
      end subroutine locate

      !> Zero of guard j on the dense output (Illinois) in [0, b0], from g = ga0
      !> at 0 to gb0 < 0 at b0.
      real(wp) function dense_root(j, ga0, b0, gb0) result(r)
         integer, intent(in) :: j
         real(wp), intent(in) :: ga0, b0, gb0
         real(wp) :: a, b, fa, fb, sm, fs
         integer :: it, side
         a = 0.0_wp; b = b0; fa = ga0; fb = gb0; side = 0
         do it = 1, 60
            if (b - a <= tol) exit
            sm = (a*fb - b*fa)/(fb - fa)
            sm = min(max(sm, a + 0.01_wp*(b - a)), b - 0.01_wp*(b - a))
            fs = g_dense(j, sm)
            if (fs < 0.0_wp) then
               b = sm; fb = fs
               if (side == -1) fa = 0.5_wp*fa
               side = -1
            else
               a = sm; fa = fs
               if (side == 1) fb = 0.5_wp*fb
               side = 1
            end if
         end do
         r = b
      end function dense_root

      !> Refine the zero of guard j on the step map inside [0, b0] (g(0) >= 0 >
      !> g(b0)) from the estimate s0: a Newton step with the dense output's
      !> slope, then secant steps, each aimed tol/2 past the zero; stops when the
      !> bracket is within tol or the secant of two step-map points puts the zero
      !> within 0.75 tol before a point where g < 0; Illinois after 8 points.
      !> ys holds the step to the returned point.
      real(wp) function refine(j, s0, ga0, b0, gb0) result(b)
         integer, intent(in) :: j
         real(wp), intent(in) :: s0, ga0, b0, gb0
         real(wp) :: a, fa, fb, sp, gp, sc, gc, r, dl, slope, yb(6)
         integer :: it, side
         logical :: have_b, have_r
         a = 0.0_wp; fa = ga0; b = b0; fb = gb0; side = 0
         sc = min(max(s0, a + 0.5_wp*tol), b)
         have_b = .false.; sp = 0.0_wp; gp = 0.0_wp; r = 0.0_wp
         do it = 1, 200
            gc = g_map(j, sc)
            if (gc < 0.0_wp) then
               b = sc; fb = gc; yb = ys; have_b = .true.
               if (side == -1) fa = 0.5_wp*fa
               side = -1
            else
               a = sc; fa = gc
               if (side == 1) fb = 0.5_wp*fb
               side = 1
            end if
            if (b - a <= tol) exit
            have_r = .false.
            if (it <= 8) then
               if (it > 1) then
                  if (gc /= gp) then
                     r = sc - gc*(sc - sp)/(gc - gp)
                     have_r = .true.
                  end if
               else
                  dl = 1.0e-3_wp*h
                  slope = (g_dense(j, sc + dl) - g_dense(j, sc - dl))/(2.0_wp*dl)
                  if (slope /= 0.0_wp) then
                     r = sc - gc/slope
                     have_r = .true.
                  end if
               end if
               if (have_r .and. gc < 0.0_wp) then
                  if (r <= b .and. b - r <= 0.75_wp*max(tol, t_res*abs(t + b)) .and. r > a) exit
               end if
            end if
            sp = sc; gp = gc
            if (have_r) have_r = r > a .and. r < b
            if (have_r) then
               sc = min(r + 0.5_wp*tol, b - 0.25_wp*tol)
               if (sc <= a) sc = 0.5_wp*(a + b)
            else
               sc = (a*fb - b*fa)/(fb - fa)
               sc = min(max(sc, a + 0.01_wp*(b - a)), b - 0.01_wp*(b - a))
            end if
         end do
         if (have_b) then
            ys = yb
         else
            gc = g_map(j, b)
         end if
      end function refine
   end subroutine ref_rig
end module bench_reference
