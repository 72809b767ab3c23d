"""A finite-element rotor of ROSS (the ross-rotordynamics package) reduced to its lateral modes.

The full model is ROSS's (Timoshenko shaft elements, rigid disks, linear bearings), as ROSS integrates
a run-up (``Rotor.integrate_system``):

    M q'' + (C + omega G) q' + (K + alpha K_sdt) q = F(t),

with the unbalance forces of ``Rotor.unbalance_force_over_time`` at speed omega, acceleration alpha and
angle phi: F_x = m e (omega^2 cos(phi + beta) + alpha sin(phi + beta)),
F_y = m e (omega^2 sin(phi + beta) - alpha cos(phi + beta)).

Reduction: the undamped, non-rotating modes Phi of the lateral degrees of freedom (x, y, alpha, beta at
every node; ROSS's axial and torsional ones are uncoupled from them) with natural frequencies up to
``cutoff`` x the final speed, mass-normalised (Phi' M Phi = I); the reduced matrices are
Phi' K Phi, Phi' C Phi, Phi' G Phi and Phi' K_sdt Phi, full (cross-coupled bearings, non-proportional
damping).  The speed-dependent gyroscopic terms (G, K_sdt) are kept when they move a retained critical
speed by more than ``gyro_tol`` (0.1 % by default), the criterion this module states and the reduction
reports.

For a synchronous unbalance the state s = (eta, eta') of s' = A(omega, alpha) s + B f has the exact
complex envelope S with s = Re(S e^{i phi}) and S' = (A - i omega) S + B F^, F^ = sum m e e^{i beta}
(omega^2 - i alpha)(e_x - i e_y): smooth where s whirls at the running speed.  The optimal-control
problem (:mod:`autobal.ocp.modal`) is written on S, its re-simulation on s; both use :meth:`ModalRotor.ode`.

ROSS is heavy (numba, plotly) and optional: it is imported only by :func:`import_ross`, inside the
functions that need it (``pip install -e '.[ross]'``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import sys
import warnings
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from autobal.errors import ScenarioError
from autobal.models.params import si

EXTRA = "pip install -e '.[ross]'"
DOFS_PER_NODE = 6  # ROSS: x, y, z, alpha, beta, theta
LATERAL = (0, 1, 3, 4)  # x, y, alpha, beta
TORSION = 5  # theta, the rotation about the axis
RESIM_TOL = 1e-9  # CVODES relative tolerance of the fixed-frame response (:func:`simulate_fixed`)
POINTS_PER_REV = 64  # its output points per revolution (the peak between them: < 1e-3)


@contextlib.contextmanager
def _quiet():
    """Silence what ROSS's dependencies print at import (a REFPROP notice on stdout, from C)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        with warnings.catch_warnings(), open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink):
            warnings.simplefilter("ignore")
            yield
    finally:
        sys.stdout.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


def import_ross():
    """The ``ross`` module, imported quietly; a one-line ScenarioError naming the extra when it is missing.

    Returns
    -------
    module
        ``ross`` (ross-rotordynamics 2.3).
    """
    if sys.modules.get("ross") is not None:
        return sys.modules["ross"]
    try:
        with _quiet():
            import ross
    except ImportError as exc:
        raise ScenarioError(f"a ROSS rotor needs the optional ross-rotordynamics package ({exc}); install it "
                            f"with: {EXTRA}") from None
    return ross


# ---- the rotor as ROSS elements (SI) -------------------------------------------------------------------

# the scene's ross_rotor elements are derived from these declarations (autobal/parts/ross_rotor.py)
NODES = {"ge": 0, "le": 10_000}  # the range of a node number
_NODE = {"doc": "node number (0 at the left end)", **NODES}


@dataclass(frozen=True)
class Material:
    """Shaft material: density (kg/m^3), Young's modulus E (Pa), shear modulus G (Pa); the defaults are ROSS's
    steel."""

    density: float = si("kg/m**3", 7810.0, kind="density", doc="rho")
    young_modulus: float = si("Pa", 211e9, kind="pressure", doc="E")
    shear_modulus: float = si("Pa", 81.2e9, kind="pressure", doc="G_s")


@dataclass(frozen=True)
class Shaft:
    """One Timoshenko shaft element of ROSS (``ross.ShaftElement``): length, inner and outer diameter, m."""

    length: float = si("m", kind="length", doc="element length L")
    inner_diameter: float = si("m", kind="length", scene_default=0.0, ge=0, doc="idl (0 for a solid shaft)")
    outer_diameter: float = si("m", kind="length", doc="odl")


@dataclass(frozen=True)
class Disk:
    """A rigid disk (``ross.DiskElement``) at ``node``: mass (kg), diametral and polar inertia (kg m^2)."""

    node: int = si("", **_NODE)
    mass: float = si("kg", kind="mass", doc="m")
    diametral_inertia: float = si("kg*m**2", kind="moment of inertia", doc="I_d")
    polar_inertia: float = si("kg*m**2", kind="moment of inertia", doc="I_p")


@dataclass(frozen=True)
class Bearing:
    """A linear bearing (``ross.BearingElement``) at ``node``: stiffness (N/m) and damping (N s/m)."""

    node: int = si("", **_NODE)
    kxx: float = si("N/m", kind="stiffness", ge=0, doc="direct stiffness in x")
    kyy: float = si("N/m", kind="stiffness", scene_default=None, ge=0, doc="direct stiffness in y (default kxx)")
    cxx: float = si("N*s/m", kind="damping", scene_default=0.0, ge=0, doc="direct damping in x")
    cyy: float = si("N*s/m", kind="damping", scene_default=None, ge=0, doc="direct damping in y (default cxx)")
    kxy: float = si("N/m", 0.0, kind="stiffness", ge=0, doc="cross-coupled stiffness")
    kyx: float = si("N/m", 0.0, kind="stiffness", ge=0, doc="cross-coupled stiffness")
    cxy: float = si("N*s/m", 0.0, kind="damping", key="", doc="cross-coupled damping (not in a scene)")
    cyx: float = si("N*s/m", 0.0, kind="damping", key="", doc="cross-coupled damping (not in a scene)")


@dataclass(frozen=True)
class Unbalance:
    """Unbalance m e (kg m) at ``node`` with phase beta (rad)."""

    node: int = si("", **_NODE)
    magnitude: float = si("kg*m", doc="m e, kg m", gt=0, le=1e3)
    phase: float = si("rad", 0.0, key="", doc="phase beta (the scene: degrees)")


@dataclass(frozen=True)
class RossRotorSpec:
    """A rotor given as ROSS elements, or a ROSS example rotor by name (``rotor_example``, ...)."""

    example: str | None = None
    shaft: tuple[Shaft, ...] = ()
    disks: tuple[Disk, ...] = ()
    bearings: tuple[Bearing, ...] = ()
    material: Material = Material()


def ross_rotor(spec: RossRotorSpec):
    """The ``ross.Rotor`` of a spec (imports ROSS).

    Parameters
    ----------
    spec : RossRotorSpec
        Elements in SI, or the name of a ROSS example function.

    Returns
    -------
    ross.Rotor
    """
    rs = import_ross()
    with _quiet():
        if spec.example is not None:
            fn = getattr(rs, spec.example, None)
            if not (spec.example.endswith("example") and callable(fn)):
                names = sorted(n for n in dir(rs) if n.endswith("rotor_example") or n == "compressor_example")
                raise ScenarioError(f"ross_rotor.example: {spec.example!r} is not a ROSS example rotor "
                                    f"(one of {', '.join(names)})")
            return fn()
        m = spec.material
        steel = rs.Material(name="autobal_shaft", rho=m.density, E=m.young_modulus, G_s=m.shear_modulus)
        shaft = [rs.ShaftElement(s.length, s.inner_diameter, s.outer_diameter, material=steel, shear_effects=True,
                                 rotary_inertia=True, gyroscopic=True) for s in spec.shaft]
        disks = [rs.DiskElement(d.node, d.mass, d.diametral_inertia, d.polar_inertia) for d in spec.disks]
        brgs = [rs.BearingElement(b.node, kxx=b.kxx, kyy=b.kyy, kxy=b.kxy, kyx=b.kyx, cxx=b.cxx, cyy=b.cyy,
                                  cxy=b.cxy, cyx=b.cyx) for b in spec.bearings]
        return rs.Rotor(shaft, disks, brgs)


@dataclass(frozen=True)
class LateralMatrices:
    """ROSS's matrices restricted to the lateral dofs (x, y, alpha, beta of each node), SI."""

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    G: np.ndarray
    Ksdt: np.ndarray
    nodes: int
    polar_inertia: float = 0.0  # kg m^2, of the whole rotor about its axis (1' M_theta 1, the torsional dofs)

    def row(self, node: int, dof: int) -> int:
        """Row of local dof ``dof`` (0 = x, 1 = y) of ``node`` in these matrices."""
        return 4 * node + dof


def lateral_matrices(rotor) -> LateralMatrices:
    """The lateral part of a ROSS rotor's M, K, C, G and K_sdt (bearing coefficients must not vary with
    speed: the reduction is linear time-invariant apart from the speed and acceleration terms).

    Parameters
    ----------
    rotor : ross.Rotor

    Returns
    -------
    LateralMatrices
    """
    varying = [b.n for b in rotor.bearing_elements if b.frequency is not None]
    if varying:
        raise ScenarioError(f"ross_rotor: bearing coefficients that vary with speed (nodes {varying}) are not "
                            "supported by the modal reduction; give constant coefficients")
    with _quiet():
        mats = [np.asarray(a, float) for a in (rotor.M(), rotor.K(0.0), rotor.C(0.0), rotor.G(), rotor.Ksdt())]
    nd = rotor.number_dof
    if nd != DOFS_PER_NODE:
        raise ScenarioError(f"ross_rotor: {nd} dofs per node; the reduction expects ROSS's 6")
    lat = [i for i in range(rotor.ndof) if i % nd in LATERAL]
    rest = [i for i in range(rotor.ndof) if i % nd not in LATERAL]
    for name, a in zip("MKCG", mats, strict=False):
        if np.abs(a[np.ix_(lat, rest)]).max(initial=0) > 1e-9 * np.abs(a).max():
            raise ScenarioError(f"ross_rotor: the {name} matrix couples lateral and axial/torsional dofs")
    sub = [a[np.ix_(lat, lat)] for a in mats]
    # the rigid rotation of every node by the same angle: its kinetic energy is (1' M_theta 1) theta'^2 / 2
    turn = [i for i in range(rotor.ndof) if i % nd == TORSION]
    return LateralMatrices(*sub, nodes=rotor.ndof // nd, polar_inertia=float(np.sum(mats[0][np.ix_(turn, turn)])))


# ---- the reduced model ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class ModalRotor:
    """The rotor reduced to ``n`` modes: eta'' + (C + omega G) eta' + (K + alpha Ksdt) eta = Phi' F, SI."""

    Phi: np.ndarray  # (lateral dofs, n), mass-normalised
    omega_n: np.ndarray  # rad/s, undamped non-rotating natural frequencies of the retained modes
    K: np.ndarray
    C: np.ndarray
    G: np.ndarray  # zeros when the gyroscopic coupling is dropped
    Ksdt: np.ndarray
    unbalance: np.ndarray  # (n,) complex: Phi' sum m e e^{i beta} (e_x - i e_y), kg m / sqrt(kg)
    unbalances: tuple[Unbalance, ...]
    cutoff_rad_s: float
    gyroscopic: bool
    gyroscopic_shift: float  # largest relative shift of a retained critical speed by G
    nodes: int
    dropped_omega_n: float = field(default=float("nan"))  # rad/s, lowest natural frequency left out
    polar_inertia: float = 0.0  # kg m^2, of the whole rotor about its axis (what a drive accelerates)

    @property
    def n(self) -> int:
        """Number of retained modes."""
        return len(self.omega_n)

    def node_rows(self, node: int) -> np.ndarray:
        """(2, n): the x and y rows of Phi at ``node`` (deflection = rows @ eta), m / (m sqrt(kg))."""
        if not 0 <= node < self.nodes:
            raise ScenarioError(f"node {node}: the rotor has nodes 0 to {self.nodes - 1}")
        return self.Phi[[4 * node, 4 * node + 1], :]

    def ode(self) -> ca.Function:
        """(eta, eta', omega, alpha, f) -> eta'': the reduced equation of motion (SI)."""
        n = self.n
        eta, deta, f = ca.SX.sym("eta", n), ca.SX.sym("deta", n), ca.SX.sym("f", n)
        w, a = ca.SX.sym("omega"), ca.SX.sym("alpha")
        K, C, G, Ks = (ca.DM(x) for x in (self.K, self.C, self.G, self.Ksdt))
        dd = f - ca.mtimes(C + w * G, deta) - ca.mtimes(K + a * Ks, eta)
        return ca.Function("modal_rotor", [eta, deta, w, a, f], [dd], ["eta", "deta", "omega", "alpha", "f"],
                           ["ddeta"])

    def force_amplitude(self, omega, alpha):
        """Complex modal unbalance force F^ = (omega^2 - i alpha) U as (real, imaginary) parts (CasADi)."""
        Ur, Ui = ca.DM(self.unbalance.real), ca.DM(self.unbalance.imag)
        return omega**2 * Ur + alpha * Ui, omega**2 * Ui - alpha * Ur

    def state_matrix(self, omega: float) -> np.ndarray:
        """A(omega) of s' = A s + B f at zero acceleration (first-order form)."""
        n = self.n
        return np.block([[np.zeros((n, n)), np.eye(n)], [-self.K, -(self.C + omega * self.G)]])

    def steady_amplitude(self, omega: float) -> np.ndarray:
        """The complex modal amplitude E with eta = Re(E e^{i phi}) at constant speed omega."""
        if omega == 0:
            return np.zeros(self.n, complex)
        H = -omega**2 * np.eye(self.n) + 1j * omega * (self.C + omega * self.G) + self.K
        return np.linalg.solve(H, omega**2 * self.unbalance)

    def critical_speeds(self, upper: float | None = None) -> dict:
        """Synchronous critical speeds of the reduced model: omega = omega_d,k(omega), the k-th damped natural
        frequency (imaginary part of the eigenvalue, ascending), as ROSS's ``run_critical_speed`` (``wd``).

        Parameters
        ----------
        upper : float, optional
            Only those below this speed, rad/s.

        Returns
        -------
        dict
            "wd" (rad/s), "wn" (undamped |lambda| at that speed, rad/s) and "damping_ratio", per mode.
        """
        return critical_speeds(self.state_matrix, self.n, self.omega_n, upper)

    def campbell(self, omega_top: float, points: int = 200) -> dict:
        """Damped natural frequencies (rad/s) against speed, 0 to omega_top: "omega" (points,), "wd" (points, n)."""
        w = np.linspace(0, omega_top, points)
        wd = np.array([np.sort(np.linalg.eigvals(self.state_matrix(x)).imag)[self.n:] for x in w])
        return {"omega": w, "wd": wd}


# ---- the physical response of the reduced rotor (fixed frame) ------------------------------------------

def fixed_frame_integrator(rotor: ModalRotor, points: int, tol: float = RESIM_TOL, scale: float = 1.0
                           ) -> ca.Function:
    """CVODES of the physical modal state (eta/scale, eta'/scale, omega, phi) over one interval of constant
    acceleration; parameters (alpha, h); outputs at ``points`` evenly spaced instants after its start."""
    n = rotor.n
    x, p = ca.SX.sym("x", 2 * n + 2), ca.SX.sym("p", 2)
    eta, deta, w, ph = x[:n], x[n:2 * n], x[2 * n], x[2 * n + 1]
    fr, fi = rotor.force_amplitude(w, p[0])
    f = ca.cos(ph) * fr - ca.sin(ph) * fi  # Re(F^ e^{i phi})
    dd = rotor.ode()(eta, deta, w, p[0], f / scale)
    return ca.integrator("modal_fixed", "cvodes", {"x": x, "p": p, "ode": p[1] * ca.vertcat(deta, dd, p[0], w)},
                         0, list(np.linspace(0, 1, points + 1)[1:]),
                         {"abstol": tol, "reltol": tol, "max_num_steps": 500000})


def simulate_fixed(rotor: ModalRotor, omega_start: float, alpha: np.ndarray, h: np.ndarray, nodes,
                   from_rest: bool = False, tol: float = RESIM_TOL):
    """The physical response to a piecewise-constant acceleration (alpha (rad/s^2) on intervals h (s)),
    from the steady state at omega_start (or from rest, as ROSS's time response starts), sampled at
    least POINTS_PER_REV times per revolution.

    Parameters
    ----------
    rotor : ModalRotor
    omega_start : float
        rad/s.
    alpha, h : ndarray
        Acceleration (rad/s^2) and length (s) of each interval.
    nodes : sequence of int
    from_rest : bool
        Start from rest instead of the steady state.
    tol : float
        CVODES tolerance (relative; absolute on the scaled states).

    Returns
    -------
    t (s), omega (rad/s), xy (len(nodes), 2, len(t)) deflections in m
    """
    n = rotor.n
    a = float(np.abs(rotor.unbalance).max()) or 1.0
    E = np.zeros(n, complex) if from_rest else rotor.steady_amplitude(omega_start)
    x = np.concatenate([E.real / a, (1j * omega_start * E).real / a, [omega_start, 0.0]])
    w_top = np.max(np.abs(omega_start + np.concatenate([[0], np.cumsum(np.asarray(alpha) * h)])))
    m = max(4, int(np.ceil(w_top * np.max(h) / (2 * np.pi) * POINTS_PER_REV)))
    F = fixed_frame_integrator(rotor, m, tol, a)
    frac = np.linspace(0, 1, m + 1)[1:]
    ts, ws, ys, t0 = [np.zeros(1)], [np.array([omega_start])], [x[:n][:, None]], 0.0
    for al, hk in zip(alpha, h, strict=True):
        xf = np.array(F(x0=x, p=[al, hk])["xf"])
        ts.append(t0 + hk * frac)
        ws.append(xf[2 * n])
        ys.append(xf[:n])
        x, t0 = xf[:, -1], t0 + hk
    eta = np.hstack(ys) * a
    xy = np.array([rotor.node_rows(nd) @ eta for nd in nodes])
    return np.concatenate(ts), np.concatenate(ws), xy


def _modes(A_of, omega: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    lam = np.linalg.eigvals(A_of(omega))
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(lam.imag)][:n]
    return lam.imag, lam


def critical_speeds(A_of, n: int, guess: np.ndarray, upper: float | None = None) -> dict:
    """Solve omega = Im lambda_k(A(omega)) for each of the n modes (bracketed root search)."""
    from scipy.optimize import brentq  # here: a scene load must not pull scipy.optimize (tests/test_layers.py)

    wd, wn, zeta = [], [], []
    for k, w0 in enumerate(guess):
        if upper is not None and w0 > 1.5 * upper:
            break

        def g(w, k=k):
            return w - _modes(A_of, w, n)[0][k]

        lo, hi = 0.5 * w0, 1.5 * w0
        for _ in range(40):  # bracket the root; a forward branch rising faster than omega has none
            if g(lo) < 0 < g(hi):
                break
            lo, hi = (0.5 * lo, hi) if g(lo) >= 0 else (lo, 1.5 * hi)
        else:
            continue
        r = brentq(g, lo, hi, xtol=1e-12, rtol=1e-12)
        lam = _modes(A_of, r, n)[1][k]
        if upper is not None and r > upper:
            continue
        wd.append(r)
        wn.append(abs(lam))
        zeta.append(-lam.real / abs(lam))
    return {"wd": np.array(wd), "wn": np.array(wn), "damping_ratio": np.array(zeta)}


def reduce(lat: LateralMatrices, unbalances, omega_final: float, cutoff: float = 2.0,
           gyro_tol: float = 1e-3) -> ModalRotor:
    """Reduce the lateral model to its modes with natural frequencies up to ``cutoff`` x ``omega_final``.

    Parameters
    ----------
    lat : LateralMatrices
        ROSS's lateral matrices (SI).
    unbalances : sequence of Unbalance
        m e (kg m) and phase (rad) at nodes.
    omega_final : float
        The highest running speed, rad/s.
    cutoff : float
        Modes with omega_n <= cutoff omega_final are kept (at least one).
    gyro_tol : float
        The gyroscopic terms (G, K_sdt) are kept when they shift a retained critical speed below
        ``omega_final`` by more than this fraction.

    Returns
    -------
    ModalRotor
    """
    Ks = 0.5 * (lat.K + lat.K.T)
    L = np.linalg.cholesky(lat.M)  # K v = w^2 M v as a symmetric standard problem in L' v
    Li = np.linalg.inv(L)
    w2, Y = np.linalg.eigh(Li @ Ks @ Li.T)
    V = Li.T @ Y
    w = np.sqrt(np.clip(w2, 0.0, None))
    keep = w <= cutoff * omega_final
    keep[0] = True
    Phi = V[:, keep]
    Phi = Phi / np.sqrt(np.einsum("ik,ij,jk->k", Phi, lat.M, Phi))
    u = np.zeros(lat.M.shape[0], complex)
    for ub in unbalances:
        if not 0 <= ub.node < lat.nodes:
            raise ScenarioError(f"unbalance at node {ub.node}: the rotor has nodes 0 to {lat.nodes - 1}")
        c = ub.magnitude * np.exp(1j * ub.phase)
        u[lat.row(ub.node, 0)] += c
        u[lat.row(ub.node, 1)] += -1j * c
    red = {k: Phi.T @ getattr(lat, k) @ Phi for k in ("K", "C", "G", "Ksdt")}
    wk = w[keep]
    common = dict(Phi=Phi, omega_n=wk, K=red["K"], C=red["C"], unbalance=Phi.T @ u, unbalances=tuple(unbalances),
                  cutoff_rad_s=cutoff * omega_final, nodes=lat.nodes, polar_inertia=lat.polar_inertia,
                  dropped_omega_n=float(w[~keep][0]) if (~keep).any() else float("nan"))
    full = ModalRotor(G=red["G"], Ksdt=red["Ksdt"], gyroscopic=True, gyroscopic_shift=0.0, **common)
    plain = ModalRotor(G=0 * red["G"], Ksdt=0 * red["Ksdt"], gyroscopic=False, gyroscopic_shift=0.0, **common)
    a, b = full.critical_speeds(omega_final)["wd"], plain.critical_speeds(omega_final)["wd"]
    m = min(len(a), len(b))
    shift = float(np.max(np.abs(a[:m] - b[:m]) / b[:m], initial=0.0))
    chosen = full if shift > gyro_tol else plain
    return dataclasses.replace(chosen, gyroscopic_shift=shift)


# ---- ROSS's own answers (the validation side) -----------------------------------------------------------

def ross_critical_speeds(rotor, upper: float, rtol: float = 1e-6) -> dict:
    """ROSS's ``run_critical_speed`` (wd, wn, damping ratio, whirl), the lateral ones below ``upper`` (rad/s).

    Parameters
    ----------
    rotor : ross.Rotor
    upper : float
        rad/s.
    rtol : float
        Tolerance of ROSS's Newton iteration (its default 0.005 is looser than the 1 % comparison needs).

    Returns
    -------
    dict
        Arrays "wd", "wn" (rad/s), "damping_ratio", list "whirl".
    """
    with _quiet():
        cs = rotor.run_critical_speed(num_modes=16, rtol=rtol)
        wd, wn = np.asarray(cs.wd()), np.asarray(cs.wn())
        whirl = list(cs.whirl_direction)
        zeta = np.asarray(cs.damping_ratio)
    keep = [i for i in range(len(wd)) if wd[i] <= upper and whirl[i] in ("Forward", "Backward", "Mixed")]
    return {"wd": wd[keep], "wn": wn[keep], "damping_ratio": zeta[keep], "whirl": [str(whirl[i]) for i in keep]}


def compare_critical_speeds(reduced: np.ndarray, ross: np.ndarray | None) -> float | None:
    """Largest relative difference of paired critical speeds (ascending), None without ROSS's (inf when their
    counts differ)."""
    if ross is None:
        return None
    m = min(len(reduced), len(ross))
    if m == 0 or len(reduced) != len(ross):
        return float("inf")
    return float(np.max(np.abs(np.asarray(reduced[:m]) - np.asarray(ross[:m])) / np.asarray(ross[:m])))


def ross_time_response(rotor, unbalances, t: np.ndarray, omega: np.ndarray, node: int) -> np.ndarray:
    """ROSS's own time response (``run_time_response``: Newmark on the full model, speed and acceleration
    terms at each step) of a speed history, from rest; the (x, y) deflection of ``node``, m.

    Parameters
    ----------
    rotor : ross.Rotor
    unbalances : sequence of Unbalance
    t, omega : ndarray
        Times (s, evenly spaced) and speeds (rad/s).
    node : int

    Returns
    -------
    ndarray
        (len(t), 2): x and y of the node, m.
    """
    with _quiet():
        F = rotor.unbalance_force_over_time([u.node for u in unbalances], [u.magnitude for u in unbalances],
                                            [u.phase for u in unbalances], omega, t)
        res = rotor.run_time_response(omega, F.T, t)
    y = np.asarray(res.yout)
    return y[:, [DOFS_PER_NODE * node, DOFS_PER_NODE * node + 1]]
