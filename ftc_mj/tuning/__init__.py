"""Robust gain tuning: CMA-ES over a campaign's population of conditions, with diagnosis constraints
(``ftc-mj tune``). :mod:`.spec` reads a tuning file, :mod:`.optimise` runs the generations and the
held-out check, :mod:`.outcome` writes what a user reads."""
