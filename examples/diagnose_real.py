"""Real-data proofs of ``bayescal diagnose`` (data in ../shared/data/real,
see its README; the script exits with a message when it is absent).

1. ASL COWI pair (1 Hz, horizontals against AZI8 LH1/LH2, 1/8-1/3 Hz,
   2010-08-24T02:00-13:00), as it is (control), then with an effect injected
   that the tool is not told about: the COWI traces' start times shifted by
   +0.5 s (the SUT's clock 0.5 s late), and separately LHE multiplied by -1
   (a reversed channel).
2. ObsPy huddle pair (STS-2 with the two-pole ``STS2_simp.cal`` versus an
   unknown sensor with a nominal two-pole StationXML; 200 Hz) as it is, fitted
   with its response free over the full band 0.1-40 Hz.

Each case writes ``reports/diagnose/<case>/diagnosis.json`` (without the
base and final fits' samples) and a one-page ``diagnosis.pdf``/``.png``.

    python examples/diagnose_real.py [--data DIR] [--out reports/diagnose] [--mcmc]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "real"
sys.path.insert(0, str(ROOT / "examples"))


def cowi_inputs(data, effect=None):
    """(sut, sut_inv, ref, ref_inv) of the COWI pair, with ``effect``
    ("clock" or "reversed") injected into the COWI traces."""
    from bayescal import io

    d = data / "asl_cowi_azimuth"
    sut = io.read_waveforms([d / "C100823215422_COWI.LHx"])
    ref = io.read_waveforms([d / "DT000110.LH1", d / "DT000110.LH2"])
    if effect == "clock":
        for tr in sut:
            tr.stats.starttime += 0.5
    elif effect == "reversed":
        for tr in sut.select(channel="LHE"):
            tr.data = -tr.data.astype(float)
    return sut, io.flat_inventory(sut), ref, io.flat_inventory(ref)


def huddle_inputs(data, folder):
    """(sut, sut_inv, ref, ref_inv) of the huddle pair (metadata as in
    examples/real_huddle.py)."""
    from real_huddle import write_inputs

    from bayescal import io
    d = data / "obspy_relcal"
    ref_xml, sut_xml = write_inputs(d, folder)
    sut, ref = io.read_waveforms(d / "ref_unknown"), io.read_waveforms(d / "ref_STS2")
    return sut, io.read_metadata(sut_xml), ref, io.read_metadata(ref_xml)


CASES = {
    "cowi_asis": dict(kind="cowi", effect=None, band=(0.125, 1 / 3.0), free="none"),
    "cowi_clock_0.5s": dict(kind="cowi", effect="clock", band=(0.125, 1 / 3.0), free="none"),
    "cowi_reversed_LHE": dict(kind="cowi", effect="reversed", band=(0.125, 1 / 3.0), free="none"),
    "huddle_full_band": dict(kind="huddle", band=(0.1, 40.0), free="all"),
}


def run_case(name, spec, data, out, seed=0, mcmc=False, page=True, **sample_kw):
    """Diagnose one case; writes its folder and returns the Diagnosis.
    ``page=False`` skips the rendered page (diagnosis.json is still written);
    ``sample_kw`` go to the base fit's sampler (the tests pass a shorter chain:
    the diagnosis starts from the least-squares point, not from the samples)."""
    from obspy import UTCDateTime

    import bayescal
    from bayescal.criticism.diagnose import diagnose
    from bayescal.report.diagnosis import write_page
    from bayescal.io.result import write_json

    folder = os.path.join(out, name)
    os.makedirs(folder, exist_ok=True)
    if spec["kind"] == "cowi":
        inputs = cowi_inputs(data, spec["effect"])
        window = dict(start=UTCDateTime("2010-08-24T02:00:00"), end=UTCDateTime("2010-08-24T13:00:00"))
    else:
        inputs = huddle_inputs(data, os.path.join(folder, "inputs"))
        window = {}
    t0 = time.perf_counter()
    sut, sut_xml, ref, ref_xml = inputs
    base = bayescal.calibrate(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml, band=spec["band"], fit_response=spec["free"], seed=seed,
                              progress=False, ref_noise="quiet", diagnose=False, **window,
                              **sample_kw)
    d = diagnose(base.state, seed=seed, mcmc=mcmc, log=lambda s: print(s, flush=True))
    summary = d.summary()
    summary["case"] = {"name": name, **{k: v for k, v in spec.items()}, "seconds":
                       time.perf_counter() - t0}
    write_json(os.path.join(folder, "diagnosis.json"), summary)
    if page:
        write_page(d, os.path.join(folder, "diagnosis"))
    return d


def main(argv=None):
    p = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))
    p.add_argument("--data", type=Path, default=DEFAULT_DATA)
    p.add_argument("--out", default=str(ROOT / "reports" / "diagnose"))
    p.add_argument("--case", nargs="*", default=list(CASES))
    p.add_argument("--mcmc", action="store_true", help="sample the final model (slower)")
    a = p.parse_args(argv)
    if not a.data.is_dir():
        sys.exit(f"data folder {a.data} not found (see ../shared/data/README.md)")
    for name in a.case:
        print(f"== {name}", flush=True)
        d = run_case(name, CASES[name], a.data, a.out, mcmc=a.mcmc)
        for m in d.before["mismatch"]:
            print(f"  base misfit: {m['band_hz'][0]:.3g}-{m['band_hz'][1]:.3g} Hz on "
                  f"{m['channels']} p={m['p_value']:.2g} max {m['misfit_max']:.3g}")
        print(f"  misfit max per channel before {d.before['misfit'].max(axis=0).round(2)}, "
              f"after {d.after['misfit'].max(axis=0).round(2)}")
        for s in d.sentences():
            print("  " + s)


if __name__ == "__main__":
    main()
