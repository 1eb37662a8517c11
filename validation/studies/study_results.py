"""Where a study's output goes.

The file named by a study's ``--out`` holds its summary: the tables, rates
and settings the docs quote, small and tracked. The per-run records (one
entry per seed) go beside it, ``<name>.runs.json``; they are not tracked
(``.gitignore``), and the command that wrote the summary writes them again.
A study that adds to earlier runs reads them back with :func:`read`.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

#: Keys holding per-run records, at any depth of a study's document.
RUN_KEYS = ("runs", "rows")


def runs_path(path):
    """The per-run file beside summary ``path``: ``<name>.runs.json``."""
    p = Path(path)
    return p.with_name(p.stem + ".runs.json")


def _plain(obj):
    """numpy values as JSON: arrays as lists, scalars as Python numbers."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def _has_runs(doc, keys):
    if isinstance(doc, dict):
        return any(k in keys or _has_runs(v, keys) for k, v in doc.items())
    if isinstance(doc, list):
        return any(_has_runs(v, keys) for v in doc)
    return False


def summary_of(doc, keys=RUN_KEYS):
    """``doc`` without its per-run records (``keys`` at any depth)."""
    if isinstance(doc, dict):
        return {k: summary_of(v, keys) for k, v in doc.items() if k not in keys}
    if isinstance(doc, list):
        return [summary_of(v, keys) for v in doc]
    return doc


def _dump(path, obj, indent):
    tmp = str(path) + ".tmp"
    with open(tmp, "w") as fh:
        json.dump(obj, fh, indent=indent, default=_plain)
        fh.write("\n")
    os.replace(tmp, path)


def write(path, doc, keys=RUN_KEYS, indent=1):
    """Write ``doc``'s summary to ``path`` and the whole of it, per-run
    records included, to :func:`runs_path` beside it."""
    os.makedirs(os.path.dirname(str(path)) or ".", exist_ok=True)
    summary = summary_of(doc, keys)
    if _has_runs(doc, keys):
        _dump(runs_path(path), doc, indent)
        summary["runs_file"] = runs_path(path).name + " (not tracked: written by the command)"
    _dump(path, summary, indent)


def checkpoint(path, doc, indent=1):
    """Write the whole of ``doc`` to ``<path>.partial`` while a long study
    runs (not tracked; :func:`done` removes it)."""
    os.makedirs(os.path.dirname(str(path)) or ".", exist_ok=True)
    _dump(str(path) + ".partial", doc, indent)


def done(path):
    """Remove the checkpoint of ``path`` once its summary is written."""
    partial = str(path) + ".partial"
    if os.path.exists(partial):
        os.remove(partial)


def read(path):
    """A study's whole document: the per-run file when it is there, else the
    summary (whose per-run records are then missing)."""
    raw = runs_path(path)
    with open(raw if raw.exists() else path) as fh:
        return json.load(fh)
