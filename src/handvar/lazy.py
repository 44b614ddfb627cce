"""Public names of a package imported on first use (PEP 562), as scikit-image's are.

A package's ``__init__`` lists its names and the modules that define them and calls
`attach`; importing the package, or one module of it, then loads none of the others
(the detector's process imports `handvar.vision.mediapipe` without SciPy or numba).
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Iterable


def attach(package: str, modules: dict[str, Iterable[str]]) -> tuple[Callable, Callable]:
    """``__getattr__`` and ``__dir__`` for `package`, whose names in ``modules[m]`` are
    defined in module ``m``.

    Examples
    --------
    >>> import types
    >>> sys.modules["package"] = types.ModuleType("package")
    >>> getattr_, dir_ = attach("package", {"math": ["tau"]})
    >>> round(getattr_("tau"), 3), "tau" in dir_(), sys.modules["package"].tau == getattr_("tau")
    (6.283, True, True)
    >>> del sys.modules["package"]
    """
    where = {name: module for module, names in modules.items() for name in names}

    def __getattr__(name: str):
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)  # later look-ups skip this function
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *where})

    return __getattr__, __dir__
