"""``python -m ftc_mj.figures``: the command ``ftc-mj figures`` (:mod:`ftc_mj.cli.figures`) under its older name."""

import sys

from ftc_mj.cli.figures import build_parser, main  # noqa: F401

if __name__ == "__main__":
    sys.exit(main(prog="python -m ftc_mj.figures"))
