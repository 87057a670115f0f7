!> The inputs of a run as the run saw them, for the history's /inputs: each external
!> torque load, each prescribed speed and each node's own driving input (a DC motor's
!> voltage), evaluated at the sample times (issue #21 item 2). Not on the hot path:
!> once per output sample.
!>
!> Columns, in this order: the torque loads in deck order, named `<node>.load_torque`
!> (`<node>.load_torque#k` for a node's k-th load when it has several); the prescribed
!> speeds, `<node>.prescribed_speed` in node order; the nodes' driving inputs,
!> `<node>.<quantity>` (`motor.voltage`) in node order.
module trainsim_input_series
   use trainsim_kinds, only: wp
   use trainsim_strings, only: string_t, str
   use trainsim_model, only: model_t
   use trainsim_motion, only: given_speed
   implicit none
   private

   public :: input_series_count, input_series_labels, input_drivers, input_series_values

contains

   !> Number of input series of the model.
   integer function input_series_count(model) result(n)
      type(model_t), intent(in) :: model
      integer :: i
      character(len=:), allocatable :: q, u
      n = size(model%loads) + count(model%speed_of /= 0)
      do i = 1, size(model%nodes)
         call model%nodes(i)%n%driving_input(q, u)
         if (len(q) > 0) n = n + 1
      end do
   end function input_series_count

   !> Names and units of the input series (size input_series_count each).
   subroutine input_series_labels(model, names, units)
      type(model_t), intent(in) :: model
      type(string_t), allocatable, intent(out) :: names(:), units(:)
      integer :: i, j, k, nth, total
      character(len=:), allocatable :: q, u
      allocate (names(input_series_count(model)), units(input_series_count(model)))
      k = 0
      do j = 1, size(model%loads)
         associate (nid => model%nodes(model%loads(j)%node)%n%id)
            nth = count(model%loads(1:j)%node == model%loads(j)%node)
            total = count(model%loads%node == model%loads(j)%node)
            k = k + 1
            names(k)%s = nid//'.load_torque'
            if (total > 1) names(k)%s = names(k)%s//'#'//str(nth)
            units(k)%s = model%units%torque
         end associate
      end do
      do i = 1, size(model%nodes)
         if (model%speed_of(i) == 0) cycle
         k = k + 1
         names(k)%s = model%nodes(i)%n%id//'.prescribed_speed'
         units(k)%s = 'rad/s'
      end do
      do i = 1, size(model%nodes)
         call model%nodes(i)%n%driving_input(q, u)
         if (len(q) == 0) cycle
         k = k + 1
         names(k)%s = model%nodes(i)%n%id//'.'//q
         units(k)%s = u
      end do
   end subroutine input_series_labels

   !> The nodes that have a driving input, in node order (once per run, for
   !> input_series_values).
   function input_drivers(model) result(nodes)
      type(model_t), intent(in) :: model
      integer, allocatable :: nodes(:)
      integer :: i
      character(len=:), allocatable :: q, u
      allocate (nodes(0))
      do i = 1, size(model%nodes)
         call model%nodes(i)%n%driving_input(q, u)
         if (len(q) > 0) nodes = [nodes, i]
      end do
   end function input_drivers

   !> The input series at time t (v sized input_series_count; drivers from
   !> input_drivers). No allocation: once per output sample.
   subroutine input_series_values(model, drivers, t, v)
      type(model_t), intent(in) :: model
      integer, intent(in) :: drivers(:)
      real(wp), intent(in) :: t
      real(wp), intent(out) :: v(:)
      integer :: i, j, k
      k = 0
      do j = 1, size(model%loads)
         k = k + 1
         v(k) = model%loads(j)%torque%value(t)
      end do
      do i = 1, size(model%nodes)
         if (model%speed_of(i) == 0) cycle
         k = k + 1
         associate (m => model%speeds(model%speed_of(i)))
            if (m%given == given_speed) then   ! (the time function itself: one call, as before D-78)
               v(k) = m%f%value(t)
            else
               v(k) = m%value(t)
            end if
         end associate
      end do
      do j = 1, size(drivers)
         k = k + 1
         v(k) = model%nodes(drivers(j))%n%driving_input_value(t)
      end do
   end subroutine input_series_values
end module trainsim_input_series
