"""Training the keypose policy (``samplehd train policy --action keypose``): every decision of the
dataset's training episodes (:func:`samplehd.learn.policy.keyposes.decisions`) is one sample, the
top-down grid of the scene camera's RGB-D image it was made on (:mod:`samplehd.learn.policy.topdown`)
with the instruction; the labels are where to grasp and where the object goes.

The first decision of an episode is made on the dataset's scene image; a later one (after an object
was moved) on the scene camera's image of the recorded state at that frame, drawn with the renderer
the policy runs with. The prepared samples are kept in ``--out/prepared.npz`` until the run ends, so a
resumed run does not draw them again.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from PIL import Image
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from samplehd.dataset.validate import validate_scene_files, validate_stored_config
from samplehd.envs.replay_check import replay_env
from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
from samplehd.errors import ConfigError
from samplehd.learn.data import open_dataset
from samplehd.learn.policy.configuration import (
    FORMAT,
    PolicyArchitecture,
    PolicyConfig,
    PolicyGrid,
    PolicyInference,
    PolicyTraining,
)
from samplehd.learn.policy.keypose_inference import (
    FACTOR,
    HEIGHT_UNIT,
    OPENING_UNIT,
    SCENE_MODALITIES,
    grid_of,
    input_channels,
    predict_decisions,
    scene_grid,
    task_cells,
)
from samplehd.learn.policy.keyposes import Decision, decisions
from samplehd.learn.policy.modeling import ATTRIBUTE_VALUES, KEYPOSE_ATTRIBUTES, KeyposeNet
from samplehd.learn.policy.preparation import training_split
from samplehd.learn.policy.topdown import TopDownGrid
from samplehd.learn.training import (
    TrainRun,
    check_weights_fit,
    descend,
    load_model_files,
    pick_device,
    read_model_config,
    set_seed,
    step_rng,
    torch,
)
from samplehd.render.renderer import SEG_ROBOT, SceneRenderer
from samplehd.world.layout import LAYOUT

__all__ = ["PREPARED_FILE", "check_scene_inputs", "keypose_targets", "scene_grid", "train_keypose_policy"]

PREPARED_FILE = "prepared.npz"
ATTRIBUTE_WEIGHT = 0.5  # weight of the auxiliary attribute maps' loss
SHIFT = 4  # training views move by up to this many grid cells along each axis
HEAT_SIGMA = 0.75  # the spread of the heat maps' targets [cells of the network's maps]
LABELS = 13  # grasp row, col, z, yaw, opening, lift; goal row, col, z, yaw; release, last; cell-free flag


def keypose_targets(d: Decision, grid: TopDownGrid) -> np.ndarray:
    """The labels (:data:`LABELS`,) of a decision on the network's maps: grasp row and column
    (fractional cells of the coarse map), z and lift over the table [:data:`HEIGHT_UNIT`], yaw [rad],
    opening [:data:`OPENING_UNIT`]; the goal's row, column, z and yaw; release and last (0/1); 1 when
    both cells lie on the map."""
    coarse = grid.coarse(FACTOR)
    g = coarse.cell_of(np.array(d.grasp[:2]))
    p = coarse.cell_of(np.array(d.goal[:2]))
    inside = all(0 <= v[0] <= coarse.rows - 1 and 0 <= v[1] <= coarse.cols - 1 for v in (g, p))
    table = LAYOUT.table_height
    return np.array([g[0], g[1], (d.grasp[2] - table) / HEIGHT_UNIT, d.grasp[3], d.opening / OPENING_UNIT,
                     (d.lift - table) / HEIGHT_UNIT, p[0], p[1], (d.goal[2] - table) / HEIGHT_UNIT, d.goal[3],
                     float(d.release), float(d.last), float(inside)], np.float32)


def attribute_values(scenes: Sequence[Mapping[str, Any]]) -> dict[str, list[str]]:
    """Per attribute of :data:`KEYPOSE_ATTRIBUTES`, the values the scenes' objects have, sorted."""
    values = {a: sorted({str(o.get(a)) for s in scenes for o in s["objects"]}) for a in KEYPOSE_ATTRIBUTES}
    for a, v in values.items():
        if len(v) > ATTRIBUTE_VALUES:
            raise ConfigError(f"dataset: {len(v)} values of {a!r} ({', '.join(v[:5])}, ...); the keypose policy's "
                              f"attribute maps hold {ATTRIBUTE_VALUES}")
    return values


def _attribute_maps(ids: np.ndarray, scene: Mapping[str, Any], values: Mapping[str, list[str]]) -> np.ndarray:
    """(attributes, rows/FACTOR, cols/FACTOR) int8: per coarse cell the index of each attribute of the
    object seen there (``ids``: segmentation ids per grid cell), -1 where no object is."""
    coarse = ids[FACTOR // 2::FACTOR, FACTOR // 2::FACTOR]
    out = np.full((len(KEYPOSE_ATTRIBUTES), *coarse.shape), -1, np.int8)
    for obj in scene["objects"]:
        where = coarse == int(obj["segmentation_id"])
        for a, name in enumerate(KEYPOSE_ATTRIBUTES):
            out[a][where] = values[name].index(str(obj.get(name)))
    return out


def _episode_samples(reader: Any, k: int, env: Any, config: PolicyGrid, tokens_len: int,
                     renderers: dict[str, Any], values: Mapping[str, list[str]], inputs: str = "rgb"
                     ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """(grid, tokens, labels, attribute maps) of each decision of episode ``k`` (``inputs="state"``:
    the grid with the cells of the objects the task moves marked)."""
    meta = reader.episode_meta(k)
    if not meta.get("success", False):
        return []
    fr = reader.frames(k, ["subtask_index", "tcp_pos", "tcp_quat", "gripper_opening", "qpos", "qvel"])
    ds = decisions(meta["subtasks"], fr["subtask_index"], fr["tcp_pos"], fr["tcp_quat"], fr["gripper_opening"])
    if not ds:
        return []
    grid = grid_of(config)
    tokens = encode_instruction(str(meta["instruction"]), tokens_len)
    entry = reader.episodes[k]
    scene = reader.scene(entry.scene_index)
    out = []
    for d in ds:
        if d.frame == 0 and scene["camera"]["width"] == config.width and scene["camera"]["height"] == config.height:
            stem = Path(scene["image_filename"]).stem
            rgb = np.asarray(Image.open(reader.root / "images" / f"{stem}.png").convert("RGB"))
            depth = np.load(reader.root / "depth" / f"{stem}.npy", allow_pickle=False).astype(np.float32)
            seg = np.asarray(Image.open(reader.root / "segmentation" / f"{stem}.png"))
            image, ids = grid.project_with_labels(rgb, seg, depth, scene["camera"], LAYOUT.table_height,
                                                  robot=seg == SEG_ROBOT)
        else:
            env.reset(options={"dataset": str(reader.root), "episode_index": k})
            u = env.unwrapped
            u.data.qpos[:] = fr["qpos"][d.frame]
            u.data.qvel[:] = fr["qvel"][d.frame]
            mujoco.mj_forward(u.model, u.data)
            key = str(id(u.model))
            if key not in renderers:
                for r in renderers.values():
                    r.close()
                renderers.clear()
                renderers[key] = SceneRenderer(u.model, config.width, config.height, "fast")
                renderers[key].render(u.data, config.camera, SCENE_MODALITIES)  # a context's first frame differs
            image, ids = scene_grid(renderers[key], u.model, u.data, config, with_ids=True)
        if inputs == "state":
            image = np.concatenate([image, task_cells(ids, reader.instruction(k)["task"]["objects"])[None]])
        out.append((image.astype(np.float16), tokens, keypose_targets(d, grid), _attribute_maps(ids, scene, values)))
    return out


def check_scene_inputs(reader: Any) -> None:
    """Refuse, before anything is written, a dataset whose stored config, scene cameras or scene images
    (decoded, of the camera's size) the preparation reads and would fail on: the first problem in one
    line (``samplehd validate --deep`` lists them all).

    Raises:
        ConfigError: ``dataset=DIR: FILE: what is wrong``.
    """
    problems = validate_stored_config(reader.root, reader.info) + validate_scene_files(reader.root, reader.scenes,
                                                                                        deep=True)
    if problems:
        more = f" (and {len(problems) - 1} more: samplehd validate --deep lists them)" if len(problems) > 1 else ""
        raise ConfigError(f"dataset={reader.root}: {problems[0]}{more}", field="dataset")


def _prepare(reader: Any, ks: Sequence[int], config: PolicyGrid, tokens_len: int,
             inputs: str = "rgb", label: str = "prepare", quiet: bool = True) -> dict[str, np.ndarray]:
    env = replay_env(reader)
    renderers: dict[str, Any] = {}
    values = attribute_values(reader.scenes)
    grids, toks, labels, attrs, episodes = [], [], [], [], []
    # Drawing the samples renders every later decision's view: minutes on a large dataset, shown per episode.
    bars = Progress(TextColumn("{task.description:>12}"), BarColumn(), MofNCompleteColumn(), TextColumn("episodes"),
                    TimeElapsedColumn(), TimeRemainingColumn(), console=Console(stderr=True, quiet=quiet),
                    disable=quiet)
    try:
        with bars:
            task = bars.add_task(label, total=len(ks))
            for k in ks:
                for g, t, y, a in _episode_samples(reader, k, env, config, tokens_len, renderers, values, inputs):
                    if y[12] > 0:
                        grids.append(g)
                        toks.append(t)
                        labels.append(y)
                        attrs.append(a)
                        episodes.append(k)
                bars.advance(task)
    finally:
        for r in renderers.values():
            r.close()
        env.close()
    if not grids:
        return {"grid": np.zeros((0, input_channels(inputs), config.rows, config.cols), np.float16),
                "tokens": np.zeros((0, tokens_len), np.int64), "labels": np.zeros((0, LABELS), np.float32),
                "attributes": np.zeros((0, len(KEYPOSE_ATTRIBUTES), config.rows // FACTOR, config.cols // FACTOR),
                                       np.int8),
                "episode": np.zeros(0, np.int64)}
    return {"grid": np.stack(grids), "tokens": np.stack(toks), "labels": np.stack(labels),
            "attributes": np.stack(attrs), "episode": np.array(episodes, np.int64)}


def _shifted(grid: Any, labels: Any, attributes: Any, rng: np.random.Generator) -> tuple[Any, Any, Any]:
    """The batch's views moved on the table by up to :data:`SHIFT` cells each way, whole cells of the
    network's maps (the coordinate channels 5 and 6 stay), their labels with them: the same scene a
    little elsewhere."""
    grid, labels, attributes = grid.clone(), labels.clone(), attributes.clone()
    steps = rng.integers(-SHIFT // FACTOR, SHIFT // FACTOR + 1, size=(len(grid), 2))
    moved = [c for c in range(grid.shape[1]) if c not in (5, 6)]
    for i, (dr, dc) in enumerate(steps):
        grid[i, moved] = torch.roll(grid[i, moved], shifts=(int(dr) * FACTOR, int(dc) * FACTOR), dims=(1, 2))
        attributes[i] = torch.roll(attributes[i], shifts=(int(dr), int(dc)), dims=(1, 2))
        labels[i, [0, 6]] += float(dr)
        labels[i, [1, 7]] += float(dc)
    return grid, labels, attributes


def _heat_loss(logits: Any, rc: Any) -> Any:
    """Cross-entropy of the map's softmax against a Gaussian of :data:`HEAT_SIGMA` cells around the
    labelled position (a cell beside it is nearly as right as the cell itself)."""
    n, rows, cols = logits.shape
    r = torch.arange(rows, device=logits.device, dtype=logits.dtype)
    c = torch.arange(cols, device=logits.device, dtype=logits.dtype)
    d2 = (r[None, :, None] - rc[:, 0, None, None]) ** 2 + (c[None, None, :] - rc[:, 1, None, None]) ** 2
    target = torch.softmax((-d2 / (2 * HEAT_SIGMA ** 2)).reshape(n, -1), 1)
    return -(target * torch.log_softmax(logits.reshape(n, -1), 1)).sum(1).mean()


def keypose_loss(net: Any, grid: Any, tokens: Any, labels: Any, attributes: Any) -> tuple[Any, dict[str, Any]]:
    """The training loss of a batch and its parts: cross-entropy of the grasp's and the goal's cell
    over the map, smooth L1 of the values at the labelled cells (the goal's read with the labelled
    grasp's cell), binary cross-entropy of release and last, and :data:`ATTRIBUTE_WEIGHT` times the
    cross-entropy of the attribute maps over the cells that show an object."""
    F = torch.nn.functional
    n = grid.shape[0]
    c, feats, flags = net.features(grid, tokens)
    rows, cols = feats.shape[2], feats.shape[3]
    g_rc, p_rc = labels[:, 0:2], labels[:, 6:8]
    g_cell = torch.stack([g_rc[:, 0].round().clamp(0, rows - 1), g_rc[:, 1].round().clamp(0, cols - 1)], 1).long()
    p_cell = torch.stack([p_rc[:, 0].round().clamp(0, rows - 1), p_rc[:, 1].round().clamp(0, cols - 1)], 1).long()
    gm = net.grasp(feats)
    pm = net.goal_maps(c, feats, g_cell)
    ar = torch.arange(n, device=grid.device)
    g_at = gm[ar, :, g_cell[:, 0], g_cell[:, 1]]
    p_at = pm[ar, :, p_cell[:, 0], p_cell[:, 1]]
    heat = _heat_loss(gm[:, 0], g_rc) + _heat_loss(pm[:, 0], p_rc)
    g_yaw, p_yaw = labels[:, 3], labels[:, 9]
    g_want = torch.stack([g_rc[:, 0] - g_cell[:, 0], g_rc[:, 1] - g_cell[:, 1], labels[:, 2], torch.cos(2 * g_yaw),
                          torch.sin(2 * g_yaw), labels[:, 4], labels[:, 5]], 1)
    p_want = torch.stack([p_rc[:, 0] - p_cell[:, 0], p_rc[:, 1] - p_cell[:, 1], labels[:, 8], torch.cos(2 * p_yaw),
                          torch.sin(2 * p_yaw)], 1)
    values = F.smooth_l1_loss(g_at[:, 1:], g_want, beta=0.05) + F.smooth_l1_loss(p_at[:, 1:], p_want, beta=0.05)
    flag = F.binary_cross_entropy_with_logits(flags, labels[:, 10:12])
    att_logits = net.attributes(feats).view(n, len(KEYPOSE_ATTRIBUTES), ATTRIBUTE_VALUES, rows, cols)
    named = F.cross_entropy(att_logits.transpose(1, 2), attributes, ignore_index=-1) if (attributes >= 0).any() \
        else att_logits.sum() * 0.0
    return heat + 5.0 * values + flag + ATTRIBUTE_WEIGHT * named, {
        "heat": heat, "values": values, "flags": flag, "attributes": named, "grasp": gm, "goal": pm,
        "flag_logits": flags}


def train_keypose_policy(dataset: str | Path, out: str | Path, steps: int = 3000, seed: int = 0,
                         device: str | None = None, quiet: bool = False, stop_after: int | None = None,
                         batch: int = 16, lr: float = 1e-3, width: int = 16, tokens: int = 32,
                         families: Sequence[str] | None = None, grid: PolicyGrid | None = None,
                         init: str | Path | None = None, inputs: str = "rgb") -> dict[str, Any]:
    """Train the keypose policy on a dataset's L1 training episodes; metrics on its test episodes: the
    grasp's and the goal's position error [m] (median, mean, share within 1 and 2 cm), the grasp's
    height and yaw error, the flags' accuracy.

    ``grid`` (default: the dataset's scene images' size, so that first decisions read them) says what
    the policy looks at; an image of another size is drawn anew from the episode's state. ``init``: the
    folder of another keypose policy whose weights the training starts from (a ``pick_up`` model's
    grounding serves ``place``); its grid, width and inputs must be this run's. ``inputs="state"``
    trains the privileged-state reference: its view also marks the cells of the objects the task moves
    (read from the simulator when it acts), so it is told which objects the instruction means.
    """
    reader = open_dataset(dataset)
    check_scene_inputs(reader)
    scenes = {s["image_index"]: s for s in reader.scenes}
    if grid is None:
        camera = next(iter(scenes.values()))["camera"] if scenes else {}
        grid = PolicyGrid(width=int(camera.get("width", 640)), height=int(camera.get("height", 360)))
    grid_cfg = grid
    _warn_if_small(grid, quiet)
    train_k, test_k = training_split(reader, dataset, families)
    families_used = tuple(sorted({reader.instruction(k)["family"] for k in train_k}))
    start = _initial_weights(init, grid, width, inputs) if init is not None else None
    out = Path(out)
    dev = pick_device(device)
    set_seed(seed)
    config = PolicyConfig(
        format=FORMAT, dataset=str(dataset), catalogue=reader.catalogue, inputs=inputs, action="keypose", image=0,
        chunk=1, execute=1, tokens=tokens, model=PolicyArchitecture(width=width, hidden=128),
        inference=PolicyInference(), grid=grid_cfg, families=families_used,
        train=PolicyTraining(steps=steps, seed=seed, batch=batch, stride=1, lr=lr, episodes=len(train_k),
                             init=str(init) if init is not None else ""))
    run = TrainRun(out, config.to_dict(), steps, checkpoint_every=max(50, steps // 20), quiet=quiet,
                   stop_after=stop_after)
    # The samples are drawn before anything is written: a dataset refused while they are drawn leaves
    # no half-made `out`.
    prepared = out / PREPARED_FILE
    fresh = not prepared.exists()
    if fresh:
        train = _prepare(reader, train_k, grid_cfg, tokens, inputs, "prepare train", quiet)
        test = _prepare(reader, test_k, grid_cfg, tokens, inputs, "prepare test", quiet)
        arrays = {**{f"train_{k}": v for k, v in train.items()}, **{f"test_{k}": v for k, v in test.items()}}
        if len(arrays["train_grid"]) == 0:
            raise ConfigError(f"dataset={dataset}: no training episode reads as grasp, lift and carry",
                              field="dataset")
    run.prepare()
    if fresh:
        tmp = out / (PREPARED_FILE + ".tmp.npz")
        np.savez(tmp, **arrays)
        tmp.replace(prepared)
    else:
        with np.load(prepared, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    n = len(arrays["train_grid"])
    net = KeyposeNet(len(instruction_vocabulary()), input_channels(inputs), width).to(dev)
    if start is not None:
        check_weights_fit(net, start, init)
    # The lowest grasp of the training decisions: the policy never grasps lower (a finger on the table
    # is a safety stop, a grasp a little high still closes on the object).
    net.z_floor.fill_(float(arrays["train_labels"][:, 2].min()) * HEIGHT_UNIT + LAYOUT.table_height)
    opt = torch.optim.Adam(net.parameters(), lr=lr)

    def train_step(step: int) -> float:
        net.train()
        rng = step_rng(seed, step)
        for g in opt.param_groups:
            g["lr"] = lr * min(1.0, 1.5 * (1 - step / steps))
        idx = rng.integers(n, size=batch)
        grid_t = torch.as_tensor(arrays["train_grid"][idx].astype(np.float32), device=dev)
        grid_t, lab_t, att_t = _shifted(grid_t, torch.as_tensor(arrays["train_labels"][idx], device=dev),
                                        torch.as_tensor(arrays["train_attributes"][idx].astype(np.int64), device=dev),
                                        rng)
        loss, _ = keypose_loss(net, grid_t, torch.as_tensor(arrays["train_tokens"][idx], device=dev), lab_t, att_t)
        return descend(opt, loss)

    losses, t = run.train(net, opt, train_step, "policy")
    if run.stopped:
        return {"stopped_at": len(losses)}
    metrics: dict[str, Any] = {"train_loss": float(np.mean(losses[-50:])) if losses else None,
                               **_test_metrics(net, arrays, grid_of(grid_cfg), dev),
                               "train_episodes": len(train_k), "train_decisions": n, "test_episodes": len(test_k),
                               "families": list(families_used), "steps": steps, "seed": seed, "device": str(dev), **t}
    run.finish(net, metrics)
    prepared.unlink(missing_ok=True)
    return metrics


def _warn_if_small(grid: PolicyGrid, quiet: bool) -> None:
    """A line on stderr when the policy looks at images much smaller than it was designed for: below
    half the default size a cell of its grid covers less than about one pixel, so most cells are filled
    from a neighbour and the predictions blur."""
    design = PolicyGrid()
    if quiet or (grid.width * 2 >= design.width and grid.height * 2 >= design.height):
        return
    print(f"samplehd train: warning: the keypose policy is designed for {design.width}x{design.height} scene "
          f"images; these are {grid.width}x{grid.height}, so most of its {grid.rows}x{grid.cols} cells of "
          f"{grid.cell * 1000:g} mm see no pixel of their own (generate with render.width {design.width}, "
          f"render.height {design.height} for the figures of docs/BASELINES.md)", file=sys.stderr)


def _initial_weights(init: str | Path, grid: PolicyGrid, width: int, inputs: str) -> dict[str, Any]:
    """The weights of the keypose policy in ``init``; one line naming ``init`` when it is none or
    looks at another grid or other inputs."""
    raw, state = load_model_files(init, "policy", FORMAT)
    config = read_model_config(PolicyConfig, raw, init)
    if config.action != "keypose":
        raise ConfigError(f"init={init}: a policy of action {config.action!r}, not a keypose policy", field="init")
    if config.inputs != inputs:
        raise ConfigError(f"init={init}: a keypose policy of inputs {config.inputs!r}, this run's are {inputs!r}",
                          field="init")
    if config.grid != grid or config.model.width != width:
        raise ConfigError(f"init={init}: its grid or width (grid {config.grid.to_dict()}, width {config.model.width}) "
                          f"differs from this run's (grid {grid.to_dict()}, width {width})", field="init")
    return state


def _test_metrics(net: Any, arrays: dict[str, np.ndarray], grid: TopDownGrid, dev: Any) -> dict[str, Any]:
    m = len(arrays["test_grid"])
    if m == 0:
        return {"test_decisions": 0}
    net.eval()
    preds = []
    with torch.no_grad():
        for s in range(0, m, 32):
            idx = np.arange(s, min(s + 32, m))
            g = torch.as_tensor(arrays["test_grid"][idx].astype(np.float32), device=dev)
            tok = torch.as_tensor(arrays["test_tokens"][idx], device=dev)
            preds += [p.as_array() for p in predict_decisions(net, g, tok, grid)]
    pred = np.stack(preds)
    labels = arrays["test_labels"]
    coarse = grid.coarse(FACTOR)
    g_true = coarse.world(labels[:, 0], labels[:, 1])
    p_true = coarse.world(labels[:, 6], labels[:, 7])
    g_err = np.linalg.norm(pred[:, 0:2] - g_true, axis=1)
    p_err = np.linalg.norm(pred[:, 6:8] - p_true, axis=1)
    z_err = np.abs(pred[:, 2] - (labels[:, 2] * HEIGHT_UNIT + LAYOUT.table_height))
    yaw = np.abs(((pred[:, 3] - labels[:, 3]) + np.pi / 2) % np.pi - np.pi / 2)
    flags = (pred[:, 10:12] > 0.5) == (labels[:, 10:12] > 0.5)

    def summary(err: np.ndarray) -> dict[str, float]:
        return {"median": round(float(np.median(err)), 4), "mean": round(float(err.mean()), 4),
                "within_1cm": round(float((err < 0.01).mean()), 4), "within_2cm": round(float((err < 0.02).mean()), 4)}

    return {"test_decisions": m, "test_grasp_error_m": summary(g_err), "test_goal_error_m": summary(p_err),
            "test_grasp_z_error_m": round(float(np.median(z_err)), 4),
            "test_grasp_yaw_error_rad": round(float(np.median(yaw)), 4),
            "test_release_accuracy": round(float(flags[:, 0].mean()), 4),
            "test_last_accuracy": round(float(flags[:, 1].mean()), 4)}
