"""What a run's results say: metrics, and fault diagnosis (detection, isolation, estimation)."""
