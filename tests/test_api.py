"""The top-level Python API (issue 22, part 4): load_scenario, run, compare, campaign and
Controller at ``redservo.``, typed, with doctest-checked examples."""

from __future__ import annotations

import doctest
import inspect
import json
from pathlib import Path

import pytest

import redservo
import redservo.api
from redservo.errors import ConfigurationError, ScenarioError, UnknownNameError


@pytest.mark.parametrize("module", [redservo, redservo.api])
def test_the_docstring_examples_run(module: object) -> None:
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)  # type: ignore[arg-type]
    assert tried > 0 and failures == 0


def test_the_api_is_at_the_top_level_typed_and_documented() -> None:
    for name in ("load_scenario", "run", "compare", "campaign", "Controller", "load_run"):
        assert name in redservo.__all__
        obj = getattr(redservo, name)
        assert callable(obj) and obj.__doc__, name
    for name in ("load_scenario", "run", "compare", "campaign"):
        fn = getattr(redservo.api, name)
        sig = inspect.signature(fn)
        assert sig.return_annotation is not inspect.Signature.empty, name
        assert ">>> " in (fn.__doc__ or ""), name
    assert redservo.campaign.run_campaign is not None  # still the campaign package


def test_bad_input_is_one_typed_error() -> None:
    with pytest.raises(ScenarioError, match="unknown scenario"):
        redservo.load_scenario("no-such-scenario")
    with pytest.raises(ConfigurationError, match="overrides"):
        redservo.load_scenario("afma6-gaze-demo", "control.lam=2")  # type: ignore[arg-type]
    with pytest.raises(ScenarioError, match=r"control\.lam"):
        redservo.load_scenario("afma6-gaze-demo", {"control.lam": -1})
    with pytest.raises(UnknownNameError):
        redservo.compare("afma6-gaze-demo", ["gpm", "magic"])
    with pytest.raises(ConfigurationError, match="at least one method"):
        redservo.compare("afma6-gaze-demo", [])
    with pytest.raises(ConfigurationError, match="scenario"):
        redservo.load_scenario(42)


def test_run_and_compare_save_what_the_command_line_saves(tmp_path: Path) -> None:
    r = redservo.run(
        "afma6-gaze-demo", overrides=["simulation.max_iterations=5"], out=tmp_path / "run"
    )
    assert redservo.load_run(tmp_path / "run").summary["iterations"] == r.summary.iterations
    res = redservo.compare(
        "afma6-gaze-demo", ["gpm", "classical"], out=tmp_path / "cmp", max_iterations=5
    )
    assert list(res) == ["gpm", "classical"]
    table = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    assert list(table["methods"]) == ["gpm", "classical"]
    assert (tmp_path / "cmp" / "gpm" / "scenario.toml").is_file()
