"""The shipped levels and assets, inside the package: unpacked once into a cache directory so a
level can be named (``"stern_ring"``) wherever the package is installed."""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

from . import _flockway


def data_dir() -> Path:
    """Where the shipped ``levels/`` and ``assets/`` are unpacked: ``$FLOCKWAY_DATA``, or a
    directory per package build under the user's cache (``$XDG_CACHE_HOME`` or ``~/.cache``)."""
    files = _flockway.shipped_files()
    digest = hashlib.sha256()
    for rel, text in files:
        digest.update(rel.encode())
        digest.update(text.encode())
    if os.environ.get("FLOCKWAY_DATA"):
        root = Path(os.environ["FLOCKWAY_DATA"])
    else:
        cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
        root = cache / "flockway" / digest.hexdigest()[:16]
    if not (root / ".complete").exists():
        for rel, text in files:
            target = root / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            # Atomic, so processes unpacking at once (Ray workers) never read half a file.
            fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=".tmp-")
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(text)
            os.replace(tmp, target)
        (root / ".complete").write_text("")
    return root


def shipped_levels() -> list[str]:
    """The names of the shipped levels (``stern_ring``, ``sugiyama_ring``, …)."""
    return sorted(
        Path(rel).stem
        for rel, _ in _flockway.shipped_files()
        if rel.startswith("levels/") and rel.count("/") == 1
    )


def challenges() -> list[str]:
    """The names of the shipped challenges (``challenges/damp_the_wave``, …): levels with a
    score and medals, whose ``Custom`` profile is yours to drive."""
    return sorted(
        rel.removeprefix("levels/").removesuffix(".ron")
        for rel, _ in _flockway.shipped_files()
        if rel.startswith("levels/challenges/") and rel.endswith(".ron")
    )


def level_path(level: str | os.PathLike[str]) -> Path:
    """A level file: ``level`` itself when it is a file, else the shipped level of that name
    (``"stern_ring"`` or ``"challenges/damp_the_wave"``, with or without ``.ron``)."""
    path = Path(level)
    if path.is_file():
        return path
    name = str(level).removesuffix(".ron")
    name = name.removeprefix("levels/")
    shipped = data_dir() / "levels" / f"{name}.ron"
    if shipped.is_file():
        return shipped
    raise FileNotFoundError(
        f"{level}: no such level file, nor a shipped level of that name "
        f"(shipped: {', '.join(shipped_levels())})"
    )
