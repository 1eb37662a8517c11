"""The first step of a pair fit: recordings and metadata in, the spectra a
fit takes out (:class:`PairData`): channels aligned on one time grid, the
band chosen, cross-spectra, channels without coherence set aside, Welch
segments a transient spoils left out, and what a result records of them.

The band (``band``): (fmin, fmax) in Hz, or None to choose it from the data
where the two sensors are coherent (:func:`bayescal.io.band.choose_band`);
the band used is in ``result.meta.band_hz`` and how it was chosen in
``result.meta.band_choice``.

Transients (``transients``): "drop" (the default): Welch segments in which
one sensor records noise the other does not, well beyond the minutes around
them (a transient near one sensor), are left out of the fit
(:mod:`bayescal.core.spectra.transients`; how many and when in
``result.meta.data_used["transients"]``); "keep" fits every segment (as
``bayescal fit --keep-transients``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.checks import record_length_entry
from ..core.spectra import find as find_transients, summary as transient_summary
from ..core.spectra import cross_spectra
from ..errors import SpectraError
from ..io.align import align
from ..io.band import coherence_gate
from ..io.channels import check_distinct
from ..io.inventory import assumed_flat, load_inventory, placeholder_channels
from ..errors import InputError

#: What a result says of the segments a fit leaves out.
SEGMENT_NOTE = ("segments touching a gap, an overlap with conflicting data or a clipped sample "
                "are dropped, and so are those within two periods of the band's lower edge from "
                "the ends of the record or of a gap (the deconvolution's transient)")


@dataclass
class PairData:
    """Everything a pair fit starts from.

    ``spectra``: cross-spectra of every SUT channel against the reference;
    ``fitted``: the same for the channels coherent with the reference (the
    ones fitted); ``low``: channel id -> mean multiple coherence of those
    set aside. ``sut_vectors`` and ``families``: the fitted SUT channels'
    nominal axes and response families; ``ref_vectors``, ``ref_families``:
    the reference's. ``meta``: the facts a result records (nominal values,
    reference, start time, data used, band choice, files, ...).
    ``known_noise`` (B, n_r): the reference's self-noise given
    (``ref_noise_psd``), else None. ``ref_flat``, ``sut_flat``: the side's
    metadata are the assumed flat response.
    """

    spectra: object
    fitted: object
    low: dict
    sut_vectors: np.ndarray
    families: list
    ref_vectors: np.ndarray
    ref_families: list
    meta: dict
    sut_inventory: object = field(repr=False)
    ref_inventory: object = field(repr=False)
    known_noise: np.ndarray | None = None
    ref_flat: bool = False
    sut_flat: bool = False


def _describe_files(side):
    files = sorted(set(side.sources)) or [side.source]
    return ", ".join(files)


#: ``meta.band_choice`` of a band the user gave (``band``, ``--band``).
USER_BAND = "band given by the user"


def prepare(*, ref, ref_xml, sut, sut_xml, band=None, start=None, end=None, nperseg=None,
            transients="drop", sut_source="SUT", ref_source="reference", ref_noise_psd=None,
            label=None):
    """The :class:`PairData` of two co-located recordings.

    Parameters
    ----------
    ref, sut : obspy.Stream
        Recordings of the reference and of the sensor under test (keywords
        only, as ``--ref`` and ``--sut``).
    ref_xml, sut_xml : obspy.Inventory, str or "flat"
        Their metadata (azimuth, dip, response): an ObsPy ``Inventory``, a
        StationXML, RESP or GSE2 poles-and-zeros path, or ``"flat"`` (as
        ``--ref-xml`` and ``--sut-xml``).
    band : (float, float) or None
        (fmin, fmax) in Hz, or None: chosen from the data (module docstring).
    start, end, nperseg : obspy.UTCDateTime, obspy.UTCDateTime, int; or None
        Limits of the analysis window; samples per Welch segment (None: the default).
    transients : {"drop", "keep"}
        Leave out segments a transient spoils, or keep them (module docstring).
    sut_source, ref_source, label : str (label: or None)
        How messages name each side's metadata; a name the meta keeps (``batch_label``).
    ref_noise_psd : str, dict or None
        The reference's self-noise as known: a path (``bayescal noise``'s noise.json,
        a period / dB text file) or :func:`~bayescal.io.refnoise_file.read_reference_noise`'s table.

    Raises
    ------
    InputError
        When the recordings or metadata cannot be used (one line naming the
        files and the problem).
    """
    if transients not in ("drop", "keep"):
        raise ValueError(f"transients must be 'drop' or 'keep', not {transients!r}")
    sut_inventory, ref_inventory = _metadata(sut, sut_xml, ref, ref_xml)
    s, r, fs, t0 = align(sut, sut_inventory, ref, ref_inventory, sut_source=sut_source,
                         ref_source=ref_source, start=start, end=end)
    files = f"{_describe_files(s)} vs {_describe_files(r)}: "
    spectra, band, band_note = _spectra(s, r, fs, band, nperseg, files)
    low = coherence_gate(spectra, s, r, files)
    keep = [i for i, cid in enumerate(s.ids) if cid not in low]
    dropped = None
    if transients == "drop":
        nperseg = spectra.nperseg
        spectra, dropped = _drop_transients(
            spectra, keep if low else None, t0,
            redo=lambda exclude: _welch(s, r, fs, band, nperseg, files, exclude=exclude))
    meta = _facts(s, r, spectra, t0, fs, band_note, sut_inventory, ref_inventory,
                  transients=dropped, label=label)
    fitted = spectra.select(keep) if low else spectra
    families = s.families()
    known = None
    if ref_noise_psd is not None:
        known, meta["reference_noise_input"] = _known_reference_noise(ref_noise_psd, fitted)
    return PairData(spectra=spectra, fitted=fitted, low=low,
                    sut_vectors=np.asarray(s.vectors)[keep], families=[families[i] for i in keep],
                    ref_vectors=r.vectors, ref_families=r.families(), meta=meta,
                    sut_inventory=sut_inventory, ref_inventory=ref_inventory, known_noise=known,
                    ref_flat=assumed_flat(ref_inventory), sut_flat=assumed_flat(sut_inventory))


def _metadata(sut, sut_xml, ref, ref_xml):
    """Each side's Inventory (:func:`bayescal.io.inventory.load_inventory`),
    once the two sides are known to be different recordings."""
    sut_inventory = load_inventory(sut_xml, sut, "SUT StationXML")
    ref_inventory = load_inventory(ref_xml, ref, "reference StationXML")
    check_distinct(sut, ref)
    return sut_inventory, ref_inventory


def _drop_transients(spectra, keep, t0, redo):
    """(spectra, what was left out or None): the Welch segments in which one
    sensor records a transient the other does not
    (:mod:`bayescal.core.spectra.transients`, judged on the channels
    ``keep``, None: all) left out by ``redo(segment starts to exclude)``."""
    found = find_transients(spectra.select(keep) if keep is not None else spectra)
    if not found.count:
        return spectra, None
    return redo(spectra.segment_starts[found.dropped]), transient_summary(found, spectra, t0)


def _welch(s, r, fs, band, nperseg, files, exclude=None):
    """The cross-spectra of the aligned sides ``s`` and ``r`` in ``band``."""
    try:
        return cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), band,
                             nperseg=nperseg, sut_ids=s.ids, ref_ids=r.ids,
                             **({} if exclude is None else {"exclude": exclude}))
    except SpectraError as exc:
        raise InputError(f"{files}{exc}") from None


def _spectra(s, r, fs, band, nperseg, files):
    """(cross-spectra, band, how it was chosen): the band given, or chosen
    where the two sensors are coherent (:func:`bayescal.io.band.choose_band`)."""
    if band is None:
        from ..io.band import choose_band
        try:
            choice = choose_band(s, r, fs, source=files)
        except SpectraError as exc:
            raise InputError(f"{files}{exc}") from None
        band, band_note = choice.band, choice.describe()
    else:
        band_note = USER_BAND
    return _welch(s, r, fs, band, nperseg, files), band, band_note


def _nominal(s):
    """Channel id -> the SUT's metadata azimuth, dip and response values."""
    out = {}
    for cid, az, dip, fam in zip(s.ids, s.azimuths, s.dips, s.families()):
        response = {} if fam is None else {
            k: v for k, v in (("period_s", fam.period_s), ("damping", fam.damping),
                              ("gain", fam.gain), ("gain_units", fam.gain_units))
            if not isinstance(v, float) or np.isfinite(v)}
        out[cid] = {"azimuth_deg": az, "dip_deg": dip, **response}
    return out


def _facts(s, r, spectra, t0, fs, band_note, sut_inventory, ref_inventory, *, transients=None,
           label=None):
    """The meta entries a pair fit's result records of its data (with the
    segments left out for ``transients``, and the fit's ``label``)."""
    duration = s.data.shape[1] / fs
    used_s = (spectra.n_segments * spectra.step + spectra.nperseg - spectra.step) / fs
    return {"nominal": _nominal(s),
            "reference": {cid: {"azimuth_deg": az, "dip_deg": dip}
                          for cid, az, dip in zip(r.ids, r.azimuths, r.dips)},
            "starttime": str(t0), "sampling_rate": fs, "duration_s": duration,
            "data_used": {"segments": spectra.n_segments,
                          "segments_possible": spectra.n_segments_possible,
                          "fraction": spectra.fraction_used,
                          "approx_seconds": min(used_s, duration), "note": SEGMENT_NOTE,
                          **({"transients": transients} if transients else {})},
            "record_length": record_length_entry(min(used_s, duration),
                                                 float(spectra.band_edges[0])),
            "band_choice": band_note,
            "placeholder_response": {"sut": placeholder_channels(sut_inventory, s.ids),
                                     "reference": placeholder_channels(ref_inventory, r.ids)},
            "files": {"sut": sorted(set(s.sources)), "reference": sorted(set(r.sources))},
            **({"batch_label": label} if label is not None else {})}


def _known_reference_noise(psd, spectra):
    """((B, n_r) band sums of the reference's given self-noise, a JSON-safe
    note) from ``psd`` (a file path or a table)."""
    from ..core.model import band_sums_of_psd
    from ..io.refnoise_file import for_channels, read_reference_noise

    source = psd if isinstance(psd, str) else "ref_noise_psd"
    table = read_reference_noise(psd) if isinstance(psd, str) else psd
    curves = for_channels(table, spectra.ref_ids, source)
    known = np.stack([band_sums_of_psd(spectra, p, d) for _, p, d in curves], axis=1)
    lo, hi = 1.0 / spectra.band_edges[-1], 1.0 / spectra.band_edges[0]
    note = {"source": source, "curves": {cid: key for cid, (key, _, _) in
                                          zip(spectra.ref_ids, curves)}}
    short = [cid for cid, (_, p, _) in zip(spectra.ref_ids, curves)
             if p.min() > lo * 1.001 or p.max() < hi * 0.999]
    if short:
        note["extrapolated"] = (f"the given PSD does not span the band's periods {lo:.3g}-"
                                f"{hi:.3g} s for {', '.join(short)}: held at its end values")
    return known, note
