"""Base parameter sets: the result record and the routes that produce it."""
