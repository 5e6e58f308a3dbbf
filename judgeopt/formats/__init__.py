"""File formats: what judgeopt writes and reads, in one package that imports only `files`,
`trajectory` and `tasks` (every stage of the pipeline uses it). Every file starts with `format`
and `format_version`, checked by one function (`header.check_header`: an older judgeopt refuses
a newer file by name, with one line).

| file | format | module |
|---|---|---|
| plan JSON (`solve --save-json`): a result with its problem and provenance, computed once per run | judgeopt-plan | `formats.plan` |
| the importer's CSV: recordings read by `import-demos`; plans sent to a robot and datasets exported as demonstrations, by one writer | header row of columns | `formats.table_csv` |
| ROS 2 MCAP (`export`, `solve --export`) | MCAP, ROS 2 messages | `formats.mcap` |
| exporters by name and suffix (the CLI's `--format` and `--out` suffixes read them) | | `formats.exporters` |
| demonstrations (HDF5) | judgeopt-demonstrations | `judgeopt.data.dataset` (header checked here) |
| model files: JSON metadata + torch weights, one writer and one reader for every kind | judgeopt-judge, -generator | `formats.model_files` (used by `judgeopt.judge.store`, `judgeopt.planners.store`) |
| the task frame a plan is exported along ([frame] of a problem file) | | `formats.frame` |
| judge ensembles (a manifest of judges) | judgeopt-judge-ensemble | `judgeopt.judge.ensemble` (header checked here) |
| calibration, trust region | judgeopt-calibration, -trust-region | `judgeopt.verdict.calibration`, `judgeopt.planners.trust_region` |
"""
