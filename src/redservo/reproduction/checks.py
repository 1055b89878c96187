"""Claims declared as small named checks, and their verdicts.

Every statement the reproduction verifies is a :class:`Check`: a stable ``name``, the
statement as printed in the report, its ``kind`` and a function of the runs that returns
a :class:`Verdict` (does it hold, and the numbers it was decided from). The report and the
robustness sweep iterate over an experiment's checks; nothing is written by hand.

Two kinds (the report's headline counts the first only):

* ``"paper claim"``: something a paper states about its experiment (a limit hit, an
  axis stopped first, a faster convergence...) that the implementation could fail. Each
  quotes the paper's sentence in its docstring.
* ``"implementation check"``: a property that holds *by construction* of the law, the
  simulator or the equations (one axis stopped at a time, a stopped axis has zero speed, an
  exact-Jacobian law decays exponentially, the projector's rank is 0 away from the limits,
  a bound of eq. 9), and **set-up checks**, outcomes of the chosen set-up that the
  experiment needs (with no avoidance a limit is hit, so there is something to avoid).
  Useful tests that the code and the scenario do what docs/formulas.md says, not
  reproductions.

A statement checked in several variants of one experiment (two critical-axis rules of
gpm-auto; MC05 §V-A on two start poses) is one statement: the variant's check names the
one it restates (``statement``) and the headline counts it once.

Declare checks with :func:`registrar`::

    CHECKS: list[Check] = []
    check = registrar(CHECKS)

    @check("classical-hits-axis-1", PAPER, "With no avoidance a joint limit is hit", "CM01 §V-A2")
    def _classical(runs: Runs) -> Verdict:
        ...
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    from redservo.reproduction.base import Runs

__all__ = [
    "IMPL",
    "KINDS",
    "PAPER",
    "Check",
    "CheckFn",
    "Claim",
    "Kind",
    "Registrar",
    "Verdict",
    "evaluate",
    "registrar",
]

Kind = Literal["paper claim", "implementation check"]
PAPER: Kind = "paper claim"
IMPL: Kind = "implementation check"
KINDS: tuple[Kind, ...] = (PAPER, IMPL)


@dataclass(frozen=True)
class Verdict:
    """What a check finds on the logs.

    Attributes:
        holds: The verdict.
        evidence: The numbers it was computed from (plain JSON values).
        note: Why it does not hold, or any caveat (empty if none).
    """

    holds: bool
    evidence: dict[str, Any] = field(default_factory=dict)
    note: str = ""


CheckFn = Callable[["Runs"], Verdict]


@dataclass
class Claim:
    """The verdict of one check on one set of runs (what the report prints).

    Attributes:
        claim: The statement.
        reproduced: Whether it holds on these logs.
        evidence: The numbers the verdict was computed from.
        note: Why, when it does not hold (or any caveat).
        name: The check's stable identifier.
        kind: ``"paper claim"`` or ``"implementation check"``.
        source: Where the paper states it (e.g. ``"CM01 §V-A2, Fig. 9"``).
        statement: The statement it checks (the name of the check it restates, or its own).
    """

    claim: str
    reproduced: bool
    evidence: dict[str, Any]
    note: str = ""
    name: str = ""
    kind: Kind = PAPER
    source: str = ""
    statement: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "kind": self.kind,
            "claim": self.claim,
            "source": self.source,
            "statement": self.statement or self.name,
            "reproduced": bool(self.reproduced),
            "evidence": self.evidence,
            "note": self.note,
        }


@dataclass(frozen=True)
class Check:
    """A claim or an implementation check, declared once and evaluated on any runs.

    Attributes:
        name: Stable identifier, unique within its experiment (``kebab-case``).
        text: The statement, as printed in the report.
        kind: ``"paper claim"`` or ``"implementation check"`` (module docstring).
        fn: ``f(runs) -> Verdict``.
        source: Where the paper states it.
        statement: The name of the check this one restates in a variant of the same
            experiment (counted once in the headline), or "" (its own statement).
    """

    name: str
    text: str
    kind: Kind
    fn: CheckFn
    source: str = ""
    statement: str = ""

    def __call__(self, runs: Runs) -> Claim:
        """Evaluate on ``runs``; a check that raises does not hold (the error is the note)."""
        try:
            v = self.fn(runs)
        except (KeyError, IndexError, ValueError, ZeroDivisionError, FloatingPointError) as exc:
            # A perturbed run may lack what the check reads (e.g. no constrained axis at all).
            v = Verdict(False, {"error": type(exc).__name__}, f"could not be computed: {exc}")
        return Claim(
            self.text,
            bool(v.holds),
            v.evidence,
            v.note,
            self.name,
            self.kind,
            self.source,
            self.statement or self.name,
        )


class Registrar:
    """Decorator ``@check(name, kind, text, source)`` that appends a :class:`Check` to a list.

    The decorated function is returned unchanged, so it can still be called directly.

    Raises:
        ValueError: an unknown ``kind`` or a name already in the list.
    """

    def __init__(self, target: list[Check]) -> None:
        self.target = target

    def __call__(
        self, name: str, kind: Kind, text: str, source: str = "", *, statement: str = ""
    ) -> Callable[[CheckFn], CheckFn]:
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
        if any(c.name == name for c in self.target):
            raise ValueError(f"duplicate check name {name!r}")

        def deco(fn: CheckFn) -> CheckFn:
            self.target.append(Check(name, text, kind, fn, source, statement))
            return fn

        return deco


def registrar(target: list[Check]) -> Registrar:
    """Return the decorator ``@check(name, kind, text, source="")`` appending to ``target``."""
    return Registrar(target)


def evaluate(checks: Sequence[Check], runs: Runs) -> list[Claim]:
    """Evaluate every check on ``runs``, in declaration order."""
    return [c(runs) for c in checks]
