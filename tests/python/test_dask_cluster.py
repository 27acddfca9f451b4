"""The study over dask on worker processes that talk TCP, as on a cluster: scenes (dicts) pickled
to the workers, `feedsim` imported in each, results equal to the serial runs; a sweep split into
shards across the workers and merged equals the whole sweep."""

import json
import pathlib
import tomllib

import numpy as np
import pandas as pd
import pytest

import feedsim

distributed = pytest.importorskip("dask.distributed")

C = pathlib.Path(__file__).resolve().parents[2] / "scenes" / "lt50m_C.toml"


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, protocol="tcp://", host="127.0.0.1",
        dashboard_address=None, silence_logs=40,
    )
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def test_runs_on_worker_processes_equal_the_serial_runs(client):
    base = tomllib.loads(C.read_text())

    def peak(f):
        import feedsim as fs  # the worker's own import

        scene = json.loads(json.dumps(base))
        scene["stewart"]["platform"]["mass_kg"] *= f
        r = fs.run(scene, "monolithic", t_end=1.0)
        return f, r.summary["peak_disp_mm"], r.csv

    factors = [0.5, 1.0, 2.0]
    futures = client.map(peak, factors, pure=False)
    remote = client.gather(futures)
    workers = {w for w in client.who_has(futures).values() for w in w}
    assert len(workers) >= 1
    for (f, peak_mm, csv), f_local in zip(remote, factors):
        local = peak(f_local)
        assert (f, peak_mm, csv) == local, f
    assert remote[0][1] != remote[2][1]
    # the work ran in other processes, not this one
    pids = set(client.run(lambda: __import__("os").getpid()).values())
    assert __import__("os").getpid() not in pids and len(pids) == 2


def test_a_sweep_in_shards_on_the_workers_merges_to_the_whole_sweep(client):
    xs = [-1.0, -0.5, 0.0, 0.5, 1.0, 1.5]
    path = str(C)

    def shard(values):
        import feedsim as fs

        return fs.sweep(path, {"x": values, "y": [0.0, 1.0]}, modes=2, jobs=1)

    # points i, i + n, ...: each worker a part of the x axis
    parts = client.gather(client.map(shard, [xs[0::2], xs[1::2]], pure=False))
    merged = pd.concat(parts).sort_values(["x_m", "y_m"]).reset_index(drop=True)
    whole = feedsim.sweep(path, {"x": xs, "y": [0.0, 1.0]}, modes=2, jobs=1).sort_values(["x_m", "y_m"])
    whole = whole.reset_index(drop=True)
    same = [c for c in whole.columns if c not in ("index", "wall_s")]
    assert len(merged) == len(whole) == 12
    pd.testing.assert_frame_equal(merged[same], whole[same], check_exact=True)
    assert np.isfinite(whole["f1_hz"]).all()
