"""`nlmode.study` on a Dask LocalCluster (2 worker processes) against the local
thread pool and `host study`'s results.csv."""
import pathlib
import subprocess

import pytest
from conftest import HOST, import_nlmode

nlmode = import_nlmode()
distributed = pytest.importorskip("dask.distributed")
import pandas as pd  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parent.parent
STUDY = REPO / "examples" / "study_lhs.toml"  # 200 lhs samples of case (a) by nlmode


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as c:
        yield c


def test_200_samples_on_two_workers_equal_the_local_study_and_host_study(client, tmp_path):
    local = nlmode.study(STUDY)
    assert len(local) == 200
    dask = nlmode.study(STUDY, client=client, batch_size=25)
    pd.testing.assert_frame_equal(dask, local, check_exact=True)
    subprocess.run(
        [str(HOST), "study", str(STUDY), "-o", str(tmp_path)],
        check=True,
        capture_output=True,
    )
    pd.testing.assert_frame_equal(nlmode.read_results(tmp_path / "results.csv"), local, check_exact=True)
    # the default batch size, and the study kept by the workers (cached: same rows)
    pd.testing.assert_frame_equal(nlmode.study(STUDY, client=client), local, check_exact=True)


def test_reference_subset_rows_on_the_workers_equal_the_local_ones(client):
    study = {
        "design": "grid",
        "reference_subset": 2,
        "parameter": [{"key": "excitation.voltage_v", "values": [2.0, 5.0, 10.0]}],
    }
    local = nlmode.study(study)
    dask = nlmode.study(study, client=client, batch_size=1)
    pd.testing.assert_frame_equal(dask, local, check_exact=True)
    assert len(local.attrs["reference"]) == 2
    pd.testing.assert_frame_equal(dask.attrs["reference"], local.attrs["reference"], check_exact=True)


def test_bad_batch_size_is_refused(client):
    with pytest.raises(nlmode.ScenarioError, match="batch_size"):
        nlmode.study(STUDY, client=client, batch_size=0)
