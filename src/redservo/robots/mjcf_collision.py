"""The collision geometry of an MJCF robot: one enclosing capsule per body.

Which geoms: every geom of the bodies under the robot's ``base`` (base included, off-chain
bodies such as fingers too) that collides in MuJoCo (``contype`` or ``conaffinity`` not 0)
or sits in group 3 (MuJoCo Menagerie's collision group, whose geoms often have both 0).
Geoms outside the base's subtree (a scene's floor) are not the robot's: obstacles are given
as a scenario's ``[[obstacles]]``.

redservo's distances (:mod:`redservo.collision`) and the compiled primitive kernels take
one capsule per link, so each body's collision geoms are enclosed in the smallest capsule
found along a few candidate axes (the principal axis of the geoms' centres, each capsule's
or cylinder's own axis, the body's x, y, z): conservative, never smaller than the geoms.

* ``sphere``: its centre and radius; ``capsule``: its two cap centres and radius;
  ``cylinder``: as the capsule of the same radius and length (encloses it); ``ellipsoid``:
  its centre and largest semi-axis; ``box``: its 8 corners; ``mesh``: its vertices (as
  MuJoCo compiled them, in the geom frame: the convex hull of the mesh is enclosed).
* ``plane``, ``hfield`` and ``sdf`` geoms on the robot are refused (a :class:`GeometryError`).

A body whose geoms fit in a ball gets a capsule of length :data:`MIN_LENGTH`. Mesh files are
read by MuJoCo only from inside the model's folder (:func:`redservo.robots.mjcf_chain.load_model`).
Units: metres.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Final

import numpy as np

from redservo._validation import FloatArray
from redservo.collision.robot import LinkCapsule
from redservo.errors import ConfigurationError, GeometryError, UnknownNameError
from redservo.robots.mjcf_chain import pose_of

__all__ = ["MIN_LENGTH", "MJCFCollision", "enclosing_capsule"]

MIN_LENGTH: Final = 1e-4
"""Shortest capsule axis (m): a ball-like body's capsule (the distance code needs an axis)."""

_SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX, _MESH = 2, 3, 4, 5, 6, 7
_REFUSED = {0: "plane", 1: "hfield", 8: "sdf"}


def _balls(model: Any, g: int) -> tuple[FloatArray, FloatArray, FloatArray | None]:
    """``(centres (k, 3), radii (k,), axis or None)`` of geom ``g`` in its body frame."""
    kind, size = int(model.geom_type[g]), np.asarray(model.geom_size[g], dtype=float)
    M = pose_of(model.geom_pos[g], model.geom_quat[g])
    R, c = M[:3, :3], M[:3, 3]
    if kind in _REFUSED:
        raise GeometryError(
            f"geom {model.geom(g).name or g!r} of body {model.body(model.geom_bodyid[g]).name!r} "
            f"is a {_REFUSED[kind]}; a robot's collision geoms are primitives or meshes",
            argument="path",
        )
    if kind == _SPHERE:
        return c[None], size[:1], None
    if kind == _ELLIPSOID:
        return c[None], np.array([size.max()]), None
    if kind in (_CAPSULE, _CYLINDER):
        z = R[:, 2]
        return np.stack([c - size[1] * z, c + size[1] * z]), np.full(2, size[0]), z
    if kind == _BOX:
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        return (corners * size) @ R.T + c, np.zeros(8), None
    if kind == _MESH:
        mesh = int(model.geom_dataid[g])
        start, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        verts = np.asarray(model.mesh_vert[start : start + count], dtype=float)
        return verts @ R.T + c, np.zeros(count), None
    raise GeometryError(f"geom {g}: unknown MuJoCo geom type {kind}", argument="path")


def _fit(c: FloatArray, r: FloatArray, u: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """The smallest capsule along the unit axis ``u`` enclosing the balls ``(c, r)``."""
    t = c @ u
    w = c - np.outer(t, u)
    o = 0.5 * (w.min(axis=0) + w.max(axis=0))
    o -= (o @ u) * u
    rho = np.linalg.norm(w - o, axis=1)
    R = float(np.max(rho + r))
    s = np.sqrt(np.maximum((R - r) ** 2 - rho**2, 0.0))
    lo, hi = float(np.min(t + s)), float(np.max(t - s))
    if hi < lo:  # a point segment anywhere in [hi, lo] encloses them all
        lo = hi = 0.5 * (lo + hi)
    if hi - lo < MIN_LENGTH:
        mid = 0.5 * (lo + hi)
        lo, hi = mid - MIN_LENGTH / 2, mid + MIN_LENGTH / 2
    return o + lo * u, o + hi * u, R


def enclosing_capsule(
    centres: FloatArray, radii: FloatArray, axes: Sequence[FloatArray] = ()
) -> tuple[FloatArray, FloatArray, float]:
    """``(A, B, radius)``: a capsule (m) enclosing every ball ``(centres[i], radii[i])``, the
    smallest in volume over the candidate axes (module docstring) and ``axes``."""
    candidates = [*axes, *np.eye(3)]
    spread = centres - centres.mean(axis=0)
    if len(centres) > 1 and np.linalg.norm(spread) > 1e-12:
        candidates.append(np.linalg.svd(spread, full_matrices=False)[2][0])
    best = None
    for u in candidates:
        A, B, R = _fit(centres, radii, np.asarray(u) / np.linalg.norm(u))
        volume = np.pi * R * R * float(np.linalg.norm(B - A)) + 4.0 / 3.0 * np.pi * R**3
        if best is None or volume < best[0]:
            best = (volume, A, B, R)
    assert best is not None
    return best[1], best[2], best[3]


def _collides(model: Any, g: int) -> bool:
    return bool(model.geom_contype[g] or model.geom_conaffinity[g] or model.geom_group[g] == 3)


class MJCFCollision:
    """The capsules of the bodies under ``base`` (module docstring) and their end points.

    Args:
        model: The ``mujoco.MjModel``.
        base: The robot's base body id (the frame of the points).
        servo: The servoed joint ids (the Jacobians' columns, in order).
    """

    def __init__(self, model: Any, base: int, servo: Sequence[int]) -> None:
        self._model = model
        self.base = base
        self.subtree = [b for b in range(model.nbody) if self._under(b)]
        self.cols = [int(model.jnt_dofadr[j]) for j in servo]
        self.bodies: list[int] = []
        self.local: list[tuple[FloatArray, FloatArray, float]] = []
        for b in self.subtree:
            geoms = [
                g for g in range(model.ngeom) if model.geom_bodyid[g] == b and _collides(model, g)
            ]
            if not geoms:
                continue
            parts = [_balls(model, g) for g in geoms]
            centres = np.vstack([p[0] for p in parts])
            radii = np.concatenate([p[1] for p in parts])
            axes = [p[2] for p in parts if p[2] is not None]
            self.bodies.append(b)
            self.local.append(enclosing_capsule(centres, radii, axes))

    def _under(self, b: int) -> bool:
        while b != self.base and b != 0:
            b = int(self._model.body_parentid[b])
        return b == self.base

    def capsules(self, radii: Mapping[str, float] | None = None) -> tuple[LinkCapsule, ...]:
        """One :class:`~redservo.collision.LinkCapsule` per body (name: the body's), its ends
        the points ``2k`` and ``2k + 1`` of :meth:`points`; ``radii`` overrides by body name."""
        names = [self._model.body(b).name for b in self.bodies]
        for key, value in (radii or {}).items():
            if key not in names:
                raise UnknownNameError(
                    f"radii: {key!r} is not a body with collision geoms; those are: "
                    f"{', '.join(names)}",
                    argument="radii",
                )
            if not (np.isfinite(value) and value > 0.0):
                raise ConfigurationError(f"radius of body {key!r} must be > 0 (m), got {value}")
        if not names:
            raise ConfigurationError(
                "the MJCF robot has no collision geom (contype/conaffinity or group 3)",
                argument="robot",
            )
        out = []
        for k, (name, (A, B, R)) in enumerate(zip(names, self.local)):
            r = float((radii or {}).get(name, R))
            out.append(LinkCapsule(name, 2 * k, 2 * k + 1, r, float(np.linalg.norm(B - A))))
        return tuple(out)

    def points(self, data: Any) -> tuple[FloatArray, FloatArray]:
        """``(O, J)`` from MuJoCo's posed ``data``: (2K, 3) capsule ends in the base frame (m)
        and (2K, 3, n) their Jacobians ``∂o/∂q`` (m/rad or m/m)."""
        import mujoco

        m = self._model
        Rbw = data.xmat[self.base].reshape(3, 3).T
        pb = data.xpos[self.base]
        O = np.zeros((2 * len(self.bodies), 3))
        J = np.zeros((2 * len(self.bodies), 3, len(self.cols)))
        jacp = np.zeros((3, m.nv))
        for k, (b, (A, B, _)) in enumerate(zip(self.bodies, self.local)):
            R, x = data.xmat[b].reshape(3, 3), data.xpos[b]
            for i, p in enumerate((A, B)):
                w = R @ p + x
                mujoco.mj_jac(m, data, jacp, None, w, b)
                O[2 * k + i] = Rbw @ (w - pb)
                J[2 * k + i] = Rbw @ jacp[:, self.cols]
        return O, J
