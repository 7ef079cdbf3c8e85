"""Training the keypose policy (``samplehd train policy --action keypose``, :func:`train_keypose`) on
the samples of :mod:`samplehd.learn.keypose.preparation`: the loss of the grasp's and the goal's maps,
random shifts of the views, and the test decisions' errors.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.envs.tokens import SPECIAL_TOKENS, encode_instruction, instruction_vocabulary, tokenize
from samplehd.errors import ConfigError
from samplehd.learn.data import open_dataset, training_split
from samplehd.learn.keypose.configuration import (
    ATTRIBUTE_VALUES,
    FORMAT,
    KEYPOSE_ATTRIBUTES,
    KeyposeConfig,
    KeyposeGrid,
    KeyposeVocabulary,
    policy_instruction,
)
from samplehd.learn.keypose.exclusion import shape_ranges
from samplehd.learn.keypose.inference import predict_decisions
from samplehd.learn.keypose.modeling import KeyposeNet
from samplehd.learn.keypose.preparation import PREPARED_FILE, check_scene_inputs, prepare_samples
from samplehd.learn.keypose.processing import FACTOR, HEIGHT_UNIT, attribute_values, grid_of, input_channels
from samplehd.learn.topdown import TopDownGrid
from samplehd.learn.training import (
    Metrics,
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
from samplehd.world.layout import LAYOUT

__all__ = ["keypose_loss", "train_keypose"]

SHIFT = 4  # training views move by up to this many grid cells along each axis
HEAT_SIGMA = 0.75  # the spread of the heat maps' targets [cells of the network's maps]
# a grasp lies on the object most of the cells this near show [cells of the network's maps]: a mug's
# grasp on its rim, a thin spoon's beside it
OBJECT_RADIUS = 2












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


def _dropped_words(tokens: np.ndarray, share: float, rng: np.random.Generator) -> np.ndarray:
    """The batch's instructions with each word read as ``<UNK>`` with probability ``share`` (the special
    tokens and the padding stay); drawn from a stream of its own, so the batches are those of a run
    without it."""
    if not share:
        return tokens
    words = tokens >= len(SPECIAL_TOKENS)
    return np.where(words & (rng.random(tokens.shape) < share), SPECIAL_TOKENS["<UNK>"], tokens)


def _heat_loss(logits: Any, rc: Any) -> Any:
    """Cross-entropy of the map's softmax against a Gaussian of :data:`HEAT_SIGMA` cells around the
    labelled position (a cell beside it is nearly as right as the cell itself)."""
    n, rows, cols = logits.shape
    r = torch.arange(rows, device=logits.device, dtype=logits.dtype)
    c = torch.arange(cols, device=logits.device, dtype=logits.dtype)
    d2 = (r[None, :, None] - rc[:, 0, None, None]) ** 2 + (c[None, None, :] - rc[:, 1, None, None]) ** 2
    target = torch.softmax((-d2 / (2 * HEAT_SIGMA ** 2)).reshape(n, -1), 1)
    return -(target * torch.log_softmax(logits.reshape(n, -1), 1)).sum(1).mean()


def keypose_loss(net: Any, grid: Any, tokens: Any, labels: Any, attributes: Any, attribute_weight: float = 0.5,
                 placed: Any = None) -> tuple[Any, dict[str, torch.Tensor]]:
    """The training loss of a batch and its parts: cross-entropy of the grasp's and the goal's cell
    over the map, smooth L1 of the values at the labelled cells (the goal's read with the labelled
    grasp's cell), binary cross-entropy of release and last, and ``attribute_weight`` times the
    cross-entropy of the attribute maps over the cells that show an object. ``placed``: the objects put
    down before each decision (read by a network with ``placed_count``)."""
    F = torch.nn.functional
    n = grid.shape[0]
    c, feats, flags = net.features(grid, tokens, placed)
    rows, cols = feats.shape[2], feats.shape[3]
    g_rc, p_rc = labels[:, 0:2], labels[:, 6:8]
    g_cell = torch.stack([g_rc[:, 0].round().clamp(0, rows - 1), g_rc[:, 1].round().clamp(0, cols - 1)], 1).long()
    p_cell = torch.stack([p_rc[:, 0].round().clamp(0, rows - 1), p_rc[:, 1].round().clamp(0, cols - 1)], 1).long()
    gm = net.grasp_maps(c, feats)
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
    att_logits = net.attribute_maps(feats)
    named = F.cross_entropy(att_logits.transpose(1, 2), attributes, ignore_index=-1) if (attributes >= 0).any() \
        else att_logits.sum() * 0.0
    return heat + 5.0 * values + flag + attribute_weight * named, {
        "heat": heat, "values": values, "flags": flag, "attributes": named, "grasp": gm, "goal": pm,
        "flag_logits": flags}


def train_keypose(dataset: str | Path | Sequence[str | Path], out: str | Path, config: KeyposeConfig, *,
                  device: str | None = None, quiet: bool = False, stop_after: int | None = None) -> Metrics:
    """Train the keypose policy ``config`` on a dataset's L1 training episodes (on those of several
    datasets together: the same catalogue and scene camera size); metrics on its test episodes: the
    grasp's and the goal's position error [m] (median, mean, share within 1 and 2 cm), the grasp's height
    and yaw error, the flags' accuracy.

    What the dataset says is filled in (:func:`fill_from_dataset`): its path and catalogue, the grid's
    image size (the dataset's scene images', so that first decisions read them; an image of another
    size is drawn anew from the episode's state), the families and the count of its training episodes.
    ``config.families`` (empty: all) chooses the families trained on. ``config.train.init``: the folder
    of another keypose policy whose weights the training starts from (a ``pick_up`` model's grounding
    serves ``place``); its grid, width and inputs must be this run's. ``inputs: state`` trains the
    privileged-state reference: its view also marks the cells of the objects the task moves (read from
    the simulator when it acts), so it is told which objects the instruction means.

    Args:
        dataset: a dataset folder written by ``samplehd generate``, or several (a family a dataset of
            all families gives few demonstrations of, from a dataset of that family).
        out: the output folder (resumed when it holds a checkpoint).
        config: the policy to train.
        device: torch device (default: cuda when present, else cpu).
        quiet: no progress bar.
        stop_after: stop after this many steps (a checkpoint stays; for tests of resuming).

    Returns:
        The metrics written to ``metrics.json`` (``{"stopped_at": N}`` when stopped early).
    """
    datasets = [dataset] if isinstance(dataset, str | Path) else list(dataset)
    readers = [open_dataset(d) for d in datasets]
    for reader in readers:
        check_scene_inputs(reader)
    config, train_k, test_k = fill_from_dataset(config, readers, datasets)
    _warn_if_small(config.grid, quiet)
    start = _initial_weights(config) if config.train.init else None
    out = Path(out)
    dev = pick_device(device)
    set_seed(config.train.seed)
    steps = config.train.steps
    # The samples are drawn before anything is written: a dataset refused while they are drawn leaves
    # no half-made `out`.
    arrays = _samples(out, readers, config, train_k, test_k, quiet)
    if config.language != "instruction":  # the language-blind control: every sample reads the blank text
        config = replace(config, train=replace(config.train, word_dropout=0.0))
        blank = encode_instruction(policy_instruction(config, ""), config.tokens)
        for key in ("train_tokens", "test_tokens"):
            arrays[key] = np.broadcast_to(blank, arrays[key].shape).copy()
    n = len(arrays["train_grid"])
    if n == 0:
        raise ConfigError(f"dataset={' '.join(map(str, datasets))}: no training episode reads as grasp, lift and "
                          "carry", field="dataset")
    # the sizes each class was seen with, for grounding an unheard noun by exclusion
    shapes = shape_ranges(arrays["train_grid"], arrays["train_attributes"], config.vocabulary.name, FACTOR,
                          grid_of(config.grid).cell)
    config = replace(config, vocabulary=replace(config.vocabulary, shapes=shapes))
    run = TrainRun(out, config.to_dict(), steps, checkpoint_every=max(50, steps // 20), quiet=quiet,
                   stop_after=stop_after)
    run.prepare()
    _keep_samples(out, arrays)
    net = KeyposeNet(len(instruction_vocabulary()), input_channels(config.inputs), config.model.width,
                     config.model.grasp_head, config.model.placed_count).to(dev)
    if start is not None:
        check_weights_fit(net, start, config.train.init)
    # The lowest grasp of the training decisions: the policy never grasps lower (a finger on the table
    # is a safety stop, a grasp a little high still closes on the object).
    net.z_floor.fill_(float(arrays["train_labels"][:, 2].min()) * HEIGHT_UNIT + LAYOUT.table_height)
    opt = torch.optim.Adam(net.parameters(), lr=config.train.lr)
    losses, t = run.train(net, opt, _train_step(net, opt, arrays, config.train, dev), "policy")
    if run.stopped:
        return {"stopped_at": len(losses)}
    metrics: dict[str, Any] = {"train_loss": float(np.mean(losses[-50:])) if losses else None,
                               **_test_metrics(net, arrays, grid_of(config.grid), dev),
                               "train_episodes": sum(map(len, train_k)), "train_decisions": n,
                               "test_episodes": sum(map(len, test_k)),
                               "families": list(config.families), "steps": steps, "seed": config.train.seed,
                               "device": str(dev), **t}
    run.finish(net, metrics)
    (out / PREPARED_FILE).unlink(missing_ok=True)
    return metrics


def fill_from_dataset(config: KeyposeConfig, readers: Sequence[Any], datasets: Sequence[str | Path]
                      ) -> tuple[KeyposeConfig, list[list[int]], list[list[int]]]:
    """(``config`` with what the datasets say filled in, each one's training episodes, each one's test
    episodes): the datasets' paths and catalogue, the grid's image size (their scene images'; 640 × 360 px
    when they have none), the families of the training episodes (of ``config.families`` when given) and
    their count, the words of their instructions and the attribute values of the scenes' objects.

    Raises:
        ConfigError: one line naming a dataset whose catalogue or scene camera size is not the first's.
    """
    def camera(reader: Any) -> tuple[int, int]:
        c = reader.scenes[0]["camera"] if reader.scenes else {}
        return int(c.get("width", 640)), int(c.get("height", 360))

    first = readers[0]
    for d, reader in zip(datasets[1:], readers[1:], strict=True):
        if reader.catalogue != first.catalogue:
            raise ConfigError(f"dataset={d}: catalogue {reader.catalogue!r}, the first dataset's ({datasets[0]}) "
                              f"{first.catalogue!r}; datasets trained on together share one", field="dataset")
        if camera(reader) != camera(first):
            raise ConfigError(f"dataset={d}: scene camera {'x'.join(map(str, camera(reader)))} px, the first "
                              f"dataset's ({datasets[0]}) {'x'.join(map(str, camera(first)))} px; datasets trained "
                              "on together share one", field="dataset")
    width, height = camera(first)
    grid = replace(config.grid, width=width, height=height)
    splits = [training_split(r, d, config.families or None) for r, d in zip(readers, datasets, strict=True)]
    train_k, test_k = [s[0] for s in splits], [s[1] for s in splits]
    instructions = [str(r.instruction(k)["instruction"]) for r, ks in zip(readers, train_k, strict=True) for k in ks]
    families = tuple(sorted({r.instruction(k)["family"] for r, ks in zip(readers, train_k, strict=True) for k in ks}))
    values = attribute_values([s for r in readers for s in r.scenes])
    words = sorted({w for text in instructions for w in tokenize(text)})
    vocabulary = KeyposeVocabulary(words=tuple(words), **{a: tuple(values[a]) for a in KEYPOSE_ATTRIBUTES})
    return replace(config, dataset=str(datasets[0]), more_datasets=tuple(str(d) for d in datasets[1:]),
                   catalogue=first.catalogue, grid=grid, families=families,
                   train=replace(config.train, episodes=len(instructions)), vocabulary=vocabulary), train_k, test_k


def _samples(out: Path, readers: Sequence[Any], config: KeyposeConfig, train_k: Sequence[Sequence[int]],
             test_k: Sequence[Sequence[int]], quiet: bool) -> dict[str, np.ndarray]:
    """The training and test samples (``train_*``, ``test_*``) of every dataset, read from ``out``'s
    :data:`~samplehd.learn.keypose.preparation.PREPARED_FILE` when a resumed run left one, else
    prepared (:func:`_keep_samples` keeps them there until the run ends; one without the counts of
    objects put down is drawn again)."""
    prepared = out / PREPARED_FILE
    if prepared.exists():
        with np.load(prepared, allow_pickle=False) as z:
            if "train_placed" in z.files:
                return {k: z[k] for k in z.files}
        prepared.unlink()
    # the attribute maps index the values of every dataset's scenes, as the vocabulary names them
    values = {a: list(config.vocabulary.values(a)) for a in KEYPOSE_ATTRIBUTES}
    out_arrays: dict[str, np.ndarray] = {}
    for split, ks in (("train", train_k), ("test", test_k)):
        parts = [prepare_samples(r, k, config.grid, config.tokens, config.inputs, f"prepare {split}", quiet, values)
                 for r, k in zip(readers, ks, strict=True)]
        out_arrays.update({f"{split}_{key}": np.concatenate([p[key] for p in parts]) for key in parts[0]})
    return out_arrays


def _keep_samples(out: Path, arrays: dict[str, np.ndarray]) -> None:
    """Write the samples to ``out``'s prepared file (once), so that a resumed run does not draw them again."""
    prepared = out / PREPARED_FILE
    if prepared.exists():
        return
    tmp = out / (PREPARED_FILE + ".tmp.npz")
    np.savez(tmp, **arrays)
    tmp.replace(prepared)


def _warn_if_small(grid: KeyposeGrid, quiet: bool) -> None:
    """A line on stderr when the policy looks at images much smaller than it was designed for: below
    half the default size a cell of its grid covers less than about one pixel, so most cells are filled
    from a neighbour and the predictions blur."""
    design = KeyposeGrid()
    if quiet or (grid.width * 2 >= design.width and grid.height * 2 >= design.height):
        return
    print(f"samplehd train: warning: the keypose policy is designed for {design.width}x{design.height} scene "
          f"images; these are {grid.width}x{grid.height}, so most of its {grid.rows}x{grid.cols} cells of "
          f"{grid.cell * 1000:g} mm see no pixel of their own (generate with render.width {design.width}, "
          f"render.height {design.height} for the figures of docs/BASELINES.md)", file=sys.stderr)


def _train_step(net: Any, opt: Any, arrays: dict[str, np.ndarray], train: Any, dev: Any) -> Any:
    """The optimiser step ``step`` of the run (``train``: the config's training options): a batch of
    shifted views, the learning rate decaying linearly over the last two thirds."""
    n = len(arrays["train_grid"])

    def train_step(step: int) -> float:
        net.train()
        rng = step_rng(train.seed, step)
        for g in opt.param_groups:
            g["lr"] = train.lr * min(1.0, 1.5 * (1 - step / train.steps))
        idx = rng.integers(n, size=train.batch)
        grid_t = torch.as_tensor(arrays["train_grid"][idx].astype(np.float32), device=dev)
        grid_t, lab_t, att_t = _shifted(grid_t, torch.as_tensor(arrays["train_labels"][idx], device=dev),
                                        torch.as_tensor(arrays["train_attributes"][idx].astype(np.int64), device=dev),
                                        rng)
        tokens = _dropped_words(arrays["train_tokens"][idx], train.word_dropout, step_rng(train.seed, step, stream=1))
        loss, _ = keypose_loss(net, grid_t, torch.as_tensor(tokens, device=dev), lab_t, att_t,
                               train.attribute_weight, torch.as_tensor(arrays["train_placed"][idx], device=dev))
        return descend(opt, loss)

    return train_step


def _initial_weights(config: KeyposeConfig) -> dict[str, torch.Tensor]:
    """The weights of the keypose policy in ``config.train.init``; one line naming ``init`` when it is
    none or looks at another grid or other inputs."""
    init = config.train.init
    raw, state = load_model_files(init, "policy", FORMAT)
    if raw.get("action") != config.action:
        raise ConfigError(f"init={init}: a policy of action {raw.get('action')!r}, not a keypose policy", field="init")
    start = read_model_config(KeyposeConfig, raw, init)
    if start.inputs != config.inputs:
        raise ConfigError(f"init={init}: a keypose policy of inputs {start.inputs!r}, this run's are "
                          f"{config.inputs!r}", field="init")
    if start.grid != config.grid or start.model != config.model:
        raise ConfigError(f"init={init}: its grid or network (grid {start.grid.to_dict()}, model "
                          f"{start.model.to_dict()}) differs from this run's (grid {config.grid.to_dict()}, model "
                          f"{config.model.to_dict()})", field="init")
    return state


def _test_metrics(net: Any, arrays: dict[str, np.ndarray], grid: TopDownGrid, dev: Any) -> Metrics:
    m = len(arrays["test_grid"])
    if m == 0:
        return {"test_decisions": 0}
    net.eval()
    preds, classes = [], []
    with torch.no_grad():
        for s in range(0, m, 32):
            idx = np.arange(s, min(s + 32, m))
            g = torch.as_tensor(arrays["test_grid"][idx].astype(np.float32), device=dev)
            tok = torch.as_tensor(arrays["test_tokens"][idx], device=dev)
            features = net.features(g, tok, torch.as_tensor(arrays["test_placed"][idx], device=dev))
            preds += [p.as_array() for p in predict_decisions(net, g, tok, grid, features=features)]
            classes.append(net.attribute_maps(features[1])[:, 0].argmax(1).cpu().numpy())
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
            "test_last_accuracy": round(float(flags[:, 1].mean()), 4),
            **_grounding_metrics(arrays["test_attributes"], labels, coarse.cell_of(pred[:, 0:2]),
                                 np.concatenate(classes))}


def _grounding_metrics(attributes: np.ndarray, labels: np.ndarray, grasp_cells: np.ndarray,
                       classes: np.ndarray) -> Metrics:
    """Which object the held-out decisions grasp, and what the auxiliary class map calls each object
    (``attributes``: the true attribute maps; ``grasp_cells``: the predicted grasps' cells of the
    network's map; ``classes``: the class map's most likely class per cell):

    - ``test_grasp_on_object``: the share of the decisions whose labelled grasp lies on an object
      (within :data:`OBJECT_RADIUS` cells) where the predicted grasp lies on that same object;
    - ``test_class_accuracy``: per object seen in a held-out view, whether the class its cells are most
      often given is its class (``cells``: per cell)."""
    objects = _object_ids(attributes)
    rows, cols = objects.shape[1:]
    true_cells = np.clip(np.round(labels[:, 0:2]).astype(int), 0, [rows - 1, cols - 1])
    pred_cells = np.clip(np.round(grasp_cells).astype(int), 0, [rows - 1, cols - 1])
    true = np.array([_object_near(o, *rc) for o, rc in zip(objects, true_cells, strict=True)])
    pred = np.array([_object_near(o, *rc) for o, rc in zip(objects, pred_cells, strict=True)])
    on = true >= 0
    names = attributes[:, 0]
    seen = names >= 0
    right = total = 0
    for view, cls, name in zip(objects, classes, names, strict=True):
        for obj in np.unique(view[view >= 0]):
            cells = view == obj
            right += int(np.bincount(cls[cells]).argmax() == name[cells][0])
            total += 1
    return {"test_grasp_on_object": round(float((pred[on] == true[on]).mean()), 4) if on.any() else None,
            "test_class_accuracy": {"objects": round(right / total, 4) if total else None,
                                    "cells": round(float((classes[seen] == names[seen]).mean()), 4)
                                    if seen.any() else None}}


def _object_ids(attributes: np.ndarray) -> np.ndarray:
    """Per cell of the attribute maps (N, attribute, rows, cols), one id per object seen there (its
    class, colour, material and size together; -1 where no object is seen)."""
    a = attributes.astype(np.int64)
    ids = ((a[:, 0] * ATTRIBUTE_VALUES + a[:, 1]) * ATTRIBUTE_VALUES + a[:, 2]) * ATTRIBUTE_VALUES + a[:, 3]
    return np.where(a[:, 0] >= 0, ids, -1)


def _object_near(objects: np.ndarray, row: int, col: int) -> int:
    """The object most of the cells within :data:`OBJECT_RADIUS` of (row, col) show, or -1 (none)."""
    r = OBJECT_RADIUS
    near = objects[max(row - r, 0):row + r + 1, max(col - r, 0):col + r + 1].ravel()
    near = near[near >= 0]
    if not len(near):
        return -1
    values, counts = np.unique(near, return_counts=True)
    return int(values[counts.argmax()])
