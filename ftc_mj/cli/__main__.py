"""``python -m ftc_mj.cli ...``: the ``ftc-mj`` command without its installed script."""

import sys

from ftc_mj.cli.main import main

sys.exit(main())
