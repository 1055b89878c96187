"""Placeholder demo (replaced by the reproduction)."""

print("redservo demo")
