"""Read-only records whose fields are made when first read (a hot loop's results).

A step of a control loop returns a record (the command, the task state, the diagnostics,
...) that the loop usually reads one field of, or none. Building every field as a
``NamedTuple`` does (array views of a kernel's buffer, nested records) costs more than the
arithmetic on a small arm. :class:`LazyRecord` is the record's public type with the
behaviour of a ``NamedTuple`` that its callers use (attribute access, unpacking and
iteration, ``len``, indexing, ``==`` with another record or a tuple, ``repr``, pickling and
copying, ``_fields``, ``_asdict``, ``_replace``, ``_make``), made either

* **eagerly**, ``Record(a, b, ...)`` or by keyword, every field given (what a
  ``NamedTuple``'s constructor takes); or
* **lazily**, by a subclass whose fields are :class:`lazy_field` functions of one source
  object (``_src``, what the step produced, given to :meth:`LazyRecord._lazy`): each field is
  computed on its first read, then kept (a plain attribute read afterwards).

A lazy record never changes under its caller: its source must be what the step made for
this record alone (a buffer the next step does not overwrite), and each field, once read,
stays the same object. It is read-only (setting an attribute raises ``AttributeError``, as
on a ``NamedTuple``), and pickles, copies and compares as the eager record of its public
type (the subclass declaring ``_fields``). Not a ``tuple``: ``isinstance(r, tuple)`` is
False, and ``r + (x,)`` is not defined.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any, ClassVar, Generic, TypeVar, overload

__all__ = ["LazyRecord", "lazy_field"]

T = TypeVar("T")
R = TypeVar("R", bound="LazyRecord")

_new = object.__new__


class lazy_field(Generic[T]):
    """A field of a :class:`LazyRecord` subclass computed by ``fn(record)`` on its first read
    (``fn`` reads ``record._src``) and then kept in the record (later reads are plain
    attribute reads)."""

    def __init__(self, fn: Callable[[Any], T]) -> None:
        self.fn = fn
        self.name = fn.__name__
        self.__doc__ = fn.__doc__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> lazy_field[T]: ...

    @overload
    def __get__(self, obj: object, owner: type | None = None) -> T: ...

    def __get__(self, obj: object, owner: type | None = None) -> T | lazy_field[T]:
        if obj is None:
            return self
        value = obj.__dict__[self.name] = self.fn(obj)
        return value


class LazyRecord:
    """Base of a read-only record of named fields (module docstring). A public record type
    declares ``_fields`` (and may declare ``_field_defaults``); its lazy subclasses declare
    their fields as :class:`lazy_field` and are made by :meth:`_lazy`."""

    __slots__ = ("__dict__", "_src")
    _src: Any
    """What a lazy record's fields are made from (unset for an eager record)."""
    _fields: ClassVar[tuple[str, ...]] = ()
    _field_defaults: ClassVar[dict[str, Any]] = {}
    _public: ClassVar[type[LazyRecord]]
    """The class declaring ``_fields`` (what a lazy subclass prints, pickles and compares as)."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "_fields" in cls.__dict__:
            cls._public = cls
            setattr(cls, "__match_args__", cls._fields)  # noqa: B010 - a class attribute
            cls.__init__ = _constructor(cls)  # type: ignore[method-assign]

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        """Every field by position or keyword (the public class's own constructor, made
        from ``_fields`` and ``_field_defaults`` as a ``NamedTuple``'s is)."""
        raise TypeError(f"{type(self).__name__} declares no _fields")

    @classmethod
    def _lazy(cls: type[R], src: Any) -> R:
        """A record of ``cls`` (a subclass with :class:`lazy_field` fields) on ``src``."""
        record = _new(cls)
        _set_src(record, src)
        return record

    @classmethod
    def _make(cls: type[R], iterable: Any) -> R:
        """The record of the values of ``iterable`` in field order (``NamedTuple._make``)."""
        return cls._public(*iterable)  # type: ignore[return-value]

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{self._public.__name__} is read-only (field {name!r})")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"{self._public.__name__} is read-only (field {name!r})")

    def __iter__(self) -> Iterator[Any]:
        return iter([getattr(self, name) for name in self._fields])

    def __len__(self) -> int:
        return len(self._fields)

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, int):
            return getattr(self, self._fields[index])
        return tuple(self)[index]

    def __eq__(self, other: object) -> bool:
        if isinstance(other, LazyRecord):
            return self._public is other._public and tuple(self) == tuple(other)
        if isinstance(other, tuple):
            return tuple(self) == other
        return NotImplemented

    def __hash__(self) -> int:
        return hash(tuple(self))

    def __repr__(self) -> str:
        body = ", ".join(f"{name}={getattr(self, name)!r}" for name in self._fields)
        return f"{self._public.__name__}({body})"

    def __reduce__(self) -> tuple[Any, ...]:
        return (self._public, tuple(self))

    def _asdict(self) -> dict[str, Any]:
        """The fields by name, in order (``NamedTuple._asdict``)."""
        return {name: getattr(self, name) for name in self._fields}

    def _replace(self: R, **changes: Any) -> R:
        """A new (eager) record with ``changes`` (``NamedTuple._replace``).

        Raises:
            ValueError: a name in ``changes`` is not a field.
        """
        unknown = sorted(set(changes) - set(self._fields))
        if unknown:
            raise ValueError(f"{self._public.__name__} has no field(s) {unknown}")
        return self._public(**{**self._asdict(), **changes})  # type: ignore[return-value]


_set_src = LazyRecord._src.__set__
"""Set a record's source (the slot's own setter: :meth:`LazyRecord.__setattr__` refuses)."""
_set_dict = LazyRecord.__dict__["__dict__"].__set__
"""Set a record's field dictionary (what an eager record's constructor does)."""


def _constructor(cls: type[LazyRecord]) -> Callable[..., None]:
    """``cls.__init__(self, <fields>)``: the fields by position or keyword, with the defaults
    of ``cls._field_defaults``, into the record's dictionary (generated, as ``NamedTuple``
    generates its ``__new__``: Python checks the arguments, at the cost of one call)."""
    fields, defaults = cls._fields, cls._field_defaults
    if not all(f.isidentifier() and not f.startswith("_") for f in fields):
        raise ValueError(f"{cls.__name__}._fields must be public identifiers, got {fields}")
    params = ", ".join(f"{f}=_d[{f!r}]" if f in defaults else f for f in fields)
    body = ", ".join(f"{f!r}: {f}" for f in fields)
    code = f"def __init__(self, {params}):\n    _set_dict(self, {{{body}}})\n"
    scope: dict[str, Any] = {"_d": defaults, "_set_dict": _set_dict}
    exec(code, scope)
    init: Callable[..., None] = scope["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    init.__doc__ = f"A {cls.__name__} of every field: {', '.join(fields)}."
    return init
