!> Rattle indices of a gear mesh from the literature (issue 26 item 5, D-134),
!> beside D-105's impacts per mesh cycle and open fraction:
!>
!> * The inertial rattle criterion of Brosey, Seaman, Johnson & Hamilton (Int. J. Vehicle
!>   Design 7(1/2), 1986, 45-66), as Singh, Xie & Comparin (J. Sound Vib. 131, 1989, Fig. 3)
!>   state it: the loose (driven) gear rattles when the inertial torque it needs to follow
!>   the driver's angular acceleration exceeds the drag torque that holds it on the driving
!>   flank,
!>
!>       R = J2 alpha1_max (r1/r2) / T_drag,   T_drag = |F_mean| r2,
!>
!>   J2 the driven node's inertia, alpha1_max the driver's largest |angular acceleration|
!>   over the metrics window (reflected to the driven gear by the base radii r1/r2), F_mean
!>   the mean mesh force over the window's whole mesh cycles (in a settled window the mean
!>   of every torque that drags the loose gear: a load, a damper, a shaft further on).
!>   Rattle is expected above 1.
!> * An impact-energy index: the kinetic energy of the relative motion at each impact,
!>   E_i = 1/2 m_eq V_i^2, V_i the approach velocity along the line of action at the
!>   contact onset and m_eq = 1 / (r1^2/J1 + r2^2/J2) the mesh's equivalent mass from its
!>   two gear inertias (a held or fixed node: J infinite, its term 0); summed over the
!>   window's impacts, per whole mesh cycle (`rattle_energy`) and per second
!>   (`rattle_power`).
!>
!> Undefined values are NaN (documented in docs/output-format.md): the criterion with
!> F_mean = 0 (no drag) or a driven node without an inertia of its own (held or fixed); the
!> energy with both nodes held (m_eq infinite) and at least one impact. 0 where nothing was
!> tracked (no whole mesh cycle, an element that is no gear mesh), as D-105's indices.
module trainsim_rattle
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
   use trainsim_kinds, only: wp
   use trainsim_model, only: model_t
   use trainsim_param_list, only: param_list_t, param_of
   implicit none
   private

   public :: rattle_mesh_t, rattle_mesh, rattle_criterion, impact_energy

   !> What a mesh's rattle indices need of the model.
   type :: rattle_mesh_t
      real(wp) :: j_loose = 0.0_wp    !< the driven (loose) gear's inertia; 0: held or fixed
      real(wp) :: r1 = 0.0_wp, r2 = 0.0_wp   !< base radii of driver and driven gear
      !> 1 / m_eq = r1^2/J1 + r2^2/J2 (a held or fixed node's term 0); 0: both held
      real(wp) :: inv_meq = 0.0_wp
   end type rattle_mesh_t

contains

   !> The rattle constants of element i (a gear mesh with rb_driver, rb_driven).
   function rattle_mesh(model, i) result(c)
      type(model_t), intent(in) :: model
      integer, intent(in) :: i
      type(rattle_mesh_t) :: c
      type(param_list_t) :: p
      real(wp) :: j1
      integer :: l, r
      p = model%elements(i)%e%params()
      c%r1 = param_of(p, 'rb_driver', 0.0_wp); c%r2 = param_of(p, 'rb_driven', 0.0_wp)
      l = model%elements(i)%e%left; r = model%elements(i)%e%right
      j1 = own_inertia(model, l)
      c%j_loose = own_inertia(model, r)
      c%inv_meq = 0.0_wp
      if (j1 > 0.0_wp) c%inv_meq = c%r1**2/j1
      if (c%j_loose > 0.0_wp) c%inv_meq = c%inv_meq + c%r2**2/c%j_loose
   end function rattle_mesh

   !> Brosey's ratio J2 alpha1 (r1/r2) / (|f_mean| r2) (module note); NaN when undefined.
   pure real(wp) function rattle_criterion(c, alpha1, f_mean) result(ratio)
      type(rattle_mesh_t), intent(in) :: c
      real(wp), intent(in) :: alpha1, f_mean
      if (.not. (c%j_loose > 0.0_wp .and. c%r2 > 0.0_wp .and. abs(f_mean) > 0.0_wp)) then
         ratio = ieee_value(1.0_wp, ieee_quiet_nan)
         return
      end if
      ratio = c%j_loose*abs(alpha1)*(c%r1/c%r2)/(abs(f_mean)*c%r2)
   end function rattle_criterion

   !> The impact energy m_eq * half_v2 (half_v2: the sum of V_i^2 / 2); NaN for m_eq
   !> infinite (both nodes held) with an impact, 0 without one.
   pure real(wp) function impact_energy(c, half_v2) result(e)
      type(rattle_mesh_t), intent(in) :: c
      real(wp), intent(in) :: half_v2
      e = 0.0_wp
      if (.not. half_v2 > 0.0_wp) return
      if (c%inv_meq > 0.0_wp) then
         e = half_v2/c%inv_meq
      else
         e = ieee_value(1.0_wp, ieee_quiet_nan)
      end if
   end function impact_energy

   !> A node's own inertia, 0 if it is held (a prescribed motion) or fixed.
   real(wp) function own_inertia(model, n) result(j)
      type(model_t), intent(in) :: model
      integer, intent(in) :: n
      j = 0.0_wp
      if (model%is_held(n) .or. model%nodes(n)%n%is_fixed()) return
      j = max(0.0_wp, model%nodes(n)%n%inertia())
   end function own_inertia
end module trainsim_rattle
