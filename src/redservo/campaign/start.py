"""Is a drawn sample's start valid? Its experiment and the one-iteration check, compiled.

A campaign sample whose target is lost at the start (a feature that cannot be measured, a
point outside the image with the campaign's margin) is drawn again (:mod:`redservo.campaign`,
"Invalid starts"). The check is the first iteration of a run: :func:`start_check` performs
it with the sensing kernel of the compiled loop (:func:`redservo.kernels.sensed.sense` at
``q0``, ``t = 0``: the features, the image check with the margin, ``e1``, ``J1``, the known
feed-forward), which is what the object path's first iteration measures before the law,
and returns the built experiment so that the sample's runs use it (no second build). A
set-up the compiled loop does not cover, or a first iteration the object path would end in
an exception (non-finite ``J1``, a feed-forward that cannot be computed), runs the object
path's iteration instead (``Experiment.run`` with ``max_iterations = 1``), as before; both
give the same verdict on the shipped campaigns (tests/test_campaign_start.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.campaign.definition import CampaignDefinition
from redservo.errors import RedservoError
from redservo.scenario import Scenario

__all__ = ["compiled_start_lost", "start_check"]


def compiled_start_lost(exp: Any, margin: float) -> bool | None:
    """Whether the first iteration of ``exp`` loses its target with the image margin
    ``margin`` (pixels), by the compiled loop's sensing kernel; None when that kernel does not
    cover ``exp`` or the object path would raise at that iteration (then it decides)."""
    from redservo.campaign.fastloop import _packed
    from redservo.kernels import compiled

    if not compiled():
        return None
    packed = _packed(exp)  # the reason, or the packs the sample's runs use too (cached)
    if isinstance(packed, str):
        return None
    from redservo.kernels.sensed import MAX_ITERATIONS, TARGET_LOST, sense

    opt = exp.options
    camera = packed.scene[4].copy()  # scene_pack's camera row, with the start's margin
    camera[6] = float(margin)
    scene = (*packed.scene[:4], camera, True, *packed.scene[6:])
    sim = (0.0, float(opt.dt), 0.0, False, np.ones(1), False, opt.feedforward == "known")
    if packed.q0 is None:
        return None  # the start does not pass the limits' check: the object path says why
    outcome, abort = sense(0, packed.q0.copy(), packed.robot, scene, packed.task, sim)[5:]
    if outcome == TARGET_LOST:
        return True
    if outcome == MAX_ITERATIONS and abort != 0:
        return None  # the object path would raise here: let it
    return False


def start_check(defn: CampaignDefinition, sc: Scenario) -> tuple[str | None, Any]:
    """``(problem, experiment)``: why the sample's start is invalid (None: it is valid) and
    its built experiment (None when building failed)."""
    from redservo.campaign.sample_build import sample_experiment

    try:
        exp = sample_experiment(defn, sc)  # build(sc)'s experiment, shared parts built once
    except RedservoError as exc:
        return str(exc), None
    margin = max(exp.options.image_margin_px, defn.target.image_margin_px)
    lost = compiled_start_lost(exp, margin)
    if lost is None:
        res = exp.run(
            method="classical",
            law_options={},
            max_iterations=1,
            image_margin_px=margin,
            check_image=True,
        )
        outcome = res.outcome if res.outcome in ("target_lost", "occluded") else None
    else:
        outcome = "target_lost" if lost else None
    if outcome is not None:
        return f"{outcome} at the start (image margin {margin:g} px)", exp
    return None, exp
