"""The success judge NN_judge (paper II, Fig. 2): P(success | response trajectory, environment).

model.py     the judge: config, normalisation, checked entry points; its network from archs/
archs/       the architectures by name (lstm: the paper's, the default; tcn), each with its CasADi export
train.py     training with a validation split, history and Fig. 6-style plot
store.py     <name>.pt + <name>.json, validated loading, compatibility checks
evaluate.py  accuracy, precision, recall, calibration, confusion matrix
casadi_fn.py the judge as a CasADi Function with first derivatives (several backends)
cli.py       `judgeopt train-judge`, `judgeopt test-judge`, model inspection
"""

from importlib import import_module
from typing import Any

#: public name -> the module holding it, imported at first use: importing a light submodule
#: (judge.errors, judge.backends, judge.train_config) must not load torch
_WHERE = {"Judge": "model", "JudgeConfig": "model", "JudgeError": "errors", "TrajectoryError": "errors",
          "JudgeFileError": "store", "IncompatibleJudgeError": "store", "check_compatible": "store",
          "load_judge": "store", "save_judge": "store"}

__all__ = list(_WHERE)


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module 'judgeopt.judge' has no attribute {name!r}")
    return getattr(import_module(f"judgeopt.judge.{_WHERE[name]}"), name)
