"""autobal: CasADi models, solvers and studies for rotor balancing devices.

The public API::

    scene = autobal.load("pump_pe600_statics", set={"device.disc.outer_seal.length": "300 mm"})
    run = autobal.run(scene)           # Run: analysis name -> Result
    run["statics"].summary(); run["statics"].plot(); run.save("out/pump")
    done = autobal.load_run("out/pump")  # a finished run back: analysis name -> Result
"""

__version__ = "0.2.0"

__all__ = ["AutobalError", "DeviceParams", "DynamicData", "LiquidLayer", "Result", "RotorParams", "Run", "Scenario",
           "ScenarioError", "SolveError", "__version__", "display_units", "load", "load_run", "reset_solver_defaults",
           "run", "set_solver_defaults", "solver_defaults", "using_solver_defaults"]

_WHERE = {"load": "autobal.api", "run": "autobal.api", "load_run": "autobal.api",
          "Run": "autobal.api", "Result": "autobal.analysis.run.result",
          "Scenario": "autobal.scenario", "AutobalError": "autobal.errors", "ScenarioError": "autobal.errors",
          "SolveError": "autobal.errors", "DeviceParams": "autobal.models.device",
          "DynamicData": "autobal.models.dynamics", "RotorParams": "autobal.models.rotor",
          "LiquidLayer": "autobal.models.rotor", "display_units": "autobal.analysis.run.quantities",
          # module:name where the front door's name is not the module's
          "solver_defaults": "autobal.analysis.run.solver_options:get",
          "set_solver_defaults": "autobal.analysis.run.solver_options:set_defaults",
          "reset_solver_defaults": "autobal.analysis.run.solver_options:reset_defaults",
          "using_solver_defaults": "autobal.analysis.run.solver_options:using"}


def __getattr__(name: str):
    """Import the public names when first used, so ``import autobal.models`` stays light."""
    if name in _WHERE:
        import importlib

        module, _, attr = _WHERE[name].partition(":")
        return getattr(importlib.import_module(module), attr or name)
    raise AttributeError(f"module 'autobal' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
