"""``python -m ftc_mj.ranking``: the command ``ftc-mj bench`` (:mod:`ftc_mj.cli.bench`).

A script only (nothing imports it): it reaches the command line by name, so that the bench package holds no
import of the layer above it.
"""

import importlib
import sys

if __name__ == "__main__":
    sys.exit(importlib.import_module("ftc_mj.cli.bench").main(prog="python -m ftc_mj.ranking"))
