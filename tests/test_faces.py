"""Each package's public face: ``__all__`` names what the package offers,
every name resolves to what its module defines, and importing a face loads
no module but the package ``__init__``s and the standard library
(:func:`lazy_loader.attach`, PEP 562)."""
from __future__ import annotations

import importlib
import json
import pathlib
import pkgutil
import subprocess
import sys
import types

import pytest

PKG = pathlib.Path(__file__).resolve().parents[1] / "bayescal"

#: Every package of bayescal, the root included.
FACES = sorted(".".join(p.parent.relative_to(PKG.parent).parts) for p in PKG.rglob("__init__.py"))
#: What every face may load besides the standard library and its own and its
#: parents' ``__init__``: the version the root and the command line print, and
#: the library that makes faces lazy.
LEAVES = {"bayescal.version", "lazy_loader"}

#: Run in a fresh interpreter: the modules that importing the face ``argv[1]`` adds.
_LOADED = ("import importlib, json, sys\n"
           "before = set(sys.modules)\n"
           "importlib.import_module(sys.argv[1])\n"
           "print(json.dumps(sorted(set(sys.modules) - before)))\n")


def loaded_beyond_the_face(face, loaded):
    """The modules of ``loaded`` that importing ``face`` may not load: all but
    the standard library's, :data:`LEAVES` and the ``__init__`` of ``face`` and
    of its parents."""
    parts = face.split(".")
    allowed = LEAVES | {".".join(parts[:k]) for k in range(1, len(parts) + 1)}
    return sorted(m for m in loaded if m not in allowed
                  and m.split(".")[0] not in sys.stdlib_module_names)


@pytest.mark.parametrize("face", FACES)
def test_importing_a_face_loads_only_package_inits(face):
    """In its own fresh interpreter, importing the face adds to ``sys.modules``
    only that package's ``__init__`` (and its parents'), :data:`LEAVES` and
    modules of the standard library: no module of the package, no numpy, no
    Dask."""
    out = subprocess.run([sys.executable, "-c", _LOADED, face], capture_output=True, text=True,
                         cwd=str(PKG.parent), check=True).stdout
    extra = loaded_beyond_the_face(face, json.loads(out))
    assert not extra, f"{face} loads {extra}"


def test_face_rule_sees_a_third_party_import():
    """The rule flags a third-party or package module that a face loads, and
    passes the standard library and the face's own ``__init__``s."""
    loaded = ["bayescal.network", "bayescal", "lazy_loader", "argparse", "importlib.util",
              "dask", "dask.base", "numpy", "bayescal.network.plan"]
    assert loaded_beyond_the_face("bayescal.network", loaded) == [
        "bayescal.network.plan", "dask", "dask.base", "numpy"]


def test_every_public_name_resolves():
    """Each face has an ``__all__``; every name in it is listed by ``dir``,
    resolves to a value that is not a module, and does not share its name
    with a submodule of the package (which, once imported, would shadow it)."""
    bad = []
    for face in FACES:
        mod = importlib.import_module(face)
        names = getattr(mod, "__all__", None)
        if not names:
            bad.append(f"{face} has no __all__")
            continue
        subs = {m.name for m in pkgutil.iter_modules(mod.__path__)}
        listed = set(dir(mod))
        for name in names:
            if name in subs:
                bad.append(f"{face}.{name} is also a submodule")
            elif name not in listed:
                bad.append(f"{face}.{name} not in dir()")
            elif isinstance(getattr(mod, name), types.ModuleType):
                bad.append(f"{face}.{name} is a module")
    assert not bad, "\n".join(bad)
