!> trainsim continue: the periodic orbit of a deck followed in a deck parameter by
!> pseudo-arclength continuation (src/periodic/trainsim_arclength.f90,
!> docs/periodic.md "Continuation"), its folds and other bifurcations, each
!> point's multipliers and stability, written as a branch file (text, one row a
!> point) as it grows, so that a killed run continues with --resume.
module trainsim_cmd_continue
   use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
   use trainsim_kinds, only: wp
   use trainsim_error, only: error_t, fatal_error, err_io, err_input
   use trainsim_strings, only: str, string_t
   use trainsim_model, only: model_t
   use trainsim_deck, only: deck_t, deck_group_t, read_deck
   use trainsim_overrides, only: override_t, parse_set_argument, split_sweep_groups
   use trainsim_prepare, only: prepare_model
   use trainsim_observer, only: run_result_t
   use trainsim_sink, only: null_sink_t
   use trainsim_period_map, only: period_map_t, forcing_period
   use trainsim_orbit, only: orbit_run
   use trainsim_arclength, only: branch_problem_t, branch_options_t, branch_point_t, branch_t, continue_branch, &
                                 branch_done, switch_period_doubling
   use trainsim_cli, only: nargs, arg, quit, fail, add_set, real_value, text_value, deck_path, sets
   use trainsim_cmd_help, only: continue_usage
   use trainsim_monodromy_map, only: monodromy_code
   implicit none
   private

   public :: do_continue

   !> the deck at a value of one key (an override TARGET.KEY=value after the --set ones)
   type, extends(branch_problem_t) :: deck_problem_t
      type(deck_t) :: deck
      type(override_t), allocatable :: ovs(:)
      character(len=:), allocatable :: key
      real(wp) :: lam_first = 0.0_wp
   contains
      procedure :: model_at => deck_model_at
   end type deck_problem_t

   character(len=*), parameter :: kinds(0:4) = [character(len=15) :: '', 'fold', 'period-doubling', 'neimark-sacker', &
                                                 'grazing']

   type(deck_problem_t), save :: prob
   character(len=:), allocatable, save :: out_path

contains

   subroutine deck_model_at(self, lam, model, err)
      class(deck_problem_t), intent(in) :: self
      real(wp), intent(in) :: lam
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      type(override_t) :: ov
      character(len=32) :: buf
      write (buf, '(es25.17)') lam
      call parse_set_argument(self%key//'='//trim(adjustl(buf)), ov, err)
      if (.not. allocated(err)) call prepare_model(self%deck, [self%ovs, ov], model, err)
   end subroutine deck_model_at

   !> trainsim continue DECK --param TARGET.KEY=FROM:TO [options] [-o FILE [--resume]]
   subroutine do_continue()
      type(branch_options_t) :: opt
      type(branch_t) :: br, old
      type(error_t), allocatable :: err
      type(deck_group_t), allocatable :: sweeps(:)
      character(len=:), allocatable :: param
      real(wp) :: lam0, lam1
      logical :: resume, switch_pd
      integer :: i
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
         case ('--points')
            opt%max_points = nint(positive(i))
            i = i + 1
         case ('--period-count')
            opt%k = nint(positive(i))
            i = i + 1
         case ('--transient')
            opt%shoot%transient = nint(real_value(i))
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
      call read_deck(deck_path, prob%deck, err)
      if (allocated(err)) call fail(err)
      call split_sweep_groups(prob%deck, sweeps)
      prob%ovs = sets
      write (output_unit, '(a)') 'trainsim continue: '//deck_path//', '//prob%key//' from '//str(lam0)//' to '//str(lam1)
      write (output_unit, '(a)') '      lambda            period        max|mu|     stability  corrector  bifurcation'
      if (resume) then
         call read_branch(out_path, old, err)
         if (allocated(err)) call fail(err)
         write (output_unit, '(a)') 'resumed after '//str(size(old%pts))//' stored points'
         call continue_branch(prob, lam0, opt, br, err, resume=old, hook=on_point)
      else if (len(out_path) > 0) then
         call continue_branch(prob, lam0, opt, br, err, hook=on_point)
      else
         call continue_branch(prob, lam0, opt, br, err, hook=print_point)
      end if
      if (allocated(err)) call fail(err)
      write (output_unit, '(a)') str(size(br%pts))//' points, '//str(br%maps)//' period maps, '//str(br%rejected)// &
         ' steps refused, '//str(br%passes)//' variational passes'
      if (br%status == branch_done .and. allocated(br%message)) then
         if (len(br%message) > 0) write (output_unit, '(a)') br%message
      end if
      if (switch_pd) call doubled_branch(br, opt)
      if (br%status /= branch_done) then
         write (error_unit, '(a)') 'trainsim: continue: the branch stopped early (status '//str(br%status)//'): '// &
            br%message
         call quit(1)
      end if
   end subroutine do_continue

   !> --switch-pd: the period-doubled branch from the branch's first period-doubling
   !> point, printed and (with -o FILE) written to FILE with '.pd2' before its
   !> extension (resume it with --period-count 2 times the first's).
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
         call switch_period_doubling(prob, br, ipd, opt, br2, err, hook=on_point)
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
      associate (p => br%pts(i))
         write (output_unit, '(es22.14,es14.6,es12.4,2x,a10,i6,5x,a)') p%lam, p%period, maxval(abs(p%mu)), &
            p%stability, p%corrector, p%kind
      end associate
   end subroutine print_point

   !> One point printed and appended to the branch file (created with its header at
   !> point 1); i = 0: the branch's status as the last line.
   subroutine on_point(br, i, err)
      type(branch_t), intent(in) :: br
      integer, intent(in) :: i
      type(error_t), allocatable, intent(out) :: err
      integer :: u, ios, j
      real(wp), allocatable :: dmin(:), dmax(:)
      type(string_t), allocatable :: ids(:)
      call print_point(br, i, err)
      if (i == 1) then
         call element_ids(ids, err)
         if (allocated(err)) return
         open (newunit=u, file=out_path, status='replace', action='write', iostat=ios)
         if (ios /= 0) then
            call fatal_error(err, "cannot write the branch file '"//out_path//"'", err_io)
            return
         end if
         write (u, '(a)') '# trainsim continue branch: '//deck_path//', parameter '//prob%key
         write (u, '(a,es25.17)') '# lam_scale', br%lam_scale
         write (u, '(a,es25.17)') '# phase', br%phase
         write (u, '(a,i0)') '# states ', size(br%scale)
         write (u, '(a,*(es25.17))') '# scale', br%scale
         write (u, '(a,i0,*(1x,a))') '# elements ', size(ids), (ids(j)%s, j=1, size(ids))
         write (u, '(a)') 'lambda,period,t0,kind,stable,max_abs_mu,corrector,maps,ds,residual,'// &
            'disp_min(element)...,disp_max(element)...,x...,tangent...,mu_re...,mu_im...'
      else
         open (newunit=u, file=out_path, status='old', position='append', action='write', iostat=ios)
         if (ios /= 0) then
            call fatal_error(err, "cannot append to the branch file '"//out_path//"'", err_io)
            return
         end if
      end if
      if (i == 0) then
         write (u, '(a)') '# status '//str(br%status)//' '//br%message
      else
         associate (p => br%pts(i))
            call orbit_extremes(p, dmin, dmax, err)
            if (allocated(err)) then
               close (u)
               return
            end if
            write (u, '(es25.17,2(",",es25.17),2(",",i0),5(",",es25.17))', &
                   advance='no') p%lam, p%period, p%t0, kind_code(p%kind), &
               merge(1, 0, p%stability == 'stable'), maxval(abs(p%mu)), real(p%corrector, wp), real(p%maps, wp), &
               p%ds, p%residual
            write (u, '(*(",",es25.17))') dmin, dmax, p%x, p%tangent, (real(p%mu(j)), j=1, size(p%mu)), &
               (aimag(p%mu(j)), j=1, size(p%mu))
         end associate
      end if
      close (u)
   end subroutine on_point

   !> 0 a regular point, 1 fold, 2 period-doubling, 3 Neimark-Sacker, 4 grazing (a contact-sequence change).
   integer function kind_code(kind) result(k)
      character(len=*), intent(in) :: kind
      do k = 4, 1, -1
         if (kind == trim(kinds(k))) return
      end do
   end function kind_code

   !> The deck's element ids (the columns of the extremes).
   subroutine element_ids(ids, err)
      type(string_t), allocatable, intent(out) :: ids(:)
      type(error_t), allocatable, intent(out) :: err
      type(model_t) :: m
      integer :: e
      call prob%model_at(prob%lam_first, m, err)
      if (allocated(err)) return
      allocate (ids(size(m%elements)))
      do e = 1, size(m%elements)
         ids(e)%s = m%elements(e)%e%id
      end do
   end subroutine element_ids

   !> Every element's displacement extremes over the orbit of point p (its run).
   subroutine orbit_extremes(p, dmin, dmax, err)
      type(branch_point_t), intent(in) :: p
      real(wp), allocatable, intent(out) :: dmin(:), dmax(:)
      type(error_t), allocatable, intent(out) :: err
      type(model_t) :: m
      type(period_map_t) :: pm
      type(run_result_t) :: run
      type(null_sink_t) :: none
      real(wp) :: period
      integer :: e
      call prob%model_at(p%lam, m, err)
      if (.not. allocated(err)) call forcing_period(m, period, err)
      if (allocated(err)) return
      m%run%t_start = p%t0   ! (its own: t0 moves along a branch where a memory contact drifts onto it)
      call pm%setup(m, period, 1, err)
      if (.not. allocated(err)) call orbit_run(m, pm, p%x, none, run, err)
      call pm%finish()
      if (allocated(err)) return
      allocate (dmin(size(run%el)), dmax(size(run%el)))
      do e = 1, size(run%el)
         dmin(e) = run%el(e)%disp_min
         dmax(e) = run%el(e)%disp_max
      end do
   end subroutine orbit_extremes

   !> The branch stored in a branch file (for --resume).
   subroutine read_branch(path, br, err)
      character(len=*), intent(in) :: path
      type(branch_t), intent(out) :: br
      type(error_t), allocatable, intent(out) :: err
      character(len=20000) :: line
      type(branch_point_t) :: p
      real(wp), allocatable :: row(:)
      integer :: u, ios, n, kind, st, ne
      allocate (br%pts(0))
      n = -1
      ne = -1
      open (newunit=u, file=path, status='old', action='read', iostat=ios)
      if (ios /= 0) then
         call fatal_error(err, "cannot read the branch file '"//path//"' to resume", err_io)
         return
      end if
      do
         read (u, '(a)', iostat=ios) line
         if (ios /= 0) exit
         if (index(line, '# lam_scale') == 1) read (line(12:), *) br%lam_scale
         if (index(line, '# phase') == 1) read (line(8:), *) br%phase
         if (index(line, '# states') == 1) then
            read (line(9:), *) n
            allocate (br%scale(n))
         end if
         if (index(line, '# scale') == 1) read (line(8:), *) br%scale
         if (index(line, '# elements') == 1) then
            read (line(11:), *) ne
            allocate (row(10 + 2*ne + 4*n + 1))
         end if
         if (line(1:1) == '#' .or. line(1:6) == 'lambda' .or. n < 0 .or. ne < 0) cycle
         read (line, *, iostat=ios) row
         if (ios /= 0) exit   ! a row cut by a kill: the points before it
         p%lam = row(1)
         p%period = row(2)
         p%t0 = row(3)
         kind = nint(row(4))
         st = nint(row(5))
         p%kind = trim(kinds(kind))
         p%stability = merge('stable  ', 'unstable', st == 1)
         p%corrector = nint(row(7))
         p%maps = nint(row(8))
         p%ds = row(9)
         p%residual = row(10)
         associate (o => 10 + 2*ne)
            p%x = row(o + 1:o + n)
            p%tangent = row(o + n + 1:o + 2*n + 1)
            p%mu = cmplx(row(o + 2*n + 2:o + 3*n + 1), row(o + 3*n + 2:o + 4*n + 1), kind=wp)
         end associate
         br%pts = [br%pts, p]
         br%maps = p%maps
      end do
      close (u)
      if (size(br%pts) == 0) call fatal_error(err, "the branch file '"//path//"' holds no point to resume from", &
                                              err_input)
   end subroutine read_branch
end module trainsim_cmd_continue
