import sys

from judgeopt.cli.main import main

sys.exit(main())
