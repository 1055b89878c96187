"""Fuzz every control law with random and degenerate inputs (issue 8 item 9).

    .venv/bin/python benchmarks/fuzz_laws.py [--calls 1000000] [--workers 2] [--seed 0]
                                             [--shield-off] [--json fuzz.json] [--replay CASE]

Every method of :data:`redservo.METHODS`, with its defaults (shield on, robust on), is
called on the same random case; cases are drawn until ``--calls`` law calls are made.
A case mixes (each with some probability): a random ``J1`` (m = 1..8, n = 2..9),
rank-deficient ones (duplicate, nearly duplicate or zero rows, zero columns, low rank,
all zero), condition numbers up to 1e16, ``J1`` and ``e1`` scaled by 1e-12..1e12, joints
exactly at the thresholds q̃, at the limits, at the safe limits (limits less the margin),
one float step around them, inside the margin band, up to 1e-9 beyond a limit (the
validation tolerance), more joints in the band than the redundancy, ``secondary`` up to
1e12, ``de1_dt``, ``qdot_prev`` within the velocity limits or None, limits with and
without ``qdot_max``, ``qddot_max`` and a margin, ``dt`` in 1e-4..0.2 s and ``lam`` in
1e-3..50 1/s or an :class:`~redservo.AdaptiveGain`.

Zero targets, per law (exact float64, no tolerance; the exit code is 1 if any is non-zero):

* ``nonfinite``: ``q̇`` holds NaN or inf;
* ``vel``: some ``|q̇_i| > qdot_max_i``;
* ``cross``: a joint with ``q_i`` in ``[safe_min, safe_max]`` gets ``q_i + dt q̇_i`` outside;
* ``outward``: a joint in the margin band (or beyond its limit) moves further out;
* ``exc``: the call raised (every input is valid).

Reported as well: ``nanfix`` (calls where the law itself produced NaN/inf and the safety
stage replaced it, flag ``non-finite-replaced``), ``acc`` (``|q̇ - q̇_prev| > q̈_max dt``
beyond a few float steps without ``acceleration-exceeded``), and the amplification::

    amp = ‖q̇‖ / (λ‖e1‖/σ_max + ‖secondary‖ + ‖de1_dt‖/σ_max + J_law + F + 1e-300)

The first three terms are issue 8's definition. ``J_law`` is the law's own joint-limit
motion, which exists with no task error at all (``λ α ‖e2‖`` for ``gpm`` and
``iterative-smooth-e2``, α = 2; ``κ ‖e2‖`` for ``directional``, κ = 1; for
``large-projection`` the ``b_i := 1`` rule where ``|P_ii| < 10 ε`` adds at most
``1.7 n √(10 n ε)`` ≈ 2e-6, P being positive semi-definite; else 0), and ``F``
the motion the safety stage forces whatever the law says (the norm of the point closest
to 0 of the rate box and of the shield's box: braking within the acceleration limit,
retreat from the margin band). The bound (``bound`` column) follows from the robust
filters (docs/safety.md): 1000 for the task inverse; x101 for ``gpm-auto`` (eq. 9
filter) and per level of the iterative family; ``(1 + 170 √n)`` for ``large-projection``
(``b_i <= 100 |q̇1_i|``, ``1 + λ_tune = 1.7``). ``wln``, ``sns`` and ``qp`` invert without
a filter and have none. ``amp>bound`` counts the calls above their own bound. ``amp_strict``
in the JSON is the max of issue 8's formula alone (huge whenever ``J_law`` or ``F`` acts
with a zero task error).

``--shield-off`` runs every law with ``shield=False`` on cases that always carry velocity
and acceleration limits and a previous command, with ``dt`` up to 10 s (issue 17 item 5: a
previous command too fast to stop within ``q̈_max dt``). ``cross`` and ``outward`` then mean:

* ``cross``: a joint taken past its hard limit without ``position-limit-unavoidable`` where no
  command within the rate limits could keep it inside (any law), or at all (``sns``, ``qp``);
  or the flag's value differs from the largest such distance (a false or wrong flag);
* ``outward``: ``sns`` or ``qp`` leave the safe limits (or move further out of the margin
  band) although a command within the rate limits would not (their promise without the
  shield); other laws have none without the shield.

``unavoid`` counts the calls with the flag, ``chosen`` the crossings a law made although some
command could have avoided them (the unshielded laws' own choice; never ``sns`` or ``qp``).

Cases are seeded by ``(seed, case index)``: results do not depend on ``--workers``;
``--replay CASE`` prints that case's inputs with full digits and every law's outcome.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import sys
import time
from typing import Any

import numpy as np

from redservo import METHODS, AdaptiveGain, Flag, JointLimits, make_law
from redservo.redundancy.safety import command_box, rate_box

TARGETS = ("nonfinite", "vel", "cross", "outward", "exc")
INFO = ("nanfix", "acc", "amp_over", "unavoid", "chosen")
UNAVOIDABLE = Flag.POSITION_LIMIT_UNAVOIDABLE
CHUNK = 200
A_TASK, B_LEVEL = 1e3, 1e2
J_LAW = {"gpm": "lam_alpha", "iterative-smooth-e2": "lam_alpha", "directional": "kappa"}


# -- inputs ---------------------------------------------------------------------------------------


def _jacobian(rng: np.random.Generator, m: int, n: int) -> tuple[np.ndarray, str]:
    J = rng.normal(size=(m, n))
    kind = str(
        rng.choice(
            ["random", "dup", "near-dup", "zero-rows", "zero-cols", "low-rank", "ill", "zero"],
            p=[0.35, 0.1, 0.05, 0.1, 0.1, 0.1, 0.18, 0.02],
        )
    )
    if kind in ("dup", "near-dup") and m >= 2:
        src, dst = rng.choice(m, size=2, replace=False)
        J[dst] = J[src] * (rng.choice([1.0, -1.0, 2.5]))
        if kind == "near-dup":
            J[dst] += 1e-10 * rng.normal(size=n)
    elif kind == "zero-rows":
        J[rng.random(m) < 0.5] = 0.0
    elif kind == "zero-cols":
        J[:, rng.random(n) < 0.4] = 0.0
    elif kind == "low-rank":
        r = int(rng.integers(1, max(1, min(m, n) - 1) + 1))
        J = rng.normal(size=(m, r)) @ rng.normal(size=(r, n))
    elif kind == "ill":
        k = min(m, n)
        U = np.linalg.qr(rng.normal(size=(m, m)))[0]
        V = np.linalg.qr(rng.normal(size=(n, n)))[0]
        S = np.zeros((m, n))
        S[range(k), range(k)] = np.logspace(0, -rng.uniform(2, 16), k)
        J = U @ S @ V.T
    elif kind == "zero":
        J[:] = 0.0
    return J * 10.0 ** rng.uniform(-12, 12), kind


def _limits(rng: np.random.Generator, n: int) -> JointLimits:
    width = 10.0 ** rng.uniform(-2, 1.5, n)
    offset = rng.choice([0.0, 1.0, 1e3]) * rng.uniform(-10, 10, n)
    if rng.random() < 0.05:
        offset = 10.0 ** rng.uniform(0, 6, n) * rng.choice([-1.0, 1.0], n)
    lo = offset - width * rng.uniform(0.1, 0.9, n)
    hi = lo + width
    rho = float(rng.uniform(0.02, 0.45))
    kw: dict[str, Any] = {}
    if rng.random() < 0.7:
        kw["qdot_max"] = 10.0 ** rng.uniform(-3, 1.5, n) if rng.random() < 0.8 else 0.5
    if rng.random() < 0.6:
        kw["qddot_max"] = 10.0 ** rng.uniform(-2, 3, n)
    u = rng.random()
    if u < 0.4:
        kw["margin"] = float(rng.uniform(0, rho) * rng.choice([1.0, 0.999999, 0.01]))
    elif u < 0.6:
        kw["margin_abs"] = rng.uniform(0, rho, n) * (hi - lo) * 0.999
    return JointLimits(lo, hi, rho, **kw)


def _joint_position(rng: np.random.Generator, lim: JointLimits, i: int, crowded: bool) -> float:
    """One joint position, from a list of special places (all valid inputs)."""
    up = rng.random() < 0.5
    lim_q = lim.q_max[i] if up else lim.q_min[i]
    safe = lim.safe_max[i] if up else lim.safe_min[i]
    thr = lim.q_tilde_max[i] if up else lim.q_tilde_min[i]
    out = 1.0 if up else -1.0
    kind = int(rng.integers(0, 10)) if not crowded else int(rng.choice([1, 3, 4, 5, 6]))
    if kind == 0:
        return float(rng.uniform(lim.q_tilde_min[i], lim.q_tilde_max[i]))
    if kind == 1:
        return float(thr)
    if kind == 2:
        return float(lim_q)
    if kind == 3:
        return float(safe)
    if kind == 4:  # inside the margin band (or at the limit when there is none)
        return float(safe + rng.uniform(0, 1) * (lim_q - safe))
    if kind == 5:  # in the critical band, between q̃ and the safe limit
        return float(thr + rng.uniform(0, 1) * (safe - thr))
    if kind == 6:  # one float step around the safe limit
        return float(np.nextafter(safe, safe + out * rng.choice([1.0, -1.0])))
    if kind == 7:
        return float(np.nextafter(lim_q, -out * np.inf))
    if kind == 8:  # beyond the limit, within the validation tolerance 1e-9
        return float(lim_q + out * rng.uniform(0, 0.9e-9))
    return float(lim.center[i] + rng.uniform(-0.5, 0.5) * lim.range[i])


def make_case(seed: int, index: int, shield: bool = True) -> dict[str, Any]:
    """The law inputs of case ``index`` (deterministic in ``(seed, index)``; ``shield=False``:
    the shield-off cases of the module docstring, another stream)."""
    rng = np.random.default_rng([seed, index] if shield else [seed, index, 1])
    m, n = int(rng.integers(1, 9)), int(rng.integers(2, 10))
    crowded = rng.random() < 0.2
    if crowded:  # more joints in the band than the redundancy
        m = int(rng.integers(max(1, n - 2), n + 1))
    J, _ = _jacobian(rng, m, n)
    lim = _limits(rng, n)
    if not shield:  # rate limits always; small accelerations make stopping often impossible
        lim = lim.replace(
            qdot_max=10.0 ** rng.uniform(-3, 1.5, n), qddot_max=10.0 ** rng.uniform(-3, 2, n)
        )
    q = np.array([_joint_position(rng, lim, i, crowded) for i in range(n)])
    e1 = rng.normal(size=m) * 10.0 ** rng.uniform(-12, 12)
    if rng.random() < 0.05:
        e1[:] = 0.0
    lam: float | AdaptiveGain = float(10.0 ** rng.uniform(-3, math.log10(50.0)))
    if rng.random() < 0.2:
        zero = float(10.0 ** rng.uniform(-3, math.log10(50.0)))
        lam = AdaptiveGain(
            zero, zero * float(rng.uniform(0.01, 1.0)), float(10.0 ** rng.uniform(-3, 3))
        )
    prev = None
    if not shield or rng.random() < 0.6:
        v = lim.qdot_max
        prev = rng.uniform(-1, 1, n) * (10.0 ** rng.uniform(-3, 1) if v is None else v)
        if v is not None and rng.random() < 0.2:
            prev = v * rng.choice([-1.0, 1.0], n)
    top = 1.0 if not shield else math.log10(0.2)
    return {
        "J1": J,
        "e1": e1,
        "q": q,
        "limits": lim,
        "lam": lam,
        "dt": float(rng.choice([1e-4, 10.0**top]))
        if rng.random() < 0.1
        else float(10.0 ** rng.uniform(-4, top)),
        "de1_dt": rng.normal(size=m) * 10.0 ** rng.uniform(-12, 12) if rng.random() < 0.5 else None,
        "secondary": rng.normal(size=n) * 10.0 ** rng.uniform(-6, 12)
        if rng.random() < 0.5
        else None,
        "qdot_prev": prev,
    }


# -- checks ---------------------------------------------------------------------------------------


def _context(kw: dict[str, Any]) -> dict[str, float]:
    """Per-case quantities the amplification needs (the same for every law)."""
    J, lim, q, dt = kw["J1"], kw["limits"], kw["q"], kw["dt"]
    lam = kw["lam"]
    lam_v = lam(float(np.max(np.abs(kw["e1"])))) if isinstance(lam, AdaptiveGain) else lam
    sigma = float(np.linalg.norm(J, 2)) if J.any() else 0.0
    task = 0.0
    if sigma > 0.0:
        ff = 0.0 if kw["de1_dt"] is None else float(np.linalg.norm(kw["de1_dt"]))
        task = (lam_v * float(np.linalg.norm(kw["e1"])) + ff) / sigma
    sec = 0.0 if kw["secondary"] is None else float(np.linalg.norm(kw["secondary"]))
    rlo, rhi, _ = rate_box(lim, dt, kw["qdot_prev"])
    clo, chi = command_box(q, lim, dt, kw["qdot_prev"])
    forced = np.maximum(np.abs(np.clip(0.0, rlo, rhi)), np.abs(np.clip(0.0, clo, chi)))
    # sns and qp also return a joint lying beyond its hard limit (by <= 1e-9) to the limit.
    hard = np.abs(np.clip(0.0, (lim.q_min - q) / dt, (lim.q_max - q) / dt))
    return {
        "strict": task + sec,
        "base": task + sec + float(np.linalg.norm(forced)),
        "base_box": task + sec + float(np.linalg.norm(np.maximum(forced, hard))),
        "lam": float(lam_v),
        "e2": float(np.linalg.norm(lim.gradient(q))),
    }


def amp_bound(name: str, n: int, iterations: int) -> float:
    """The amplification bound of law ``name`` (module docstring); inf when there is none."""
    if name in ("classical", "gpm", "directional"):
        return A_TASK
    if name == "gpm-auto":
        return A_TASK * (1.0 + B_LEVEL)
    if name.startswith("iterative"):
        return A_TASK * (1.0 + B_LEVEL) ** iterations
    if name == "large-projection":
        return A_TASK * (1.0 + 1.7 * B_LEVEL * math.sqrt(n))
    return math.inf


def check_unshielded(name: str, kw: dict[str, Any], res: Any) -> dict[str, bool]:
    """``cross``, ``outward``, ``unavoid`` and ``chosen`` of a shield-off call (docstring)."""
    lim, q, dt, qdot = kw["limits"], kw["q"], kw["dt"], res.qdot
    rlo, rhi, _ = rate_box(lim, dt, kw["qdot_prev"])
    nxt = q + dt * qdot

    def stays(lo_lim: np.ndarray, hi_lim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        top, bottom = np.maximum(hi_lim, q), np.minimum(lo_lim, q)
        ok = (q + dt * rlo <= top) & (q + dt * rhi >= bottom)
        return ok, np.maximum(np.maximum(nxt - top, bottom - nxt), 0.0)

    hard_ok, past = stays(lim.q_min, lim.q_max)
    safe_ok, out_safe = stays(lim.safe_min, lim.safe_max)
    forced = float(np.where(hard_ok, 0.0, past).max())
    value = res.diagnostics.value(UNAVOIDABLE)
    baseline = name in ("sns", "qp", "qp-goal")  # qp-goal: qp without a model (a bare call)
    wrong = (value is None) if forced > 0.0 else (value is not None)
    wrong = wrong or (value is not None and value != forced)
    chosen = bool(np.any(hard_ok & (past > 0.0)))
    return {
        "cross": wrong or (baseline and chosen),
        "outward": baseline and bool(np.any(safe_ok & (out_safe > 0.0))),
        "unavoid": value is not None,
        "chosen": chosen,
    }


def check_call(
    name: str, kw: dict[str, Any], ctx: dict[str, float], res: Any, shield: bool = True
) -> dict[str, Any]:
    """The per-call outcome: which targets it violates, and its amplification."""
    qdot, d = res.qdot, res.diagnostics
    lim, q, dt, prev = kw["limits"], kw["q"], kw["dt"], kw["qdot_prev"]
    out: dict[str, Any] = {k: False for k in (*TARGETS, *INFO)}
    if not np.isfinite(qdot).all():
        out["nonfinite"] = True
        return out
    v = lim.qdot_max
    out["vel"] = v is not None and bool(np.any(np.abs(qdot) > v))
    smin, smax = lim.safe_min, lim.safe_max
    nxt = q + dt * qdot
    inside = (q >= smin) & (q <= smax)
    out["cross"] = bool(np.any(inside & ((nxt < smin) | (nxt > smax))))
    out["outward"] = bool(np.any(((q > smax) & (nxt > q)) | ((q < smin) & (nxt < q))))
    if not shield:
        out.update(check_unshielded(name, kw, res))
    out["nanfix"] = d.has(Flag.NON_FINITE_REPLACED)
    a = lim.qddot_max
    if a is not None and prev is not None and not d.has(Flag.ACCELERATION_EXCEEDED):
        slack = 4.0 * np.spacing(np.maximum(np.abs(prev), np.abs(qdot))) + 1e-12 * dt * (1.0 + a)
        out["acc"] = bool(np.any(np.abs(qdot - prev) > a * dt + slack))
    j_law = 0.0
    if name in J_LAW:
        j_law = ctx["e2"] * (2.0 * ctx["lam"] if J_LAW[name] == "lam_alpha" else 1.0)
    elif name == "large-projection":  # b_i := 1 where |P_ii| < 10 ε, P PSD: ‖P g_i‖ <= √(10 n ε)
        n = q.shape[0]
        j_law = 1.7 * n * math.sqrt(10.0 * n * np.finfo(float).eps)
    nq = float(np.linalg.norm(qdot))
    base = ctx["base_box"] if name in ("sns", "qp", "qp-goal") else ctx["base"]
    out["amp"] = nq / (base + j_law + 1e-300)
    out["amp_strict"] = nq / (ctx["strict"] + 1e-300)
    bound = amp_bound(name, q.shape[0], d.iterations)
    out["amp_over"] = out["amp"] > bound * (1.0 + 1e-9)
    out["ratio"] = out["amp"] / bound
    return out


# -- running --------------------------------------------------------------------------------------


def _empty() -> dict[str, Any]:
    return {
        "calls": 0,
        **{k: 0 for k in (*TARGETS, *INFO)},
        "amp": 0.0,
        "amp_strict": 0.0,
        "ratio": 0.0,
        "amp_case": -1,
        "flags": {},
        "examples": {},
    }


def run_chunk(job: tuple[int, int, int, bool]) -> dict[str, dict[str, Any]]:
    """Run cases ``[start, stop)`` through every law; return the per-law tallies."""
    seed, start, stop, shield = job
    laws = {name: make_law(name, shield=shield) for name in METHODS}
    stats = {name: _empty() for name in METHODS}
    for index in range(start, stop):
        kw = make_case(seed, index, shield)
        ctx = _context(kw)
        for name, law in laws.items():
            st = stats[name]
            st["calls"] += 1
            try:
                res = law(**kw)
            except Exception as exc:  # every input is valid: any exception is a finding
                st["exc"] += 1
                st["examples"].setdefault("exc", (index, f"{type(exc).__name__}: {exc}"))
                continue
            out = check_call(name, kw, ctx, res, shield)
            for key in (*TARGETS, *INFO):
                if out[key]:
                    st[key] += 1
                    st["examples"].setdefault(key, (index, ""))
            if out.get("amp", 0.0) > st["amp"]:
                st["amp_case"] = index
            for key in ("amp", "amp_strict", "ratio"):
                st[key] = max(st[key], out.get(key, 0.0))
            for flag in res.diagnostics.flags:
                st["flags"][flag.value] = st["flags"].get(flag.value, 0) + 1
    return stats


def merge(total: dict[str, dict[str, Any]], part: dict[str, dict[str, Any]]) -> None:
    """Add the tallies of ``part`` to ``total`` (sums, maxima, the lowest-index example)."""
    for name, st in part.items():
        tot = total.setdefault(name, _empty())
        for key in ("calls", *TARGETS, *INFO):
            tot[key] += st[key]
        if st["amp"] > tot["amp"] or (st["amp"] == tot["amp"] and st["amp_case"] < tot["amp_case"]):
            tot["amp_case"] = st["amp_case"]
        for key in ("amp", "amp_strict", "ratio"):
            tot[key] = max(tot[key], st[key])
        for flag, count in st["flags"].items():
            tot["flags"][flag] = tot["flags"].get(flag, 0) + count
        for key, ex in st["examples"].items():
            if key not in tot["examples"] or ex[0] < tot["examples"][key][0]:
                tot["examples"][key] = ex


def table(total: dict[str, dict[str, Any]]) -> str:
    """The final markdown table, one row per law."""
    head = (
        "| method | calls | NaN/inf | vel | cross | outward | exc | nanfix | acc | "
        "max amp (case) | bound | amp>bound | unavoid | chosen |"
    )
    lines = [head, "|" + "---|" * 14]
    for name in METHODS:
        st = total[name]
        bound = amp_bound(name, 9, 9) if name.startswith("iterative") else amp_bound(name, 9, 0)
        btxt = "none" if math.isinf(bound) else f"{bound:.3g}"
        if name.startswith("iterative"):
            btxt = "1e3·101^L"
        lines.append(
            f"| {name} | {st['calls']} | "
            + " | ".join(str(st[k]) for k in (*TARGETS, "nanfix", "acc"))
            + f" | {st['amp']:.3g} ({st['amp_case']}) | {btxt} | {st['amp_over']} | "
            + f"{st['unavoid']} | {st['chosen']} |"
        )
    return "\n".join(lines)


def replay(seed: int, index: int, shield: bool = True) -> None:
    """Print case ``index`` with full digits and every law's outcome."""
    np.set_printoptions(precision=17, floatmode="unique", linewidth=120)
    kw = make_case(seed, index, shield)
    lim = kw["limits"]
    print(f"case {index} (seed {seed})")
    for key, value in kw.items():
        if key == "limits":
            print(
                f"limits = JointLimits({lim.q_min!r}, {lim.q_max!r}, rho={lim.rho!r}, "
                f"qdot_max={lim.qdot_max!r}, qddot_max={lim.qddot_max!r}, "
                f"margin_abs={lim.margin_abs!r})"
            )
        else:
            print(f"{key} = {value!r}")
    ctx = _context(kw)
    for name in METHODS:
        try:
            res = make_law(name, shield=shield)(**kw)
        except Exception as exc:
            print(f"{name}: raised {type(exc).__name__}: {exc}")
            continue
        out = check_call(name, kw, ctx, res, shield)
        bad = [k for k in (*TARGETS, *INFO) if out[k]]
        print(f"{name}: qdot={res.qdot!r} flags={sorted(f.value for f in res.diagnostics.flags)}")
        print(f"    amp={out.get('amp', math.nan):.3g} findings={bad}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=1_000_000, help="law calls in total")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=None, help="write the results as JSON ('-': stdout)")
    parser.add_argument("--replay", type=int, default=None, help="print one case and exit")
    parser.add_argument(
        "--shield-off", action="store_true", help="the laws without their shield, rates always on"
    )
    args = parser.parse_args(argv)
    shield = not args.shield_off
    if args.replay is not None:
        replay(args.seed, args.replay, shield)
        return 0
    cases = -(-args.calls // len(METHODS))
    jobs = [(args.seed, s, min(s + CHUNK, cases), shield) for s in range(0, cases, CHUNK)]
    mode = "shield on" if shield else "shield off, rate limits and a previous command always"
    print(f"fuzzing {len(METHODS)} laws on {cases} cases ({mode}), {args.workers} workers")
    total: dict[str, dict[str, Any]] = {}
    t0 = time.perf_counter()
    done, next_report = 0, 0.0
    with mp.get_context("spawn").Pool(args.workers) as pool:
        for part in pool.imap_unordered(run_chunk, jobs):
            merge(total, part)
            done += next(iter(part.values()))["calls"]
            if done / cases >= next_report or done == cases:
                el = time.perf_counter() - t0
                bad = sum(st[k] for st in total.values() for k in TARGETS)
                print(
                    f"[{done}/{cases} cases, {done * len(METHODS)} calls, {el:.0f} s, "
                    f"eta {el * (cases - done) / done:.0f} s] findings so far: {bad}",
                    flush=True,
                )
                next_report += 0.05
    elapsed = time.perf_counter() - t0
    print(
        f"\n{cases} cases x {len(METHODS)} laws = {cases * len(METHODS)} calls in {elapsed:.0f} s"
    )
    print(f"seed {args.seed}, {args.workers} workers, {mode}\n")
    print(table(total))
    failing = {n: {k: st[k] for k in TARGETS if st[k]} for n, st in total.items()}
    failing = {n: f for n, f in failing.items() if f}
    for name, st in total.items():
        for key, (index, msg) in sorted(st["examples"].items()):
            print(f"first {key} of {name}: case {index} {msg}".rstrip())
    if args.json:
        doc = {"seed": args.seed, "shield": shield, "cases": cases, "seconds": elapsed}
        doc["laws"] = total
        text = json.dumps(doc, indent=2, default=float)
        if args.json == "-":
            print(text)
        else:
            with open(args.json, "w") as fh:
                fh.write(text)
    print("\nOK: every zero target is zero" if not failing else f"\nFAILED: {failing}")
    return 1 if failing else 0


if __name__ == "__main__":
    sys.exit(main())
