"""A video of a finished run: the camera view with the measured and desired features, and the
error beside it (``redservo run … --video run.gif``).

The frames are rendered again from the logged joint positions (the simulator does not keep
the images of a run): the robot's camera pose at each logged iteration, the scene at that
time, the image sensor's rendering options when the run used one (else a clean image). The
measured features drawn are the ones the law saw (the log's ``s``), the desired ones ``s*``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from redservo.vision.render import Renderer
from redservo.vision.video import Progress, write_video

if TYPE_CHECKING:  # pragma: no cover
    from redservo.experiment.build import Experiment
    from redservo.simulation import SimulationResult

__all__ = ["run_video"]


def run_video(
    exp: Experiment,
    result: SimulationResult,
    path: str | Path,
    *,
    max_frames: int = 150,
    fps: float = 10.0,
    progress: bool = True,
) -> Path:
    """Write ``path`` (``.gif`` or ``.mp4``) for ``result``, a run of ``exp``; return the path.

    Args:
        exp: The experiment that was run (robot, scene, task, camera, sensor).
        result: Its result (the log's ``q``, ``t``, ``s`` and ``error_norm`` are used).
        path: Output file; the extension chooses the format.
        max_frames: At most this many frames, evenly spaced over the run (the last included).
        fps: Frames per second.
        progress: Say on stderr how far the rendering is (:class:`~redservo.vision.video.Progress`).
    """
    log = result.log
    n = len(log)
    idx = np.unique(np.linspace(0, max(n - 1, 0), num=min(n, max_frames)).round().astype(int))
    sensor_renderer = getattr(exp.sensor, "renderer", None)
    options = sensor_renderer.options if isinstance(sensor_renderer, Renderer) else None
    renderer = Renderer(exp.camera, options)
    frames = []
    said = Progress("video: rendering", len(idx), enabled=progress)
    for j, i in enumerate(idx):
        bMc = exp.robot.fkine(log.q[i], check_limits=False)
        frames.append(renderer.render(exp.scene, bMc, float(log.t[i])))
        said.frame(j)
    distortion = (options.k1, options.k2) if options is not None else 0.0
    return write_video(
        path,
        frames,
        camera=exp.camera,
        distortion=distortion,
        task=exp.task,
        detected=[log.s[i] for i in idx],
        desired=exp.task.s_star,
        errors=log.error_norm[idx],
        fps=fps,
        progress=Progress("video: drawing", len(idx), enabled=progress),
    )
