"""``python -m ftc_mj.report``: the command ``ftc-mj report`` (:mod:`ftc_mj.cli.report`) under its older name."""

import sys

from ftc_mj.cli.report import build_parser, main  # noqa: F401

if __name__ == "__main__":
    sys.exit(main(prog="python -m ftc_mj.report"))
