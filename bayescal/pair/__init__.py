"""A pair fit, one step a module, data flowing one way:

* :mod:`.prepare`   recordings and metadata -> :class:`~.prepare.PairData`
                    (aligned, band chosen, spectra, transients left out)
* :mod:`.fit`       PairData -> :class:`~bayescal.core.posterior.state.FitState`
                    (model, least-squares point, samples, convergence)
* :mod:`.criticise` FitState -> :class:`~bayescal.criticism.verdict.Criticism`
* :mod:`.choose`    FitState and Criticism -> the frozen
                    :class:`~bayescal.result.record.Result` (self-noise,
                    the reference's tolerance, the prior flags applied first)
* :mod:`.calibrate` the four in a row: :func:`~.calibrate.calibrate` and
                    :func:`~.calibrate.calibrate_files`

May import :mod:`bayescal.core`, :mod:`bayescal.io`, :mod:`bayescal.criticism`
and :mod:`bayescal.result`.
"""
