"""The residual diagnosis: candidate effects scored on the held-out part, the loop, explanations."""
