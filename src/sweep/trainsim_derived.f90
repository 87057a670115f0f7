!> Derived parameters: values that are not one deck key but set several model
!> quantities consistently. All are keys of a gear element (spur or helical: one with
!> `teeth` on its driver):
!>
!> - `mesh_frequency` f (teeth/s): the driver gear turns at w = 2 pi f / N. Every node
!>   joined to it through elements (fixed nodes excepted) gets the kinematically
!>   consistent initial speed, carried through each element's speed ratio; every
!>   prescribed (`constant`) speed in that part of the train is set to its node's speed.
!>   With no prescribed speed there, only the initial speeds are set.
!> - `settle_cycles` n_s: run%settle_time = n_s / f.
!> - `measure_cycles` n_m: run%t_end = t_start + settle_time + n_m / f.
!> - `settle_max_cycles` n_b: run%settle_max_time = n_b / f (the settling budget,
!>   with `&run settle_tol`).
!>
!> Each of the three cycle keys also sets run%settle_period = 1 / f, the mesh period
!> at which a run with settle_tol compares its state (docs/sweeps.md#settling). After
!> each, the run's times are checked against the limits of &run (check_run_times), so
!> a cycle count cannot take a run beyond what `t_end` itself may be.
!>
!> f in the cycle counts is the pair's mesh frequency as the run starts (after any
!> `mesh_frequency`): from the driver's prescribed speed at t_start, else its initial speed.
module trainsim_derived
   use trainsim_kinds, only: wp, two_pi
   use trainsim_error, only: error_t, fatal_error, err_input
   use trainsim_strings, only: str, to_lower
   use trainsim_model, only: model_t, rigid_speeds
   use trainsim_signal, only: constant_signal
   use trainsim_param_list, only: param_list_t
   use trainsim_overrides, only: override_t, derived_keys
   use trainsim_deck, only: parse_real
   use trainsim_builder, only: check_run_times
   use trainsim_limits, only: in_range
   implicit none
   private

   public :: apply_derived, set_mesh_frequency, mesh_frequency_of, default_settle_period

contains

   !> Apply the derived overrides of `ovs` to `model`: every mesh_frequency first (in
   !> order), then settle_cycles, then measure_cycles, then settle_max_cycles.
   subroutine apply_derived(model, ovs, err)
      type(model_t), intent(inout) :: model
      type(override_t), intent(in) :: ovs(:)
      type(error_t), allocatable, intent(out) :: err
      integer :: pass, k, ie
      real(wp) :: v, f
      character(len=:), allocatable :: blame
      integer :: by_pass(size(derived_keys))   ! the override that set each pass's key (0: none)
      by_pass = 0

      do pass = 1, size(derived_keys)
         do k = 1, size(ovs)
            if (.not. ovs(k)%derived) cycle
            if (ovs(k)%key /= trim(derived_keys(pass))) cycle
            call value_of(ovs(k), v, err); if (allocated(err)) return
            ie = element_of(model, ovs(k)%target)
            if (ie == 0) then
               call fatal_error(err, ovs(k)%origin//": error: no element '"//ovs(k)%target//"'", err_input)
               return
            end if
            select case (pass)
            case (1)
               call set_mesh_frequency(model, ie, v, err)
               ! the builder's lists (D-175) kept: a mesh frequency sets speeds, not an element's
               ! parameters; the element it names asked again should it list one (D-183)
               if (allocated(model%element_params)) then
                  if (size(model%element_params) == size(model%elements)) &
                     model%element_params(ie) = model%elements(ie)%e%params()
               end if
            case default
               f = mesh_frequency_of(model, ie)
               if (.not. f > 0.0_wp) then
                  call fatal_error(err, "error: the mesh frequency of '"//ovs(k)%target// &
                                   "' is 0 as the run starts, so a time in mesh cycles is undefined", err_input)
               else
                  model%run%settle_period = 1.0_wp/f
                  select case (pass)
                  case (2)
                     model%run%settle_time = v/f
                  case (3)
                     model%run%t_end = model%run%t_start + model%run%settle_time + v/f
                  case default
                     model%run%settle_max_time = v/f
                  end select
                  if (pass == 3 .and. model%run%dt > model%run%t_end - model%run%t_start) &
                     call fatal_error(err, 'error: dt = '//str(model%run%dt)//' is longer than the run ('// &
                                      str(model%run%t_end - model%run%t_start)//' s)', err_input)
                  by_pass(pass) = k
               end if
            end select
            if (allocated(err)) then
               call blame_override(k)
               return
            end if
         end do
      end do
      ! the times the cycle keys set, against the limits of &run (once all are set)
      if (all(by_pass(2:) == 0)) return
      call check_run_times(model%run, blame, err)
      if (.not. allocated(err)) return
      select case (blame)
      case ('t_end'); k = by_pass(3)
      case ('settle_time'); k = by_pass(2)
      case default; k = by_pass(4)
      end select
      if (k == 0) k = maxval(by_pass(2:))
      err%message = 'error: &run '//blame//' (from '//ovs(k)%key//'): '//err%message
      call blame_override(k)
   contains
      subroutine blame_override(kk)
         integer, intent(in) :: kk
         if (index(err%message, 'error: ') == 1) then
            err%message = ovs(kk)%origin//': '//err%message
         else
            err%message = ovs(kk)%origin//': error: '//err%message
         end if
      end subroutine blame_override
   end subroutine apply_derived

   !> &run settle_tol or settle_time without a settle_period (and no cycle key that sets
   !> it): the mesh period at t_start of the first gear pair with teeth, then the run's
   !> times against the limits (the default budget is 1000 periods). With settle_tol, an
   !> error if there is no gear pair; with settle_time alone (a verdict at settle_time,
   !> D-44), no period and no verdict.
   subroutine default_settle_period(model, err)
      type(model_t), intent(inout) :: model
      type(error_t), allocatable, intent(out) :: err
      character(len=:), allocatable :: blame
      integer :: ie
      real(wp) :: f
      if (model%run%settle_period /= 0.0_wp) return
      if (.not. (model%run%settle_tol > 0.0_wp .or. model%run%settle_time > 0.0_wp)) return
      do ie = 1, size(model%elements)
         if (driver_teeth(model, ie) > 0.0_wp) exit
      end do
      f = 0.0_wp
      if (ie <= size(model%elements)) f = mesh_frequency_of(model, ie)
      if (.not. f > 0.0_wp .and. .not. model%run%settle_tol > 0.0_wp) return   ! no verdict at settle_time
      if (.not. f > 0.0_wp) then
         call fatal_error(err, 'error: &run settle_tol needs the period at which the state is compared: give '// &
                          '&run settle_period (s); no gear pair with teeth turns at t_start to give its mesh period', &
                          err_input)
         return
      end if
      model%run%settle_period = 1.0_wp/f
      call check_run_times(model%run, blame, err)
      if (allocated(err)) err%message = 'error: &run '//blame//' (with settle_period = '//str(1.0_wp/f)// &
                                        " s, the mesh period of '"//model%elements(ie)%e%id//"'): "//err%message
   end subroutine default_settle_period

   !> The single positive real value of a derived override.
   subroutine value_of(ov, v, err)
      type(override_t), intent(in) :: ov
      real(wp), intent(out) :: v
      type(error_t), allocatable, intent(out) :: err
      integer :: ios
      v = 0.0_wp
      if (size(ov%values) /= 1 .or. ov%quoted(1)) then
         call fatal_error(err, ov%origin//": error: key '"//ov%key//"': expected one real number", err_input)
         return
      end if
      call parse_real(ov%values(1)%s, v, ios)   ! checked as text first: 1e999 is refused, never converted
      if (ios == 2) then
         call fatal_error(err, ov%origin//": error: key '"//ov%key//"': '"//ov%values(1)%s// &
                          "' is beyond the range of double precision", err_input)
      else if (ios /= 0) then
         call fatal_error(err, ov%origin//": error: key '"//ov%key//"': expected a real number, got '"// &
                          ov%values(1)%s//"'", err_input)
      else if (.not. (v > 0.0_wp .and. v < huge(v))) then
         call fatal_error(err, ov%origin//": error: "//ov%key//' must be > 0, got '//ov%values(1)%s, err_input)
      end if
   end subroutine value_of

   integer function element_of(model, id) result(ie)
      type(model_t), intent(in) :: model
      character(len=*), intent(in) :: id
      integer :: i
      ie = 0
      do i = 1, size(model%elements)
         if (model%elements(i)%e%id == id) ie = i
      end do
      if (ie > 0) return
      ! element#k
      if (index(id, '#') > 1) then
         if (to_lower(id(1:index(id, '#') - 1)) == 'element') then
            read (id(index(id, '#') + 1:), *, iostat=i) ie
            if (i /= 0 .or. ie < 1 .or. ie > size(model%elements)) ie = 0
         end if
      end if
   end function element_of

   !> Teeth on the driver of element ie (0 if it is not a gear with teeth).
   real(wp) function driver_teeth(model, ie) result(n)
      type(model_t), intent(in) :: model
      integer, intent(in) :: ie
      type(param_list_t) :: p
      integer :: j
      n = 0.0_wp
      p = model%elements(ie)%e%params()
      if (.not. allocated(p%names)) return
      do j = 1, size(p%names)
         if (p%names(j)%s == 'teeth') n = p%values(j)
      end do
   end function driver_teeth

   !> Set the mesh frequency of gear element ie to f (teeth/s): initial speeds of the
   !> connected train and its prescribed constant speeds (see the module's note).
   subroutine set_mesh_frequency(model, ie, f, err)
      type(model_t), intent(inout) :: model
      integer, intent(in) :: ie
      real(wp), intent(in) :: f
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: w(:)
      logical, allocatable :: known(:)
      real(wp) :: teeth
      integer :: nn, i, loop_el

      teeth = driver_teeth(model, ie)
      associate (e => model%elements(ie)%e)
         if (.not. teeth > 0.0_wp) then
            call fatal_error(err, "error: element '"//e%id//"' of type '"//e%type_name// &
                             "' has no teeth; mesh_frequency needs a gear pair (spur_gear, helical_gear)", err_input)
            return
         end if
         if (model%nodes(e%left)%n%is_fixed()) then
            call fatal_error(err, "error: the driver of '"//e%id//"' is a fixed node", err_input)
            return
         end if
         if (.not. in_range(two_pi*f/teeth)) then
            call fatal_error(err, 'error: mesh_frequency = '//str(f)//" gives the driver of '"//e%id// &
                             "' a speed of "//str(two_pi*f/teeth)//' rad/s, beyond the magnitude limit of the deck''s '// &
                             'speeds (1e20)', err_input)
            return
         end if
         nn = size(model%nodes)
         call rigid_speeds(model, e%left, two_pi*f/teeth, w, known, loop_el)
      end associate
      if (loop_el > 0) then
         call fatal_error(err, "error: the speed ratios around a loop through element '"// &
                          model%elements(loop_el)%e%id//"' do not agree, so no speeds turn the whole train rigidly", &
                          err_input)
         return
      end if
      ! prescribed speeds in the connected part must be constant; set them
      do i = 1, nn
         if (.not. known(i)) cycle
         if (model%speed_of(i) == 0) cycle
         associate (s => model%speeds(model%speed_of(i)))
            if (s%label /= 'constant') then
               call fatal_error(err, "error: node '"//model%nodes(i)%n%id//"' has a prescribed speed of kind '"// &
                                s%label//"'; mesh_frequency can only set a constant one", err_input)
               return
            end if
         end associate
      end do
      do i = 1, nn
         if (.not. known(i)) cycle
         model%nodes(i)%n%omega0 = w(i)
         if (model%speed_of(i) /= 0) model%speeds(model%speed_of(i)) = constant_signal(w(i))
      end do
   end subroutine set_mesh_frequency

   !> Mesh frequency (teeth/s) of gear element ie as the run starts: from its driver's
   !> prescribed speed at t_start, else the driver's initial speed. 0 if not a gear.
   real(wp) function mesh_frequency_of(model, ie) result(f)
      type(model_t), intent(in) :: model
      integer, intent(in) :: ie
      real(wp) :: w
      integer :: nl
      nl = model%elements(ie)%e%left
      if (model%speed_of(nl) /= 0) then
         w = model%speeds(model%speed_of(nl))%value(model%run%t_start)
      else
         w = model%nodes(nl)%n%omega0
      end if
      f = abs(w)*driver_teeth(model, ie)/two_pi
   end function mesh_frequency_of
end module trainsim_derived
