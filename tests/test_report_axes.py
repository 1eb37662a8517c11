"""Report axes a user reads (issue 14 item 12): the PSD's unit with 'flat'
metadata, tick labels on a narrow band, convergence traces in degrees and
percent, and the diagnosis page's labels and legends inside the page and
off the data. Checked on the matplotlib Figures the report code builds."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from bayescal.report.layout import A4
from bayescal.result.meta import Meta

SUT = ["XX.SIM.10.BH1", "XX.SIM.10.BH2"]
REF = ["XX.SIM.00.BHN", "XX.SIM.00.BHE"]


def _data_ctx(fmin=0.125, fmax=0.3333, flat=()):
    f = np.geomspace(fmin, fmax, 40)
    edges = np.geomspace(fmin, fmax, 5)
    d = {"freqs": f, "sut_ids": np.array(SUT), "ref_ids": np.array(REF),
         "psd": np.ones((4, f.size)) * 1e-12, "multiple_coherence": np.full((2, f.size), 0.99),
         "band_edges": edges, "band_misfit": np.ones((4, 2))}
    meta = Meta(placeholder_response={"sut": [c for c in SUT if c in flat],
                                      "reference": [c for c in REF if c in flat]})
    return SimpleNamespace(post=SimpleNamespace(diagnostics=d, meta=meta), page=A4)


def _labels(fig, ax, axis="x"):
    FigureCanvasAgg(fig).draw()
    lo, hi = ax.get_xlim() if axis == "x" else ax.get_ylim()
    ticks = ax.get_xticklabels() if axis == "x" else ax.get_yticklabels()
    return [t.get_text() for t in ticks
            if t.get_text() and lo <= (t.get_position()[0] if axis == "x" else
                                       t.get_position()[1]) <= hi]


def test_psd_axis_says_counts_with_flat_metadata():
    from bayescal.report.fit_pages import page_data_fit

    flat = page_data_fit(_data_ctx(flat=SUT + REF)).axes[0].get_ylabel()
    assert "counts" in flat and "(m/s)" not in flat
    assert page_data_fit(_data_ctx()).axes[0].get_ylabel() == "PSD ((m/s)²/Hz)"
    mixed = page_data_fit(_data_ctx(flat=SUT)).axes[0].get_ylabel()
    assert "counts" in mixed and "(m/s)" in mixed


def test_flat_inventory_channels_are_marked_as_placeholders():
    import obspy

    from bayescal.io.inventory import placeholder_channels
    from bayescal.io.read import flat_inventory

    st = obspy.read()
    ids = [tr.id for tr in st]
    assert placeholder_channels(flat_inventory(st), ids) == ids
    assert placeholder_channels(obspy.read_inventory(), ids) == []


def test_narrow_band_frequency_axes_carry_several_labels():
    from bayescal.report.fit_pages import page_data_fit

    fig = page_data_fit(_data_ctx(0.125, 0.3333))
    for ax in fig.axes:
        labels = _labels(fig, ax)
        assert len(labels) >= 3, labels
        assert "0.2" in labels and "0.3" in labels


def test_convergence_traces_in_degrees_and_percent():
    from bayescal.report.fit_pages import page_convergence

    rng = np.random.default_rng(1)
    names = ["A:orient_a", "A:orient_b", "B:azimuth_rad", "A:log_gain"]
    trace = np.stack([rng.normal(0.01, 1e-3, (50, 8)), rng.normal(0.0, 1e-3, (50, 8)),
                      rng.normal(1.6, 1e-3, (50, 8)), rng.normal(np.log(761.0), 1e-3, (50, 8))],
                     axis=-1)
    conv = SimpleNamespace(n_steps=500, burn=100)
    per = {n: {"tau": 10.0, "ess": 2000.0, "rhat": 1.001} for n in names}
    summary = {"convergence": {"n_steps": 500, "per_parameter": per, "acceptance": 0.3,
                               "n_walkers": 8, "tau_max": 10.0, "ess_min": 2000.0,
                               "rhat_max": 1.001, "converged": True}}
    post = SimpleNamespace(names=names, trace=trace, convergence=conv,
                           meta=Meta(nominal={"A": {"gain": 750.0}}))
    fig = page_convergence(SimpleNamespace(post=post, summary=summary, page=A4))
    axes = fig.axes[:4]
    assert [a.get_ylabel() for a in axes] == ["deg from start axis", "deg from start axis",
                                              "azimuth (deg)", "gain, % off metadata"]
    ys = [np.concatenate([s[:, 1] for s in a.collections[0].get_segments()]) for a in axes]
    assert np.median(ys[0]) == pytest.approx(np.degrees(0.01), rel=0.05)
    assert np.median(ys[2]) == pytest.approx(np.degrees(1.6), rel=1e-3)
    assert np.median(ys[3]) == pytest.approx(100 * (761 / 750 - 1), abs=0.2)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    for t in fig.texts:                       # captions stay on the page
        box = t.get_window_extent(canvas.get_renderer())
        assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1, t.get_text()


def _diagnosis(n_ch=2, n_b=6):
    edges = np.geomspace(0.125, 0.3333, n_b + 1)
    ones = np.ones((n_b, n_ch))
    base, final = object(), object()
    return SimpleNamespace(
        band_edges=edges, sentences=lambda: ["a finding in words"], before={"mismatch": []},
        ids=[f"XX.SIM.10.BH{i + 1}" for i in range(n_ch)],
        before_common={"misfit": 3 * ones}, after={"misfit": ones},
        ratio_before=(1.01 + 0.02j) * ones, ratio_after=ones.astype(complex),
        base=base, final=final)


def test_diagnosis_page_labels_inside_and_legends_beside_the_data():
    from bayescal.report.diagnosis import build_figure

    fig = build_figure(_diagnosis())
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    page = fig.bbox
    data_axes = [a for a in fig.axes if a.lines]
    assert len(data_axes) == 2
    for ax in data_axes:
        label = ax.yaxis.label.get_window_extent(renderer)
        assert page.x0 <= label.x0 and label.x1 <= page.x1
        assert page.y0 <= label.y0 and label.y1 <= page.y1
        legend = ax.get_legend()
        box = legend.get_window_extent(renderer)
        assert page.x0 <= box.x0 and box.x1 <= page.x1 + 0.5
        assert not box.overlaps(ax.get_window_extent(renderer))   # beside, not on the data
        assert len(legend.get_texts()) <= 2 + 4                   # channels + line styles
        assert len(_labels(fig, ax)) >= 3
