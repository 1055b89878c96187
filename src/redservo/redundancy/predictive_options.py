"""The options of the ``predictive`` law (:mod:`redservo.redundancy.predictive`; docs/predictive.md).

Units: as each option says (periods, seconds, pixels, normalized image units, Hz).
"""

from __future__ import annotations

from redservo.redundancy.base import RCOND
from redservo.redundancy.options import Option

__all__ = ["GOAL_STEPS", "OPTIONS"]

GOAL_STEPS = 20
"""Default iterations of the joint-goal search per period (``goal_steps``)."""

OPTIONS = (
    Option("horizon", 10, kind="int", doc="prediction horizon N (periods)", low=1, high=200),
    Option(
        "control_horizon",
        3,
        kind="int",
        doc="velocity blocks Nc (the last held to the end of the horizon)",
        low=1,
        high=50,
    ),
    Option(
        "model",
        "global",
        kind="choice",
        choices=("global", "local"),
        doc="'global' (kinematics + projection) or 'local' (constant J1)",
    ),
    Option(
        "effort",
        1e-3,
        doc="relative weight ρ of ‖U − Ū‖² (damping of the step from the warm start)",
        low=0.0,
        low_open=True,
    ),
    Option(
        "margin",
        0.0102,
        doc="keep-out band at each joint limit, a fraction of the range (at least the "
        "limits' own margin)",
        low=0.0,
        high=0.5,
        high_open=True,
    ),
    Option(
        "image_margin_px",
        10.0,
        doc="the image points stay this far inside the image (default camera)",
        unit="px",
        low=0.0,
    ),
    Option(
        "goal_weight",
        0.1,
        doc="relative weight γ of the terminal joint goal ‖q_N - q*‖² (0: none)",
        low=0.0,
    ),
    Option(
        "replan",
        50,
        kind="int",
        doc="periods between two searches of the joint goal q*",
        low=1,
    ),
    Option(
        "goal_steps",
        GOAL_STEPS,
        kind="int",
        doc="iterations of the joint-goal search per period (each one kinematics "
        "evaluation and one step, tens of µs): the search is spread over periods",
        low=1,
    ),
    Option("sqp_iterations", 1, kind="int", doc="SQP iterations per period", low=1, high=20),
    Option("max_qp_iterations", 1000, kind="int", doc="daqp's iteration limit", low=1),
    Option(
        "time_budget",
        None,
        doc="wall-clock limit of one step (model, goal search, solve), or None (deterministic)",
        unit="s",
        low=0.0,
        low_open=True,
        none=True,
    ),
    Option(
        "max_image_motion",
        None,
        doc="largest motion of an image point per camera frame (normalized units, measured "
        "with the camera's px), or None: max_image_motion_px",
        low=0.0,
        low_open=True,
        none=True,
    ),
    Option(
        "max_image_motion_px",
        None,
        doc="largest motion of an image point per camera frame, or None: 0.5 x the image "
        "sensor's tracker gate (25 px + 3 blur), and no limit with the ideal sensor",
        unit="px",
        low=0.0,
        low_open=True,
        none=True,
    ),
    Option(
        "frame_rate",
        None,
        doc="the camera's frame rate, or None: the simulated camera's, else the control rate",
        unit="Hz",
        low=0.0,
        low_open=True,
        high=10000.0,
        none=True,
    ),
    Option(
        "model_depth",
        "pose",
        kind="choice",
        choices=("pose", "measured"),
        doc="depths of the point model: 'pose' (from the target's pose estimated from its "
        "known points, the measured depths when that fails) or 'measured' (the sensor's)",
    ),
    Option(
        "latency",
        0.0,
        doc="age of a measurement when the law gets it (exposure to availability): the "
        "model puts the points where the camera was then",
        unit="s",
        low=0.0,
        high=10.0,
    ),
    RCOND,
)

"""The predictive law's options, in their documented order."""
