"""The spin-up model protocol (autobal.ocp.protocol.SpinupProblem): both problem classes implement it, every member
is documented, and the transcription and the solver read nothing of a problem outside it (a problem seen through
the protocol alone transcribes to the same NLP and solves to the same optimum, bit for bit)."""

from __future__ import annotations

import ast
import dataclasses
import inspect

import casadi as ca
import numpy as np
import pytest

from autobal.models import ross_rotor as rr
from autobal.ocp import modal, problem, solve
from autobal.ocp.protocol import SpinupProblem
from autobal.ocp.transcription import DirectCollocation, MultipleShooting, transcribe
from tests.test_ross_rotor import disk_rotor
from tests.test_spinup import real_problem

MEMBERS = set(SpinupProblem.__annotations__) | {
    k for k, v in vars(SpinupProblem).items() if not k.startswith("_") and (callable(v) or isinstance(v, property))}


class Seen:
    """A problem seen through the protocol: reading any other member fails the test."""

    def __init__(self, ocp):
        object.__setattr__(self, "_ocp", ocp)

    def __getattr__(self, name):
        if name not in MEMBERS:
            raise AssertionError(f"the pipeline read {name!r} of the problem, not a member of SpinupProblem")
        return getattr(self._ocp, name)


def modal_problem(**kw) -> modal.ModalSpinupOcp:
    red = rr.reduce(disk_rotor(), [rr.Unbalance(0, 1e-4)], omega_final=150.0, cutoff=1.5)
    return modal.ModalSpinupOcp(red, 50.0, 150.0, 1.5, 100.0, (0,), settling_time=0.3, omega_max=150.0,
                                intervals=20, **kw)


def test_every_member_is_documented():
    """Each data member has its docstring (the string after its annotation), each property and method its own; the
    protocol covers the state, dynamics, path constraints, starts, reference level, re-simulation and ranking."""
    tree = ast.parse(inspect.getsource(SpinupProblem))
    body = tree.body[0].body
    for i, node in enumerate(body):
        if isinstance(node, ast.AnnAssign):
            nxt = body[i + 1] if i + 1 < len(body) else None
            assert isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant) and nxt.value.value.strip(), \
                node.target.id
    for k, v in vars(SpinupProblem).items():
        if not k.startswith("_") and (callable(v) or isinstance(v, property)):
            assert (v.fget if isinstance(v, property) else v).__doc__, k
    assert {"nx", "dynamics", "path_constraints", "starts", "reference_level", "resimulate",
            "rank_coarse", "hold_states"} <= MEMBERS


def test_both_problem_classes_implement_it():
    jeffcott, mod = real_problem(40.0), modal_problem()
    for ocp in (jeffcott, mod):
        assert isinstance(ocp, SpinupProblem)
        assert all(hasattr(ocp, m) for m in MEMBERS)
    assert jeffcott.hold_states and not mod.hold_states  # the two models' own choice of coarse guesses
    assert not hasattr(solve, "MODELS")  # no registry: the pipeline calls the problem's methods


@pytest.mark.parametrize("case", ["peak", "integrated", "min_time_jerk", "shooting", "modal", "modal_min_time"])
def test_transcription_reads_only_the_protocol(case):
    """The NLP of a problem seen through the protocol equals the problem's own: objective and constraints at a
    random point bit for bit, the same bounds and blocks."""
    base = real_problem(40.0)
    method = DirectCollocation(20)
    ocp = {"peak": base, "integrated": dataclasses.replace(base, objective="integrated_deflection"),
           "min_time_jerk": dataclasses.replace(base, objective="min_time", deflection_limit=20.0, jerk_max=400.0),
           "shooting": base, "modal": None, "modal_min_time": None}[case]
    if case == "shooting":
        method = MultipleShooting(8)
    if case.startswith("modal"):
        ocp = modal_problem(**({"objective": "min_time", "deflection_limit": 1e-3} if case == "modal_min_time"
                               else {}))
    a, b = transcribe(ocp, method, 2.0, "MX"), transcribe(Seen(ocp), method, 2.0, "MX")
    x = np.random.default_rng(0).standard_normal(a.x.numel()) * 0.1
    fa, fb = (ca.Function("nlp", [n.x], [n.f, n.g]) for n in (a, b))
    for p, q in zip(fa(x), fb(x), strict=True):
        assert np.array_equal(np.array(p), np.array(q))
    for k in ("lbx", "ubx", "lbg", "ubg"):
        assert np.array_equal(getattr(a, k), getattr(b, k))
    assert [n for n, _ in a.blocks] == [n for n, _ in b.blocks]


@pytest.mark.parametrize("make", [lambda: real_problem(40.0), modal_problem], ids=["jeffcott", "modal"])
def test_solver_reads_only_the_protocol(make):
    """One IPOPT solve of a problem seen through the protocol (its reference level, its first start, the
    re-simulation of the optimum) gives the problem's own optimum, bit for bit."""
    ocp = make()
    method = DirectCollocation(20)
    out = []
    for o in (ocp, Seen(ocp)):
        u = o.starts(20, multistart=False)[0][1]
        sol = solve.Solver(o, method, o.reference_level(), {"max_iter": 300}).solve(u)
        out.append((sol.objective, sol.peak_collocation, o.resimulate(sol.u, sol.h, "optimum").peak))
    assert out[0] == out[1] and np.isfinite(out[0]).all()


def test_a_new_problem_class_needs_no_registration():
    """A subclass of the Jeffcott problem (not a registered type) is solved by the shared loop: its own starts are
    called (the single-start list) and each solved and re-simulated; the registry's lookup by type would have
    failed."""

    @dataclasses.dataclass
    class OneStart(problem.SpinupOcp):
        calls: list = dataclasses.field(default_factory=list)

        def starts(self, n, multistart=True):
            out = super().starts(n, multistart=False)
            self.calls.append((n, len(out)))
            return out

    ocp = OneStart(**{f.name: getattr(real_problem(40.0), f.name) for f in dataclasses.fields(problem.SpinupOcp)})
    opt = solve.optimize(ocp, DirectCollocation(25), multistart=True, options={"max_iter": 300})
    (n, count), = ocp.calls
    assert n == 25 and count == len([r for r in opt.starts if "objective" in r]) >= 1
    assert opt.score == pytest.approx(ocp.resimulate(opt.solution.u, opt.solution.h, "again").peak, rel=1e-12)
