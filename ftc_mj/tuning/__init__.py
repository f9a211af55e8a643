"""Robust gain tuning: CMA-ES over a campaign's population of conditions, with diagnosis constraints
(``python -m ftc_mj.tune``). :mod:`.spec` reads a tuning file, :mod:`.optimise` runs the generations and the
held-out check, :mod:`.report` writes what a user reads."""
