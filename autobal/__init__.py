"""autobal: CasADi models, solvers and studies for rotor balancing devices."""
__version__ = "0.1.0"
