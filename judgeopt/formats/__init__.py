"""File formats: what judgeopt writes and reads, in one package. Every file starts with `format`
and `format_version`, checked by one function (`header.check_header`: an older judgeopt refuses
a newer file by name, with one line).

| file | format | module |
|---|---|---|
| plan JSON (`solve --save-json`): a result with its problem and provenance, computed once per run | judgeopt-plan | `formats.plan` |
| the importer's CSV: recordings read by `import-demos`; plans sent to a robot and datasets exported as demonstrations, by one writer | header row of columns | `formats.table_csv` |
| ROS 2 MCAP (`export`, `solve --export`) | MCAP, ROS 2 messages | `formats.mcap` |
| exporters by name and suffix (the CLI's `--format` and `--out` suffixes read them) | | `formats.exporters` |
| demonstrations (HDF5) | judgeopt-demonstrations | `judgeopt.data.dataset` (header checked here) |
| judges, generators, ensembles (JSON metadata + torch weights) | judgeopt-judge, -generator, -judge-ensemble | `judgeopt.judge.store`, `judgeopt.planners.store`, `judgeopt.judge.ensemble` |
| calibration, trust region | judgeopt-calibration, -trust-region | `judgeopt.planners.calibration`, `judgeopt.planners.trust_region` |
"""
