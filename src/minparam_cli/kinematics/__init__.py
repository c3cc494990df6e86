"""Kinematics beside the dynamics pipeline: screws and singular positions, parallel platforms."""
