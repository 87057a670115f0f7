!> The energy-tracking kernels of RK4 on a simple model, compiled apart from the
!> energy-off ones (D-160, D-169): RK4's inner stages (`rk4_energy_stages`), a
!> block's step end before its last (`column_energy_end`, D-120) and the block
!> loop (`rk4_block_energy`, D-182), each from the includes of the energy-off
!> path with ENERGY 1 (trainsim_model_rk4_kernels.inc and the stage kernel,
!> trainsim_model_stage.inc). Their `module procedure`s are declared, with their
!> arguments and their docs, in trainsim_model.
submodule (trainsim_model) trainsim_model_energy_kernels
   use trainsim_model_families, only: spring_ni, spring_nr, contact_ni, contact_nr, free_ni, free_nr, held_ni, held_nr
   use trainsim_model_families, only: chain_ni, chain_nr, ch_spring, ch_damper, ch_open, ch_ys, ch_unit
   use trainsim_kinds, only: i8
   implicit none

#define ENERGY 1
contains

   module procedure column_energy_end
      integer :: c
      c = self%blk%col
      associate (b => self%blk)
#define CE_K dydt
#define CE_C c
#include "trainsim_model_column_end.inc"
#undef CE_C
#undef CE_K
      end associate
   contains
#include "trainsim_model_rk4_kernels.inc"
   end procedure column_energy_end

   module procedure rk4_energy_stages
      real(wp) :: hh, h6
      self%ws_step_end = .false.
      hh = 0.5_wp*h
#include "trainsim_model_rk4_inner.inc"
      h6 = h/6.0_wp
      ynew = y + h6*(k1 + 2.0_wp*(k2 + k3) + k4)   ! (RK4's combination, as model_rk4_stages')
   contains
#define RK4_INNER 1
#include "trainsim_model_rk4_kernels.inc"
#undef RK4_INNER
   end procedure rk4_energy_stages

   module procedure rk4_block_energy
      integer :: j, i
      real(wp) :: t_grid, h, hh, h6, t4, s
      logical :: below
      associate (b => self%blk, r => self%blk%run)
#include "trainsim_model_block_loop.inc"
      end associate
   contains
#define RK4_INNER 1
#include "trainsim_model_rk4_kernels.inc"
#undef RK4_INNER
#include "trainsim_model_rk4_kernels.inc"
#include "trainsim_model_windows.inc"
   end procedure rk4_block_energy
#undef ENERGY
end submodule trainsim_model_energy_kernels
