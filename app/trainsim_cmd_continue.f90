!> trainsim continue: the periodic orbit of a deck followed in a deck parameter by
!> pseudo-arclength continuation (src/periodic/trainsim_arclength.f90,
!> docs/periodic.md "Continuation"), its folds and other bifurcations, each
!> point's multipliers and stability, written as a branch file (text, one row a
!> point) as it grows, so that a killed run continues with --resume.
module trainsim_cmd_continue
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t
   use trainsim_strings, only: str
   use trainsim_model, only: model_t
   use trainsim_deck, only: deck_t, deck_group_t, read_deck
   use trainsim_overrides, only: override_t, parse_set_argument, split_sweep_groups
   use trainsim_prepare, only: prepare_model
   use trainsim_derived, only: apply_derived, default_settle_period
   use trainsim_observer, only: run_result_t, make_meta
   use trainsim_sink, only: null_sink_t, run_meta_t
   use trainsim_period_map, only: period_map_t, forcing_period
   use trainsim_orbit, only: orbit_run
   use trainsim_arclength, only: branch_problem_t, branch_options_t, branch_point_t, branch_t, continue_branch, &
                                 branch_done, branch_stale, switch_period_doubling
   use trainsim_branch_file, only: branch_file_t
   use trainsim_sweep_layout, only: sweep_layout_t, element_metric_names, element_record
   use trainsim_sweep, only: fingerprint
   use trainsim_version, only: version_full
   use trainsim_cli, only: nargs, arg, quit, fail, add_set, real_value, text_value, deck_path, sets
   use trainsim_cmd_help, only: continue_usage
   use trainsim_monodromy_map, only: monodromy_code
   use trainsim_clearance_element, only: clearance_element_t
   implicit none
   private

   public :: do_continue

   !> the deck at a value of one key (an override TARGET.KEY=value after the --set ones)
   type, extends(branch_problem_t) :: deck_problem_t
      type(deck_t) :: deck
      type(override_t), allocatable :: ovs(:)
      character(len=:), allocatable :: key
      real(wp) :: lam_first = 0.0_wp
      !> the key is a mesh_frequency and no --set sets a derived key: a model is retuned
      !> to another lambda without building the deck (D-131)
      logical :: retunes = .false.
      logical :: period_from_mesh = .false.   !< no settle_period in &run or --set: the mesh period's
   contains
      procedure :: model_at => deck_model_at
      procedure :: retune => deck_retune
   end type deck_problem_t

   type(deck_problem_t), save :: prob
   type(branch_file_t), save :: bfile
   type(sweep_layout_t), save :: blay     !< the branch file's layout (also for --switch-pd's)
   integer, save :: bn = 0                 !< its states
   integer, save :: n_memory(2) = 0        !< its memory values and elements (yang_sun's D, e, V_i: D-150)
   character(len=:), allocatable, save :: out_path
   integer, save :: kperiods = 1
   !> points whose t0 lies in a contact that came from an impact (orbit_run's `stale`, D-144)
   integer, save :: n_stale = 0
   real(wp), save :: stale_lam(2) = 0.0_wp
   character(len=:), allocatable, save :: stale_id

contains

   subroutine deck_model_at(self, lam, model, err)
      class(deck_problem_t), intent(in) :: self
      real(wp), intent(in) :: lam
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      type(override_t) :: ov
      call lam_override(self, lam, ov, err)
      if (.not. allocated(err)) call prepare_model(self%deck, [self%ovs, ov], model, err)
   end subroutine deck_model_at

   !> The override key = lam.
   subroutine lam_override(self, lam, ov, err)
      class(deck_problem_t), intent(in) :: self
      real(wp), intent(in) :: lam
      type(override_t), intent(out) :: ov
      type(error_t), allocatable, intent(out) :: err
      character(len=32) :: buf
      write (buf, '(es25.17)') lam
      call parse_set_argument(self%key//'='//trim(adjustl(buf)), ov, err)
   end subroutine lam_override

   !> A model of this deck at another mesh frequency, set to lam as prepare_model sets
   !> it (the derived parameter applied, the fast-path tables built again, the mesh
   !> period as the settle period when the deck gives none): D-131.
   subroutine deck_retune(self, lam, model, done, err)
      class(deck_problem_t), intent(in) :: self
      real(wp), intent(in) :: lam
      type(model_t), intent(inout) :: model
      logical, intent(out) :: done
      type(error_t), allocatable, intent(out) :: err
      type(override_t) :: ov
      done = .false.
      if (.not. self%retunes .or. model%run%preload) return
      call lam_override(self, lam, ov, err)
      if (.not. allocated(err)) call apply_derived(model, [ov], err)
      if (allocated(err)) return
      call model%build_fast_path()
      if (self%period_from_mesh) then
         model%run%settle_period = 0.0_wp
         call default_settle_period(model, err)
      end if
      done = .not. allocated(err)
   end subroutine deck_retune

   !> Whether lambda can be retuned in a model (deck_retune): the key is a
   !> mesh_frequency and no --set sets a derived key; and whether the deck gives a
   !> settle period (&run or --set run.settle_period).
   subroutine retune_setup(p)
      type(deck_problem_t), intent(inout) :: p
      type(override_t) :: ov
      type(error_t), allocatable :: err
      integer :: g, e
      call lam_override(p, p%lam_first, ov, err)
      if (allocated(err)) return
      p%retunes = ov%derived .and. ov%key == 'mesh_frequency'
      if (size(p%ovs) > 0) p%retunes = p%retunes .and. .not. any(p%ovs(:)%derived)
      p%period_from_mesh = .true.
      do g = 1, size(p%deck%groups)
         if (p%deck%groups(g)%name /= 'run') cycle
         do e = 1, p%deck%groups(g)%nentries()
            if (p%deck%groups(g)%key_of(e) == 'settle_period') p%period_from_mesh = .false.
         end do
      end do
      do g = 1, size(p%ovs)
         if (p%ovs(g)%key == 'settle_period') p%period_from_mesh = .false.
      end do
   end subroutine retune_setup

   !> trainsim continue DECK --param TARGET.KEY=FROM:TO [options] [-o FILE [--resume]]
   subroutine do_continue()
      type(branch_options_t) :: opt
      type(branch_t) :: br, old
      type(error_t), allocatable :: err
      type(deck_group_t), allocatable :: sweeps(:)
      type(sweep_layout_t) :: lay
      character(len=:), allocatable :: param
      real(wp) :: lam0, lam1
      logical :: resume, switch_pd
      integer :: i, n, n_failed, n_released
      character(len=:), allocatable :: rel
      deck_path = ''
      switch_pd = .false.
      out_path = ''
      param = ''
      resume = .false.
      allocate (sets(0))
      i = 2
      do while (i <= nargs)
         select case (arg(i))
         case ('-h', '--help')
            call continue_usage(output_unit)
            call quit(0)
         case ('-o', '--output')
            out_path = text_value(i)
            i = i + 1
         case ('--param')
            param = text_value(i)
            i = i + 1
         case ('--resume')
            resume = .true.
         case ('--ds')
            opt%ds = positive(i)
            i = i + 1
         case ('--ds-max')
            opt%ds_max = positive(i)
            i = i + 1
         case ('--ds-min')
            opt%ds_min = positive(i)
            i = i + 1
         case ('--points')
            opt%max_points = nint(positive(i))
            i = i + 1
         case ('--period-count')
            opt%k = nint(positive(i))
            i = i + 1
         case ('--transient')
            opt%shoot%transient = nint(real_value(i))
            i = i + 1
         case ('--restarts')
            opt%restarts = nint(real_value(i))
            if (opt%restarts < 0) call refuse('option --restarts needs a count >= 0, got '//arg(i + 1))
            i = i + 1
         case ('--restart-step')
            opt%restart_step = positive(i)
            i = i + 1
         case ('--newton')
            opt%shoot%max_newton = nint(positive(i))
            i = i + 1
         case ('--retries')
            opt%shoot%retries = nint(real_value(i))
            i = i + 1
         case ('--corrector')
            opt%max_corrector = nint(positive(i))
            i = i + 1
         case ('--monodromy')
            opt%monodromy = monodromy_code(text_value(i))
            i = i + 1
            if (opt%monodromy < 0) call refuse("option --monodromy needs auto, saltation or fd, got '"//arg(i)//"'")
         case ('--smooth')
            opt%nonsmooth = .false.
         case ('--switch-pd')
            switch_pd = .true.
         case ('--set')
            call add_set(i)
            i = i + 1
         case default
            if (index(arg(i), '-') == 1 .or. len(deck_path) > 0) &
               call refuse("unexpected argument '"//arg(i)//"' (try trainsim continue --help)")
            deck_path = arg(i)
         end select
         i = i + 1
      end do
      if (len(deck_path) == 0) call refuse('no deck given (usage: trainsim continue DECK --param TARGET.KEY=FROM:TO)')
      call parse_param(param, prob%key, lam0, lam1)
      prob%lam_first = lam0
      if (resume .and. len(out_path) == 0) call refuse('--resume needs -o FILE (the branch to continue)')
      opt%lam_min = min(lam0, lam1)
      opt%lam_max = max(lam0, lam1)
      opt%direction = merge(1, -1, lam1 >= lam0)
      kperiods = opt%k
      call read_deck(deck_path, prob%deck, err)
      if (allocated(err)) call fail(err)
      call split_sweep_groups(prob%deck, sweeps)
      prob%ovs = sets
      call retune_setup(prob)
      write (output_unit, '(a)') 'trainsim continue: '//deck_path//', '//prob%key//' from '//str(lam0)//' to '//str(lam1)
      write (output_unit, '(a)') '      lambda            period        max|mu|     stability  corrector  bifurcation'
      if (len(out_path) > 0) then
         call branch_layout(prob%deck, lam0, opt, param, lay, n, err)
         if (.not. allocated(err)) call bfile%open(out_path, lay, n, prob%key, resume, err, period_count=opt%k, &
                                                   memory=n_memory)
         blay = lay
         bn = n
         if (allocated(err)) call fail(err)
      end if
      if (resume) then
         call bfile%read(old, err)
         if (allocated(err)) call close_fail(err)
         opt%k = bfile%period_count   ! (a doubled branch's 2k, from its file: D-122)
         kperiods = opt%k
         write (output_unit, '(a)') 'resumed after '//str(size(old%pts))//' stored points'
         call continue_branch(prob, lam0, opt, br, err, resume=old, hook=on_point)
      else if (len(out_path) > 0) then
         call continue_branch(prob, lam0, opt, br, err, hook=on_point)
      else
         call continue_branch(prob, lam0, opt, br, err, hook=print_point)
      end if
      if (allocated(err)) call close_fail(err)
      call bfile%close()
      n_failed = count(br%pts%status /= branch_done)
      n_released = released_count(br%pts)
      rel = ''
      if (n_released > 0) rel = ', '//str(n_released)//' of them stale with an orbit stored at the same value'
      write (output_unit, '(a)') str(size(br%pts))//' points ('//str(n_failed)//' failed'//rel//'), '//str(br%maps)// &
         ' period maps, '//str(br%rejected)//' steps refused, '//str(br%passes)//' variational passes'
      if (br%status == branch_done .and. allocated(br%message)) then
         if (len(br%message) > 0) write (output_unit, '(a)') br%message
      end if
      if (switch_pd) call doubled_branch(br, opt)
      if (br%status /= branch_done) then
         write (error_unit, '(a)') 'trainsim: continue: the branch stopped early (status '//str(br%status)//'): '// &
            br%message
         call quit(1)
      else if (n_failed > n_released) then
         write (error_unit, '(a)') 'trainsim: continue: the branch reached the end of its range, with '// &
            str(n_failed - n_released)//' failed points without an orbit at their value (their reasons '// &
            'above and in the branch file)'
         call quit(1)
      end if
   end subroutine do_continue

   !> Stale points (reason 6) released: the next stored point an orbit at the same value
   !> (D-188). They are failed points of the stale map, not of the branch: the branch holds
   !> an orbit at each of them, so they alone do not make the exit status 1.
   integer function released_count(pts) result(n)
      type(branch_point_t), intent(in) :: pts(:)
      integer :: i
      n = 0
      do i = 1, size(pts) - 1
         if (pts(i)%status == branch_stale .and. pts(i + 1)%status == branch_done .and. &
             pts(i + 1)%lam == pts(i)%lam) n = n + 1
      end do
   end function released_count

   subroutine close_fail(err)
      type(error_t), intent(in) :: err
      call bfile%close()
      call fail(err)
   end subroutine close_fail

   !> --switch-pd: the period-doubled branch from the branch's first period-doubling
   !> point, printed and (with -o FILE) written to FILE with '.pd2' before its
   !> extension (its period count in the file: resumed with the first's options, D-122).
   subroutine doubled_branch(br, opt)
      type(branch_t), intent(in) :: br
      type(branch_options_t), intent(in) :: opt
      type(branch_t) :: br2
      type(error_t), allocatable :: err
      integer :: i, ipd, dot
      ipd = 0
      do i = size(br%pts), 1, -1
         if (br%pts(i)%kind == 'period-doubling') ipd = i
      end do
      if (ipd == 0) then
         write (output_unit, '(a)') 'no period-doubling point on the branch: nothing to switch onto'
         return
      end if
      write (output_unit, '(a)') 'the period-doubled branch from lambda = '//str(br%pts(ipd)%lam, 12)//':'
      if (len(out_path) > 0) then
         dot = index(out_path, '.', back=.true.)
         if (dot <= index(out_path, '/', back=.true.)) dot = len(out_path) + 1
         out_path = out_path(1:dot - 1)//'.pd2'//out_path(dot:)
         kperiods = 2*opt%k
         call bfile%open(out_path, blay, bn, prob%key, .false., err, period_count=kperiods, memory=n_memory)
         if (allocated(err)) call fail(err)
         call switch_period_doubling(prob, br, ipd, opt, br2, err, hook=on_point)
         call bfile%close()
      else
         call switch_period_doubling(prob, br, ipd, opt, br2, err, hook=print_point)
      end if
      if (allocated(err)) call fail(err)
      write (output_unit, '(a)') str(size(br2%pts))//' points, '//str(br2%maps)//' period maps, '// &
         str(br2%rejected)//' steps refused'
      if (br2%status /= branch_done) then
         write (error_unit, '(a)') 'trainsim: continue: the doubled branch stopped early (status '// &
            str(br2%status)//'): '//br2%message
         call quit(1)
      end if
   end subroutine doubled_branch

   real(wp) function positive(k) result(x)
      integer, intent(in) :: k
      x = real_value(k)
      if (.not. x > 0.0_wp) call refuse('option '//arg(k)//' needs a value > 0, got '//arg(k + 1))
   end function positive

   subroutine refuse(msg)
      character(len=*), intent(in) :: msg
      write (error_unit, '(a)') 'trainsim: continue: error: '//msg
      call quit(2)
   end subroutine refuse

   !> TARGET.KEY=FROM:TO
   subroutine parse_param(text, key, lam0, lam1)
      character(len=*), intent(in) :: text
      character(len=:), allocatable, intent(out) :: key
      real(wp), intent(out) :: lam0, lam1
      integer :: peq, pc, ios
      peq = index(text, '=')
      pc = index(text, ':', back=.true.)
      if (len(text) == 0 .or. peq < 2 .or. pc < peq + 2 .or. pc == len(text) .or. index(text(1:peq), '.') < 2) &
         call refuse("--param needs TARGET.KEY=FROM:TO (e.g. mesh.mesh_frequency=385:645), got '"//text//"'")
      key = text(1:peq - 1)
      read (text(peq + 1:pc - 1), *, iostat=ios) lam0
      if (ios == 0) read (text(pc + 1:), *, iostat=ios) lam1
      if (ios /= 0 .or. .not. (abs(lam0) < huge(1.0_wp) .and. abs(lam1) < huge(1.0_wp)) .or. lam0 == lam1) &
         call refuse("--param needs two different numbers FROM:TO, got '"//text(peq + 1:)//"'")
   end subroutine parse_param

   !> One point on standard output.
   subroutine print_point(br, i, err)
      type(branch_t), intent(in) :: br
      integer, intent(in) :: i
      type(error_t), allocatable, intent(out) :: err
      if (i == 0) return
      if (br%pts(i)%status /= branch_done) then
         write (output_unit, '(es22.14,2x,a)') br%pts(i)%lam, 'failed (reason '//str(br%pts(i)%status)//'): '// &
            br%pts(i)%message
         return
      end if
      associate (p => br%pts(i))
         write (output_unit, '(es22.14,es14.6,es12.4,2x,a10,i6,5x,a)') p%lam, p%period, maxval(abs(p%mu)), &
            p%stability, p%corrector, p%kind
      end associate
   end subroutine print_point

   !> One point printed and written to the branch file with its orbit's metrics (a
   !> failed point: its reason); i = 0: the branch's end status.
   subroutine on_point(br, i, err)
      type(branch_t), intent(in) :: br
      integer, intent(in) :: i
      type(error_t), allocatable, intent(out) :: err
      real(wp), allocatable :: el(:, :)
      call print_point(br, i, err)
      if (i == 0) then
         call bfile%write_end(br, err)
         if (n_stale > 0) write (error_unit, '(a)') 'trainsim: warning: '//str(n_stale)//' point(s) between '// &
            'lambda = '//str(stale_lam(1), 10)//' and '//str(stale_lam(2), 10)//" have t0 in a contact of '"// &
            stale_id//"' that came from an impact: the map restarts it with the contact law's start, not its "// &
            "impact's damping, so they are not orbits of the train (D-144)"
         return
      end if
      allocate (el(size(element_metric_names), bfile%ne))
      el = ieee_value(1.0_wp, ieee_quiet_nan)
      if (br%pts(i)%status == branch_done) call orbit_metrics(br%pts(i), el, err)
      if (.not. allocated(err)) call bfile%write_point(br, i, el, err)
   end subroutine on_point

   !> Every element metric over the orbit of point p (its run, as `trainsim periodic` reports it).
   subroutine orbit_metrics(p, el, err)
      type(branch_point_t), intent(in) :: p
      real(wp), intent(inout) :: el(:, :)
      type(error_t), allocatable, intent(out) :: err
      type(model_t) :: m
      type(period_map_t) :: pm
      type(run_result_t) :: run
      type(null_sink_t) :: none
      real(wp) :: period
      logical :: done
      integer :: stale
      type(model_t), allocatable, save :: base   ! (the first point's model, retuned to the others: D-131)
      done = .false.
      if (allocated(base)) then
         m = base
         call prob%retune(p%lam, m, done, err)
         if (allocated(err)) deallocate (err)
      end if
      if (.not. done) call prob%model_at(p%lam, m, err)
      if (.not. allocated(err) .and. .not. allocated(base) .and. prob%retunes) base = m
      if (.not. allocated(err)) call forcing_period(m, period, err)
      if (allocated(err)) return
      m%run%t_start = p%t0   ! (its own: t0 moves along a branch where a memory contact drifts onto it)
      call pm%setup(m, period, kperiods, err)
      if (allocated(p%mem)) then   ! (the point's memory: a contact closed at t0 keeps its D, D-150)
         pm%mem = p%mem
         pm%kept = p%kept
      end if
      if (.not. allocated(err)) call orbit_run(m, pm, p%x, none, run, err, stale)
      call pm%finish()
      if (.not. allocated(err)) el = element_record(run)
      if (allocated(err) .or. stale == 0) return
      n_stale = n_stale + 1   ! (reported at the branch's end: stale_note)
      if (n_stale == 1) then
         stale_lam = [p%lam, p%lam]
         stale_id = m%elements(stale)%e%id
      end if
      stale_lam = [min(stale_lam(1), p%lam), max(stale_lam(2), p%lam)]
   end subroutine orbit_metrics

   !> What the branch file describes: the deck at the first parameter value, and a
   !> fingerprint of everything that decides the branch (deck, tables, --set, --param,
   !> the options, the version).
   subroutine branch_layout(deck, lam0, opt, param, lay, n, err)
      type(deck_t), intent(in) :: deck
      real(wp), intent(in) :: lam0
      type(branch_options_t), intent(in) :: opt
      character(len=*), intent(in) :: param
      type(sweep_layout_t), intent(out) :: lay
      integer, intent(out) :: n
      type(error_t), allocatable, intent(out) :: err
      type(model_t) :: model
      type(run_meta_t) :: meta
      character(len=400) :: buf
      integer :: k
      call prob%model_at(lam0, model, err)
      if (allocated(err)) return
      n = model%n_states
      n_memory = 0
      do k = 1, size(model%elements)   ! (as period_map_t's memory: the clearances whose law keeps one)
         select type (el => model%elements(k)%e)
         class is (clearance_element_t)
            if (el%memory_size() > 0) n_memory = n_memory + [el%memory_size(), 1]
         end select
      end do
      lay%version = version_full()
      lay%deck_file = deck_path
      lay%deck_text = deck%text
      meta = make_meta(model)
      call move_alloc(meta%input_keys, lay%input_keys)
      call move_alloc(meta%input_files, lay%input_files)
      call move_alloc(meta%input_texts, lay%input_texts)
      lay%title = model%title
      lay%units = model%units%name
      write (buf, '(a,5es25.17,5(1x,i0),4es25.17)') ' --param '//param, opt%ds, opt%ds_min, opt%ds_max, opt%tol, &
         opt%restart_step, opt%max_points, opt%k, opt%shoot%transient, opt%restarts, opt%max_corrector, &
         opt%fd_lam, opt%lam_tol, opt%shoot%tol, opt%shoot%fd_step
      lay%overrides = ''
      do k = 1, size(sets)
         lay%overrides = lay%overrides//sets(k)%origin//' '
      end do
      lay%overrides = lay%overrides//trim(buf)
      lay%fingerprint = fingerprint(deck, lay)
      lay%n_runs = opt%max_points
      allocate (lay%element_ids(size(model%elements)), lay%element_types(size(model%elements)))
      do k = 1, size(model%elements)
         lay%element_ids(k)%s = model%elements(k)%e%id
         lay%element_types(k)%s = model%elements(k)%e%type_name
      end do
   end subroutine branch_layout
end module trainsim_cmd_continue
