"""Writing files and output folders so that a reader never sees them half
written: a file is written under a temporary name beside it and renamed onto
its name when complete (a rename within one file system replaces the target
in one step); an output folder's files are written into a temporary folder
beside it and moved in when all are complete. On an error the temporary file
or folder is removed and what was there before is left as it was.

* :func:`atomic_path`, :func:`write_json` one file;
* :func:`staging` one output folder, published by :func:`publish` (files
  moved into a folder that may hold the user's own files: the previous run's
  files, listed in its :data:`MANIFEST`, are replaced), by
  :func:`replace_folder` (a folder bayescal owns, replaced as a whole) or by
  :func:`move_files` (files moved in, named stale ones removed, optionally
  listed in the folder's manifest by :func:`record_written`).
"""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
import uuid

#: The list of what bayescal wrote into an output folder (one name a line).
MANIFEST = ".bayescal-written"


@contextlib.contextmanager
def atomic_path(path):
    """A temporary path beside ``path`` to write to: renamed onto ``path``
    when the block ends without error, removed when it raises.

    The temporary name is hidden (a leading dot) and keeps ``path``'s
    extension, so writers that choose the format by the extension (numpy's
    ``savez``, matplotlib, Pillow) write the same file. The file takes the
    usual permissions of a new file, as ``open`` gives them.

    Examples
    --------
    >>> with atomic_path("out/samples.npz") as tmp:        # doctest: +SKIP
    ...     np.savez_compressed(tmp, x=x)
    """
    path = os.fspath(path)
    folder, name = os.path.split(path)
    stem, ext = os.path.splitext(name)
    tmp = os.path.join(folder, f".{stem}.tmp-{uuid.uuid4().hex[:8]}{ext}")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)
        raise


def write_json(path, obj, default=None):
    """Write ``obj`` as indented JSON to ``path`` atomically; ``default``
    converts what ``json`` cannot (as :func:`json.dump`'s)."""
    with atomic_path(path) as tmp, open(tmp, "w") as fh:
        json.dump(obj, fh, indent=2, default=default)


def _usual_permissions(folder):
    """Give ``folder`` the permissions ``mkdir`` would (``mkdtemp`` makes it private)."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(folder, 0o777 & ~umask)


def move_files(tmp, out, stale=(), record=False):
    """Move every entry of folder ``tmp`` into the existing folder ``out``
    (replacing one of the same name), after removing the names in ``stale``
    that ``tmp`` does not hold (what an earlier run wrote and this one does
    not). With ``record`` the names moved are added to ``out``'s
    :data:`MANIFEST` and the stale ones taken off it (:func:`record_written`),
    so a later run into ``out`` removes them. Returns the names moved."""
    names = sorted(os.listdir(tmp), key=lambda n: (n == MANIFEST, n))   # the list last
    removed = [old for old in stale if old not in names]
    for old in removed:
        _remove(os.path.join(out, old))
    for name in names:
        dest = os.path.join(out, name)
        if os.path.isdir(dest) and not os.path.islink(dest):
            shutil.rmtree(dest)
        os.replace(os.path.join(tmp, name), dest)
    if record:
        record_written(out, names, removed)
    return names


def record_written(out, names, removed=()):
    """Add ``names`` to the :data:`MANIFEST` of folder ``out`` (made when
    missing) and take ``removed`` off it: files written into an output
    folder after its run (a report drawn later) are then removed, as the
    run's own are, by the next run published there (:func:`publish`)."""
    listed = set(_previous_run(out)) - set(removed)
    listed |= {n for n in names if n != MANIFEST and os.sep not in n}
    with atomic_path(os.path.join(out, MANIFEST)) as tmp, open(tmp, "w") as fh:
        fh.write("".join(f"{n}\n" for n in sorted(listed)))


def _remove(path):
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path, ignore_errors=True)
    elif os.path.lexists(path):
        os.remove(path)


def publish(tmp, out):
    """Move the finished files from ``tmp`` into ``out``. A rerun into the
    same folder first removes what the previous run wrote there (the names
    in its :data:`MANIFEST`) and this run does not write again, so no file
    of an earlier run can be read as this one's; files bayescal did not
    write are left alone. The new manifest lists this run's files."""
    names = sorted(n for n in os.listdir(tmp) if n != MANIFEST)
    with open(os.path.join(tmp, MANIFEST), "w") as fh:
        fh.write("".join(f"{n}\n" for n in names))
    if not os.path.exists(out):
        _usual_permissions(tmp)
        os.replace(tmp, out)
        return
    move_files(tmp, out, stale=_previous_run(out))


def _previous_run(out):
    """Names the previous run listed in ``out``'s manifest (plain names
    only: nothing outside ``out``)."""
    try:
        with open(os.path.join(out, MANIFEST)) as fh:
            names = [ln.strip() for ln in fh]
    except OSError:
        return []
    return [n for n in names if n and n not in (".", "..", MANIFEST) and os.sep not in n
            and (os.altsep is None or os.altsep not in n)]


def replace_folder(tmp, out):
    """Put folder ``tmp`` in place of ``out`` as a whole: for a folder only
    bayescal writes, so a reader sees the old folder or the new one, never a
    mixture."""
    if os.path.exists(out):
        trash = f"{tmp}.old"
        os.replace(out, trash)
        shutil.rmtree(trash, ignore_errors=True)
    os.replace(tmp, out)


@contextlib.contextmanager
def staging(out, *, finish=publish, within=None):
    """A new hidden temporary folder to write the files of output folder
    ``out`` into. When the block ends without error ``finish(tmp, out)``
    moves them into ``out``; in every case the temporary folder is then
    removed, so on an error ``out`` is as it was.

    Parameters
    ----------
    out : the output folder.
    finish : how the files reach ``out``: :func:`publish` (the default),
        :func:`replace_folder`, or any callable ``(tmp, out)``.
    within : the folder to make the temporary one in (created if missing);
        default ``out``'s parent. It must be on ``out``'s file system, so that
        publishing is renaming.
    """
    out = os.fspath(out)
    parent = within or os.path.dirname(os.path.abspath(out))
    os.makedirs(parent, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix=f".{os.path.basename(out)}.tmp-", dir=parent)
    _usual_permissions(tmp)
    try:
        yield tmp
        finish(tmp, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
