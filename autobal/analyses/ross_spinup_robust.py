"""``analyses.ross_spinup_robust``: one spin-up profile of a ROSS rotor reduced to its modes minimising the
worst-case peak over a set of rotors around the scene's (every natural frequency and the modal damping scaled),
validated on a random sample beside the nominal optimum and the constant ramps: the robust study of
:mod:`autobal.ocp.robust_study` on the modal problem of :mod:`autobal.ocp.modal`.

Needs the optional ROSS package (``pip install -e '.[ross]'``).
"""

from __future__ import annotations

from pydantic import create_model, model_validator

from autobal.analyses import COST, ross_spinup
from autobal.analyses.ross_spinup import RossSpinup
from autobal.analyses.spinup_robust import SpinupRobust, report_section  # noqa: F401  one section for both rotors

DESCRIPTION = "one spin-up profile of a ROSS rotor for a set of rotors (worst case; the ross extra)"
NEEDS = "ross_rotor"
EXTRA = "ross"  # the optional package it needs (autobal.analyses.EXTRAS)
QUANTITIES_MODULE = "autobal.ocp.robust_study"  # the robust study's declarations: peaks in m for the modal rotor
TITLE = "Robust spin-up of a ROSS rotor (multi-mode)"

#: the robust study's settings, as the Jeffcott rotor's spinup_robust declares them (no liquid: the modal rotor has
#: none)
ROBUST = ("critical_speed_spread", "damping_factor", "design_points", "validation_samples", "seed", "ramps")


class RossSpinupRobust(create_model("_RossSpinupWithRanges", __base__=RossSpinup,
                                    **{k: (SpinupRobust.model_fields[k].annotation, SpinupRobust.model_fields[k])
                                       for k in ROBUST})):
    """Robust spin-up of the ROSS rotor reduced to its modes, posed as ``ross_spinup``: one profile minimising
    the worst-case re-simulated peak over the rotors with every natural frequency within (1 +- spread) of the
    scene's (modal stiffness scaled) and the modal damping scaled by a factor in ``damping_factor``, checked on a
    random validation sample beside the nominal optimum and the constant ramps."""

    @model_validator(mode="after")
    def _robust(self):
        if "validate_with_ross" in self.model_fields_set:
            raise ValueError("validate_with_ross: the robust study does not compare critical speeds with ROSS's "
                             "(the ross_spinup analysis does)")
        lo, hi = self.damping_factor
        if lo > hi:
            raise ValueError("damping_factor: [lo, hi] with lo <= hi (dimensionless)")
        return self


SETTINGS = RossSpinupRobust


def problem(scene, settings: RossSpinupRobust):
    """The nominal spin-up problem of the scene's ROSS rotor reduced to its modes (SI; needs the ross extra)."""
    return ross_spinup.problem(scene, settings, "ross_spinup_robust")


def check(scene, settings: RossSpinupRobust) -> None:
    """``autobal check``: the nominal modal problem posed, nothing solved."""
    problem(scene, settings)


def run(scene, settings: RossSpinupRobust):
    """One spin-up profile of the reduced ROSS rotor minimising the worst-case peak over a set of rotors,
    validated on a random sample (on the executor the CLI or the scene names; needs the ross extra)."""
    from autobal.analysis.run import executor, progress, solver_options
    from autobal.ocp import robust, robust_study

    ocp = problem(scene, settings)
    unc = robust.Uncertainty(settings.critical_speed_spread, tuple(settings.damping_factor))
    with executor.make(scene_executor=getattr(scene, "executor", None)) as exe, \
            progress.steps(None, "robust spin-up of the modal rotor (nominal, scenario generation)", "IPOPT solve",
                           catch=True):
        return robust_study.run(ocp, ocp.method, unc, settings.design_points, settings.validation_samples,
                                settings.seed, settings.ramps, exe, scene.title,
                                options=solver_options.ipopt_options(settings.max_iterations))


def estimate_seconds(settings: RossSpinupRobust) -> float:
    """ROSS's import and the rotor's matrices (about 10 s), the nominal and multi-rotor collocation NLPs of the
    modal envelope, then every profile on every validation rotor."""
    return (COST["ross_rotor"] + COST["start"] + COST["modal_ocp_point"] * settings.intervals * settings.degree * 8
            + COST["robust_validation_run"] * 10 * settings.validation_samples * (settings.ramps + 2))
