"""Set-ups drawn without the phenomenon filter (``redservo reproduce --unfiltered N``).

Every nominal set-up of the reproduction was chosen by a random search that *kept* the draws
showing the papers' phenomena (a limit hit by classical, an axis stopped first, an
occlusion to avoid: each scenario file says which). The perturbed set-ups of the robustness
sweep stay within a careful re-run's reach of that choice (±2 cm, ±2°); they say how stable
a claim is near the chosen set-up, not how often the phenomenon shows at all. This module
draws set-ups in a neighbourhood as wide as the searches' own (a start moved by up to
``START_TURN_DEG`` per revolute joint, ``START_SHIFT`` per prismatic one, the targets by
``TARGET_SHIFT`` and ``TARGET_TURN_DEG``) and keeps **every** valid one: the only redraw is
of a set-up whose scenario is invalid (the target outside the image at the start), never of
one where the phenomenon is missing. The ideal sensor, the nominal period and the true depth
are kept, so only the choice of the set-up differs from the nominal one.

The claims' rates over these set-ups sit beside the nominal verdicts and the perturbed
sweep in ``report.md`` (the column *unfiltered*): a claim that holds nominally but rarely
here was, at least partly, selected into the reproduction. The set-up checks (with no
avoidance a limit is hit, ...) say how often the search's filter would have kept a draw.
Draws come from ``numpy.random.SeedSequence(seed, spawn_key=(crc32(id), index, attempt,
UNFILTERED_KEY))``: the same on any machine, in any order, and independent of the
perturbed sweep's.
"""

from __future__ import annotations

import zlib

import numpy as np

from redservo.reproduction import perturbation as pert
from redservo.reproduction.perturbation import MAX_JOINTS, Perturbation

__all__ = [
    "FACTOR",
    "START_SHIFT",
    "START_TURN_DEG",
    "TARGET_SHIFT",
    "TARGET_TURN_DEG",
    "draw_unfiltered",
]

FACTOR = "unfiltered"
"""The factor name of these set-ups in the sweep's tallies and tables."""
START_TURN_DEG = 15.0
"""Half-width (deg) of the uniform move of each revolute joint of the start."""
START_SHIFT = 0.1
"""Half-width (m) of the uniform move of each prismatic joint of the start."""
TARGET_SHIFT = 0.1
"""Half-width (m) of the uniform shift of the targets along each start-camera axis."""
TARGET_TURN_DEG = 15.0
"""Half-width (deg) of each component of the targets' rotation vector."""
UNFILTERED_KEY = 0x55F
"""Last element of the draws' spawn key (keeps them apart from the perturbed sweep's)."""


def draw_unfiltered(
    experiment: str, index: int, *, seed: int = 0, attempt: int = 0
) -> Perturbation:
    """Draw unfiltered set-up ``index`` of ``experiment`` (module docstring).

    The start offsets are expressed, as :class:`Perturbation` wants them, in units of the
    perturbed sweep's half-widths (``perturbation.START_TURN_DEG`` and ``START_SHIFT``); the
    start is clipped to each joint's range as there. A joint kind's scale is the ratio of the
    two half-widths, so a revolute joint moves by up to ``START_TURN_DEG`` degrees.
    """
    key = (zlib.crc32(experiment.encode()), int(index), int(attempt), UNFILTERED_KEY)
    rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=key))
    shift = rng.uniform(-TARGET_SHIFT, TARGET_SHIFT, 3)
    turn = rng.uniform(-TARGET_TURN_DEG, TARGET_TURN_DEG, 3)
    offsets = rng.uniform(-1.0, 1.0, MAX_JOINTS)
    return Perturbation(
        experiment=experiment,
        index=int(index),
        attempt=int(attempt),
        target_shift=(float(shift[0]), float(shift[1]), float(shift[2])),
        target_turn_deg=(float(turn[0]), float(turn[1]), float(turn[2])),
        start_offsets=tuple(float(v) for v in offsets),
        period=None,
        depth_scale=1.0,
        noise_px=None,
        seed=0,
        factor=FACTOR,
        start_scale=(START_TURN_DEG / pert.START_TURN_DEG, START_SHIFT / pert.START_SHIFT),
    )
