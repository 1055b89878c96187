"""One declaration per law (issue 29, item 2): the ids, the option slots and the compiled
dispatch come from the laws' declarations (``KERNEL``, ``slotted``), and a new law is one
file (examples/custom_law_damped.py), compiled through ``simulate`` and a campaign."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from redservo.errors import ConfigurationError
from redservo.kernels import lawopts
from redservo.redundancy import law_class, registered_methods
from redservo.redundancy.declare import (
    OUTPUTS,
    LawKernel,
    bind_law,
    declared_laws,
    kernel_class,
    law_slots,
)
from redservo.redundancy.options import COMMON_SLOTS, RCOND, Option, slotted
from tests.examples_cache import run_example

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "custom_law_damped.py"


def test_the_ids_and_the_dispatch_come_from_the_declarations() -> None:
    from redservo.kernels import law_dispatch

    declared = [name for name, _ in declared_laws(registered_methods())]
    assert list(law_dispatch.LAW_IDS) == declared
    assert list(law_dispatch.LAW_IDS.values()) == list(range(len(declared)))
    # every shipped method but the solver-based ones (qp-goal is qp with a goal) declares its kernel
    assert set(registered_methods()) - set(declared) == {"qp", "predictive", "qp-goal"}
    called = {v for k, v in vars(law_dispatch).items() if k[:2] == "_k" and k[2:].isdigit()}
    for name in law_dispatch.LAW_IDS:
        module, func = law_class(name).KERNEL.kernel.split(":")
        assert getattr(importlib.import_module(module), func) in called, name
    assert law_dispatch.SOURCE.count("def ") == 2


def test_no_law_slot_is_numbered_by_hand() -> None:
    shared = {"NF", "NI", "F_RCOND", "F_ROBUST", "I_SHIELD", "I_FIRST"}
    assert {k for k in vars(lawopts) if k.isupper()} == shared
    assert lawopts.__all__ == sorted(shared)


def test_slots_are_numbered_in_declaration_order() -> None:
    opts, slots = slotted(
        (
            Option("a", 1.0, slot_kind="f"),
            Option("flag", False, kind="bool", slot_kind="i"),
            RCOND,
            Option("b", 2.0, slot_kind="f"),
            Option("per", None, kind="per-joint", none=True, slot_kind="v"),
        ),
        packed=(("extra", "f"), ("count", "i")),
    )
    assert [o.slot for o in opts] == [("f", 2), ("i", 2), ("f", 0), ("f", 3), ("v", 0)]
    assert slots == {
        **COMMON_SLOTS,
        "a": ("f", 2),
        "flag": ("i", 2),
        "rcond": ("f", 0),
        "b": ("f", 3),
        "per": ("v", 0),
        "extra": ("f", 4),
        "count": ("i", 3),
    }


def test_too_many_slots_is_one_clear_error() -> None:
    many = tuple(Option(f"x{i}", 0.0, slot_kind="f") for i in range(lawopts.NF - 1))
    with pytest.raises(ConfigurationError, match=r"more than 8 packed 'f' slots"):
        slotted(many)


def test_every_shipped_law_packs_its_options_where_its_declaration_reads_them() -> None:
    for name, cls in declared_laws(registered_methods()):
        slots = law_slots(cls)
        for token in (*cls.KERNEL.args.split(), *cls.KERNEL.event_args.split()):
            if token.startswith("opt."):
                assert token[4:].rstrip("?") in slots, (name, token)
        taken = [s for s in slots.values()]
        assert len(taken) == len(set(taken)), f"{name}: two names share a slot"


def test_named_outputs_replace_numbers() -> None:
    from redservo.kernels.law_dispatch import F_SNS_SCALE, I_SNS_BAD, I_SNS_RESTORED

    sns = law_class("sns").KERNEL
    assert (I_SNS_RESTORED, I_SNS_BAD) == (sns.output("restored")[1], sns.output("bad_joint")[1])
    assert F_SNS_SCALE == OUTPUTS["scale"][1]
    with pytest.raises(KeyError):
        sns.output("nothing")


def test_a_bad_declaration_is_one_clear_error() -> None:
    base = law_class("classical")

    def law(**kw: str) -> type:
        fields = {
            "kernel": "redservo.kernels.laws:classical",
            "args": "J1 e lam sec has_sec opt.rcond opt.robust",
            "events": "redservo.kernels.events:classical_events",
            "event_args": "m n iout opt.robust",
        }
        return type("Bad", (base,), {"name": "bad", "KERNEL": LawKernel(**{**fields, **kw})})

    with pytest.raises(ConfigurationError, match=r"Bad.KERNEL: unknown argument 'lambda'"):
        bind_law("bad", law(args="J1 e lambda"))
    with pytest.raises(ConfigurationError, match=r"'opt.alpha' is not a packed option of 'bad'"):
        bind_law("bad", law(args="J1 e opt.alpha"))
    with pytest.raises(ConfigurationError, match=r"events kernel reads float options only"):
        bind_law("bad", law(event_args="m opt.shield"))
    with pytest.raises(ConfigurationError, match=r"no kernel 'redservo.kernels.laws:nothing'"):
        bind_law("bad", law(kernel="redservo.kernels.laws:nothing"))


def test_only_a_class_declaring_its_kernel_or_defined_beside_it_runs_it() -> None:
    from redservo.redundancy.wln import WeightedLeastNorm, _WeightedLeastNormHistory

    assert kernel_class(_WeightedLeastNormHistory) is WeightedLeastNorm
    assert kernel_class(law_class("classical")) is law_class("classical")
    elsewhere = type("Mine", (law_class("gpm"),), {"__module__": "user.laws"})
    assert kernel_class(elsewhere) is None
    assert kernel_class(law_class("qp")) is None


@pytest.mark.xdist_group("examples")  # one compiled chain (tests/examples_cache.py)
def test_a_new_law_is_one_file_and_runs_compiled() -> None:
    """The example's law (one file) has an id, runs on the compiled step through ``run``
    (hence ``simulate``) and on the campaign's compiled loop, beside a shipped law."""
    from redservo.kernels import compiled

    if not compiled():
        pytest.skip("numba is not installed")
    # its own numba cache, shared with the robot-kind example (tests/examples_cache.py)
    done = run_example("custom_law_damped")
    assert done.returncode == 0, done.stderr
    text = done.stdout
    assert "engine compiled" in text
    assert "campaign: classical" in text and "campaign: damped" in text
    assert "Engine: 4 run(s) computed by this call on the compiled loop." in text
    assert "object path" not in text


def test_the_new_law_matches_its_formula_on_the_reference_path() -> None:
    """The plain-Python path of the same declaration: the damped command, the safety layer
    off its limits, equals ``-λ J1ᵀ(J1J1ᵀ + μ²I)⁻¹ e1``."""
    code = (
        "import sys, numpy as np, redservo\n"
        f"sys.path.insert(0, {str(EXAMPLE.parent)!r})\n"
        "import custom_law_damped\n"
        "from redservo.kernels.step import LAW_IDS\n"
        "assert 'damped' in LAW_IDS\n"
        "law = redservo.make_law('damped', damping=0.2)\n"
        "rng = np.random.default_rng(1)\n"
        "J1, e1 = rng.normal(size=(3, 6)), rng.normal(size=3) * 1e-3\n"
        "lim = redservo.JointLimits(-np.ones(6) * 3, np.ones(6) * 3)\n"
        "r = law(J1=J1, e1=e1, q=np.zeros(6), limits=lim, lam=0.5, dt=0.01)\n"
        "ref = -0.5 * J1.T @ np.linalg.solve(J1 @ J1.T + 0.04 * np.eye(3), e1)\n"
        "assert np.allclose(r.qdot, ref, atol=1e-12), (r.qdot, ref)\n"
        "print('ok', r.diagnostics.method)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, "PYTHONPATH": str(ROOT / "src"), "REDSERVO_NO_NUMBA": "1"},
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["ok", "damped"]


def test_the_generated_dispatch_is_part_of_its_callers_cache_stamp() -> None:
    """A law added or edited changes the numba cache stamp of the dispatch and of the step
    that calls it (a stale compiled step is never loaded); the same laws keep the stamp."""
    from redservo.kernels import _jit, law_dispatch

    step_file = str(Path(law_dispatch.__file__).with_name("step.py"))
    before = _jit._stamp(step_file)
    saved = _jit._EXTRA["law_dispatch"]
    try:
        _jit.add_stamp("law_dispatch", saved + b"\n# another law")
        assert _jit._stamp(step_file) != before
        _jit.add_stamp("law_dispatch", saved)
        assert _jit._stamp(step_file) == before
    finally:
        _jit.add_stamp("law_dispatch", saved)
