"""Self-collision pairs: every two links of the robot, minus the pairs that cannot collide.

The usual exclusions (as in MoveIt's allowed-collision matrix and Pinocchio's
``removeCollisionPair``): a link and its neighbours on the chain (adjacent capsules share
a joint and always touch), and two links on either side of a link shorter than the sum of
their radii (they overlap at every configuration: on the Panda, link 5 and the flange
around the short link 7). Exclude more by passing ``exclude=[("link_a", "link_b"), ...]``
to :func:`self_pairs` or :func:`~redservo.collision.distances` (order does not matter).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from redservo.collision.robot import LinkCapsule
from redservo.errors import UnknownNameError

__all__ = ["self_pairs"]


def self_pairs(
    capsules: Sequence[LinkCapsule], exclude: Iterable[tuple[str, str]] = ()
) -> list[tuple[str, str]]:
    """The (link, link) name pairs checked for self-collision, base to tip.

    Args:
        capsules: The robot's capsules, base to tip (consecutive ones share a frame).
        exclude: More pairs to skip, as link names.

    Raises:
        UnknownNameError: an excluded name is not one of the capsules.
    """
    names = [c.name for c in capsules]
    skip = set()
    for pair in exclude:
        for name in pair:
            if name not in names:
                raise UnknownNameError(f"exclude: unknown link {name!r}; links: {', '.join(names)}")
        skip.add(frozenset(pair))
    out = []
    for i, ci in enumerate(capsules):
        for k, cj in enumerate(capsules[i + 2 :], start=i + 2):
            bridged = k == i + 2 and capsules[i + 1].length < ci.radius + cj.radius
            if frozenset({ci.name, cj.name}) not in skip and not bridged:
                out.append((ci.name, cj.name))
    return out
