"""What a reader of recordings is: its flags, its inputs, and how it is called. Kept apart from the
registry so a reader module (and a test's toy reader) imports this without importing every reader.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from judgeopt.data.recording import ImportSpec, RawDemo


@dataclass(frozen=True)
class Flag:
    """One command-line flag of a reader (`judgeopt import-demos`), and the option it sets.

    `parse` turns the flag's text into the option's value, given the shared spec (a key map
    needs the task's channels and the environment names); without it the value is taken as
    argparse's `type` gives it."""

    spelling: str
    #: the field of the reader's options dataclass it sets
    option: str
    #: argparse's help, saying the default
    help: str
    #: what it does, for the one line that refuses it when no input it applies to is given
    does: str
    metavar: str | None = None
    type: Callable[[str], Any] = str
    parse: Callable[[Any, ImportSpec], Any] | None = None
    #: flags of one kind name each other when one is given for the wrong inputs ("map": where values are)
    kind: str = ""

    @property
    def dest(self) -> str:
        return self.spelling.lstrip("-").replace("-", "_")

    def value(self, given: Any, spec: ImportSpec) -> Any:
        return self.parse(given, spec) if self.parse is not None else given


@dataclass(frozen=True)
class Source:
    """One input a reader reads as a unit: a file, a folder, or files merged into one recording
    (CSV `--streams`: `path` is then NAME, the files' common part, and `parts` the files)."""

    path: Path
    parts: tuple[Path, ...] = ()

    def names(self) -> set[str]:
        """What a labels-file row may call it: the name and stem of it and of each of its files."""
        return {n for p in (self.path, *self.parts) for n in (p.name, p.stem)}


@dataclass(frozen=True)
class NoOptions:
    """The options of a reader that has none."""


@dataclass(frozen=True)
class Reader:
    """A format of recordings: how it is recognised, read and configured."""

    name: str
    #: the format, for help ("CSV", "HDF5 (robomimic)")
    title: str
    #: one input, for messages: "no .csv file is given"
    inputs: str
    #: (source, spec, options) -> the demonstrations read and one message per one that could not be;
    #: raises ImportError_ when the input as a whole cannot be read
    read: Callable[[Source, ImportSpec, Any], tuple[list[RawDemo], list[str]]]
    #: its options dataclass (every field with a default), set by `flags`
    options: type = NoOptions
    flags: tuple[Flag, ...] = ()
    #: recognised by suffix (lower case, with the dot) ...
    suffixes: tuple[str, ...] = ()
    #: ... by a folder's content ...
    folder: Callable[[Path], bool] | None = None
    #: ... or, for a file with a suffix no reader claims, by its first bytes
    magic: bytes = b""
    #: the reader of a file nothing else claims
    fallback: bool = False
    #: a bad demonstration skips the whole input (a CSV table is one session, kept or not as a whole)
    whole: bool = False
    #: what to pass instead when every label of an input comes from a done flag (`refuse_done_labels`)
    done_hint: str = ""
    #: groups the paths this reader reads into sources (CSV `--streams`); default: one source per path
    gather: Callable[[Sequence[Path], Any], list[Source]] | None = None

    def claims(self, path: Path) -> bool:
        """By folder content or suffix (what a folder of recordings is listed by)."""
        if path.is_dir():
            return self.folder is not None and self.folder(path)
        return path.suffix.lower() in self.suffixes

    def configure(self, given: Mapping[str, Any], spec: ImportSpec) -> Any:
        """Its options from its flags' values (flag dest -> value; None: not given, the default kept)."""
        return self.options(**{f.option: f.value(given[f.dest], spec) for f in self.flags
                                if given.get(f.dest) is not None})

    def sources(self, paths: Sequence[Path], options: Any) -> list[Source]:
        return self.gather(paths, options) if self.gather is not None else [Source(p) for p in paths]


#: the dense-reward threshold HDF5 and LeRobot both take (one flag, one help, one default)
SUCCESS_THRESHOLD = Flag(
    "--success-threshold", "success_threshold", type=float, metavar="X", does="labels dense rewards",
    help="label dense rewards: success when the largest reward of a demonstration is >= X, in the reward's own "
    "units (default: none; the last value of the success flag, 1 or 0)")
