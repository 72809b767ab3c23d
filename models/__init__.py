"""Physics of balancing devices as CasADi SX graphs (imported as autobal.models)."""
