"""The benchmark: a versioned suite of robots, faults and sensor conditions (:mod:`ftc_mj.ranking.suite`) on
which any observer is scored for fault diagnosis and any observer-controller pair for tracking under faults
(:mod:`ftc_mj.ranking.score`), the entries named in a bench file (:mod:`ftc_mj.ranking.entries`), run as campaigns
(:mod:`ftc_mj.ranking.execute`) and reported as a leaderboard (:mod:`ftc_mj.ranking.leaderboard`).
``ftc-mj bench`` (:mod:`ftc_mj.cli.bench`) is the command."""
