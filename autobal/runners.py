"""One runner per analysis a scene can name: ``runner(scene, settings) -> Result``.

A runner turns the validated scene into what the analysis takes (parameter objects in SI,
through :mod:`autobal.adapters` where they exist) and returns the analysis' Result; it writes
no files and prints nothing.  ``RUNNERS`` order is the run order.
"""

from __future__ import annotations

import math

from autobal import adapters
from autobal.analysis import progress
from autobal.analysis.result import Result
from autobal.errors import ScenarioError


def statics(scene, settings) -> Result:
    """Static calculation of the balancing device: operating point, criticals, sweep, force-gap."""
    from autobal.analysis import statics_study
    from autobal.analysis.statics import StaticsSolver

    with progress.steps(None, "statics", "IPOPT solve", catch=True):
        return statics_study.run(StaticsSolver(adapters.design(scene.device)), settings, scene.title)


def frequency(scene, settings) -> Result:
    """AFC/PFC of the face gap of every named model (Pavlenko (2014), Eqs. (2.100)-(2.110))."""
    from autobal.analysis import frequency as fr
    from autobal.analysis.linearize import Setup

    setup = Setup(adapters.dynamic_device(scene), settings.operating_ratio)
    o = settings.omega
    res = fr.study(setup, list(settings.models), settings.forcing, (o.start, o.stop, o.points), scene.title)
    res.data["accuracy"] = fr.accuracy(setup, res.data["curves"], settings.forcing)
    return res


def stability(scene, settings) -> Result:
    """Poles, damping, Hurwitz determinants, margin and the optional stability map."""
    from autobal.analysis import stability as st
    from autobal.analysis.linearize import Setup

    setup = Setup(adapters.dynamic_device(scene), settings.operating_ratio)
    res = st.study(setup, list(settings.models), settings.map, scene.title)
    res.data["accuracy"] = st.accuracy(setup, list(settings.models))
    return res


def transient(scene, settings) -> Result:
    """Time responses of the nonlinear device model from its static solution (CVODES / IDAS / RODAS4)."""
    from autobal.analysis import simulate as sim
    from autobal.analysis.linearize import Setup

    setup = Setup(adapters.dynamic_device(scene), settings.operating_ratio)
    model = setup.nonlinear("chain" if settings.model == "nonlinear_chain" else "energy")
    cases = [{"input": c.input, "amplitude": c.amplitude, "frequency": c.frequency,
              "couple": c.thrust_follows_pressure} for c in settings.cases]
    res = sim.study(model, cases, settings.duration, settings.points, settings.integrator, scene.title)
    res.data["accuracy"] = sim.accuracy(model, res, cases, settings.duration, settings.points, settings.integrator)
    return res


def liquid_balancer(scene, settings) -> Result:
    """Design calculations of the liquid auto-balancer (Khomyak (2020); Pashkov (2010), ch. 3)."""
    from autobal.analysis import liquid_balancer as lb

    return lb.run(adapters.liquid_balancer(scene.liquid_balancer), settings, scene.title)


def rotor_dynamics(scene, settings) -> Result:
    """The source's studies of the Jeffcott rotor with a liquid auto-balancer (Pashkov (2010))."""
    from autobal.analysis import rotor_study

    if scene.rotor is None:
        raise ScenarioError("analyses.rotor_dynamics needs a rotor section")
    from autobal.ocp.problem import MAX_PERIODS

    drive, params = scene.rotor.drive, adapters.rotor(scene.rotor)
    ps = settings.passage
    for key in ("acceleration", "sensitivity_acceleration"):
        a = getattr(ps, key, None)
        periods = (ps.final_ratio * params.Omega0 - ps.start_speed) / a * params.Omega0 / (2 * math.pi) if a else 0
        if periods > MAX_PERIODS:  # CVODES over the passage would not finish
            raise ScenarioError(f"analyses.rotor_dynamics.passage.{key}: {a:g} rad/s^2 takes {periods:.3g} natural "
                                f"periods of the rotor to reach final_ratio, more than {MAX_PERIODS:.0e}: give at "
                                f"least {a * periods / MAX_PERIODS:.3g} rad/s^2")
    with progress.steps(None, "rotor dynamics (curves, steps, passage, Lewis cases)", "part", catch=True):
        return rotor_study.run(params, settings, scene.title, drive.motor if drive else None)


def montecarlo(scene, settings) -> Result:
    """Monte Carlo of the device statics (and optionally the AFC) over uncertain groups (Pavlenko (2014),
    ch. 3), on the executor the CLI or the scene names."""
    from autobal.analysis import executor
    from autobal.analysis import montecarlo as mc

    if scene.device is None:
        raise ScenarioError("analyses.montecarlo needs a device section")
    device = adapters.device(scene.device)
    with executor.make(scene_executor=getattr(scene, "executor", None)) as exe:
        return mc.run(adapters.design(scene.device), settings, exe, scene.title, device=device)


def design(scene, settings) -> Result:
    """Stability-constrained design of the balancing device (analysis/design.py)."""
    from autobal.analysis import design as ds
    from autobal.analysis import design_study

    try:
        bounds = settings.bounds_si()
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None
    variables = tuple(ds.Variable(path, key, lo, hi) for path, (key, lo, hi) in bounds.items())
    gap = (settings.face_gap.lower, settings.face_gap.upper)
    weights = {"leakage": (1.0, 0.0), "stiffness": (0.0, 1.0), "mix": tuple(settings.weights)}[settings.objective]
    spec = ds.Spec(variables=variables, points=tuple(settings.operating_ratios), nominal_ratio=settings.nominal_ratio,
                   decay_rate=settings.decay_rate, gap=gap, valve_band=settings.valve_band,
                   min_stiffness=-float("inf") if settings.min_stiffness is None else settings.min_stiffness,
                   weights=weights, form=settings.model)
    with progress.steps(None, "design", "IPOPT solve", catch=True):
        return design_study.run(adapters.dynamic_device(scene), spec, settings.samples, settings.seed,
                                settings.sweep_points, scene.title)


def reliability(scene, settings) -> Result:
    """Reliability of the traditional balance disc: P(t), MTTF, wear (Pavlenko 2014, ch. 1.2)."""
    from autobal.analysis import reliability as rel

    return rel.run(settings, scene.title)


def estimation(scene, settings) -> Result:
    """Parameter estimation from measured static and flow characteristics (Pavlenko (2014), Sec. 4.4)."""
    from autobal.analysis import estimation_study

    device = adapters.device(scene.device) if scene.device is not None else None
    with progress.steps(None, "estimation", "IPOPT solve", catch=True):
        return estimation_study.run(settings, device, scene.title)


def spinup_ocp(scene, settings):
    """The declared spin-up problem (autobal.ocp.problem.SpinupOcp) of a scene's rotor and settings."""
    from autobal.ocp.problem import SpinupOcp

    if scene.rotor is None:
        raise ScenarioError("analyses.spinup needs a rotor section")
    drive = scene.rotor.drive
    try:
        ocp = SpinupOcp(
            adapters.rotor(scene.rotor), settings.start_speed, settings.final_speed, settings.horizon,
            settings.max_acceleration,
            objective=settings.objective, settling_time=settings.settling_time, omega_max=settings.max_speed,
            torque_max=drive.max_torque if drive else None, power_max=drive.max_power if drive else None,
            braking_torque_max=drive.max_braking_torque if drive else None,
            alpha_min=-drive.max_deceleration if drive and drive.max_deceleration is not None else None,
            motor_stall_torque=drive.motor.stall_torque if drive and drive.motor else None,
            motor_no_load_speed=drive.motor.no_load_speed if drive and drive.motor else None,
            deflection_limit=settings.deflection_limit, jerk_max=settings.max_jerk,
            jerk_penalty=settings.jerk_penalty, jerk_variation=settings.jerk_variation)
    except ValueError as exc:
        raise ScenarioError(f"analyses.spinup: {exc}") from None
    why = ocp.ill_posed()
    if why:
        raise ScenarioError(f"analyses.spinup: {why}")
    return ocp


def spinup(scene, settings) -> Result:
    """Optimal spin-up through the critical speed (global search, collocation, CVODES re-simulation)."""
    from autobal.ocp import spinup_study
    from autobal.ocp.solve import ipopt_options

    with progress.steps(None, "spin-up (starts, mesh stages)", "IPOPT solve", catch=True):
        return spinup_study.run(spinup_ocp(scene, settings), spinup_study.method_of(settings), scene.title,
                                settings.multistart, ipopt_options(settings.max_iterations, settings.tolerance),
                                settings.segments)


def spinup_robust(scene, settings) -> Result:
    """One spin-up profile minimising the worst-case peak over a set of rotors, validated on a random sample
    (on the executor the CLI or the scene names)."""
    from autobal.analysis import executor
    from autobal.ocp import robust, robust_study
    from autobal.ocp.solve import ipopt_options
    from autobal.ocp.transcription import DirectCollocation

    ocp = spinup_ocp(scene, settings)
    liquid = settings.liquid_mass_factor
    if liquid is not None and ocp.params.m2_star == 0:
        raise ScenarioError("analyses.spinup_robust.liquid_mass_factor: the rotor has no liquid block (rotor.liquid)")
    unc = robust.Uncertainty(settings.critical_speed_spread, tuple(settings.damping_factor),
                             tuple(liquid) if liquid is not None else None)
    with executor.make(scene_executor=getattr(scene, "executor", None)) as exe, \
            progress.steps(None, "robust spin-up (nominal, scenario generation)", "IPOPT solve", catch=True):
        return robust_study.run(ocp, DirectCollocation(settings.intervals, settings.degree, settings.scheme), unc,
                                settings.design_points, settings.validation_samples, settings.seed, settings.ramps,
                                exe, scene.title, settings.multistart,
                                ipopt_options(settings.max_iterations, settings.tolerance))


def spinup_time_optimal(scene, settings) -> Result:
    """The earliest arrival with the peak bounded, and the front of peak against arrival time."""
    from autobal.ocp import time_optimal_study
    from autobal.ocp.solve import ipopt_options
    from autobal.ocp.transcription import DirectCollocation

    with progress.steps(None, "time-optimal spin-up (front deadlines)", "IPOPT solve", catch=True):
        return time_optimal_study.run(spinup_ocp(scene, settings),
                                      DirectCollocation(settings.intervals, settings.degree, settings.scheme),
                                      settings.front_points, scene.title, settings.multistart,
                                      ipopt_options(settings.max_iterations, settings.tolerance))


def ross_spinup(scene, settings) -> Result:
    """Optimal spin-up of a ROSS rotor reduced to its modes, through its critical speeds, with the reduced
    model's critical speeds checked against ROSS's own (needs the ross extra)."""
    from autobal.models import ross_rotor as rr
    from autobal.ocp import modal

    spec, unbalances = adapters.ross_rotor(scene.ross_rotor)
    rotor = rr.ross_rotor(spec)
    reduced = rr.reduce(rr.lateral_matrices(rotor), unbalances, settings.final_speed, settings.mode_cutoff,
                        settings.gyroscopic_tolerance)
    ross_cs = rr.ross_critical_speeds(rotor, settings.final_speed) if settings.validate_with_ross else None
    kw = {"omega_start": settings.start_speed, "omega_final": settings.final_speed, "horizon": settings.horizon,
          "alpha_max": settings.max_acceleration, "nodes": tuple(settings.nodes),
          "settling_time": settings.settling_time, "omega_max": settings.max_speed, "intervals": settings.intervals,
          "degree": settings.degree}
    try:
        with progress.steps(None, "multi-mode spin-up (starts)", "IPOPT solve", catch=True):
            return modal.run(reduced, kw, scene.title, ross_cs, {"max_iter": settings.max_iterations})
    except ValueError as exc:
        raise ScenarioError(f"analyses.ross_spinup: {exc}") from None


RUNNERS = {
    "statics": statics,
    "frequency": frequency,
    "stability": stability,
    "transient": transient,
    "liquid_balancer": liquid_balancer,
    "estimation": estimation,
    "reliability": reliability,
    "montecarlo": montecarlo,
    "rotor_dynamics": rotor_dynamics,
    "spinup": spinup,
    "spinup_robust": spinup_robust,
    "spinup_time_optimal": spinup_time_optimal,
    "design": design,
    "ross_spinup": ross_spinup,
}



# ---- work-precision studies of a scene (``autobal accuracy``) ---------------------------------------

def statics_accuracy(scene, settings):
    """Work-precision of the statics at the scene's operating point."""
    from autobal.analysis import workprecision
    from autobal.analysis.statics import StaticsSolver

    solver = StaticsSolver(adapters.design(scene.device))
    return workprecision.statics_study(solver, settings.operating_ratio, solver.design.dpsi)


def transient_accuracy(scene, settings):
    """Work-precision of the time integration of the scene's transient (first force step, or dtau = 0.01)."""
    from autobal.analysis import workprecision
    from autobal.analysis.linearize import Setup

    setup = Setup(adapters.dynamic_device(scene), settings.operating_ratio)
    model = setup.nonlinear("chain" if settings.model == "nonlinear_chain" else "energy")
    dtau = next((c.amplitude for c in settings.cases if c.input == "force_step"), 0.01)
    return workprecision.dynamics_study(model, settings.duration, dtau)


def spinup_accuracy(scene, settings):
    """Work-precision of the scene's spin-up OCP (collocation degree and intervals)."""
    from autobal.ocp.workprecision import spinup_study

    with progress.steps(None, "accuracy spinup (degrees x intervals)", "IPOPT solve", catch=True):
        return spinup_study(spinup_ocp(scene, settings))


def estimation_accuracy(scene, settings):
    """Work-precision of the scene's first traditional-disc fit in u (its data, its free parameters)."""
    from autobal.analysis import workprecision

    fit = next((f for f in settings.fits if f.model == "traditional_disc" and f.residual == "u"), None)
    if fit is None:
        raise ScenarioError("work-precision of the estimation needs a traditional_disc fit with residual u")
    data = settings.measurements()
    bases = settings.bases.values()
    return workprecision.estimation_study(data.dimensionless("load", bases), data.dimensionless("gap", bases),
                                          fit.free(), {k: p.value for k, p in fit.parameters.items()})


ACCURACY = {"statics": statics_accuracy, "transient": transient_accuracy, "spinup": spinup_accuracy,
            "estimation": estimation_accuracy}
