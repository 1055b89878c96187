"""Figures of runs, comparisons and campaigns, in the house style
(:mod:`redservo.plots.figures.style`; matplotlib is imported lazily where possible)."""
