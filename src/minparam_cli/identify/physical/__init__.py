"""Physically consistent fits (a convex program), payload and drive gains, the motor side."""
