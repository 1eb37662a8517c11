"""The package layout: imports point only down the layers named in
``bayescal/__init__.py``, there is no import cycle, and modules stay small."""
from __future__ import annotations

import ast
import pathlib

PKG = pathlib.Path(__file__).resolve().parents[1] / "bayescal"

#: What each subpackage may import (besides itself and the top-level modules every layer
#: may import: bayescal.version, bayescal.errors, bayescal.atomic).
ALLOWED = {
    "result": set(),
    "core": {"result"},
    "io": {"core", "result"},
    "criticism": {"core", "result"},
    "pair": {"core", "io", "criticism", "result"},
    "simulate": {"core", "io", "pair"},
    "coil": {"core", "io"},
    "report": {"core", "io", "criticism", "coil", "result"},
    "network": {"core", "io", "criticism", "report", "pair", "result"},
    "record": {"core", "io", "pair", "report", "result"},
    "cli": {"core", "io", "criticism", "coil", "report", "network", "simulate", "pair",
            "record", "result"},
}
#: Top-level modules every layer may import: leaves that import nothing of bayescal.
LEAVES = ("version", "errors", "atomic")
MAX_LINES = 520

#: What each group of bayescal.core may import of the core (besides itself
#: and the core's top-level modules, e.g. core.threads): the order data flow
#: through them. A new likelihood term goes in model, a new emcee move in
#: sampling; reading a result (posterior) needs no model.
CORE_ALLOWED = {
    "orientation": set(),
    "response": set(),
    "spectra": set(),
    "checks": {"orientation", "response", "spectra", "model"},
    "model": {"orientation", "response", "spectra"},
    "posterior": {"orientation", "response", "checks"},
    "sampling": {"posterior"},
    "fit": {"orientation", "response", "spectra", "model", "checks", "sampling", "posterior"},
    "selfnoise": {"spectra"},
}


def _module_name(path):
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path):
    """Every bayescal module imported by ``path`` (lazy imports included)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.split(".")[0] != "bayescal":
                continue
            for alias in node.names:   # "from . import effects" imports a module
                sub = f"{mod}.{alias.name}"
                out.add(sub if _exists(sub) else mod)
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == "bayescal"}
        elif isinstance(node, ast.Call):
            out |= _called_imports(node, package)
    return out


def _called_imports(call, package):
    """The bayescal modules a call imports: the targets of a lazy face
    (``lazy_loader.attach(__name__, submod_attrs={"welch": [...]})``, keys
    relative to the package) and ``importlib.import_module("bayescal...")``."""
    func = call.func
    name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
    if name == "attach":
        attrs = [k.value for k in call.keywords if k.arg == "submod_attrs"]
        attrs += call.args[2:3]
        return {f"{package}.{key.value}" for d in attrs if isinstance(d, ast.Dict)
                for key in d.keys if isinstance(key, ast.Constant)}
    if name == "import_module" and call.args and isinstance(call.args[0], ast.Constant):
        target = call.args[0].value
        if isinstance(target, str) and target.split(".")[0] == "bayescal":
            return {target}
    return set()


def _exists(module):
    p = PKG.parent.joinpath(*module.split("."))
    return p.with_suffix(".py").exists() or (p / "__init__.py").exists()


def _graph():
    return {_module_name(p): _imports(p) for p in PKG.rglob("*.py")}


def test_imports_point_down_the_layers():
    bad = []
    for mod, deps in _graph().items():
        parts = mod.split(".")
        if len(parts) < 2 or parts[1] not in ALLOWED:
            continue
        layer = parts[1]
        for dep in deps:
            dparts = dep.split(".")
            target = dparts[1] if len(dparts) > 1 else "bayescal"
            if target == layer or target in LEAVES or target in ALLOWED[layer]:
                continue
            bad.append(f"{mod} imports {dep}")
    assert not bad, "upward imports:\n" + "\n".join(sorted(bad))


def test_core_groups_import_down_their_order():
    bad = []
    for mod, deps in _graph().items():
        parts = mod.split(".")
        if parts[:2] != ["bayescal", "core"] or len(parts) < 3:
            continue
        if parts[2] not in CORE_ALLOWED:
            assert (PKG / "core" / f"{parts[2]}.py").exists(), f"{mod}: a group without rules"
            continue
        for dep in deps:
            d = dep.split(".")
            if d[:2] != ["bayescal", "core"] or len(d) < 3 or d[2] == parts[2]:
                continue
            if (PKG / "core" / f"{d[2]}.py").exists() or d[2] in CORE_ALLOWED[parts[2]]:
                continue
            bad.append(f"{mod} imports {dep}")
    assert not bad, "imports against the core's order:\n" + "\n".join(sorted(bad))


def test_core_group_docstrings_state_their_imports():
    """Each core group's docstring says what of the core it may import, as
    :data:`CORE_ALLOWED` has it."""
    bad = []
    for group, allowed in CORE_ALLOWED.items():
        doc = ast.get_docstring(ast.parse((PKG / "core" / group / "__init__.py").read_text()))
        if not allowed and "Imports no other part of :mod:`bayescal.core`" not in doc:
            bad.append(f"core.{group} does not say it imports no other group")
        bad += [f"core.{group} does not name core.{a}" for a in sorted(allowed)
                if f":mod:`bayescal.core.{a}`" not in doc]
    assert not bad, "\n".join(bad)


def test_each_package_docstring_names_its_modules():
    """Every package's ``__init__`` docstring names each of its modules and
    subpackages (as ``:mod:`.name```), and names nothing that is not there."""
    import re

    bad = []
    for init in PKG.rglob("__init__.py"):
        here = init.parent
        held = {p.stem for p in here.glob("*.py") if p.name not in ("__init__.py", "__main__.py")}
        held |= {p.name for p in here.iterdir() if (p / "__init__.py").exists()}
        doc = ast.get_docstring(ast.parse(init.read_text())) or ""
        named = set(re.findall(r":mod:`\.(\w+)`", doc))
        if here == PKG:
            continue             # the top level names its layers in prose
        bad += [f"{_module_name(init)} does not name {m}" for m in sorted(held - named)]
        bad += [f"{_module_name(init)} names {m}, which it does not hold"
                for m in sorted(named - held)]
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    graph = _graph()
    state, cycles = {}, []

    def visit(node, stack):
        state[node] = 1
        for dep in graph.get(node, ()):
            if dep == node or dep not in graph:
                continue
            if state.get(dep) == 1 and not node.startswith(dep + "."):
                cycles.append(" -> ".join(stack[stack.index(dep):] + [dep]))
            elif not state.get(dep):
                visit(dep, stack + [dep])
        state[node] = 2

    for mod in graph:
        # a package's __init__ re-exporting its own modules is not a cycle
        if not state.get(mod):
            visit(mod, [mod])
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def test_modules_stay_small():
    big = {_module_name(p): n for p in PKG.rglob("*.py")
           if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not big, f"modules over {MAX_LINES} lines: {big}"


def test_public_api_as_the_readme_shows():
    import bayescal
    for name in ("calibrate", "calibrate_files", "write_results", "Posterior", "simulate_pair"):
        assert callable(getattr(bayescal, name))
    from bayescal import errors, io
    for name in ("paz_inventory", "two_pole_inventory", "flat_inventory"):
        assert hasattr(io, name)
    assert bayescal.InputError is errors.InputError


def test_fit_path_does_not_import_heavy_modules():
    """Start-up: importing the modules a pair fit runs through, or those that
    read and report a result, loads neither scipy.stats (about 1 s),
    matplotlib, Dask nor emcee: emcee (which imports scipy.stats) is
    imported when sampling starts (bayescal.core.sampling.mcmc), by commands that
    sample."""
    import subprocess
    import sys

    code = ("import sys; import bayescal.cli.fit, bayescal.pair.workflow, bayescal.core.fit.run, "
            "bayescal.core.fit.modes, bayescal.core.model.eiv, bayescal.core.checks.separation, "
            "bayescal.core.selfnoise.pair_noise, bayescal.core.posterior.convergence, bayescal.core.posterior.samples; print(sorted(m for m in ('scipy.stats', 'matplotlib', "
            "'dask', 'emcee') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=str(PKG.parent), check=True).stdout.strip()
    assert out == "[]"


def test_reading_a_result_is_light(tmp_path):
    """``import bayescal; bayescal.load_posterior(folder)`` loads at most 8
    bayescal modules (package ``__init__`` modules included) and none of
    scipy.stats, scipy.special, emcee, matplotlib or ObsPy: a result is read
    by :mod:`bayescal.result` alone, its summaries as result.json holds
    them."""
    import json
    import subprocess
    import sys

    import numpy as np

    rng = np.random.default_rng(1)
    folder = tmp_path / "fit"
    folder.mkdir()
    vectors = rng.normal(size=(50, 1, 3))
    conv = {"tau": [1.0], "ess": [50.0], "rhat": [1.0], "acceptance": 0.5, "n_steps": 10,
            "n_walkers": 4, "burn": 2, "converged": True}
    np.savez(folder / "samples.npz", samples=rng.normal(size=(50, 2)), log_prob=np.zeros(50),
             vectors=vectors, extra=json.dumps({"channel_ids": ["XX.S.00.BHZ"],
                                                "kinds": ["sphere"], "names": ["a", "b"],
                                                "convergence": conv}))
    (folder / "result.json").write_text(json.dumps(
        {"schema": "bayescal.fit/1", "channels": {"XX.S.00.BHZ": {"kind": "sphere"}},
         "convergence": {}, "meta": {"band_hz": [0.1, 1.0]}}))
    code = ("import sys, bayescal; from bayescal import load_posterior; "
            f"r = load_posterior({str(folder)!r}); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'bayescal')); "
            "print(sorted(m for m in ('scipy.stats', 'scipy.special', 'emcee', 'matplotlib', "
            "'obspy') if m in sys.modules)); print(r.meta.band_hz[1], r.convergence.n_steps)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=str(PKG.parent), check=True).stdout.strip().splitlines()
    loaded = eval(out[0])                              # noqa: S307 - our own printout
    assert len(loaded) <= 8, loaded
    assert out[1] == "[]"
    assert out[2] == "1.0 10"


def test_no_private_name_imported_from_another_module():
    """A name with a leading underscore is its module's own: no module of
    bayescal imports one from another (``from .x import _y``), nor reaches
    one through an imported module (``x._y``)."""
    bad = []
    for path in PKG.rglob("*.py"):
        tree = ast.parse(path.read_text())
        modules = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                bad += [f"{_module_name(path)}:{node.lineno} imports {a.name}" for a in node.names
                        if a.name.startswith("_") and not a.name.startswith("__")]
                modules |= {a.asname or a.name for a in node.names}
            elif isinstance(node, ast.Import):
                modules |= {a.asname or a.name.split(".")[0] for a in node.names}
        bad += [f"{_module_name(path)}:{node.lineno} uses {node.value.id}.{node.attr}"
                for node in ast.walk(tree)
                if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                and node.value.id in modules and node.attr.startswith("_")
                and not node.attr.startswith("__")]
    assert not bad, "private names used across modules:\n" + "\n".join(sorted(bad))


MAX_FUNCTION_LINES = 60
MAX_POSITIONAL = 8

#: Functions allowed over :data:`MAX_FUNCTION_LINES` lines or
#: :data:`MAX_POSITIONAL` positional parameters: none, and none may be added
#: (:func:`test_allow_lists_do_not_grow`).
LONG_FUNCTIONS_ALLOWED = {}


def _functions():
    """``(name, lines, positional)`` of every function, method and lambda of
    the package, ``name`` as ``module:qualname`` (module without ``bayescal.``),
    ``positional`` not counting a leading ``self`` or ``cls``."""
    out = []

    def walk(node, prefix, module):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                args = [a.arg for a in child.args.posonlyargs + child.args.args]
                if args[:1] in (["self"], ["cls"]):
                    args = args[1:]
                name = prefix + child.name
                out.append((f"{module}:{name}", child.end_lineno - child.lineno + 1, len(args)))
                walk(child, name + ".<locals>.", module)
            elif isinstance(child, ast.Lambda):
                args = child.args.posonlyargs + child.args.args
                name = prefix + "<lambda>"
                out.append((f"{module}:{name}", child.end_lineno - child.lineno + 1, len(args)))
                walk(child, name + ".<locals>.", module)
            elif isinstance(child, ast.ClassDef):
                walk(child, prefix + child.name + ".", module)
            else:
                walk(child, prefix, module)

    for path in sorted(PKG.rglob("*.py")):
        walk(ast.parse(path.read_text()), "", _module_name(path).removeprefix("bayescal."))
    return out


def _exceeds(lines, positional):
    return lines > MAX_FUNCTION_LINES or positional > MAX_POSITIONAL


def test_functions_stay_short():
    """No function is over :data:`MAX_FUNCTION_LINES` lines (``def`` to its
    last line) or takes over :data:`MAX_POSITIONAL` positional parameters
    (options after ``*`` are keyword-only and not counted), unless
    :data:`LONG_FUNCTIONS_ALLOWED` names it."""
    bad = [f"{name}: {lines} lines, {positional} positional"
           for name, lines, positional in _functions()
           if _exceeds(lines, positional) and name not in LONG_FUNCTIONS_ALLOWED]
    assert not bad, "functions too long to hold in mind:\n" + "\n".join(bad)


def test_allowed_long_functions_still_exceed():
    """Every entry of :data:`LONG_FUNCTIONS_ALLOWED` is a function that is
    still over a limit: one brought within them leaves the list."""
    over = {name for name, lines, positional in _functions() if _exceeds(lines, positional)}
    stale = sorted(set(LONG_FUNCTIONS_ALLOWED) - over)
    assert not stale, "allowed but within the limits (remove them):\n" + "\n".join(stale)


#: Reads of another object's private attribute that cannot be avoided:
#: (module, "value.attr") -> why. None are left; the list only shrinks
#: (:func:`test_allow_lists_do_not_grow`).
PRIVATE_READS_ALLOWED = {}


def private_reads(source):
    """``(line, "value.attr")`` of every attribute with one leading underscore
    read or set on something other than the object itself, a class of the
    same module, or an imported module (that case is
    :func:`test_no_private_name_imported_from_another_module`'s):
    ``value._name``, ``getattr(value, "_name")`` (``setattr``, ``hasattr``)
    and ``vars(value)["_name"]``. The object itself is the first parameter of
    a method when it is named ``self`` or ``cls`` (in the method and the
    functions it holds), ``type(self)`` and ``super()``."""
    tree = ast.parse(source)
    shared = {n.name for n in ast.walk(tree) if isinstance(n, ast.ClassDef)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            shared |= {a.asname or a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            shared |= {a.asname or a.name for a in node.names}
    out = []

    def own(value, selves):
        if isinstance(value, ast.Name):
            return value.id in shared or value.id in selves
        if isinstance(value, ast.Call) and isinstance(value.func, ast.Name):
            return value.func.id == "super" or (
                value.func.id == "type" and len(value.args) == 1
                and isinstance(value.args[0], ast.Name) and value.args[0].id in selves)
        return False

    def check(node, selves):
        read = None
        if isinstance(node, ast.Attribute):
            read = node.value, node.attr
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id in ("getattr", "setattr", "hasattr") and len(node.args) > 1
              and isinstance(node.args[1], ast.Constant)):
            read = node.args[0], node.args[1].value
        elif (isinstance(node, ast.Subscript) and isinstance(node.value, ast.Call)
              and isinstance(node.value.func, ast.Name) and node.value.func.id == "vars"
              and node.value.args and isinstance(node.slice, ast.Constant)):
            read = node.value.args[0], node.slice.value
        if (read and isinstance(read[1], str) and read[1].startswith("_")
                and not read[1].startswith("__") and not own(read[0], selves)):
            out.append((node.lineno, f"{ast.unparse(read[0])}.{read[1]}"))

    def visit(node, selves):
        check(node, selves)
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                a = child.args
                params = [x.arg for x in a.posonlyargs + a.args]
                inner = selves - set(params) - {x.arg for x in a.kwonlyargs}
                if (isinstance(node, ast.ClassDef) and not isinstance(child, ast.Lambda)
                        and params[:1] in (["self"], ["cls"])):
                    inner |= {params[0]}
                visit(child, inner)
            else:
                visit(child, selves)

    visit(tree, frozenset())
    return sorted(out)


def test_no_private_attribute_of_another_object_is_read():
    """An object's ``_name`` is its own: no module of bayescal reads or sets
    one on another object (a model's arrays are reached through its public
    attributes and methods), except :data:`PRIVATE_READS_ALLOWED`."""
    made = {(_module_name(p), what) for p in PKG.rglob("*.py")
            for _, what in private_reads(p.read_text())}
    bad = [f"{_module_name(p)}:{line} reads {what}" for p in PKG.rglob("*.py")
           for line, what in private_reads(p.read_text())
           if (_module_name(p), what) not in PRIVATE_READS_ALLOWED]
    assert not bad, "private attributes of other objects:\n" + "\n".join(sorted(bad))
    stale = sorted(set(PRIVATE_READS_ALLOWED) - made)
    assert not stale, f"no longer made (remove): {stale}"


def test_private_read_rule_sees_a_reintroduced_read():
    """The rule catches a model's private array read from outside (a
    report reading the coil model's arrays), by attribute, by ``getattr``/``setattr``/
    ``hasattr`` with a literal name and by ``vars``, and a ``cls`` that is
    not a method's first parameter; it passes the object's own reads."""
    src = ("from . import likelihood\n"
           "class M:\n"
           "    def f(self):\n"
           "        return self._saa, type(self)._g, M._h, likelihood.X, lambda: self._k\n"
           "    @classmethod\n"
           "    def c(cls):\n"
           "        return cls._a, getattr(cls, '_b')\n"
           "def g(model):\n"
           "    return model._saa_b, model.spectra._x\n"
           "def h(model, cls):\n"
           "    setattr(model, '_y', 1)\n"
           "    return getattr(model, '_z'), hasattr(model, '_w'), vars(model)['_v'], cls._u\n"
           "def k(other):\n"
           "    return type(other)._t\n")
    assert private_reads(src) == [(9, "model._saa_b"), (9, "model.spectra._x"),
                                  (11, "model._y"), (12, "cls._u"), (12, "model._v"),
                                  (12, "model._w"), (12, "model._z"), (14, "type(other)._t")]


#: Run in a fresh interpreter: every module of the package imported, the
#: exception and warning classes it defines (``__module__`` its own) listed.
_EXCEPTIONS = ("import importlib, json, pkgutil, bayescal\n"
               "bad = []\n"
               "for info in pkgutil.walk_packages(bayescal.__path__, 'bayescal.'):\n"
               "    if info.name.endswith('__main__') or info.name == 'bayescal.errors':\n"
               "        continue\n"
               "    mod = importlib.import_module(info.name)\n"
               "    bad += [f'{info.name} defines {n}' for n, v in vars(mod).items()\n"
               "            if isinstance(v, type) and issubclass(v, BaseException)\n"
               "            and v.__module__ == info.name]\n"
               "print(json.dumps(bad))\n")


def test_exceptions_and_warnings_live_in_errors():
    """Every exception and warning class of the package is defined in
    ``bayescal/errors.py``: importing each other module of the package, none
    defines a subclass of ``BaseException`` (whatever its base is called)."""
    import json
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", _EXCEPTIONS], capture_output=True, text=True,
                         cwd=str(PKG.parent), check=True).stdout
    bad = json.loads(out)
    assert not bad, "exceptions or warnings outside bayescal.errors:\n" + "\n".join(bad)


#: Imports of a core group's module from outside the core still made. This
#: list only shrinks (:func:`test_allow_lists_do_not_grow`).
DEEP_ALLOWED = set()


def test_core_is_imported_through_its_faces():
    """Outside bayescal.core, the core is imported from the face of a group
    (``from ..core.spectra import cross_spectra``) or of the core itself and
    its top-level modules (``from ..core import Priors``), never from a
    group's modules (``bayescal.core.<group>.<module>``), besides
    :data:`DEEP_ALLOWED`."""
    made, bad = set(), []
    for mod, deps in _graph().items():
        if mod == "bayescal.core" or mod.startswith("bayescal.core."):
            continue
        for dep in deps:
            d = dep.split(".")
            if d[:2] == ["bayescal", "core"] and len(d) > 3:
                made.add((mod, dep))
                if (mod, dep) not in DEEP_ALLOWED:
                    bad.append(f"{mod} imports {dep}")
    assert not bad, "imports into a core group's modules:\n" + "\n".join(sorted(bad))
    assert not DEEP_ALLOWED - made, f"no longer made (remove): {sorted(DEEP_ALLOWED - made)}"


#: The most entries each allow-list may hold. A cap only goes down: lower it
#: when an entry leaves its list, never raise it.
DEEP_ALLOWED_CAP = 0
PRIVATE_READS_ALLOWED_CAP = 0


def test_allow_lists_do_not_grow():
    """No function is allowed over the limits, and the lists of deep imports
    and private reads hold no more than their caps."""
    assert not LONG_FUNCTIONS_ALLOWED
    assert len(DEEP_ALLOWED) <= DEEP_ALLOWED_CAP
    assert len(PRIVATE_READS_ALLOWED) <= PRIVATE_READS_ALLOWED_CAP


def test_import_rules_see_lazy_faces_and_import_module():
    """The import graph holds a lazy face's targets (resolved against its
    package) and a literal ``importlib.import_module("bayescal...")``."""
    tree = ast.parse("__getattr__, __dir__, __all__ = lazy_loader.attach(\n"
                     "    __name__, submod_attrs={'welch': ['hann'], 'x.y': ['z']})\n"
                     "importlib.import_module('bayescal.report.fit')\n"
                     "importlib.import_module('numpy')\n")
    found = set().union(*(_called_imports(n, "bayescal.core.spectra")
                          for n in ast.walk(tree) if isinstance(n, ast.Call)))
    assert found == {"bayescal.core.spectra.welch", "bayescal.core.spectra.x.y",
                     "bayescal.report.fit"}
