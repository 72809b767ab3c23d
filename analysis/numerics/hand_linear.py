"""The source's hand-derived linear model (Pavlenko 2014, (2.43)-(2.45), (2.101); gas (2.168)/(2.169)).

28 constants K1..K13, T1..T9, tau3, tau5, tau6, tau7, zeta1, zeta2 from a static operating point
and the dynamic data, in three modes:

* ``"thesis"``: the formulas as printed, (2.44) (pump) / (2.169) (compressor), with z_B in
  T4, T6, tau6 and K2 and the printed xi0^(3/2) in K4's denominator;
* ``"program"``: what Appendices A/B compute: K1 := chi, K2 := sigma_m dpsi,
  pump K7 without its factor 2, K8 twice (2.44), K6 with xi0^1.5; compressor K9 with an extra 1/2,
  K12 with sqrt(u0 (psi20 - psi30)), the liquid tau7, tau3 = V_cam/(E G); z_B in T4, T6, tau6.
  This mode, at the appendix's closed-form operating point, reproduces the published AFC;
* ``"consistent"``: the linearisation of the chain form (2.40) done right: x_B, the dimensional
  K1 = k_pr z_B/(p_B s_B), K2 = k_reg x_B/(p_B s_B), and every coefficient from the local
  derivatives of the throttle laws (liquid or gas).  At the same point it equals the exact
  Jacobian of the nonlinear chain model (models/dynamics.py, form "chain"): the cross-check.

The model is the operator matrix N(p) of (2.101) (6x6; 3x3 without the regulator, (2.46)) with
columns (du, dxi, dpsi_cam, dpsi_e, dpsi2, dpsi3), and inputs (dtau, dpsi1); without the regulator
the barrier pressure is ideal, dpsi_e = dpsi1.  Its descriptor form E dX/dt = A X + G [dtau, dpsi1]
is the source's table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from autobal.analysis.numerics import closed_form
from autobal.models.device import DeviceDesign
from autobal.models.dynamics import DynamicData

MODES = ("thesis", "program", "consistent")
K_NAMES = tuple(f"K{i}" for i in range(1, 14))
T_NAMES = tuple(f"T{i}" for i in range(1, 10))
OTHER = ("tau3", "tau5", "tau6", "tau7", "zeta1", "zeta2")
REGULATOR_ONLY = ("K2", "K3", "K4", "K5", "K6", "K7", "T2", "T3", "T4", "T5", "T6", "tau3", "tau5", "tau6", "zeta2")


@dataclass
class Constants:
    """K1..K13, T1..T9 (s), tau3, tau5, tau6, tau7 (s), zeta1, zeta2 and the groups they act with.

    ``regulator`` False: the simplified system (2.46) (rows 1, 5, 6; dpsi_e = dpsi1).
    """

    c: dict  # name -> value
    sigma: float
    sigma_m: float
    b: float
    z_B: float
    regulator: bool = True
    mode: str = "given"
    point: dict = field(default_factory=dict)

    def __getitem__(self, k: str) -> float:
        return self.c[k]

    @property
    def coords(self) -> list[str]:
        return ["u", "xi", "psi_cam", "psi_e", "psi2", "psi3"] if self.regulator else ["u", "psi2", "psi3"]

    def operator(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """N(p) = N0 + N1 p + N2 p^2 of (2.101) (with -tau6 p in row 5) and the input matrix
        G_in (columns dtau, dpsi1): N(p) dU = G_in [dtau, dpsi1]."""
        c, s = self.c, self.sigma
        n = 6 if self.regulator else 3
        N0, N1, N2 = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
        Gin = np.zeros((n, 2))
        i = {k: j for j, k in enumerate(self.coords)}
        r1 = 0
        N2[r1, 0], N1[r1, 0], N0[r1, 0] = c["K1"] * c["T1"] ** 2, 2 * c["zeta1"] * c["K1"] * c["T1"], c["K1"]
        N0[r1, i["psi2"]], N0[r1, i["psi3"]] = -s, s
        Gin[r1, 0] = -1.0
        if self.regulator:
            K2, T2 = c["K2"], c["T2"]
            N2[1, 1], N1[1, 1], N0[1, 1] = K2 * T2**2, 2 * c["zeta2"] * K2 * T2, K2
            N0[1, 3] = self.sigma_m
            Gin[1, 1] = self.sigma_m
            N0[2, 1], N1[2, 1] = c["K4"], c["K4"] * c["T4"]
            N0[2, 2], N1[2, 2], N0[2, 3] = 1.0, c["T3"], -c["K3"]
            N0[3, 1], N1[3, 1] = -c["K6"], -c["K6"] * c["T6"]
            N0[3, 2], N1[3, 2] = -c["K5"], -c["K5"] * c["tau3"]
            N0[3, 3], N1[3, 3], N0[3, 4] = 1.0, c["T5"], -c["K7"]
        r5, r6 = n - 2, n - 1
        N0[r5, 0], N1[r5, 0] = c["K8"], c["K8"] * c["T8"]
        N0[r5, i["psi2"]], N1[r5, i["psi2"]], N0[r5, i["psi3"]] = 1.0, c["T7"], -c["K10"]
        if self.regulator:
            N1[r5, 1] = -c["tau6"]
            N0[r5, 3], N1[r5, 3] = -c["K9"], -c["K9"] * c["tau5"]
            Gin[r5, 1] = c["K11"]
        else:
            Gin[r5, 1] = c["K11"] + c["K9"]  # ideal regulator: dpsi_e = dpsi1
        N0[r6, 0] = -c["K12"]
        N0[r6, i["psi2"]], N1[r6, i["psi2"]] = -c["K13"], -c["K13"] * c["tau7"]
        N0[r6, i["psi3"]], N1[r6, i["psi3"]] = 1.0, c["T9"]
        return N0, N1, N2, Gin

    def forcing(self, convention: str = "appendix") -> np.ndarray:
        """B of (2.100) for a unit dpsi1: dtau = dpsi1 ("appendix": B = (-1, sigma_m, 0, 0, K11, 0),
        App. A/B) or dtau = b dpsi1 ("physical", (2.100) as printed)."""
        N0, N1, N2, Gin = self.operator()
        return Gin @ np.array([1.0 if convention == "appendix" else self.b, 1.0])

    def response(self, omega, convention: str = "appendix") -> np.ndarray:
        """W(i omega) = N(i omega)^-1 B, rows over omega, columns the coordinates (2.100)."""
        N0, N1, N2, _ = self.operator()
        B = self.forcing(convention)
        out = []
        for w in np.atleast_1d(np.asarray(omega, float)):
            s = 1j * w
            out.append(np.linalg.solve(N0 + s * N1 + s * s * N2, B))
        return np.array(out)

    def descriptor(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
        """E dX/dt = A X + G [dtau, dpsi1] with X = (du, du', [dxi, dxi'], pressures)."""
        N0, N1, N2, Gin = self.operator()
        mech = [0, 1] if self.regulator else [0]
        names, col = [], {}
        for j, k in enumerate(self.coords):
            col[j] = len(names)
            names.append(k)
            if j in mech:
                names.append("d" + k)
        m = len(names)
        E, A, G = np.zeros((m, m)), np.zeros((m, m)), np.zeros((m, 2))
        row = 0
        for r in range(len(self.coords)):
            if r in mech:  # kinematic row: d(q)/dt = q'
                E[row, col[r]] = 1.0
                A[row, col[r] + 1] = 1.0
                row += 1
            for j in range(len(self.coords)):
                if j in mech:
                    A[row, col[j]] -= N0[r, j]
                    A[row, col[j] + 1] -= N1[r, j]
                    E[row, col[j] + 1] += N2[r, j]
                else:
                    A[row, col[j]] -= N0[r, j]
                    E[row, col[j]] += N1[r, j]
            G[row] = Gin[r]
            row += 1
        return E, A, G, names

    def characteristic(self) -> np.ndarray:
        """Coefficients a0..an (descending powers) of D(p) = det N(p) (2.68)/(2.93): det(E) prod(p - lambda)."""
        E, A, _, _ = self.descriptor()
        lam = np.linalg.eigvals(np.linalg.solve(E, A))
        return np.real(np.linalg.det(E) * np.poly(lam))


def program_point(dev: DeviceDesign, psi1: float = 1.0) -> dict:
    """The appendix's operating point: closed forms (2.24)-(2.28) (pump) or (2.145)-(2.147) with
    the pump's regulator formulas (compressor), psi_e0 = psi1 + dpsi."""
    g, dpsi = dev.groups, dev.dpsi
    cf = closed_form.for_medium(g, psi1, dpsi)
    pt = {"psi1": psi1, "dpsi": dpsi, "u": float(cf["u"]), "psi2": float(cf["psi2"]),
          "psi3": float(cf["psi3"]), "psi_e": psi1 + dpsi}
    if g.regulator is not None:
        pt |= {"xi": float(cf["xi"]), "psi_cam": float(cf["psi_cam"])}
    return pt


def constants(dev: DeviceDesign, data: DynamicData, point: dict, mode: str = "consistent") -> Constants:
    """The 28 constants (2.44) / (2.169) at ``point`` (u, psi2, psi3, [xi, psi_e, psi_cam]) in ``mode``."""
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r}; expected one of {MODES}")
    g, sc = dev.groups, dev.scales
    gas = g.medium == "gas"
    p_b, s_b, z_b, g1, s_e = sc["p_B"], sc["s_B"], sc["z_B"], sc["g1"], sc["s_e"]
    u0, p2, p3, p4 = point["u"], point["psi2"], point["psi3"], g.psi4
    a_e, a_t, a_31 = g.alpha_e1, g.alpha_TB1, g.alpha_31
    ut = a_t * u0**1.5  # face conductance ratio at u0

    def theta(vol):  # V/(E g1), s
        return vol / (data.E * g1)

    # local derivatives of the disc throttles over g1 (2.15) / (2.136): dQ_T/dp2, -dQ_T/dp3, dQ_3/dp3
    if gas:
        s23, s34 = math.sqrt(p2**2 - p3**2), math.sqrt(p3**2 - p4**2)
        a2, a3, a4 = ut * p2 / s23, ut * p3 / s23, a_31 * p3 / s34
        bT = 1.5 * a_t * math.sqrt(u0) * s23  # dQ_T/du over g1 p_B
    else:
        d23, d34 = p2 - p3, p3 - p4
        a2 = a3 = ut / (2 * math.sqrt(d23))
        a4 = a_31 / (2 * math.sqrt(d34))
        bT = 1.5 * a_t * math.sqrt(u0 * d23)
    Bp = 1 + a_e + a2  # B/g1 (pump), B_g/g1 (gas)
    A3 = a3 + a4  # A3/2 (pump), p30 (g_TB u^1.5/S23 + g3/S34)/g1 (gas)
    c = {
        "T1": math.sqrt(data.m_p / data.k_pr), "zeta1": data.c_z / (2 * data.k_pr * math.sqrt(data.m_p / data.k_pr)),
        "K1": data.k_pr * z_b / (p_b * s_b),
        "T7": theta(data.V2) / Bp, "K8": bT / Bp, "T8": s_e * z_b / (g1 * p_b * bT), "K9": a_e / Bp,
        "K10": a3 / Bp, "K11": 1 / Bp, "T9": theta(data.V3) / A3, "K12": bT / A3, "K13": a2 / A3,
        "tau7": theta(data.V2) / a2,
    }
    reg = g.regulator
    if reg is not None:
        xi0, pe, pc = point["xi"], point["psi_e"], point["psi_cam"]
        x_b = sc["x_B"] if mode == "consistent" else z_b  # x_B*
        sq = math.sqrt(pc - pe)
        av, bv = reg.alpha_B1 * xi0 / (2 * sq), reg.alpha_B1 * sq  # dQ_v/dp_cam, dQ_v/dxi (over g1 [p_B])
        Cp, Gp = reg.alpha_in1 + av, av + a_e
        c |= {
            "T2": math.sqrt(data.m0 / data.k_reg),
            "zeta2": data.c_x / (2 * data.k_reg * math.sqrt(data.m0 / data.k_reg)),
            "K2": data.k_reg * x_b / (p_b * s_b),
            "T3": theta(data.V_cam) / Cp, "K3": av / Cp, "K4": bv / Cp, "T4": data.s_c * x_b / (g1 * p_b * bv),
            "T5": theta(data.V_m) / Gp, "K5": av / Gp, "tau3": theta(data.V_cam) / av, "K6": bv / Gp,
            "T6": (data.s_c - data.s_m) * x_b / (g1 * p_b * bv), "K7": a_e / Gp,
            "tau5": theta(data.V_m) / a_e, "tau6": data.s_m * x_b / (g1 * p_b * Bp),
        }
        if mode == "thesis":
            c["K4"] = bv / (reg.alpha_in1 + reg.alpha_B1 * xi0**1.5 / (2 * sq))  # printed xi0^(3/2)
            if gas:  # (2.169) as printed
                c["tau3"], c["tau5"] = theta(data.V_cam) / Gp, theta(data.V_m) / Bp
        if mode == "program":
            c["K1"], c["K2"] = g.chi, reg.sigma_m * point["dpsi"]
            if gas:  # App. B
                c["tau3"], c["tau5"] = theta(data.V_cam) / Gp, theta(data.V_m) / Bp
            else:  # App. A
                c["K6"] = bv / (reg.alpha_B1 * xi0**1.5 / (2 * sq) + a_e)
                c["K7"] = a_e / (reg.alpha_B1 * xi0 / sq + a_e)
    if mode == "program":
        c["K1"] = g.chi
        if gas:
            c["K9"] = a_e / (1 + a_e + a2 / 2)
            c["K12"] = 1.5 * a_t * math.sqrt(u0 * (p2 - p3)) / A3
            c["tau7"] = theta(data.V2) / (ut / (2 * math.sqrt(p2 - p3)))  # the liquid formula
        else:
            c["K8"] = 2 * bT / Bp
    return Constants(c=c, sigma=g.sigma, sigma_m=reg.sigma_m if reg else math.nan, b=g.b, z_B=z_b,
                     regulator=reg is not None, mode=mode, point=dict(point))


def from_operator(N0: np.ndarray, N1: np.ndarray, N2: np.ndarray, Gin: np.ndarray,
                  template: Constants) -> tuple[dict, dict]:
    """Read the 28 constants off an operator matrix in the (2.101) layout (e.g. from the exact
    Jacobians of the nonlinear model's rows); returns (constants, extra entries): an entry that
    (2.101) does not have (e.g. the per-chamber form's squeeze term s_e dz/dt in row 6) is returned
    under its position "N1[r,c]"."""
    reg = template.regulator
    n = N0.shape[0]
    c = {}
    c["K1"] = N0[0, 0]
    c["T1"] = math.sqrt(N2[0, 0] / N0[0, 0])
    c["zeta1"] = N1[0, 0] / (2 * c["K1"] * c["T1"])
    r5, r6 = n - 2, n - 1
    j2, j3 = n - 2, n - 1
    c["K11" if reg else "K9+K11"] = Gin[r5, 1]  # without the regulator dpsi_e = dpsi1
    used = {(0, 0, 0), (0, 0, 1), (0, 0, 2), (0, j2, 0), (0, j3, 0)}
    c["K8"] = N0[r5, 0]
    c["T8"] = N1[r5, 0] / N0[r5, 0]
    c["T7"], c["K10"] = N1[r5, j2], -N0[r5, j3]
    c["K12"], c["K13"] = -N0[r6, 0], -N0[r6, j2]
    c["tau7"], c["T9"] = N1[r6, j2] / N0[r6, j2], N1[r6, j3]
    used |= {(r5, 0, 0), (r5, 0, 1), (r5, j2, 0), (r5, j2, 1), (r5, j3, 0),
             (r6, 0, 0), (r6, j2, 0), (r6, j2, 1), (r6, j3, 0), (r6, j3, 1)}
    if reg:
        c["K2"] = N0[1, 1]
        c["T2"] = math.sqrt(N2[1, 1] / N0[1, 1])
        c["zeta2"] = N1[1, 1] / (2 * c["K2"] * c["T2"])
        c["K4"], c["T4"] = N0[2, 1], N1[2, 1] / N0[2, 1]
        c["T3"], c["K3"] = N1[2, 2], -N0[2, 3]
        c["K6"], c["T6"] = -N0[3, 1], N1[3, 1] / N0[3, 1]
        c["K5"], c["tau3"] = -N0[3, 2], (N1[3, 2] / N0[3, 2] if N0[3, 2] else math.nan)
        c["T5"], c["K7"] = N1[3, 3], -N0[3, 4]
        c["tau6"] = -N1[r5, 1]
        c["K9"] = -N0[r5, 3]
        c["tau5"] = N1[r5, 3] / N0[r5, 3]
        used |= {(1, 1, 0), (1, 1, 1), (1, 1, 2), (1, 3, 0), (2, 1, 0), (2, 1, 1), (2, 2, 0), (2, 2, 1),
                 (2, 3, 0), (3, 1, 0), (3, 1, 1), (3, 2, 0), (3, 2, 1), (3, 3, 0), (3, 3, 1), (3, 4, 0),
                 (r5, 1, 1), (r5, 3, 0), (r5, 3, 1)}
    extra = {}
    for order, N in enumerate((N0, N1, N2)):
        tol = 1e-10 * np.abs(N).max()
        for (r, j), v in np.ndenumerate(N):
            if (r, j, order) not in used and abs(v) > tol:
                extra[f"N{order}[{r},{j}]"] = float(v)
    return c, extra
