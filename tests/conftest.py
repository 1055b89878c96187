"""Test-session settings shared by every test module."""

from __future__ import annotations

import os

# The suite checks the compiled kernels (and compares them with the plain ones where it says
# so): a cold cache must not switch a test process, or the commands it starts, to the plain
# kernels (redservo.bench.kernel_mode's `auto`). tests/test_kernel_mode.py clears it for its own
# processes.
os.environ.setdefault("REDSERVO_KERNELS", "compiled")
