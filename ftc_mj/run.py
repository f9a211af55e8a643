"""``python -m ftc_mj.run``: the command ``ftc-mj run`` (:mod:`ftc_mj.cli.run`) under its older name."""

import sys

from ftc_mj.cli.run import build_parser, main, metrics_document, metrics_table  # noqa: F401

if __name__ == "__main__":
    sys.exit(main(prog="python -m ftc_mj.run"))
