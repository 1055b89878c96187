"""One compiled specialization per kernel for the argument types real runs pass: the callers
hand the kernels the types ``redservo warmup`` compiled them for (a read-only or strided
array is another numba type, for which a whole chain would be compiled again), with the
same numbers."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.kernels import compiled
from tests.test_public_path_speed import _controller

needs_numba = pytest.mark.skipif(not compiled(), reason="numba's types (plain Python: none)")


def _readonly_signatures(*dispatchers: Any) -> list[str]:
    """The signatures loaded in this process with a read-only array among their types."""
    return [str(s) for d in dispatchers for s in d.signatures if "True, aligned" in str(s)]


@needs_numba
@pytest.mark.parametrize("layout", ["readonly", "strided"])
@pytest.mark.parametrize("with_J", [False, True])
def test_a_read_only_or_strided_qdot_prev_reaches_the_step_kernel_as_the_warmed_type(
    layout: str, with_J: bool
) -> None:
    """The Controller's compiled step (its own kinematics, or the Jacobian the simulator
    passes) gets a read-only or strided ``qdot_prev`` as a writable C-contiguous copy: on
    main a read-only one was passed on with the Jacobian, and the step chain (22-26 kernels,
    every law) was compiled a second time for it, by the warm-up and in
    tests/test_controller_quick_step.py. The command is a writable ``qdot_prev``'s."""
    from redservo.kernels import control as K

    ctl, q, meas = _controller()
    ref, _, _ = _controller()
    J = ctl.robot.kinematics(q)[1] if with_J else None
    for c in (ctl, ref):
        c.step(q, meas, 0.0, qdot_prev=None, J=J)
    prev = 0.01 * np.random.default_rng(3).normal(size=q.shape[0])
    given = np.repeat(prev, 2)[::2] if layout == "strided" else prev.copy()
    given.setflags(write=layout != "readonly")
    got = ctl.step(q, meas, 0.04, qdot_prev=given, J=J)
    want = ref.step(q, meas, 0.04, qdot_prev=prev, J=J)
    assert got.qdot.tobytes() == want.qdot.tobytes()
    assert _readonly_signatures(K.measured_control, K.robot_control) == []
