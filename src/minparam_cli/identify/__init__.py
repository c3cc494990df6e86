"""Identification from measured joint data: loading, fitting, diagnosis, simulation."""
