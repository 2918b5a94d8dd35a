"""rollsim."""
