!> A plain description of a built train as JSON (`trainsim diagram`): its nodes and
!> elements with their parameters as used, the connections, the loads, prescribed
!> speeds and motor voltages as the deck gives them. scripts/trainsim_diagram.py draws
!> the block diagram from it; nothing here knows how it is drawn.
module trainsim_describe
   use trainsim_kinds, only: wp
   use trainsim_deck, only: deck_t, deck_group_t
   use trainsim_model, only: model_t
   use trainsim_element, only: element_t
   use trainsim_param_list, only: param_list_t
   use trainsim_strings, only: str, to_lower, string_t
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   implicit none
   private

   public :: write_description

contains

   !> Write the description of `model` (built from `deck`) to `unit` as one JSON object:
   !> {"title", "deck_file", "units": {name, length, force, torque, inertia},
   !>  "nodes": [{index, id, type, fixed, prescribed_speed, params: {name: value}, choices: {name: word}}],
   !>  "elements": [{index, id, type, left, right, [ports: {key: node},] displacement_unit, guards, params,
   !>                choices}] (ports: an n-port element's further ports by deck key, e.g. carrier; D-73),
   !>  "loads": [{node, quantity, kind, line, keys: {key: text}}]}.
   !> Node and element indices are 1-based, as in the history file.
   subroutine write_description(deck, model, unit)
      type(deck_t), intent(in) :: deck
      type(model_t), intent(in) :: model
      integer, intent(in) :: unit
      integer :: i, j, k, n
      character(len=:), allocatable :: sep, quantity, kind, node, keys, du

      write (unit, '(a)') '{"title": '//jstr(model%title)//', "deck_file": '//jstr(model%deck_file)//','
      write (unit, '(a)') ' "units": {"name": '//jstr(model%units%name)//', "length": '//jstr(model%units%length)// &
         ', "force": '//jstr(model%units%force)//', "torque": '//jstr(model%units%torque)// &
         ', "inertia": '//jstr(model%units%inertia)//'},'
      write (unit, '(a)') ' "nodes": ['
      do i = 1, size(model%nodes)
         associate (nd => model%nodes(i)%n)
            sep = merge(',', ' ', i < size(model%nodes))
            write (unit, '(a)') '  {"index": '//str(i)//', "id": '//jstr(nd%id)//', "type": '//jstr(nd%type_name)// &
               ', "fixed": '//jbool(nd%is_fixed())//', "prescribed_speed": '//jbool(model%speed_of(i) /= 0)// &
               ', "params": '//jparams(nd%params())//', "choices": '//jchoices(nd%params())//'}'//trim(sep)
         end associate
      end do
      write (unit, '(a)') ' ],'
      write (unit, '(a)') ' "elements": ['
      do i = 1, size(model%elements)
         associate (e => model%elements(i)%e)
            sep = merge(',', ' ', i < size(model%elements))
            du = e%displacement_unit()
            if (du == 'length') du = model%units%length
            write (unit, '(a)') '  {"index": '//str(i)//', "id": '//jstr(e%id)//', "type": '//jstr(e%type_name)// &
               ', "left": '//jstr(model%nodes(e%left)%n%id)//', "right": '//jstr(model%nodes(e%right)%n%id)// &
               more_ports(model, e)//', "displacement_unit": '//jstr(du)//', "guards": '//str(e%n_guards())// &
               ', "params": '//jparams(e%params())//', "choices": '//jchoices(e%params())//'}'//trim(sep)
         end associate
      end do
      write (unit, '(a)') ' ],'
      ! loads as the deck writes them (the model keeps a motor's voltage inside the node)
      write (unit, '(a)') ' "loads": ['
      n = deck%count_groups('load')
      k = 0
      do i = 1, size(deck%groups)
         if (deck%groups(i)%name /= 'load') cycle
         k = k + 1
         associate (g => deck%groups(i))
            node = ''
            quantity = 'torque'
            kind = 'constant'
            keys = ''
            do j = 1, g%nentries()
               if (g%nvalues(j) == 0) cycle
               select case (g%key_of(j))
               case ('node'); node = g%value_of(j, 1)
               case ('quantity'); quantity = to_lower(g%value_of(j, 1))
               case ('kind'); kind = to_lower(g%value_of(j, 1))
               case default
                  if (len(keys) > 0) keys = keys//', '
                  keys = keys//jstr(g%key_of(j))//': '//jstr(tokens(g, j))
               end select
            end do
            sep = merge(',', ' ', k < n)
            write (unit, '(a)') '  {"node": '//jstr(node)//', "quantity": '//jstr(quantity)//', "kind": '// &
               jstr(kind)//', "line": '//str(g%line)//', "keys": {'//keys//'}}'//trim(sep)
         end associate
      end do
      write (unit, '(a)') ' ]'
      write (unit, '(a)') '}'
   end subroutine write_description

   !> The raw tokens of a deck value, joined by ', ' (a long table: its first 6 and a count).
   !> ', "ports": {"carrier": "housing"}' for an element with ports beyond left and
   !> right (D-73), '' for a two-port element.
   function more_ports(model, e) result(s)
      type(model_t), intent(in) :: model
      class(element_t), intent(in) :: e
      character(len=:), allocatable :: s
      integer :: k
      s = ''
      if (e%n_ports() == 2) return
      do k = 3, e%n_ports()
         if (k > 3) s = s//', '
         s = s//jstr(e%port_keys(k - 2)%s)//': '//jstr(model%nodes(e%port(k))%n%id)
      end do
      s = ', "ports": {'//s//'}'
   end function more_ports

   function tokens(g, j) result(s)
      type(deck_group_t), intent(in) :: g
      integer, intent(in) :: j
      character(len=:), allocatable :: s
      integer :: k
      s = ''
      do k = 1, min(g%nvalues(j), 6)
         if (k > 1) s = s//', '
         s = s//g%value_of(j, k)
      end do
      if (g%nvalues(j) > 6) s = s//', ... ('//str(g%nvalues(j))//' values)'
   end function tokens

   !> {"name": value, ...} of a parameter list (a value that is not finite: null).
   function jparams(p) result(s)
      type(param_list_t), intent(in) :: p
      character(len=:), allocatable :: s
      integer :: k
      s = '{'
      do k = 1, size(p%names)
         if (k > 1) s = s//', '
         s = s//jstr(p%names(k)%s)//': '//jnum(p%values(k))
      end do
      s = s//'}'
   end function jparams

   !> {"name": "word", ...} of the choice keys of a parameter list (stiffness_fit: 'tight').
   function jchoices(p) result(s)
      type(param_list_t), intent(in) :: p
      character(len=:), allocatable :: s
      integer :: k
      s = '{'
      if (allocated(p%words)) then
         do k = 1, min(size(p%words), size(p%names))
            if (len(p%words(k)%s) == 0) cycle
            if (len(s) > 1) s = s//', '
            s = s//jstr(p%names(k)%s)//': '//jstr(p%words(k)%s)
         end do
      end if
      s = s//'}'
   end function jchoices

   !> A real as a JSON number, to full precision (null if it is not finite).
   function jnum(x) result(s)
      real(wp), intent(in) :: x
      character(len=:), allocatable :: s
      character(len=32) :: buf
      if (.not. ieee_is_finite(x)) then
         s = 'null'
         return
      end if
      write (buf, '(es24.16e3)') x
      s = trim(adjustl(buf))
   end function jnum

   pure function jbool(b) result(s)
      logical, intent(in) :: b
      character(len=:), allocatable :: s
      if (b) then
         s = 'true'
      else
         s = 'false'
      end if
   end function jbool

   !> `text` as a JSON string: quotes, backslashes and control characters escaped.
   pure function jstr(text) result(s)
      character(len=*), intent(in) :: text
      character(len=:), allocatable :: s
      character(len=*), parameter :: hex = '0123456789abcdef'
      integer :: k, c
      s = '"'
      do k = 1, len(text)
         c = iachar(text(k:k))
         if (text(k:k) == '"' .or. text(k:k) == '\') then
            s = s//'\'//text(k:k)
         else if (c < 32) then
            s = s//'\u00'//hex(c/16 + 1:c/16 + 1)//hex(mod(c, 16) + 1:mod(c, 16) + 1)
         else
            s = s//text(k:k)
         end if
      end do
      s = s//'"'
   end function jstr
end module trainsim_describe
