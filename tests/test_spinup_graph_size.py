"""The spin-up collocation NLP's symbolic size does not grow with the number of intervals: the terms
outside the mapped interval Function (the objective with its jerk terms, the final-speed and jerk-limit
rows) are a fixed number of MX nodes, so their MX derivatives build in time linear in N (written as n
scalar nodes, the study's NLP build grew as N^1.6: benchmarks/spinup_ocp.md, "Study scaling with N")."""

import dataclasses

import casadi as ca
import pytest

from autobal.models.rotor import RotorParams
from autobal.ocp import spinup as S

BASE = S.SpinupOcp(RotorParams.from_groups(105.0, 5.0, 1.0), 40.0, 210.0, 5.0, 40.0, settling_time=3.0,
                   omega_max=210.0)


@pytest.mark.parametrize("jerk", [{"jerk_variation": 1e-4}, {"jerk_penalty": 1e-3, "jerk_max": 400.0}])
def test_terms_outside_the_intervals_have_a_size_independent_of_n(jerk):
    ocp = dataclasses.replace(BASE, **jerk)
    sizes = []
    for n in (20, 160):
        nlp = S.transcribe(ocp, S.DirectCollocation(n), 200.0, "MX")
        sizes.append(ca.Function("rest", [nlp.x], [nlp.f, nlp.intervals["tail"]]).n_nodes())
    assert sizes[0] == sizes[1]
