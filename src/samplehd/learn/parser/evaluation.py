"""How well a parser reads a dataset's test instructions: exact match and executor accuracy."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from samplehd.errors import ConfigError
from samplehd.language.executor import ProgramError, execute
from samplehd.language.scene import parse_scene
from samplehd.learn.data import instruction_examples, open_dataset
from samplehd.learn.parser.inference import InstructionParser
from samplehd.learn.training import Metrics, pick_device, timed

__all__ = ["evaluate_parser", "parser_test_metrics", "score_parser"]


def _task_equal(program: Any, scene: Mapping[str, Any], task: Mapping[str, Any]) -> bool:
    try:
        got = execute(list(program), parse_scene(scene)).to_program_dict()
    except (ProgramError, ValueError, KeyError, IndexError):
        return False
    return got == {k: task.get(k) for k in got}


def evaluate_parser(parser: InstructionParser, examples: Sequence[Mapping[str, Any]]) -> Metrics:
    """Exact match (flat program; node list) and executor accuracy (same task on the scene), overall and per level."""
    preds = parser.parse([e["instruction"] for e in examples])
    rows = []
    for e, p in zip(examples, preds, strict=True):
        gt_flat = tuple(str(e["program_sequence"]).split())
        gt_nodes = [{"type": n["type"], "inputs": list(n.get("inputs", [])),
                     "value_inputs": list(n.get("value_inputs", []))} for n in e["program"]]
        rows.append({
            "level": e.get("level", "L1"),
            "exact": p.flat == gt_flat,
            "nodes_exact": p.nodes is not None and list(p.nodes) == gt_nodes,
            "executor": _task_equal(p.flat, e["scene"], e["task"]),
            "executor_nodes": p.nodes is not None and _task_equal(p.nodes, e["scene"], e["task"]),
        })

    def rates(rs: list[dict[str, str | bool]]) -> dict[str, float | None]:
        n = len(rs)
        return {"n": n, **{k: (sum(r[k] for r in rs) / n if n else None)
                           for k in ("exact", "nodes_exact", "executor", "executor_nodes")}}

    by_level = {lv: rates([r for r in rows if r["level"] == lv]) for lv in sorted({r["level"] for r in rows})}
    return {"all": rates(rows), "by_level": by_level}


def parser_test_metrics(parser: InstructionParser, test: Sequence[Mapping[str, Any]]) -> Metrics:
    """The ``test_*`` and ``l3_*`` entries of a parser's ``metrics.json`` (:func:`evaluate_parser`)."""
    seen = [e for e in test if e["level"] == "L1"]
    heldout = [e for e in test if e["level"] == "L3"]
    m_seen = evaluate_parser(parser, seen) if seen else {"all": {}}
    m_l3 = evaluate_parser(parser, heldout) if heldout else {"all": {}}
    m_all = evaluate_parser(parser, test) if test else {"all": {}, "by_level": {}}
    return {
        "test_exact_match": m_seen["all"].get("exact"),
        "test_node_exact_match": m_seen["all"].get("nodes_exact"),
        "test_executor_accuracy": m_seen["all"].get("executor"),
        "test_executor_accuracy_nodes": m_seen["all"].get("executor_nodes"),
        "test_examples": m_seen["all"].get("n", 0),
        "l3_exact_match": m_l3["all"].get("exact"),
        "l3_executor_accuracy": m_l3["all"].get("executor"),
        "l3_examples": m_l3["all"].get("n", 0),
        "test_by_level": m_all.get("by_level", {}),
    }


def score_parser(dataset: str | Path, models: str | Path, device: str | None = None) -> Metrics:
    """Test a trained parser (the ``--out`` folder of ``samplehd train parser``) on a dataset's test
    instructions without training: the ``test_*`` and ``l3_*`` metrics of ``metrics.json``, with the
    wall time and load average of the test (``test_wall_s``, ``test_load_average_1min``).

    Raises:
        ConfigError: no trained parser in ``models``, or no dataset (or test instructions) in ``dataset``.
    """
    parser = InstructionParser.load(models, pick_device(device))
    data = instruction_examples(open_dataset(dataset))
    if not data["test"]:
        raise ConfigError(f"dataset={dataset}: no test instructions (generate with a test split)", field="dataset")
    with timed() as t:
        metrics = parser_test_metrics(parser, data["test"])
    return {**metrics, **{f"test_{k}": v for k, v in t.items()}}
