"""Random commands, the dataset file format, and resumable parallel collection."""

import json
from dataclasses import replace

import h5py
import numpy as np
import pytest

from judgeopt.data import dataset as D
from judgeopt.data.collect import CollectionSpec, _chunks, _save_chunk, collect, run_chunk
from judgeopt.tasks.scoop.commands import RandomCommandConfig, random_command


def test_random_commands_are_seeded_and_plausible():
    cfg = RandomCommandConfig()
    a = [random_command(np.random.default_rng([7, i]), 0.19) for i in range(50)]
    b = [random_command(np.random.default_rng([7, i]), 0.19) for i in range(50)]
    assert all(np.array_equal(p.as_array(), q.as_array()) for p, q in zip(a, b))
    for p in a:
        assert p.horizon == cfg.horizon and p.dt == cfg.dt
        assert p.y[0] == pytest.approx(cfg.q0) and p.ydot[0] == 0.0 and p.ydot[-1] == 0.0
        assert np.abs(p.ydot).max() <= cfg.max_speed
        assert cfg.force[0] <= p.f.min() and p.f.max() <= cfg.force[1]
        assert np.all(np.diff(p.y) >= -1e-9)  # forward only
        assert abs(p.y[-1] - 0.19) <= 0.12 + 1e-9
    assert len({round(p.y[-1], 6) for p in a}) == 50  # varied


def _tiny_dataset(n=6, horizon=4):
    rng = np.random.default_rng(0)
    return D.Dataset(rng.normal(size=(n, horizon + 1, 3)), rng.normal(size=(n, horizon + 1, 3)),
                     rng.integers(0, 2, n), rng.uniform(size=(n, 2)), 0.05, ("y_obj", "mu"),
                     meta={"seed": 3, "command": "test", "source": "test"})


def test_dataset_round_trip(tmp_path):
    ds = _tiny_dataset()
    D.save(ds, tmp_path / "d.h5")
    back = D.load(tmp_path / "d.h5")
    assert np.array_equal(back.commands, ds.commands) and np.array_equal(back.labels, ds.labels)
    assert back.env_names == ("y_obj", "mu") and back.dt == 0.05 and back.horizon == 4
    assert back.meta["seed"] == 3 and back.meta["command"] == "test"
    assert not list(tmp_path.glob("*.tmp"))  # atomic write leaves no temporary file


def test_bad_dataset_files_get_clear_errors(tmp_path):
    with pytest.raises(D.DatasetError, match="no such file"):
        D.load(tmp_path / "missing.h5")
    (tmp_path / "junk.h5").write_text("not hdf5")
    with pytest.raises(D.DatasetError, match="not a readable HDF5"):
        D.load(tmp_path / "junk.h5")
    with h5py.File(tmp_path / "other.h5", "w") as h:
        h.attrs["format"] = "something-else"
    with pytest.raises(D.DatasetError, match="not a judgeopt demonstration file"):
        D.load(tmp_path / "other.h5")
    D.save(_tiny_dataset(), tmp_path / "d.h5")
    with h5py.File(tmp_path / "d.h5", "a") as h:
        del h["labels"]
    with pytest.raises(D.DatasetError, match=r"missing arrays \['labels'\]"):
        D.load(tmp_path / "d.h5")
    D.save(_tiny_dataset(), tmp_path / "n.h5")
    with h5py.File(tmp_path / "n.h5", "a") as h:
        h["responses"][0, 0, 0] = np.nan
    with pytest.raises(D.DatasetError, match="NaN"):
        D.load(tmp_path / "n.h5")
    with pytest.raises(D.DatasetError, match="labels must be 0"):
        D.Dataset(np.zeros((2, 3, 3)), np.zeros((2, 3, 3)), np.array([0, 2]), np.zeros((2, 2)), 0.05, ("y_obj", "mu"))


SPEC = CollectionSpec(seed=11, n=6)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "ref.h5"
    return collect(SPEC, out, n_jobs=1, chunk_size=2, progress=False)


def test_collection_writes_a_complete_documented_file(reference, tmp_path):
    assert reference.n == 6 and reference.horizon == 30
    assert list(reference.index) == list(range(6))
    m = reference.meta
    assert m["seed"] == 11 and m["source"] == "simulation" and m["package_version"]
    assert reference.task == "scoop" and reference.channels == ("y", "ydot", "f")
    assert m["settings"]["controller"]["selection"] == [1.0, 1.0, 0.1, 1.0, 1.0, 1.0]
    assert m["generator"]["ranges"]["mu"] == [1.0, 3.0]
    assert ((0.10 <= reference.env[:, 0]) & (reference.env[:, 0] <= 0.28)).all()


def test_collection_is_the_same_in_parallel(reference, tmp_path):
    par = collect(SPEC, tmp_path / "par.h5", n_jobs=2, chunk_size=1, progress=False)
    assert np.array_equal(par.commands, reference.commands) and np.array_equal(par.labels, reference.labels)
    assert np.array_equal(par.responses, reference.responses)


def test_interrupted_collection_resumes_without_loss_or_repeat(reference, tmp_path):
    out = tmp_path / "resumed.h5"
    partial = tmp_path / "resumed.h5.partial"
    partial.mkdir()
    (partial / "spec.json").write_text(SPEC.fingerprint())
    chunks = _chunks(SPEC.total, 2)
    _save_chunk(partial, 1, run_chunk(SPEC, chunks[1]))  # as if stopped after the second chunk
    resumed = collect(SPEC, out, n_jobs=1, chunk_size=2, progress=False)
    assert list(resumed.index) == list(range(6))
    assert np.array_equal(resumed.responses, reference.responses)
    assert not partial.exists()


def test_resuming_with_other_settings_is_refused(tmp_path):
    partial = tmp_path / "x.h5.partial"
    partial.mkdir()
    (partial / "spec.json").write_text(replace(SPEC, seed=12).fingerprint())
    with pytest.raises(D.DatasetError, match="unfinished collection with other settings"):
        collect(SPEC, tmp_path / "x.h5", n_jobs=1, progress=False)


def test_bad_demonstrations_are_recorded_and_collection_goes_on():
    spec = CollectionSpec(seed=1, n=3, ranges={"y_obj": (0.10, 0.28), "mu": (6.0, 7.0)})  # mu beyond the scene
    out = run_chunk(spec, [0, 1, 2])
    assert len(out["labels"]) == 0 and len(out["errors"]) == 3
    assert "mu" in out["errors"][0]["error"] and "range" in out["errors"][0]["error"]


def test_a_command_that_cannot_be_made_is_recorded_with_its_own_environment(monkeypatch):
    from judgeopt.tasks import get_task
    from judgeopt.trajectory import PlanError

    task = get_task("scoop")
    made = task.random_command

    def failing_once(rng, env, settings=None):
        if env["mu"] > 2.0:  # decided by the environment drawn, so the record can be checked against it
            raise PlanError("no command here")
        return made(rng, env, settings)

    monkeypatch.setattr(task, "random_command", failing_once)
    spec = CollectionSpec(seed=1, n=4)
    out = run_chunk(spec, [0, 1, 2, 3])
    envs = [spec.environment(i, np.random.default_rng([1, i])) for i in range(4)]
    failed = [i for i, e in enumerate(envs) if e["mu"] > 2.0]
    assert 0 < len(failed) < 4
    assert [e["index"] for e in out["errors"]] == failed
    assert all(e["mu"] == envs[e["index"]]["mu"] for e in out["errors"])
    assert list(out["index"]) == [i for i in range(4) if i not in failed]


@pytest.mark.slow
def test_collection_on_a_local_dask_cluster(reference, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        ds = collect(SPEC, tmp_path / "dask.h5", scheduler=cluster.scheduler_address, chunk_size=2, progress=False)
    assert np.array_equal(ds.responses, reference.responses) and np.array_equal(ds.labels, reference.labels)
    assert json.dumps(ds.meta["seed"]) == "11"
