"""A reference's noise given by a third co-located sensor
(docs/validation/errors_in_variables.md, "A reference's noise given by a
third sensor"): the relative gain of a one-channel huddle with the
reference's noise ignored (``quiet``) and with ``bayescal noise``'s estimate
from a third sensor (``--ref-noise-psd``).

Three simulated co-located verticals (:func:`bayescal.simulate.selfnoise.
simulate_colocated`, 4 h at 5 Hz, seed 3, true gains as in the metadata):
``bayescal noise`` on the three, then ``bayescal fit`` of the second against
the first at 0.01-0.05 Hz, both through the command line as a user runs
them. The fit's own relative gain is kept (``rejected_fit`` when the
criticism's improved model heads the result). The same run as
``tests/test_known_ref_noise.py::test_third_sensor_noise_json_through_the_command_line``,
which asserts its outcome. About a minute.

    python validation/studies/third_sensor_gain.py --out validation/results/eiv/third_sensor_gain.json
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import study_results                          # the sibling module, run as a script

SEED, DURATION, FS, BAND = 3, 4 * 3600, 5.0, ("0.01", "0.05")
CHANNEL = "XS.SIM.10.BHZ"


def command(*args):
    """``python -m bayescal.cli ARGS``; raises on a failed command."""
    proc = subprocess.run([sys.executable, "-m", "bayescal.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=900)
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    return proc


def run(folder):
    """The two fits' relative gains of :data:`CHANNEL`, by reference-noise
    mode (``quiet``, ``fixed``)."""
    from bayescal.simulate.selfnoise import simulate_colocated

    folder = Path(folder)
    data, xml = simulate_colocated(duration=DURATION, fs=FS, seed=SEED).write(str(folder / "in"))
    command("noise", "--data", *data, "--xml", *xml, "--out", folder / "noise")
    out = {}
    for name, extra in (("quiet", []), ("fixed", ["--ref-noise-psd", folder / "noise" / "noise.json"])):
        command("fit", "--sut", data[1], "--sut-xml", xml[1], "--ref", data[0], "--ref-xml", xml[0],
                "--band", *BAND, *extra, "--out", folder / name, "--quiet", "--no-report")
        res = json.loads((folder / name / "result.json").read_text())
        fit = res.get("rejected_fit") or res
        rel = fit["channels"][CHANNEL]["response"]["relative_gain"]
        out[name] = {"mode": res["meta"]["reference_noise"]["mode"], "median": rel["median"],
                     "sd": rel["sd"], "ci95": rel["ci95"],
                     "holds_1": bool(rel["ci95"][0] <= 1.0 <= rel["ci95"][1])}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="validation/results/eiv/third_sensor_gain.json")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        gains = run(tmp)
    study_results.write(args.out, {
        "command": "python validation/studies/third_sensor_gain.py --out " + args.out,
        "settings": {"seed": SEED, "duration_s": DURATION, "fs": FS, "band_hz": list(map(float, BAND)),
                     "channel": CHANNEL, "truth": 1.0},
        "relative_gain": gains, "seconds": time.perf_counter() - t0})
    print(json.dumps(gains, indent=1))


if __name__ == "__main__":
    main()
