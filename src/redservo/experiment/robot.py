"""The robot of a scenario's ``[robot]`` table: a shipped model, a URDF file or an MJCF file.

Errors name the scenario key: the key the robot's constructor names (``robot.tip``,
``robot.joints``, ...) when the table has it, else ``robot.options`` (a shipped model),
``robot.urdf`` or ``robot.file`` (an MJCF file).
"""

from __future__ import annotations

from redservo.errors import RedservoError
from redservo.robots import Robot
from redservo.scenario import Scenario
from redservo.schema.scenario import ScenarioSpec

__all__ = ["scenario_robot"]


def _build(spec: ScenarioSpec) -> Robot:
    r = spec.robot
    eMc = None if r.eMc is None else r.eMc.matrix()
    if r.model is not None:
        from redservo.robots import make_robot

        return make_robot(r.model, **r.options)
    if r.kind == "mjcf":
        from redservo.robots.mjcf import MJCFRobot, shipped_mjcf

        assert r.file is not None
        path = r.file if r.file.endswith(".xml") or "/" in r.file else shipped_mjcf(r.file)
        keys = ("tip", "base", "joints", "locked_q", "qdot_max", "qddot_max")
        return MJCFRobot(path, eMc=eMc, **{key: getattr(r, key) for key in keys})
    from redservo.robots.urdf import URDFRobot, shipped_urdf

    assert r.urdf is not None
    path = r.urdf if r.urdf.endswith(".urdf") or "/" in r.urdf else shipped_urdf(r.urdf)
    # Rate limits given in the scenario replace the file's (which may lack them).
    keys = ("camera_link", "joints", "base_link", "locked_q", "qdot_max", "qddot_max")
    return URDFRobot(path, eMc=eMc, **{key: getattr(r, key) for key in keys})


def scenario_robot(sc: Scenario, spec: ScenarioSpec) -> Robot:
    """The scenario's robot (module docstring).

    Raises:
        ScenarioError: the robot cannot be built (names the key).
    """
    r = spec.robot
    try:
        return _build(spec)
    except RedservoError as exc:
        arg = getattr(exc, "argument", None)
        fields = type(r).model_fields
        if arg == "path":
            arg = None
        default = "robot.options" if r.model is not None else "robot.urdf"
        if r.kind == "mjcf":
            default = "robot.file"
        key = f"robot.{arg}" if arg and arg in fields else default
        raise sc.error(key, str(exc)) from None
