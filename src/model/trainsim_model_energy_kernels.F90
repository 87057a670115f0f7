!> The energy-tracking step end of a block's step before its last (D-120): the
!> stage kernel (trainsim_model_stage.inc, ENERGY 1, STEP_END 3) in a procedure
!> of its own, so that the energy-off step end (`model_rhs_step_end`) is
!> compiled without it (D-160). Its `module procedure` is declared, with its
!> arguments and their docs, in trainsim_model.
submodule (trainsim_model) trainsim_model_energy_kernels
   use trainsim_model_families, only: spring_ni, spring_nr, contact_ni, contact_nr, free_ni, free_nr, held_ni, held_nr
   use trainsim_model_families, only: chain_ni, chain_nr, ch_spring, ch_damper, ch_open, ch_ys, ch_unit
   use trainsim_kinds, only: i8
   implicit none

contains

   module procedure column_energy_end
      integer :: c
      ! (the workspace's marks as `ws_mark` leaves them at a step's end with
      ! energy tracking; its stored energy is not written here, only the
      ! column's: the block's last step end writes the workspace, D-120)
      self%ws_step_end = .false.
      self%ws_t = t
      self%ws_energy = self%n_cold == 0
      c = self%blk%col
      associate (b => self%blk)
         if (self%fam%chain%n > 0) then
            call column_energy_chain(self%fam, self%fam%iw, self%fam%rw, self%elements, t, y, dydt, self%el_torque, &
                                     self%theta, self%omega, self%fam%pw, self%el_pe, self%ws_energy, b%stored(c), &
                                     b%elastic(c), b%disp(:, c), b%force(:, c), b%torque(:, c), b%omega(:, c))
         else
            call column_energy(self%fam, self%fam%iw, self%fam%rw, self%elements, t, y, dydt, self%el_torque, &
                               self%theta, self%omega, self%fam%pw, self%el_pe, self%ws_energy, b%stored(c), &
                               b%elastic(c), b%disp(:, c), b%force(:, c), b%torque(:, c), b%omega(:, c))
         end if
         b%t(c) = t
         b%work(1, c) = y(self%n_states + 1)
         b%work(2, c) = y(self%n_states + 2)
      end associate
   contains
      ! (and the chain's path alone, D-164; internal: each inlined at its one call)
#define STEP_END 3
#define ENERGY 1
#define KERNEL column_energy
#define CHAIN_KERNEL column_energy_chain
#include "trainsim_model_stage_chain.inc"
#undef CHAIN_KERNEL
#undef KERNEL
#undef ENERGY
#undef STEP_END
   end procedure column_energy_end

   module procedure rk4_energy_stages
      real(wp) :: hh, h6
      self%ws_step_end = .false.
      hh = 0.5_wp*h
      ! (the three stages through kernel K, spelled once)
#define STAGES(K) \
call K(self%fam, self%fam%iw, self%fam%rw, self%elements, t + hh, y, k2, self%el_torque, self%fam%th, self%fam%w, hh, k1, self%fam%pw); \
call K(self%fam, self%fam%iw, self%fam%rw, self%elements, t + hh, y, k3, self%el_torque, self%fam%th, self%fam%w, hh, k2, self%fam%pw); \
call K(self%fam, self%fam%iw, self%fam%rw, self%elements, t4, y, k4, self%el_torque, self%fam%th, self%fam%w, h, k3, self%fam%pw)
      if (self%fam%chain%n > 0) then
         STAGES(chain_energy_at)
      else
         STAGES(stage_energy_at)
      end if
#undef STAGES
      h6 = h/6.0_wp
      ynew = y + h6*(k1 + 2.0_wp*(k2 + k3) + k4)   ! (RK4's combination, as model_rk4_stages')
   contains
      ! the stage kernel at y + c k with energy tracking, and the chain's path
      ! alone (D-164; internal: each inlined at its one call)
#define FROM 1
#define STEP_END 0
#define ENERGY 1
#define KERNEL stage_energy_at
#define CHAIN_KERNEL chain_energy_at
#include "trainsim_model_stage_chain.inc"
#undef CHAIN_KERNEL
#undef KERNEL
#undef ENERGY
#undef STEP_END
#undef FROM
   end procedure rk4_energy_stages
end submodule trainsim_model_energy_kernels
