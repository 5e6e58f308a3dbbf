"""The success judge NN_judge (paper II, Fig. 2): P(success | response trajectory, environment).

model.py     the judge: config, normalisation, checked entry points; its network from archs/
archs/       the architectures by name (lstm: the paper's, the default; tcn), each with its CasADi export
train.py     training with a validation split, history and Fig. 6-style plot
store.py     <name>.pt + <name>.json, validated loading, compatibility checks
evaluate.py  accuracy, precision, recall, calibration, confusion matrix
casadi_fn.py the judge as a CasADi Function with first derivatives (several backends)
cli.py       `judgeopt train-judge`, `judgeopt test-judge`, model inspection
"""

from judgeopt.judge.model import Judge, JudgeConfig, JudgeError, TrajectoryError
from judgeopt.judge.store import IncompatibleJudgeError, JudgeFileError, check_compatible, load_judge, save_judge

__all__ = ["Judge", "JudgeConfig", "JudgeError", "TrajectoryError", "JudgeFileError", "IncompatibleJudgeError",
           "check_compatible", "load_judge", "save_judge"]
