"""``bayescal noise`` takes the metadata ``bayescal fit`` takes and says what
it found on the console.

Three co-located vertical sensors are synthesised with known self-noise,
white in ground acceleration: -170 dB and -165 dB re 1 (m/s^2)^2/Hz for two
of them and -200 dB for the third, far below what the other two let any
estimate resolve (its error is set by their noise). Ground acceleration is
-140 dB. Each sensor records through a known response:

* all three flat at 1 count per m/s, run with ``--xml flat flat flat``;
* a RESP file (ObsPy's STS-2 test file), a GSE2 poles-and-zeros file and
  ``flat``, one per sensor; the recordings are made with ObsPy's own
  evaluation of the RESP response and the GSE2 formula, not with bayescal's.

The console's period-band table must give the two resolved sensors within
2 dB of the truth with 90 % intervals holding it (a binomial band at the
suite's level 0.001: at least 6 of 12 rows),
and the quiet sensor as "below resolution" with an upper bound above its
true -200 dB and below the others' noise. The figure must draw those bounds
as markers at the upper bound, not as points at the estimate.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from bayescal.cli import main
from tests.tolerance import coverage_band

FS = 20.0
DURATION = 1800.0
GROUND_DB = -140.0
NOISE_DB = (-170.0, -165.0, -200.0)
BAND = ("0.01", "4")

#: A GSE2 CAL1 PAZ file (a 1 Hz geophone, gain 400 counts per m/s, A0 = 1).
GSE2 = """CAL1 GSE    LE-3D    Z  M24    PAZ 010824 0001
2
-4.39823 4.48709
-4.39823 -4.48709
2
0.0 0.0
0.0 0.0
400.0
"""


def _gse2_response(f):
    s = 2j * np.pi * f
    p = complex(-4.39823, 4.48709)
    return 400.0 * s ** 2 / ((s - p) * (s - p.conjugate()))


def _resp_path():
    import obspy
    path = (Path(obspy.__file__).parent / "io" / "xseed" / "tests" / "data"
            / "RESP.XX.NS085..BHZ.STS2_gen3.120.1500")
    if not path.is_file():
        pytest.skip("ObsPy's test data (RESP files) are not installed")
    return path


def _resp_response(path):
    """ObsPy's own evaluation of the RESP file's velocity response."""
    import obspy
    resp = obspy.read_inventory(str(path), format="RESP")[0][0][0].response

    def fn(f):
        out = np.zeros(f.size, complex)
        out[1:] = resp.get_evalresp_response_for_frequencies(f[1:], output="VEL")
        return out
    return fn


def _spectrum(rng, n, psd):
    """Fourier coefficients of a real series of n samples with one-sided PSD ``psd``."""
    X = np.sqrt(n * FS * psd / 2) * (rng.standard_normal(psd.size)
                                     + 1j * rng.standard_normal(psd.size)) / np.sqrt(2)
    X[0] = 0
    X[-1] = X[-1].real
    return X


def _synthesise(folder, sensors, seed=4):
    """One miniSEED per sensor: ``sensors`` are (network, station, response
    function of frequency in counts per m/s, noise dB). Returns the paths."""
    import obspy

    rng = np.random.default_rng(seed)
    n = int(DURATION * FS)
    f = np.fft.rfftfreq(n, 1 / FS)
    w2 = (2 * np.pi * np.where(f > 0, f, 1.0)) ** 2
    ground = _spectrum(rng, n, np.full(f.size, 10 ** (GROUND_DB / 10)) / w2)   # velocity
    paths = []
    for net, sta, response, noise_db in sensors:
        noise = _spectrum(rng, n, np.full(f.size, 10 ** (noise_db / 10)) / w2)
        x = np.fft.irfft(response(f) * (ground + noise), n=n)
        tr = obspy.Trace(x, header=dict(network=net, station=sta, location="", channel="BHZ",
                                        sampling_rate=FS,
                                        starttime=obspy.UTCDateTime(2024, 3, 1)))
        paths.append(str(folder / f"{net}.{sta}.mseed"))
        obspy.Stream([tr]).write(paths[-1], format="MSEED", encoding="FLOAT64")
    return paths


_ROW = re.compile(r"< (-?\d+\.\d) below resolution|(-?\d+\.\d) \[(-?\d+\.\d), (-?\d+\.\d)\]")


def _table(stdout, ids):
    """{id: [(estimate or None, lower or None, upper)]} from the console table."""
    lines = stdout.splitlines()
    head = next(i for i, ln in enumerate(lines) if ln.split() and ln.split()[:2] == ["period", "s"])
    assert lines[head].split()[2:] == ids, lines[head]
    out = {cid: [] for cid in ids}
    for ln in lines[head + 1:]:
        if not re.match(r"\s*[\d.]+-[\d.]+\s", ln):
            break
        cells = _ROW.findall(ln)
        assert len(cells) == len(ids), ln
        for cid, (bound, est, lo, hi) in zip(ids, cells):
            out[cid].append((None, None, float(bound)) if bound
                            else (float(est), float(lo), float(hi)))
    assert all(len(v) >= 5 for v in out.values()), stdout
    return out


def _check(table, ids):
    """The numbers of the table against the synthesised truth."""
    resolved = [(cid, row, truth) for cid, truth in zip(ids[:2], NOISE_DB[:2])
                for row in table[cid]]
    assert all(row[0] is not None for _, row, _ in resolved), table
    assert all(abs(row[0] - truth) < 2.0 for _, row, truth in resolved), table
    inside = sum(row[1] <= truth <= row[2] for _, row, truth in resolved)
    # binomial band of 90 % intervals at the suite's level 0.001 (the period
    # bands do not overlap, so the rows are close to independent): 6 of 12.
    # "all but 3" (9 of 12) would fail right intervals 2.6 % of the time.
    assert inside >= coverage_band(len(resolved), 0.9)[0], (inside, table)
    quiet = table[ids[2]]
    bounds = [row[2] for row in quiet if row[0] is None]
    assert len(bounds) >= len(quiet) - 1, quiet          # said to be below resolution
    assert all(NOISE_DB[2] <= b < NOISE_DB[0] for b in bounds), quiet


def _complex_wishart(rng, C, dof, size):
    """``size`` draws of the complex Wishart CW(dof, C / dof), real ``dof``
    (Bartlett: chi-square diagonal with 2(dof - i) degrees of freedom,
    complex normal below)."""
    n = C.shape[0]
    A = np.zeros((size, n, n), complex)
    for i in range(n):
        A[:, i, i] = np.sqrt(rng.gamma(dof - i, 1.0, size))
        for j in range(i):
            A[:, i, j] = (rng.standard_normal(size) + 1j * rng.standard_normal(size)) / np.sqrt(2)
    LA = np.linalg.cholesky(C) @ A
    return LA @ np.conj(np.swapaxes(LA, 1, 2)) / dof


def _interval_width_ratio(doc, ids, reps=4000):
    """Widths of noise.json's ``ci90_db`` (linear power) of the two resolved
    sensors ``ids[:2]``, over the widths of the interval its ``interval``
    note states, recomputed here: the basic bootstrap [N - q95, N - q5] of
    N* - N, N* Sleeman's estimate (Re(C_ii - C_ij C_ki / C_kj)) of matrices
    drawn from the complex Wishart with the band's ``dof`` around the
    one-factor matrix of the estimates (off-diagonal sqrt((P_i - N_i)(P_j -
    N_j)), P the recorded PSD, N the self-noise; the quiet sensor's taken
    as 0 where not positive). One ratio per band and sensor."""
    lin = lambda a: np.array([np.nan if v is None else 10.0 ** (v / 10.0) for v in a])  # noqa
    S = doc["sensors"]
    assert "basic bootstrap on linear power, parametric complex Wishart" in doc["meta"]["interval"]
    N = np.nan_to_num(np.array([lin(S[c]["psd_db"]) for c in ids]))
    P = np.array([lin(S[c]["recorded_psd_db"]) for c in ids])
    dof = np.array(S[ids[0]]["dof"])
    rng = np.random.default_rng(1)
    ratios = []
    for i in (0, 1):
        j, k = [m for m in range(3) if m != i]
        lo, hi = (lin(b) for b in S[ids[i]]["ci90_db"])
        for b in range(dof.size):
            g = np.sqrt(P[:, b] - N[:, b])
            W = _complex_wishart(rng, (np.outer(g, g) + np.diag(N[:, b])) / N[i, b], dof[b], reps)
            est = np.real(W[:, i, i] - W[:, i, j] * W[:, k, i] / W[:, k, j])
            q5, q95 = np.percentile(est - 1.0, [5.0, 95.0])
            ratios.append((hi[b] - lo[b]) / N[i, b] / (q95 - q5))
    return np.array(ratios)


def test_flat_metadata_for_every_sensor(tmp_path, capsys):
    flat = lambda f: np.ones(f.size, complex)   # noqa: E731
    data = _synthesise(tmp_path, [("XF", "A", flat, NOISE_DB[0]), ("XF", "B", flat, NOISE_DB[1]),
                                  ("XF", "C", flat, NOISE_DB[2])])
    out = tmp_path / "noise"
    code = main(["noise", "--data", *data, "--xml", "flat", "flat", "flat", "--out", str(out),
                 "--band", *BAND, "--n-boot", "300", "--quiet", "--no-report"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    ids = ["XF.A..BHZ", "XF.B..BHZ", "XF.C..BHZ"]
    doc = json.loads((out / "noise.json").read_text())
    assert doc["meta"]["flat_metadata"] == ids
    # ci90_db is the 90 % interval it says: its mean width over the resolved
    # sensors' 2 x 34 bands against the stated construction recomputed with
    # 4000 draws. The written bounds come from 300 replicates: a 90 % range
    # from 300 draws has relative sd sqrt(2 x 0.05 x 0.95 / 300) / phi(1.645)
    # / 3.29 = 0.053 (0.006 for the mean of 68; 0.021 at 3.29 sd) and is
    # about 1.2 % narrow (linear interpolation between order statistics);
    # the recomputation also omits the 1 mrad axis leakage (60 dB below the
    # ambient) and the 0.01 dB rounding of the bounds. The levels a label
    # could be confused with give ratios z_level / z_0.90: 80 % 0.78, 95 %
    # 1.19, 68 % 0.61; the tolerance, 0.1, is half the distance to the
    # nearest of them and five times the replicates' error above. A band
    # whose lower bound is null (no width) is left out; at least 60 of 68
    # have one here (the quiet sensor's estimate is positive in most bands).
    ratios = _interval_width_ratio(doc, ids)
    finite = np.isfinite(ratios)
    assert ratios.size == 68 and finite.sum() >= 60, ratios
    assert abs(ratios[finite].mean() - 1.0) < 0.1, ratios
    _check(_table(captured.out, ids), ids)
    assert "flat metadata" in captured.out and "not in ground units" in captured.out


def test_resp_gse2_and_flat_side_by_side(tmp_path, capsys):
    resp = _resp_path()
    cal = tmp_path / "geophone.cal"
    cal.write_text(GSE2)
    data = _synthesise(tmp_path, [("XX", "NS085", _resp_response(resp), NOISE_DB[0]),
                                  ("XG", "GSE", _gse2_response, NOISE_DB[1]),
                                  ("XF", "C", lambda f: np.ones(f.size, complex), NOISE_DB[2])])
    out = tmp_path / "noise"
    code = main(["noise", "--data", *data, "--xml", str(resp), str(cal), "flat",
                 "--out", str(out), "--band", *BAND, "--n-boot", "300", "--quiet", "--no-report"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    ids = ["XX.NS085..BHZ", "XG.GSE..BHZ", "XF.C..BHZ"]
    _check(_table(captured.out, ids), ids)


def test_figure_draws_upper_bounds_not_points(tmp_path):
    """Where an interval reaches zero power the figure has no estimate point
    and a marker at the upper bound."""
    import obspy

    from bayescal.core.selfnoise.sleeman import db
    from bayescal.io.noise import self_noise_streams
    from bayescal.io.read import flat_inventory
    from bayescal.report.noise import figure_component

    flat = lambda f: np.ones(f.size, complex)   # noqa: E731
    data = _synthesise(tmp_path, [("XF", "A", flat, NOISE_DB[0]), ("XF", "B", flat, NOISE_DB[1]),
                                  ("XF", "C", flat, NOISE_DB[2])])
    streams = [obspy.read(p) for p in data]
    result = self_noise_streams(streams, [flat_inventory(st) for st in streams], sources=data,
                                band=(0.01, 4.0), n_boot=200)
    comp = result.components[0]
    e = comp.estimate
    order = np.argsort(e.period_s)
    hi = e.hi[2, order]
    below = ~(e.lo[2, order] > 0)
    # (an interval wholly at zero power has no upper bound to draw)
    assert below.sum() >= 10 and np.mean(hi[below] > 10 ** (NOISE_DB[2] / 10)) > 0.8
    ax = figure_component(comp, result).axes[0]
    per = e.period_s[order]
    bounded = below & (hi > 0)
    bound_db = db(hi[bounded])
    # no line draws a finite point of sensor C's estimate where it is below resolution
    estimate_db = db(e.psd[2, order])
    for line in ax.get_lines():
        x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
        if x.size == per.size and np.allclose(x, per):
            drawn = np.isfinite(y) & below & np.isclose(y, estimate_db, equal_nan=False)
            assert not drawn.any(), line.get_label()
    # a marker-only line sits on every upper bound
    markers = [ln for ln in ax.get_lines() if ln.get_linestyle() in ("None", "none", "")
               and ln.get_marker() not in (None, "None", "none", "")]
    hits = [ln for ln in markers if np.asarray(ln.get_xdata()).size == bounded.sum()
            and np.allclose(ln.get_xdata(), per[bounded])
            and np.allclose(ln.get_ydata(), bound_db)]
    assert hits, [ln.get_label() for ln in ax.get_lines()]
    assert hits[0].get_marker() not in MARKER_POINTS


#: Point markers of the estimates (a bound is drawn with none of these).
MARKER_POINTS = ("o", "s", "^", "D", "P", "X", "*")
