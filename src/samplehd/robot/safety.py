"""Safety monitor: stops the arm on collisions, excessive contact force or joint overload.

Checked events (:attr:`SafetyEvent.kind`):

- ``self_collision``: two robot geoms touch (adjacent links and the two fingers never do).
- ``environment_collision``: a robot geom touches anything that is not a scene object: the table
  (body ``table``), the floor, the backdrop (walls, counter) or any other static geom.
- ``contact_force``: the normal force between one robot body and one scene object (bodies
  ``object_{i}`` and their descendants), summed over their contact points, exceeds
  ``max_contact_force`` for ``force_hold_time`` or longer (a force sensor's filter: the few-
  millisecond impulse of a finger pad meeting a light object is not a sustained push). Touching
  and grasping objects is allowed (the grip force is 85 N per finger, so even one finger pushing
  with both fingers' force through their coupling stays below the default limit of 150 N).
- ``joint_torque``: an arm motor delivers at least ``torque_ratio`` of its torque limit for
  ``torque_hold_time`` or longer (a stall against an obstacle or an excessive load).

The monitor only detects; :class:`samplehd.robot.controller.RobotController` holds the arm.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from samplehd.errors import ConfigError
from samplehd.robot.constants import JOINT_NAMES, ROBOT_BODY, TORQUE_LIMITS
from samplehd.schema import Config, bounded

__all__ = ["SAFETY_EVENT_CODES", "SAFETY_EVENT_KINDS", "SafetyConfig", "SafetyEvent", "SafetyMonitor"]

SAFETY_EVENT_KINDS = ("self_collision", "environment_collision", "contact_force", "joint_torque")
# Integer codes for per-frame records: 0 means no event.
SAFETY_EVENT_CODES: dict[str, int] = {kind: i + 1 for i, kind in enumerate(SAFETY_EVENT_KINDS)}

# Geom classes.
_OTHER, _ROBOT, _OBJECT = 0, 1, 2


@dataclass(frozen=True)
class SafetyConfig(Config, section="SafetyConfig"):
    """Thresholds of the safety monitor.

    Attributes:
        max_contact_force: largest allowed normal force between the robot and one scene object [N].
        force_hold_time: how long the force must stay above the limit before the arm stops [s]
            (contacts are checked every few physics steps; 0 stops at the first sample).
        torque_ratio: fraction of a joint's torque limit that counts as overload (0, 1].
        torque_hold_time: how long an overload must last before the arm stops [s] (torques are
            sampled once per control step by the controller).
        min_penetration: contacts shallower than this are ignored (grazing touches) [m].
        check_self_collision: whether robot–robot contacts stop the arm.
        check_environment: whether robot–table/floor/wall contacts stop the arm.
    """

    max_contact_force: float = bounded(150.0, lo=0.0, lo_open=True, unit="N")
    force_hold_time: float = bounded(0.008, lo=0.0, unit="s")
    torque_ratio: float = bounded(0.98, lo=0.0, lo_open=True, hi=1.0)
    torque_hold_time: float = bounded(0.1, lo=0.0, unit="s")
    min_penetration: float = bounded(0.0, lo=0.0, unit="m")
    check_self_collision: bool = True
    check_environment: bool = True


@dataclass(frozen=True)
class SafetyEvent:
    """One safety stop.

    Attributes:
        kind: one of :data:`SAFETY_EVENT_KINDS`.
        time: simulation time of detection [s].
        bodies: the two bodies in contact (robot body first); for ``joint_torque`` the link the
            joint moves and its parent.
        geoms: the two geoms in contact (empty strings for ``joint_torque``).
        joint: the overloaded joint (``joint_torque`` only, else "").
        value: penetration depth [m], normal force [N] or joint torque [N·m].
        threshold: the limit that was crossed, in the unit of ``value``.
    """

    kind: str
    time: float
    bodies: tuple[str, str]
    geoms: tuple[str, str] = ("", "")
    joint: str = ""
    value: float = 0.0
    threshold: float = 0.0

    @property
    def code(self) -> int:
        """Integer code of :attr:`kind` (:data:`SAFETY_EVENT_CODES`; 0 is reserved for "none")."""
        return SAFETY_EVENT_CODES[self.kind]

    def __str__(self) -> str:
        what = f"joint {self.joint}" if self.joint else f"{self.bodies[0]} and {self.bodies[1]}"
        unit = {"contact_force": "N", "joint_torque": "N·m"}.get(self.kind, "m")
        return (
            f"{self.kind} at t={self.time:.3f} s between {what} ({self.value:.4g} {unit}, limit {self.threshold:.4g})"
        )

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dictionary."""
        return {
            "kind": self.kind,
            "time": self.time,
            "bodies": list(self.bodies),
            "geoms": list(self.geoms),
            "joint": self.joint,
            "value": self.value,
            "threshold": self.threshold,
        }

    @classmethod
    def from_dict(cls, d: dict[str, object]) -> SafetyEvent:
        """Inverse of :meth:`to_dict`."""
        return cls(
            kind=str(d["kind"]),
            time=float(d["time"]),  # type: ignore[arg-type]
            bodies=tuple(d["bodies"]),  # type: ignore[arg-type]
            geoms=tuple(d.get("geoms", ("", ""))),  # type: ignore[arg-type]
            joint=str(d.get("joint", "")),
            value=float(d.get("value", 0.0)),  # type: ignore[arg-type]
            threshold=float(d.get("threshold", 0.0)),  # type: ignore[arg-type]
        )


def _descendants(model: mujoco.MjModel, root: int) -> np.ndarray:
    """Boolean mask over bodies: ``root`` and everything below it."""
    mask = np.zeros(model.nbody, dtype=bool)
    mask[root] = True
    for b in range(root + 1, model.nbody):  # MuJoCo orders bodies so parents precede children
        mask[b] = mask[model.body_parentid[b]]
    return mask


@dataclass
class SafetyMonitor:
    """Classifies contacts and joint loads of a compiled world; call :meth:`check` after stepping.

    Args:
        model: compiled world containing the robot (root body ``robot_base``).
        config: thresholds.
    """

    model: mujoco.MjModel
    config: SafetyConfig = field(default_factory=SafetyConfig)

    def __post_init__(self) -> None:
        m = self.model
        robot_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, ROBOT_BODY)
        if robot_id < 0:
            raise ConfigError(f"model has no body {ROBOT_BODY!r}; build the world with samplehd.robot.ur5e.add_robot")
        robot_bodies = _descendants(m, robot_id)
        object_bodies = np.zeros(m.nbody, dtype=bool)
        for b in range(m.nbody):
            name = m.body(b).name
            if name.startswith("object_") and name.removeprefix("object_").isdigit():
                object_bodies |= _descendants(m, b)
        body_class = np.where(robot_bodies, _ROBOT, np.where(object_bodies, _OBJECT, _OTHER))
        self._geom_class = body_class[m.geom_bodyid].astype(np.int8)
        self._robot_geom = self._geom_class == _ROBOT
        self._geom_body: list[int] = m.geom_bodyid.tolist()
        dofs = [int(m.jnt_dofadr[m.joint(j).id]) for j in JOINT_NAMES]
        contiguous = dofs == list(range(dofs[0], dofs[0] + len(dofs)))
        self._arm_dofs = slice(dofs[0], dofs[-1] + 1) if contiguous else np.array(dofs)
        self._torque_limit = TORQUE_LIMITS * self.config.torque_ratio
        self._torque_limit_list: list[float] = self._torque_limit.tolist()
        self._overload_since = np.full(len(JOINT_NAMES), np.nan)
        self._overloaded = False
        self._force = np.zeros(6)
        self._pushing_since: dict[tuple[int, int], float] = {}

    def reset(self) -> None:
        """Forget accumulated overload timers (after the arm was reset)."""
        self._pushing_since.clear()
        self._overload_since[:] = np.nan
        self._overloaded = False

    def check(self, data: mujoco.MjData, torque: bool = True) -> SafetyEvent | None:
        """Return the first safety event in the current state of ``data``, or None.

        Args:
            data: the simulation state to inspect.
            torque: also sample the joint torques (overload needs ``torque_hold_time`` of samples;
                the controller samples them once per control step, contacts more often).
        """
        if data.ncon:
            contacts = data.contact
            geom = contacts.geom
            robot = self._robot_geom[geom]
            involved = (robot[:, 0] | robot[:, 1]).nonzero()[0]
            if involved.size:
                event = self._check_contacts(data, involved, geom[involved], contacts.dist[involved])
                if event is not None:
                    return event
                return self._check_torque(data) if torque else None
        self._pushing_since.clear()
        return self._check_torque(data) if torque else None

    def _check_contacts(
        self, data: mujoco.MjData, involved: np.ndarray, geom: np.ndarray, dist: np.ndarray
    ) -> SafetyEvent | None:
        """The contacts ``involved`` (their geom pairs ``geom`` and distances ``dist``) of the robot."""
        cfg = self.config
        m = self.model
        body_of = self._geom_body
        # Normal force summed over the contact points of each (robot body, object body) pair.
        pair_force: dict[tuple[int, int], list[float | int]] = {}
        # one conversion to Python numbers for all of them (the loop runs at every safety check)
        for i, (g1, g2), (c1, c2), d in zip(involved.tolist(), geom.tolist(), self._geom_class[geom].tolist(),
                                            dist.tolist(), strict=True):
            if c1 != _ROBOT:
                g1, g2, c1, c2 = g2, g1, c2, c1
            if c2 == _OBJECT:
                mujoco.mj_contactForce(m, data, i, self._force)
                key = (body_of[g1], body_of[g2])
                entry = pair_force.setdefault(key, [0.0, g1, g2])
                entry[0] += abs(float(self._force[0]))
                continue
            depth = -d
            if depth < cfg.min_penetration:
                continue
            if c2 == _ROBOT and cfg.check_self_collision:
                return self._contact_event("self_collision", data, g1, g2, depth, cfg.min_penetration)
            if c2 == _OTHER and cfg.check_environment:
                return self._contact_event("environment_collision", data, g1, g2, depth, cfg.min_penetration)
        now = float(data.time)
        since = self._pushing_since
        pushing = {key: v for key, v in pair_force.items() if v[0] > cfg.max_contact_force}
        for key in [k for k in since if k not in pushing]:
            del since[key]
        for key, (force, g1, g2) in pushing.items():
            start = since.setdefault(key, now)
            if now - start >= cfg.force_hold_time - 1e-9:
                return self._contact_event("contact_force", data, int(g1), int(g2), float(force), cfg.max_contact_force)
        return None

    def _contact_event(self, kind: str, data, g1: int, g2: int, value: float, threshold: float) -> SafetyEvent:
        m = self.model
        b1, b2 = m.geom_bodyid[g1], m.geom_bodyid[g2]
        return SafetyEvent(
            kind=kind,
            time=float(data.time),
            bodies=(m.body(b1).name or f"body{b1}", m.body(b2).name or "world"),
            geoms=(m.geom(g1).name or f"geom{g1}", m.geom(g2).name or f"geom{g2}"),
            value=value,
            threshold=threshold,
        )

    def _check_torque(self, data: mujoco.MjData) -> SafetyEvent | None:
        if not self._overloaded:
            # the usual case, every joint below its limit, on Python floats (this runs at every control
            # step); anything else (NaN included) takes the array path below
            for value, limit in zip(data.qfrc_actuator[self._arm_dofs].tolist(), self._torque_limit_list,
                                    strict=True):
                if not abs(value) < limit:
                    break
            else:
                return None
        torque = np.abs(data.qfrc_actuator[self._arm_dofs])
        over = torque >= self._torque_limit
        if not over.any():
            if self._overloaded:
                self.reset()
            return None
        self._overloaded = True
        now = float(data.time)
        self._overload_since[~over] = np.nan
        start = np.where(over & np.isnan(self._overload_since), now, self._overload_since)
        self._overload_since[:] = start
        lasting = over & (now - start >= self.config.torque_hold_time)
        if not lasting.any():
            return None
        j = int(np.flatnonzero(lasting)[0])
        m = self.model
        jid = m.joint(JOINT_NAMES[j]).id
        body = m.jnt_bodyid[jid]
        return SafetyEvent(
            kind="joint_torque",
            time=now,
            bodies=(m.body(body).name, m.body(m.body_parentid[body]).name),
            joint=JOINT_NAMES[j],
            value=float(torque[j]),
            threshold=float(self._torque_limit[j]),
        )
