"""Optimal control problems (imported as autobal.ocp)."""
