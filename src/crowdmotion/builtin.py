"""The scenario files shipped with the package (the papers' scenes and the built-in demos)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def builtin_scenarios() -> list[Path]:
    """The scenario files shipped with the package, sorted by name."""
    folder = resources.files("crowdmotion") / "scenarios"
    return sorted(Path(str(p)) for p in folder.iterdir() if p.name.endswith(".toml"))
