!> A block's plain RK4 steps of a simple model without energy tracking in one
!> call (D-168): `model_rk4_block`, each step's inner stages, its combination
!> and its end in the block's column with the kernels of `model_rk4_stages` and
!> `model_rhs_step_end` (trainsim_model_rk4_kernels.inc) inlined in one loop, so
!> that a step makes no call (no frames, dispatch or argument lists a step). The
!> `module procedure` is declared, with its arguments and their docs, in
!> trainsim_model.
submodule (trainsim_model) trainsim_model_block
   use trainsim_model_families, only: spring_ni, spring_nr, contact_ni, contact_nr, free_ni, free_nr, held_ni, held_nr
   use trainsim_model_families, only: chain_ni, chain_nr, ch_spring, ch_damper, ch_open, ch_ys, ch_unit
   use trainsim_kinds, only: i8
   implicit none

contains

   ! The loop is `advance_block`'s (trainsim_int_rk4) from its step blk%col + 1,
   ! with the same tests in the same order; it hands back (done false) where
   ! that loop would ask for the grid's next point (grid_target) and returns
   ! at once (done false, no step) for a model it does not run.
   module procedure model_rk4_block
      integer :: j, i
      real(wp) :: t_grid, h, hh, h6, t4, s
      logical :: below
      associate (b => self%blk, r => self%blk%run)
         r%done = .false.
         r%pend = .false.
         if (.not. self%simple .or. self%run%track_energy) return
         do j = b%col + 1, b%cap
            t_grid = min(r%t0 + real(r%istep, wp)*r%dt, r%t_end)
            if (t >= t_grid - r%tiny_t) return
            r%done = .true.
            if (t_grid > r%t_goal .or. t_grid >= r%t_bp) return
            h = t_grid - t
            hh = 0.5_wp*h
            t4 = t + h
#include "trainsim_model_rk4_inner.inc"
            h6 = h/6.0_wp
            do i = 1, self%n_y
               ynew(i) = y(i) + h6*(k1(i) + 2.0_wp*(k2(i) + k3(i)) + k4(i))
            end do
            r%ns = j
            if (r%nw /= 0) then
               below = .true.
               if (r%nw > 0) below = windows_below(r%nw, gw_i, gw, ynew)
               if (below) below = model_guards_below(self, t + h, ynew, g1)
               if (below) then
                  r%pend = .true.
                  r%h = h
                  return
               end if
            end if
            ! y = ynew; the sum of |y(i)| in order (D-126, D-161)
            s = 0.0_wp
            do i = 1, self%n_y
               y(i) = ynew(i)
               s = s + abs(ynew(i))
            end do
            t = t_grid
            r%istep = r%istep + 1
            b%col = j
            ! `model_rhs_step_end` of a block's step before its last (D-120)
            self%ws_step_end = .false.
            self%ws_t = t
            self%ws_energy = .false.
            if (self%fam%chain%n > 0) then
               call column_chain(self%fam, self%fam%iw, self%fam%rw, self%elements, t, y, k1, self%el_torque, &
                                 self%theta, self%omega, b%disp(:, j), b%force(:, j), b%torque(:, j), b%omega(:, j))
            else
               call column_plain(self%fam, self%fam%iw, self%fam%rw, self%elements, t, y, k1, self%el_torque, &
                                 self%theta, self%omega, b%disp(:, j), b%force(:, j), b%torque(:, j), b%omega(:, j))
            end if
            b%t(j) = t
            if (.not. s <= r%y_limit .or. r%t_goal - t <= r%t_tol) return
            r%done = .false.
         end do
      end associate
   contains
#define RK4_INNER 1
#include "trainsim_model_rk4_kernels.inc"
#undef RK4_INNER
#include "trainsim_model_rk4_kernels.inc"
#include "trainsim_model_windows.inc"
   end procedure model_rk4_block
end submodule trainsim_model_block
