"""The per-band noise scale where the model misses: the ASL COWI pair
(1/8-1/3 Hz, reference taken as quiet, as the published method does) fitted
with the default likelihood (inverse-gamma shape a = 2) and with the plain
Gaussian one (``misfit_shape=inf``); the azimuths' medians, 95 % intervals
and sd, and each band's variance factor (docs/validation/misfit_scale.md,
"Where the model misses: ASL COWI"). About a minute; needs the shared data
(../shared/data/real/asl_cowi_azimuth).

    python validation/studies/misfit_scale_cowi.py [--out validation/results/misfit_scale/cowi.json]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import study_results                          # the sibling module, run as a script

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "real" / "asl_cowi_azimuth"
SHAPES = {"default (a = 2)": 2.0, "Gaussian": float("inf")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "misfit_scale"
                                         / "cowi.json"))
    a = ap.parse_args(argv)
    if not a.data.is_dir():
        sys.exit(f"data folder {a.data} not found (see ../shared/data/README.md)")
    import bayescal

    d, t0, fits = a.data, time.time(), {}
    for label, shape in SHAPES.items():
        post = bayescal.calibrate_files(
            ref=[str(d / "DT000110.LH1"), str(d / "DT000110.LH2")], ref_xml="flat",
            sut=str(d / "C100823215422_COWI.LHx"), sut_xml="flat", band=(0.125, 0.3333333),
            start="2010-08-24T02:00:00", end="2010-08-24T13:00:00", ref_noise="quiet",
            misfit_shape=shape, progress=False)
        s = post.summary()
        fits[label] = {
            "misfit_shape": "inf" if shape == float("inf") else shape,
            "azimuth_deg": {cid: {k: s["channels"][cid]["azimuth_deg"][k]
                                  for k in ("median", "sd", "ci95")}
                            for cid in ("US.COWI..LHN", "US.COWI..LHE")},
            "band_variance_factor": s["meta"].get("misfit_scale", {}).get(
                "band_variance_factor"),
            "converged": bool(s["convergence"]["converged"])}
        az = fits[label]["azimuth_deg"]["US.COWI..LHN"]
        print(f"{label}: LHN {az['median']:.2f} [{az['ci95'][0]:.2f}, {az['ci95'][1]:.2f}] "
              f"sd {az['sd']:.3f}; band variance factors "
              f"{fits[label]['band_variance_factor']}", flush=True)
    gauss, default = (fits[k]["azimuth_deg"]["US.COWI..LHN"]["sd"] for k in ("Gaussian",
                                                                               "default (a = 2)"))
    study_results.write(a.out, {
        "command": "python validation/studies/misfit_scale_cowi.py",
        "fits": fits, "lhn_sd_ratio_default_to_gaussian": default / gauss,
        "seconds": time.time() - t0})
    return 0


if __name__ == "__main__":
    sys.exit(main())
