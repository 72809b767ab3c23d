"""Monte Carlo of the face-gap amplitude A_u(omega) through a linear model of the dynamics
(Pavlenko 2014, Fig. 3.7), evaluated for all samples at once per frequency, beside the nominal AFC of
analysis/numerics/frequency.py.

By default (the scene schema's) the exact linearisation of the energy-consistent nonlinear model under
the physical forcing dtau = b dpsi1, with its dynamic data uncertain: the model the toolkit finds stable.
For the validation against the source, its hand model (2.44)/(2.101) ("program", the appendix forcing,
its 28 constants uncertain) reproduces Fig. 3.7, although that model is unstable at the operating point
(analysis/numerics/stability.py), so its "AFC" is not a steady response.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from autobal.analysis.numerics import frequency
from autobal.analysis.numerics.hand_linear import K_NAMES, OTHER, T_NAMES, Constants
from autobal.analysis.numerics.linearize import Setup, jacobians
from autobal.analysis.numerics.sampling import Chunks, Sampler, marginals, statistics
from autobal.errors import ScenarioError
from autobal.models.dynamics import PARAM_NAMES

HAND_MODES = ("program", "thesis", "consistent")


def afc_parameters(model: str) -> tuple:
    """Names a model of the AFC Monte Carlo can take as uncertain: the 28 constants of the hand
    model (2.44)/(2.169), or the dynamic data of the nonlinear model (models/dynamics.py)."""
    if model in HAND_MODES:
        return K_NAMES + T_NAMES + OTHER
    return PARAM_NAMES


def afc_names(model: str, parameters) -> list[str]:
    """The names of an AFC Monte Carlo's uncertain ``parameters`` (names, or a mapping name -> distribution) of the
    linear ``model``, each checked to be one of its model's (:func:`afc_parameters`); ScenarioError naming the first
    that is not."""
    allowed = afc_parameters(model)
    for name in parameters:
        if name not in allowed:
            raise ScenarioError(f"analyses.montecarlo.afc.parameters.{name}: not a parameter of the {model} "
                                f"model; expected one of {', '.join(allowed)}")
    return list(parameters)


class AfcModel:
    """Face-gap amplitude A_u(omega) in um for parameter samples (analysis/numerics/linearize.py's models).

    Hand models (Fig. 3.7 with mode "program"): each sample's constants give N(p) of (2.101)
    (hand_linear.Constants.operator, assembled per sample) and W = N(i omega)^-1 B, solved for all
    samples at once per omega.  Nonlinear models: the exact Jacobians A, B of the nonlinear model
    at its equilibrium (linearize.jacobians), mapped over the samples of the dynamic data with
    CasADi ``map``, then (i omega I - A)^-1 b per omega for all samples at once.
    A_u = |W_u| dpsi1a z_B, m (App. A L3412 prints it in micrometres)."""

    def __init__(self, setup, model: str, names, convention: str = "appendix"):
        self.setup, self.model, self.names, self.convention = setup, model, tuple(names), convention
        self.scale = setup.data.forcing_amplitude * setup.dev.scales["z_B"]
        if model in HAND_MODES:
            self.base = setup.constants(model)
            self._nominal = dict(self.base.c)
        else:
            self.nl = setup.nonlinear("chain" if model == "nonlinear_chain" else "energy")
            self._nominal = dict(zip(PARAM_NAMES, map(float, self.nl.p0), strict=True))
        self._maps: dict = {}

    def nominal(self) -> dict:
        return dict(self._nominal)

    def amplitude(self, X: np.ndarray, omega) -> np.ndarray:
        """A_u (um), samples x omega, for rows of X in the order of ``names``."""
        omega = np.asarray(omega, float)
        if self.model in HAND_MODES:
            M0, M1, M2, bvec = self._hand(X)
        else:
            M0, M1, M2, bvec = self._nonlinear(X)
        out = np.empty((len(X), len(omega)))
        for j, w in enumerate(omega):
            s = 1j * w
            W = np.linalg.solve(M0 + s * M1 + (s * s) * M2, bvec[..., None])[..., 0]
            out[:, j] = np.abs(W[:, self._u]) * self.scale
        return out

    def _hand(self, X):
        b = self.base
        mats = []
        for row in X:  # the operator's layout is hand_linear's; only its assembly runs per sample
            c = Constants(c=self._nominal | dict(zip(self.names, map(float, row), strict=True)), sigma=b.sigma,
                          sigma_m=b.sigma_m, b=b.b, z_B=b.z_B, regulator=b.regulator, mode=b.mode)
            N0, N1, N2, Gin = c.operator()
            mats.append((N0, N1, N2, Gin @ np.array([1.0 if self.convention == "appendix" else b.b, 1.0])))
        self._u = 0
        return tuple(np.array([m[k] for m in mats]) for k in range(4))

    def _nonlinear(self, X):
        nl, n = self.nl, len(X)
        P = np.tile(nl.p0, (n, 1))
        for j, name in enumerate(self.names):
            P[:, PARAM_NAMES.index(name)] = X[:, j]
        if n not in self._maps:
            self._maps = {n: jacobians(nl).map(n)}
        A, B = self._maps[n](nl.x0, nl.w0, P.T)
        nx = len(nl.states)
        A = np.asarray(A).reshape(nx, n, nx).transpose(1, 0, 2)
        B = np.asarray(B).reshape(nx, n, 2).transpose(1, 0, 2)  # inputs (psi1, tau)
        tau = 1.0 if self.convention == "appendix" else nl.design.groups.b
        self._u = nl.index("u")
        eye = np.broadcast_to(np.eye(nx), A.shape)
        return -A, eye, np.zeros_like(A), B[..., 0] + tau * B[..., 1]


_AFC_MODELS: dict = {}


def afc_model(device, psi1: float, model: str, names, convention: str) -> AfcModel:
    """One AfcModel per process, device, operating point and model (built once per worker)."""
    key = (repr(device), psi1, model, tuple(names), convention)
    if key not in _AFC_MODELS:
        _AFC_MODELS[key] = AfcModel(Setup(device, psi1), model, names, convention)
    return _AFC_MODELS[key]


@dataclass(frozen=True)
class AfcTask(Chunks):
    """Chunk i of the AFC Monte Carlo: draw its samples (stream 1) and evaluate A_u on the omega grid."""

    device: object = None  # the scene's validated ``device`` (plain data)
    psi1: float = 1.0
    model: str = "nonlinear"
    convention: str = "physical"
    omega: tuple = ()

    def __call__(self, chunk: int) -> np.ndarray:
        return afc_model(self.device, self.psi1, self.model, self.sampler.names, self.convention).amplitude(
            self.draw(chunk), self.omega)


def afc_study(device, a, seed: int, executor, band_sigma: float, quantiles) -> dict:
    """AFC Monte Carlo (Fig. 3.7) of the spec ``a`` (:class:`autobal.analysis.studies.montecarlo.AfcSpec`): statistics
    of A_u on the grid, at the nominal model's peaks and at the operating speed, beside the nominal AFC of
    analysis/numerics/frequency.py."""
    if device is None or getattr(device, "dynamics", None) is None:
        raise ScenarioError("analyses.montecarlo.afc needs device.dynamics (masses, springs, volumes)")
    names = afc_names(a.model, a.parameters)
    am = afc_model(device, a.operating_ratio, a.model, names, a.forcing)
    lin = am.setup.linear(a.model)
    d = am.setup.data
    nominal = frequency.characteristic(lin, (a.omega.start, a.omega.stop, a.omega.points), a.forcing,
                                       d.forcing_amplitude, d.omega0)
    marks = {"operating_speed": d.omega0} | {f"peak_{i + 1}": p["omega"] for i, p in enumerate(nominal["peaks"])}
    marks = {k: float(v) for k, v in marks.items() if np.isfinite(v) and v > 0}
    grid = np.geomspace(a.omega.start, a.omega.stop, a.omega.points)
    omega = np.concatenate([grid, list(marks.values())])
    sampler = Sampler(marginals(a.parameters, am.nominal(), "analyses.montecarlo.afc.parameters"), None, seed,
                      stream=1)
    task = AfcTask(sampler, a.samples, min(a.chunk_size, a.samples), device=device, psi1=a.operating_ratio,
                   model=a.model, convention=a.forcing, omega=tuple(omega))
    amp = np.concatenate(executor.map(task, range(task.chunks), desc="monte carlo afc"))
    det = am.amplitude(np.array([[am.nominal()[n] for n in names]]), omega)[0]
    st = statistics(amp, band_sigma, quantiles)
    n = len(grid)
    at = {k: {"omega": w, "nominal": det[n + i], "mean": st["mean"][n + i], "std": st["std"][n + i],
              "cv": st["cv"][n + i]} for i, (k, w) in enumerate(marks.items())}
    return {"model": a.model, "forcing": a.forcing, "samples": a.samples, "psi1": a.operating_ratio,
            "parameters": names, "omega": grid, "nominal": det[:n],
            **{k: (v[:n] if isinstance(v, np.ndarray) else v) for k, v in st.items() if k != "quantiles"},
            "quantiles": {q: v[:n] for q, v in st["quantiles"].items()},
            "nominal_peaks": nominal["peaks"], "at": at, "amplitude_samples": amp}

