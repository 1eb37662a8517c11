"""Awkward inputs: the time and peak memory of ``bayescal fit`` on the shared
real pairs and on simulated pairs whose metadata name the wrong instrument.

Cases (each a fresh ``python -m bayescal fit --no-report`` subprocess; wall
time, the child's CPU time, the machine's load over the minute before it
started, and peak memory as the child's ``resource.getrusage``
``ru_maxrss``):

* ``cowi_flat``: ASL's COWI pair (``../shared/data``), its whole record
  (about 17 h at 1 Hz), ``flat`` metadata, band 1/8-1/3 Hz, the defaults;
* ``cowi_nominal_all``: the same with a nominal 120-s two-pole StationXML
  for both sensors and ``--fit-response all``;
* ``huddle``: ObsPy's huddle pair (200 Hz, 1 h), the reference's GSE2
  poles and zeros and a nominal 120-s SUT, ``--fit-response all``, band
  0.1-2 Hz;
* ``period_3x``: a simulated 120-s sensor (2 h at 20 Hz) whose metadata say
  360 s, the defaults;
* ``period_3x_all``: a 40-s sensor whose metadata say 120 s,
  ``--fit-response all`` (the prior's period against the data's: a ridge on
  which the sampler's independence proposal fails and the
  differential-evolution moves carry on);
* ``pole_999``: the same with metadata saying 999 s (wrong but valid-looking),
  the defaults and ``--fit-response all``;
* ``flat_all``: ``flat`` SUT metadata with ``--fit-response all`` (refused
  with a message: ``flat`` has no pendulum to fit);
* ``day_1hz``: a simulated full day at 1 Hz with nominal metadata, gains free;
* ``hours_100hz``: a simulated 2 h at 100 Hz, the same;
* ``day_1hz_wrong_all``: a simulated full day at 1 Hz, both sensors given
  nominal 120-s two-pole StationXML while the reference is truly a 360-s /
  0.7 sensor and the SUT a 40-s one, ``--fit-response all --band 0.125
  0.333`` (the configuration of a day-long GSN pair that ran for 25 minutes);
* ``day_1hz_no_digitizer``: the same with the reference's nominal
  StationXML lacking the digitizer's gain (its gain 4e5 times too small:
  the spectra place every SUT gain far outside the prior, and the fit is
  refused from its start, naming the factor and the files to check);
* ``extra_pole_100hz``: 20 min at 100 Hz, a real pole at 8 Hz that the
  SUT's metadata lack (validation/studies/wrong_instrument.py's
  ``extra_pz`` kind), the criticism on.

Every case should end (an answer, or a clear "budget spent" / NOT
CONVERGED line) within 120 s and 1 GB on a two-core computer.

    python benchmarks/awkward_inputs.py [--cases NAME ...] [--timeout 900]
                                        [--out reports/benchmarks/awkward.json]
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT.parent / "shared" / "data" / "real"
COWI = REAL / "asl_cowi_azimuth"
HUDDLE = REAL / "obspy_relcal"
NOMINAL = dict(period_s=120.0, damping=0.707, gain=1500.0)
LIMIT_S, LIMIT_MB = 120.0, 1024.0


def cowi_inputs(folder):
    """The COWI pair's files and a nominal 120-s two-pole StationXML per
    sensor (written into ``folder``): ``(ref, sut, ref_xml, sut_xml)``."""
    sys.path.insert(0, str(ROOT))
    from bayescal import io

    ref = [str(COWI / "DT000110.LH1"), str(COWI / "DT000110.LH2")]
    sut = [str(COWI / "C100823215422_COWI.LHx")]
    xml = []
    for name, files in (("ref", ref), ("sut", sut)):
        path = os.path.join(folder, f"cowi_{name}.xml")
        io.two_pole_inventory(io.read_waveforms(files), **NOMINAL).write(path, format="STATIONXML")
        xml.append(path)
    return ref, sut, xml[0], xml[1]


def _real_cases(folder):
    cases = {}
    if COWI.is_dir():
        ref, sut, ref_xml, sut_xml = cowi_inputs(folder)
        band = ["--band", "0.125", "0.3333333"]
        cases["cowi_flat"] = ["--ref", *ref, "--ref-xml", "flat", "--sut", *sut,
                              "--sut-xml", "flat", *band]
        cases["cowi_nominal_all"] = ["--ref", *ref, "--ref-xml", ref_xml, "--sut", *sut,
                                     "--sut-xml", sut_xml, *band, "--fit-response", "all"]
    if HUDDLE.is_dir():
        from bayescal import io
        poles, zeros, gain = io.read_gse2_paz(HUDDLE / "STS2_simp.cal")
        ref_xml, sut_xml = os.path.join(folder, "sts2.xml"), os.path.join(folder, "unknown.xml")
        io.paz_inventory(io.read_waveforms(HUDDLE / "ref_STS2"), zeros=zeros, poles=poles,
                         gain=gain, normalize=False).write(ref_xml, format="STATIONXML")
        io.two_pole_inventory(io.read_waveforms(HUDDLE / "ref_unknown"), **NOMINAL).write(
            sut_xml, format="STATIONXML")
        cases["huddle"] = ["--ref", str(HUDDLE / "ref_STS2"), "--ref-xml", ref_xml,
                           "--sut", str(HUDDLE / "ref_unknown"), "--sut-xml", sut_xml,
                           "--band", "0.1", "2", "--fit-response", "all"]
    return cases


def _pair(files):
    return ["--ref", files["ref.mseed"], "--ref-xml", files["ref.xml"],
            "--sut", files["sut.mseed"], "--sut-xml", files["sut.xml"]]


def _simulated(folder, name, **kw):
    """A simulated pair written into ``folder/name``: its files."""
    from bayescal.simulate.pair import simulate_pair
    return simulate_pair(**kw).write(os.path.join(folder, name))


def _nominal_ref_xml(files, folder, digitizer=True):
    """The pair's reference metadata replaced by a nominal 120-s two-pole
    StationXML (the pair's truth unchanged): the simulated digitizer's gain
    in its sensitivity, or, without ``digitizer``, left out (the gain 4e5
    times too small)."""
    from bayescal import io
    from bayescal.simulate.pair import DIGITIZER_GAIN
    path = os.path.join(folder, "ref_nominal.xml")
    gain = NOMINAL["gain"] * (DIGITIZER_GAIN if digitizer else 1.0)
    io.two_pole_inventory(io.read_waveforms(files["ref.mseed"]), **dict(NOMINAL, gain=gain)).write(
        path, format="STATIONXML")
    return dict(files, **{"ref.xml": path})


def _simulated_builders():
    """{case: builder(folder) -> argv} of the simulated cases: each writes
    only its own pair."""
    truth = ((120.0, 0.707, 1500.0),) * 3

    def wrong(period):
        return lambda folder: _pair(_simulated(
            folder, f"p{period:g}", duration=7200, fs=20, seed=4, sut_response=truth,
            nominal_response=(period, 0.707, 1500.0), noise_in_counts=True))

    def flat(folder):
        argv = _pair(_simulated(folder, "flat", duration=3600, fs=20, seed=5,
                                sut_response=truth, nominal_response=truth[0]))
        argv[argv.index("--sut-xml") + 1] = "flat"
        return argv + ["--fit-response", "all"]

    def nominal(name, duration, fs, seed):
        return lambda folder: _pair(_simulated(folder, name, duration=duration, fs=fs, seed=seed,
                                               sut_response=truth, nominal_response=truth[0],
                                               noise_in_counts=True))

    def day_wrong_instruments(digitizer):
        # a day-long GSN pair's configuration: a day at 1 Hz, both sensors given nominal 120-s
        # metadata, the reference truly a 360-s / 0.7 sensor, the SUT a 40-s one
        def build(folder):
            name = "day_wrong" if digitizer else "day_no_digitizer"
            files = _simulated(folder, name, duration=86400, fs=1, seed=8,
                               sut_response=((40.0, 0.707, 1500.0),) * 3,
                               nominal_response=truth[0], ref_response=(360.0, 0.7, 1500.0),
                               noise_in_counts=True)
            return _pair(_nominal_ref_xml(files, os.path.join(folder, name), digitizer)) + [
                "--fit-response", "all", "--band", "0.125", "0.333"]
        return build

    def extra_pole(folder):
        # validation/studies/wrong_instrument.py's extra_pz kind: 20 min at
        # 100 Hz, noise shaped as the ground, a real pole at 8 Hz the SUT's
        # metadata lack; the criticism on (the default)
        return _pair(_simulated(folder, "extra_pole", duration=1200, fs=100, seed=44_003,
                                sut_response=((120.0, 0.707, 750.0),) * 3,
                                nominal_response=(120.0, 0.707, 750.0),
                                ref_response=(120.0, 0.707, 1500.0), coherence=0.999,
                                extra_pole=("sut", 8.0)))

    return {"period_3x": wrong(360.0), "pole_999": wrong(999.0),
            "pole_999_all": lambda folder: wrong(999.0)(folder) + ["--fit-response", "all"],
            "period_3x_all": lambda folder: _pair(_simulated(
                folder, "short", duration=7200, fs=20, seed=4,
                sut_response=((40.0, 0.707, 1500.0),) * 3, nominal_response=truth[0],
                noise_in_counts=True)) + ["--fit-response", "all"],
            "flat_all": flat, "day_1hz": nominal("day", 86400, 1, 6),
            "hours_100hz": nominal("hours100", 7200, 100, 7),
            "day_1hz_wrong_all": day_wrong_instruments(True),
            "day_1hz_no_digitizer": day_wrong_instruments(False), "extra_pole_100hz": extra_pole}


def prepare(folder, only=None):
    """Write the inputs of the cases asked (all by default) into
    ``folder``; returns {case: argv}."""
    sys.path.insert(0, str(ROOT))
    cases = {k: v for k, v in _real_cases(folder).items() if not only or k in only}
    for name, build in _simulated_builders().items():
        if not only or name in only:
            cases[name] = build(folder)
    return cases


def run(argv, folder, timeout):
    """One case in a child process: wall time, CPU time, peak memory, the
    load over the minute before it started (``os.getloadavg``), exit code and
    the last lines it printed."""
    out = tempfile.mkdtemp(dir=folder)
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")
    cmd = [sys.executable, "-m", "bayescal", "fit", *argv, "--out", out, "--no-report"]
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=folder)
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        stdout, stderr = proc.communicate()
    wall = time.perf_counter() - t0
    # of the children waited for so far (this case's alone: :func:`_measured`):
    # ru_maxrss the largest child's (KiB on Linux), the CPU time theirs
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    peak_mb = usage.ru_maxrss / 1024.0
    text = (stderr + stdout).strip().splitlines()
    ends = [ln for ln in text if ln.startswith(("NOT CONVERGED", "budget spent", "verdict:",
                                                "bayescal: error"))]
    return {"wall_s": round(wall, 1), "cpu_s": round(usage.ru_utime + usage.ru_stime, 1),
            "load_at_start": round(load, 1), "peak_mb": round(peak_mb), "exit": proc.returncode,
            "timed_out": proc.returncode is not None and proc.returncode < 0,
            "ends": ends[-3:], "last": text[-1:] if text else []}


def table(rows):
    """Markdown table of the results."""
    out = ["| case | wall (s) | CPU (s) | load | peak memory (MB) | exit | within 120 s and 1 GB "
           "| how it ended |", "|---|---|---|---|---|---|---|---|"]
    for case, r in rows.items():
        ok = r["wall_s"] <= LIMIT_S and r["peak_mb"] <= LIMIT_MB and not r["timed_out"]
        how = "; ".join(r["ends"]) or (r["last"][0] if r["last"] else "")
        out.append(f"| {case} | {r['wall_s']:.0f} | {r['cpu_s']:.0f} | {r['load_at_start']:.1f} "
                   f"| {r['peak_mb']:.0f} | {r['exit']} | "
                   f"{'yes' if ok else 'NO'} | {how[:160]} |")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", help="only these cases")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds before a case is killed")
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "awkward.json"))
    a = ap.parse_args(argv)
    rows = {}
    with tempfile.TemporaryDirectory() as folder:
        for case, args in prepare(folder, a.cases).items():
            # one child at a time, each measured alone: a fresh interpreter per case
            rows[case] = _measured(args, folder, a.timeout)
            print(f"{case:18s} {rows[case]['wall_s']:7.1f} s (CPU {rows[case]['cpu_s']:.1f} s) "
                  f"{rows[case]['peak_mb']:6.0f} MB exit {rows[case]['exit']}", file=sys.stderr,
                  flush=True)
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    Path(a.out).write_text(json.dumps({"command": "python benchmarks/awkward_inputs.py "
                                       + " ".join(argv or sys.argv[1:]), "cases": rows},
                                      indent=1) + "\n")
    print(table(rows))


def _measured(args, folder, timeout):
    """:func:`run` in a process of its own, so that ``ru_maxrss`` of the
    children is this case's alone."""
    import multiprocessing as mp

    with mp.get_context("spawn").Pool(1) as pool:
        return pool.apply(run, (args, folder, timeout))


if __name__ == "__main__":
    main()
