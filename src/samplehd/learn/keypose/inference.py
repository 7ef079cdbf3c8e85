"""The trained keypose policy acting in the environment (:class:`KeyposePolicy`): it looks at the table
through the scene camera (RGB-D, re-projected from above), decides where to grasp and where the object
goes, and carries the decision out with :class:`~samplehd.learn.keypose.follower.KeyposeFollower`, one
steering vector per ``env.step``; after each release, after a grasp that closed on nothing and after
the fingers were found empty (the object slipped out), it goes back to its start pose and looks again,
until the episode ends (as a closed-loop behaviour-cloning policy acts until the environment says
success or time is up) or :data:`MAX_DECISIONS` are made. The network's "last decision" flag never
ends an episode (a network without the count is right on about as many held-out decisions as always
saying yes); a network with ``placed_count`` reads the objects put down so far, a count that stops at
a release flagged as the last.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any, TypedDict

import numpy as np

from samplehd.envs.tokens import instruction_vocabulary
from samplehd.errors import ConfigError
from samplehd.learn.actions import tcp_yaw
from samplehd.learn.keypose.configuration import (
    KEYPOSE_ATTRIBUTES,
    KeyposeConfig,
    policy_instruction,
    policy_tokens,
)
from samplehd.learn.keypose.exclusion import SeenObject, exclusion_target, moves_unheard, table_objects, unknown_nouns
from samplehd.learn.keypose.follower import KeyposeFollower
from samplehd.learn.keypose.modeling import KeyposeNet
from samplehd.learn.keypose.processing import (
    FACTOR,
    HEIGHT_UNIT,
    OPENING_UNIT,
    SCENE_MODALITIES,
    Decision,
    grid_of,
    input_channels,
    scene_grid,
    task_cells,
)
from samplehd.learn.topdown import TopDownGrid
from samplehd.learn.training import set_seed, torch
from samplehd.render.renderer import SceneRenderer
from samplehd.robot.constants import GRIPPER_STROKE
from samplehd.world.layout import LAYOUT

__all__ = ["AVOID_RADIUS", "GROUNDED_GRASP_OVER_TOP", "MAX_DECISIONS", "KeyposeDiagnosis", "KeyposePolicy",
           "grounded_grasp", "predict_decisions"]


AVOID_RADIUS = 0.03  # a later grasp is not sought this close to an earlier grasp or release [m]
MAX_DECISIONS = 6  # an episode's decisions at most (the families move up to three objects; the rest retry)
# The grasp of an object grounded by exclusion, whose height the network never learnt: the TCP at most
# this far above the object's top (the demonstrations' grasps of objects lower than 7 cm: 6-12 mm above
# their top, median), the fingers open wide (GRIPPER_STROKE).
GROUNDED_GRASP_OVER_TOP = 0.01  # [m]


class DecisionRecord(TypedDict):
    """A decision as evaluation records keep it: grasp and goal (x, y, z [m], yaw [rad]) rounded to the
    millimetre, whether it lets go, and whether it is the episode's last."""

    grasp: list[float]
    goal: list[float]
    release: bool
    last: bool


class KeyposeDiagnosis(TypedDict, total=False):
    """A keypose episode so far (:meth:`KeyposePolicy.diagnosis`; empty before the first decision): the
    follower's stage, the decisions made again after the fingers were found empty and where each time
    (:data:`~samplehd.learn.keypose.follower.LOST_AT`), whether grounding by exclusion fired, and the
    decisions."""

    stage: str
    retries: int
    lost: list[str]
    exclusion: bool
    decisions: list[DecisionRecord]


class KeyposePolicy:
    """The keypose policy in ``env`` (steering control; any observation mode: it renders the scene
    camera itself, as the dataset's scene images were drawn).

    Args:
        config: the trained model's config.
        state: its state dict (None: an untrained network).
        env: the environment.
    """

    def __init__(self, config: KeyposeConfig, state: Mapping[str, Any] | None, env: Any = None,
                 device: Any = None) -> None:
        set_seed(config.train.seed)
        self.config = config
        self.device = device or torch.device("cpu")
        self.net = KeyposeNet(len(instruction_vocabulary()), input_channels(config.inputs),
                              config.model.width, config.model.grasp_head, config.model.placed_count).to(self.device)
        if state is not None:
            self.net.load_state_dict(state)
        self.net.eval()
        self.grid = grid_of(config.grid)
        self.env = env
        if env is not None and env.unwrapped.config.control_mode != "steering":
            raise ConfigError(f"policy=bc: the environment's control_mode={env.unwrapped.config.control_mode!r}, "
                              f"the keypose policy needs 'steering'", field="policy")
        self._renderer: Any = None
        self._renderer_model: Any = None
        self.decisions: list[Decision] = []
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self._follower: KeyposeFollower | None = None
        self._home: np.ndarray | None = None
        self._episode: Any = None
        self.decisions = []
        self.exclusion = False  # whether this episode's instruction fired the rule of grounding by exclusion
        self._restricted = False  # whether the current decision's grasp was sought on that object alone ...
        self._grounded_moved = False  # ... and whether such a decision has moved it (the rule is then done)
        self.retries = 0  # decisions made again after the fingers were found empty ...
        self.lost: list[str] = []  # ... and where, each time (KeyposeFollower.lost)
        # the objects put down so far: decisions carried through to a release, up to the one the network
        # called the last (after it, the task is not done and the last object is sought again)
        self.placed = 0

    def decide(self, instruction: str) -> Decision:
        """The decision on the scene camera's current view (a network with ``placed_count`` reads
        :attr:`placed` too). The grasp is not sought within
        :data:`AVOID_RADIUS` of this episode's earlier grasps and releases: what was put down stays there,
        and a grasp that did not take is not tried the same way again."""
        u = self.env.unwrapped
        cfg = self.config.grid
        if self._renderer_model is not u.model:
            self.close()
            self._renderer = SceneRenderer(u.model, cfg.width, cfg.height, "fast")
            self._renderer_model = u.model
            self._renderer.render(u.data, cfg.camera, SCENE_MODALITIES)  # a context's first frame differs
        if self.config.inputs == "state":  # the privileged reference is told which objects the task moves
            grid, ids = scene_grid(self._renderer, u.model, u.data, cfg, with_ids=True)
            grid = np.concatenate([grid, task_cells(ids, u.task.objects)[None]])
        else:
            grid = scene_grid(self._renderer, u.model, u.data, cfg)
        # what the policy reads: the language-blind control neither reads nor grounds the instruction's words
        text = policy_instruction(self.config, instruction)
        tokens = policy_tokens(self.config, instruction)
        with torch.no_grad():
            grid_t = torch.as_tensor(grid[None], device=self.device)
            tokens_t = torch.as_tensor(tokens[None], device=self.device)
            placed_t = torch.tensor([self.placed], device=self.device)
            features = self.net.features(grid_t, tokens_t, placed_t)
            grounded = self._grounded_by_exclusion(text, grid, features[1])
            avoid = [np.array(p[:2]) for d in self.decisions for p in (d.grasp, d.goal)]
            only = None if grounded is None else grounded.cells
            decision = predict_decisions(self.net, grid_t, tokens_t, self.grid, [avoid], [only], features)[0]
        return decision if grounded is None else grounded_grasp(decision, grounded)

    def _grounded_by_exclusion(self, instruction: str, grid: np.ndarray, feats: Any) -> SeenObject | None:
        """The object an unheard noun means (:mod:`samplehd.learn.keypose.exclusion`), or None
        when the rule does not fire; whether it fired is kept for the diagnosis. The grasp is sought on
        that object alone only where the noun names an object to move (not a reference or a container:
        :func:`~samplehd.learn.keypose.exclusion.moves_unheard`) and until a grasp of it has been carried
        through; the other objects an instruction moves are the network's to find."""
        vocabulary = self.config.vocabulary
        self._restricted = False
        if not unknown_nouns(instruction, vocabulary):
            return None
        self.exclusion = True
        if self._grounded_moved or not moves_unheard(instruction, vocabulary):
            return None
        maps = self.net.attribute_maps(feats)[0].cpu().numpy().astype(np.float64)
        logits = {a: maps[k, :len(vocabulary.values(a))] for k, a in enumerate(KEYPOSE_ATTRIBUTES)}
        objects = table_objects(grid, logits["name"], logits, vocabulary, FACTOR, self.grid.cell)
        target = exclusion_target(instruction, vocabulary, objects)
        self._restricted = target is not None
        return None if target is None else objects[target]

    def __call__(self, obs: Mapping[str, Any]) -> np.ndarray:
        episode = getattr(self.env.unwrapped, "episode", None)
        if self._home is None or episode is not self._episode:
            self.reset()
            self._episode = episode
            self._home = np.r_[np.asarray(obs["tcp_pos"], np.float64), tcp_yaw(np.asarray(obs["tcp_quat"], np.float64))]
        follower = self._follower
        again = follower is None or (follower.done and (self.decisions[-1].release or follower.missed))
        if again and len(self.decisions) < MAX_DECISIONS:
            if follower is not None and follower.lost is not None:
                self.retries += 1
                self.lost.append(follower.lost)
            elif follower is not None and self.decisions[-1].release and not self.decisions[-1].last:
                self.placed += 1  # not after what the network called the last: a decision again is that one again
            self._grounded_moved |= follower is not None and self._restricted and follower.lost is None
            decision = self.decide(str(obs["instruction"]))
            self.decisions.append(decision)
            follower = self._follower = KeyposeFollower(decision, obs, self._home, self.env,
                                                        z_floor=float(self.net.z_floor))
        return follower(obs)

    @property
    def diagnosis(self) -> KeyposeDiagnosis:
        """The episode so far, copied into evaluation records: the stage the follower is at (where a failed
        episode is charged), where the fingers were found empty (the current decision's too, after the
        last one) and the decisions made, rounded to the millimetre."""
        follower = self._follower
        if follower is None:
            return {}
        lost = self.lost + ([follower.lost] if follower.lost is not None else [])
        return {"stage": follower.stage, "retries": self.retries, "lost": lost, "exclusion": self.exclusion,
                "decisions": [{"grasp": [round(v, 3) for v in d.grasp], "goal": [round(v, 3) for v in d.goal],
                               "release": d.release, "last": d.last} for d in self.decisions]}

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
            self._renderer_model = None


def grounded_grasp(decision: Decision, grounded: SeenObject) -> Decision:
    """``decision`` with the grasp of an object grounded by exclusion: the TCP no higher than
    :data:`GROUNDED_GRASP_OVER_TOP` above the object's top on the map, the fingers open wide."""
    x, y, z, yaw = decision.grasp
    top = LAYOUT.table_height + grounded.shape[0] + GROUNDED_GRASP_OVER_TOP
    return replace(decision, grasp=(x, y, min(z, top), yaw), opening=GRIPPER_STROKE)


def predict_decisions(net: Any, grid_batch: Any, tokens: Any, grid: TopDownGrid,
                      avoid: Sequence[Sequence[np.ndarray]] | None = None,
                      only: Sequence[np.ndarray | None] | None = None, features: Any = None) -> list[Decision]:
    """The decisions the network makes on a batch of grid images: the most likely cell of the grasp,
    the values there, then the goal's maps given that cell and their most likely cell. ``avoid``: per
    image, table points (x, y) whose cells within :data:`AVOID_RADIUS` the grasp is not sought in.
    ``only``: per image, None or the cells of the network's map (bool, rows × cols) the grasp is sought
    in alone (an object grounded by exclusion). ``features``: ``net.features`` of these images when the
    caller has them already."""
    c, feats, flags = net.features(grid_batch, tokens) if features is None else features
    gm = net.grasp_maps(c, feats)
    n, _, rows, cols = gm.shape
    heat = gm[:, 0].clone()
    for i, cells in enumerate(only or ()):
        if cells is not None and cells.any():
            heat[i][torch.as_tensor(~cells, device=heat.device)] = -torch.inf
    coarse = grid.coarse(FACTOR)
    if avoid:
        centres = coarse.world(*np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij"))
        for i, points in enumerate(avoid):
            for xy in points:
                near = np.linalg.norm(centres - np.asarray(xy)[None, None], axis=-1) < AVOID_RADIUS
                if near.all() or torch.isinf(heat[i][torch.as_tensor(~near, device=heat.device)]).all():
                    continue
                heat[i][torch.as_tensor(near, device=heat.device)] = -torch.inf
    g_idx = heat.reshape(n, -1).argmax(1)
    g_cell = torch.stack([g_idx // cols, g_idx % cols], 1)
    pm = net.goal_maps(c, feats, g_cell)
    p_idx = pm[:, 0].reshape(n, -1).argmax(1)
    p_cell = torch.stack([p_idx // cols, p_idx % cols], 1)
    ar = torch.arange(n, device=gm.device)
    g_at = gm[ar, :, g_cell[:, 0], g_cell[:, 1]].cpu().numpy().astype(np.float64)
    p_at = pm[ar, :, p_cell[:, 0], p_cell[:, 1]].cpu().numpy().astype(np.float64)
    fl = torch.sigmoid(flags).cpu().numpy()
    g_cell, p_cell = g_cell.cpu().numpy(), p_cell.cpu().numpy()
    table = LAYOUT.table_height
    out = []
    for i in range(n):
        gxy = coarse.world(g_cell[i, 0] + np.clip(g_at[i, 1], -0.5, 0.5), g_cell[i, 1] + np.clip(g_at[i, 2], -0.5, 0.5))
        pxy = coarse.world(p_cell[i, 0] + np.clip(p_at[i, 1], -0.5, 0.5), p_cell[i, 1] + np.clip(p_at[i, 2], -0.5, 0.5))
        g_yaw = 0.5 * float(np.arctan2(g_at[i, 5], g_at[i, 4]))
        p_yaw = 0.5 * float(np.arctan2(p_at[i, 5], p_at[i, 4]))
        out.append(Decision((float(gxy[0]), float(gxy[1]), table + HEIGHT_UNIT * float(g_at[i, 3]), g_yaw),
                            max(0.0, OPENING_UNIT * float(g_at[i, 6])), table + HEIGHT_UNIT * float(g_at[i, 7]),
                            (float(pxy[0]), float(pxy[1]), table + HEIGHT_UNIT * float(p_at[i, 3]), p_yaw),
                            bool(fl[i, 0] > 0.5), bool(fl[i, 1] > 0.5)))
    return out
