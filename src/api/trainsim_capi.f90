!> The C interface of trainsim (include/trainsim.h; docs/c-api.md): `bind(C)` procedures
!> over the Fortran API (module `trainsim`), built into the shared library
!> libtrainsim_c.so. A `trainsim_sim *` is a pointer to a `capi_sim_t` allocated here.
!>
!> Every procedure returns an error code (0 ok, else `err_input` .. `err_interrupted` of
!> trainsim_error, or `code_argument` for a misuse: a NULL or stale handle, an index out
!> of range, a buffer too small) and keeps the message of its handle's last call, which
!> `trainsim_error_message` copies out (as trainsim prints it: file, line, group, key).
!> Nothing here stops the program. Results are copied into the caller's buffers; the
!> caller asks the sizes first (`trainsim_count`).
module trainsim_capi
   use, intrinsic :: iso_c_binding, only: c_int, c_double, c_size_t, c_ptr, c_char, c_null_char, c_null_ptr, &
                                          c_associated, c_f_pointer, c_loc
   use trainsim, only: simulation_t, error_t, wp, string_t, event_t, run_result_t, model_t, version_full, &
                       ev_name, sweep_spec_t, chain_state_t, session_t, session_state_t
   use trainsim_capture, only: capture_sink_t
   use trainsim_error, only: fatal_error, err_input
   use trainsim_strings, only: str
   use trainsim_capi_tables, only: metric_table, event_columns, event_row
   implicit none
   private

   !> for the session calls (trainsim_capi_session)
   public :: capi_sim_t, take, finish, misuse, built_model, code_argument, f_string

   integer(c_int), parameter :: code_argument = 6   !< TRAINSIM_ERR_ARGUMENT
   integer, parameter :: alive = 20240611           !< capi_sim_t%magic of a live handle

   !> What `trainsim_count` / `trainsim_name` list (TRAINSIM_<WHAT> in trainsim.h).
   integer(c_int), parameter :: w_metrics = 1, w_metric_units = 2, w_series = 3, w_series_units = 4, &
                                w_event_columns = 5, w_elements = 6, w_nodes = 7, w_sweep_parameters = 8, &
                                w_samples = 9, w_events = 10, w_sweep_runs = 11, w_event_kinds = 12

   !> A handle's simulation and what its last run left.
   type :: capi_sim_t
      integer :: magic = alive
      type(simulation_t) :: sim
      type(capture_sink_t) :: cap
      integer(c_int) :: code = 0
      character(len=:), allocatable :: message
      logical :: has_run = .false.
      type(string_t), allocatable :: metric_names(:), metric_units(:)
      real(wp), allocatable :: metric_values(:)
      type(event_t), allocatable :: events(:)
      !> a run advanced by the caller (trainsim_session_*) and the points it saved
      type(session_t), allocatable :: session
      type(session_state_t), allocatable :: saved(:)
   end type capi_sim_t

   !> The message of a call given no valid handle.
   character(len=:), allocatable, save :: orphan_message
   character(kind=c_char), target, save :: version_text(64)

   interface
      pure function c_strlen(s) bind(C, name='strlen') result(n)
         import :: c_ptr, c_size_t
         type(c_ptr), value :: s
         integer(c_size_t) :: n
      end function c_strlen
   end interface

contains

   ! ------------------------------------------------------------------ handles

   !> `trainsim_sim *trainsim_new(void)`: an empty simulation (read a deck next).
   function trainsim_new() result(p) bind(C, name='trainsim_new')
      type(c_ptr) :: p
      type(capi_sim_t), pointer :: h
      integer :: st
      allocate (h, stat=st)
      p = c_null_ptr
      if (st == 0) p = c_loc(h)
   end function trainsim_new

   !> `void trainsim_free(trainsim_sim *)`: NULL is ignored.
   subroutine trainsim_free(p) bind(C, name='trainsim_free')
      type(c_ptr), value :: p
      type(capi_sim_t), pointer :: h
      if (.not. c_associated(p)) return
      call c_f_pointer(p, h)
      if (h%magic /= alive) return
      h%magic = 0
      deallocate (h)
   end subroutine trainsim_free

   !> The handle behind `p`, with its message cleared; .false. (and the orphan
   !> message set) for NULL or a handle already freed.
   logical function take(p, h)
      type(c_ptr), intent(in) :: p
      type(capi_sim_t), pointer, intent(out) :: h
      h => null()
      take = .false.
      if (.not. c_associated(p)) then
         orphan_message = 'trainsim: error: the simulation handle is NULL'
         return
      end if
      call c_f_pointer(p, h)
      if (h%magic /= alive) then
         orphan_message = 'trainsim: error: the simulation handle is not a live trainsim_sim (freed?)'
         h => null()
         return
      end if
      h%code = 0
      h%message = ''
      take = .true.
   end function take

   !> Record `err` (if any) in `h`; return its code.
   integer(c_int) function finish(h, err) result(code)
      type(capi_sim_t), intent(inout) :: h
      type(error_t), allocatable, intent(in) :: err
      code = 0
      if (allocated(err)) then
         code = int(err%code, c_int)
         h%message = err%message
      end if
      h%code = code
   end function finish

   integer(c_int) function misuse(h, message) result(code)
      type(capi_sim_t), intent(inout) :: h
      character(len=*), intent(in) :: message
      code = code_argument
      h%code = code
      h%message = 'trainsim: error: '//message
   end function misuse

   !> `int trainsim_error_code(const trainsim_sim *)`: the code of the handle's last call.
   integer(c_int) function trainsim_error_code(p) result(code) bind(C, name='trainsim_error_code')
      type(c_ptr), value :: p
      type(capi_sim_t), pointer :: h
      code = code_argument
      if (.not. c_associated(p)) return
      call c_f_pointer(p, h)
      if (h%magic == alive) code = h%code
   end function trainsim_error_code

   !> `size_t trainsim_error_message(const trainsim_sim *, char *buf, size_t size)`: the
   !> message of the handle's last call ('' if it succeeded), as snprintf: at most
   !> size - 1 characters and a NUL; returns the full length. NULL handle: the message
   !> of the last call given no valid handle.
   integer(c_size_t) function trainsim_error_message(p, buf, bufsize) result(n) bind(C, name='trainsim_error_message')
      type(c_ptr), value :: p, buf
      integer(c_size_t), value :: bufsize
      type(capi_sim_t), pointer :: h
      character(len=:), allocatable :: m
      m = ''
      if (allocated(orphan_message)) m = orphan_message
      if (c_associated(p)) then
         call c_f_pointer(p, h)
         if (h%magic == alive .and. allocated(h%message)) m = h%message
      end if
      call put_string(m, buf, bufsize)
      n = len(m, c_size_t)
   end function trainsim_error_message

   !> `const char *trainsim_library_version(void)`: "0.1.0 (git ...)" (not `trainsim_version`:
   !> gfortran 12 makes a binding label equal to a module's name, trainsim_version, call itself).
   function capi_version() result(p) bind(C, name='trainsim_library_version')
      type(c_ptr) :: p
      character(len=:), allocatable :: v
      integer :: i
      v = version_full()
      v = v(1:min(len(v), size(version_text) - 1))
      do i = 1, len(v)
         version_text(i) = v(i:i)
      end do
      version_text(len(v) + 1) = c_null_char
      p = c_loc(version_text)
   end function capi_version

   ! ------------------------------------------------------------------ deck and parameters

   !> `int trainsim_read_file(trainsim_sim *, const char *path)`.
   integer(c_int) function trainsim_read_file(p, path) result(code) bind(C, name='trainsim_read_file')
      type(c_ptr), value :: p, path
      type(capi_sim_t), pointer :: h
      type(error_t), allocatable :: err
      code = code_argument
      if (.not. take(p, h)) return
      if (.not. c_associated(path)) then
         code = misuse(h, 'trainsim_read_file: the path is NULL')
         return
      end if
      h%has_run = .false.
      call h%sim%read_file(f_string(path), err)
      code = finish(h, err)
   end function trainsim_read_file

   !> `int trainsim_read_text(trainsim_sim *, const char *text, const char *name)`:
   !> `name` stands for the file name in messages (NULL: "<text>").
   integer(c_int) function trainsim_read_text(p, text, name) result(code) bind(C, name='trainsim_read_text')
      type(c_ptr), value :: p, text, name
      type(capi_sim_t), pointer :: h
      type(error_t), allocatable :: err
      code = code_argument
      if (.not. take(p, h)) return
      if (.not. c_associated(text)) then
         code = misuse(h, 'trainsim_read_text: the text is NULL')
         return
      end if
      h%has_run = .false.
      if (c_associated(name)) then
         call h%sim%read_text(f_string(text), err, f_string(name))
      else
         call h%sim%read_text(f_string(text), err)
      end if
      code = finish(h, err)
   end function trainsim_read_text

   !> `int trainsim_set(trainsim_sim *, const char *path, const char *value)`: set a deck
   !> key (GROUP.KEY, as --set) to `value` in deck syntax ("0.002", "'cvode-bdf'").
   integer(c_int) function trainsim_set(p, path, value) result(code) bind(C, name='trainsim_set')
      type(c_ptr), value :: p, path, value
      type(capi_sim_t), pointer :: h
      type(error_t), allocatable :: err
      code = code_argument
      if (.not. take(p, h)) return
      if (.not. c_associated(path) .or. .not. c_associated(value)) then
         code = misuse(h, 'trainsim_set: the path or the value is NULL')
         return
      end if
      h%has_run = .false.
      call h%sim%set(f_string(path), f_string(value), err)
      code = finish(h, err)
   end function trainsim_set

   !> `int trainsim_set_real(trainsim_sim *, const char *path, double value)` (exact).
   integer(c_int) function trainsim_set_real(p, path, value) result(code) bind(C, name='trainsim_set_real')
      type(c_ptr), value :: p, path
      real(c_double), value :: value
      type(capi_sim_t), pointer :: h
      type(error_t), allocatable :: err
      code = code_argument
      if (.not. take(p, h)) return
      if (.not. c_associated(path)) then
         code = misuse(h, 'trainsim_set_real: the path is NULL')
         return
      end if
      h%has_run = .false.
      call h%sim%set(f_string(path), real(value, wp), err)
      code = finish(h, err)
   end function trainsim_set_real

   !> `int trainsim_clear(trainsim_sim *)`: forget every set (the deck's own values).
   integer(c_int) function trainsim_clear(p) result(code) bind(C, name='trainsim_clear')
      type(c_ptr), value :: p
      type(capi_sim_t), pointer :: h
      code = code_argument
      if (.not. take(p, h)) return
      h%has_run = .false.
      call h%sim%clear_sets()
      code = 0
   end function trainsim_clear

   ! ------------------------------------------------------------------ run

   !> `int trainsim_run(trainsim_sim *, int flags, const char *output)`: build (if the
   !> deck or a parameter changed) and run. flags: 1 keep the series (the sampled
   !> history) in memory, 2 keep the event table; `output` (NULL: none) an HDF5 history.
   integer(c_int) function trainsim_run(p, flags, output) result(code) bind(C, name='trainsim_run')
      type(c_ptr), value :: p, output
      integer(c_int), value :: flags
      type(capi_sim_t), pointer :: h
      type(error_t), allocatable :: err
      type(model_t) :: model
      type(run_result_t) :: res
      type(chain_state_t) :: st
      code = code_argument
      if (.not. take(p, h)) return
      h%has_run = .false.
      call built_model(h, model, err)
      if (allocated(err)) then
         code = finish(h, err)
         return
      end if
      h%cap%series = iand(flags, 1_c_int) /= 0
      h%cap%t_metrics = model%run%t_start + model%run%settle_time
      if (model%run%settle_tol > 0.0_wp) h%cap%t_metrics = huge(1.0_wp)   ! until settled (metrics_from)
      if (c_associated(output)) then
         call h%sim%run(err, output=f_string(output), keep_events=iand(flags, 2_c_int) /= 0, sink=h%cap)
      else
         call h%sim%run(err, keep_events=iand(flags, 2_c_int) /= 0, sink=h%cap)
      end if
      if (.not. allocated(err)) call h%sim%result(res, err)
      if (.not. allocated(err)) call h%sim%end_state(st, err)
      if (.not. allocated(err)) then
         call metric_table(model, res, st, h%cap%wmin, h%cap%wmax, h%metric_names, h%metric_units, h%metric_values)
         call h%sim%events(h%events, err)
      end if
      h%has_run = .not. allocated(err)
      code = finish(h, err)
   end function trainsim_run

   !> The model as built from the deck and the sets (built now if it is not).
   subroutine built_model(h, model, err)
      type(capi_sim_t), intent(inout) :: h
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      call h%sim%get_model(model, err)
      if (.not. allocated(err)) return
      deallocate (err)
      call h%sim%build(err)
      if (.not. allocated(err)) call h%sim%get_model(model, err)
   end subroutine built_model

   ! ------------------------------------------------------------------ sizes and names

   !> `int trainsim_count(trainsim_sim *, int what, size_t *n)`: how many names (or rows)
   !> `what` has. Elements, nodes and the sweep need the deck (and build the model);
   !> metrics, series, samples and events need a run.
   integer(c_int) function trainsim_count(p, what, n) result(code) bind(C, name='trainsim_count')
      type(c_ptr), value :: p
      integer(c_int), value :: what
      integer(c_size_t), intent(out) :: n
      type(capi_sim_t), pointer :: h
      type(string_t), allocatable :: names(:)
      integer :: rows
      n = 0
      code = code_argument
      if (.not. take(p, h)) return
      code = listing(h, what, names, rows)
      if (code /= 0) return
      n = size(names, kind=c_size_t)
      if (what == w_samples .or. what == w_events .or. what == w_sweep_runs) n = int(rows, c_size_t)
   end function trainsim_count

   !> `int trainsim_name(trainsim_sim *, int what, size_t i, char *buf, size_t size,
   !> size_t *length)`: the i-th (0-based) name of `what`, as snprintf; `length` (may be
   !> NULL) gets its full length.
   integer(c_int) function trainsim_name(p, what, i, buf, bufsize, length) result(code) bind(C, name='trainsim_name')
      type(c_ptr), value :: p, buf, length
      integer(c_int), value :: what
      integer(c_size_t), value :: i, bufsize
      type(capi_sim_t), pointer :: h
      type(string_t), allocatable :: names(:)
      integer(c_size_t), pointer :: n
      integer :: rows
      code = code_argument
      if (.not. take(p, h)) return
      code = listing(h, what, names, rows)
      if (code /= 0) return
      if (i >= size(names, kind=c_size_t)) then
         code = misuse(h, 'trainsim_name: index '//str(int(i))//' out of range (0 to '// &
                       str(size(names) - 1)//')')
         return
      end if
      call put_string(names(i + 1)%s, buf, bufsize)
      if (c_associated(length)) then
         call c_f_pointer(length, n)
         n = len(names(i + 1)%s, c_size_t)
      end if
   end function trainsim_name

   !> The names of `what` (and the rows of a table).
   integer(c_int) function listing(h, what, names, rows) result(code)
      type(capi_sim_t), intent(inout) :: h
      integer(c_int), intent(in) :: what
      type(string_t), allocatable, intent(out) :: names(:)
      integer, intent(out) :: rows
      type(error_t), allocatable :: err
      type(model_t) :: model
      type(sweep_spec_t) :: spec
      integer :: k
      allocate (names(0))
      rows = 0
      code = 0
      select case (what)
      case (w_elements, w_nodes)
         call built_model(h, model, err)
         if (allocated(err)) then
            code = finish(h, err)
            return
         end if
         if (what == w_elements) then
            deallocate (names)
            allocate (names(size(model%elements)))
            do k = 1, size(names)
               names(k)%s = model%elements(k)%e%id
            end do
         else
            deallocate (names)
            allocate (names(size(model%nodes)))
            do k = 1, size(names)
               names(k)%s = model%nodes(k)%n%id
            end do
         end if
      case (w_sweep_parameters, w_sweep_runs)
         code = sweep_of(h, spec)
         if (code /= 0) return
         names = spec%names
         rows = spec%n_runs
      case (w_event_columns)
         names = event_columns()
      case (w_event_kinds)
         deallocate (names)
         allocate (names(4))
         do k = 1, 4
            names(k)%s = ev_name(k)
         end do
      case (w_metrics, w_metric_units, w_series, w_series_units, w_samples, w_events)
         if (.not. h%has_run) then
            code = misuse(h, 'no run since the deck was read or changed (call trainsim_run first)')
            return
         end if
         select case (what)
         case (w_metrics); names = h%metric_names
         case (w_metric_units); names = h%metric_units
         case (w_series); names = h%cap%names
         case (w_series_units); names = h%cap%units
         case (w_samples); rows = h%cap%n_rows
         case (w_events); rows = size(h%events)
         end select
      case default
         code = misuse(h, 'unknown list '//str(int(what))//' (see TRAINSIM_METRICS ... in trainsim.h)')
      end select
   end function listing

   ! ------------------------------------------------------------------ values

   !> `int trainsim_metrics(trainsim_sim *, double *values, size_t n)`: every metric of
   !> the last run, in the order of its names (n >= trainsim_count(TRAINSIM_METRICS)).
   integer(c_int) function trainsim_metrics(p, values, n) result(code) bind(C, name='trainsim_metrics')
      type(c_ptr), value :: p
      integer(c_size_t), value :: n
      real(c_double), intent(out) :: values(n)
      type(capi_sim_t), pointer :: h
      code = code_argument
      if (.not. take(p, h)) return
      if (.not. ran(h, size(h%metric_values), n, code)) return
      values(1:size(h%metric_values)) = h%metric_values
   end function trainsim_metrics

   !> `int trainsim_metric(trainsim_sim *, const char *name, double *value)`: one metric
   !> by name: "ELEMENT.METRIC" (mesh.p2p_mean), "NODE.METRIC" (n1.speed_max) or
   !> "run.STAT" (run.steps).
   integer(c_int) function trainsim_metric(p, name, value) result(code) bind(C, name='trainsim_metric')
      type(c_ptr), value :: p, name
      real(c_double), intent(out) :: value
      type(capi_sim_t), pointer :: h
      character(len=:), allocatable :: nm
      integer :: k
      value = 0.0_c_double
      code = code_argument
      if (.not. take(p, h)) return
      if (.not. c_associated(name)) then
         code = misuse(h, 'trainsim_metric: the name is NULL')
         return
      end if
      if (.not. ran(h, 0, 0_c_size_t, code)) return
      nm = f_string(name)
      do k = 1, size(h%metric_names)
         if (h%metric_names(k)%s == nm) then
            value = h%metric_values(k)
            return
         end if
      end do
      code = misuse(h, "trainsim_metric: no metric '"//nm//"' (names: ELEMENT.METRIC, NODE.METRIC, run.STAT; "// &
                    'trainsim_name(TRAINSIM_METRICS) lists them)')
   end function trainsim_metric

   !> `int trainsim_series(trainsim_sim *, double *values, size_t n)`: the series of the
   !> last run (flag 1), row-major (samples x columns).
   integer(c_int) function trainsim_series(p, values, n) result(code) bind(C, name='trainsim_series')
      type(c_ptr), value :: p
      integer(c_size_t), value :: n
      real(c_double), intent(out) :: values(n)
      type(capi_sim_t), pointer :: h
      integer :: nc, nr
      code = code_argument
      if (.not. take(p, h)) return
      nc = size(h%cap%names); nr = h%cap%n_rows
      if (.not. ran(h, nc*nr, n, code)) return
      values(1:nc*nr) = reshape(h%cap%data(:, 1:nr), [nc*nr])
   end function trainsim_series

   !> `int trainsim_events(trainsim_sim *, double *values, size_t n)`: the event table of
   !> the last run (flag 2), row-major (events x TRAINSIM_EVENT_COLUMNS).
   integer(c_int) function trainsim_events(p, values, n) result(code) bind(C, name='trainsim_events')
      type(c_ptr), value :: p
      integer(c_size_t), value :: n
      real(c_double), intent(out) :: values(n)
      type(capi_sim_t), pointer :: h
      integer :: nc, k
      code = code_argument
      if (.not. take(p, h)) return
      nc = size(event_columns())
      if (.not. ran(h, nc*size(h%events), n, code)) return
      do k = 1, size(h%events)
         values((k - 1)*nc + 1:k*nc) = event_row(h%events(k))
      end do
   end function trainsim_events

   !> `int trainsim_sweep_values(trainsim_sim *, double *values, size_t n)`: the values of
   !> the deck's &sweep parameters in each run, row-major (runs x parameters), as
   !> `trainsim sweep` makes them.
   integer(c_int) function trainsim_sweep_values(p, values, n) result(code) bind(C, name='trainsim_sweep_values')
      type(c_ptr), value :: p
      integer(c_size_t), value :: n
      real(c_double), intent(out) :: values(n)
      type(capi_sim_t), pointer :: h
      type(sweep_spec_t) :: spec
      integer :: m
      code = code_argument
      if (.not. take(p, h)) return
      code = sweep_of(h, spec)
      if (code /= 0) return
      m = size(spec%values)
      if (int(m, c_size_t) > n) then
         code = misuse(h, 'trainsim_sweep_values: the buffer holds '//str(int(n))//' values, '//str(m)//' needed')
         return
      end if
      values(1:m) = reshape(spec%values, [m])
      code = 0
   end function trainsim_sweep_values

   !> The runs of the deck's &sweep groups; a continuation sweep is refused (its runs
   !> start from each other's end states: `trainsim sweep` makes them).
   integer(c_int) function sweep_of(h, spec) result(code)
      type(capi_sim_t), intent(inout) :: h
      type(sweep_spec_t), intent(out) :: spec
      type(error_t), allocatable :: err
      call h%sim%sweep_spec(spec, err)
      if (.not. allocated(err) .and. allocated(spec%prev)) then
         if (any(spec%prev > 0)) call fatal_error(err, 'error: the deck''s &sweep groups make a continuation '// &
                                                  'sweep (each run starts from the end of the one before): '// &
                                                  'run it with trainsim sweep', err_input)
      end if
      code = finish(h, err)
   end function sweep_of

   !> A run was made and `need` values fit in `n` (else `code` says why).
   logical function ran(h, need, n, code)
      type(capi_sim_t), intent(inout) :: h
      integer, intent(in) :: need
      integer(c_size_t), intent(in) :: n
      integer(c_int), intent(out) :: code
      ran = .false.
      if (.not. h%has_run) then
         code = misuse(h, 'no run since the deck was read or changed (call trainsim_run first)')
      else if (int(need, c_size_t) > n) then
         code = misuse(h, 'the buffer holds '//str(int(n))//' values, '//str(need)//' needed (trainsim_count)')
      else
         code = 0
         ran = .true.
      end if
   end function ran

   ! ------------------------------------------------------------------ strings

   !> The C string at `p` (NUL-terminated) as a Fortran string.
   function f_string(p) result(s)
      type(c_ptr), intent(in) :: p
      character(len=:), allocatable :: s
      character(kind=c_char), pointer :: chars(:)
      integer :: i, n
      n = int(c_strlen(p))
      call c_f_pointer(p, chars, [n])
      allocate (character(len=n) :: s)
      do i = 1, n
         s(i:i) = chars(i)
      end do
   end function f_string

   !> Copy `s` into the C buffer `buf` of `size` bytes (truncated, NUL-terminated; NULL
   !> or size 0: nothing).
   subroutine put_string(s, buf, bufsize)
      character(len=*), intent(in) :: s
      type(c_ptr), intent(in) :: buf
      integer(c_size_t), intent(in) :: bufsize
      character(kind=c_char), pointer :: chars(:)
      integer :: i, n
      if (.not. c_associated(buf) .or. bufsize == 0) return
      call c_f_pointer(buf, chars, [bufsize])
      n = int(min(int(len(s), c_size_t), bufsize - 1))
      do i = 1, n
         chars(i) = s(i:i)
      end do
      chars(n + 1) = c_null_char
   end subroutine put_string
end module trainsim_capi
