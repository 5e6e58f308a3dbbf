"""Collect random demonstrations in simulation, in parallel, resumably.

Every demonstration i draws its environment (for random sets) and its command from its own
generator, seeded by (seed, i): the data do not depend on how the work is split between
processes or machines, and a resumed collection gives the file an uninterrupted one gives.

Work is split into chunks run through joblib (local processes by default, or any joblib
backend such as a Dask distributed cluster). Each finished chunk is written atomically to
`<out>.partial/`; a rerun of the same command skips the chunks already there, and the final
HDF5 file is written (atomically) only when every chunk is done.
"""

from __future__ import annotations

import itertools
import json
import shutil
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

import judgeopt
from judgeopt.data.dataset import Dataset, DatasetError, load, save
from judgeopt.files import atomic_path, atomic_write
from judgeopt.parallel import run_chunks, worker_cache
from judgeopt.tasks import DEFAULT_TASK, get_task
from judgeopt.trajectory import PlanError


@dataclass(frozen=True)
class CollectionSpec:
    """What to collect for `task`. `grid` given: `per_env` demonstrations at each grid point
    (product of the value lists); otherwise `n` demonstrations with environments uniform in
    `ranges` (default: the task's sampled ranges). `settings`: the task's own settings
    (default: its shipped ones). `randomize`: perturbation name -> (lo, hi), drawn uniformly per
    demonstration (`Task.perturbations`; the command is made for the recorded environment, the
    world differs from it by the draw), from its own generator seeded by (seed, i, 1): a
    collection without it is the one it always was. `focus`: a dataclass with `accepts(command,
    env) -> bool` and a `tries` count (judgeopt.judge.focus.JudgeFocus: the judge is unsure);
    demonstration i then keeps the first of its candidates it accepts (candidate 0 is the
    unfocused draw, candidate k > 0 draws environment and command from (seed, i, 3, k)), or
    its last after `tries`."""

    task: str = DEFAULT_TASK
    seed: int = 0
    n: int = 1000
    grid: dict[str, tuple[float, ...]] | None = None
    per_env: int = 0
    ranges: dict[str, tuple[float, float]] | None = None
    settings: Any = None
    randomize: dict[str, tuple[float, float]] | None = None
    focus: Any = None

    def __post_init__(self) -> None:
        task = get_task(self.task)
        if self.randomize is not None:
            object.__setattr__(self, "randomize", task.check_randomization(self.randomize) or None)
        if self.ranges is None:
            object.__setattr__(self, "ranges", task.env_ranges())
        if self.settings is None:
            object.__setattr__(self, "settings", task.settings())

    @property
    def env_names(self) -> tuple[str, ...]:
        return get_task(self.task).env_names

    @property
    def total(self) -> int:
        if self.grid is None:
            return self.n
        return self.per_env * int(np.prod([len(self.grid[k]) for k in self.env_names]))

    def environment(self, i: int, rng: np.random.Generator) -> dict[str, float]:
        if self.grid is not None:
            points = list(itertools.product(*(self.grid[k] for k in self.env_names)))
            return dict(zip(self.env_names, map(float, points[i // self.per_env])))
        return {k: float(rng.uniform(*self.ranges[k])) for k in self.env_names}

    def world(self, i: int) -> dict[str, float]:
        """Demonstration i's draw of the randomised parameters (its sensor noise is seeded by (seed, i, 2))."""
        rng = np.random.default_rng([self.seed, i, 1])
        return {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in (self.randomize or {}).items()}

    def fingerprint(self) -> str:
        d = asdict(self)
        if d["randomize"] is None:  # what an unfinished collection made before --randomize recorded
            del d["randomize"]
        if d["focus"] is None:  # nor before --focus
            del d["focus"]
        return json.dumps(d, sort_keys=True, default=str)


def _simulator(spec: CollectionSpec):
    """One simulator per worker process, task and settings (building a scene costs ~0.1 s)."""
    key = json.dumps(["collect", spec.task, asdict(spec.settings) if spec.settings is not None else None],
                     sort_keys=True, default=str)
    return worker_cache(key, lambda: get_task(spec.task).simulator(spec.settings))


def run_chunk(spec: CollectionSpec, indices: list[int]) -> dict[str, Any]:
    """Run demonstrations `indices`; bad commands or environments are recorded, not raised."""
    task, sim = get_task(spec.task), _simulator(spec)
    rows: dict[str, list] = {"commands": [], "responses": [], "labels": [], "env": [], "index": [], "randomized": []}
    errors, misses = [], 0
    for i in indices:
        draw = spec.world(i)
        env: dict[str, float] = {}
        try:
            # candidate 0 is the unfocused draw; with a focus, candidate c > 0 comes from (seed, i, 3, c)
            for c in range(spec.focus.tries if spec.focus else 1):
                rng = np.random.default_rng([spec.seed, i] if c == 0 else [spec.seed, i, 3, c])
                env = spec.environment(i, rng)
                plan = task.random_command(rng, env, spec.settings)
                if spec.focus is None or spec.focus.accepts(plan, env):
                    break
            else:
                misses += 1  # out of tries: the last candidate is kept
            if spec.randomize:
                sim.perturb(draw, seed=[spec.seed, i, 2])
            try:
                result = sim.simulate(plan, env)
            finally:
                if spec.randomize:
                    sim.perturb({})
        except (PlanError, ValueError, RuntimeError) as exc:
            errors.append({"index": i, **env, **draw, "error": str(exc)})
            continue
        rows["commands"].append(plan)
        rows["responses"].append(result.response)
        rows["labels"].append(int(result.success))
        rows["env"].append([env[k] for k in spec.env_names])
        rows["index"].append(i)
        rows["randomized"].append([draw[k] for k in draw])
    out = {k: np.array(v) for k, v in rows.items()}
    out["errors"] = errors
    out["focus_misses"] = np.array(misses)
    return out


def _chunks(total: int, size: int) -> list[list[int]]:
    return [list(range(s, min(s + size, total))) for s in range(0, total, size)]


def _save_chunk(folder: Path, k: int, result: dict[str, Any]) -> None:
    with atomic_path(folder / f"chunk_{k:06d}.npz") as tmp, open(tmp, "wb") as fh:
        np.savez(fh, errors=json.dumps(result["errors"]), **{k2: v for k2, v in result.items() if k2 != "errors"})


def _load_chunk(path: Path) -> dict[str, Any]:
    with np.load(path) as z:
        out = {k: z[k] for k in z.files}
    out["errors"] = json.loads(str(out["errors"]))
    return out


def collect(spec: CollectionSpec, out: str | Path, n_jobs: int = -1, scheduler: str | None = None,
            chunk_size: int = 25, progress: bool = True, command: str | None = None) -> Dataset:
    """Collect `spec` into the HDF5 file `out` (resuming from `<out>.partial/` if present)."""
    out = Path(out)
    partial = out.with_name(out.name + ".partial")
    partial.mkdir(parents=True, exist_ok=True)
    spec_file = partial / "spec.json"
    if spec_file.exists() and spec_file.read_text() != spec.fingerprint():
        raise DatasetError(f"{partial} holds an unfinished collection with other settings: "
                           f"rerun that command to finish it, or delete {partial} to start over")
    atomic_write(spec_file, spec.fingerprint())
    chunks = _chunks(spec.total, chunk_size)
    todo = [k for k in range(len(chunks)) if not (partial / f"chunk_{k:06d}.npz").exists()]
    start = time.perf_counter()
    run_chunks([(k, run_chunk, (spec, chunks[k])) for k in todo], lambda k, result: _save_chunk(partial, k, result),
               n_jobs=n_jobs, scheduler=scheduler, progress=progress, desc=f"collect {out.name}", unit="demo",
               sizes={k: len(chunks[k]) for k in todo}, done=spec.total - sum(len(chunks[k]) for k in todo))
    elapsed = time.perf_counter() - start
    parts = [_load_chunk(partial / f"chunk_{k:06d}.npz") for k in range(len(chunks))]
    errors = [e for p in parts for e in p["errors"]]
    task = get_task(spec.task)
    shape = (-1, task.horizon + 1, len(task.channels))
    names = tuple(spec.randomize or ())
    ds = Dataset(
        commands=np.concatenate([p["commands"].reshape(shape) for p in parts]),
        responses=np.concatenate([p["responses"].reshape(shape) for p in parts]),
        labels=np.concatenate([p["labels"].reshape(-1) for p in parts]).astype(np.int64),
        env=np.concatenate([p["env"].reshape(-1, len(spec.env_names)) for p in parts]),
        dt=task.dt, env_names=spec.env_names, task=task.name, channels=task.channel_names, units=task.units,
        index=np.concatenate([p["index"].reshape(-1) for p in parts]),
        randomized=np.concatenate([p["randomized"].reshape(-1, len(names)) for p in parts]) if names else None,
        randomized_names=names,
        meta={
            "seed": spec.seed, "source": "simulation", "package_version": judgeopt.__version__,
            "command": command or "judgeopt.data.collect.collect()", "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "settings": asdict(spec.settings) if spec.settings is not None else None,
            "generator": {"grid": spec.grid, "per_env": spec.per_env, "ranges": None if spec.grid else spec.ranges},
            "errors": errors, "collection_seconds_last_run": round(elapsed, 1),
            **({"randomize": {k: list(v) for k, v in spec.randomize.items()}} if names else {}),
            **({"focus": {**asdict(spec.focus), "misses": int(sum(p.get("focus_misses", 0) for p in parts)),
                          "note": "demonstrations kept where the focus judge was unsure: not a sample of the "
                                  "task's distribution (train on it beside random ones; never test on it)"}}
               if spec.focus is not None else {}),
        },
    )
    save(ds, out)
    shutil.rmtree(partial)
    return load(out)  # what the file holds, validated
