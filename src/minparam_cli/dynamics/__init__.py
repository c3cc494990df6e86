"""Dynamics: the Newton–Euler regressor and Krutikov's projection matrix."""
