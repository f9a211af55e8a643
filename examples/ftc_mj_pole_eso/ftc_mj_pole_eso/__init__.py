"""An example third-party observer for ftc_mj (the docs' plugin tutorial builds it)."""
