"""Studies of a scene: each puts the numerics together into the Result of one analysis.

The statics study (statics_study.py), the stability-constrained design (design_study.py), the estimation
(estimation_study.py), the Monte Carlo study (montecarlo.py, with its statics and AFC parts montecarlo_statics.py,
montecarlo_afc.py), the disc's reliability (reliability.py), the rotor with a liquid auto-balancer
(rotor_study.py), the rotor identified from a run-up (runup.py), the liquid auto-balancer (liquid_balancer.py) and
the work-precision studies (workprecision.py).  Their rooms (settings, runner, report section) are
autobal/analyses/.
"""
