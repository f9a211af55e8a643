"""The command lines' argument parser."""

from __future__ import annotations

import argparse


class ArgumentParser(argparse.ArgumentParser):
    """An ``argparse`` parser whose bad option is one line and exit status 2, as for every other bad input."""

    def error(self, message: str) -> None:
        self.exit(2, f"{self.prog}: error: {message}\n")
