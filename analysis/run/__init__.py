"""Run infrastructure: what every analysis' run and Result are made of, whatever it computes.

The Result protocol and its writers (result.py), typed Results (fields.py), declared quantities and display units
(quantities.py) over the one unit vocabulary (kinds.py), figures with their captions and axes (figures.py), the
solvers' options (solver_options.py) and where their output goes (solver_output.py), progress bars (progress.py),
interrupts no solver swallows (interrupt.py) and the executor of sweeps and Monte Carlo (executor.py).

Imports neither the numerics nor the studies (import-linter contract in pyproject.toml).
"""
