"""A new control law in one file: damped least squares, compiled into the step kernel.

``q̇ = -λ J1ᵀ (J1 J1ᵀ + μ² I)⁻¹ e + J1^⊥ secondary`` (Wampler 1986; Nakamura & Hanafusa
1986): the classical law (CM01 eq. 2) with its pseudo-inverse damped by μ, so that the
command stays bounded near a singular task Jacobian. Everything a law needs is below: its
kernel (a :func:`~redservo.kernels._jit.kernel`), its options (slots numbered by
:func:`~redservo.redundancy.options.slotted`) and its declaration (``KERNEL``); the ids,
the compiled dispatch, the packing and the safety layer come from the library
(docs/extending.md, "Add a law"). Register the law before the first compiled step of the
process (here: at import, before any run).

    python examples/custom_law_damped.py [--samples N] [--quick]
"""

from __future__ import annotations

import argparse
from typing import Any

import redservo
from redservo.kernels._jit import kernel
from redservo.kernels.laws import I_PROJ, new_outputs, svd_outputs
from redservo.kernels.linalg import null_project, task_svd
from redservo.records import outcome_text
from redservo.redundancy import register
from redservo.redundancy.classical import Classical
from redservo.redundancy.declare import LawKernel
from redservo.redundancy.options import RCOND, Option, slotted


@kernel
def damped_kernel(
    J1: Any, e: Any, lam: float, sec: Any, has_sec: bool, mu: float, rcond: float, robust: float
) -> Any:
    """The damped command (module docstring) in the common layout of
    :mod:`redservo.kernels.laws`: ``-λ Σ σᵢ/(σᵢ² + μ²) vᵢ uᵢᵀ e`` over the singular triplets
    of ``J1`` (m, n), plus the secondary command (n,) projected on ``Ker J1``; rad/s or m/s."""
    n = J1.shape[1]
    U, sigma, V, rank, _, filtered = task_svd(J1, rcond, robust)
    qdot, iout, fout, axes, axf, vec = new_outputs(n, 0)
    for i in range(sigma.shape[0]):
        c = 0.0
        for r in range(U.shape[0]):
            c += U[r, i] * e[r]
        w = lam * c * sigma[i] / (sigma[i] * sigma[i] + mu * mu)  # μ > 0: never 0/0
        for j in range(n):
            qdot[j] -= w * V[j, i]
    if has_sec:
        ns = null_project(V, rank, sec)
        for j in range(n):
            qdot[j] += ns[j]
        iout[I_PROJ] = n - rank
    svd_outputs(sigma, rank, filtered, iout, fout)
    return qdot, iout, fout, axes, axf, vec


@register
class Damped(Classical):
    """Damped least squares: the classical law with ``(J1 J1ᵀ + μ² I)⁻¹`` (module docstring);
    its diagnostics and events are the classical law's."""

    name = "damped"
    description = "damped least squares, q̇ = -λ J1ᵀ(J1J1ᵀ + μ²I)⁻¹ e1: no avoidance"
    KERNEL = LawKernel(
        f"{__name__}:damped_kernel",
        "J1 e lam sec has_sec opt.damping opt.rcond opt.robust",
        "redservo.kernels.events:classical_events",
        "m n iout opt.robust",
    )
    OPTIONS, SLOTS = slotted(
        (
            Option(
                "damping",
                0.05,
                doc="damping μ of the task inverse, in the units of J1's singular values",
                ref="Wampler 1986; Nakamura & Hanafusa 1986",
                low=0.0,
                low_open=True,
                slot_kind="f",
            ),
            RCOND,
        )
    )
    damping: float


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=8, help="campaign samples (default 8)")
    parser.add_argument("--quick", action="store_true", help="short runs (tests)")
    args = parser.parse_args(argv)
    iters = {"max_iterations": 30} if args.quick else {}
    r = redservo.run("afma6-gaze-demo", method="damped", **iters)
    print(f"simulate: {outcome_text(r.summary)}, engine {r.engine}")
    res = redservo.campaign(
        "afma6-gaze-demo",
        methods=["classical", "damped"],
        samples=2 if args.quick else args.samples,
    )
    for method, st in res.stats.items():
        print(f"campaign: {method:10s} success {st.successes}/{st.runs}")
    print(*(line for line in res.markdown.splitlines() if line.startswith("Engine:")))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
