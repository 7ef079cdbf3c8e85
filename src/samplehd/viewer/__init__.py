"""Web browser for samplehd datasets: a read-only standard-library HTTP server plus a static page.

``samplehd view DIR`` serves it; :func:`make_server` does the same from Python.
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
