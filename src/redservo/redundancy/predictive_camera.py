"""The camera-motion limit of the ``predictive`` law: the image points move at most so far
per camera frame that the tracker keeps them (docs/predictive.md, "Camera motion").

A dot tracker predicts each dot at constant velocity and accepts a blob within its gate
``g`` (pixels) of that prediction (:mod:`redservo.vision.tracking`): a dot that moves at most
``a`` pixels per frame is at most ``2a`` from the prediction, so ``a = g / 2`` keeps every
dot; the default limit is :data:`GATE_FRACTION` of the gate (one half: the realistic
camera preset's limit in the Controller, ``sensor.motion_limit``, is the same share). A
point moving at ``ṡ`` moves ``‖ṡ‖ / frame_rate`` per frame, so the limit per control
*period* ``dt`` is ``a · frame_rate · dt`` (``a`` without a frame rate: a frame every
period). Through a camera, the horizon's image bounds are also damped
(:func:`damped_image_bounds`).

It is enforced twice:

* in the horizon QP, as rows on the linearised motion of each point between consecutive
  predicted periods (:func:`motion_rows`), ``|Δx| <= a_x/√2`` and ``|Δy| <= a_y/√2``
  (normalized units: ``a_x = a / px``, ``a_y = a / py``), so that the Euclidean motion in
  pixels is at most ``a``;
* on the command, exactly: the nonlinear model's motion of the first period is checked,
  and the command scaled down until it holds (:func:`scale_to_limit`): a linearisation
  error or a fallback command never moves a point further.

Units: seconds, pixels, normalized image coordinates.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.redundancy.base import LawInputs, LawResult
from redservo.redundancy.flags import Event, Flag
from redservo.redundancy.predictive_model import Horizon, Prediction, horizon

__all__ = [
    "BORDER_DAMPING",
    "GATE_FRACTION",
    "MotionGain",
    "MotionLimit",
    "damped_image_bounds",
    "limited",
    "motion_rows",
    "scale_to_limit",
]

GATE_FRACTION = 0.5
"""The default limit of a point's motion per frame, a fraction of the tracker's gate (at most
1/2: the constant-velocity prediction then stays within the gate). It was 0.4 per control
period until branch ``gatefix`` (docs/predictive.md, "Camera motion")."""


class MotionLimit:
    """A point's largest motion per control period: ``ax``, ``ay`` (normalized units) and
    ``px``, ``py`` (the camera's focal lengths, pixels per normalized unit) to measure it in
    pixels, ``limit_px`` (the Euclidean limit per period, pixels)."""

    def __init__(self, limit_px: float, px: float, py: float) -> None:
        self.limit_px = float(limit_px)
        self.px, self.py = float(px), float(py)
        self.ax, self.ay = self.limit_px / self.px, self.limit_px / self.py

    @classmethod
    def resolve(
        cls,
        *,
        normalized: float | None,
        pixels: float | None,
        gate_px: float | None,
        frame_rate: float | None,
        dt: float,
        camera: Any,
    ) -> MotionLimit | None:
        """The limit per period (None: no limit) from the law's options: ``normalized``
        (per frame, normalized units, measured with the camera's ``px``) or ``pixels`` (per
        frame), else :data:`GATE_FRACTION` of the bound tracker's gate ``gate_px`` (pixels),
        else none; per period with a camera at ``frame_rate`` (Hz, None: the control rate
        ``1/dt``, s)."""
        if normalized is not None:
            per_frame = normalized * camera.px
        elif pixels is not None:
            per_frame = pixels
        elif gate_px is not None:
            per_frame = GATE_FRACTION * gate_px
        else:
            return None
        share = 1.0 if frame_rate is None else frame_rate * dt
        return cls(per_frame * share, camera.px, camera.py)

    def pixels(self, ds: FloatArray) -> FloatArray:
        """The Euclidean motion (pixels) of each point of a (…, 2p) normalized motion."""
        d = np.asarray(ds).reshape(*np.shape(ds)[:-1], -1, 2)
        return np.asarray(np.hypot(d[..., 0] * self.px, d[..., 1] * self.py))


BORDER_DAMPING = 0.1
"""Through a camera (a tracker bound), the largest fraction of its gap to the image bound
(less the law's ``image_margin_px``) that an image point may close per period of the
horizon (:func:`damped_image_bounds`)."""


def damped_image_bounds(
    s_lo: FloatArray, s_hi: FloatArray, s0: FloatArray, N: int
) -> tuple[FloatArray, FloatArray]:
    """The image bounds (N, 2p) of the horizon through a camera: at period ``k = 1…N`` each
    point keeps at least ``(1 - ξ)^k`` of its gap at ``s0`` (2p,; the points now) to the
    bounds ``[s_lo, s_hi]`` (2p,), ``ξ`` = :data:`BORDER_DAMPING`, so that it slows down as
    it nears the border: the measured points lag the true ones by the image motion of the
    camera's latency (less what the compensation predicts), and that motion then shrinks
    with the gap. A point already past a bound keeps the bound (the QP relaxes it to the
    point). Units: normalized image coordinates."""
    keep = (1.0 - BORDER_DAMPING) ** np.arange(1, N + 1)[:, None]
    lo = s_lo + keep * np.maximum(s0 - s_lo, 0.0)
    hi = s_hi - keep * np.maximum(s_hi - s0, 0.0)
    return lo, hi


def motion_rows(
    pred: Prediction, hz: Horizon, dt: float, Ubar: FloatArray, s0: FloatArray, lim: MotionLimit
) -> tuple[list[FloatArray], list[FloatArray], list[FloatArray]]:
    """Rows ``blo <= A U <= bhi`` of the horizon QP: each point's linearised motion between
    the predicted periods ``k - 1`` and ``k`` (``k = 1…N``; period 0 is ``s0``, the points
    now) within ``±(a_x, a_y)/√2``."""
    assert pred.s is not None and pred.S is not None
    ub = Ubar.reshape(-1)
    p = pred.s.shape[1] // 2
    box = np.tile([lim.ax, lim.ay], p) / math.sqrt(2.0)
    rows, blo, bhi = [], [], []
    prev_A = np.zeros((pred.s.shape[1], ub.size))
    prev_b = np.asarray(s0, dtype=float)
    for k in range(1, hz.N + 1):
        Ak = dt * np.concatenate([hz.M[k - 1, j] * pred.S[k - 1] for j in range(hz.Nc)], axis=1)
        bk = pred.s[k - 1] - Ak @ ub
        rows.append(Ak - prev_A)
        blo.append(-box - (bk - prev_b))
        bhi.append(box - (bk - prev_b))
        prev_A, prev_b = Ak, bk
    return rows, blo, bhi


def _motion_px(model: Any, q: FloatArray, u: FloatArray, dt: float, lim: MotionLimit) -> float:
    """The largest Euclidean motion (pixels) of a point in one period at the command ``u``
    under ``model`` (``inf`` when the prediction fails)."""
    pred = model.predict(q, u[None, :], horizon(1, 1), dt)
    if pred is None or pred.s is None or model.s_now is None:
        return math.inf
    return float(np.max(lim.pixels(pred.s[0] - model.s_now)))


def scale_to_limit(
    model: Any, q: FloatArray, u: FloatArray, dt: float, lim: MotionLimit, bisections: int = 20
) -> tuple[FloatArray, float, float]:
    """``(α u, α, motion)``: the command ``u`` (n,) scaled by the largest ``α`` in ``[0, 1]``
    found by bisection whose first-period image motion under the nonlinear ``model`` (from
    ``q``, period ``dt``, s) is within ``lim`` (``motion``, pixels, before the scaling);
    ``u`` itself when it already is; 0 when no positive ``α`` was found."""
    motion = _motion_px(model, q, u, dt, lim)
    if motion <= lim.limit_px:
        return u, 1.0, motion
    lo, hi = 0.0, min(1.0, lim.limit_px / motion) if math.isfinite(motion) else 1.0
    if _motion_px(model, q, hi * u, dt, lim) <= lim.limit_px:
        return hi * u, hi, motion
    for _ in range(bisections):
        mid = 0.5 * (lo + hi)
        if _motion_px(model, q, mid * u, dt, lim) <= lim.limit_px:
            lo = mid
        else:
            hi = mid
    return lo * u, lo, motion


class MotionGain:
    """How much faster the points move than the model predicts: the model's depths may be
    wrong (the image sensor's ``depth = "desired"`` or an estimate), and the image motion of
    a translation scales with ``1/Z``. At each period the measured motion since the previous
    period is compared with the motion the previous model predicted for the command actually
    sent (``q̇_prev``, after the safety stage); their ratio (from 1 to :data:`MAX_GAIN`,
    averaged over two periods) divides the limit, so that the measured motion, not only the
    model's, keeps within it. Only motions above :data:`MIN_MOTION_PX` count (the image
    noise)."""

    def __init__(self) -> None:
        self.gain = 1.0
        """The current ratio (>= 1)."""
        self._last: tuple[Any, FloatArray] | None = None

    def reset(self) -> None:
        """Forget the previous period (the ratio back to 1)."""
        self.gain, self._last = 1.0, None

    def update(
        self, model: Any, q: FloatArray, qdot_prev: FloatArray | None, dt: float, lim: MotionLimit
    ) -> MotionLimit:
        """The limit of this period, ``lim`` divided by the ratio updated with the motion
        from the previous period's points to ``model.s_now`` (the points now), and remember
        this period's model and joints ``q``."""
        last, self._last = self._last, (model, q)
        if last is not None and qdot_prev is not None and model.s_now is not None:
            predicted = _motion_px(last[0], last[1], qdot_prev, dt, lim)
            if last[0].s_now is not None and MIN_MOTION_PX < predicted < math.inf:
                measured = float(np.max(lim.pixels(model.s_now - last[0].s_now)))
                ratio = min(MAX_GAIN, max(1.0, measured / predicted))
                self.gain = max(1.0, 0.5 * (self.gain + ratio))
        if self.gain <= 1.0:
            return lim
        return MotionLimit(lim.limit_px / self.gain, lim.px, lim.py)


MAX_GAIN = 5.0
"""The largest ratio of the measured over the predicted image motion (:class:`MotionGain`)."""
MIN_MOTION_PX = 1.0
"""Predicted motions below this (px) do not update the ratio (:class:`MotionGain`)."""


def limited(res: LawResult, x: LawInputs, model: Any, lim: MotionLimit | None) -> LawResult:
    """``res`` with its command scaled down so that no image point moves more than the
    camera-motion limit ``lim`` in the first period under the nonlinear ``model``
    (:func:`scale_to_limit`), ``task-scaled`` raised with the scale factor; ``res`` itself
    when it already keeps within (or without a limit or a model)."""
    if lim is None or model is None:
        return res
    u, alpha, motion = scale_to_limit(model, x.q, res.qdot, x.dt, lim)
    if alpha >= 1.0:
        return res
    d = res.diagnostics
    text = (
        f"predictive: command scaled by {alpha:.3g} so that no image point moves more than "
        f"{lim.limit_px:.3g} px in a period ({motion:.3g} px before; camera-motion limit)"
    )
    ev = (*d.events, Event(Flag.TASK_SCALED, alpha, text))
    return LawResult(np.ascontiguousarray(u), replace(d, events=ev))
