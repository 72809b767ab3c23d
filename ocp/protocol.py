"""The spin-up model protocol: what the shared pipeline (:mod:`autobal.ocp.transcription`, :mod:`autobal.ocp.solve`,
:mod:`autobal.ocp.simulation`) takes from a problem, written down once.

Two problem classes implement it: the Jeffcott rotor's :class:`autobal.ocp.problem.SpinupOcp` (Pashkov (2010),
Eq. (2)) and the modal (ROSS) rotor's :class:`autobal.ocp.modal.ModalSpinupOcp`.  A new spin-up model is a dataclass
with these members (most come from :class:`autobal.ocp.problem.Dimensionless`, given the SI members and ``Om``); the
pipeline finds them on the problem itself, there is no registry.

Inside, every problem is dimensionless: time tau = Om t, speed nu = omega/Om, acceleration a* = alpha/Om^2, the
control u = alpha/alpha_max piecewise constant per interval, a state q of ``nx`` components with the speed nu at
``speed_index``, and ``n_extra`` decision variables v beside the trajectory (the epigraph level, or the final time
over the horizon).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import casadi as ca
import numpy as np

if TYPE_CHECKING:  # the problem classes implement the protocol: the pipeline below them never imports them
    from autobal.ocp.problem import PathConstraint

#: the results.json suffix of a peak by the problem's ``deflection_unit``: delta/e for the Jeffcott rotor (Pashkov
#: (2010), Eq. (2)), m for the modal (ROSS) rotor (the largest whirl radius over its nodes, 0-peak)
PEAK_KEY = {"1": "over_e", "m": "m"}


@runtime_checkable
class SpinupProblem(Protocol):
    """A spin-up problem as the transcription, the solver and the re-simulation read it (SI members in rad/s, rad/s^2,
    s; the dimensionless ones as the module says)."""

    # ---- what :func:`autobal.ocp.transcription.transcribe` reads ----------------------------------------------------
    objective: str
    """"peak_deflection", "peak_unbalance", "integrated_deflection" or "min_time" (the free final time)."""
    alpha_max: float
    """The acceleration limit, rad/s^2 (u = alpha/alpha_max)."""
    jerk_max: float | None
    """Bound on the change of alpha between control intervals, rad/s^3 (None: none)."""
    jerk_penalty: float
    """Weight of sum (Delta u)^2 in the objective (0: none)."""
    jerk_variation: float
    """Weight of the smoothed total variation of u in the objective (0: none)."""
    p: list[float] | tuple
    """The parameters of :meth:`rhs` (its third argument)."""

    @property
    def nx(self) -> int:
        """Number of states of the model."""

    @property
    def speed_index(self) -> int:
        """Where the speed nu = omega/Om sits in the state."""

    @property
    def n_extra(self) -> int:
        """Extra decision variables v: 1 (the epigraph level, or the final time over the horizon) or 0."""

    @property
    def free_time(self) -> bool:
        """Whether the final time is free (the ``min_time`` objective): v_0 scales the horizon's intervals."""

    @property
    def Om(self) -> float:
        """The time scale, 1/s: tau = Om t."""

    @property
    def tau_h(self) -> float:
        """The horizon (deadline), tau (its upper bound when the time is free)."""

    @property
    def tau_s(self) -> float:
        """The settling window held at the final speed after the horizon, tau."""

    @property
    def nuf(self) -> float:
        """The final speed omega_final/Om."""

    @property
    def a_max(self) -> float:
        """The acceleration limit alpha_max/Om^2."""

    @property
    def u_min(self) -> float:
        """Lower bound of the control u (-1, or the minimum acceleration's over alpha_max)."""

    @property
    def q0(self) -> list[float] | np.ndarray:
        """The fixed initial state (nx): the steady state at omega_start, scaled as the state."""

    def nu_bounds(self) -> tuple[float, float]:
        """Bounds of nu at the nodes of the horizon (0, and the speed cap or inf)."""

    def rhs(self) -> ca.Function:
        """(q, a*, p) -> dq/dtau: the model's equation (also what CVODES integrates)."""

    def dynamics(self) -> ca.Function:
        """(q, u, h) -> h dq/dtau at a* = u a_max: the model over an interval of length h (tau)."""

    def deflection2(self) -> ca.Function:
        """q -> the squared deflection measure the ``integrated_deflection`` objective integrates."""

    def path_constraints(self, ref: float) -> list[PathConstraint]:
        """The named path constraints (epigraph, deflection limit, drive limits), each row scaled to order one;
        ``ref`` is the scale of the epigraph level (:meth:`reference_level`)."""

    # ---- what :class:`autobal.ocp.solve.Solver`, :func:`autobal.ocp.solve.optimize` and the simulation read -----
    omega_start: float
    """Speed at t = 0, rad/s (the state starts steady there)."""
    omega_final: float
    """Speed reached at the deadline and held over the settling window, rad/s."""
    omega_max: float | None
    """Speed cap, rad/s (None: none)."""
    horizon: float
    """The deadline, s (the upper bound of the final time when it is free)."""
    settling_time: float
    """The window held at omega_final after the horizon, s (the peak counts over it too)."""
    deflection_limit: float | None
    """Largest deflection allowed at every path point, in :attr:`deflection_unit` (None: none)."""
    deflection_unit: str
    """Unit of ``deflection_limit`` and of every peak: "1" (delta/e, the Jeffcott rotor) or "m"."""
    max_steps: int
    """CVODES steps per integrator call at most."""
    hold_states: bool
    """Whether the coarse starts' collocation states begin held at the interval-start values (rockit's guess) rather
    than simulated from the profile."""

    @property
    def epigraph_unit(self) -> float:
        """The reported peak is sqrt(epigraph level) times this (1 for delta/e, a in m for the modal rotor)."""

    def epigraph2(self, states: np.ndarray) -> np.ndarray:
        """The squared measure the epigraph bounds at states (..., nx)."""

    def deflection_of(self, states: np.ndarray) -> dict:
        """The deflection at states (k, nx), named with its unit: a failed solve's last iterate."""

    def starts(self, n: int, multistart: bool = True) -> list[tuple[str, np.ndarray]]:
        """Labelled initial control profiles (u on the n control intervals of the horizon), best first; without
        ``multistart`` only the first."""

    def reference_level(self) -> float:
        """The scale of the objective (``ref`` of the transcription): the epigraph level's, or 1."""

    def resimulate(self, u: np.ndarray, h: np.ndarray, label: str):
        """CVODES re-simulation of the control u on intervals of lengths h (tau), settling window included: a
        trajectory whose ``peak`` is in :attr:`deflection_unit` (what every reported peak is)."""

    def rank_coarse(self, found: list, n: int) -> tuple[int, dict[int, float]]:
        """The best of the coarse optima ``found`` ((label, solution) pairs in start order, n control intervals):
        its index, and the re-simulated objective of those it was judged by (by index)."""
