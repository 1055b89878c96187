"""The compiled start check of campaign samples (redservo.campaign.start): the object path's
verdict, one build per sample."""

from __future__ import annotations

import importlib.util
from typing import Any

import pytest

pytest.importorskip("numba", reason="the compiled start check needs numba (redservo[fast])")

from redservo.campaign import load_campaign, start
from redservo.campaign.definition import shipped_campaigns
from redservo.campaign.sampling import _draw, draw_built, draw_sample
from redservo.errors import RedservoError
from redservo.experiment.build import build


def _object_path_lost(exp: Any, margin: float) -> bool:
    res = exp.run(method="classical", law_options={}, max_iterations=1, image_margin_px=margin)
    return res.outcome in ("target_lost", "occluded")


def test_the_compiled_start_check_gives_the_object_paths_verdicts() -> None:
    """Every shipped campaign the compiled loop covers, the first 3 attempts of 12 samples
    and a wide image margin (more lost starts): the same verdict as the object path's first
    iteration, and some starts are lost."""
    lost = checked = 0
    for name in sorted(shipped_campaigns()):
        d = load_campaign(name)
        if "urdf" in d.scenario.name and importlib.util.find_spec("pinocchio") is None:
            continue
        for i in range(12):
            for attempt in range(3):
                try:
                    exp = build(_draw(d, 0, i, attempt).scenario)
                except RedservoError:
                    continue
                for margin in (0.0, 120.0):
                    verdict = start.compiled_start_lost(exp, margin)
                    if verdict is None:
                        continue
                    assert verdict == _object_path_lost(exp, margin), (name, i, attempt, margin)
                    checked += 1
                    lost += verdict
    assert checked > 300 and lost > 20


def test_a_sample_is_built_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """draw_built returns the experiment of the start check, which the runs use: one build
    per valid sample, and the same sample as draw_sample."""
    import redservo.experiment.build as experiment

    d = load_campaign("cm01-gaze")
    builds = [0]
    real = experiment.build

    def counted(sc: Any, *args: Any, **kwargs: Any) -> Any:  # with shared parts or not
        builds[0] += " sample " in sc.source  # not the definition's nominal experiment
        return real(sc, *args, **kwargs)

    monkeypatch.setattr(experiment, "build", counted)
    s, exp = draw_built(d, 0, 0)
    assert builds[0] == s.attempts + 1 and exp is not None
    assert repr(draw_sample(d, 0, 0)) == repr(s)
    from redservo.campaign import run_campaign

    builds[0] = 0
    run_campaign(d, samples=1, methods=["classical", "gpm"], workers=1, progress=False)
    assert builds[0] == s.attempts + 1  # the start check's build only
