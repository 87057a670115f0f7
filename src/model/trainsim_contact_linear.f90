!> The contact law's deck keys, its linearised damping (modes, the dt bound: D-25,
!> D-55) and its elastic energy (the energy ledger): trainsim_contact's procedures
!> off the right-hand side's path, declared there.
submodule (trainsim_contact) trainsim_contact_linear
   implicit none

contains

   !> Read the contact-law keys shared by all clearance elements (declared in
   !> trainsim_contact). `v_scale` converts the element's approach velocity to a
   !> line speed in the deck's length unit (1 for gears and keys; a radius for an
   !> angular coupling).
   module procedure law_configure
      character(len=:), allocatable :: name
      real(wp) :: vmin_ips

      call grp%get_string('contact_law', name, err, default=default_law); if (allocated(err)) return
      select case (to_lower(name))
      case ('yang_sun'); self%law = law_yang_sun
      case ('linear'); self%law = law_linear
      case ('elasto_backlash'); self%law = law_elasto
      case default
         call fatal_error(err, grp%where('contact_law')//": error: unknown contact_law '"//name// &
                          "'; valid laws are: yang_sun, linear, elasto_backlash", err_input)
         return
      end select
      if (self%law == law_yang_sun) then
         call grp%get_string('restitution_law', name, err, default='goldsmith'); if (allocated(err)) return
         select case (to_lower(name))
         case ('goldsmith'); self%restitution_law = rest_goldsmith
         case ('smith'); self%restitution_law = rest_smith
         case ('constant')
            self%restitution_law = rest_constant
            call grp%get_real('restitution', self%e_const, err); if (allocated(err)) return
            if (.not. (self%e_const > 0.0_wp .and. self%e_const <= 1.0_wp)) then
               call fatal_error(err, grp%where('restitution')//': error: restitution must be in (0, 1], got '// &
                                str(self%e_const), err_input)
               return
            end if
         case default
            call fatal_error(err, grp%where('restitution_law')//": error: unknown restitution_law '"//name// &
                             "'; valid laws are: goldsmith, smith, constant", err_input)
            return
         end select
         ! 1e-3 in/s: below it eq. (3.12) is evaluated at this floor (D stays finite)
         call grp%get_real('min_approach_velocity', vmin_ips, err, default=1.0e-3_wp/(units%to_inch*v_scale))
         if (allocated(err)) return
         self%v_min = vmin_ips
         if (.not. self%v_min > 0.0_wp) then
            call fatal_error(err, grp%where('min_approach_velocity')//': error: must be > 0, got '// &
                             str(self%v_min), err_input)
            return
         end if
         call grp%get_real('initial_contact_velocity', self%v_initial, err, default=0.0_wp); if (allocated(err)) return
         ! deck values in D-28's range (D of eq. 3.12 divides by them); no element lists them in params()
         call check_magnitude(grp, 'min_approach_velocity', self%v_min, err)
         call check_magnitude(grp, 'initial_contact_velocity', self%v_initial, err); if (allocated(err)) return
         if (.not. self%v_initial >= 0.0_wp) then
            call fatal_error(err, grp%where('initial_contact_velocity')//': error: must be >= 0, got '// &
                             str(self%v_initial), err_input)
            return
         end if
      else
         call grp%get_real('contact_damping', self%c, err); if (allocated(err)) return
         ! in D-28's range like every parameter of the equations of motion (5e30 left CVODE
         ! crawling through a contact whose time constant is 1e-33 s; fuzz_decks deck 298)
         call check_magnitude(grp, 'contact_damping', self%c, err); if (allocated(err)) return
         if (.not. self%c >= 0.0_wp) then
            call fatal_error(err, grp%where('contact_damping')//': error: must be >= 0, got '//str(self%c), err_input)
            return
         end if
      end if
      call grp%get_logical('no_tension', self%no_tension, err, default=.false.); if (allocated(err)) return
      self%v_to_ips = units%to_inch*v_scale
   end procedure law_configure

   !> The smallest restitution the law gives for approach velocities from the
   !> floor min_approach_velocity up to the largest plausible one,
   !> v_plausible_ips (D-25). Both fits are monotone in V_i (goldsmith falls,
   !> smith rises), so it is the smaller of the two ends; constant is constant.
   pure real(wp) module function law_lowest_restitution(self) result(e)
      class(contact_law_t), intent(in) :: self
      if (self%restitution_law == rest_constant) then
         e = self%e_const
      else
         e = min(self%restitution(self%v_min), self%restitution(v_plausible_ips/self%v_to_ips))
      end if
   end function law_lowest_restitution

   !> Linearised damping along the contact normal (force per unit rate) of a
   !> closed contact with stiffness factor c and effective mass m_eff behind it
   !> (D-25). yang_sun: the force c D p pdot linearises to c D p; at the largest
   !> compression of an impact at V_i, p = V_i sqrt(m_eff/(c k)), and eq. (3.12)
   !> gives D V_i = phi(e) k with phi(e) = 6(1-e)/((2e-1)^2+3) <= 3/2, so
   !>   c D p = phi(e) sqrt(c k m_eff),
   !> independent of V_i except through e. `largest`: e is the law's lowest
   !> (any contact that may still begin), else the contact in progress's e.
   !> `scale` multiplies it (0..1). linear, elasto_backlash: the viscous d.
   !>
   !> A contact that closes gently and then carries a load is not bounded by
   !> that (D-55): at the static penetration p = F/(c k) its damping is
   !> c D p = phi(e(V)) F / V, with V as slow as the floor min_approach_velocity
   !> (or initial_contact_velocity, for a contact closed at t_start). With
   !> `largest` and f_load > 0 (the largest force the loads can drive through
   !> the contact), the larger of the two is taken; for the contact in progress
   !> (not `largest`), its own D at that penetration, c D p = D F / k.
   pure real(wp) module function law_linear_damping(self, c, m_eff, largest, scale, f_load) result(cd)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: c, m_eff, scale
      logical, intent(in) :: largest
      real(wp), intent(in), optional :: f_load
      real(wp) :: e, phi
      if (self%law == law_yang_sun) then
         if (largest) then
            e = self%lowest_restitution()
         else
            e = self%e
         end if
         phi = 6.0_wp*(1.0_wp - e)/((2.0_wp*e - 1.0_wp)**2 + 3.0_wp)    ! D V_i / k, eq. (3.12)
         cd = scale*phi*sqrt(c*self%k*m_eff)
         if (present(f_load)) then
            if (largest) then
               cd = max(cd, scale*self%gentle_damping(f_load))
            else if (self%k > 0.0_wp) then
               cd = max(cd, scale*self%d*f_load/self%k)    ! c D p at p = F/(c k): the contact in progress
            end if
         end if
      else
         cd = self%c
      end if
   end function law_linear_damping

   !> yang_sun: damping c D p of a contact closed at the slowest approach the law
   !> allows and carrying force f at its static penetration p = f/(c k):
   !> phi(e(V)) f / V (eq. (3.12)), V the floor min_approach_velocity or a
   !> smaller initial_contact_velocity (D-55). 0 for the other laws.
   pure real(wp) module function law_gentle_damping(self, f) result(cd)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: f
      cd = 0.0_wp
      if (self%law /= law_yang_sun .or. .not. f > 0.0_wp) return
      if (self%v_min > 0.0_wp) cd = phi_over_v(self%v_min)
      if (self%v_initial > 0.0_wp) cd = max(cd, phi_over_v(self%v_initial))
   contains
      pure real(wp) function phi_over_v(v) result(r)
         real(wp), intent(in) :: v
         real(wp) :: e
         e = self%restitution(v)
         r = 6.0_wp*(1.0_wp - e)/((2.0_wp*e - 1.0_wp)**2 + 3.0_wp)*f/v
      end function phi_over_v
   end function law_gentle_damping

   !> Elastic energy at penetration p (factor 1): k p^2/2, or the integral of the
   !> load-dependent key force: exact below the 100 lbf floor of the fit (linear
   !> there), 5-point Gauss-Legendre above it (smooth; the kink is the split point).
   pure real(wp) module function law_elastic_energy(self, p) result(e)
      class(contact_law_t), intent(in) :: self
      real(wp), intent(in) :: p
      real(wp), parameter :: x(5) = [-0.9061798459386640_wp, -0.5384693101056831_wp, 0.0_wp, &
                                     0.5384693101056831_wp, 0.9061798459386640_wp]
      real(wp), parameter :: w(5) = [0.2369268850561891_wp, 0.4786286704993665_wp, 0.5688888888888889_wp, &
                                     0.4786286704993665_wp, 0.2369268850561891_wp]
      real(wp) :: k100, dk, klin, pk, a
      integer :: i
      if (self%fit == fit_none) then
         e = 0.5_wp*self%k*p**2
         return
      end if
      call key_lineal_stiffness(self%fit, 100.0_wp, k100, dk)
      klin = k100*self%key_length_in*self%to_inch/self%to_lbf     ! force/length below 100 lbf
      pk = (100.0_wp/self%to_lbf)/klin                             ! penetration at 100 lbf
      if (abs(p) <= pk) then
         e = 0.5_wp*klin*p**2
         return
      end if
      a = sign(pk, p)
      e = 0.5_wp*klin*pk**2
      do i = 1, 5
         e = e + 0.5_wp*(p - a)*w(i)*self%fit_elastic_force(a + 0.5_wp*(p - a)*(x(i) + 1.0_wp))
      end do
   end function law_elastic_energy

   !> cl_torques and cl_dissipation at one state from one elastic force (one key
   !> fit, not two): bit for bit the two calls (s p is mode p, s f is mode f).
   pure module subroutine cl_torques_dissipation(self, c, thl, wl, thr, wr, tl, tr, pw)
      class(clearance_t), intent(in) :: self
      real(wp), intent(in) :: c, thl, wl, thr, wr
      real(wp), intent(out) :: tl, tr, pw
      real(wp) :: s, p, pdot, fel, f, fs
      fs = 0.0_wp
      pw = 0.0_wp
      if (self%mode /= 0) then
         s = real(self%mode, wp)
         p = s*(self%r1*thl - self%r2*thr) - self%b
         pdot = s*(self%r1*wl - self%r2*wr)
         fel = self%law%elastic_force(p)
         f = self%law%force_of(c, fel, p, pdot)
         fs = s*f
         pw = (f - c*fel)*pdot
      end if
      tl = -fs*self%r1
      tr = fs*self%r2
   end subroutine cl_torques_dissipation
end submodule trainsim_contact_linear
