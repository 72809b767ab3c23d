"""Solvers and studies on a model (imported as autobal.analysis), in three layers.

- ``run/``: run infrastructure (the Result protocol, typed fields, quantities and units, figures, solver options
  and output, progress, interrupts, the executor);
- ``numerics/``: solvers, closed forms, linear models, integrators, fits and the standards' rules on a model;
- ``studies/``: the studies that make an analysis' Result from the numerics.

Each imports only the ones above it in this list (import-linter contract in pyproject.toml).
"""
