"""A fit's Result on disk (:mod:`bayescal.result.schema`): what is written is
what is read back, field for field, and a Result is frozen."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from bayescal.result.convergence import Convergence
from bayescal.result.meta import Meta
from bayescal.result.record import Result
from bayescal.result.schema import load, save

META = {"nominal": {"XX.S.00.BHN": {"azimuth_deg": 0.0, "dip_deg": 0.0, "gain": 750.0}},
        "free_response": "gain", "band_hz": [0.05, 1.0], "plugin_weights": None,
        "set_by_prior": {"XX.S.00.BHN:log_gain": {"reason": "pinned", "action": "held at nominal",
                                                  "nominal": 750.0}},
        "multimodal": {"detected": False, "modes": []}, "batch_label": "a",
        "not_a_field": {"kept": True}}


def _result():
    rng = np.random.default_rng(0)
    conv = Convergence(tau=np.array([2.0, 3.0]), ess=np.array([900.0, 1200.0]),
                       rhat=np.array([1.001, 1.004]), acceptance=0.41, n_steps=400,
                       n_walkers=16, burn=100, converged=True)
    return Result(channel_ids=["XX.S.00.BHN"], kinds=["sphere"],
                  vectors=rng.normal(size=(20, 1, 3)), response={"XX.S.00.BHN": rng.normal(size=(20, 3))},
                  samples=rng.normal(size=(20, 2)), names=["a", "b"], log_prob=rng.normal(size=20),
                  convergence=conv, meta=Meta.from_dict(META),
                  channels={"XX.S.00.BHN": {"kind": "sphere", "azimuth_deg": {"median": 1.5}}},
                  orthogonality_deg={}, adequacy={"ok": True},
                  not_estimable={"XX.S.00.BHZ": "no coherence"},
                  diagnostics={"freqs": np.arange(4.0)}, self_noise={"basis": "b"})


def test_meta_round_trip_keeps_nulls_and_unnamed_entries():
    """Every entry comes back as given: a null entry stays null (not
    dropped), an entry the schema does not name is kept, and ``multimodal``
    is left out only where result.json holds it beside meta."""
    m = Meta.from_dict(META)
    assert m.plugin_weights is None and "plugin_weights" in m.to_dict()
    assert m.to_dict() == META
    assert "multimodal" not in m.to_dict(multimodal=False)
    assert m.replace(plugin_weights=[1.0]).to_dict()["plugin_weights"] == [1.0]


def test_saved_result_reads_back_the_same(tmp_path):
    """save then load: the same summary (result.json) and the same arrays;
    the convergence summary is the slowest parameter's figures."""
    r = _result()
    save(r, str(tmp_path))
    back = load(str(tmp_path))
    assert back.summary() == r.summary()
    with open(tmp_path / "result.json") as fh:
        assert json.load(fh) == r.summary()
    for name in ("vectors", "samples", "log_prob"):
        np.testing.assert_array_equal(getattr(back, name), getattr(r, name))
    np.testing.assert_array_equal(back.response["XX.S.00.BHN"], r.response["XX.S.00.BHN"])
    c = r.summary()["convergence"]
    assert (c["ess_min"], c["tau_max"], c["rhat_max"]) == (900.0, 3.0, 1.004)
    assert c["per_parameter"]["b"] == {"tau": 3.0, "ess": 1200.0, "rhat": 1.004}
    assert r.summary()["set_by_prior"] == {"XX.S.00.BHN": {"gain": "pinned"}}
    assert back.meta == r.meta and back.state is None and back.improved is None


def test_result_is_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        _result().meta = Meta()


@pytest.mark.parametrize("schema", ["bayescal.fit/2", "bayescal.cal/1", None])
def test_a_result_of_another_schema_is_refused(tmp_path, schema):
    """A result.json of a later version of the schema, of another kind of
    result, or of none is refused with one message naming the folder and the
    schema (an earlier version would be read)."""
    from bayescal.errors import InputError

    save(_result(), str(tmp_path))
    path = tmp_path / "result.json"
    saved = json.loads(path.read_text())
    saved["schema"] = schema
    path.write_text(json.dumps(saved))
    with pytest.raises(InputError, match=f"{tmp_path}.*schema {schema!r}"):
        load(str(tmp_path))


def test_convergence_figures_one_line_everywhere():
    """The slowest parameter's figures in words, as the console, the reports
    and the NOT CONVERGED line print them: ESS to the draw, R-hat to 1e-4."""
    from bayescal.core.posterior.convergence import not_converged_line

    c = dataclasses.replace(_result().convergence, converged=False).summary()
    assert Convergence.figures(c) == "ESS min 900, R-hat max 1.0040"
    line = not_converged_line(c)
    assert line.startswith("NOT CONVERGED: the sampler stopped at 400 steps")
    assert "(ESS min 900, R-hat max 1.0040)" in line
