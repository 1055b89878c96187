"""Array-only kernels: the numerical core of the laws, features and kinematics (docs/speed.md).

Every function in the submodules takes and returns plain float64 arrays, numbers and
integer codes, and is compiled by numba when the optional extra ``redservo[fast]`` is
installed (:func:`redservo.kernels._jit.kernel`); without numba the same functions run
as plain Python. The public objects (laws, features, robots) validate their inputs, call
these kernels and wrap the results into typed objects.

Importing this package is cheap: numba is imported, and the kernels compiled or loaded
from the on-disk cache, only when a submodule is first used. The public modules hold
their kernels through :func:`lazy`, so that ``import redservo`` does not load numba; each
handle is the kernel module itself for the type checker (``if TYPE_CHECKING: from
redservo.kernels import features as _K`` / ``else: _K = lazy("features")``), so that mypy
checks every kernel call against the kernel's signature and go-to-definition reaches it
(``tests/test_kernel_handles.py`` keeps every handle so).
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

__all__ = ["COMPILED", "LazyModule", "compiled", "lazy"]


class LazyModule:
    """A module imported on first attribute access; later accesses are plain lookups."""

    def __init__(self, name: str) -> None:
        self.__dict__["_lazy_name"] = name

    def __getattr__(self, attr: str) -> Any:
        module: ModuleType = importlib.import_module(self.__dict__["_lazy_name"])
        self.__dict__.update({k: v for k, v in vars(module).items() if not k.startswith("__")})
        try:
            return self.__dict__[attr]
        except KeyError:
            raise AttributeError(f"module {module.__name__!r} has no attribute {attr!r}") from None


def lazy(name: str) -> Any:
    """Return a :class:`LazyModule` for the kernel module ``name`` (e.g. ``"linalg"``)."""
    return LazyModule(f"redservo.kernels.{name}")


def compiled() -> bool:
    """True when the kernels are compiled by numba (imports numba if not done yet)."""
    from redservo.kernels._jit import COMPILED

    return COMPILED


def __getattr__(name: str) -> Any:
    if name == "COMPILED":
        return compiled()
    raise AttributeError(f"module 'redservo.kernels' has no attribute {name!r}")
