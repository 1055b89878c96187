"""Robot models with an eye-in-hand camera."""
