"""Editing levels from Python: :class:`Level` opens a level file, applies the editor's commands
to it (checked as the window's editor checks them, each one undo step), saves it, and runs it as
a :class:`~flockway.Sim`. A parameter study makes its variants this way instead of editing RON
by hand."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from . import _flockway
from .data import data_dir, level_path
from .sim import Sim

#: What :meth:`Level.set` accepts as ``item``: the kind of a named item.
ITEM_KINDS = (
    "road", "junction", "spawner", "destroyer", "trigger", "detector", "profile", "vehicle_type",
)

_TARGETS = {
    "road": "Road",
    "junction": "Junction",
    "spawner": "Spawner",
    "destroyer": "Destroyer",
    "trigger": "Trigger",
    "detector": "Detector",
    "profile": "Profile",
    "vehicle_type": "VehicleType",
}


class Level:
    """A level file being edited.

    ``level`` is a path to a level file or the name of a shipped level (``"crossroads_signal"``);
    without one, a new level from the ``empty`` template (the reference vehicle types and the
    ``autonomous`` and ``human`` profiles, no roads). Edits are the editor's commands
    (``docs/levels.md``, "Editing from scripts"): :meth:`apply` takes one as RON text or as a
    dict (its JSON form), :meth:`set` is the short form of ``Set``. An edit that would make the
    level one ``flockway run`` rejects raises ``ValueError`` saying what and where, and leaves
    the level as it was.
    """

    def __init__(self, level: str | os.PathLike[str] | None = None) -> None:
        self._source = None if level is None else level_path(level)
        self._doc = _flockway.LevelDoc(None if self._source is None else str(self._source))

    @classmethod
    def load(cls, level: str | os.PathLike[str]) -> Level:
        """Opens a level file (or a shipped level by name)."""
        return cls(level)

    # -- edits -----------------------------------------------------------------------------
    def apply(self, command: str | dict[str, Any]) -> Level:
        """Applies one editor command as one undo step: RON text
        (``'Set(item: Road("west in"), field: "lanes", value: 2)'``) or its JSON form as a dict
        (``{"Set": {"item": {"Road": "west in"}, "field": "lanes", "value": 2}}``). Returns the
        level, so edits chain."""
        if isinstance(command, str):
            self._doc.apply(command)
        elif isinstance(command, dict):
            self._doc.apply(json.dumps(command), json=True)
        else:
            raise TypeError(f"apply({command!r}): expected RON text or a dict")
        return self

    def set(self, item: str, name: str | None, field: str, value: Any) -> Level:
        """Sets one field of a named item: ``set("road", "west in", "lanes", 2)``,
        ``set("junction", "crossroads", "signal.phases.0.duration_s", 25)``,
        ``set("trigger", "slow zone", "effect.SpeedLimit.kmh", 60)``; ``item`` is one of
        :data:`ITEM_KINDS`, or ``"level"`` with ``name=None`` for the level's settings
        (``seed``, ``duration_s``, ``telemetry.period_s``, …). ``field`` is a dotted path into
        the item as the level file writes it. Returns the level."""
        if item == "level":
            target: Any = "Level"
        elif item in _TARGETS:
            if name is None:
                raise ValueError(f"set({item!r}, …): a {item} is named")
            target = {_TARGETS[item]: name}
        else:
            raise ValueError(
                f"set({item!r}, …): expected one of {', '.join(ITEM_KINDS)} or 'level'"
            )
        return self.apply({"Set": {"item": target, "field": field, "value": value}})

    def undo(self) -> bool:
        """Undoes the last edit; False if there is none."""
        return self._doc.undo()

    def redo(self) -> bool:
        """Redoes the last undone edit; False if there is none."""
        return self._doc.redo()

    # -- reading ---------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The level as a dict: every field as the level file has it (``roads``,
        ``junctions``, ``spawners``, …)."""
        return json.loads(self._doc.to_json())

    @property
    def path(self) -> Path | None:
        """The file it was opened from or last saved to."""
        p = self._doc.path
        return None if p is None else Path(p)

    @property
    def dirty(self) -> bool:
        """Whether there are edits not saved."""
        return self._doc.dirty

    # -- saving and running ----------------------------------------------------------------
    def save(self, path: str | os.PathLike[str] | None = None) -> Path:
        """Saves atomically to ``path`` (which becomes its file), or to the file it was opened
        from; a level ``flockway run`` would reject is refused with ``ValueError``. Returns the
        path written."""
        return Path(self._doc.save(None if path is None else str(path)))

    def to_sim(self, **kwargs: Any) -> Sim:
        """A :class:`~flockway.Sim` of the level as edited (saved or not): written to a
        temporary directory beside the vehicle and driver assets it uses. ``kwargs`` are
        :class:`~flockway.Sim`'s (``seed``, ``overrides``, ``drivers``, ``csv``)."""
        tmp = tempfile.TemporaryDirectory(prefix="flockway-level-")
        stem = self._source.stem if self._source is not None else "untitled"
        path = Path(tmp.name) / f"{stem}.ron"
        path.write_text(self._doc.checked_text(str(path)), encoding="utf-8")
        assets = _assets_for(self._source)
        try:
            os.symlink(assets, Path(tmp.name) / "assets", target_is_directory=True)
        except OSError:
            shutil.copytree(assets, Path(tmp.name) / "assets")
        sim = Sim(path, **kwargs)
        # The level file lives as long as the Sim that read it.
        sim._level_dir = tmp
        return sim


def _assets_for(source: Path | None) -> Path:
    """The assets a level uses: the nearest ``assets/`` above its file, else the shipped ones."""
    if source is not None:
        for parent in source.resolve().parents:
            candidate = parent / "assets"
            if candidate.is_dir():
                return candidate
    return data_dir() / "assets"
