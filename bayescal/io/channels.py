"""Choosing each sensor's channels: SEED-id patterns (``XX.SIM.10.BH?``)
select the traces of one sensor from files that hold several, and the two
sides may not share a channel (the same file given as ``--ref`` and
``--sut`` would fit a sensor against itself)."""
from __future__ import annotations

from fnmatch import fnmatchcase

from ..errors import InputError


def _files(stream):
    return sorted({getattr(tr.stats, "bayescal_source", tr.id) for tr in stream})


def select_channels(stream, patterns, side="SUT"):
    """The traces of ``stream`` whose SEED id (NET.STA.LOC.CHA) matches one
    of ``patterns`` (shell wildcards ``*``, ``?``, ``[..]``; case-insensitive).
    ``patterns`` None or empty keeps every trace. Raises :class:`InputError`
    naming the files and the ids they hold when nothing matches."""
    if not patterns:
        return stream
    if isinstance(patterns, str):
        patterns = [patterns]
    pats = [p.upper() for p in patterns]
    kept = type(stream)(
        [tr for tr in stream if any(fnmatchcase(tr.id.upper(), p) for p in pats)])
    if len(kept) == 0:
        ids = sorted({tr.id for tr in stream})
        raise InputError(f"{', '.join(_files(stream))}: no {side} channel matches "
                         f"{' '.join(patterns)} (the files hold {', '.join(ids)})")
    return kept


def check_distinct(sut, ref):
    """Refuse a pair whose sides share a channel (a sensor fitted against
    itself gives a singular problem, not a calibration)."""
    shared = sorted({tr.id for tr in sut} & {tr.id for tr in ref})
    if not shared:
        return
    files = sorted(set(_files(sut)) | set(_files(ref)))
    same = set(_files(sut)) & set(_files(ref))
    why = (f"{', '.join(sorted(same))} is given as both reference and SUT" if same
           else f"{', '.join(files)}: reference and SUT share channels")
    raise InputError(f"{why} (channels {', '.join(shared)}); a sensor cannot be calibrated "
                     "against itself: choose each sensor's channels with --ref-id/--sut-id "
                     "(e.g. --ref-id 'XX.SIM.00.*' --sut-id 'XX.SIM.10.*')")
