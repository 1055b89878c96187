"""Read the kinematic tree of a URDF file (standard library XML, no Pinocchio).

This module checks what :class:`~redservo.robots.URDFRobot` needs before Pinocchio
sees the file, so that every mistake is reported with the file name and the
offending link or joint: the XML is well formed, the root element is ``<robot>``,
every link and joint has a unique name, every joint names existing ``parent`` and
``child`` links, every link has at most one parent joint and there is exactly one
root link. Joint positions are read from ``<limit lower upper>`` (m or rad), velocities
from ``<limit velocity>`` (m/s or rad/s) and accelerations from the redservo extension
``<redservo:limit acceleration>`` (m/s² or rad/s², namespace :data:`REDSERVO_NS`); efforts
are ignored. Rates are kept as written: :mod:`redservo.robots.urdf_limits` checks those
of the servoed joints (the caller may replace them).

Geometry (origins, axes, position limits) is checked by :mod:`redservo.robots.urdf_values`.

:func:`chain` finds the joints from a base link down to a tip link and
:func:`locked_values` the values of the joints a sub-chain leaves out.
:func:`pinocchio_xml` rewrites the tree for Pinocchio: every ``continuous`` joint
becomes a ``revolute`` joint with limits ``±CONTINUOUS_LIMIT`` (one angle instead of
Pinocchio's ``(cos θ, sin θ)`` pair; see :class:`~redservo.robots.URDFRobot`).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Final

import numpy as np

from redservo.errors import ConfigurationError, JointLimitError, UnknownNameError
from redservo.robots.urdf_values import (
    AXIS_KINDS,
    REDSERVO_LIMIT,
    REDSERVO_NS,
    Triple,
    as_float,
    fail,
    finite_or_zero,
    joint_geometry,
    position,
)

__all__ = [
    "CONTINUOUS_LIMIT",
    "REDSERVO_NS",
    "URDFJoint",
    "URDFTree",
    "chain",
    "locked_values",
    "pinocchio_xml",
    "read_urdf",
]

CONTINUOUS_LIMIT: Final = 2.0 * math.pi
"""Position limit (rad) given to a ``continuous`` joint: ``q ∈ [-2π, 2π]``."""

JOINT_KINDS: Final = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
"""The joint types of the URDF specification."""
_ONE_VARIABLE: Final = ("revolute", "continuous", "prismatic")


@dataclass(frozen=True, slots=True)
class URDFJoint:
    """One ``<joint>`` of a URDF file.

    Attributes:
        name: Joint name.
        kind: URDF type (one of :data:`JOINT_KINDS`).
        parent: Parent link name.
        child: Child link name.
        lower: ``<limit lower>`` (m or rad), or None when absent.
        upper: ``<limit upper>`` (m or rad), or None when absent.
        velocity_text: ``<limit velocity>`` as written (m/s or rad/s), or None when absent.
        acceleration_text: ``<redservo:limit acceleration>`` as written (m/s² or rad/s²), or
            None when absent.
        mimic: The joint has a ``<mimic>`` element.
        xyz: ``<origin xyz>`` (m), checked.
        rpy: ``<origin rpy>`` (rad), checked.
        axis: ``<axis xyz>``, normalised (``(1, 0, 0)`` when absent or not used).
    """

    name: str
    kind: str
    parent: str
    child: str
    lower: float | None
    upper: float | None
    velocity_text: str | None
    acceleration_text: str | None
    mimic: bool
    xyz: Triple = (0.0, 0.0, 0.0)
    rpy: Triple = (0.0, 0.0, 0.0)
    axis: Triple = (1.0, 0.0, 0.0)

    @property
    def velocity(self) -> float | None:
        """``<limit velocity>`` (m/s or rad/s; NaN if not a number), or None when absent."""
        return as_float(self.velocity_text)

    @property
    def acceleration(self) -> float | None:
        """``<redservo:limit acceleration>`` (m/s² or rad/s²; NaN if not a number), or None."""
        return as_float(self.acceleration_text)

    @property
    def movable(self) -> bool:
        """True for every kind but ``fixed``."""
        return self.kind != "fixed"


@dataclass(frozen=True, eq=False)
class URDFTree:
    """The kinematic tree of a URDF file.

    Attributes:
        source: The file name, for error messages.
        name: ``<robot name>``.
        links: Link names, in file order.
        joints: Joints by name, in file order.
        parent_joint: For each non-root link, the name of the joint whose child it is.
        root: The root link (the only link that is no joint's child).
        element: The parsed ``<robot>`` element.
    """

    source: str
    name: str
    links: tuple[str, ...]
    joints: dict[str, URDFJoint]
    parent_joint: dict[str, str]
    root: str
    element: ET.Element

    def check_link(self, link: str, argument: str) -> None:
        """Raise :class:`UnknownNameError` if ``link`` is not a link of the file."""
        if link not in self.parent_joint and link != self.root:
            raise UnknownNameError(
                f"{argument}={link!r} is not a link of {self.source}; "
                f"its links are: {', '.join(self.links)}",
                argument=argument,
            )


_fail = fail


def _read_joint(elem: ET.Element, source: str, links: set[str]) -> URDFJoint:
    name = elem.get("name")
    if not name:
        raise _fail(source, "a <joint> has no name attribute")
    kind = elem.get("type", "")
    if kind not in JOINT_KINDS:
        raise _fail(
            source, f"joint {name!r} has type {kind!r}; URDF types are: {', '.join(JOINT_KINDS)}"
        )
    ends = []
    for tag in ("parent", "child"):
        sub = elem.find(tag)
        link = None if sub is None else sub.get("link")
        if not link:
            raise _fail(source, f'joint {name!r} has no <{tag} link="..."/>')
        if link not in links:
            raise _fail(source, f"joint {name!r}: {tag} link {link!r} is not defined")
        ends.append(link)
    limit = elem.find("limit")
    bounded = kind in ("revolute", "prismatic")
    extension = elem.find(REDSERVO_LIMIT)
    xyz, rpy, axis = joint_geometry(elem, kind, source, name)
    return URDFJoint(
        name=name,
        kind=kind,
        parent=ends[0],
        child=ends[1],
        lower=position(limit, "lower", source, name, bounded),
        upper=position(limit, "upper", source, name, bounded),
        velocity_text=None if limit is None else limit.get("velocity"),
        acceleration_text=None if extension is None else extension.get("acceleration"),
        mimic=elem.find("mimic") is not None,
        xyz=xyz,
        rpy=rpy,
        axis=axis,
    )


def read_urdf(path: str | os.PathLike[str]) -> URDFTree:
    """Parse and check the kinematic tree of a URDF file.

    Args:
        path: The ``.urdf`` file.

    Raises:
        ConfigurationError: the file is missing or unreadable, not well-formed XML, or
            not a valid URDF tree (the message names the file and the link or joint).
    """
    source = str(path)
    try:
        text = Path(path).read_bytes()
    except FileNotFoundError:
        raise ConfigurationError(f"URDF file {source} does not exist", argument="path") from None
    except OSError as exc:
        raise ConfigurationError(
            f"cannot read URDF file {source}: {exc.strerror or exc}", argument="path"
        ) from None
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        line, col = exc.position
        raise _fail(source, f"not well-formed XML at line {line}, column {col + 1}") from None
    if root.tag == "mujoco":
        raise _fail(
            source,
            "an MJCF (MuJoCo) model, not a URDF (root <mujoco>, expected <robot>): give it "
            "as robot.kind = 'mjcf' with robot.file (MJCFRobot in Python; "
            'docs/robots.md, "MJCF models")',
        )
    if root.tag != "robot":
        raise _fail(source, f"the root element is <{root.tag}>, expected <robot>")
    links: list[str] = []
    for elem in root.findall("link"):
        name = elem.get("name")
        if not name:
            raise _fail(source, "a <link> has no name attribute")
        if name in links:
            raise _fail(source, f"link {name!r} is defined twice")
        links.append(name)
    if not links:
        raise _fail(source, "no <link> element")
    link_set = set(links)
    joints: dict[str, URDFJoint] = {}
    parent_joint: dict[str, str] = {}
    for elem in root.findall("joint"):
        joint = _read_joint(elem, source, link_set)
        if joint.name in joints:
            raise _fail(source, f"joint {joint.name!r} is defined twice")
        if joint.child in parent_joint:
            raise _fail(
                source,
                f"link {joint.child!r} is the child of two joints, "
                f"{parent_joint[joint.child]!r} and {joint.name!r}",
            )
        joints[joint.name] = joint
        parent_joint[joint.child] = joint.name
    roots = [link for link in links if link not in parent_joint]
    if len(roots) != 1:
        what = "a cycle" if not roots else f"{len(roots)} root links ({', '.join(roots)})"
        raise _fail(source, f"the links must form one tree, found {what}")
    return URDFTree(
        source, root.get("name", ""), tuple(links), joints, parent_joint, roots[0], root
    )


def chain(tree: URDFTree, base_link: str, tip_link: str) -> list[URDFJoint]:
    """Return the joints (fixed ones included) from ``base_link`` down to ``tip_link``, in order.

    Raises:
        UnknownNameError: either link is not in the file.
        ConfigurationError: ``tip_link`` is not downstream of ``base_link``.
    """
    tree.check_link(base_link, "base_link")
    tree.check_link(tip_link, "camera_link")
    path: list[URDFJoint] = []
    link = tip_link
    while link != base_link:
        if link == tree.root:
            raise ConfigurationError(
                f"camera_link {tip_link!r} is not downstream of base_link {base_link!r} in "
                f"{tree.source}; the links above {tip_link!r} are: "
                f"{', '.join(reversed(_ancestors(tree, tip_link)))}",
                argument="camera_link",
            )
        joint = tree.joints[tree.parent_joint[link]]
        path.append(joint)
        link = joint.parent
    return path[::-1]


def _ancestors(tree: URDFTree, link: str) -> list[str]:
    out = []
    while link != tree.root:
        link = tree.joints[tree.parent_joint[link]].parent
        out.append(link)
    return out


def pinocchio_xml(tree: URDFTree) -> str:
    """Return the URDF text for Pinocchio, with ``continuous`` joints made ``revolute``.

    A rewritten joint gets ``<limit lower="-2π" upper="2π">`` (:data:`CONTINUOUS_LIMIT`).
    Every ``<limit>`` gets a ``velocity`` and an ``effort`` that urdfdom accepts (``0``, i.e.
    unknown, where absent or not a finite number: redservo takes its rate limits from the
    checked tree or from the caller, never from Pinocchio, and ignores efforts); every axis
    is written normalised, and redservo's own elements are left out.
    """
    root = ET.fromstring(ET.tostring(tree.element))  # a copy; the tree stays as read
    for elem in root.findall("joint"):
        for extension in elem.findall(REDSERVO_LIMIT):
            elem.remove(extension)
        joint = tree.joints.get(elem.get("name", ""))
        axis = elem.find("axis")
        if joint is not None and axis is not None and joint.kind in AXIS_KINDS:
            axis.set("xyz", " ".join(repr(v) for v in joint.axis))
        limit = elem.find("limit")
        if elem.get("type") == "continuous":
            elem.set("type", "revolute")
            if limit is None:
                limit = ET.SubElement(elem, "limit")
            limit.set("lower", repr(-CONTINUOUS_LIMIT))
            limit.set("upper", repr(CONTINUOUS_LIMIT))
        if limit is not None:
            limit.set("effort", finite_or_zero(limit.get("effort")))
            limit.set("velocity", finite_or_zero(limit.get("velocity")))
    return ET.tostring(root, encoding="unicode")


def locked_values(
    tree: URDFTree, servo: list[URDFJoint], locked_q: Mapping[str, float] | None
) -> dict[str, float]:
    """Return the value (m or rad) of every one-variable joint of ``tree`` not in ``servo``.

    A joint listed in ``locked_q`` takes that value, checked against its limits; any other
    sits at 0, or at mid-range when 0 is outside its limits.

    Raises:
        UnknownNameError: a ``locked_q`` name is not a lockable joint of the file.
        ConfigurationError: a ``locked_q`` name is a servoed joint, or its value no number.
        JointLimitError: a ``locked_q`` value is outside its joint's limits.
    """
    servo_names = {j.name for j in servo}
    lockable = [
        j for j in tree.joints.values() if j.name not in servo_names and j.kind in _ONE_VARIABLE
    ]
    given = dict(locked_q or {})
    for name in given:
        if name in servo_names:
            raise ConfigurationError(
                f"locked_q: joint {name!r} is servoed (listed in joints); lock it by leaving it "
                "out of joints=",
                argument="locked_q",
            )
        if name not in {j.name for j in lockable}:
            raise UnknownNameError(
                f"locked_q: {name!r} is not a lockable joint of {tree.source}; lockable "
                f"joints: {', '.join(j.name for j in lockable) or '(none)'}",
                argument="locked_q",
            )
    out: dict[str, float] = {}
    for j in lockable:
        lo = j.lower if j.kind != "continuous" else None
        hi = j.upper if j.kind != "continuous" else None
        if j.name in given:
            value = given[j.name]
            if isinstance(value, bool) or not isinstance(value, int | float | np.number):
                raise ConfigurationError(
                    f"locked_q[{j.name!r}] must be a number (m or rad), got {value!r}",
                    argument="locked_q",
                )
            v = float(value)
            if not math.isfinite(v) or (lo is not None and hi is not None and not lo <= v <= hi):
                raise JointLimitError(
                    f"locked_q[{j.name!r}] = {v!r} is outside the joint's limits [{lo}, {hi}]",
                    argument="locked_q",
                    value=v,
                    lower=lo,
                    upper=hi,
                )
        elif lo is not None and hi is not None and not lo <= 0.0 <= hi:
            v = 0.5 * (lo + hi)
        else:
            v = 0.0
        out[j.name] = v
    return out
