"""Bad input fails early with a message naming the attribute, file or name at fault."""

from __future__ import annotations

import re

import mujoco
import pytest

import skidsteer
from skidsteer.robot import load_spec, tire

BAD_ATTRIBUTES = [
    ("stiffness_y", "-5", "must be a finite number > 0"),
    ("stiffness_z", "0", "must be a finite number > 0"),
    ("damping_z", "-1", "must be a finite number >= 0"),
    ("belt_stiffness", "inf", "must be a finite number > 0"),
    ("tread_stiffness_x", "-3", "must be > 0"),
    ("mu_static", "0", "must be a finite number > 0"),
    ("mu_kinetic", "0.9", "must not exceed mu_static"),
    ("lambda_max", "0", "must lie in (0, 1]"),
    ("lambda_max", "1.5", "must lie in (0, 1]"),
    ("contact_mass", "0", "must be a finite number > 0"),
    ("sliding_friction_ratio", "0", "must lie in (0, 1]"),
    ("sliding_friction_ratio", "1.2", "must lie in (0, 1]"),
    ("sliding_velocity", "-0.1", "must be a finite number > 0"),
    ("sliding_velocity", "inf", "must be a finite number > 0"),
    ("stiffness_y_load_exponent", "-0.5", "must lie in [0, 2]"),
    ("stiffness_y_load_exponent", "3", "must lie in [0, 2]"),
    ("reference_load", "0", "must be a finite number > 0"),
    ("lug_count", "2.5", "must be a whole number in [0, 1000]"),
    ("lug_count", "-1", "must be a whole number in [0, 1000]"),
    ("lug_depth", "0.1", "must lie in [0, 0.05] m"),
    ("radius", "-0.1", "must be > 0"),
    ("lateral_friction_ratio", "0", "must lie in (0, 10]"),
    ("lateral_friction_ratio", "nan", "is not a number"),
    ("lateral_friction_ratio", "12", "must lie in (0, 10]"),
    ("tread_lateral_friction_ratio", "-1", "must lie in (0, 10]"),
    ("damping_y", "abc", "is not a number"),
    ("contact_substeps", "0", "must be a whole number in [1, 1000]"),
    ("contact_substeps", "2.5", "must be a whole number in [1, 1000]"),
    ("stiffness_x_typo", "1", None),  # unknown key: rejected by the compiler
]


@pytest.mark.parametrize("key, value, rule", BAD_ATTRIBUTES)
def test_bad_tire_attribute_fails_at_compile_time_naming_it(key, value, rule):
    spec = mujoco.MjSpec.from_file(str(skidsteer.model_path("extended")))
    instance = spec.plugins[0]
    config = dict(instance.config)
    config[key] = value
    instance.config = config
    with pytest.raises(ValueError) as error:
        spec.compile()
    message = str(error.value)
    assert key in message
    if rule is not None:
        assert f'{key}="{value}"' in message and rule in message


def test_mu_kinetic_above_mu_static_names_both_values():
    with pytest.raises(ValueError, match=r'mu_kinetic="0\.99".*must not exceed mu_static'):
        skidsteer.load_model(tire={"mu_static": 0.9, "mu_kinetic": 0.99})


def test_contact_substeps_need_the_implicit_coupling():
    # the substeps' mean force is solved for by the implicit coupling; the explicit one
    # applies the start-of-step force and has no use for them
    with pytest.raises(ValueError, match=r'contact_substeps="10".*coupling="explicit"'):
        skidsteer.load_model(tire={"coupling": "explicit", "contact_substeps": 10})
    skidsteer.load_model(tire={"coupling": "implicit", "contact_substeps": 10})


CHOICE_ATTRIBUTES = [a for a in tire.attributes().values() if a.kind == "choice"]


@pytest.mark.parametrize("attribute", CHOICE_ATTRIBUTES, ids=lambda a: a.name)
def test_unknown_choice_fails_at_compile_time_naming_it_and_the_choices(attribute):
    # every choice attribute of the plugin's table (floor, contact_point, coupling,
    # floor_interpolation, ...): the message names the attribute, the value and its rule
    assert "ice" not in attribute.choices
    spec = mujoco.MjSpec.from_file(str(skidsteer.model_path("extended")))
    spec.plugins[0].config = {attribute.name: "ice"}
    with pytest.raises(ValueError, match=re.escape(
            f'{attribute.name}="ice" is unknown: {attribute.rule}')):
        spec.compile()


def test_unknown_contact_point_model_fails_naming_it():
    with pytest.raises(ValueError, match='contact_point="stick" is unknown: use coulomb'):
        skidsteer.load_model(tire={"contact_point": "stick"})


def test_loader_rejects_unknown_names_before_compiling():
    with pytest.raises(ValueError, match="unknown floor 'ice'"):
        skidsteer.load_model("extended", "ice")
    with pytest.raises(ValueError, match="unknown model 'tank'"):
        skidsteer.load_model("tank")
    with pytest.raises(FileNotFoundError, match="nowhere.xml"):
        skidsteer.load_model("nowhere.xml")
    with pytest.raises(ValueError, match="unknown tire attribute 'stifness_y'"):
        skidsteer.load_model(tire={"stifness_y": 1})
    for bad in (0, -1e-4, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="timestep must be a finite number > 0 s"):
            skidsteer.load_model(timestep=bad)


def test_wheel_that_also_collides_natively_is_rejected():
    spec = load_spec("extended")
    spec.geom("tire2").contype = 1
    spec.geom("tire2").conaffinity = 1
    with pytest.raises(ValueError, match="geom 'tire2' of wheel 'wheel2' also collides"):
        spec.compile()


def test_wheel_without_radius_source_is_rejected():
    spec = load_spec("extended")
    spec.geom("tire3").type = mujoco.mjtGeom.mjGEOM_BOX
    spec.geom("tire3").size = [0.1, 0.05, 0.1]
    with pytest.raises(ValueError, match="wheel body 'wheel3' has no cylinder or sphere geom"):
        spec.compile()


def test_model_without_floor_is_rejected():
    spec = load_spec("extended")
    spec.delete(spec.geom("floor"))
    with pytest.raises(ValueError, match="no floor"):
        spec.compile()


def test_cli_reports_bad_input_without_a_traceback(capsys):
    from skidsteer.cli import main

    assert main(["tire-loads", "--config", "extended", "--surface", "concrete", "--json"]) == 0
    capsys.readouterr()
    with pytest.raises(SystemExit):  # argparse names the bad choice
        main(["swivel", "--surface", "ice"])
    assert "invalid choice: 'ice'" in capsys.readouterr().err
