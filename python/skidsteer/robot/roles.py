"""What a model's parts are to skidsteer: its drive, its sensors, its wheels, its parts.

A model says it with ``<custom><text name="skidsteer.ROLE" data="NAMES"/></custom>``
(models/pioneer3at/parts/drive.xml); without a text, a role is inferred:

- wheels: the bodies that name the tire plugin instance (the plugin's rule),
  in body order; the chassis: their root body;
- ``skidsteer.drive.left`` / ``skidsteer.drive.right``: the actuators whose
  transmission (a joint or a fixed tendon) moves wheel axles of one side only,
  by the sign of those wheels' y in the chassis frame (y left); their control
  is the side's wheel speed in rad/s;
- ``skidsteer.accelerometer`` / ``skidsteer.gyro``: the model's only sensor of
  that type (two or more need the text);
- the tire forces: the plugin sensor of the tire instance;
- ``skidsteer.part.mast`` / ``skidsteer.part.payload``: never inferred; the
  causes that act on them do not apply without;
- ``<numeric name="skidsteer.drive.logged_speed_scale">``: the wheels' rim speed per
  wheel speed in a recording of the robot (1 without), which a replay applies.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from skidsteer.robot import tire

PREFIX = "skidsteer."
_ACCELEROMETER = int(mujoco.mjtSensor.mjSENS_ACCELEROMETER)
_GYRO = int(mujoco.mjtSensor.mjSENS_GYRO)
_TRN_JOINT = int(mujoco.mjtTrn.mjTRN_JOINT)
_TRN_TENDON = int(mujoco.mjtTrn.mjTRN_TENDON)


def model_text(m: mujoco.MjModel, role: str) -> str | None:
    """The data of <text name="skidsteer.ROLE">, None without one."""
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TEXT, PREFIX + role)
    if i < 0:
        return None
    adr, size = int(m.text_adr[i]), int(m.text_size[i])
    return bytes(m.text_data[adr:adr + size]).split(b"\0", 1)[0].decode()


def spec_text(spec: mujoco.MjSpec, role: str) -> str | None:
    text = spec.text(PREFIX + role)
    return None if text is None else text.data


def model_numeric(m: mujoco.MjModel, role: str, default: float) -> float:
    """The value of <numeric name="skidsteer.ROLE">, default without one."""
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_NUMERIC, PREFIX + role)
    if i < 0:
        return default
    return float(m.numeric_data[int(m.numeric_adr[i])])


def spec_numeric(spec: mujoco.MjSpec, role: str, default: float) -> float:
    numeric = spec.numeric(PREFIX + role)
    return default if numeric is None else float(numeric.data[0])


def set_spec_numeric(spec: mujoco.MjSpec, role: str, value: float) -> None:
    """Sets (adding it if needed) <numeric name="skidsteer.ROLE" data="value">."""
    numeric = spec.numeric(PREFIX + role)
    if numeric is None:
        numeric = spec.add_numeric(name=PREFIX + role, size=1)
    numeric.data = [float(value)]


def _only(kind: str, ids: list[int], names: list[str], role: str) -> int | None:
    if len(ids) > 1:
        raise ValueError(f"the model has {len(ids)} {kind} sensors ({', '.join(names)}); name "
                         f"the one to use with <custom><text name=\"{PREFIX}{role}\" "
                         f"data=\"NAME\"/></custom>")
    return ids[0] if ids else None


def _sensor_by_role(m: mujoco.MjModel, role: str, kind: int, label: str) -> int | None:
    named = model_text(m, role)
    if named is not None:
        i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, named)
        if i < 0:
            raise ValueError(f"<text name=\"{PREFIX}{role}\"> names sensor {named!r}, which the "
                             "model does not have")
        return i
    ids = [s for s in range(m.nsensor) if int(m.sensor_type[s]) == kind]
    return _only(label, ids, [m.sensor(s).name for s in ids], role)


def spec_sensor(spec: mujoco.MjSpec, role: str):
    """The spec's accelerometer or gyro sensor (role "accelerometer" or "gyro"), None
    without one."""
    named = spec_text(spec, role)
    if named is not None:
        return spec.sensor(named)
    kind = {"accelerometer": mujoco.mjtSensor.mjSENS_ACCELEROMETER,
            "gyro": mujoco.mjtSensor.mjSENS_GYRO}[role]
    found = [s for s in spec.sensors if s.type == kind]
    if len(found) > 1:
        raise ValueError(f"the model has {len(found)} {role} sensors; name the one to use with "
                         f"<custom><text name=\"{PREFIX}{role}\" data=\"NAME\"/></custom>")
    return found[0] if found else None


def spec_part(spec: mujoco.MjSpec, part: str):
    """The body the model names as its `part` (mast, payload), None without one."""
    name = spec_text(spec, f"part.{part}")
    return None if name is None else spec.body(name)


@dataclasses.dataclass(frozen=True)
class Roles:
    """Ids of a compiled model's parts, as skidsteer uses them."""

    wheels: tuple[tire.Wheel, ...]  # the plugin's order
    chassis: int  # body id of the wheels' root body
    left: tuple[int, ...]  # actuator ids driving the left wheels
    right: tuple[int, ...]
    accelerometer: int | None  # sensor ids
    gyro: int | None
    tire_forces: int | None
    wheel_side: tuple[int, ...]  # +1 left, -1 right, per wheel
    wheel_position_m: np.ndarray  # (nwheel, 3) wheel centres in the chassis frame at qpos0

    def sensor_slice(self, m: mujoco.MjModel, sensor: int | None, what: str) -> slice:
        if sensor is None:
            raise ValueError(f"the model has no {what} sensor")
        adr = int(m.sensor_adr[sensor])
        return slice(adr, adr + int(m.sensor_dim[sensor]))


def _actuator_joints(m: mujoco.MjModel, a: int) -> list[int]:
    trn, target = int(m.actuator_trntype[a]), int(m.actuator_trnid[a, 0])
    if trn == _TRN_JOINT:
        return [target]
    if trn == _TRN_TENDON:
        adr, num = int(m.tendon_adr[target]), int(m.tendon_num[target])
        if all(int(m.wrap_type[w]) == int(mujoco.mjtWrap.mjWRAP_JOINT) for w in range(adr, adr + num)):
            return [int(m.wrap_objid[w]) for w in range(adr, adr + num)]
    return []


def _named_actuators(m: mujoco.MjModel, side: str) -> tuple[int, ...] | None:
    names = model_text(m, f"drive.{side}")
    if names is None:
        return None
    ids = []
    for name in names.split():
        i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
        if i < 0:
            raise ValueError(f"<text name=\"{PREFIX}drive.{side}\"> names actuator {name!r}, "
                             "which the model does not have")
        ids.append(i)
    return tuple(ids)


def roles_of(m: mujoco.MjModel) -> Roles:
    """The model's wheels, chassis, drive and sensors (see the module's rules)."""
    instance = tire.instance_id(m)
    wheels = tuple(tire.find_wheels(m, instance))
    if not wheels:
        raise ValueError(f"the model has no wheels using the {tire.PLUGIN_NAME} plugin")
    chassis = int(m.body_rootid[wheels[0].body])
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    frame = d.xmat[chassis].reshape(3, 3)
    position = np.array([frame.T @ (d.xpos[w.body] - d.xpos[chassis]) for w in wheels])
    side_of_joint = {w.joint: (1 if p[1] > 0 else -1) for w, p in zip(wheels, position)}
    left, right = _named_actuators(m, "left"), _named_actuators(m, "right")
    if left is None or right is None:
        inferred = {1: [], -1: []}
        for a in range(m.nu):
            joints = _actuator_joints(m, a)
            sides = {side_of_joint.get(j) for j in joints}
            if joints and len(sides) == 1 and None not in sides:
                inferred[sides.pop()].append(a)
        left = left if left is not None else tuple(inferred[1])
        right = right if right is not None else tuple(inferred[-1])
    if not left or not right:
        raise ValueError("cannot tell which actuators drive the left and right wheels: give each "
                         "side's velocity actuators with <custom><text name=\"skidsteer.drive."
                         "left\" data=\"NAMES\"/> (and drive.right)</custom>")
    return Roles(wheels, chassis, left, right,
                 _sensor_by_role(m, "accelerometer", _ACCELEROMETER, "accelerometer"),
                 _sensor_by_role(m, "gyro", _GYRO, "gyro"), tire.sensor(m, instance),
                 tuple(side_of_joint[w.joint] for w in wheels), position)
