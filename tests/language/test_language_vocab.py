"""Vocabularies and tokenisation."""

from __future__ import annotations

from samplehd.language.vocab import (
    SPECIAL_TOKENS,
    build_vocab,
    decode,
    encode,
    instruction_words,
    program_node_tokens,
    tokenize,
)


def test_tokenize_separates_punctuation() -> None:
    assert tokenize("Put the mug on the plate, then lift it.") == [
        "put",
        "the",
        "mug",
        "on",
        "the",
        "plate",
        ",",
        "then",
        "lift",
        "it",
        ".",
    ]


def test_build_vocab_and_encode(generated: list) -> None:
    entries = [i.to_dict() for _, r in generated for i in r.instructions]
    vocab = build_vocab(entries)
    for table in ("instruction_token_to_idx", "program_token_to_idx", "program_node_token_to_idx"):
        assert {k: vocab[table][k] for k in SPECIAL_TOKENS} == SPECIAL_TOKENS
        assert sorted(vocab[table].values()) == list(range(len(vocab[table])))
    words = vocab["instruction_token_to_idx"]
    assert "place[left]" in vocab["program_token_to_idx"]
    assert "filter_color[red]" in vocab["program_node_token_to_idx"] or "unique" in vocab["program_node_token_to_idx"]
    entry = entries[0]
    ids = encode(tokenize(entry["instruction"]), words)
    assert ids[0] == SPECIAL_TOKENS["<START>"] and ids[-1] == SPECIAL_TOKENS["<END>"]
    assert decode(ids, words) == tokenize(entry["instruction"])
    assert encode(["zebra"], words, add_start_end=False) == [SPECIAL_TOKENS["<UNK>"]]
    assert build_vocab(entries) == vocab  # deterministic


def test_program_node_tokens() -> None:
    program = [
        {"type": "scene", "inputs": [], "value_inputs": []},
        {"type": "filter_color", "inputs": [0], "value_inputs": ["red"]},
    ]
    assert program_node_tokens(program) == ["scene", "filter_color[red]"]


def test_fixed_word_list_covers_generated_text(generated: list) -> None:
    words = set(instruction_words())
    for scene, result in generated:
        values = {w for o in scene.objects for v in (o.colour, o.material, o.size, o.name) for w in v.split("_")}
        for inst in result.instructions:
            missing = set(tokenize(inst.text)) - words - values
            assert not missing, (inst.text, missing)
