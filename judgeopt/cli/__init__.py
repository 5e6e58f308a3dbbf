"""The `judgeopt` command line: one package, one subcommand module per pipeline stage."""

from judgeopt.cli.main import main

__all__ = ["main"]
