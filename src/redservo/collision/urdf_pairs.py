"""Self-collision pairs of a URDF robot's ``<collision>`` elements.

Every two links that carry elements, minus the pairs that cannot or need not collide, as
MoveIt's allowed-collision matrix excludes them:

* two links of one **rigid body** (links joined by ``fixed`` joints move as one);
* **adjacent** bodies, joined by one moving joint (their elements meet at the joint by
  construction; MoveIt's setup assistant marks them "Adjacent");
* the pairs an **SRDF** file names, ``<disable_collisions link1="a" link2="b" reason="..."/>``
  (the MoveIt configuration a robot ships with: "Never", "Default", "Adjacent" pairs);
* the pairs the caller excludes, as ``(link, link)`` names.

A link name the SRDF or the exclusions give that the URDF has not is an error naming the
file (or the argument) and the link: a pair list written for another robot excludes
nothing it should, silently.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from pathlib import Path

from redservo.errors import ConfigurationError, GeometryError, UnknownNameError

__all__ = ["disabled_pairs", "rigid_bodies", "urdf_self_pairs"]


def _root(path: Path, what: str) -> ET.Element:
    try:
        return ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise GeometryError(f"{path}: cannot read the {what} ({exc})") from None


def rigid_bodies(urdf: str | Path) -> tuple[dict[str, str], set[frozenset[str]]]:
    """The URDF's links grouped into rigid bodies, and the adjacent bodies.

    Returns:
        ``(body, adjacent)``: ``body[link]`` names the body's first link (base side) for
        every link of the file; ``adjacent`` holds the ``{body, body}`` pairs joined by one
        moving joint.
    """
    root = _root(Path(urdf), "URDF")
    links = [el.get("name", "") for el in root.findall("link")]
    joints = []
    for j in root.findall("joint"):
        up, down = j.find("parent"), j.find("child")
        if up is None or down is None:
            continue
        joints.append((up.get("link", ""), down.get("link", ""), j.get("type", "")))
    body = {name: name for name in links}

    def find(name: str) -> str:
        while body.get(name, name) != name:
            name = body[name]
        return name

    for parent, child, kind in joints:
        if kind == "fixed":
            body[find(child)] = find(parent)
    flat = {name: find(name) for name in links}
    adjacent = {
        frozenset({flat.get(p, p), flat.get(c, c)})
        for p, c, kind in joints
        if kind != "fixed" and flat.get(p, p) != flat.get(c, c)
    }
    return flat, adjacent


def disabled_pairs(srdf: str | Path, links: Iterable[str]) -> set[frozenset[str]]:
    """The ``<disable_collisions>`` pairs of the SRDF file ``srdf``.

    Raises:
        GeometryError: the file cannot be read or parsed (names it).
        UnknownNameError: a pair names a link ``links`` does not hold (names the file).
    """
    path = Path(srdf)
    known = set(links)
    out: set[frozenset[str]] = set()
    for k, el in enumerate(_root(path, "SRDF").iter("disable_collisions")):
        pair = (el.get("link1", ""), el.get("link2", ""))
        for name in pair:
            if name not in known:
                raise UnknownNameError(
                    f"{path.name}: disable_collisions {k} names link {name!r}, which the "
                    f"robot's URDF does not have",
                    argument="srdf",
                )
        out.add(frozenset(pair))
    return out


def urdf_self_pairs(
    urdf: str | Path,
    links: Sequence[str],
    *,
    srdf: str | Path | None = None,
    exclude: Iterable[tuple[str, str]] = (),
) -> list[tuple[str, str]]:
    """The ``(link, link)`` pairs checked for self-collision, in ``links`` order.

    Args:
        urdf: The robot's URDF file.
        links: The links that carry ``<collision>`` elements, in file order.
        srdf: An SRDF file whose ``<disable_collisions>`` pairs are skipped.
        exclude: More pairs to skip, as link names.

    Raises:
        GeometryError: the URDF or SRDF cannot be read.
        UnknownNameError: the SRDF or ``exclude`` names a link the URDF has not.
        ConfigurationError: no pair is left to check (``argument="self"``).
    """
    body, adjacent = rigid_bodies(urdf)
    skip = disabled_pairs(srdf, body) if srdf is not None else set()
    for pair in exclude:
        for name in pair:
            if name not in body:
                raise UnknownNameError(
                    f"exclude: unknown link {name!r}; links: {', '.join(body)}", argument="exclude"
                )
        skip.add(frozenset(pair))
    order = list(dict.fromkeys(links))
    out = []
    for i, a in enumerate(order):
        for b in order[i + 1 :]:
            ba, bb = body.get(a, a), body.get(b, b)
            if ba == bb or frozenset({ba, bb}) in adjacent or frozenset({a, b}) in skip:
                continue
            out.append((a, b))
    if not out:
        raise ConfigurationError(
            f"{Path(urdf).name}: self-collision asked for, but no two links with <collision> "
            "elements can collide (one rigid body, adjacent or disabled); set self = false",
            argument="self",
        )
    return out
