"""A pair fit, one step a module, data flowing one way:

* :mod:`.preparation` :func:`prepare`: recordings and metadata ->
                    :class:`~.preparation.PairData`
                    (aligned, band chosen, spectra, transients left out)
* :mod:`.fitting`   :func:`fit`: PairData -> :class:`~bayescal.core.posterior.state.FitState`
                    (model, least-squares point, samples, convergence)
* :mod:`.criticism` :func:`criticise`: FitState -> :class:`~bayescal.criticism.verdict.Criticism`
* :mod:`.choice`    :func:`choose`: FitState and Criticism -> the frozen
                    :class:`~bayescal.result.record.Result` (self-noise,
                    the reference's tolerance, the prior flags applied first)
* :mod:`.response_curve` :func:`relative_response`: the headline's
                    SUT response relative to the reference's metadata
                    (result.json's ``response_curve``), called by ``choose``
* :mod:`.workflow`  the four in a row: :func:`calibrate` and
                    :func:`calibrate_files`
* :mod:`.caller`    the user's line, where the fit's warnings point

May import :mod:`bayescal.core`, :mod:`bayescal.io`, :mod:`bayescal.criticism`
and :mod:`bayescal.result`.

Its public names (``__all__``) are loaded on first use
(:func:`lazy_loader.attach`)::

    from bayescal.pair import prepare, fit, criticise, choose
    data = prepare(ref=ref_stream, ref_xml="ref.xml", sut=sut_stream, sut_xml="sut.xml")
    state = fit(data)
    result = choose(state, criticise(state), data=data)
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "preparation": ["PairData", "prepare"],
    "fitting": ["fit"],
    "criticism": ["criticise"],
    "choice": ["choose"],
    "response_curve": ["relative_response"],
    "workflow": ["calibrate", "calibrate_files"],
})
