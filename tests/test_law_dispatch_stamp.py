"""The generated law dispatch is recompiled when a law kernel or anything it calls changes.

Its numba cache stamp used to hold only the generated text: an edit of a law kernel or of
kernels/linalg.py left the cached dispatch (and every step compiled after it) linking the
old code."""

from __future__ import annotations

from pathlib import Path


def test_law_dispatch_cache_stamp_holds_the_law_kernels_sources() -> None:
    from redservo.kernels import law_dispatch, laws, linalg, sns

    for module in (laws, linalg, sns):
        assert Path(str(module.__file__)).read_bytes() in law_dispatch._STAMP
