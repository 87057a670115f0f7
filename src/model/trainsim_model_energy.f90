!> The model's energy ledger: stored (kinetic, elastic, magnetic) energy and
!> the dissipated and input power of a part of the train.
!> Each `module procedure` here is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_energy
   use trainsim_model_families, only: nk_plain, nk_held
   use trainsim_ports, only: potential_at
   implicit none

contains

   module procedure model_potential_energy
      integer :: i, l, r
      e = 0.0_wp
      do i = 1, size(self%fe)
         l = self%fe(i)%l
         r = self%fe(i)%r
         if (self%fe(i)%linear) then
            e = e + 0.5_wp*self%fe(i)%k*(self%fe(i)%r1*self%theta(l) - self%fe(i)%r2*self%theta(r))**2
         else if (self%nport) then
            e = e + potential_at(self%elements(i)%e, self%theta)      ! (over its ports: D-73)
         else
            e = e + self%elements(i)%e%potential_energy(self%theta(l), self%theta(r))
         end if
      end do
   end procedure model_potential_energy

   module procedure model_part_power
      integer :: k, i, l, r, s
      real(wp) :: dv
      pdiss = 0.0_wp
      pin = 0.0_wp
      do i = 1, size(self%fl)
         l = self%fl(i)%node
         if (.not. in_der(l)) cycle   ! (on a held node too: the drive's power below counts it against)
         if (self%fl(i)%const) then
            pin = pin + self%fl(i)%v*self%omega(l)
         else
            pin = pin + self%loads(i)%at(t, self%omega(l))*self%omega(l)
         end if
      end do
      do k = 1, size(els)
         i = els(k)
         associate (e => self%fe(i))
            l = e%l
            r = e%r
            if (e%linear) then
               dv = e%r1*self%omega(l) - e%r2*self%omega(r)
               pdiss = pdiss + e%c*dv**2
            else
               pdiss = pdiss + self%elements(i)%e%dissipation_power(self%theta(l), self%omega(l), self%theta(r), &
                                                                    self%omega(r))
               if (self%elements(i)%e%supplies_power) pin = pin + self%elements(i)%e%input_power(self%theta(l), &
                                                             self%omega(l), self%theta(r), self%omega(r))
            end if
         end associate
      end do
      do k = 1, size(der)
         i = der(k)
         associate (nd => self%fn(i))
            select case (nd%kind)
            case (nk_plain)
               pdiss = pdiss + nd%d*self%omega(i)**2
            case (nk_held)
               if (nd%const_speed) then
                  pin = pin - self%torque(i)*self%omega(i)
               else
                  s = self%speed_of(i)
                  pin = pin + (self%nodes(i)%n%inertia()*self%speeds(s)%derivative(t) - self%torque(i))*self%omega(i)
               end if
            case default
               pdiss = pdiss + self%nodes(i)%n%dissipation_power(y)
               pin = pin + self%nodes(i)%n%input_power(t, y)
            end select
         end associate
      end do
   end procedure model_part_power

   module procedure model_stored_energy
      real(wp) :: pot
      call kinematics_all(self, t, y)
      call self%workspace_energy(y, e, pot)
   end procedure model_stored_energy

   module procedure model_workspace_energy
      integer :: i, l, r
      real(wp) :: pe
      e = 0.0_wp
      pot = 0.0_wp
      do i = 1, size(self%nodes)
         select case (self%fn(i)%kind)
         case (nk_plain)
            e = e + 0.5_wp*self%fn(i)%j*self%omega(i)**2
         case (nk_held)
            e = e + 0.5_wp*self%fn(i)%j*self%omega(i)**2     ! j: the held node's inertia
         case default
            e = e + self%nodes(i)%n%stored_energy(y)
         end select
      end do
      do i = 1, size(self%elements)
         l = self%fe(i)%l
         r = self%fe(i)%r
         if (self%fe(i)%linear) then
            pe = 0.5_wp*self%fe(i)%k*(self%fe(i)%r1*self%theta(l) - self%fe(i)%r2*self%theta(r))**2
         else if (self%nport) then
            pe = potential_at(self%elements(i)%e, self%theta)         ! (over its ports: D-73)
         else
            pe = self%elements(i)%e%potential_energy(self%theta(l), self%theta(r))
         end if
         pot = pot + pe
      end do
      e = e + pot   ! (the kinetic sum, then the elastic: the kernels' order, D-160)
   end procedure model_workspace_energy
end submodule trainsim_model_energy
