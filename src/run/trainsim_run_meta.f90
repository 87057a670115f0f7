!> The description of a run for its output file (`run_meta_t`): title, deck and its
!> overrides, units, version, integrator, the names of the states, nodes and elements,
!> the input series and the table files the deck reads.
module trainsim_run_meta
   use trainsim_strings, only: string_t
   use trainsim_model, only: model_t
   use trainsim_signal, only: signal_t
   use trainsim_input_series, only: input_series_labels
   use trainsim_sink, only: run_meta_t
   use trainsim_version, only: version_full
   use trainsim_node_dc_motor, only: dc_motor_node_t
   implicit none
   private

   public :: make_meta

contains

   !> The run's description for the output file.
   function make_meta(model) result(meta)
      type(model_t), intent(in) :: model
      type(run_meta_t) :: meta
      integer :: i, k, n, ne, nn
      logical :: kept
      type(string_t), allocatable :: names(:)
      nn = size(model%nodes); ne = size(model%elements)
      meta%title = model%title
      meta%deck_file = model%deck_file
      meta%deck_text = model%deck_text
      meta%overrides = ''
      if (allocated(model%overrides)) meta%overrides = model%overrides
      meta%units = model%units%name
      meta%version = version_full()
      meta%integrator = model%run%integrator
      allocate (meta%state_names(model%n_y))
      k = 0
      do i = 1, nn
         if (model%speed_of(i) /= 0) cycle
         n = model%nodes(i)%n%nstates()
         if (n == 0) cycle
         allocate (names(n))
         call model%nodes(i)%n%state_names(names)
         meta%state_names(k + 1:k + n) = names
         deallocate (names)
         k = k + n
      end do
      if (model%run%track_energy) then
         meta%state_names(k + 1)%s = 'energy.dissipated'
         meta%state_names(k + 2)%s = 'energy.input'
      end if
      allocate (meta%node_ids(nn), meta%node_types(nn), meta%node_params(nn))
      do i = 1, nn
         meta%node_ids(i)%s = model%nodes(i)%n%id
         meta%node_types(i)%s = model%nodes(i)%n%type_name
         if (model%speed_of(i) /= 0) meta%node_types(i)%s = meta%node_types(i)%s//' (prescribed speed)'
         meta%node_params(i) = model%nodes(i)%n%params()
      end do
      allocate (meta%element_ids(ne), meta%element_types(ne), meta%element_params(ne), meta%element_disp_units(ne))
      kept = .false.
      if (allocated(model%element_params)) kept = size(model%element_params) == ne
      allocate (meta%element_left(ne), meta%element_right(ne))
      do i = 1, ne
         associate (e => model%elements(i)%e)
            meta%element_ids(i)%s = e%id
            meta%element_types(i)%s = e%type_name
            meta%element_left(i) = e%left
            meta%element_right(i) = e%right
            if (kept) then   ! the builder's (D-175)
               meta%element_params(i) = model%element_params(i)
            else
               meta%element_params(i) = e%params()
            end if
            meta%element_disp_units(i)%s = e%displacement_unit()
            if (meta%element_disp_units(i)%s == 'length') meta%element_disp_units(i)%s = model%units%length
         end associate
      end do
      call input_series_labels(model, meta%input_series_names, meta%input_series_units)
      allocate (meta%input_keys(0), meta%input_files(0), meta%input_texts(0))
      do i = 1, size(model%loads)
         call add_input_file(model%loads(i)%torque)
         call add_input_file(model%loads(i)%law%curve)
      end do
      do i = 1, size(model%speeds)
         call add_input_file(model%speeds(i)%f)
      end do
      do i = 1, size(model%nodes)                  ! a controller's setpoint table (D-76)
         select type (m => model%nodes(i)%n)
         type is (dc_motor_node_t)
            if (m%controlled) call add_input_file(m%ctl%setpoint)
         end select
      end do
   contains
      !> The table file behind `sig`, once per file opened.
      subroutine add_input_file(sig)
         type(signal_t), intent(in) :: sig
         integer :: j
         if (.not. allocated(sig%source_file)) return
         do j = 1, size(meta%input_files)
            if (meta%input_files(j)%s == sig%source_file) return
         end do
         call append(meta%input_keys, sig%source_key)
         call append(meta%input_files, sig%source_file)
         call append(meta%input_texts, sig%source_text)
      end subroutine add_input_file
      subroutine append(list, text)
         type(string_t), allocatable, intent(inout) :: list(:)
         character(len=*), intent(in) :: text
         type(string_t), allocatable :: tmp(:)
         allocate (tmp(size(list) + 1))
         tmp(1:size(list)) = list
         tmp(size(tmp))%s = text
         call move_alloc(tmp, list)
      end subroutine append
   end function make_meta

end module trainsim_run_meta
