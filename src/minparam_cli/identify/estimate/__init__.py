"""Least squares over the streamed factor: the accumulator (factor updates) and the solve with its errors."""
