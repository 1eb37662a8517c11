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

from ..core.priors import Priors
from ..criticism.verdict import DEFAULT_BUDGET_S
from ..io.channels import select_channels
from ..io.inventory import load_inventory
from ..io.read import read_waveforms
from .caller import caller_stacklevel
from .choice import choose
from .criticism import criticise
from .fitting import fit
from .preparation import prepare

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
              ref_noise_psd=None, diagnose=True, diagnose_budget_s=DEFAULT_BUDGET_S,
              transients="drop", label=None, **sample_kw):
    """Posterior over the SUT's orientation (and response) from co-located
    recordings: what ``bayescal fit`` computes, from ObsPy objects:
    :func:`~bayescal.pair.preparation.prepare`, :func:`~bayescal.pair.fitting.fit`,
    :func:`~bayescal.pair.criticism.criticise` and
    :func:`~bayescal.pair.choice.choose` in a row.

    Parameters
    ----------
    ref, ref_xml, sut, sut_xml : obspy.Stream; obspy.Inventory, str or "flat"
        The two sensors' recordings and metadata (keywords only, as
        ``--ref``, ``--ref-xml``, ``--sut`` and ``--sut-xml``).
    band, start, end, nperseg, transients, ref_noise_psd, sut_source, ref_source, label
        What of the recordings is fitted, and a name the result's meta keeps:
        :func:`~bayescal.pair.preparation.prepare`.
    fit_response, seed, priors, ref_noise, progress, **sample_kw
        How it is fitted: :func:`~bayescal.pair.fitting.fit` (``priors``'s
        ``reference_tolerance``: :func:`~bayescal.pair.choice.choose`).
    diagnose, diagnose_budget_s
        Whether a fit that fails its model check is criticised, and the
        criticism's work budget in seconds:
        :func:`~bayescal.pair.criticism.criticise` (``enabled``, ``budget_s``).

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
                   ref_source=ref_source, ref_noise_psd=ref_noise_psd, label=label)
    state = fit(data, fit_response=fit_response, priors=priors, seed=seed, ref_noise=ref_noise,
                progress=progress, **sample_kw)
    from ..core import progress as display

    with display.shown(progress):       # the criticism's stages, as the fit's
        criticism = criticise(state, budget_s=diagnose_budget_s, seed=seed, enabled=diagnose,
                              **sample_kw)
    result = choose(state, criticism, data=data, fit_response=fit_response,
                    tolerance=priors.reference_tolerance, seed=seed, priors=priors)
    _warn_on_misfit(result)
    return result


def _warn_on_misfit(result):
    """A failed model check of the fit as a Python warning
    (:class:`ModelMisfitWarning`), so a script sees it as the console does
    (also when the verdict puts the improved model in the headline). The
    warning points at the caller's line that called into bayescal, and its
    next step is said in Python."""
    import warnings

    from ..core.checks import describe
    from ..errors import ModelMisfitWarning
    adequacy = result.rejected.get("adequacy") or result.adequacy   # the fit's own check
    if adequacy.get("ok") is False:
        c = result.criticism.get("verdict_text") if result.criticism else None
        step = (f"Criticism: {c}." if c else "The criticism was not run (diagnose=False): "
                "bayescal.criticism.diagnose.diagnose(result.state) finds and names the cause.")
        warnings.warn(describe(adequacy, next_step=step), ModelMisfitWarning,
                      stacklevel=caller_stacklevel())


def read_pair(*, ref, ref_xml, sut, sut_xml, sut_id=None, ref_id=None):
    """``(ref, ref_inventory, sut, sut_inventory)`` from file paths (any
    waveform format ObsPy reads; StationXML, RESP, GSE2 or ``"flat"``), the
    channels chosen by ``sut_id``/``ref_id``, as :func:`calibrate_files`
    reads them."""
    sut = select_channels(read_waveforms(sut, "SUT waveform"), sut_id, "SUT")
    ref = select_channels(read_waveforms(ref, "reference waveform"), ref_id, "reference")
    return (ref, load_inventory(ref_xml, ref, "reference StationXML"),
            sut, load_inventory(sut_xml, sut, "SUT StationXML"))


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
    ref, ref_inv, sut, sut_inv = read_pair(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml,
                                           sut_id=sut_id, ref_id=ref_id)
    start = UTCDateTime(start) if start is not None else None
    end = UTCDateTime(end) if end is not None else None
    sut_name = sut_xml if isinstance(sut_xml, str) else "SUT StationXML"
    ref_name = ref_xml if isinstance(ref_xml, str) else "reference StationXML"
    return calibrate(ref=ref, ref_xml=ref_inv, sut=sut, sut_xml=sut_inv, band=band,
                     fit_response=fit_response,
                     seed=seed, start=start, end=end, progress=progress,
                     sut_source=str(sut_name), ref_source=str(ref_name), **kw)
