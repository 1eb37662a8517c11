"""The whole chain in one call: recordings -> spectra -> posterior.

From files (any waveform format ObsPy reads, StationXML), the same as
``bayescal fit``::

    >>> from bayescal.io.pipeline import calibrate_files, write_results
    >>> post = calibrate_files(ref="ref.mseed", ref_xml="ref.xml", sut="sut.mseed",
    ...                        sut_xml="sut.xml", band=(0.05, 1))
    >>> write_results(post, "out")   # result.json, samples.npz, diagnostics.npz, sut_corrected.xml

From ObsPy objects::

    >>> post = bayescal.calibrate(ref=ref_stream, ref_xml=ref_inventory, sut=sut_stream,
    ...                           sut_xml=sut_inventory, band=(0.05, 1.0), fit_response="gain")
"""
from __future__ import annotations

import numpy as np

from ..core.fit import fit_spectra, judge_reported_response
from .channels import check_distinct, select_channels
from ..errors import InputError, SpectraError
from .read import flat_inventory, read_metadata, read_waveforms
from .align import align
from ..core.priors import Priors
from ..core.spectra import cross_spectra, find as find_transients, summary as transient_summary
from ..core.checks.record_length import record_length
from ..core.response import reference_tolerance


def _describe_files(side):
    files = sorted(set(side.sources)) or [side.source]
    return ", ".join(files)


#: How :func:`calibrate` and :func:`calibrate_files` take their data.
KEYWORDS = "ref=..., ref_xml=..., sut=..., sut_xml=..."


def _keywords_only(name, args):
    if args:
        raise TypeError(f"{name}() takes its data as keywords, named as bayescal fit's "
                        f"options: {name}({KEYWORDS}) (the reference first; positional "
                        "arguments are refused so that the two sensors cannot be swapped)")


def calibrate(*args, ref=None, ref_xml=None, sut=None, sut_xml=None, band=None,
              fit_response="gain", seed=0, priors=Priors(), nperseg=None, start=None, end=None,
              progress=True, sut_source="SUT", ref_source="reference", ref_noise=None,
              ref_noise_psd=None, diagnose=True, diagnose_budget_s=60.0, transients="drop",
              **sample_kw):
    """Posterior over the SUT's orientation (and response) from co-located
    recordings: what ``bayescal fit`` computes, from ObsPy objects.

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
        (fmin, fmax) in Hz; None chooses it from the data where the two
        sensors are coherent (:func:`bayescal.io.band.choose_band`); the band
        used is in ``posterior.meta["band_hz"]`` and how it was chosen in
        ``posterior.meta["band_choice"]``.
    fit_response : {"gain", "none", "all"}
        "gain" (the default: angles and each SUT channel's gain, reported
        also as a relative gain, fitted / metadata, which is what a
        relative-gain experiment measures; works with ``flat`` metadata too),
        "all" (period, damping and gain per channel; needs a poles-and-zeros
        first stage) or "none" (angles only, gains held at their metadata
        values). With a one-channel horizontal reference the gains are held
        whatever is asked short of "all" (see :mod:`bayescal.core.fit.rotation`).
    seed : int
        Random seed (results are reproducible).
    ref_noise : {None, "estimate", "quiet", "equal"}
        How the reference's own self-noise is treated: "quiet" (negligible
        next to the SUT's), "estimate" (estimated from the data: white in
        ground units plus white in its counts) or "equal" (the same as the
        SUT's in ground units); None (the default): "estimate" with two or
        more channels on each side (unbiased whatever the split of noise),
        "quiet" otherwise (a one-channel pair cannot separate the
        reference's noise); see :mod:`bayescal.core.model.refnoise`. The mode used
        is in ``posterior.meta["reference_noise"]``.
    ref_noise_psd : str, dict or None
        The reference's self-noise as known (mode "fixed"): a file path or
        :func:`bayescal.io.refnoise_file.read_reference_noise`'s table
        (``bayescal noise``'s noise.json from a third co-located sensor, or a
        period / dB text file): the remedy for a one-channel pair.
    start, end : obspy.UTCDateTime or None
        Limits of the analysis window.
    priors : bayescal.core.model.likelihood.Priors
        The priors; with ``fit_response="all"`` its ``period_tolerance`` and
        ``damping_tolerance`` (relative standard deviations of the log-normal
        priors on period and damping, default 0.05) are the manufacturer's
        tolerance (:mod:`bayescal.core.response.pendulum`); its
        ``reference_tolerance`` (default 0: the reference's metadata taken as
        exact) the relative standard deviation of the reference's gain,
        period and damping, carried into the SUT's response intervals
        (:mod:`bayescal.core.response.reference_tolerance`).
    diagnose : bool
        When the model check fails, criticise the fit (True, the default):
        find what the model leaves out, model it from the fit's own
        spectra and least-squares point, and give a verdict
        (``posterior.criticism``, result.json's ``criticism``; the improved
        model's posterior is ``posterior.improved``); see
        :mod:`bayescal.criticism.verdict`. False skips it (as ``bayescal
        fit --no-diagnose``).
    diagnose_budget_s : float
        The criticism's work budget, stated in seconds: each stands for
        :data:`bayescal.criticism.verdict.WORK_PER_SECOND` model
        evaluations (about a second's work on a two-core computer), so the
        same seed names the same effects on any machine (checked between
        candidates; when it runs out the verdict is "unexplained" and says
        which candidates were tried). Ten times as many seconds of wall
        clock stop it as a safety net, and the criticism then says so.
    transients : {"drop", "keep"}
        "drop" (the default): Welch segments in which one sensor records
        noise the other does not, well beyond the minutes around them (a
        transient near one sensor), are left out of the fit
        (:mod:`bayescal.core.spectra.transients`; how many and when in
        ``posterior.meta["data_used"]["transients"]``); "keep" fits every
        segment (as ``bayescal fit --keep-transients``).

    Returns
    -------
    Posterior
        Samples, their summary (``.summary()``, the content of
        ``result.json``) and what was run (``.meta``).

    Warns
    -----
    ModelMisfitWarning
        When the model check fails (:mod:`bayescal.core.checks.adequacy`).
    NotConvergedWarning
        When the sampler stopped before meeting its convergence rule.
    """
    _keywords_only("calibrate", args)
    if any(x is None for x in (ref, ref_xml, sut, sut_xml)):
        raise TypeError(f"calibrate() needs {KEYWORDS}")
    if transients not in ("drop", "keep"):
        raise ValueError(f"transients must be 'drop' or 'keep', not {transients!r}")
    sut_inventory = load_inventory(sut_xml, sut, "SUT StationXML")
    ref_inventory = load_inventory(ref_xml, ref, "reference StationXML")
    fit_response = {None: "gain", False: "none", True: "all"}.get(fit_response, fit_response)
    check_distinct(sut, ref)
    s, r, fs, t0 = align(sut, sut_inventory, ref, ref_inventory, sut_source=sut_source,
                         ref_source=ref_source, start=start, end=end)
    files = f"{_describe_files(s)} vs {_describe_files(r)}: "
    try:
        if band is None:
            from .band import choose_band
            choice = choose_band(s, r, fs, source=files)
            band, band_note = choice.band, choice.describe()
        else:
            band_note = "band given by the user"
        spectra = cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), band,
                                nperseg=nperseg, sut_ids=s.ids, ref_ids=r.ids)
    except SpectraError as exc:
        raise InputError(f"{files}{exc}") from None
    from .band import MIN_COHERENCE, coherence_gate
    low = coherence_gate(spectra, s, r, files)
    families = s.families()
    keep = [i for i, cid in enumerate(s.ids) if cid not in low]
    dropped = None
    if transients == "drop":
        found = find_transients(spectra.select(keep) if low else spectra)
        if found.count:
            dropped = transient_summary(found, spectra, t0)
            try:
                spectra = cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(),
                                        band, nperseg=spectra.nperseg, sut_ids=s.ids,
                                        ref_ids=r.ids,
                                        exclude=spectra.segment_starts[found.dropped])
            except SpectraError as exc:
                raise InputError(f"{files}{exc}") from None
    nominal = {cid: {"azimuth_deg": az, "dip_deg": dip,
                     **({} if fam is None else {k: v for k, v in (
                         ("period_s", fam.period_s), ("damping", fam.damping), ("gain", fam.gain),
                         ("gain_units", fam.gain_units)) if not isinstance(v, float)
                         or np.isfinite(v)})}
               for cid, az, dip, fam in zip(s.ids, s.azimuths, s.dips, families)}
    used_s = (spectra.n_segments * spectra.step + spectra.nperseg - spectra.step) / fs
    meta = {"nominal": nominal, "reference": {cid: {"azimuth_deg": az, "dip_deg": dip}
                                              for cid, az, dip in zip(r.ids, r.azimuths, r.dips)},
            "starttime": str(t0), "sampling_rate": fs,
            "duration_s": s.data.shape[1] / fs,
            "data_used": {"segments": spectra.n_segments,
                          "segments_possible": spectra.n_segments_possible,
                          "fraction": spectra.fraction_used,
                          "approx_seconds": min(used_s, s.data.shape[1] / fs),
                          "note": "segments touching a gap, an overlap with conflicting data "
                                  "or a clipped sample are dropped, and so are those within two "
                                  "periods of the band's lower edge from the ends of the record "
                                  "or of a gap (the deconvolution's transient)"},
            "record_length": record_length(min(used_s, s.data.shape[1] / fs),
                                           float(spectra.band_edges[0])),
            "band_choice": band_note,
            "placeholder_response": {"sut": placeholder_channels(sut_inventory, s.ids),
                                     "reference": placeholder_channels(ref_inventory, r.ids)},
            "files": {"sut": sorted(set(s.sources)), "reference": sorted(set(r.sources))}}
    if dropped:
        meta["data_used"]["transients"] = dropped
    fitted = spectra.select(keep) if low else spectra
    known = None
    if ref_noise_psd is not None:
        ref_noise, known, meta["reference_noise_input"] = _known_reference_noise(
            ref_noise_psd, ref_noise, fitted)
    post = fit_spectra(fitted, r.vectors, np.asarray(s.vectors)[keep],
                       [families[i] for i in keep], free=fit_response, priors=priors,
                       seed=seed, progress=progress, meta=meta, ref_noise=ref_noise,
                       known_noise=known, **sample_kw)
    if "reference_noise_input" in meta:
        post.meta["reference_noise"]["input"] = meta["reference_noise_input"]
    for cid, c in low.items():
        post.not_estimable[cid] = (f"no coherence with the reference in the band (mean multiple "
                                   f"coherence {c:.3f}, needed {MIN_COHERENCE:g})")
    from ..core.selfnoise import for_fit
    used = post.meta.get("reference_noise", {}).get("mode", ref_noise)
    post.self_noise, post.sensor_order = for_fit(post.model, post.full_samples,
                                                 used, fit_response, seed,
                                                 (spectra.sut_ids, spectra.ref_ids),
                                                 _assumed_flat(ref_inventory)
                                                 or (_assumed_flat(sut_inventory)
                                                     and fit_response == "none"),
                                                 _assumed_flat(sut_inventory),
                                                 "note" in post.meta.get("reference_noise", {})
                                                 .get("separation", {}))
    post.spectra = spectra
    post.sut_inventory = sut_inventory
    if diagnose:
        _criticise(post, diagnose_budget_s, seed, sample_kw)
    # after the criticism, which judges how far its improved model moves the
    # estimates on the data's own intervals (the reference's error moves both alike)
    for p in (post, post.improved):
        if p is not None:
            reference_tolerance.apply(p, np.asarray(s.vectors)[keep], r.vectors, r.families(),
                                      priors.reference_tolerance, seed)
    if priors.reference_tolerance:
        judge_reported_response(post)
    _warn_on_misfit(post)
    return post


def _criticise(post, budget_s, seed, sample_kw):
    """When the model check fails, the criticism of the fit (see
    :mod:`bayescal.criticism.verdict`), kept on ``post``."""
    from ..core.checks import from_diagnostics

    if post.model is None or post.theta_ls is None:
        return
    from ..criticism.verdict import check_orientation, criticise, failed
    ok = from_diagnostics(post.diagnostics).get("ok")
    if ok is None:
        return
    if ok:      # the orientation is fitted freely: a reversed channel fits, but say so
        post.criticism = check_orientation(post) or {}
        return
    try:
        c = criticise(post, budget_s=budget_s, seed=seed, **sample_kw)
    except Exception as exc:   # noqa: BLE001 - the fit's results stand without it
        post.criticism = failed(exc)
        return
    post.criticism = c.summary
    post.improved = c.improved


def _warn_on_misfit(post):
    """A failed model check as a Python warning (:class:`ModelMisfitWarning`),
    so a script sees it as the console does."""
    import warnings

    from ..errors import ModelMisfitWarning
    from ..core.checks import describe, from_diagnostics
    verdict = from_diagnostics(post.diagnostics)
    if verdict.get("ok") is False:
        c = post.criticism.get("verdict_text") if post.criticism else None
        warnings.warn(describe(verdict, next_step=c and f"Criticism: {c}."), ModelMisfitWarning,
                      stacklevel=3)


def _known_reference_noise(psd, ref_noise, spectra):
    """(mode "fixed", (B, n_r) band sums, a JSON-safe note) from ``psd``."""
    from ..core.model import band_sums_of_psd
    from .refnoise_file import for_channels, read_reference_noise

    if ref_noise not in (None, "fixed"):
        raise InputError(f"--ref-noise {ref_noise} and --ref-noise-psd both say how to treat the "
                         "reference's noise: give one")
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
    return "fixed", known, note


def _assumed_flat(inventory):
    """True when ``inventory`` is the invented flat response of ``flat``."""
    return any("assumed flat" in (c.value or "") for net in inventory for sta in net
               for ch in sta for c in ch.comments)


def placeholder_channels(inventory, ids):
    """The ids among ``ids`` whose metadata are bayescal placeholders
    (``flat``: their deconvolved spectra are counts, not ground units)."""
    out = []
    for cid in ids:
        net, sta, loc, cha = str(cid).split(".")
        chans = [c for n in inventory.select(network=net, station=sta, location=loc, channel=cha)
                 for s in n for c in s]
        if any(getattr(c, "subject", None) == "bayescal placeholder"
               for ch in chans for c in ch.comments):
            out.append(str(cid))
    return out


def load_inventory(spec, stream, side="StationXML"):
    """An Inventory from ``spec``: an ObsPy Inventory, a metadata file
    (StationXML, RESP, or GSE2 poles and zeros applied to every channel of
    ``stream``; see :func:`bayescal.io.read_metadata`), or
    the word ``"flat"`` (flat velocity response, orientations from the
    channel codes: N/1 north, E/2 east, Z/3 vertical; see
    :func:`bayescal.io.flat_inventory`)."""
    if spec is None:
        raise InputError(f"no {side} given")
    if hasattr(spec, "networks"):
        return spec
    if str(spec).lower() == "flat":
        return flat_inventory(stream)
    return read_metadata(spec, side, stream=stream)


def calibrate_files(*args, ref=None, ref_xml=None, sut=None, sut_xml=None, band=None,
                    fit_response="gain", seed=0, start=None, end=None, progress=True,
                    sut_id=None, ref_id=None, **kw):
    """:func:`calibrate` from file paths, keywords only as ``bayescal fit``'s
    options.

    Parameters
    ----------
    ref, sut : str or list of str
        One path or a list per side (any waveform format ObsPy reads).
    ref_xml, sut_xml : str or obspy.Inventory
        A StationXML, RESP or GSE2 poles-and-zeros path, an Inventory, or
        ``"flat"`` (see :func:`load_inventory`).
    start, end : str, obspy.UTCDateTime or None
        Limits of the analysis window (ISO strings accepted).
    sut_id, ref_id : str, list of str or None
        SEED-id patterns (``"XX.SIM.10.BH?"``) that choose each sensor's
        channels from files holding several (see
        :func:`bayescal.io.channels.select_channels`).
    **kw
        Every other keyword of :func:`calibrate` (``band``,
        ``fit_response``, ``seed``, ``ref_noise``, ...).

    Returns
    -------
    Posterior
        As :func:`calibrate` (its ``sut_inventory`` is what the corrected
        StationXML is written from).
    """
    from obspy import UTCDateTime

    _keywords_only("calibrate_files", args)
    if any(x is None for x in (ref, ref_xml, sut, sut_xml)):
        raise TypeError(f"calibrate_files() needs {KEYWORDS}")
    sut_files, ref_files = sut, ref
    sut = select_channels(read_waveforms(sut_files, "SUT waveform"), sut_id, "SUT")
    ref = select_channels(read_waveforms(ref_files, "reference waveform"), ref_id, "reference")
    sut_inv = load_inventory(sut_xml, sut, "SUT StationXML")
    ref_inv = load_inventory(ref_xml, ref, "reference StationXML")
    start = UTCDateTime(start) if start is not None else None
    end = UTCDateTime(end) if end is not None else None
    sut_name = sut_xml if isinstance(sut_xml, str) else "SUT StationXML"
    ref_name = ref_xml if isinstance(ref_xml, str) else "reference StationXML"
    return calibrate(ref=ref, ref_xml=ref_inv, sut=sut, sut_xml=sut_inv, band=band,
                     fit_response=fit_response,
                     seed=seed, start=start, end=end, progress=progress,
                     sut_source=str(sut_name), ref_source=str(ref_name), **kw)


def write_results(posterior, folder):
    """Write everything ``bayescal fit`` writes (without the report) into
    ``folder``.

    Parameters
    ----------
    posterior : Posterior
        From :func:`calibrate` or :func:`calibrate_files`.
    folder : str
        Output folder (created when missing).

    Returns
    -------
    list of str
        The paths written: ``result.json``, ``samples.npz``,
        ``diagnostics.npz`` and, when the posterior came from
        :func:`calibrate_files` or :func:`calibrate` (it holds a ``sut_inventory``),
        ``sut_corrected.xml``. Each file is written atomically.
    """
    import os

    from .result import save_posterior
    from .stationxml import write_corrected

    save_posterior(posterior, folder)
    names = ["result.json", "samples.npz"] + (["diagnostics.npz"] if posterior.diagnostics
                                              else [])
    inv = posterior.sut_inventory
    if inv is not None:
        crit = posterior.criticism or {}
        improved = posterior.improved
        use = improved if crit.get("stationxml") == "improved model" and improved else posterior
        write_corrected(inv, use, os.path.join(folder, "sut_corrected.xml"),
                        criticism=crit if use is improved else None)
        names.append("sut_corrected.xml")
    return [os.path.join(folder, n) for n in names]
