"""A pair fit in one call: recordings -> spectra -> posterior -> result.

From files (any waveform format ObsPy reads, StationXML), the same as
``bayescal fit``::

    >>> from bayescal import calibrate_files, write_results
    >>> result = calibrate_files(ref="ref.mseed", ref_xml="ref.xml", sut="sut.mseed",
    ...                          sut_xml="sut.xml", band=(0.05, 1))
    >>> write_results(result, "out")   # result.json, samples.npz, diagnostics.npz, sut_corrected.xml

From ObsPy objects::

    >>> result = bayescal.calibrate(ref=ref_stream, ref_xml=ref_inventory, sut=sut_stream,
    ...                             sut_xml=sut_inventory, band=(0.05, 1.0), fit_response="gain")
"""
from __future__ import annotations

from ..core.model.likelihood import Priors
from ..io.channels import select_channels
from ..io.inventory import load_inventory
from ..io.read import read_waveforms
from .choose import choose
from .criticise import criticise
from .fit import fit
from .prepare import prepare

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
    recordings: what ``bayescal fit`` computes, from ObsPy objects:
    :func:`~bayescal.pair.prepare.prepare`, :func:`~bayescal.pair.fit.fit`,
    :func:`~bayescal.pair.criticise.criticise` and
    :func:`~bayescal.pair.choose.choose` in a row.

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
        used is in ``result.meta.band_hz`` and how it was chosen in
        ``result.meta.band_choice``.
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
        is in ``result.meta.reference_noise``.
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
        (``result.criticism``, result.json's ``criticism``; the improved
        model's result is ``result.improved``); see
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
        ``result.meta.data_used["transients"]``); "keep" fits every
        segment (as ``bayescal fit --keep-transients``).

    Returns
    -------
    Result
        Samples, their summary (``.summary()``, the content of
        ``result.json``) and what was run (``.meta``); the live fit (model,
        least-squares point, spectra, the SUT's metadata) is ``.state``.

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
    fit_response = {None: "gain", False: "none", True: "all"}.get(fit_response, fit_response)
    data = prepare(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml, band=band, start=start,
                   end=end, nperseg=nperseg, transients=transients, sut_source=sut_source,
                   ref_source=ref_source, ref_noise_psd=ref_noise_psd)
    state = fit(data, fit_response=fit_response, priors=priors, seed=seed, ref_noise=ref_noise,
                progress=progress, **sample_kw)
    criticism = criticise(state, budget_s=diagnose_budget_s, seed=seed, enabled=diagnose,
                          **sample_kw)
    result = choose(state, criticism, data=data, fit_response=fit_response,
                    tolerance=priors.reference_tolerance, seed=seed)
    _warn_on_misfit(result)
    return result


def _warn_on_misfit(result):
    """A failed model check as a Python warning (:class:`ModelMisfitWarning`),
    so a script sees it as the console does."""
    import warnings

    from ..core.checks.adequacy import ModelMisfitWarning, describe
    if result.adequacy.get("ok") is False:
        c = result.criticism.get("verdict_text") if result.criticism else None
        warnings.warn(describe(result.adequacy, next_step=c and f"Criticism: {c}."),
                      ModelMisfitWarning, stacklevel=3)


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
    Result
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
