!> Stale points of trainsim_arclength's continuation and their release (issue 27, D-188).
!>
!> The map at a point restarts each contact closed at t0 with the memory it holds
!> there (yang_sun's D, e, V_i: the held one for a contact taken to stay closed, else
!> the law's start). Where such a contact opens and strikes again within the period,
!> the impact sets another memory, the orbit's own, and the point is a fixed point of
!> a map that is not the train's (D-144): x repeats, the memory does not. Along a
!> branch this happens past a grazing where a contact that spanned t0 begins to
!> strike, with t0 left in it (D-156: Table 7.1 going down from 450 teeth/s, 12 points
!> 433.23 ... 365.91 with mesh1's D = 0 held while its impact sets D(V_i)).
!>
!> Such a point is not stored as an orbit. It is *released*: t0 moved into the
!> longest stretch of its orbit in which every memory contact that opens is open
!> (`rephase`, D-99: there the map does not depend on the memory) and the orbit
!> corrected there by full Newton at the same lambda. The stale point is a failed
!> point (reason 6); if the release converges to an orbit that is not stale itself,
!> that orbit is stored after it at the same lambda, else the message says why not.
!> Either way the continuation goes on from the stale point along the stale map, which
!> serves as the predictor's path; its points are not stored as orbits (a jump onto
!> the released orbit lost the Fig. 5.11 folds: D-188).
submodule(trainsim_arclength) trainsim_arclength_release
   implicit none

contains

   !> q%stale: the first element of the map's memory list (pm%memory) whose contact is
   !> closed at t0 on the flow from q's state and whose memory at the end of the last
   !> map differs from the memory that contact started with (an impact within the
   !> period set it), 0 if none. Read after `linearise` of q: its last map is from q's
   !> state at lambda - h, on the session set up there (no map of its own).
   module procedure stale_check
      real(wp), allocatable :: disp(:), force(:), mem0(:)
      integer, allocatable :: contact(:)
      type(error_t), allocatable :: err
      integer :: i, ne
      q%stale = 0
      if (size(c%pm%memory) == 0) return
      ne = size(c%pm%model%elements)
      allocate (disp(ne), force(ne), contact(ne))
      call c%pm%s%restore(c%pm%p0, err)
      if (.not. allocated(err)) then
         call c%pm%hold_memory(c%pm%s%model)
         call c%pm%s%set_state(c%pm%full_state(q%z(1:c%n)*c%s), err)
      end if
      if (allocated(err)) return   ! (the map from this state ran: not met)
      call c%pm%s%element_status(disp, force, contact)
      mem0 = c%pm%memory_of(c%pm%s%model)
      do i = 1, size(c%pm%memory)   ! (3 values an element: yang_sun's memory_size, as pm_map's `changed`)
         if (contact(c%pm%memory(i)) == 0) cycle
         if (any(c%pm%mem_end(3*i - 2:3*i) /= mem0(3*i - 2:3*i))) then
            q%stale = i
            return
         end if
      end do
   end procedure stale_check

   !> The accepted point q is stale (q%stale > 0; cur the last accepted point, `before`
   !> the points stored before this step, cur_stale whether cur was stale too): q
   !> stored as a failed point (reason 6) and released. Points located between two
   !> stale points (a grazing, a fold: of the stale map) are failed points too.
   !> released: the orbit found there is stored after it (segment restarts + 1). Either
   !> way the context is put back as before the release (t0, held memory), and the
   !> continuation goes on from q along the stale map (D-188: a jump onto the released
   !> orbit's branch cost the Fig. 5.11 rig its folds).
   module procedure release
      type(node_t) :: fix, r
      real(wp) :: x(c%n), t_dir(c%n + 1), lam, phase0
      real(wp), allocatable :: mem0(:), lams(:)
      logical, allocatable :: kept0(:)
      character(len=:), allocatable :: why, id, msg
      integer :: i
      logical :: moved
      released = .false.
      lam = q%z(c%n + 1)*c%ls
      id = c%pm%model%elements(c%pm%memory(q%stale))%e%id
      if (cur_stale .and. size(br%pts) > before) then
         lams = br%pts(before + 1:)%lam
         br%pts = br%pts(1:before)
         do i = 1, size(lams)
            call failed_point(br, lams(i), branch_stale, "a grazing or bifurcation located between two stale "// &
                              "points (t0 in a struck contact of '"//id//"'): of a map that is not the train's")
         end do
      end if
      msg = "t0 lies in a contact of '"//id//"' that strikes within the period: the map restarts it with "// &
            "another memory than its impact's, so the point is not an orbit of the train (D-144)"
      phase0 = c%phase
      allocate (mem0, source=c%pm%mem)
      allocate (kept0, source=c%pm%kept)
      t_dir = 0.0_wp
      t_dir(c%n + 1) = sign(1.0_wp, q%t(c%n + 1))
      call t0_to_open(c, q%z, x, moved, err)
      if (allocated(err)) return
      if (.not. moved) then
         why = 'no stretch of the orbit has every memory contact that opens open'
      else
         allocate (fix%t(c%n + 1))
         fix%t = t_dir   ! (the bordering row: lambda held)
         call correct(c, fix, [x/c%s, q%z(c%n + 1)], opt, r, why, full=.true.)
         if (len(why) == 0) then
            call linearise(c, r, t_dir, err)
            if (allocated(err)) then
               why = err%message
               deallocate (err)
            end if
         end if
         if (len(why) == 0) then
            call stale_check(c, r)
            if (r%stale > 0) why = 'the orbit found there is stale too'
         end if
      end if
      if (len(why) == 0) then   ! (the orbit at lam: stored, the stale point before it says why)
         call failed_point(br, lam, branch_stale, msg//'; released: t0 moved into the open stretch (phase '// &
                           str(c%phase, 6)//'), the orbit there is the next point')
         call store(br, c, r, 0.0_wp, '', t_dir, restarts + 1)
         released = .true.
      else
         call failed_point(br, lam, branch_stale, msg//'; no release: '//why)
      end if
      c%phase = phase0   ! (the continuation goes on along the stale map: its t0 and held memory)
      c%pm%mem = mem0
      c%pm%kept = kept0
      c%lam = huge(1.0_wp)
   end procedure release
end submodule trainsim_arclength_release
