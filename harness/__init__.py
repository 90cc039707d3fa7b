"""Harness: timed sweeps, statistics and the ``tribench`` command line."""
