"""redservo.records.lazy: a read-only record made eagerly or with fields built on first read,
behaving as the NamedTuple it replaces where callers use one."""

from __future__ import annotations

import copy
import pickle
from typing import Any, ClassVar, NamedTuple

import pytest

from redservo.records.lazy import LazyRecord, lazy_field


class Pair(LazyRecord):
    """A public record type of two fields."""

    _fields = ("a", "b")
    a: int
    b: list[int]


class Defaulted(LazyRecord):
    """A record with a default, as a NamedTuple's ``x: int = 0``."""

    _fields = ("x", "y")
    _field_defaults = {"y": 7}  # noqa: RUF012 - as NamedTuple's class attribute
    x: int
    y: int


def test_a_field_default_and_bad_field_names() -> None:
    assert Defaulted(1) == (1, 7) and Defaulted(1, y=2)._asdict() == {"x": 1, "y": 2}
    with pytest.raises(ValueError, match="public identifiers"):
        type("Bad", (LazyRecord,), {"_fields": ("a", "_b")})


class LazyPair(Pair):
    """``Pair`` on a source ``(a, counter)``: ``b`` is made (and counted) on first read."""

    made: ClassVar[list[str]] = []

    @lazy_field
    def a(self) -> int:
        LazyPair.made.append("a")
        return int(self._src[0])

    @lazy_field
    def b(self) -> list[int]:
        LazyPair.made.append("b")
        return [self._src[0], self._src[0] + 1]


class Tup(NamedTuple):
    a: int
    b: list[int]


def test_a_lazy_field_is_made_once_on_first_read_and_kept() -> None:
    LazyPair.made.clear()
    r = LazyPair._lazy((3,))
    assert LazyPair.made == []
    b = r.b
    assert b == [3, 4] and r.b is b and LazyPair.made == ["b"]
    assert r.a == 3 and r.a == 3 and LazyPair.made == ["b", "a"]
    assert isinstance(r, Pair) and not isinstance(r, tuple)


@pytest.mark.parametrize("make", [lambda: Pair(3, [3, 4]), lambda: LazyPair._lazy((3,))])
def test_records_behave_as_the_named_tuple_they_replace(make: Any) -> None:
    r, t = make(), Tup(3, [3, 4])
    a, b = r
    assert (a, b) == tuple(t) and len(r) == 2 and r[0] == 3 and r[-1] == [3, 4] and r[:1] == (3,)
    assert r == t and r == Pair(a=3, b=[3, 4]) and r != Pair(3, [0])
    assert repr(r) == "Pair(a=3, b=[3, 4])"
    assert r._fields == ("a", "b") and r._asdict() == t._asdict()
    assert r._replace(a=5) == Pair(5, [3, 4]) and type(r._replace(a=5)) is Pair
    assert Pair._make([1, [2]]) == Pair(1, [2])
    for back in (pickle.loads(pickle.dumps(r)), copy.copy(r), copy.deepcopy(r)):
        assert type(back) is Pair and back == r
    match r:
        case Pair(a=x, b=y):
            assert (x, y) == (3, [3, 4])


def test_a_record_is_read_only_and_its_constructor_checks_its_fields() -> None:
    r = LazyPair._lazy((1,))
    with pytest.raises(AttributeError, match="read-only"):
        r.a = 2
    with pytest.raises(AttributeError, match="read-only"):
        del r.b
    with pytest.raises(TypeError, match="missing 1 required positional argument: 'b'"):
        Pair(1)
    with pytest.raises(TypeError, match="takes 3 positional arguments but 4 were given"):
        Pair(1, 2, 3)
    with pytest.raises(TypeError, match="unexpected keyword argument 'c'"):
        Pair(1, 2, c=3)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="multiple values for argument 'a'"):
        Pair(1, a=2)  # type: ignore[misc]
    with pytest.raises(ValueError, match=r"\['c'\]"):
        Pair(1, 2)._replace(c=3)
    with pytest.raises(TypeError):
        hash(Pair(1, [2]))  # a list field: unhashable, as in the tuple
    assert hash(Pair(1, 2)) == hash((1, 2))
