"""Language instructions for tabletop scenes: templates, referring expressions, programs, executor.

Instructions are made by rejection from JSON templates (``templates/*.json``), with the shortest
unique description of each object, a CLEVR node-list program and a SAMPLE-HD flat program, both of
which execute to the same task.

Example:
    >>> import numpy as np
    >>> from samplehd.language import execute, generate_instructions, synthetic_scene
    >>> rng = np.random.default_rng(0)
    >>> scene = synthetic_scene(rng, 4)
    >>> result = generate_instructions(scene, rng, per_scene=3)
    >>> inst = result.instructions[0]
    >>> execute(list(inst.program), scene) == execute(" ".join(inst.program_sequence), scene) == inst.task
    True
    >>> from samplehd.language import compute_relationships
    >>> compute_relationships([{"3d_coords": [0, 0, 0]}, {"3d_coords": [0, -0.2, 0]}])["left"]
    [[1], []]
"""

from __future__ import annotations

from samplehd.language.constraints import (
    CONSTRAINTS,
    ConstraintContext,
    default_reachable,
    register_constraint,
)
from samplehd.language.descriptions import (
    Description,
    SceneDescriber,
    render_description,
    shortest_unique_description,
)
from samplehd.language.executor import ProgramError, execute, execute_nodes, execute_sequence
from samplehd.language.generator import (
    GenerationResult,
    Instruction,
    TemplateBalancer,
    generate_instructions,
)
from samplehd.language.instruction_file import (
    generate_instruction_file,
    read_instructions,
    write_instructions,
)
from samplehd.language.lexicon import Lexicon, default_lexicon
from samplehd.language.scene import Scene, SceneObject, load_scenes, parse_scene
from samplehd.language.synthetic import synthetic_scene, synthetic_scenes_file
from samplehd.language.templates import Template, default_templates, load_templates
from samplehd.language.vocab import SPECIAL_TOKENS, build_vocab, decode, encode, tokenize
from samplehd.world.free_spot import FreeSpots, SpotSearch
from samplehd.world.reach import IKReachable, make_reachable
from samplehd.world.relations import RELATIONS, compute_relationships

__all__ = [
    "CONSTRAINTS",
    "RELATIONS",
    "SPECIAL_TOKENS",
    "ConstraintContext",
    "Description",
    "FreeSpots",
    "GenerationResult",
    "IKReachable",
    "Instruction",
    "Lexicon",
    "ProgramError",
    "Scene",
    "SceneDescriber",
    "SceneObject",
    "SpotSearch",
    "Template",
    "TemplateBalancer",
    "build_vocab",
    "compute_relationships",
    "decode",
    "default_lexicon",
    "default_reachable",
    "default_templates",
    "encode",
    "execute",
    "execute_nodes",
    "execute_sequence",
    "generate_instruction_file",
    "generate_instructions",
    "load_scenes",
    "load_templates",
    "make_reachable",
    "parse_scene",
    "read_instructions",
    "register_constraint",
    "render_description",
    "shortest_unique_description",
    "synthetic_scene",
    "synthetic_scenes_file",
    "tokenize",
    "write_instructions",
]
