"""``python -m ftc_mj.tune``: the command ``ftc-mj tune`` (:mod:`ftc_mj.cli.tune`) under its older name."""

import sys

from ftc_mj.cli.tune import build_parser, main  # noqa: F401

if __name__ == "__main__":
    sys.exit(main(prog="python -m ftc_mj.tune"))
