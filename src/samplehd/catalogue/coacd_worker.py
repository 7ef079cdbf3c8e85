"""Run CoACD in a child process: ``python coacd_worker.py IN.npz OUT.npz PARAMS_JSON``.

CoACD is a C++ library that can abort the whole process on meshes it does not like (degenerate or
duplicate faces, some non-manifold input). Running it here turns such a crash into a non-zero exit
status that :mod:`samplehd.catalogue.importer` reports as a one-line error, instead of killing the
caller. Input and output are plain ``.npz`` arrays (loaded with ``allow_pickle=False``).
"""

from __future__ import annotations

import json
import sys

import numpy as np

__all__ = ["main"]


def main(argv: list[str]) -> int:
    """Decompose the mesh in ``argv[0]`` into convex pieces written to ``argv[1]``."""
    import coacd

    src, dst, params = argv[0], argv[1], json.loads(argv[2])
    with np.load(src, allow_pickle=False) as z:
        vertices = np.asarray(z["vertices"], np.float64)
        faces = np.asarray(z["faces"], np.int32)
    coacd.set_log_level("error")
    parts = coacd.run_coacd(
        coacd.Mesh(vertices, faces),
        threshold=float(params["threshold"]),
        max_convex_hull=int(params["max_pieces"]),
        seed=int(params["seed"]),
        preprocess_mode="auto",
    )
    pieces = [np.asarray(v, np.float64) for v, _ in parts]
    pieces = [p for p in pieces if len(p) >= 4 and float(np.ptp(p, axis=0).min()) > 1e-6]
    counts = np.array([len(p) for p in pieces], np.int64)
    points = np.vstack(pieces) if pieces else np.zeros((0, 3))
    np.savez(dst, counts=counts, points=points)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
