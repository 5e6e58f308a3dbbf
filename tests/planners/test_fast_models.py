"""What a fast start (no torch) reads in place of the models: the cache's numpy copy of a generator's
weights (formats.model_files.read_arrays) and the record of a judge's built library
(judge.compiled). Each is used only where it still is what the torch path would load."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from judgeopt.formats.model_files import SOURCE_KEY, arrays_path
from judgeopt.judge.compiled import LibraryRecord, file_digests, installed_versions, read_record, remember
from judgeopt.planners.amortized import AmortizedPlanner, GeneratorArrays
from judgeopt.planners.generator import Generator
from judgeopt.planners.limits import LimitRanges
from judgeopt.planners.problem import Problem
from judgeopt.planners.store import load_generator, load_generator_arrays, save_generator


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("JUDGEOPT_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.mark.parametrize("conditioned", [None, LimitRanges()])
def test_a_saved_generator_plans_the_same_from_its_numpy_copy(tmp_path, cache, conditioned):
    """save_generator leaves the copy; the arrays read from it without torch equal the network's,
    and so do the plans (to the bit: both are the same float32 numbers in float64)."""
    torch.manual_seed(0)
    p = Problem(qdot_max=0.4)
    gen = Generator(p, conditioned=conditioned)
    _, js = save_generator(gen, tmp_path / "g")
    meta = json.loads(js.read_text())
    assert arrays_path(meta["weights_sha256"]).is_file()
    arrays, _ = load_generator_arrays(tmp_path / "g")
    want = gen.arrays()
    for (w, b), (w2, b2) in zip(arrays.weights, want.weights, strict=True):
        assert np.array_equal(w, w2) and np.array_equal(b, b2)
    env = {"y_obj": 0.2, "mu": 2.0}
    assert np.array_equal(AmortizedPlanner(arrays, p).plan(env).as_array(),
                          AmortizedPlanner(gen, p).plan(env).as_array())


def test_a_copy_that_is_missing_damaged_or_of_other_weights_is_not_read(tmp_path, cache):
    """No copy, a copy naming other weights, one that is not an npz, or a .pt replaced after saving:
    None (the torch path reads the .pt, which makes the copy again or says what is wrong)."""
    torch.manual_seed(0)
    p = Problem()
    pt, js = save_generator(Generator(p), tmp_path / "g")
    sha = json.loads(js.read_text())["weights_sha256"]
    copy = arrays_path(sha)
    good = copy.read_bytes()
    copy.unlink()
    assert load_generator_arrays(tmp_path / "g") is None
    load_generator(tmp_path / "g")  # the torch path makes it again
    assert copy.read_bytes() == good and load_generator_arrays(tmp_path / "g") is not None
    with np.load(copy) as npz:
        state = {k: npz[k] for k in npz.files}
    np.savez(copy, **{**state, SOURCE_KEY: np.array("0" * 64)})
    assert load_generator_arrays(tmp_path / "g") is None
    copy.write_bytes(b"not an npz")
    assert load_generator_arrays(tmp_path / "g") is None
    copy.write_bytes(good)
    pt.write_bytes(pt.read_bytes() + b"\0")
    assert load_generator_arrays(tmp_path / "g") is None


def test_arrays_of_the_wrong_shape_are_one_line():
    p = Problem()
    state = {k: v.numpy() for k, v in Generator(p).state_dict().items()}
    state["net.2.weight"] = state["net.2.weight"][:, :3]
    with pytest.raises(ValueError, match=r"^net.2.weight has shape \(150, 3\), the architecture needs \(150, 150\)$"):
        GeneratorArrays.from_state(p, Generator(p).config, None, state)


def _record(tmp_path, source) -> LibraryRecord:
    lib = tmp_path / "lib" / "libjudge.so"
    lib.parent.mkdir(exist_ok=True)
    lib.write_bytes(b"")
    (lib.parent / "complete.json").write_text("{}")
    config = {"arch": "lstm", "env_names": ["y_obj", "mu"], "channels": ["y", "ydot", "f"], "horizon": 30, "dt": 0.05}
    return LibraryRecord("ab" * 32, "l4casadi32", str(lib), "judge", {"x_mean": [0.0] * 3, "x_std": [1.0] * 3,
                         "e_mean": [0.0] * 2, "e_std": [1.0] * 2}, config, installed_versions(), file_digests([source]))


def test_a_library_record_is_read_only_while_what_built_the_library_is_unchanged(tmp_path):
    """A record names the library the torch path would load only while the library is there, the
    versions are the installed ones and every generating source file is unchanged."""
    source = tmp_path / "gen.py"
    source.write_text("x = 1\n")
    record = _record(tmp_path, source)
    remember(tmp_path, record)
    assert read_record(tmp_path, record.weights_sha256, "l4casadi32") == record
    assert read_record(tmp_path, record.weights_sha256, "l4casadi") is None  # another backend's
    source.write_text("x = 2\n")
    assert read_record(tmp_path, record.weights_sha256, "l4casadi32") is None
    source.write_text("x = 1\n")
    old = LibraryRecord(**{**record.__dict__, "versions": {**record.versions, "torch": "0.0"}})
    remember(tmp_path, old)
    assert read_record(tmp_path, record.weights_sha256, "l4casadi32") is None
    remember(tmp_path, record)
    (tmp_path / "lib" / "libjudge.so").unlink()
    assert read_record(tmp_path, record.weights_sha256, "l4casadi32") is None


def test_a_judges_library_is_loaded_once_per_process_and_judges_as_a_fresh_one():
    """A service's worker loads planners for every new environment or limits: the judge's library is
    recalled once, and the reused one gives the fresh one's logits and gradients to the bit."""
    from judgeopt.files import resolve
    from judgeopt.judge.compiled import fast_start
    from judgeopt.planners import loaded
    from judgeopt.planners.problem import load_problem

    methods = ("amortized", "direct")
    chosen = loaded.choose_models(load_problem(resolve("problems/paper_sim.toml")), methods)
    rng = np.random.default_rng(0)
    with fast_start():
        loaded._RECALLED_HERE.clear()
        assert loaded.fast_models(chosen, methods) is not None  # built with torch where no run left its library
        kept, again = loaded.fast_models(chosen, methods)[0].cjudge, loaded.fast_models(chosen, methods)[0].cjudge
        assert again is kept and len(loaded._RECALLED_HERE) == 1
        points = [(0.1 * rng.normal(size=kept.fn.size1_in(0)), 0.1 * rng.normal(size=kept.fn.size1_in(1)))
                  for _ in range(3)]
        used = [kept.value_and_gradient(x, e) for x, e in points * 2]
        loaded._RECALLED_HERE.clear()
        fresh = loaded.fast_models(chosen, methods)[0].cjudge
    assert fresh is not kept
    for (x, e), (z, gx, ge) in zip(points, used[len(points):]):  # the kept one called before, the fresh one not
        z2, gx2, ge2 = fresh.value_and_gradient(x, e)
        assert z == z2 and np.array_equal(gx, gx2) and np.array_equal(ge, ge2)
