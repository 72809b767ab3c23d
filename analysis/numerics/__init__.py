"""Numerics on a model: solvers, the sources' closed forms, linear models, integrators, fits and rules.

IPOPT in one place (ipopt.py) and C-compiled maps (compiled.py); the statics (statics.py) beside the closed forms
(closed_form.py); the exact and the source's hand linear models (linearize.py, hand_linear.py) with the stability
and frequency analyses on them (stability.py, frequency.py); time responses (simulate.py, RODAS4 in rosenbrock.py);
least squares (least_squares.py) and the fits of the disc and the device (disc_fit.py, device_fit.py) with their
adequacy test (adequacy.py); the design NLP (design.py); the liquid balancer's optimum problems
(liquid_balancer_optimum.py); the rotor with a liquid auto-balancer (rotor.py) and rotor identification
(rotor_identification.py); sampling and sample statistics (sampling.py); the standards' rules (standards.py).

Imports the run infrastructure (analysis/run/), never a study (import-linter contract in pyproject.toml).
"""
