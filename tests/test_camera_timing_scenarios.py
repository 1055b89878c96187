"""Camera timing from a scenario file and the command line: bad keys are one error naming the
key, the realistic preset runs a shipped scenario through images, campaigns take the object
path for a timed camera."""

from __future__ import annotations

import inspect
import os
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco's import, as redservo.physics does

from redservo import ScenarioError
from redservo.cli.entry import main
from redservo.experiment.build import build
from redservo.experiment.camera_presets import REALISTIC_TOLERANCE_PX, camera_overrides
from redservo.hardware import ServoLoop
from redservo.scenario import apply_overrides, load_scenario
from redservo.sensors.timing import MAX_LATENCY, TimedSensor


def _panda(*sets: str):  # type: ignore[no-untyped-def]
    return build(apply_overrides(load_scenario("panda-4points"), list(sets)))


@pytest.mark.parametrize(
    ("sets", "key", "hint"),
    [
        (["sensor.rate=nan"], "sensor.rate", "finite"),
        (["sensor.rate=-30.0"], "sensor.rate", "> 0"),
        (["sensor.rate=20000.0"], "sensor.rate", "10000"),
        (["sensor.latency=inf"], "sensor.latency", "finite"),
        (["sensor.latency=-0.01"], "sensor.latency", ">= 0"),
        (["sensor.latency=0.5"], "sensor.latency", "watchdog"),
        (["sensor.exposure=-0.001"], "sensor.exposure", ">= 0"),
        (
            ["sensor.rate=30.0", "sensor.exposure=0.05", "sensor.latency=0.1"],
            "sensor.exposure",
            "frame interval",
        ),
        (["sensor.exposure=0.05", "sensor.latency=0.1"], "sensor.exposure", "control.dt"),
        (["sensor.exposure=0.02", "sensor.latency=0.005"], "sensor.latency", "half the exposure"),
        (
            ["sensor.latency=0.3", "simulation.max_iterations=5"],
            "sensor.latency",
            "shorter than the run",
        ),
        (["simulation.tolerance_px=-1.0"], "simulation.tolerance_px", "> 0"),
    ],
)
def test_bad_timing_is_one_scenario_error_naming_the_key(
    sets: list[str], key: str, hint: str
) -> None:
    with pytest.raises(ScenarioError) as info:
        _panda(*sets)
    msg = str(info.value)
    assert f"key '{key}'" in msg and hint in msg and "\n" not in msg, msg


def test_a_latency_the_servo_loop_would_find_stale_is_refused_at_build_time() -> None:
    watchdog = inspect.signature(ServoLoop).parameters["watchdog_timeout"].default
    assert MAX_LATENCY == watchdog
    with pytest.raises(ScenarioError, match="watchdog"):
        _panda(f"sensor.latency={MAX_LATENCY}")


def test_bad_timing_on_the_command_line_is_one_line_exit_2(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    argv = ["run", "panda-4points", "--set", "sensor.rate=1e9", "--out", str(tmp_path), "-q"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("redservo: error: ") and "sensor.rate" in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_the_default_keeps_the_perfect_camera() -> None:
    exp = _panda()
    assert exp.sensor is None and exp.timing.perfect and exp.options.tolerance == 1e-3


def test_the_realistic_preset_converges_through_images_within_its_pixel_tolerance(
    tmp_path: Path,
) -> None:
    pytest.importorskip("cv2", reason="the image sensor needs redservo[vision]")
    exp = _panda(*camera_overrides("realistic"))
    assert isinstance(exp.sensor, TimedSensor) and exp.timing.rate == 30.0
    assert exp.options.tolerance == pytest.approx(REALISTIC_TOLERANCE_PX / exp.camera.px)
    result = exp.run()
    assert result.outcome == "converged", result.summary.outcome
    assert result.log.error_norm[-1] * exp.camera.px < REALISTIC_TOLERANCE_PX
    # The same through the command line's option.
    out = tmp_path / "run"
    assert (
        main(
            ["run", "panda-4points", "--camera", "realistic", "--out", str(out), "-q", "--no-plot"]
        )
        == 0
    )
    assert 'kind = "image"' in (out / "scenario.toml").read_text()


def test_a_campaign_sends_a_timed_camera_to_the_object_path_with_the_reason() -> None:
    from redservo.campaign.task import _run_task, _Task

    exp = _panda("sensor.rate=25.0", "sensor.latency=0.04", "simulation.max_iterations=20")
    row = _run_task(_Task(0, "classical", {}, "panda-4points", None, {}, exp, True))
    assert row["_path"] == "camera timing"


def test_the_mujoco_camera_is_timed_live_and_refuses_an_exposure() -> None:
    pytest.importorskip("mujoco", reason="the MuJoCo backend needs redservo[mujoco]")
    from redservo.physics._mj import rendering_available

    if rendering_available() is not None:
        pytest.skip("no offscreen rendering (EGL) here")
    name = "panda-mujoco-4points"
    sets = ["sensor.rate=10.0", "sensor.latency=0.1", "simulation.max_iterations=20"]
    exp = build(apply_overrides(load_scenario(name), sets))
    assert isinstance(exp.sensor, TimedSensor) and exp.sensor.live
    result = exp.run()
    assert len(result.log.t) > 0
    with pytest.raises(ScenarioError, match=r"key 'sensor.exposure': .*cannot model an exposure"):
        build(apply_overrides(load_scenario(name), [*sets, "sensor.exposure=0.01"]))


def test_reproduce_takes_the_realistic_camera_through_images() -> None:
    pytest.importorskip("cv2", reason="the image sensor needs redservo[vision]")
    from redservo.cli.parser import build_parser
    from redservo.errors import ConfigurationError
    from redservo.reproduction import _check, image_sensors
    from redservo.vision import ImageSensor

    exp = _panda()
    timed_sensor = image_sensors(True)(exp)
    assert isinstance(timed_sensor, TimedSensor) and timed_sensor.timing.latency == 0.066
    assert isinstance(timed_sensor.sensor, ImageSensor)
    assert isinstance(image_sensors(False)(exp), ImageSensor)
    args = build_parser().parse_args(["reproduce", "--camera", "realistic"])
    assert args.camera == "realistic"
    with pytest.raises(ConfigurationError) as info:
        _check(0, None, "ideal", 0, "blurry")
    assert info.value.argument == "camera"
