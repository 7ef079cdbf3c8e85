"""Instruction → program: a GRU encoder–decoder with attention (Luong) over the fixed instruction
vocabulary of :mod:`samplehd.envs.tokens`.

The decoder writes one sequence: the SAMPLE-HD flat program, ``<SEP>``, then the CLEVR node list,
each node as its token (``filter_color[red]``) followed by one ``@k`` token per input node. Both
formats come out of one greedy decode and go straight into the project's executor.

Modules, one job each (LeRobot's split of a model):

- :mod:`~samplehd.learn.parser.configuration`: :class:`ParserConfig`, a model's ``config.json``;
- :mod:`~samplehd.learn.parser.processing`: instructions and programs as token sequences;
- :mod:`~samplehd.learn.parser.modeling`: the network;
- :mod:`~samplehd.learn.parser.inference`: :class:`InstructionParser`, a trained parser;
- :mod:`~samplehd.learn.parser.evaluation`: exact match and executor accuracy, :func:`score_parser`;
- :mod:`~samplehd.learn.parser.training`: :func:`train_parser`.
"""

from __future__ import annotations

from samplehd.learn.parser.configuration import FORMAT, ParserArchitecture, ParserConfig, ParserTraining
from samplehd.learn.parser.evaluation import evaluate_parser, parser_test_metrics, score_parser
from samplehd.learn.parser.inference import InstructionParser
from samplehd.learn.parser.processing import ParsedProgram, decode_target, encode_target
from samplehd.learn.parser.training import train_parser

__all__ = ["FORMAT", "InstructionParser", "ParsedProgram", "ParserArchitecture", "ParserConfig", "ParserTraining",
           "decode_target", "encode_target", "evaluate_parser", "parser_test_metrics", "score_parser",
           "train_parser"]
