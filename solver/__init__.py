"""rollsim.solver (under construction)."""
