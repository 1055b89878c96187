"""See a saved run move: an interactive 3-D view in the browser, or a video (extra
``redservo[viewer]``: viser, imageio, Pillow; the video also needs matplotlib).

* :class:`Playback` (:mod:`~redservo.viewer.playback`) — the scene at each iteration;
* :func:`serve` (:mod:`~redservo.viewer.server`) — ``redservo view PATH``;
* :func:`write_animation` (:mod:`~redservo.viewer.animate`) — ``redservo animate PATH``;
* :func:`camera_image` (:mod:`~redservo.viewer.image`) — the camera image of a frame.

Importing this package imports none of the optional libraries. See docs/viewer.md.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

from redservo.errors import ConfigurationError

if TYPE_CHECKING:  # pragma: no cover
    from redservo.runs.load import Run
    from redservo.viewer.animate import write_animation
    from redservo.viewer.image import camera_image
    from redservo.viewer.playback import Playback
    from redservo.viewer.server import serve

__all__ = ["Playback", "camera_image", "pick_run", "serve", "write_animation"]

_WHERE = {
    "Playback": "playback",
    "serve": "server",
    "write_animation": "animate",
    "camera_image": "image",
}


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'redservo.viewer' has no attribute {name!r}")
    return getattr(importlib.import_module(f"redservo.viewer.{module}"), name)


def pick_run(path: str | Path, method: str | None = None) -> Run:
    """The run to show: ``path`` itself, or in a comparison or reproduction directory the
    run of ``method`` (a method name or a run directory's name; default: the first).

    Raises:
        ConfigurationError: no run there, or none for ``method`` (lists the choices); a
            campaign directory (replay a sample first).
    """
    from redservo.runs.load import find_runs, is_run_dir, load_run

    p = Path(path)
    if is_run_dir(p):
        return load_run(p)
    if (p / "samples.csv").is_file():
        raise ConfigurationError(
            f"{p}: a campaign stores no logs; replay a sample first: redservo replay {p} "
            "--sample K --method M, then view the directory it writes",
            argument="path",
        )
    runs = find_runs(p)
    if not runs:
        return load_run(p)  # raises: says what the path is
    if method is None:
        return load_run(runs[0])
    for r in runs:
        run = load_run(r)
        if method in (run.method, r.name, str(run.summary.get("label", ""))):
            return run
    names = ", ".join(r.relative_to(p).as_posix() for r in runs)
    raise ConfigurationError(
        f"{p}: no run for --method {method!r}; runs: {names}", argument="method"
    )
