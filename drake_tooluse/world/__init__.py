"""The truth: the typed scenario, its randomization, the world built from it, the task's metrics."""
