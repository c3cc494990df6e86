"""Motions and data made on purpose: trajectories (one Fourier series), simulation, excitation design."""
