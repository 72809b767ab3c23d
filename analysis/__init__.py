"""Solvers and studies on a model (imported as autobal.analysis)."""
