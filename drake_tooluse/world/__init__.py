"""The truth: the typed scenario, its randomization, the world built from it, the contacts the
tasks' metrics read."""
