"""How far to trust the fit: σ (uncertainty), essential parameters, quality flags."""
