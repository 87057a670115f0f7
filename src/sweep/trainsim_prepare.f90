!> Deck + overrides -> model: the one path from a parsed deck to a model that `run`,
!> `modes` and every run of a sweep take. The overrides are set in a copy of the deck
!> (so each plug-in checks them), the model is built, then the derived parameters
!> (mesh_frequency, settle_cycles, measure_cycles) are applied to it. Messages about an
!> override name the override ("--set mesh.half_backlash=abc: error: ...").
module trainsim_prepare
   use trainsim_error, only: error_t
   use trainsim_deck, only: deck_t
   use trainsim_builder, only: build_model
   use trainsim_model, only: model_t
   use trainsim_overrides, only: override_t, apply_overrides, localize_error, localize_text, describe_overrides
   use trainsim_derived, only: apply_derived, default_settle_period
   use trainsim_preload, only: preload_info_t, apply_preload
   implicit none
   private

   public :: prepare_model, prepare_model_in_place

contains

   !> Build `model` from `deck` (without &sweep groups) with the overrides `ovs` applied.
   !> `deck` is not changed.
   !> With &run initial_state = 'preload' the initial angles are the static wind-up
   !> (trainsim_preload), described by `preload` if present.
   subroutine prepare_model(deck, ovs, model, err, preload)
      type(deck_t), intent(in) :: deck
      type(override_t), intent(in) :: ovs(:)
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      type(preload_info_t), intent(out), optional :: preload
      type(deck_t) :: work
      work = deck
      call prepare_model_in_place(work, ovs, model, err, preload)
   end subroutine prepare_model

   !> prepare_model for a caller that has no further use of `deck`: the overrides
   !> are set in it and the builder marks its keys as read, without the copy
   !> (a deep copy of every group, 15 000 instructions a node: D-82).
   subroutine prepare_model_in_place(deck, ovs, model, err, preload)
      type(deck_t), intent(inout) :: deck
      type(override_t), intent(in) :: ovs(:)
      type(model_t), intent(out) :: model
      type(error_t), allocatable, intent(out) :: err
      type(preload_info_t), intent(out), optional :: preload
      type(preload_info_t) :: info
      integer :: i

      call apply_overrides(deck, ovs, err)
      if (.not. allocated(err)) call build_model(deck, model, err)
      if (.not. allocated(err)) model%overrides = describe_overrides(ovs)
      if (.not. allocated(err)) call apply_derived(model, ovs, err)
      ! (parameters set after finalize: its fast-path tables built again, D-114)
      if (.not. allocated(err) .and. any(ovs(:)%derived)) call model%build_fast_path()
      if (.not. allocated(err)) call default_settle_period(model, err)
      if (.not. allocated(err) .and. model%run%preload) call apply_preload(model, info, err)
      if (present(preload)) preload = info
      if (allocated(err)) call localize_error(err, deck%file, ovs)
      if (allocated(model%warnings)) then   ! warnings about an override name it, as errors do
         do i = 1, size(model%warnings)
            call localize_text(model%warnings(i)%s, deck%file, ovs)
         end do
      end if
   end subroutine prepare_model_in_place
end module trainsim_prepare
