"""`python -m judgeopt`: the command line, as the `judgeopt` command (judgeopt.cli)."""

import sys

from judgeopt.cli import main

sys.exit(main())
