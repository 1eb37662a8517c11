"""Each subpackage's public face: ``__all__`` names what the package offers,
every name resolves to what its module defines, and importing a face loads
no module of the package (PEP 562, :func:`bayescal.lazy.attach`)."""
from __future__ import annotations

import importlib
import json
import pathlib
import pkgutil
import subprocess
import sys
import types

PKG = pathlib.Path(__file__).resolve().parents[1] / "bayescal"

#: Every subpackage of bayescal (the root's face is tested in test_layout).
FACES = sorted(".".join(p.parent.relative_to(PKG.parent).parts)
               for p in PKG.rglob("__init__.py") if p.parent != PKG)
#: Leaves every face may load besides its own ``__init__`` and its parents'.
LEAVES = {"bayescal", "bayescal.version", "bayescal.lazy"}


def test_importing_a_face_loads_only_package_inits():
    """In a fresh interpreter, importing each face in turn adds to
    ``sys.modules`` only that package's ``__init__`` (and its parents' and
    the leaves'), and imports no numpy."""
    code = ("import importlib, json, sys\n"
            f"out = {{}}\n"
            f"for face in {FACES!r}:\n"
            "    before = set(sys.modules)\n"
            "    importlib.import_module(face)\n"
            "    out[face] = sorted(m for m in set(sys.modules) - before\n"
            "                       if m.split('.')[0] == 'bayescal' or m == 'numpy')\n"
            "print(json.dumps(out))\n")
    out = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                    cwd=str(PKG.parent), check=True).stdout)
    bad = {}
    for face, added in out.items():
        parts = face.split(".")
        allowed = LEAVES | {".".join(parts[:k]) for k in range(1, len(parts) + 1)}
        if extra := set(added) - allowed:
            bad[face] = sorted(extra)
    assert not bad, f"faces that import more than their package: {bad}"


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
