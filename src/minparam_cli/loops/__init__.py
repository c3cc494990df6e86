"""Closed kinematic chains: the loop constraints of a spanning tree, the tangent map G from the
actuated joints to every tree joint, states sampled on the constraint manifold, the base set of the
actuated torques τ_a = Gᵀ·Y_tree·φ and the energy route that checks it (docs/methods/closed_chains.md)."""
