"""What a run leaves on disk: the Rerun recording, and Markdown tables of a run's metrics."""
