"""Excitation trajectory design (``minparam excite``): series, criterion, constraints, optimiser."""
