"""The package importable from a clone without installing it (the suite runs these tests too)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
