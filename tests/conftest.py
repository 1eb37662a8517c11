"""Shared fixtures: a simulated pair written to disk, one ``bayescal fit`` run
of it that the command-line tests share, and the real data folder."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

#: ../shared/data next to the repository (absent in a user's fresh clone).
SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"

#: The simulated pair's set-up: a SUT turned 3 degrees, one channel tilted,
#: nominal responses exact (orientation fits), coherence 0.99.
SIM_KW = dict(duration=3600.0, fs=10.0, seed=11, coherence=0.99,
              sut_azimuth=(3.0, 93.0, 0.0), sut_dip=(0.0, 0.5, -89.5))
SIM_BAND = (0.03, 1.0)


@pytest.fixture(scope="session")
def sim_pair():
    """The simulated pair (ObsPy objects and truth)."""
    from bayescal.simulate.pair import simulate_pair
    return simulate_pair(**SIM_KW)


@pytest.fixture(scope="session")
def sim_files(sim_pair, tmp_path_factory):
    """The simulated pair written as miniSEED + StationXML; dict of paths."""
    folder = tmp_path_factory.mktemp("simpair")
    return {k: Path(v) for k, v in sim_pair.write(str(folder)).items()}


@pytest.fixture(scope="session")
def both_sensors(sim_files, tmp_path_factory):
    """One miniSEED holding both sensors of the simulated pair (locations 00
    and 10)."""
    import obspy
    st = obspy.read(str(sim_files["sut.mseed"])) + obspy.read(str(sim_files["ref.mseed"]))
    path = tmp_path_factory.mktemp("both") / "both.mseed"
    st.write(str(path), format="MSEED", encoding="FLOAT64")
    return path


@pytest.fixture(scope="session")
def cli_fit(sim_files, both_sensors, tmp_path_factory):
    """One ``bayescal fit`` of the simulated pair, run as a user runs it (a
    subprocess, ``--quiet --no-report``, band ``SIM_BAND``, seed 3), both
    sensors read from one file and chosen by SEED-id patterns. The
    command-line tests share it: ``proc`` (the finished process), ``out``
    (its folder), ``result`` (result.json)."""
    from tests.cli_helpers import read_result, run_fit
    out = tmp_path_factory.mktemp("cli_fit") / "out"
    proc = run_fit("--ref", both_sensors, "--ref-xml", sim_files["ref.xml"],
                   "--sut", both_sensors, "--sut-xml", sim_files["sut.xml"],
                   "--sut-id", "XX.SIM.10.BH?", "--ref-id", "xx.sim.00.*",
                   "--band", *SIM_BAND, "--seed", 3, out=out)
    assert proc.returncode == 0, proc.stderr
    return {"proc": proc, "out": out, "result": read_result(out)}


#: Every test that needs ../shared/data skips with a reason starting so.
REAL_DATA_SKIP = "real data folder"
#: Set (to 1) by CI: with ../shared/data present, a test skipped for want of
#: real data fails the run (a folder renamed, a path mistyped).
REQUIRE_REAL_DATA = "BAYESCAL_REQUIRE_REAL_DATA"


def _real(name):
    path = SHARED_DATA / "real" / name
    if not path.is_dir():
        pytest.skip(f"{REAL_DATA_SKIP} {path} is absent")
    return path


def real_data_skips(reports):
    """The skip reports among ``reports`` that say real data are absent."""
    return [r for r in reports if REAL_DATA_SKIP in str(r.longrepr)]


def pytest_sessionfinish(session, exitstatus):
    """Under :data:`REQUIRE_REAL_DATA`, with ../shared/data present, fail the
    run when a test skipped for want of real data (on the controller only
    under pytest-xdist, which sees every worker's reports)."""
    if os.environ.get(REQUIRE_REAL_DATA) != "1" or not SHARED_DATA.is_dir():
        return
    if hasattr(session.config, "workerinput"):
        return
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    missed = real_data_skips(reporter.stats.get("skipped", [])) if reporter else []
    if missed:
        names = ", ".join(r.nodeid for r in missed)
        reporter.write_line(f"\n{SHARED_DATA} is present but {len(missed)} real-data test(s) "
                            f"skipped: {names}", red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


@pytest.fixture
def cowi_data():
    """Folder of the ASL COWI azimuth set (skips when absent)."""
    return _real("asl_cowi_azimuth")


@pytest.fixture
def huddle_data():
    """Folder of ObsPy's huddle pair (skips when absent)."""
    return _real("obspy_relcal")
