"""Errors that reach the user as one line, without a traceback."""

from __future__ import annotations


class InputError(Exception):
    """Bad input: a scenario file, a field in it, or a command-line value. Exit status 2.

    ``str(error)`` is the one line shown to the user: ``FILE: FIELD: PROBLEM``.
    """

    def __init__(self, file: str, field: str, problem: str):
        self.file = file
        self.field = field
        self.problem = problem
        location = f"{file}: {field}" if field else file
        super().__init__(_one_line(f"{location}: {problem}"))


def _one_line(text: str) -> str:
    """Escape line breaks and other control characters (a YAML key may contain them)."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)
