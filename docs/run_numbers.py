"""The toolkit's numbers quoted in docs/, from runs of the shipped scenes.

    python docs/run_numbers.py                      # run every scene below, rewrite docs/numbers.json
    python docs/run_numbers.py pump_pe600_design    # only those named (the other runs are kept)

Each scene is run as ``autobal run SCENE`` runs it (``autobal.api.run`` into a temporary folder), and the
values that the pages quote are taken from its results.json by the extractor below and recorded in
docs/numbers.json with the command, the commit and the date.  A page quotes one as ``{{ n:SCENE.KEY:FORMAT }}``
(docs/hooks.py replaces it at build time; an unknown key stops the build).  ``tests/test_docs_numbers.py``
checks that every placeholder resolves, and (slow) that a fresh run of each scene gives the recorded values
within each value's tolerance (``TOLERANCE``).

Numbers of the benchmarks are not here: the pages take them from ``benchmarks/results/NAME.json``, which
``python -m benchmarks NAME`` writes.
"""

from __future__ import annotations

import datetime
import json
import re
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NUMBERS = ROOT / "docs" / "numbers.json"


def _by_ratio(mapping: dict) -> list[float]:
    """The values of a mapping keyed by operating ratio ("0.5", "0.75", ...), in the order of the ratios; the
    ratios without a value (null, with a ``_status``) left out."""
    return [mapping[k] for k in sorted((k for k in mapping if not k.endswith("_status")), key=float)
            if mapping[k] is not None]


def _range(mapping: dict) -> list[float]:
    """[smallest, largest] of the finite values of a mapping keyed by operating ratio."""
    finite = _by_ratio(mapping)
    return [min(finite), max(finite)]


def _short(path: str) -> str:
    """A design variable's short name: its scene path's last two parts ("supply_throttle_diameter")."""
    return "_".join(path.split(".")[-2:])


DISPLAY = {"m": ("mm", 1e3), "Pa": ("MPa", 1e-6), "m^3": ("cm3", 1e6), "m^2": ("mm2", 1e6)}


def design(results: dict) -> dict:
    """The design page's numbers of one design scene (``analyses: design``): the optimum's and the nominal
    design's leakage, decay rates and variables (display units in the key: ``_mm``, ``_MPa``, ``_cm3``),
    the active constraints' multipliers, the certification, and the other models' spectral abscissa
    ([smallest, largest] over the operating points)."""
    d = results["design"]
    o, n = d["optimum"], d["nominal"]
    variables = {}
    for path, text in o["parameters"].items():
        unit, factor = DISPLAY.get(text.partition(" ")[2], ("", 1.0))
        variables[_short(path) + (f"_{unit}" if unit else "")] = [factor * n["values_si"][path],
                                                                   factor * o["values_si"][path]]
    c = d["certification"]
    return {
        "objective": o["objective"],
        "leakage_m3_s": [n["leakage"], o["leakage"]],
        "decay_rate_1_s": _by_ratio(o["margin"]),
        "nominal_decay_rate_1_s": _by_ratio(n["margin"]),  # at the ratios where it has a static solution
        "iterations": d["iterations"],
        "variables": variables,
        "multipliers": {re.sub(r"\W+", "_", a["constraint"]).strip("_"): a["multiplier"] for a in d["active"]},
        "certification": {k: c[k] for k in ("samples", "feasible_samples", "best_sample", "local_samples",
                                            "feasible_local_samples", "best_local_sample")},
        "accuracy_estimate": results["accuracy"]["design"]["estimate"],
        "accuracy_finite_difference": max(a["relative_difference_finite_difference"]
                                          for a in results["accuracy"]["design"]["abscissa"].values()),
        "other_model_abscissa_1_s": {k: _range(d["other_model"][k]) for k in ("nominal", "optimum")},
        "program_model_abscissa_1_s": {k: _range(d["program_model"][k]) for k in ("nominal", "optimum")},
    }


def robust(results: dict) -> dict:
    """The robust spin-up's numbers (``analyses: spinup_robust``), peaks delta/e, re-simulated."""
    d = results["spinup_robust"]
    out = {}
    for key, p in d["profiles"].items():
        q = p["validation_quantiles_over_e"]
        out[key] = {"nominal_peak_over_e": p["nominal_peak_over_e"], "design_worst_over_e": p["design_worst_over_e"],
                    "validation_worst_over_e": p["validation_worst_over_e"], "validation_median_over_e": q["0.5"],
                    "validation_q99_over_e": q["0.99"]}
    r, n, b = (out[k] for k in ("robust", "nominal", "ramp"))
    out["robust_cost_on_nominal_percent"] = 100 * (r["nominal_peak_over_e"] / n["nominal_peak_over_e"] - 1)
    out["worst_below_nominal_percent"] = 100 * (1 - r["validation_worst_over_e"] / n["validation_worst_over_e"])
    out["worst_below_ramp_percent"] = 100 * (1 - r["validation_worst_over_e"] / b["validation_worst_over_e"])
    out["binding_design_rotors"] = len(d["active_design_rotors"])
    out["binding_critical_speed_factors"] = sorted(f[0] for f in d["active_design_rotors"])
    out["binding_damping_factors"] = sorted({f[1] for f in d["active_design_rotors"]})
    out["design_rotors"] = d["design_scenarios"]
    out["validation_rotors"] = d["validation_samples"]
    return out


EXTRACT: dict[str, Callable[[dict], dict]] = {
    "pump_pe600_design": design,
    "compressor_k180_design": design,
    "spinup_robust_jeffcott": robust,
}

# Relative tolerance of each value against a fresh run (a key missing here: DEFAULT_TOLERANCE) and why.
DEFAULT_TOLERANCE = 1e-6
TOLERANCE: dict[str, dict[str, float]] = {}


def commit() -> str:
    """The commit of the working tree, with ``+dirty`` when it has uncommitted changes to tracked files."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()

    try:
        head = git("rev-parse", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


def values(scene: str, results: dict) -> dict:
    """The recorded values of a scene's run, from its results.json."""
    return EXTRACT[scene](results)


def run(scene: str) -> dict:
    """Run a scene as ``autobal run`` does and read its results.json."""
    from autobal import api

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / scene
        api.run(scene, out=folder)
        return json.loads((folder / "results.json").read_text(encoding="utf-8"))


def record(scenes: list[str]) -> dict:
    """Run the scenes and rewrite docs/numbers.json (the runs not named are kept)."""
    numbers = json.loads(NUMBERS.read_text(encoding="utf-8")) if NUMBERS.is_file() else {"runs": {}}
    numbers["about"] = ("Numbers the toolkit computed, quoted in docs/ as {{ n:SCENE.KEY:FORMAT }}; "
                        "regenerated by `python docs/run_numbers.py [SCENE ...]` (docs/run_numbers.py)")
    at = commit()  # the code the runs below use (before anything else is edited)
    for scene in scenes:
        print(f"running {scene} ...", flush=True)
        results = run(scene)
        numbers["runs"][scene] = {
            "command": f"autobal run {scene}",
            "regenerate": f"python docs/run_numbers.py {scene}",
            "commit": at,
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "autobal": results.get("meta", {}).get("version", ""),
            "values": values(scene, results),
        }
    numbers["runs"] = dict(sorted(numbers["runs"].items()))
    NUMBERS.write_text(json.dumps(numbers, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return numbers


def main(argv: list[str]) -> int:
    unknown = [s for s in argv if s not in EXTRACT]
    if unknown:
        print(f"unknown scene {', '.join(unknown)}: one of {', '.join(EXTRACT)}", file=sys.stderr)
        return 2
    record(argv or list(EXTRACT))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
