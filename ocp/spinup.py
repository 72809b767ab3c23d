"""Optimal spin-up of a rotor through its critical speed: the public names of the OCP in one place.

The problem is declared once (:mod:`autobal.ocp.problem`), transcribed by a method
(:mod:`autobal.ocp.transcription`), its starts chosen by a cheap global search
(:mod:`autobal.ocp.search`), solved (:mod:`autobal.ocp.solve`) and every optimum re-simulated
(:mod:`autobal.ocp.simulation`), as rockit separates declaration, method and solver.
"""

from autobal.ocp.problem import OBJECTIVES, PathConstraint, SpinupOcp
from autobal.ocp.search import grid_search, simulate_steps, three_phase
from autobal.ocp.simulation import (
    Trajectory,
    baselines,
    initial_guess,
    ramp_profile,
    resimulate,
    runs,
    simulate_profile,
)
from autobal.ocp.solve import (
    INFEASIBLE,
    Optimum,
    Solver,
    SpinupSolution,
    infeasibility_error,
    ipopt_options,
    optimize,
    resimulated_scores,
    starts,
)
from autobal.ocp.transcription import DirectCollocation, Mesh, MultipleShooting, Nlp, mesh, path_fractions, transcribe

__all__ = ["OBJECTIVES", "PathConstraint", "SpinupOcp", "grid_search", "simulate_steps", "three_phase",
           "Trajectory", "baselines", "initial_guess", "ramp_profile", "resimulate",
           "runs", "simulate_profile", "INFEASIBLE", "Optimum", "Solver", "SpinupSolution",
           "infeasibility_error", "ipopt_options", "optimize", "resimulated_scores", "starts",
           "DirectCollocation", "Mesh", "MultipleShooting", "Nlp", "mesh", "path_fractions", "transcribe"]
