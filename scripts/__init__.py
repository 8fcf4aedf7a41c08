"""Command line, one script per figure, benchmarks."""
