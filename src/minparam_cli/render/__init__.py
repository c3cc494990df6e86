"""Renderers: pure functions from a result (a report dict) to text."""
