"""Hostile input to the scene parts whose schemas are derived from the SI parameter dataclasses of models/
(autobal/parts/derived.py): a wrong unit, a negative value and an unknown key in each part end with exit 2 and
one line naming the field (and the unit where one is expected), no traceback."""

import pytest

from autobal import cli

CASES = [  # scene, --set, what the line names
    ("pump_pe600_dynamics", "device.dynamics.regulator.stem_mass=3 mm",
     ["device.dynamics.regulator.stem_mass", "not a mass", "kg"]),
    ("pump_pe600_dynamics", "device.dynamics.rotor_mass=-5 kg", ["device.dynamics.rotor_mass", "positive", "kg"]),
    ("pump_pe600_dynamics", "device.dynamics.regulator.stem_damping=-1 N*s/m",
     ["device.dynamics.regulator.stem_damping", "negative", "N*s/m"]),
    ("pump_pe600_dynamics", "device.dynamics.regulator.stem_mas=3 kg",
     ["device.dynamics.regulator.stem_mas", "unknown key"]),
    ("pump_pe600_dynamics", "device.dynamics.forcing_amplitude=0",
     ["device.dynamics.forcing_amplitude", "greater than 0"]),
    ("washer_liquid_balancer_nested", "liquid_balancer.chamber.radius=3 kg",
     ["liquid_balancer.chamber.radius", "not a length", "mm"]),
    ("washer_liquid_balancer_nested", "liquid_balancer.rotor.mass=-5 kg", ["liquid_balancer.rotor.mass", "positive"]),
    ("washer_liquid_balancer_nested", "liquid_balancer.nested.wall_thickness=-1 mm",
     ["liquid_balancer.nested.wall_thickness", "negative", "m"]),
    ("washer_liquid_balancer_nested", "liquid_balancer.liquid.colour=3",
     ["liquid_balancer.liquid.colour", "unknown key"]),
    ("washer_liquid_balancer_nested", "liquid_balancer.rotor.damping_coefficient=2 rad/s",
     ["liquid_balancer.rotor.damping_coefficient", "1/s"]),
    ("spinup_liquid_balancer", "rotor.drive.polar_inertia=3 kg",
     ["rotor.drive.polar_inertia", "not a moment of inertia", "kg*m"]),
    ("spinup_liquid_balancer", "rotor.mass=-5 kg", ["rotor.mass", "positive", "kg"]),
    ("spinup_liquid_balancer", "rotor.drive.drag=-1 N*m*s", ["rotor.drive.drag", "negative", "N*m*s"]),
    ("spinup_liquid_balancer", "rotor.drive.torq=3 N*m", ["rotor.drive.torq", "unknown key"]),
    ("spinup_liquid_balancer", "rotor.liquid.radius=2 kg", ["rotor.liquid.radius", "not a length", "mm"]),
    ("spinup_liquid_balancer", "rotor.liquid.colour=1", ["rotor.liquid.colour", "unknown key"]),
    ("spinup_ross_rotor", "ross_rotor.shaft.0.length=3 kg", ["ross_rotor.shaft.0.length", "not a length", "mm"]),
    ("spinup_ross_rotor", "ross_rotor.disks.0.mass=-5 kg", ["ross_rotor.disks.0.mass", "positive", "kg"]),
    ("spinup_ross_rotor", "ross_rotor.bearings.0.kxx=-1 N/m", ["ross_rotor.bearings.0.kxx", "negative", "N/m"]),
    ("spinup_ross_rotor", "ross_rotor.bearings.0.cxy=1 N*s/m", ["ross_rotor.bearings.0.cxy", "unknown key"]),
    ("spinup_ross_rotor", "ross_rotor.material.colour=1", ["ross_rotor.material.colour", "unknown key"]),
    ("spinup_ross_rotor", "ross_rotor.unbalance.0.phase=400", ["ross_rotor.unbalance.0.phase", "360"]),
]


@pytest.mark.cli
@pytest.mark.parametrize("scene, setting, named", CASES, ids=[c[1].partition("=")[0] + "-" + str(i)
                                                            for i, c in enumerate(CASES)])
def test_bad_input_to_a_derived_part_is_one_line_naming_the_field(capsys, scene, setting, named):
    assert cli.main(["check", scene, "--set", setting]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    for text in named:
        assert text in lines[0], lines[0]
