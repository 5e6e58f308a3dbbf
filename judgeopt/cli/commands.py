"""Every subcommand of `judgeopt`, in the order `judgeopt --help` lists them: its one-line help and
the function that adds its full parser. Imports nothing heavy.

Why a table: a command's parser is built from its module (cli/planners.py, cli/judge.py, ...), and
those modules import numpy, the tasks and the planners' problem. `judgeopt --help` needs only these
lines, and `judgeopt solve ...` only solve's parser, so main.build_parser builds the parser of the
command typed and lists the others by their line: no other command's module is imported.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Command:
    """A subcommand's help line and its adder: "module:function", called with the subparsers action
    (one function may add several commands, each listed here)."""

    help: str
    adder: str


COMMANDS: dict[str, Command] = {
    "collect": Command("run a task's random demonstrations in simulation and save them labelled",
                   "judgeopt.cli.main:add_collect_command"),
    "tasks": Command('list the tasks judgeopt can plan for',
                   "judgeopt.cli.main:add_tasks_command"),
    "inspect": Command('summarise any file judgeopt writes (dataset, model, plan, evaluation, ...)',
                   "judgeopt.cli.inspect:add_inspect_command"),
    "models": Command('list the shipped models: what each is, and the defaults solve uses',
                   "judgeopt.cli.models:add_models_command"),
    "robots": Command('list the arms judgeopt can simulate and plan for, with their limits',
                   "judgeopt.cli.robots:add_robots_command"),
    "render": Command('replay demonstrations in PyBullet and save GIFs',
                   "judgeopt.cli.main:add_render_command"),
    "plot-data": Command('plot max velocity against max force coloured by label (paper Fig. 13)',
                   "judgeopt.cli.main:add_plot_data_command"),
    "import-demos": Command('import recorded demonstrations (CSV, robomimic-style HDF5, LeRobot v3 or ROS 2 MCAP '
                 'bags) into the dataset format',
                   "judgeopt.cli.recordings:add_recording_commands"),
    "export-demos": Command("write a dataset as one CSV table in the importer's format",
                   "judgeopt.cli.recordings:add_recording_commands"),
    "train-judge": Command('train the success judge NN_judge on a demonstration file',
                   "judgeopt.cli.judge:add_judge_commands"),
    "test-judge": Command('score a trained judge on a dataset',
                   "judgeopt.cli.judge:add_judge_commands"),
    "solve": Command("plan a motion under the problem's limits with the shipped models",
                   "judgeopt.cli.planners:add_planner_commands"),
    "train-generator": Command('train the amortised generator through the frozen judge (eqs. 2-4)',
                   "judgeopt.cli.planners:add_planner_commands"),
    "evaluate": Command("reproduce the paper's tables in simulation (Markdown, CSV, plot)",
                   "judgeopt.cli.evaluate:add_evaluate_commands"),
    "calibrate": Command('fit calibrated success predictions from evaluated (replayed) plans',
                   "judgeopt.cli.evaluate:add_evaluate_commands"),
    "refine": Command('close the loop in simulation: plan, replay, add the outcomes, fine-tune the judge',
                   "judgeopt.cli.refine:add_refine_commands"),
    "fit-trust-region": Command("model the successful demonstrations for the direct solve's trust region ([solver] "
                 'trust_region, [models] trust_model)',
                   "judgeopt.cli.planners:add_trust_region_command"),
    "train-ensemble": Command('train K judges (seeds, bootstrap samples) for pessimistic planning ([models] ensemble, '
                 '[solver] pessimism)',
                   "judgeopt.cli.judge:add_ensemble_command"),
    "export": Command('write a saved plan (solve --save-json) as CSV or ROS 2 MCAP for a robot',
                   "judgeopt.cli.export:add_export_commands"),
    "serve": Command('answer plan requests over HTTP (the models loaded once per worker)',
                   "judgeopt.cli.serve:add_serve_command"),
}
#: each command's help line, as its adder passes it to add_parser
HELP = {name: c.help for name, c in COMMANDS.items()}
