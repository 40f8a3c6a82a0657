"""The Blender add-on that ships with crowdmotion, and the zip Blender installs it from.

The add-on itself is the folder ``crowdmotion_blender`` beside this file: it runs inside
Blender (bpy and numpy only; it never imports crowdmotion), so it is not imported here.
:func:`write_addon` packs it into an archive that Blender takes both ways: as a legacy
add-on (Preferences > Add-ons > Install from Disk; ``bl_info``) and as an extension
(``blender_manifest.toml``).
"""

from __future__ import annotations

import zipfile
from pathlib import Path

from crowdmotion.io.atomic import atomic_path

ADDON = "crowdmotion_blender"
SOURCE = Path(__file__).with_name(ADDON)
ZIP_NAME = f"{ADDON}.zip"
FILES = ("__init__.py", "crowd.py", "footlock.py", "walker.py", "blender_manifest.toml")


def write_addon(folder) -> Path:
    """Write ``folder/crowdmotion_blender.zip`` (the folder must exist), atomically;
    returns its path."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder} is not a folder" if folder.exists() else f"{folder} does not exist")
    dest = folder / ZIP_NAME
    with atomic_path(dest) as tmp:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
            for name in FILES:
                zf.write(SOURCE / name, f"{ADDON}/{name}")
    return dest
