"""The models against the thesis's geometry and inertia (Sec. 5.1, Table 5.1, eq. 5.1)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import skidsteer
from conftest import INERTIA_EQ_5_1, REPO, TABLE_5_1
from skidsteer.robot import composite_inertia, load_robot, tire_config
from skidsteer.robot.tire import find_wheels, floor_geoms
from tire_reference import wheel_contact

THESIS_INERTIA_EQ_5_10 = load_robot().variants["thesis"].composite_inertia_kg_m2

import derive_mass_properties as derivation


def test_thesis_variant_has_the_inertia_of_eq_5_10():
    m = skidsteer.load_model("extended", variant="thesis")
    mass, _, inertia = composite_inertia(m, mujoco.MjData(m))
    # exact by construction up to float rounding: drift means the recipe broke
    np.testing.assert_allclose(inertia, np.diag(THESIS_INERTIA_EQ_5_10), atol=1e-9)
    base = skidsteer.load_model("extended")
    assert mass == pytest.approx(composite_inertia(base, mujoco.MjData(base))[0], rel=1e-12)
    assert tire_config("extended", variant="thesis")["contact_point"] == "relay"


def test_composite_inertia_matches_eq_5_1(extended_model):
    # acceptance: within 5 % on the diagonal.  By construction (the platform
    # carries the remainder of eq. 5.1) it is exact up to print rounding, so
    # any drift here means the parts and the derivation fell out of step.
    d = mujoco.MjData(extended_model)
    _, _, inertia = composite_inertia(extended_model, d)
    np.testing.assert_allclose(np.diag(inertia), np.diag(INERTIA_EQ_5_1), rtol=0.05)
    np.testing.assert_allclose(inertia, INERTIA_EQ_5_1, atol=2e-5)


def test_com_at_origin_and_contacts_as_table_5_1(settled):
    # acceptance: CoM-to-contact geometry within 1 cm of Table 5.1, measured
    # on the robot settled on its tires (the tires compress ~0.9 mm)
    m, d = settled
    _, com, _ = composite_inertia(m, d)
    frame = d.xmat[1].reshape(3, 3)
    wheels = find_wheels(m)
    assert [m.body(w.body).name for w in wheels] == ["wheel1", "wheel2", "wheel3", "wheel4"]
    contacts = []
    for wheel in wheels:
        _, _, point = wheel_contact(m, d, wheel, floor_geoms(m))
        contacts.append(frame.T @ (point - com))
    np.testing.assert_allclose(np.array(contacts), TABLE_5_1, atol=0.01)


def test_masses_follow_the_stated_evidence(extended_model, platform_model):
    # platform 225 N / 9.8 (Sec. 3.3, the thesis's g), frame parts as derived
    assert platform_model.body_subtreemass[1] == pytest.approx(225 / 9.8, rel=1e-6)
    derived = derivation.derive()
    assert extended_model.body_subtreemass[1] == pytest.approx(derived["total_mass_kg"], rel=1e-6)


def test_frame_parts_match_the_derivation(extended_model):
    # models/pioneer3at/parts/frame.xml carries the numbers of scripts/derive_mass_properties.py
    m = extended_model
    for name, mass, position, inertia in derivation.parts():
        body = m.body(name)
        assert body.mass[0] == pytest.approx(mass, rel=1e-9), name
        # position from the CoM (chassis frame); the frame parts hang from the
        # "frame" body at the mast's foot
        parent = m.body_parentid[body.id]
        from_com = m.body_pos[body.id] + (m.body_pos[parent] if parent != 1 else 0)
        assert m.body(parent).name in ("chassis", "frame"), name
        np.testing.assert_allclose(from_com, position, atol=1e-9, err_msg=name)
        np.testing.assert_allclose(np.sort(body.inertia), np.sort(np.diag(inertia)), rtol=1e-6,
                                   err_msg=name)
    platform = derivation.derive()
    np.testing.assert_allclose(m.body_ipos[1], platform["platform_com_m"], atol=1e-6)


def test_platform_is_the_extended_robot_without_the_frame(extended_model, platform_model):
    ext, plat = extended_model, platform_model
    frame_parts = {"frame", "mast", "laptop", "camera"}
    ext_bodies = {ext.body(b).name for b in range(ext.nbody)}
    plat_bodies = {plat.body(b).name for b in range(plat.nbody)}
    assert ext_bodies - plat_bodies == frame_parts
    for name in plat_bodies:
        a, b = ext.body(name), plat.body(name)
        np.testing.assert_array_equal(a.pos, b.pos)
        np.testing.assert_array_equal(a.mass, b.mass)
        np.testing.assert_array_equal(a.inertia, b.inertia)


def test_models_open_with_plain_mujoco_after_import():
    # the promise: import skidsteer, then plain MuJoCo loads the files
    for name in ("pioneer3at_extended.xml", "pioneer3at.xml"):
        m = mujoco.MjModel.from_xml_path(str(REPO / "models" / "pioneer3at" / name))
        d = mujoco.MjData(m)
        mujoco.mj_step(m, d)
        assert m.nplugin == 1


def _model_bytes(m: mujoco.MjModel) -> bytes:
    buffer = np.zeros(mujoco.mj_sizeModel(m), np.uint8)
    mujoco.mj_saveModel(m, None, buffer)
    return buffer.tobytes()


@pytest.mark.parametrize("robot", ["pioneer3at", "husky_a200"])
def test_scene_is_the_default_build_with_its_floor(robot):
    # scene.xml, the file MuJoCo's viewers open, compiles to the very model skidsteer
    # loads as the robot's default build: byte for byte once given the build's name
    description = load_robot(robot)
    build = mujoco.MjModel.from_xml_path(str(description.build(None).file))
    spec = mujoco.MjSpec.from_file(str(REPO / "models" / robot / "scene.xml"))
    spec.modelname = build.names[:build.names.index(b"\0")].decode()
    assert _model_bytes(spec.compile()) == _model_bytes(build)


@pytest.mark.parametrize("robot", ["pioneer3at", "husky_a200"])
def test_scene_loads_with_the_plugin_and_stands_on_its_tires(robot):
    m = mujoco.MjModel.from_xml_path(str(REPO / "models" / robot / "scene.xml"))
    assert m.nplugin == 1
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    start_m = d.body("chassis").xpos.copy()
    mujoco.mj_step(m, d, nstep=2000)  # 0.2 s at the models' 0.1 ms step
    assert np.isfinite(d.qpos).all() and not d.warning.number.any()
    # 2 cm: three times the Husky's static tire deflection (~7 mm, husky_a200.xml), a
    # tenth of the 0.2 m a robot off its tires (a floor below the wheels) falls in 0.2 s
    np.testing.assert_allclose(d.body("chassis").xpos, start_m, atol=0.02)


def test_floors_are_named_parameter_sets():
    assert skidsteer.FLOORS == ("concrete", "tile", "carpet")
    assert tire_config("extended", "carpet")["floor"] == "carpet"


def test_accelerometer_site_and_axes(extended_model):
    # p_a = [-0.2, 0, 0] from the CoM, axes parallel to the robot's (Sec. 3.2)
    m = extended_model
    site = m.site("accelerometer_cube")
    np.testing.assert_allclose(site.pos, [-0.2, 0, 0], atol=1e-12)
    np.testing.assert_allclose(site.quat, [1, 0, 0, 0], atol=1e-12)


def test_one_velocity_servo_per_side_within_motor_limits(extended_model):
    m = extended_model
    assert [m.actuator(i).name for i in range(m.nu)] == ["left_motor", "right_motor"]
    # 1200 mm/s firmware maximum over the wheel radius
    np.testing.assert_allclose(m.actuator_ctrlrange, [[-11.16, 11.16]] * 2)
    assert all(m.actuator_ctrllimited)
