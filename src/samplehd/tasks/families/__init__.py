"""The built-in task families, one module each; every module registers its family on import.

A new family is one more module here (it calls :func:`samplehd.tasks.task.register_family`) plus its
template data (``samplehd/language/templates/<family>.json``); this package imports every module in
it, so nothing else changes.
"""

from __future__ import annotations

import importlib
import pkgutil

for _module in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_module.name}")
