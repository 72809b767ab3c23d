"""Where the shipped scenarios and their data files are (a leaf module: no autobal imports, so the
scenario loader and the data reader can both use it without a cycle)."""

from __future__ import annotations

import importlib.resources
from pathlib import Path

SCENARIO_DIR = Path(str(importlib.resources.files("autobal.scenarios")))  # package data (scenarios/ in the repo)
