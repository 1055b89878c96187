"""Obstacles in the compiled campaign loop: which set-ups it covers, their pack, their records.

The loop measures the pairs, repels and shields with the kernels of
:mod:`redservo.kernels.loop_avoid` (the same distance kernel as the object path's
:class:`~redservo.control.avoidance.Collision`: :mod:`redservo.collision.pack`). Covered:
a compiled collision geometry (a DH chain's capsules among static primitives) and no output
saturation (``qdot_max``: the object path guards a saturated command before the shield).
With avoidance on, the laws avoid through their secondary term and the shield and, for
``qp`` and ``sns``, their velocity-damper rows (:mod:`redservo.redundancy.distance_rows`):
the loop builds the rows and hands a step whose command they change to the law in Python
(:mod:`redservo.kernels.loop_rows`). With ``[collision] enabled = false`` (the obstacles only
measured) no law avoids. Units: m, rad, s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.collision.pack import CompiledGeometry
from redservo.experiment.build import Experiment
from redservo.redundancy.distance_rows import ROW_LAWS
from redservo.redundancy.flags import FLAGS, Flag

__all__ = ["collision_fields", "collision_pack", "collision_reason", "off_pack"]

_LOOP_ROW_LAWS = ("qp", "sns")
"""Laws that solve with the velocity-damper rows in the loop (the other one of
:data:`redservo.redundancy.distance_rows.ROW_LAWS`, ``predictive``, has no compiled step)."""


def _geometry(exp: Experiment) -> CompiledGeometry | str | None:
    """The run's compiled geometry, None without pairs, or why it is not covered."""
    c = exp.options.collision
    if c is None or not c.active:
        return None
    if c.avoid and c.enabled and exp.options.qdot_max is not None:
        return "qdot_max with collision avoidance"
    if getattr(exp.robot, "carrier", None) is not None:
        return "an eye-to-hand robot's collision arm"
    geo = c.compiled(exp.robot)
    if geo is None:
        from redservo.collision.pack import geometry_reason

        return f"obstacles: {geometry_reason(exp.robot, c.obstacles)}"
    return geo


def collision_reason(exp: Experiment, law: Any) -> str | None:
    """Why the loop cannot run ``law`` on ``exp``'s obstacles (None: it can)."""
    geo = _geometry(exp)
    if isinstance(geo, str):
        return geo
    c = exp.options.collision
    rowed = law.name in ROW_LAWS and law.name not in _LOOP_ROW_LAWS
    if geo is not None and c is not None and c.enabled and c.avoid and rowed:
        return f"method {law.name!r} with obstacles: its velocity-damper rows (object path)"
    return None


def _rows_flag(exp: Experiment, law: Any) -> int:
    """1 when ``law`` solves with damper rows on ``exp`` (``bind_distances``' condition)."""
    c = exp.options.collision
    if c is None or not (c.enabled and c.avoid and c.active) or law.name not in _LOOP_ROW_LAWS:
        return 0
    return 1


_OFF: dict[int, tuple[Any, ...]] = {}
"""The off pack per number of joints, shared by the runs: the loop writes into no array of
a pack whose first field is False (:mod:`redservo.kernels.loop_avoid`)."""


def off_pack(n: int) -> tuple[Any, ...]:
    """The pack of a run without pairs (the loop's types, nothing measured)."""
    e2, e3 = np.zeros((0, 2), dtype=np.int64), np.zeros((0, 4, 4))
    arm = (np.zeros((8, n)), np.eye(4), np.eye(4), True)
    geom = (e2, np.zeros(0), np.zeros(0, dtype=np.int64), e3, np.zeros((0, 3)), e2)
    head = (False, arm, geom, np.ones(5), np.zeros(7, dtype=np.int64), np.zeros(n))
    return (*head, *_logs(0, 0), _cache(n, 0, 0), _scratch(n, 0, 0))


def _cache(n: int, P: int, F: int) -> tuple[Any, ...]:
    """The shield check's last measurement (:mod:`redservo.kernels.loop_avoid`)."""
    head = (np.zeros(n), np.zeros(P), np.zeros((P, n)), np.zeros(1, dtype=np.int64))
    return (*head, *_scratch(n, P, F))


def _scratch(n: int, P: int, F: int) -> tuple[Any, ...]:
    """Step 1's lower bounds and frame origins, for step 3 (:mod:`redservo.kernels.loop_avoid`)."""
    return (np.zeros(P), np.zeros((F, 3)), np.zeros((F, 3, n)))


def _logs(N: int, P: int) -> tuple[Any, ...]:
    tally = np.array([np.inf, np.inf, 0.0])
    return (
        np.full(N, np.nan),
        np.full(N, -1, dtype=np.int64),
        tally,
        np.array([-1.0, 0.0, 0.0]),
        np.zeros(P, dtype=np.int64),
    )


def collision_pack(exp: Experiment, law: Any) -> tuple[Any, ...]:
    """The loop's ``coll`` pack of ``law`` on ``exp`` (:mod:`redservo.kernels.loop_avoid`);
    :func:`collision_reason` said it is covered."""
    from redservo.control.checks import law_keywords

    geo, c, n = _geometry(exp), exp.options.collision, exp.robot.n
    if geo is None or c is None or isinstance(geo, str):
        return _OFF[n] if n in _OFF else _OFF.setdefault(n, off_pack(n))
    on = c.enabled
    acc = exp.limits.qddot_max
    fopt = np.array([c.d_safe, c.d_influence, c.xi, c.damping, exp.options.dt])
    iopt = np.array(
        [
            int(on and c.avoid and c.repel),
            int("secondary" in law_keywords(law)),
            int(on and c.shield),
            FLAGS.index(Flag.DISTANCE_SHIELD),
            FLAGS.index(Flag.ACCELERATION_EXCEEDED),
            int(acc is not None),
            _rows_flag(exp, law),
        ],
        dtype=np.int64,
    )
    qdd = np.zeros(n) if acc is None else np.broadcast_to(np.asarray(acc, float), (n,)).copy()
    N, P = exp.options.max_iterations, len(geo.names)
    logs = _logs(N, P)
    logs[4][:] = [0 if k == "environment" else 1 for k in geo.kinds]
    F = n + 2  # the frames base, joint 1 … n, ee (dh_points)
    return (True, geo.arm, geo.geom, fopt, iopt, qdd, *logs, _cache(n, P, F), _scratch(n, P, F))


def collision_fields(exp: Experiment, coll: tuple[Any, ...], rows: int) -> dict[str, Any]:
    """``{"log": SimulationLog keywords, "collision": contact, "distances": tally fields}``
    of a run of the loop (None where the object path has none)."""
    if not coll[0]:
        return {"log": {}, "collision": None, "distances": None}
    c = exp.options.collision
    assert c is not None
    geo = c.compiled(exp.robot)
    assert geo is not None
    MD, CP, tally, contact = coll[6], coll[7], coll[8], coll[9]
    log = {
        "min_distance": MD[:rows].copy(),
        "closest_pair": CP[:rows].astype(np.float64),
        "pair_names": geo.names,
    }
    hit = None
    if contact[0] >= 0:
        hit = {"pair": geo.names[int(contact[0])], "distance": float(contact[1])}
        hit["iteration"] = int(contact[2])
    minimum = {}
    for k, kind in enumerate(("environment", "self")):
        if np.isfinite(tally[k]):
            minimum[kind] = float(tally[k])
    distances = {"min_distance_by_kind": minimum or None, "steps_within_influence": int(tally[2])}
    return {"log": log, "collision": hit, "distances": distances}
