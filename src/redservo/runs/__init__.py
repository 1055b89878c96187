"""Run directories: the files a run writes and reads back, its provenance, replays,
re-plots and summary tables."""
