"""Web browser for samplehd datasets: a read-only standard-library HTTP server plus a static page
(plain JavaScript, CSS and canvas/SVG drawing shipped with the package; nothing from the internet).

``samplehd view DIR`` serves a ``samplehd generate`` dataset (also while it is being written) or a
``samplehd scenes`` + ``samplehd instructions`` folder; :func:`make_server` does the same from Python.
Pages: scene grid with filters, scene (RGB/depth/segmentation, annotation under the cursor),
instruction (programs as tree and tokens, targets outlined), episode player, dataset info. The JSON
endpoints are listed in :mod:`samplehd.viewer.app`.
"""

from samplehd.viewer.app import Response, ViewerApp
from samplehd.viewer.index import DatasetIndex, filter_scene_summaries, scene_summary
from samplehd.viewer.paths import resolve_inside
from samplehd.viewer.server import ViewerServer, make_server, open_dataset

__all__ = [
    "DatasetIndex",
    "Response",
    "ViewerApp",
    "ViewerServer",
    "filter_scene_summaries",
    "make_server",
    "open_dataset",
    "resolve_inside",
    "scene_summary",
]
