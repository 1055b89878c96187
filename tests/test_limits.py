"""Tests of JointLimits (CM01 eqs. 3-6, 17)."""

import numpy as np

from redservo import JointLimits


def test_thresholds_at_point_nine_normalized() -> None:
    lim = JointLimits([-1.0, 0.0], [1.0, 2.0], rho=0.1)
    assert np.allclose(lim.normalized(lim.q_tilde_min), -0.8)
    assert np.allclose(lim.normalized(lim.q_tilde_max), 0.8)
    assert np.allclose(lim.normalized(lim.q_min), -1.0)
    assert np.allclose(lim.normalized(lim.q_max), 1.0)
