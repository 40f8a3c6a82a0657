"""Memory sizes: what this machine has available now, and sizes in words (``1.5 GiB``) both ways."""

from __future__ import annotations

import os
import re

_UNITS = {"": 1, "b": 1, "k": 1 << 10, "kb": 1000, "kib": 1 << 10, "m": 1 << 20, "mb": 1000 ** 2, "mib": 1 << 20,
          "g": 1 << 30, "gb": 1000 ** 3, "gib": 1 << 30, "t": 1 << 40, "tb": 1000 ** 4, "tib": 1 << 40}


def available_memory() -> int | None:
    """Bytes of memory a new allocation can have now without swapping (Linux's
    MemAvailable; elsewhere the free pages), or None where the platform does not say."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def human_bytes(size: float) -> str:
    """``1536`` -> ``1.5 KiB``."""
    for unit, name in ((1 << 40, "TiB"), (1 << 30, "GiB"), (1 << 20, "MiB"), (1 << 10, "KiB")):
        if size >= unit:
            return f"{size / unit:.1f} {name}"
    return f"{int(size)} B"


def parse_size(text: str) -> int:
    """``"8G"``, ``"512 MiB"``, ``"2.5GB"`` or a number of bytes -> bytes (ValueError
    naming the text otherwise)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", text)
    unit = m.group(2).lower() if m else None
    if m is None or unit not in _UNITS:
        raise ValueError(f"{text!r} is not a memory size: write e.g. 8G, 512MiB or 2.5GB")
    value = float(m.group(1)) * _UNITS[unit]
    if not 1 <= value < 2 ** 63:
        raise ValueError(f"{text!r} is not a memory size between one byte and 8 EiB")
    return int(value)
