"""The whole chain in one call: recordings -> spectra -> posterior.

    >>> import bayescal
    >>> post = bayescal.calibrate(sut_stream, sut_inventory, ref_stream, ref_inventory,
    ...                           band=(0.05, 1.0), fit_response="gain")
    >>> post.save("out")           # result.json + samples.npz
"""
from __future__ import annotations

from .fit import fit_spectra
from .io import align
from .likelihood import Priors
from .spectra import cross_spectra


def calibrate(sut, sut_inventory, ref, ref_inventory, band, fit_response="none", seed=0,
              priors=Priors(), nperseg=None, start=None, end=None, progress=True,
              sut_source="SUT", ref_source="reference", **sample_kw):
    """Posterior over the SUT's orientation (and response) from co-located
    recordings.

    Parameters
    ----------
    sut, ref : ObsPy ``Stream`` of the sensor under test and of the reference.
    sut_inventory, ref_inventory : ObsPy ``Inventory`` with both sensors'
        channels (azimuth, dip, response).
    band : (fmin, fmax) in Hz.
    fit_response : "none" (angles only), "gain", or "all" (period, damping,
        gain per channel).
    seed : random seed (results are reproducible).
    """
    fit_response = {None: "none", False: "none", True: "all"}.get(fit_response, fit_response)
    s, r, fs, t0 = align(sut, sut_inventory, ref, ref_inventory, sut_source, ref_source,
                         start, end)
    spectra = cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), band,
                            nperseg=nperseg, sut_ids=s.ids, ref_ids=r.ids)
    families = s.families()
    nominal = {cid: {"azimuth_deg": az, "dip_deg": dip,
                     **({} if fam is None else {"period_s": fam.period_s, "damping": fam.damping,
                                                "gain": fam.gain})}
               for cid, az, dip, fam in zip(s.ids, s.azimuths, s.dips, families)}
    meta = {"nominal": nominal, "reference": {cid: {"azimuth_deg": az, "dip_deg": dip}
                                              for cid, az, dip in zip(r.ids, r.azimuths, r.dips)},
            "starttime": str(t0), "sampling_rate": fs,
            "duration_s": s.data.shape[1] / fs}
    post = fit_spectra(spectra, r.vectors, s.vectors, families, free=fit_response, priors=priors,
                       seed=seed, progress=progress, meta=meta, **sample_kw)
    post.spectra = spectra
    return post
