"""``python -m ftc_mj.campaign``: the command ``ftc-mj campaign`` (:mod:`ftc_mj.cli.campaign`) under its older
name.

A script only (nothing imports it): it reaches the command line by name, so that the campaign package holds no
import of the layer above it.
"""

import importlib
import sys

if __name__ == "__main__":
    sys.exit(importlib.import_module("ftc_mj.cli.campaign").main(prog="python -m ftc_mj.campaign"))
