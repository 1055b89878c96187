"""Visual features and their interaction matrices."""
