"""Serial chains: Plücker screws of the joints, the rank test and singular positions (Glazunov 1985), the nearest feasible twist."""
