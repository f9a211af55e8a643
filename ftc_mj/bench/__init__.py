"""The benchmark: a versioned suite of robots, faults and sensor conditions (:mod:`ftc_mj.bench.suite`) on
which any observer is scored for fault diagnosis and any observer-controller pair for tracking under faults
(:mod:`ftc_mj.bench.score`), the entries named in a bench file (:mod:`ftc_mj.bench.spec`), run as campaigns
(:mod:`ftc_mj.bench.execute`) and reported as a leaderboard (:mod:`ftc_mj.bench.leaderboard`).
``ftc-mj bench`` (:mod:`ftc_mj.cli.bench`) is the command."""
