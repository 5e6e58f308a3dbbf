"""`judgeopt train-judge`, `judgeopt test-judge` and model inspection.

"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from judgeopt.cli.commands import HELP
from judgeopt.cli.common import (JSON, OVERWRITE, QUIET, CLIError, ExitCode, command_line, names, number, out_option,
                                 positive, seed_option, threads_option)
from judgeopt.files import refuse_overwrite, resolve

from judgeopt.tasks import DEFAULT_TASK, get_task

DEFAULT_MODEL = get_task(DEFAULT_TASK).default_judge


# -- train-judge -----------------------------------------------------------------------------
def cmd_train_judge(args: argparse.Namespace) -> int:
    import numpy as np
    import torch

    from judgeopt.data.dataset import DatasetError, concatenate, load
    from judgeopt.judge.arch_configs import DEFAULT_ARCH
    from judgeopt.judge.data_ranges import env_ranges_in, env_ranges_of, union
    from judgeopt.judge.evaluate import evaluate_judge, judge_inputs
    from judgeopt.judge.model import JudgeConfig, JudgeError
    from judgeopt.files import sha256_file
    from judgeopt.judge.store import IncompatibleJudgeError, model_paths, save_judge
    from judgeopt.judge.train import TrainConfig, train_judge, write_history

    out = Path(args.out)
    if out.suffix in (".pt", ".json"):
        out = out.with_suffix("")
    refuse_overwrite(model_paths(out), args.overwrite)
    init, init_meta = _init_judge(args) if args.init else (None, None)
    args.arch = args.arch or DEFAULT_ARCH  # None until here: an --arch given with --init is refused, even lstm
    given = arch_settings(args)  # a bad --arch or --set before any data is read
    parts = [load(p) for p in args.train]
    try:
        train_ds = concatenate(parts) if len(parts) > 1 else parts[0]
    except DatasetError as exc:
        raise CLIError(f"--train {' '.join(args.train)}: {exc}", ExitCode.BAD_INPUT) from None
    test_ds = load(args.test) if args.test else None
    env_names = args.env_names or tuple(train_ds.env_names)
    missing = [n for n in env_names if n not in train_ds.env_names]
    if missing:
        raise CLIError(f"--env-names {','.join(missing)}: not in {' '.join(args.train)} (it has {','.join(train_ds.env_names)})")
    if test_ds is not None and (test_ds.horizon, test_ds.dt, test_ds.task, test_ds.channels) != (
            train_ds.horizon, train_ds.dt, train_ds.task, train_ds.channels):
        raise CLIError(f"{args.test} (task {test_ds.task}, channels {','.join(test_ds.channels)}, N = {test_ds.horizon}, "
                       f"dt = {test_ds.dt}) does not match {' '.join(args.train)} (task {train_ds.task}, channels "
                       f"{','.join(train_ds.channels)}, N = {train_ds.horizon}, dt = {train_ds.dt})")
    config = JudgeConfig(arch=args.arch, **given, env_names=env_names, horizon=train_ds.horizon,
                         dt=train_ds.dt, channels=train_ds.channels, units=train_ds.units or None)
    tc = TrainConfig(epochs=args.epochs, batch_size=args.batch_size, lr=args.lr, seed=args.seed,
                     input_noise=args.input_noise, with_commands=args.with_commands,
                     invert_labels=args.invert_labels, val_fraction=args.val_fraction, threads=args.threads,
                     progress=not args.quiet)
    try:
        model, result = train_judge(train_ds, test_ds, config, tc, init=init)
    except (JudgeError, IncompatibleJudgeError) as exc:
        raise CLIError(f"--train {' '.join(args.train)}: {exc}", ExitCode.BAD_INPUT) from None
    metrics: dict[str, Any] = {"best_epoch": result.best_epoch, "val_accuracy": result.best["val_accuracy"],
                               "val_loss": result.best["val_loss"], "train_accuracy": result.best["train_accuracy"],
                               "n_train": result.n_train, "n_val": result.n_val}
    if test_ds is not None:
        metrics["test"] = evaluate_judge(model, test_ds, invert_labels=args.invert_labels)
        metrics["test_accuracy"] = metrics["test"]["accuracy"]
        if args.invert_labels:
            metrics["test_true_labels"] = evaluate_judge(model, test_ds)
        if args.with_commands:
            metrics["test_command"] = evaluate_judge(model, test_ds, invert_labels=args.invert_labels, view="command")
    # the most it ever says: with some labels wrong (a lab's), below 1; a p_target above it is out of reach
    x, e = judge_inputs(model, train_ds)
    metrics["p_max_train"] = float(model.predict_proba(x, e).max())
    meta = {
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "command": command_line(),
        "seed": args.seed,
        "task": train_ds.task,
        "invert_labels": bool(args.invert_labels),
        "train_data": {"path": " + ".join(args.train), "sha256": " + ".join(sha256_file(p) for p in args.train),
                       "n": train_ds.n, "success_ratio": train_ds.success_ratio(),
                       "env_names": list(train_ds.env_names),
                       # what the judge has seen, per channel: planning outside it is extrapolation (coverage_notes)
                       "ranges": {c: [float(train_ds.responses[:, :, k].min()), float(train_ds.responses[:, :, k].max())]
                                  for k, c in enumerate(train_ds.channels)},
                       # and per environment variable, over every --train file (and what an --init judge
                       # learnt from): asked about a world outside them, its p is a guess (data_ranges.outside_data)
                       "env_ranges": union(env_ranges_of(train_ds), env_ranges_in(init_meta or {}))},
        "test_data": ({"path": str(args.test), "sha256": sha256_file(args.test), "n": test_ds.n,
                       "success_ratio": test_ds.success_ratio()} if test_ds is not None else None),
        "train_config": result.config,
        **({"init": {"path": str(args.init), "weights_sha256": init_meta["weights_sha256"]}} if init else {}),
        "training_seconds": result.seconds,
        "threads": torch.get_num_threads(),
        "torch_version": torch.__version__,
        "numpy_version": np.__version__,
        "metrics": metrics,
        "selection": "epoch with the best validation accuracy (seeded stratified split of the training set); "
                     "the test set is not used for selection",
    }
    pt, js = save_judge(model, out, meta)
    files = write_history(result, out, title=f"NN_judge {out.name}")
    line = f"wrote {pt} and {js} ({result.seconds:.0f} s): best epoch {result.best_epoch}, " \
           f"validation accuracy {metrics['val_accuracy']:.4f}"
    if test_ds is not None:
        line += f", test accuracy {metrics['test_accuracy']:.4f}"
        if args.invert_labels:
            line += f" (against the inverted labels; {metrics['test_true_labels']['accuracy']:.4f} against the true ones)"
        if args.with_commands:
            line += f"; on the test set's commands {metrics['test_command']['accuracy']:.4f}"
    print(line)
    print(f"highest success probability it gives a training demonstration: {metrics['p_max_train']:.3f}"
          + (" (the direct solve's p_target must lie below it: --p-target / [solver] p_target)"
             if metrics["p_max_train"] < 0.99 else ""))
    print("history: " + ", ".join(str(f) for f in files))
    return 0


def _init_judge(args: argparse.Namespace):
    """The judge --init names, loaded; its architecture is the one trained, so --set and another
    --arch or --env-names would be ignored: refused in one line instead."""
    from judgeopt.files import resolve
    from judgeopt.judge.store import JudgeFileError, load_judge

    try:
        init, meta = load_judge(resolve(args.init))
    except JudgeFileError as exc:
        raise CLIError(f"--init {args.init}: {exc}", ExitCode.BAD_INPUT) from None
    kept = init.config
    shorthands = any(getattr(args, key, None) is not None for key in ARCH_OPTIONS)
    if args.set or shorthands or args.arch not in (None, kept.arch) or (
            args.env_names and tuple(args.env_names) != tuple(kept.env_names)):
        raise CLIError(f"--init {args.init}: its architecture ({kept.arch}) and environment variables "
                       f"({','.join(kept.env_names)}) are kept: drop --arch, --set and --env-names", ExitCode.BAD_INPUT)
    args.arch = kept.arch
    return init, meta


#: the LSTM's options train-judge had before --arch and --set: shorthands for --set FIELD=VALUE
ARCH_OPTIONS = {"lstm_units": "--lstm-units", "fc_units": "--fc-units", "dropout": "--dropout",
                "lstm_dropout": "--lstm-dropout"}


def arch_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The architecture fields given (--set FIELD=VALUE and the shorthands), each parsed as the
    type its dataclass declares; one-line errors for an unknown architecture or field."""
    from dataclasses import fields

    from judgeopt.judge.archs import get_arch
    from judgeopt.judge.model import JudgeError

    try:
        spec = get_arch(args.arch)
    except JudgeError as exc:
        raise CLIError(f"--arch {args.arch}: {exc}") from None
    own = {f.name: f for f in fields(spec.Config)}

    def no_field(flag: str, key: str) -> CLIError:
        return CLIError(f"{flag}: the {spec.name} architecture has no field {key!r} (its fields: {', '.join(own)})")

    given: dict[str, Any] = {}
    for key, flag in ARCH_OPTIONS.items():
        if getattr(args, key, None) is not None:
            if key not in own:
                raise no_field(flag, key)
            given[key] = getattr(args, key)
    parse = {"int": int, "float": float, "bool": lambda v: {"true": True, "false": False}[v.lower()]}
    for item in args.set or []:
        key, sep, text = item.partition("=")
        if not sep:
            first = next(iter(own))
            raise CLIError(f"--set {item!r}: give FIELD=VALUE, e.g. {first}={getattr(spec.Config(), first)}")
        if key not in own:
            raise no_field(f"--set {item}", key)
        kind = str(own[key].type)  # the dataclass's annotation, a string under `from __future__ import annotations`
        try:
            given[key] = parse.get(kind, str)(text)
        except (ValueError, KeyError):
            raise CLIError(f"--set {item}: {key} is {'true or false' if kind == 'bool' else 'a number (' + kind + ')'}"
                           ) from None
    try:
        spec.Config(**given)  # its checks (sizes, dropout ranges) before any data is read
    except JudgeError as exc:
        raise CLIError(f"--arch {spec.name}: {exc}") from None
    return given


# -- test-judge ------------------------------------------------------------------------------
def cmd_test_judge(args: argparse.Namespace) -> int:
    from judgeopt.data.dataset import load
    from judgeopt.judge.evaluate import evaluate_judge, format_metrics
    from judgeopt.judge.store import load_judge

    model_path = resolve(args.judge, (".json",))
    model, meta = load_judge(model_path)
    ds = load(args.data)
    t0 = time.perf_counter()
    m = evaluate_judge(model, ds, view=args.view)
    inverted = bool(meta.get("invert_labels"))
    if inverted:
        m["accuracy_vs_training_target"] = evaluate_judge(model, ds, invert_labels=True, view=args.view)["accuracy"]
    m["seconds"] = time.perf_counter() - t0
    m.update(model=str(model_path), data=str(args.data), view=args.view, invert_labels=inverted, arch=model.config.arch,
             env_names=list(model.config.env_names), focused_data="focus" in ds.meta)
    if args.view == "command" and (ds.commands == ds.responses).all():
        print(f"note: {args.data} stores no command apart from the measured trajectory (recordings): "
              "--view command scores the responses", file=sys.stderr)
    if m["focused_data"]:
        print(f"note: {args.data} was collected with --focus (where a judge was unsure), so this is not the "
              "judge's accuracy on the task: score it on random demonstrations", file=sys.stderr)
    if args.json:
        print(json.dumps(_json_safe(m)))
        return 0
    print(f"{model_path} on {args.data}" + ("'s commands" if args.view == "command" else "")
          + ("  (trained on INVERTED labels: scored against the true ones)" if inverted else ""))
    print(format_metrics(m))
    if inverted:
        print(f"  accuracy against the inverted labels it was trained on: {m['accuracy_vs_training_target']:.4f}")
    return 0


def _json_safe(v: Any) -> Any:
    """NaN (precision of a judge that never says success) as null: strict JSON."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: _json_safe(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_safe(x) for x in v]
    return v


# -- inspect ---------------------------------------------------------------------------------
def inspect_model(path: str | os.PathLike) -> dict[str, Any]:
    """A saved judge's metadata, validated by loading the weights too."""
    from judgeopt.judge.casadi_fn import backends_for
    from judgeopt.judge.data_ranges import describe, env_ranges_in, limit_ranges_in
    from judgeopt.judge.store import load_judge

    model, meta = load_judge(resolve(path, (".json",)))
    n_params = sum(p.numel() for p in model.parameters())
    metrics = meta.get("metrics", {})
    cfg = model.config
    return {
        "path": str(path),
        "arch": cfg.arch,
        "network": cfg.spec.describe(cfg.net),
        "casadi_backends": list(backends_for(cfg)),
        "config": cfg.to_dict(),  # as loaded: a file from before architectures had names reads arch "lstm"
        "parameters": n_params,
        "invert_labels": meta.get("invert_labels", False),
        "val_accuracy": metrics.get("val_accuracy"),
        "test_accuracy": metrics.get("test_accuracy"),
        "best_epoch": metrics.get("best_epoch"),
        "training_seconds": meta.get("training_seconds"),
        "train_data": meta.get("train_data"),
        # what it learnt from (judgeopt.judge.data_ranges): outside these its p is a guess; {} in older files
        "env_ranges": {k: list(v) for k, v in env_ranges_in(meta).items()},
        "limit_ranges": {k: list(v) for k, v in limit_ranges_in(meta).items()},
        "data_ranges": describe(meta),
        "test_data": meta.get("test_data"),
        "command": meta.get("command"),
        "source": meta.get("source"),  # refined judges: the refinement round, and the judge it continued
        "fine_tuned_from": meta.get("fine_tuned_from"),
        "installed_from": meta.get("installed_from"),
        "seed": meta.get("seed"),
        "package_version": meta.get("package_version"),
        "created": meta.get("created"),
        "weights_sha256": meta.get("weights_sha256"),
        "normalization": meta.get("normalization"),
    }


def format_model_info(info: dict[str, Any]) -> str:
    c = info["config"]
    acc = lambda v: "-" if v is None else f"{v:.4f}"  # noqa: E731
    td = info.get("train_data") or {}
    replays = f", {td['planner_outcomes']} replayed plans x{td.get('weight')}" if td.get("planner_outcomes") else ""
    if info["command"]:
        made = f"{info['command']}  (seed {info['seed']}, {(info['training_seconds'] or 0):.0f} s)"
    else:  # a refined judge: the refinement round, and the judge it continued
        made = ", continuing ".join(str(v) for v in (info["source"], info["fine_tuned_from"]) if v)
    return "\n".join([
        f"{info['path']}  (judge, judgeopt {info['package_version']}" + (f", {info['created']})" if info["created"] else ")"),
        f"  network        : {info['arch']}: {info['network']}, {info['parameters']} parameters",
        f"  CasADi         : backends {', '.join(info['casadi_backends'])}",
        f"  reads          : {', '.join(c['channels'])} over N = {c['horizon']} steps of {c['dt']} s; "
        f"env {', '.join(c['env_names'])}" + ("  (trained on INVERTED labels)" if info["invert_labels"] else ""),
        f"  accuracy       : validation {acc(info['val_accuracy'])}, test {acc(info['test_accuracy'])} "
        f"(best epoch {info['best_epoch']})",
        f"  trained on     : {td.get('path')} (" + (f"n = {td['n']}, " if td.get("n") else "")
        + f"sha256 {str(td.get('sha256'))[:12]}...{replays})",
        "  learnt from    : " + (info.get("data_ranges") or "its environment ranges are not recorded (an older file)"),
    ] + ([f"  ranges from    : {td['env_ranges_source']}"] if td.get("env_ranges_source") else [])
      + ([f"  made by        : {made}"] if made else [])
      + ([f"  installed from : {info['installed_from']}"] if info["installed_from"] else []))


def add_judge_commands(subparsers: argparse._SubParsersAction) -> None:
    """Add `train-judge` and `test-judge` to the main parser's subcommands."""
    from judgeopt.judge.train_config import TrainConfig
    t = subparsers.add_parser(
        "train-judge", help=HELP["train-judge"],
        description="Success judge (the paper's LSTM, Fig. 2, Table 2, or another --arch) trained with Adam on the responses; the epoch "
        "with the best accuracy on a validation split of --train is kept, --test is only reported. Writes "
        "OUT.pt, OUT.json (metadata), OUT.history.csv/.json and OUT.accuracy.png.",
        parents=[out_option("STEM", "model path without suffix, e.g. out/my_judge", required=True), OVERWRITE,
                 seed_option(), threads_option(), QUIET])
    t.add_argument("--train", required=True, nargs="+", metavar="FILE",
                   help="training dataset(s) (HDF5; several are concatenated)")
    t.add_argument("--test", metavar="FILE", help="held-out test dataset (HDF5), reported every epoch")
    t.add_argument("--epochs", type=positive, default=TrainConfig.epochs, help="passes over --train")
    t.add_argument("--batch-size", type=positive, default=TrainConfig.batch_size, help="demonstrations per step")
    t.add_argument("--lr", type=number, default=TrainConfig.lr, help="peak learning rate (cosine-annealed)")
    t.add_argument("--input-noise", type=number, default=TrainConfig.input_noise,
                   help="training input noise, in normalisation std units")
    t.add_argument("--val-fraction", type=number, default=0.1, help="share of --train held out for model selection")
    t.add_argument("--env-names", type=names, help="environment variables the judge sees (default: all in --train)")
    t.add_argument("--invert-labels", action="store_true", help="train on 1 - label (paper Table 4 control)")
    t.add_argument("--init", metavar="JUDGE",
                   help="continue training this judge (fine-tuning; give a lower --lr): its architecture, "
                        "environment variables and input normalisation are kept")
    t.add_argument("--with-commands", action="store_true",
                   help="also learn each simulated demonstration from its command, the input planners give the judge")
    from judgeopt.judge.arch_configs import ARCH_CONFIGS, DEFAULT_ARCH, config_fields
    t.add_argument("--arch", metavar="NAME",
                   help=f"network architecture: {', '.join(ARCH_CONFIGS)} (judgeopt/judge/archs/; default {DEFAULT_ARCH})")
    t.add_argument("--set", action="append", metavar="FIELD=VALUE",
                   help="one of the architecture's fields (default: its dataclass's); "
                   + "; ".join(f"{a}: {', '.join(config_fields(a))}" for a in ARCH_CONFIGS))
    t.add_argument("--lstm-units", type=positive, help="--set lstm_units=: units of each of the LSTM layers")
    t.add_argument("--fc-units", type=positive, help="--set fc_units=: units of the feed-forward layers")
    t.add_argument("--dropout", type=number, help="--set dropout=: dropout of the feed-forward layers")
    t.add_argument("--lstm-dropout", type=number, help="--set lstm_dropout=: dropout between the LSTM layers")
    t.set_defaults(func=cmd_train_judge)

    e = subparsers.add_parser(
        "test-judge", help=HELP["test-judge"],
        description="Accuracy, precision, recall, expected calibration error (10 bins) and the confusion matrix.",
        parents=[JSON, threads_option()])
    e.add_argument("--judge", default=DEFAULT_MODEL, metavar="STEM", help="judge model path without suffix")
    e.add_argument("--model", dest="judge", help=argparse.SUPPRESS)  # the name older scripts use
    e.add_argument("--data", required=True, metavar="FILE", help="dataset (HDF5)")
    from judgeopt.judge.views import VIEWS
    e.add_argument("--view", choices=VIEWS, default=VIEWS[0],
                   help="score the judge on the measured trajectories (default) or on the commands, as a planner uses it")
    e.set_defaults(func=cmd_test_judge)


def cmd_train_ensemble(args) -> int:
    from judgeopt.judge.ensemble import EnsembleConfig, train_ensemble

    refuse_overwrite([Path(args.out) / "ensemble.json"], args.overwrite)  # unfinished members resume
    cfg = EnsembleConfig(k=args.k, epochs=args.epochs, seed=args.seed, bootstrap=not args.no_bootstrap, arch=args.arch)
    out = train_ensemble(resolve(args.train), resolve(args.test) if args.test else None, args.out, cfg,
                         threads=args.threads, progress=not args.quiet)
    meta = json.loads((out / "ensemble.json").read_text())
    accs = [m["metrics"].get("test_accuracy") for m in meta["members"]]
    print(f"wrote {out}/ensemble.json ({cfg.k} members; held-out accuracy per member: "
          + ", ".join("-" if a is None else f"{a:.3f}" for a in accs) + ")")
    return 0


def add_ensemble_command(sub) -> None:
    e = sub.add_parser("train-ensemble", help=HELP["train-ensemble"],
                       description="Resumable: finished members are kept; rerun to complete an interrupted run.",
                       parents=[out_option("DIR", "folder (the shipped one is models/judge_ensemble)",
                                           default="out/judge_ensemble"), OVERWRITE, seed_option(), threads_option(),
                                QUIET])
    e.add_argument("--train", default="data/train.h5", metavar="FILE", help="training demonstrations (HDF5)")
    e.add_argument("--test", default="data/test.h5", metavar="FILE", help="held-out demonstrations (HDF5)")
    e.add_argument("--k", type=positive, default=5, help="members")
    e.add_argument("--epochs", type=positive, default=20, help="epochs per member")
    e.add_argument("--no-bootstrap", action="store_true", help="members differ by seed only")
    from judgeopt.judge.arch_configs import ARCH_CONFIGS

    e.add_argument("--arch", choices=tuple(ARCH_CONFIGS), default="lstm", help="each member's architecture (default lstm)")
    e.set_defaults(func=cmd_train_ensemble)
