"""A sensor's own trouble as the step's typed flags.

The image sensor with ``depth = "pose"`` takes the depths of its interaction matrices from
the PnP pose of each point set (:func:`redservo.vision.pnp.pose_term_depth`). A frame whose
dots give no pose (fewer than four detected, or no pose within the reprojection tolerance)
keeps the depths of the set's last pose (the desired depths before the first): the reading
says so (:attr:`SensorReading.no_pose <redservo.sensors.SensorReading.no_pose>`) and the
loop adds :attr:`~redservo.redundancy.flags.Flag.NO_POSE` to the step's diagnostics
(:func:`sensor_flags`), value: the frames in a row without a pose. It is the flag the
``predictive`` law raises for its own PnP (one meaning, one log column), so the run's log,
summary and the campaign's flag counts keep it. A frame held by a slower camera
(:mod:`redservo.sensors.timing`) is flagged at every control step that uses it.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from redservo.kernels import flagbits as fb
from redservo.redundancy.base import Diagnostics
from redservo.redundancy.flags import Event
from redservo.redundancy.messages import events
from redservo.sensors import NoPose, SensorReading

__all__ = ["no_pose_event", "sensor_flags", "with_no_pose"]

_MIN_DOTS = 4
"""Detected dots PnP needs (:func:`redservo.vision.pnp.dot_pose`)."""


def no_pose_event(miss: NoPose) -> Event:
    """The ``no-pose`` event of the image sensor's frame without a pose (value: ``miss.frames``)."""
    vals = np.zeros(fb.N_FLAGS)
    src = np.zeros(fb.N_FLAGS, dtype=np.int64)
    why = fb.SENSOR_FEW_DOTS if miss.dots < _MIN_DOTS else fb.SENSOR_REJECTED
    vals[fb.NO_POSE], src[fb.NO_POSE] = float(miss.frames), why
    (ev,) = events(
        1 << fb.NO_POSE, vals, src, target=miss.target, dots=miss.dots, points=miss.points
    )
    return ev


def sensor_flags(diagnostics: Diagnostics, reading: SensorReading) -> Diagnostics:
    """``diagnostics`` of the step that used ``reading``, with the sensor's own flags (the
    image sensor's ``no-pose``); ``diagnostics`` itself when there are none."""
    return with_no_pose(diagnostics, reading.no_pose)


def with_no_pose(diagnostics: Diagnostics, miss: NoPose | None) -> Diagnostics:
    """``diagnostics`` with the ``no-pose`` event of ``miss`` added (the simulation's reading
    or the servo loop's :class:`~redservo.hardware.FeatureMeasurement`); ``diagnostics``
    itself when ``miss`` is None."""
    if miss is None:
        return diagnostics
    ev = no_pose_event(miss)
    return dataclasses.replace(diagnostics, events=(*diagnostics.events, ev))
