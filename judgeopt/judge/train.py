"""Training NN_judge (paper IV-B-1): Adam, binary cross-entropy, dropout, seeded.

Model selection differs from the paper on purpose: the paper reports the "maximum accuracy
rate" over epochs on the TEST set, which picks the epoch on the data it is scored on. Here
a seeded, label-stratified validation split (default 10 %) is carved from the training set,
the epoch with the best validation accuracy is kept, and the test set is only reported.
"""

from __future__ import annotations

import copy
import json
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import nn

from judgeopt.data.dataset import Dataset, concatenate
from judgeopt.judge.model import Judge, JudgeConfig, JudgeError, select_env
from judgeopt.judge.evaluate import judge_inputs
from judgeopt.judge.train_config import TrainConfig

if TYPE_CHECKING:
    from matplotlib.figure import Figure



def with_command_views(ds: Dataset) -> Dataset:
    """`ds` followed by its command view: every demonstration whose command differs from its
    response once more, with the command as its input and the same label. Recordings (commands
    equal to responses) have no second view: a one-line JudgeError when none has one."""
    differ = np.any(ds.commands != ds.responses, axis=(1, 2))
    if not differ.any():
        raise JudgeError("no demonstration here has a command apart from its response (recordings store the "
                         "measured trajectory as both): train without --with-commands")
    twins = ds.subset(differ)
    return concatenate([ds, replace(twins, responses=twins.commands)])


@dataclass
class TrainResult:
    history: list[dict[str, float]]
    best_epoch: int
    best: dict[str, float]
    seconds: float
    n_train: int
    n_val: int
    n_test: int
    config: dict[str, Any] = field(default_factory=dict)


def stratified_split(labels: np.ndarray, fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(train indices, validation indices), `fraction` of each class to validation."""
    rng = np.random.default_rng(seed)
    val = []
    for c in np.unique(labels):
        idx = np.flatnonzero(labels == c)
        rng.shuffle(idx)
        val.append(idx[:int(round(fraction * len(idx)))])
    v = np.sort(np.concatenate(val)) if val else np.zeros(0, int)
    t = np.setdiff1d(np.arange(len(labels)), v)
    return t, v


def split_minimum(fraction: float) -> int:
    """The fewest demonstrations of a class for which `stratified_split` puts at least one in
    validation and leaves at least one to train on (round(fraction n) >= 1 and < n)."""
    n = 2
    while not 1 <= int(round(fraction * n)) < n:
        n += 1
    return n


def check_split(labels: np.ndarray, fraction: float) -> None:
    """Refuse a training set too small for its validation split: a class with no validation
    demonstration gives a validation accuracy of nan (or of one class only) and an arbitrary epoch."""
    labels = np.asarray(labels)
    counts = {"successes": int(np.sum(labels == 1)), "failures": int(np.sum(labels == 0))}
    need = split_minimum(fraction)
    if min(counts.values()) >= need:
        return
    fewest = min(counts.values())
    other = next((f for f in (0.3, 0.4, 0.45) if fraction < f and split_minimum(f) <= fewest), None)
    s, f = counts["successes"], counts["failures"]
    raise JudgeError(f"{len(labels)} demonstrations ({s} success{'es' * (s != 1)}, {f} failure{'s' * (f != 1)}) "
                     f"are too few for a validation split of {fraction:g}: each class needs at least {need} "
                     f"demonstrations (one or more to validate on, one or more to train on); add demonstrations"
                     + (f" or raise --val-fraction to {other:g}" if other is not None else
                        "" if fewest >= 2 else " (at least 2 per class at any --val-fraction)"))


def _tensors(model: Judge, ds: Dataset, invert: bool, view: str = "response"
             ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    x, e = model.check_inputs(*judge_inputs(model, ds, view))
    y = (1 - ds.labels) if invert else ds.labels
    return (torch.as_tensor(x, dtype=torch.float32), torch.as_tensor(e, dtype=torch.float32),
            torch.as_tensor(y, dtype=torch.float32))


@torch.no_grad()
def _score(model: Judge, data: tuple[torch.Tensor, torch.Tensor, torch.Tensor], batch: int) -> tuple[float, float]:
    """(accuracy, mean BCE) in eval mode."""
    x, e, y = data
    if not len(y):
        return float("nan"), float("nan")
    model.eval()
    logits = torch.cat([model(x[i:i + batch], e[i:i + batch]) for i in range(0, len(y), batch)])
    loss = nn.functional.binary_cross_entropy_with_logits(logits, y).item()
    acc = ((logits >= 0).float() == y).float().mean().item()
    return acc, loss


def train_judge(train_ds: Dataset, test_ds: Dataset | None, config: JudgeConfig | None = None,
                tc: TrainConfig | None = None, init: Judge | None = None) -> tuple[Judge, TrainResult]:
    """Train on train_ds (minus a validation split); returns the model of the best
    validation epoch (eval mode) and the per-epoch history (train/val/test accuracy).

    `init`: fine-tune a copy of this judge (its architecture and input normalisation are
    kept, so its CasADi build and generators stay comparable) instead of starting afresh."""
    tc = tc or TrainConfig()
    if init is not None:
        config = init.config
    config = config or JudgeConfig(horizon=train_ds.horizon, dt=train_ds.dt)
    if config.horizon != train_ds.horizon or abs(config.dt - train_ds.dt) > 1e-12:
        config = JudgeConfig(**{**config.to_dict(), "horizon": train_ds.horizon, "dt": train_ds.dt})
    if tc.threads:
        torch.set_num_threads(tc.threads)
    torch.manual_seed(tc.seed)
    np.random.seed(tc.seed)
    if len(np.unique(train_ds.labels)) < 2:
        raise JudgeError("the training set holds only one class: nothing to learn")
    check_split(train_ds.labels, tc.val_fraction)

    tr_idx, va_idx = stratified_split(train_ds.labels, tc.val_fraction, tc.seed)
    train_part, val_part = train_ds.subset(tr_idx), train_ds.subset(va_idx)
    if tc.with_commands:  # after the split, so that no demonstration's two views fall on both sides
        train_part, val_part = with_command_views(train_part), with_command_views(val_part)
    if init is not None:
        model = copy.deepcopy(init).float()
    else:
        model = Judge(config)
        model.fit_normalization(train_part.responses, select_env(train_part.env, train_part.env_names,
                                                                 config.env_names))
    tr = _tensors(model, train_part, tc.invert_labels)
    va = _tensors(model, val_part, tc.invert_labels)
    te = _tensors(model, test_ds, tc.invert_labels) if test_ds is not None else None
    tr_eval = tr
    if tc.train_eval_max and len(tr[2]) > tc.train_eval_max:
        pick = torch.as_tensor(np.sort(np.random.default_rng(tc.seed + 1).choice(len(tr[2]), tc.train_eval_max,
                                                                                  replace=False)))
        tr_eval = (tr[0][pick], tr[1][pick], tr[2][pick])
    te_true = (te[0], te[1], torch.as_tensor(test_ds.labels, dtype=torch.float32)) if te is not None else None
    te_cmd = _tensors(model, test_ds, tc.invert_labels, "command") if te is not None and tc.with_commands else None

    opt = torch.optim.Adam(model.parameters(), lr=tc.lr, weight_decay=tc.weight_decay)
    loss_fn = nn.BCEWithLogitsLoss()
    steps = tc.epochs * ((len(tr[2]) + tc.batch_size - 1) // tc.batch_size)
    sched = None
    if tc.schedule == "cosine":
        sched = torch.optim.lr_scheduler.LambdaLR(
            opt, lambda k: tc.lr_final + (1 - tc.lr_final) * 0.5 * (1 + np.cos(np.pi * min(k, steps) / steps)))
    gen = torch.Generator().manual_seed(tc.seed)
    history: list[dict[str, float]] = []
    best_key, best_state, best_epoch = None, None, 0
    t0 = time.perf_counter()
    bar = None
    if tc.progress:
        from tqdm import tqdm
        bar = tqdm(total=tc.epochs, desc="train judge", unit="epoch")
    n = len(tr[2])
    for epoch in range(1, tc.epochs + 1):
        model.train()
        perm = torch.randperm(n, generator=gen)
        total, count = 0.0, 0
        for i in range(0, n, tc.batch_size):
            b = perm[i:i + tc.batch_size]
            opt.zero_grad(set_to_none=True)
            xb, eb = tr[0][b], tr[1][b]
            if tc.input_noise:
                xb = xb + tc.input_noise * model.x_std * torch.randn(xb.shape, generator=gen)
                eb = eb + tc.input_noise * model.e_std * torch.randn(eb.shape, generator=gen)
            loss = loss_fn(model(xb, eb), tr[2][b])
            loss.backward()
            if tc.grad_clip:
                nn.utils.clip_grad_norm_(model.parameters(), tc.grad_clip)
            opt.step()
            if sched is not None:
                sched.step()
            total += loss.item() * len(b)
            count += len(b)
        row = {"epoch": epoch, "lr": opt.param_groups[0]["lr"], "train_loss_running": total / count}
        row["train_accuracy"], row["train_loss"] = _score(model, tr_eval, tc.eval_batch)
        row["val_accuracy"], row["val_loss"] = _score(model, va, tc.eval_batch)
        if te is not None:
            row["test_accuracy"], row["test_loss"] = _score(model, te, tc.eval_batch)
            if tc.invert_labels:
                row["test_accuracy_true_labels"] = _score(model, te_true, tc.eval_batch)[0]
            if te_cmd is not None:
                row["test_command_accuracy"] = _score(model, te_cmd, tc.eval_batch)[0]
        row["seconds"] = time.perf_counter() - t0
        history.append(row)
        key = (row["val_accuracy"], -row["val_loss"])
        if best_key is None or key > best_key:
            best_key, best_epoch = key, epoch
            best_state = copy.deepcopy(model.state_dict())
        if bar is not None:
            bar.update(1)
            bar.set_postfix(train=f"{row['train_accuracy']:.3f}", val=f"{row['val_accuracy']:.3f}",
                            test=f"{row.get('test_accuracy', float('nan')):.3f}", best=best_epoch)
    if bar is not None:
        bar.close()
    model.load_state_dict(best_state)
    model.eval()
    result = TrainResult(history=history, best_epoch=best_epoch, best=dict(history[best_epoch - 1]),
                         seconds=time.perf_counter() - t0, n_train=len(tr_idx), n_val=len(va_idx),
                         n_test=test_ds.n if test_ds is not None else 0, config=asdict(tc))
    return model, result


def write_history(result: TrainResult, prefix: str | Path, title: str = "NN_judge") -> list[Path]:
    """`<prefix>.history.csv`, `<prefix>.history.json` and `<prefix>.accuracy.png`
    (train/validation/test accuracy per epoch, like paper Fig. 6)."""
    from judgeopt.files import atomic_write, save_figure
    from judgeopt.formats.table_csv import write_records

    prefix = Path(prefix)
    csv_path = prefix.with_name(prefix.name + ".history.csv")
    json_path = prefix.with_name(prefix.name + ".history.json")
    png_path = prefix.with_name(prefix.name + ".accuracy.png")
    write_records(csv_path, result.history)
    atomic_write(json_path, json.dumps({"best_epoch": result.best_epoch, "best": result.best,
                                        "seconds": result.seconds, "train_config": result.config,
                                        "history": result.history}, indent=1) + "\n")
    save_figure(plot_history(result, title), png_path)
    return [csv_path, json_path, png_path]


def plot_history(result: TrainResult, title: str = "NN_judge") -> Figure:
    """Train/validation/test accuracy per epoch and the epoch kept (paper Fig. 6)."""
    from matplotlib.figure import Figure

    ep = [r["epoch"] for r in result.history]
    fig = Figure(figsize=(6, 4))
    ax = fig.subplots()
    keys = {k for row in result.history for k in row}
    for key, label in (("train_accuracy", "training"), ("val_accuracy", "validation"), ("test_accuracy", "test")):
        if key in keys:
            ax.plot(ep, [100 * r[key] for r in result.history], label=label)
    ax.axvline(result.best_epoch, color="grey", ls=":", label=f"kept (best validation, epoch {result.best_epoch})")
    ax.set_xlabel("epoch")
    ax.set_ylabel("accuracy rate [%]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    fig.tight_layout()
    return fig
