"""rollsim.geometry (under construction)."""
