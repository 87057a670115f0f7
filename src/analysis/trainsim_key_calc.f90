!> Off-line calculator of a keyed joint's constants from its size and fit (Ch. IV,
!> eqs. 4.35-4.37): `trainsim key` prints its stiffness curve and a deck fragment
!> ready to paste. (The gear pair's calculator, trainsim_gear_calc, re-exports it.)
module trainsim_key_calc
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_units, only: units_t
   use trainsim_contact, only: key_lineal_stiffness, fit_tight, fit_loose, fit_average
   implicit none
   private

   public :: key_input_t, key_result_t, key_calc, key_report, key_max_points, unset

   !> Rows of `trainsim key`'s curve: 2 (its ends) to this many.
   integer, parameter :: key_max_points = 1000

   !> Marks an optional input that was not given.
   real(wp), parameter :: unset = -huge(1.0_wp)

   !> A keyed joint as `trainsim key` takes it (lengths in the input's units).
   type :: key_input_t
      type(units_t) :: units
      real(wp) :: diameter = unset
      real(wp) :: key_length = unset
      real(wp) :: key_width = unset, key_height = unset   !< optional: checked against d/4
      real(wp) :: clearance = 0.0_wp                      !< total, key to hub keyway
      real(wp) :: torque_max = unset                      !< top of the curve; default the fits' range
      integer :: fit = 0                                  !< fit_tight, fit_loose, fit_average; 0: all three
      integer :: points = 13
      character(len=:), allocatable :: id
   end type key_input_t

   !> The stiffness curve of Ch. IV: one row per torque.
   type :: key_result_t
      real(wp), allocatable :: torque(:)        !< joint torque (torque units)
      real(wp), allocatable :: key_force(:)     !< P = 2 T / d (force units)
      real(wp), allocatable :: lineal(:, :)     !< (row, fit): k_l(P), force/length per length of key
      real(wp), allocatable :: stiffness(:, :)  !< k_l L (force/length)
      real(wp), allocatable :: angular(:, :)    !< k_l L (d/2)^2 (torque/rad)
      real(wp), allocatable :: deflection(:, :) !< P / (k_l L) along the key face
      integer, allocatable :: fits(:)           !< the fits in the columns
      type(string_t), allocatable :: warnings(:)
   end type key_result_t

   character(len=*), parameter :: fit_names(3) = [character(len=7) :: 'tight', 'loose', 'average']

contains

   !> The keyed joint's stiffness curve (Ch. IV, eqs. 4.35-4.37) over the torques
   !> whose key force lies in the fitted range [100, 60000] lbf.
   subroutine key_calc(inp, res, err)
      type(key_input_t), intent(in) :: inp
      type(key_result_t), intent(out) :: res
      type(error_t), allocatable, intent(out) :: err
      real(wp) :: to_m, p_lo, p_hi, p, kl, dk, t_hi
      integer :: i, j, n

      allocate (res%warnings(0))
      if (inp%diameter == unset .or. inp%key_length == unset) then
         call fatal_error(err, 'key: error: the shaft diameter (--diameter) and the key length (--key-length) '// &
                          'are required', err_input)
         return
      end if
      if (.not. (inp%diameter > 0.0_wp .and. inp%key_length > 0.0_wp)) then
         call fatal_error(err, 'key: error: diameter and key length must be > 0, got '//str(inp%diameter)// &
                          ' and '//str(inp%key_length), err_input)
         return
      end if
      to_m = inp%units%to_inch*0.0254_wp
      if (inp%diameter*to_m < 1.0e-3_wp .or. inp%diameter*to_m > 2.0_wp) then
         call fatal_error(err, 'key: error: shaft diameter '//str(inp%diameter)//' '//inp%units%length//' ('// &
                          str(inp%diameter*to_m, 3)//' m): implausible; is it in the unit system''s length ('// &
                          inp%units%length//')?', err_input)
         return
      end if
      if (inp%key_length > 10.0_wp*inp%diameter .or. inp%key_length < 0.05_wp*inp%diameter) then
         call fatal_error(err, 'key: error: key length '//str(inp%key_length)//' '//inp%units%length// &
                          ' on a shaft of '//str(inp%diameter)//' '//inp%units%length//': is it in '// &
                          inp%units%length//'?', err_input)
         return
      end if
      if (.not. inp%clearance >= 0.0_wp .or. inp%clearance > 0.05_wp*inp%diameter) then
         call fatal_error(err, 'key: error: clearance '//str(inp%clearance)//' '//inp%units%length// &
                          ' must be >= 0 and small beside the diameter (a total clearance between key and hub '// &
                          'keyway, e.g. 0.002 in)', err_input)
         return
      end if
      if (inp%diameter*inp%units%to_inch < 0.75_wp .or. inp%diameter*inp%units%to_inch > 2.0_wp) &
         call kwarn('the fits of eqs. 4.35-4.37 were made for shafts of 0.750 to 2.000 in (FEM, Ch. IV); '// &
                    str(inp%diameter*inp%units%to_inch, 4)//' in is outside')
      if (inp%key_width /= unset) then
         if (abs(inp%key_width/inp%diameter - 0.25_wp) > 0.1_wp) &
            call kwarn('key width '//str(inp%key_width)//' is '//str(inp%key_width/inp%diameter, 3)// &
                       ' d; the fits are for standard square keys of width about d/4')
      end if
      if (inp%key_height /= unset .and. inp%key_width /= unset) then
         if (abs(inp%key_height/inp%key_width - 1.0_wp) > 0.35_wp) &
            call kwarn('key '//str(inp%key_width)//' x '//str(inp%key_height)//' is not square; the fits are '// &
                       'for square keys')
      end if

      if (inp%fit == 0) then
         res%fits = [fit_tight, fit_loose, fit_average]
      else
         res%fits = [inp%fit]
      end if
      ! key force range of the fits, in the unit system's force
      p_lo = 100.0_wp/inp%units%to_lbf
      p_hi = 60000.0_wp/inp%units%to_lbf
      t_hi = 0.5_wp*inp%diameter*p_hi
      if (inp%torque_max /= unset) then
         if (.not. inp%torque_max > 0.5_wp*inp%diameter*p_lo) then
            call fatal_error(err, 'key: error: --torque-max '//str(inp%torque_max)//' is below the fits'' range '// &
                             '(key force 100 lbf: '//str(0.5_wp*inp%diameter*p_lo, 4)//' '//inp%units%torque//')', &
                             err_input)
            return
         end if
         if (inp%torque_max > t_hi) call kwarn('--torque-max '//str(inp%torque_max)//' beyond the fits'' '// &
                                               'range (key force 60000 lbf); the stiffness is held there')
         t_hi = inp%torque_max
      end if
      if (inp%points < 2 .or. inp%points > key_max_points) then
         call fatal_error(err, 'key: error: --points must be a whole number in [2, '//str(key_max_points)// &
                          '] (rows of the curve), got '//str(inp%points), err_input)
         return
      end if
      n = inp%points
      allocate (res%torque(n), res%key_force(n))
      allocate (res%lineal(n, size(res%fits)), res%stiffness(n, size(res%fits)), &
                res%angular(n, size(res%fits)), res%deflection(n, size(res%fits)))
      do i = 1, n   ! geometric spacing: the fits change fastest at small loads
         res%torque(i) = 0.5_wp*inp%diameter*p_lo*(t_hi/(0.5_wp*inp%diameter*p_lo))**(real(i - 1, wp)/(n - 1))
         res%key_force(i) = res%torque(i)/(0.5_wp*inp%diameter)
         p = res%key_force(i)*inp%units%to_lbf
         do j = 1, size(res%fits)
            call key_lineal_stiffness(res%fits(j), p, kl, dk)       ! eqs. (4.35)-(4.37), lbf/in per in
            res%lineal(i, j) = kl*inp%units%to_inch**2/inp%units%to_lbf
            res%stiffness(i, j) = res%lineal(i, j)*inp%key_length
            res%angular(i, j) = res%stiffness(i, j)*(0.5_wp*inp%diameter)**2
            res%deflection(i, j) = res%key_force(i)/res%stiffness(i, j)
         end do
      end do
   contains
      subroutine kwarn(text)
         character(len=*), intent(in) :: text
         res%warnings = [res%warnings, string_t('key: warning: '//text)]
      end subroutine kwarn
   end subroutine key_calc

   !> Print the stiffness curve and a deck fragment.
   subroutine key_report(inp, res, unit)
      type(key_input_t), intent(in) :: inp
      type(key_result_t), intent(in) :: res
      integer, intent(in) :: unit
      character(len=:), allocatable :: l, id, line
      integer :: i, j
      l = inp%units%length
      id = 'key'
      if (allocated(inp%id)) id = inp%id
      write (unit, '(a)') 'keyed joint ('//inp%units%name//'; Ch. IV, eqs. 4.35-4.37): shaft '//str(inp%diameter)// &
         ' '//l//', key length '//str(inp%key_length)//' '//l//', half clearance '//str(0.5_wp*inp%clearance)//' '//l
      write (unit, '(a)') '  key force P = 2T/d; lineal stiffness k_l(P) per length of key; k = k_l L; '// &
         'angular k (d/2)^2'
      line = '  '//pad('torque', 12)//pad('key force', 12)
      do j = 1, size(res%fits)
         line = line//pad(trim(fit_names(res%fits(j)))//' k', 12)//pad('angular', 12)
      end do
      write (unit, '(a)') line
      line = '  '//pad(inp%units%torque, 12)//pad(inp%units%force, 12)
      do j = 1, size(res%fits)
         line = line//pad(inp%units%force//'/'//l, 12)//pad(inp%units%torque//'/rad', 12)
      end do
      write (unit, '(a)') line
      do i = 1, size(res%torque)
         line = '  '//pad(str(res%torque(i), 4), 12)//pad(str(res%key_force(i), 4), 12)
         do j = 1, size(res%fits)
            line = line//pad(str(res%stiffness(i, j), 4), 12)//pad(str(res%angular(i, j), 4), 12)
         end do
         write (unit, '(a)') line
      end do
      write (unit, '(a)') ''
      write (unit, '(a)') '! deck fragment (trainsim key): the keyed joint with the load-dependent fit'
      if (inp%units%name == 'si') write (unit, '(a)') "! needs &run units = 'si'"
      write (unit, '(a)') "&element id = '"//id//"', type = 'keyed_joint', diameter = "//str(inp%diameter)// &
         ', half_clearance = '//str(0.5_wp*inp%clearance)//','
      write (unit, '(a)') "   stiffness_fit = '"//trim(fit_names(res%fits(size(res%fits))))//"', key_length = "// &
         str(inp%key_length)//' /'
   contains
      pure function pad(s, w) result(o)
         character(len=*), intent(in) :: s
         integer, intent(in) :: w
         character(len=max(w, len(s) + 1)) :: o
         o = s
      end function pad
   end subroutine key_report
end module trainsim_key_calc
