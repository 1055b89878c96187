"""Import MuJoCo lazily, with its offscreen OpenGL backend chosen before the import.

MuJoCo reads ``MUJOCO_GL`` when it is first imported: ``egl`` renders offscreen on a
machine without a display (Debian's ``libegl1`` + ``libegl-mesa0`` + ``libgl1-mesa-dri``,
installed by ``make test`` when missing and root). A value already set by the user is kept.
"""

from __future__ import annotations

import os
from typing import Any

from redservo.errors import ConfigurationError

__all__ = ["rendering_available", "require_mujoco"]

_RENDER_OK: list[str | None] = []


def require_mujoco() -> Any:
    """Return the ``mujoco`` module (``MUJOCO_GL=egl`` unless set).

    Raises:
        ConfigurationError: MuJoCo is not installed (``pip install 'redservo[mujoco]'``), or
            its OpenGL backend fails to load.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - the extra is installed by make test
        raise ConfigurationError(
            f"the MuJoCo backend needs the mujoco package: pip install 'redservo[mujoco]' ({exc})",
            argument="simulator.kind",
        ) from None
    except Exception as exc:  # its OpenGL backend failed to load (MUJOCO_GL names it)
        raise ConfigurationError(
            f"mujoco failed to import with MUJOCO_GL={os.environ.get('MUJOCO_GL')!r} "
            f"({type(exc).__name__}: {exc}); unset it for egl (docs/physics.md)",
            argument="simulator.kind",
        ) from None
    return mujoco


def rendering_available() -> str | None:
    """None when MuJoCo renders offscreen here, else why not (one line; cached)."""
    if not _RENDER_OK:
        why: str | None = None
        try:
            mj = require_mujoco()
            model = mj.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
            with mj.Renderer(model, 8, 8) as r:
                r.render()
        except Exception as exc:
            why = (
                f"MuJoCo cannot render offscreen with MUJOCO_GL="
                f"{os.environ.get('MUJOCO_GL')!r}: {type(exc).__name__}: {exc}"
            )
        _RENDER_OK.append(why)
    return _RENDER_OK[0]
