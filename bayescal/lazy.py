"""A package's public face, loaded on first use (PEP 562).

Each subpackage's ``__init__`` names its public names and the module that
defines each; :func:`attach` gives it the module-level ``__getattr__`` and
``__dir__`` that import a name's module when the name is first read, so that
importing a face costs no import time, and ``__all__``. The interface is the
one of scientific Python's ``lazy_loader.attach`` (SPEC 1). A leaf: imports
nothing of bayescal.
"""
from __future__ import annotations

import importlib
import sys


def attach(package, names):
    """The lazy face of a package.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    names : dict
        Module -> the public names it defines; a module is relative to the
        package (``".welch"``) or absolute (``"bayescal.core.orientation"``).

    Returns
    -------
    __getattr__, __dir__, __all__
        To assign at the package's top level. ``__getattr__`` imports a
        public name's module on first read (then keeps the name), and
        otherwise the package's submodule of that name; ``__all__`` is the
        sorted public names.
    """
    where = {name: module for module, held in names.items() for name in held}

    def __getattr__(name):
        if name in where:
            value = getattr(importlib.import_module(where[name], package), name)
            setattr(sys.modules[package], name, value)
            return value
        try:
            return importlib.import_module(f"{package}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{package}.{name}":
                raise
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(where))

    return __getattr__, __dir__, sorted(where)
