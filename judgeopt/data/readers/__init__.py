"""Readers of recorded demonstrations, one module per format, each a plugin as the exporters are
(`judgeopt.formats.exporters`): CSV (`csv`), robomimic-style HDF5 (`hdf5`), LeRobot v3 (`lerobot`)
and ROS 2 bags (`mcap`).

A reader turns one input (a file, a folder, or files merged into one recording) into `RawDemo`s;
`judgeopt.data.recording.check` holds every format to the same rules. What a reader needs beyond
`ImportSpec` (what all formats share) is its own options dataclass, set from its own command-line
flags (`base.Flag`). Which reader reads a path is decided in one place, `registry.reader_for`
(folder content, then suffix, then the file's first bytes, else CSV). Adding a format is a module
with a `Reader` and one entry in `registry.READERS`; `judgeopt import-demos` builds its flags and
checks from that registry. This package's `__init__` imports nothing, so a reader module importing
`base` never runs the registry.
"""
