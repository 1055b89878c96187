"""Checked values of a URDF joint: origin, axis, position limits (no Pinocchio).

:mod:`redservo.robots.urdf_parse` reads every joint through these helpers, so that a
value no real robot has is refused with the file and the joint named, before it becomes
a silent NaN or a misleading error downstream (an origin of ``1e308`` used to surface as
a feature "behind the camera"). The bounds are far beyond any real arm and catch typos,
degrees written for radians and overflowing values:

* ``<origin xyz>``: three finite numbers, each in ``[-ORIGIN_BOUND, ORIGIN_BOUND]`` (m);
* ``<origin rpy>``: three finite numbers, each in ``[-RPY_BOUND, RPY_BOUND]`` (rad);
* ``<axis xyz>`` of a revolute, continuous, prismatic or planar joint: three finite
  numbers, not all zero; it is normalised (default ``1 0 0``, as in URDF);
* ``<limit lower upper>`` of a revolute or prismatic joint: finite, each in
  ``[-POSITION_BOUND, POSITION_BOUND]`` (rad or m).

Rates (``<limit velocity>``, ``<redservo:limit acceleration>``) are kept as written and
checked by :mod:`redservo.robots.urdf_limits` for the servoed joints only, because the
caller may replace them.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from typing import Final

import numpy as np

from redservo.errors import ConfigurationError

__all__ = [
    "AXIS_KINDS",
    "ORIGIN_BOUND",
    "POSITION_BOUND",
    "REDSERVO_LIMIT",
    "REDSERVO_NS",
    "RPY_BOUND",
    "Triple",
    "as_float",
    "fail",
    "finite_or_zero",
    "joint_geometry",
    "position",
]

ORIGIN_BOUND: Final = 100.0
"""Largest ``|x|``, ``|y|``, ``|z|`` (m) of a joint ``<origin xyz>``."""
RPY_BOUND: Final = 7.0
"""Largest ``|roll|``, ``|pitch|``, ``|yaw|`` (rad) of a joint ``<origin rpy>``: a little over
one turn (2π ≈ 6.28) so that rounded values of ±2π pass; larger values are usually degrees."""
POSITION_BOUND: Final = 100.0
"""Largest ``|lower|``, ``|upper|`` of a revolute (rad, about 16 turns) or prismatic (m) joint."""
REDSERVO_NS: Final = "urn:redservo:urdf"
"""XML namespace of redservo's URDF extension, ``<redservo:limit acceleration="..."/>`` inside
a ``<joint>`` (declare ``xmlns:redservo="urn:redservo:urdf"`` on ``<robot>``)."""
REDSERVO_LIMIT: Final = f"{{{REDSERVO_NS}}}limit"
"""The ElementTree tag of ``<redservo:limit>``."""
AXIS_KINDS: Final = ("revolute", "continuous", "prismatic", "planar")
"""Joint types whose ``<axis>`` matters (urdfdom ignores it on fixed and floating joints)."""

Triple = tuple[float, float, float]


def fail(source: str, what: str) -> ConfigurationError:
    """The error for a malformed file ``source``: ``what`` names the link or joint."""
    return ConfigurationError(f"malformed URDF {source}: {what}", argument="path")


def as_float(text: str | None) -> float | None:
    """``float(text)``, NaN if it is not a number, None for None."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        return math.nan


def finite_or_zero(text: str | None) -> str:
    """``text`` if it is a finite number, else ``"0"`` (urdfdom's "unknown" for a rate)."""
    value = as_float(text)
    return text if text is not None and value is not None and math.isfinite(value) else "0"


def position(
    limit: ET.Element | None, attr: str, source: str, joint: str, bounded: bool
) -> float | None:
    """Return ``<limit attr>`` (m or rad), None if absent; finite, and bounded if ``bounded``."""
    if limit is None or limit.get(attr) is None:
        return None
    text = limit.get(attr, "")
    value = as_float(text)
    assert value is not None
    if not math.isfinite(value):
        raise fail(source, f"joint {joint!r}: <limit {attr}={text!r}> is not a finite number")
    if bounded and abs(value) > POSITION_BOUND:
        raise fail(
            source,
            f"joint {joint!r}: <limit {attr}={text!r}> is out of bounds; position limits must "
            f"lie in [-{POSITION_BOUND:g}, {POSITION_BOUND:g}] (rad for a revolute joint, m for "
            "a prismatic one)",
        )
    return value


def _triple(elem: ET.Element | None, attr: str, default: Triple, source: str, joint: str) -> Triple:
    """Return ``elem``'s attribute ``attr`` as three finite numbers (``default`` if absent)."""
    if elem is None or elem.get(attr) is None:
        return default
    text = elem.get(attr, "")
    values = [as_float(part) for part in text.split()]
    finite = [v for v in values if v is not None and math.isfinite(v)]
    if len(values) != 3 or len(finite) != 3:
        raise fail(
            source, f"joint {joint!r}: <{elem.tag} {attr}={text!r}> must be three finite numbers"
        )
    return finite[0], finite[1], finite[2]


def joint_geometry(
    elem: ET.Element, kind: str, source: str, name: str
) -> tuple[Triple, Triple, Triple]:
    """Return the checked ``(xyz, rpy, axis)`` of a ``<joint>``: origin (m, rad), unit axis."""
    origin = elem.find("origin")
    xyz = _triple(origin, "xyz", (0.0, 0.0, 0.0), source, name)
    rpy = _triple(origin, "rpy", (0.0, 0.0, 0.0), source, name)
    for attr, values, bound, unit, hint in (
        ("xyz", xyz, ORIGIN_BOUND, "m", ""),
        ("rpy", rpy, RPY_BOUND, "rad", " (radians: degrees are a common mistake)"),
    ):
        if max(abs(v) for v in values) > bound:
            text = "" if origin is None else origin.get(attr, "")
            raise fail(
                source,
                f"joint {name!r}: <origin {attr}={text!r}> is out of bounds; each value must lie "
                f"in [-{bound:g}, {bound:g}] {unit}{hint}",
            )
    axis: Triple = (1.0, 0.0, 0.0)
    if kind in AXIS_KINDS:
        raw = np.array(_triple(elem.find("axis"), "xyz", axis, source, name))
        scale = float(np.max(np.abs(raw)))
        if scale == 0.0:
            text = elem.find("axis").get("xyz", "")  # type: ignore[union-attr]
            raise fail(
                source,
                f"joint {name!r}: <axis xyz={text!r}> has no direction; give a non-zero vector "
                "(it is normalised), e.g. '0 0 1'",
            )
        unit_axis = raw / scale  # no overflow for huge components, no underflow for tiny ones
        unit_axis /= np.linalg.norm(unit_axis)
        axis = (float(unit_axis[0]), float(unit_axis[1]), float(unit_axis[2]))
    return xyz, rpy, axis
