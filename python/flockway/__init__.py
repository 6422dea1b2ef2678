"""Flockway from Python: a deterministic traffic sandbox with rigid-body vehicles.

``flockway.Sim`` steps a level and shows its vehicles as NumPy arrays; ``flockway.Level`` edits
a level file with the editor's commands (variants for a parameter study); drivers written in Python
drive a level's ``Custom("NAME")`` profiles; ``flockway.run`` runs a level to its end and
returns its summary (with the score and medal of a challenge, ``flockway.challenges()``). Importing
the package registers the gymnasium environments (``flockway/RingWave-v0``, ``flockway/Level-v0``)
when gymnasium is installed.
"""

from ._flockway import __version__, set_threads
from .data import challenges, data_dir, level_path, shipped_levels
from .level import Level
from .sim import DT_S, Sim, run
from .sweep import sweep

__all__ = [
    "DT_S",
    "Level",
    "Sim",
    "__version__",
    "challenges",
    "data_dir",
    "level_path",
    "run",
    "set_threads",
    "shipped_levels",
    "sweep",
]

try:
    from . import envs as _envs

    _envs.register_all()
    from .vector import VectorEnv  # noqa: F401  (needs gymnasium, as the environments do)
except ImportError:  # gymnasium is not installed: the environments are not offered.
    pass
