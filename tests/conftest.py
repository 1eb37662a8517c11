"""Shared fixtures: a simulated pair written to disk, and the real data folder."""
from __future__ import annotations

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


def _real(name):
    path = SHARED_DATA / "real" / name
    if not path.is_dir():
        pytest.skip(f"real data folder {path} is absent")
    return path


@pytest.fixture
def cowi_data():
    """Folder of the ASL COWI azimuth set (skips when absent)."""
    return _real("asl_cowi_azimuth")


@pytest.fixture
def huddle_data():
    """Folder of ObsPy's huddle pair (skips when absent)."""
    return _real("obspy_relcal")
