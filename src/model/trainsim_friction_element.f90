!> The friction elements' common part (D-81; docs/elements.md "Friction"):
!> Coulomb, Stribeck and viscous friction (or a table against the relative
!> speed) between the left and right node (a fixed node for ground), with the
!> modes slipping forward (+1), slipping backward (-1) and stuck (0). Stuck,
!> the element declares the constraint wl - wr = 0 (row (1, -1)) and carries
!> the constraint torque lam (on the left node; -lam on the right) within its
!> static limit. Its guard: slipping, max(s (wl - wr), s (al - ar)) >= 0 (the
!> relative speed through zero with the relative acceleration against s: a
!> release from rest is not stopped by the integrator's error in the speed,
!> D-91; al, ar from the model, con%acc); stuck, limit - |lam|
!> >= 0 (one-way: -lam >= 0, and capacity + lam >= 0).
!>
!>   slipping torque f(v) = e(t) (Tc + (Ts - Tc) exp(-|v|/vs) + cv |v|)   (vs > 0)
!>                        = e(t) (Tc + cv |v|)                              (vs = 0)
!>                        = e(t) (table(|v|) + cv |v|)                      (a table)
!>   tl = -s f, tr = s f;  static limit e(t) Ts;  e(t) the engagement in [0, 1].
module trainsim_friction_element
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_deck, only: deck_group_t
   use trainsim_units, only: units_t
   use trainsim_param_list, only: param_list_t, make_param_list
   use trainsim_element, only: element_t
   use trainsim_controller, only: sequence_t, sequence_holds
   use trainsim_event, only: event_t, ev_stick, ev_slip_forward, ev_slip_backward
   implicit none
   private

   public :: friction_element_t, friction_configure, read_friction

   integer, parameter, public :: fm_stuck = 0, fm_forward = 1, fm_backward = -1

   !> A friction element; the concrete types choose the keys they accept.
   type, extends(element_t) :: friction_element_t
      real(wp) :: t_slide = 0.0_wp, t_static = 0.0_wp, v_s = 0.0_wp, visc = 0.0_wp
      real(wp), allocatable :: tab_v(:), tab_t(:)     !< friction torque against |relative speed|
      !> engagement: constant (eng0) or piecewise linear in time (eng_t, eng_v)
      real(wp) :: eng0 = 1.0_wp
      real(wp), allocatable :: eng_t(:), eng_v(:)
      !> a brake commanded by a &controller's positioning sequence (D-76, control):
      !> engagement 1 while the sequence holds, else 0 (set by the builder)
      type(sequence_t), pointer :: command => null()
      !> a freewheel: the left (driver) never turns faster than the right: locked
      !> (stuck, lam <= 0: it drives the right) or free (right overrunning, mode -1)
      logical :: one_way = .false.
      real(wp) :: capacity = huge(1.0_wp)             !< one-way: largest locked torque
      integer :: mode = fm_forward
   contains
      procedure :: configure => friction_configure
      procedure :: torques => friction_torques
      procedure :: dissipation_power => friction_dissipation
      procedure :: n_guards => friction_n_guards
      procedure :: guards => friction_guards
      procedure :: init_mode => friction_init_mode
      procedure :: update_mode => friction_update_mode
      procedure :: status => friction_status
      procedure :: params => friction_params
      procedure :: engagement => friction_engagement
      procedure :: limit => friction_limit
      procedure :: breakpoints => friction_breakpoints
   end type friction_element_t

contains

   !> Default configure: bearing friction's keys (no engagement).
   subroutine friction_configure(self, grp, units, err)
      class(friction_element_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      type(units_t), intent(in) :: units
      type(error_t), allocatable, intent(out) :: err
      associate (unused => units)
      end associate
      call read_friction(self, grp, .false., err)
   end subroutine friction_configure

   !> Read and check the friction keys (torque_sliding, torque_static,
   !> stribeck_speed, viscous, or friction_speeds + friction_torques) and, if
   !> `engaged`, the engagement (engagement, or engagement_times +
   !> engagement_values); every element with them may stick (`constrains`).
   subroutine read_friction(self, grp, engaged, err)
      class(friction_element_t), intent(inout) :: self
      type(deck_group_t), intent(inout) :: grp
      logical, intent(in) :: engaged
      type(error_t), allocatable, intent(out) :: err
      integer :: k
      logical :: has_table
      self%con%on = .true.                         ! stuck: the row wl - wr = 0 (D-81)
      self%con%g(1, 1:2) = [1.0_wp, -1.0_wp]
      has_table = grp%has('friction_speeds')
      if (grp%has('friction_torques')) has_table = .true.
      if (has_table) then
         call grp%get_real_array('friction_speeds', self%tab_v, err); if (allocated(err)) return
         call grp%get_real_array('friction_torques', self%tab_t, err); if (allocated(err)) return
         if (size(self%tab_v) /= size(self%tab_t) .or. size(self%tab_v) < 1) then
            call fatal_error(err, grp%where('friction_torques')//': error: friction_torques has '// &
                             str(size(self%tab_t))//' values for '//str(size(self%tab_v))//' friction_speeds', err_input)
            return
         end if
         do k = 1, size(self%tab_v)
            if (.not. self%tab_t(k) >= 0.0_wp) then
               call fatal_error(err, grp%where('friction_torques')//': error: friction_torques must be >= 0, got '// &
                                str(self%tab_t(k)), err_input)
               return
            end if
            if (k == 1) cycle
            if (.not. self%tab_v(k) > self%tab_v(k - 1)) then
               call fatal_error(err, grp%where('friction_speeds')//': error: friction_speeds must increase, got '// &
                                str(self%tab_v(k - 1))//' then '//str(self%tab_v(k)), err_input)
               return
            end if
         end do
         if (.not. self%tab_v(1) == 0.0_wp) then
            call fatal_error(err, grp%where('friction_speeds')//': error: friction_speeds must start at 0, got '// &
                             str(self%tab_v(1)), err_input)
            return
         end if
         self%t_slide = self%tab_t(1)
      else if (.not. self%one_way) then
         call grp%get_real('torque_sliding', self%t_slide, err); if (allocated(err)) return
      else
         call grp%get_real('torque_sliding', self%t_slide, err, default=0.0_wp); if (allocated(err)) return
      end if
      call grp%get_real('torque_static', self%t_static, err, default=self%t_slide); if (allocated(err)) return
      call grp%get_real('stribeck_speed', self%v_s, err, default=0.0_wp); if (allocated(err)) return
      call grp%get_real('viscous', self%visc, err, default=0.0_wp); if (allocated(err)) return
      call grp%require_nonnegative('torque_sliding', self%t_slide, err)
      call grp%require_nonnegative('torque_static', self%t_static, err)
      call grp%require_nonnegative('stribeck_speed', self%v_s, err)
      call grp%require_nonnegative('viscous', self%visc, err)
      if (allocated(err)) return
      if (self%t_static < self%t_slide .and. .not. self%one_way) then
         call fatal_error(err, grp%where('torque_static')//': error: torque_static must be >= the sliding torque '// &
                          str(self%t_slide)//' (the static limit is never below sliding friction), got '// &
                          str(self%t_static), err_input)
         return
      end if
      if (self%one_way) then
         call grp%get_real('capacity', self%capacity, err, default=huge(1.0_wp)); if (allocated(err)) return
         call grp%require_positive('capacity', self%capacity, err); if (allocated(err)) return
      end if
      if (.not. engaged) return
      has_table = grp%has('engagement_times')
      if (grp%has('engagement_values')) has_table = .true.
      if (has_table) then
         call grp%get_real_array('engagement_times', self%eng_t, err); if (allocated(err)) return
         call grp%get_real_array('engagement_values', self%eng_v, err); if (allocated(err)) return
         if (size(self%eng_t) /= size(self%eng_v) .or. size(self%eng_t) < 1) then
            call fatal_error(err, grp%where('engagement_values')//': error: engagement_values has '// &
                             str(size(self%eng_v))//' values for '//str(size(self%eng_t))//' engagement_times', err_input)
            return
         end if
         do k = 1, size(self%eng_t)
            call check_engagement(grp, 'engagement_values', self%eng_v(k), err); if (allocated(err)) return
            if (k == 1) cycle
            if (.not. self%eng_t(k) >= self%eng_t(k - 1)) then
               call fatal_error(err, grp%where('engagement_times')//': error: engagement_times must not decrease, got '// &
                                str(self%eng_t(k - 1))//' then '//str(self%eng_t(k)), err_input)
               return
            end if
         end do
      else
         call grp%get_real('engagement', self%eng0, err, default=1.0_wp); if (allocated(err)) return
         call check_engagement(grp, 'engagement', self%eng0, err)
      end if
   end subroutine read_friction

   subroutine check_engagement(grp, key, v, err)
      type(deck_group_t), intent(in) :: grp
      character(len=*), intent(in) :: key
      real(wp), intent(in) :: v
      type(error_t), allocatable, intent(out) :: err
      if (v >= 0.0_wp .and. v <= 1.0_wp) return
      call fatal_error(err, grp%where(key)//': error: '//key//' must be in [0, 1] (0 open, 1 fully engaged), got '// &
                       str(v), err_input)
   end subroutine check_engagement

   !> The engagement e(t) in [0, 1] at the element's t_now: the one place it is
   !> read (a controller that drives it would set it here).
   pure real(wp) function friction_engagement(self) result(e)
      class(friction_element_t), intent(in) :: self
      integer :: k, n
      real(wp) :: t, f
      if (associated(self%command)) then
         e = merge(1.0_wp, 0.0_wp, sequence_holds(self%command, self%con%t_now))
         return
      end if
      if (.not. allocated(self%eng_t)) then
         e = self%eng0
         return
      end if
      t = self%con%t_now
      n = size(self%eng_t)
      if (t <= self%eng_t(1)) then
         e = self%eng_v(1)
         return
      end if
      if (t >= self%eng_t(n)) then
         e = self%eng_v(n)
         return
      end if
      do k = 2, n
         if (t < self%eng_t(k)) exit
      end do
      f = (t - self%eng_t(k - 1))/(self%eng_t(k) - self%eng_t(k - 1))
      e = self%eng_v(k - 1) + f*(self%eng_v(k) - self%eng_v(k - 1))
   end function friction_engagement

   !> The engagement table's knots, where e(t) kinks (D-87): the driver
   !> stops there, so RK4 never steps across a kink (its order holds).
   pure subroutine friction_breakpoints(self, bp)
      class(friction_element_t), intent(in) :: self
      real(wp), allocatable, intent(out) :: bp(:)
      if (allocated(self%eng_t) .and. .not. associated(self%command)) then
         bp = self%eng_t
      else
         allocate (bp(0))
      end if
   end subroutine friction_breakpoints

   !> The static limit at t_now: e(t) Ts (a freewheel: its capacity).
   pure real(wp) function friction_limit(self) result(lim)
      class(friction_element_t), intent(in) :: self
      if (self%one_way) then
         lim = self%capacity
      else
         lim = self%engagement()*self%t_static
      end if
   end function friction_limit

   !> The slipping friction torque f(|v|) >= 0 (without the sign of the mode).
   pure real(wp) function slip_torque(self, v) result(f)
      class(friction_element_t), intent(in) :: self
      real(wp), intent(in) :: v
      integer :: k, n
      real(wp) :: a, w
      a = abs(v)
      if (allocated(self%tab_v)) then
         n = size(self%tab_v)
         if (a >= self%tab_v(n)) then
            f = self%tab_t(n)
         else
            do k = 2, n
               if (a < self%tab_v(k)) exit
            end do
            w = (a - self%tab_v(k - 1))/(self%tab_v(k) - self%tab_v(k - 1))
            f = self%tab_t(k - 1) + w*(self%tab_t(k) - self%tab_t(k - 1))
         end if
      else if (self%v_s > 0.0_wp) then
         f = self%t_slide + (self%t_static - self%t_slide)*exp(-a/self%v_s)   ! Stribeck
      else
         f = self%t_slide                                                     ! Coulomb
      end if
      f = f + self%visc*a
      if (.not. self%one_way) f = self%engagement()*f
   end function slip_torque

   pure subroutine friction_torques(self, thl, wl, thr, wr, tl, tr)
      class(friction_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr
      real(wp) :: f
      associate (u1 => thl, u2 => thr)
      end associate
      if (self%mode == fm_stuck) then
         tl = 0.0_wp                              ! the constraint torque lam is added by the model
         tr = 0.0_wp
         return
      end if
      f = real(self%mode, wp)*slip_torque(self, wl - wr)
      tl = -f
      tr = f
   end subroutine friction_torques

   !> Power of the slipping friction, -(tl wl + tr wr) = s f (wl - wr) (stuck: 0).
   pure real(wp) function friction_dissipation(self, thl, wl, thr, wr) result(p)
      class(friction_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp) :: tl, tr
      call self%torques(thl, wl, thr, wr, tl, tr)
      p = -(tl*wl + tr*wr)
   end function friction_dissipation

   pure integer function friction_n_guards(self) result(n)
      class(friction_element_t), intent(in) :: self
      associate (unused => self)
      end associate
      n = 1
   end function friction_n_guards

   !> Slipping: s (wl - wr) (the relative speed keeps the mode's sign); stuck:
   !> the static limit minus |lam| (one-way: lam, and capacity - lam).
   pure subroutine friction_guards(self, thl, wl, thr, wr, g)
      class(friction_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: g(:)
      associate (u1 => thl, u2 => thr)
      end associate
      if (self%mode /= fm_stuck) then   ! speed through zero against the acceleration (D-91)
         g(1) = max(real(self%mode, wp)*(wl - wr), real(self%mode, wp)*(self%con%acc(1) - self%con%acc(2)))
      else if (self%one_way) then
         g(1) = min(-self%con%lam(1), self%capacity + self%con%lam(1))
      else
         g(1) = self%limit() - abs(self%con%lam(1))
      end if
   end subroutine friction_guards

   !> Slipping in the direction of the relative speed; stuck at equal speeds
   !> (the first event then lets it slip if the limit cannot hold).
   subroutine friction_init_mode(self, thl, wl, thr, wr)
      class(friction_element_t), intent(inout) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      associate (u1 => thl, u2 => thr)
      end associate
      self%con%lam = 0.0_wp
      if (wl > wr .and. .not. self%one_way) then
         self%mode = fm_forward
      else if (wl < wr) then
         self%mode = fm_backward
      else
         self%mode = fm_stuck                      ! (a freewheel whose driver is faster: locked)
      end if
      self%con%n = merge(1, 0, self%mode == fm_stuck)
      self%con%want_acc = self%mode /= fm_stuck
   end subroutine friction_init_mode

   !> Slipping and the relative speed reached zero: stuck (the model then checks
   !> the constraint torque against the limit at once). Stuck and lam reached
   !> the limit: slipping against lam (the torque that held it); a freewheel
   !> free again (the right overrunning: mode -1).
   subroutine friction_update_mode(self, t, thl, wl, thr, wr, fired, ev, nev)
      class(friction_element_t), intent(inout) :: self
      real(wp), intent(in) :: t, thl, wl, thr, wr
      logical, intent(in) :: fired(:)
      type(event_t), intent(inout) :: ev(:)
      integer, intent(out) :: nev
      associate (u1 => t)
      end associate
      nev = 0
      if (.not. fired(1)) return
      nev = 1
      ev(1) = event_t()
      ev(1)%theta_left = thl; ev(1)%omega_left = wl; ev(1)%theta_right = thr; ev(1)%omega_right = wr
      ev(1)%displacement = thl - thr
      if (self%mode /= fm_stuck) then
         self%mode = fm_stuck
         self%con%n = 1
         self%con%want_acc = .false.
         ev(1)%kind = ev_stick
         ev(1)%force = self%con%lam(1)                 ! (the model sets the constraint torque once known)
         return
      end if
      ev(1)%force = self%con%lam(1)
      if (self%con%lam(1) < 0.0_wp .and. .not. self%one_way) then
         self%mode = fm_forward
         ev(1)%kind = ev_slip_forward
      else
         self%mode = fm_backward
         ev(1)%kind = ev_slip_backward
      end if
      self%con%lam = 0.0_wp
      self%con%n = 0
      self%con%want_acc = .true.      ! its guard reads the accelerations (released from rest)
   end subroutine friction_update_mode

   !> Relative angle, the torque on the right node (stuck: -lam, the constraint
   !> torque it carries; slipping: the friction torque), contact = the mode
   !> (0 stuck, +1 slipping forward, -1 slipping backward), pairs 0.
   pure subroutine friction_status(self, thl, wl, thr, wr, disp, force, contact, pairs)
      class(friction_element_t), intent(in) :: self
      real(wp), intent(in) :: thl, wl, thr, wr
      real(wp), intent(out) :: disp, force
      integer, intent(out) :: contact, pairs
      real(wp) :: tl
      disp = thl - thr
      if (self%mode == fm_stuck) then
         force = -self%con%lam(1)
      else
         call self%torques(thl, wl, thr, wr, tl, force)
      end if
      contact = self%mode
      pairs = 0
   end subroutine friction_status

   function friction_params(self) result(p)
      class(friction_element_t), intent(in) :: self
      type(param_list_t) :: p
      p = make_param_list([character(len=40) :: 'torque_sliding', 'torque_static', 'stribeck_speed', 'viscous', &
                           'engagement'], [self%t_slide, self%t_static, self%v_s, self%visc, self%eng0])
   end function friction_params
end module trainsim_friction_element
