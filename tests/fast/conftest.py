"""Every test here is of an accelerator: the fast paths on whatever ``FTC_MJ_FAST`` says (a test that compares
with the definitions switches them off itself)."""

import pytest


@pytest.fixture(autouse=True)
def _fast_paths_on(fast_paths):
    """The fast paths on (tests/conftest.py)."""
