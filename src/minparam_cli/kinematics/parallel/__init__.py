"""Parallel platforms: hexapods and the dodekapod (Dang 2013): inverse and forward kinematics, workspace."""
