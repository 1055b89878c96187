"""Timing and compiling: the set-ups and steps ``redservo bench`` and ``benchmarks/`` time,
``redservo warmup`` and the progress of a first run's compilations."""
