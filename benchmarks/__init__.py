"""Ratio benchmarks of autobal against peers, run in one process on this machine."""
