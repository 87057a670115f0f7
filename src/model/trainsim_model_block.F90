!> A block's plain RK4 steps of a simple model in one call (D-168):
!> `model_rk4_block`, the block loop (trainsim_model_block_loop.inc) with the
!> kernels of `model_rk4_stages` and `model_rhs_step_end`
!> (trainsim_model_rk4_kernels.inc) inlined, so that a step makes no call (no
!> frames, dispatch or argument lists a step); with energy tracking the same
!> loop in `rk4_block_energy` (trainsim_model_energy_kernels.F90, D-182). The
!> `module procedure` is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_block
   use trainsim_model_families, only: spring_ni, spring_nr, contact_ni, contact_nr, free_ni, free_nr, held_ni, held_nr
   use trainsim_model_families, only: chain_ni, chain_nr, ch_spring, ch_damper, ch_open, ch_ys, ch_unit
   use trainsim_kinds, only: i8
   implicit none

contains

   ! (at once, done false and no step, for a model it does not run)
   module procedure model_rk4_block
      integer :: j, i
      real(wp) :: t_grid, h, hh, h6, t4, s
      logical :: below
      associate (b => self%blk, r => self%blk%run)
         r%done = .false.
         r%pend = .false.
         if (.not. self%simple) return
         if (self%run%track_energy) then
            ! (the energy-tracking loop in a file of its own, D-182)
            call rk4_block_energy(self, t, y, k1, k2, k3, k4, ynew, g1, gw_i, gw)
            return
         end if
#define ENERGY 0
#include "trainsim_model_block_loop.inc"
#undef ENERGY
      end associate
   contains
#define RK4_INNER 1
#include "trainsim_model_rk4_kernels.inc"
#undef RK4_INNER
#include "trainsim_model_rk4_kernels.inc"
#include "trainsim_model_windows.inc"
   end procedure model_rk4_block
end submodule trainsim_model_block
