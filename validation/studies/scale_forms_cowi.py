"""Forms of the misfit scale where the model misses: the ASL COWI pair over
11 hours (2010-08-24T02:00-13:00, 1/8-1/3 Hz, the default fit: gains free,
the reference's noise estimated, the criticism off), fitted with the scale
per band (the default), the pooled scale (each band its own with
probability 0.25, every scale at least 1) and the pooled scale per SUT
channel (:mod:`bayescal.core.model.channel_scale`; shape 2.5, every scale at
least 1, no own scales: the form refitted on the ten-minute windows). Per
form: each channel's azimuth (median, 95 % interval, sd from the 68 %) and
the variance factors at the posterior median, per band (shared forms) or
per band and channel (the form per channel); and the model check of the
default fit with the reference taken as quiet. Under a minute; needs the
shared data (../shared/data/real/asl_cowi_azimuth).

    python validation/studies/scale_forms_cowi.py --out validation/results/misfit_scale/cowi_forms.json
"""
from __future__ import annotations

import argparse
import shlex
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import study_results                          # the sibling module, run as a script

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "real" / "asl_cowi_azimuth"
RESULTS = ROOT / "validation" / "results" / "misfit_scale"
#: label -> (misfit shape, own-scale probability, scale floor, per channel)
FORMS = {"per band, free (default)": (2.0, 1.0, False, False),
         "pooled, pi = 0.25, s >= 1": (2.0, 0.25, True, False),
         "per channel, pooled (pi = 0), s >= 1, a = 2.5": (2.5, 0.0, True, True)}


def fit(data, shape, pi, floor, per_channel):
    """One fit under a form: azimuths per channel and the variance factors."""
    import bayescal
    from bayescal.core.model import channel_scale, misfit_scale
    old = (misfit_scale.OWN_SCALE_PROB, misfit_scale.SCALE_FLOOR, misfit_scale.PER_CHANNEL)
    misfit_scale.OWN_SCALE_PROB, misfit_scale.SCALE_FLOOR = pi, floor
    misfit_scale.PER_CHANNEL = per_channel
    try:
        post = bayescal.calibrate_files(
            ref=[str(data / "DT000110.LH1"), str(data / "DT000110.LH2")], ref_xml="flat",
            sut=str(data / "C100823215422_COWI.LHx"), sut_xml="flat", band=(0.125, 0.3333333),
            start="2010-08-24T02:00:00", end="2010-08-24T13:00:00", misfit_shape=shape,
            diagnose=False, progress=False)
        model = post.state.model
        theta = np.median(post.samples, axis=0)[None]
        weight = getattr(model.noise, "weight", None)
        if per_channel:
            q, k = channel_scale.channel_energy(model, theta)
            factors = channel_scale.channel_scale(q[0], k, shape, weight).T.tolist()
        else:
            q, k = model.band_energy(theta)
            factors = misfit_scale.band_scale(q[0], k, shape, weight).tolist()
    finally:
        misfit_scale.OWN_SCALE_PROB, misfit_scale.SCALE_FLOOR, misfit_scale.PER_CHANNEL = old
    ch = post.summary()["channels"]
    out = {"variance_factors": factors}
    for c in ("LHN", "LHE"):
        az = ch[f"US.COWI..{c}"]["azimuth_deg"]
        out[c] = {"median": az["median"], "ci95": az["ci95"],
                  "sd68": (az["ci68"][1] - az["ci68"][0]) / 2}
    return out


def quiet_check(data):
    """The default fit's model check with the reference taken as quiet (the
    published method's assumption): ``result.json``'s ``adequacy``."""
    import bayescal
    post = bayescal.calibrate_files(
        ref=[str(data / "DT000110.LH1"), str(data / "DT000110.LH2")], ref_xml="flat",
        sut=str(data / "C100823215422_COWI.LHx"), sut_xml="flat", band=(0.125, 0.3333333),
        start="2010-08-24T02:00:00", end="2010-08-24T13:00:00", ref_noise="quiet",
        diagnose=False, progress=False)
    return post.adequacy


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RESULTS / "cowi_forms.json"))
    a = ap.parse_args(argv)
    if not DATA.is_dir():
        sys.exit(f"data folder {DATA} not found (see ../shared/data/README.md)")
    warnings.simplefilter("ignore")
    t0 = time.time()
    fits = {label: fit(DATA, *form) for label, form in FORMS.items()}
    command = " ".join(["python validation/studies/scale_forms_cowi.py"]
                       + [shlex.quote(x) for x in (sys.argv[1:] if argv is None else argv)])
    check = quiet_check(DATA)
    study_results.write(a.out, {"command": command, "forms": fits, "quiet_reference_check": check,
                                "seconds": round(time.time() - t0, 1)})
    for label, f in fits.items():
        print(label, f)


if __name__ == "__main__":
    main()
