"""The simulation from Python: :class:`Sim` steps a level, shows its vehicles as NumPy arrays and
takes commands for the vehicles a controller drives; :func:`run` runs a level to its end with
drivers written in Python."""

from __future__ import annotations

import copy
import json
import os
import pickle
import tempfile
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from . import _flockway
from .data import level_path

#: One fixed step of the simulation, s.
DT_S = 1.0 / 120.0


def _ids(ids: Any) -> np.ndarray:
    return np.ascontiguousarray(np.atleast_1d(np.asarray(ids, dtype=np.uint32)))


def _values(values: Any, n: int, dtype: Any) -> np.ndarray:
    """`values` as a contiguous array of `n` entries (a scalar is repeated)."""
    a = np.asarray(values, dtype=dtype)
    if a.ndim == 0:
        a = np.full(n, a, dtype=dtype)
    return np.ascontiguousarray(a)


#: Native calls that only read the run (the session's documented contract: reading changes
#: nothing a step computes); a snapshot leaves them out.
_READS = frozenset({
    "vehicles", "leaders", "signals", "approaches", "detectors", "detector_log_csv",
    "summary_json", "render", "road_names",
})

#: The snapshot format this version writes and reads.
SNAPSHOT_FORMAT = 1


def _kept(value: Any) -> Any:
    """`value` as a call's log keeps it: a copy the caller can no longer change."""
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, (list, dict, tuple)):
        return copy.deepcopy(value)
    return value


class _Recorded:
    """The native session, every call that changes the run logged in order (unless
    ``log`` is ``None``): a run is its level, seed and the calls made on it (the same calls
    give the same bytes), so the log is a snapshot of it. Consecutive steps are one entry."""

    __slots__ = ("_s", "log")

    def __init__(self, session: Any, record: bool) -> None:
        self._s = session
        self.log: list[tuple[str, tuple[Any, ...]]] | None = [] if record else None

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self._s, name)
        if self.log is None or name in _READS or not callable(attr):
            return attr

        def call(*args: Any) -> Any:
            out = attr(*args)
            # Logged once it succeeded: a refused call changes nothing.
            if name == "step" and self.log and self.log[-1][0] == "step":
                self.log[-1] = ("step", (self.log[-1][1][0] + int(args[0]),))
            else:
                self.log.append((name, tuple(_kept(a) for a in args)))
            return out

        return call


class Sim:
    """A level run step by step.

    ``level`` is a path to a level file, or the name of a shipped level (``"stern_ring"``).
    ``seed`` replaces the level's seed; ``overrides`` maps ``"duration_s"`` or
    ``"PROFILE.PARAMETER"`` (a driver profile's name and a parameter of its model, as a
    profile's ``set`` names it) to a number. ``drivers`` maps a custom model's name (a profile
    with ``model: Custom("NAME")``) to a Python driver: an object whose ``decide(obs)`` is called
    once per step with the observations of all that model's vehicles (see :meth:`observe`) and
    returns their target speeds, or a dict with ``speed_mps`` (and ``lane``), or with
    ``throttle`` and ``steering`` (and ``handbrake``). A string instead of an object, a built-in
    model's name (``"WaveDamper"``), drives that custom model's profiles (or the profile of that
    name) with the built-in driver and its default parameters, as ``flockway run --driver
    NAME=MODEL`` does: the bar a challenge's controller has to beat. The telemetry CSV streams
    to ``csv`` (a temporary file without one; none at all with ``csv=False``) and
    :meth:`telemetry` reads it back. With ``snapshots=False`` it keeps no log of the calls
    that change it (see :meth:`snapshot`): a long run with Python drivers then does not grow
    with their decisions, and :meth:`snapshot` raises ``RuntimeError``.

    The same level, seed and sequence of calls give bit-identical arrays.
    """

    def __init__(
        self,
        level: str | os.PathLike[str],
        seed: int | None = None,
        overrides: Mapping[str, float] | None = None,
        drivers: Mapping[str, Any] | None = None,
        csv: str | os.PathLike[str] | None | bool = None,
        snapshots: bool = True,
    ) -> None:
        path = level_path(level)
        self._snapshots = bool(snapshots)
        self._tmp = None
        if csv is None or csv is True:
            self._tmp = tempfile.TemporaryDirectory(prefix="flockway-")
            csv = Path(self._tmp.name) / "run.csv"
        #: Where the telemetry streams; ``None`` with ``csv=False`` (no telemetry written).
        self.csv: Path | None = None if csv is False else Path(csv)
        pairs = [(str(k), float(v)) for k, v in (overrides or {}).items()]
        given = dict(drivers or {})
        models = [(str(k), v) for k, v in given.items() if isinstance(v, str)]
        # What opens the run again, for snapshots.
        self._opened = (str(path), seed, pairs, models)
        self._s = self._open()
        self.level = path
        self.drivers: dict[str, Any] = {
            k: v for k, v in given.items() if not isinstance(v, str)
        }
        for name, driver in self.drivers.items():
            if not callable(getattr(driver, "decide", None)):
                raise TypeError(f"driver `{name}` has no decide(obs) method")

    def _open(self) -> _Recorded:
        """A new native session of this Sim's level, seed, overrides and built-in drivers,
        streaming to its CSV."""
        path, seed, pairs, models = self._opened
        csv = None if self.csv is None else str(self.csv)
        return _Recorded(_flockway.Session(path, seed, pairs, csv, models), self._snapshots)

    # -- snapshots -------------------------------------------------------------------------
    def snapshot(self) -> bytes:
        """The run's state now as bytes (they pickle, and survive the process): its level
        file's text, seed, overrides and built-in drivers, and every call made on it that
        changed it, in order. :meth:`restore` runs those again, so a restored run is the
        same, bit for bit, as one never snapshotted, whatever it holds (rigid bodies, random
        streams, drivers' memories, spawners' timers, signals, detectors); restoring costs
        the time the run took to get here. A Python driver is not asked again: what it
        decided is among the calls. A ``RuntimeError`` for a Sim made with
        ``snapshots=False``."""
        if self._s.log is None:
            raise RuntimeError("this Sim keeps no snapshots (it was made with snapshots=False)")
        path = self._opened[0]
        return pickle.dumps(
            {
                "format": SNAPSHOT_FORMAT,
                "flockway": _flockway.__version__,
                "opened": self._opened,
                "level_text": Path(path).read_text(encoding="utf-8"),
                "calls": self._s.log,
                "time_s": self.time_s,
            },
            protocol=pickle.HIGHEST_PROTOCOL,
        )

    def restore(self, state: bytes) -> None:
        """Puts this Sim in the state of :meth:`snapshot`'s ``state`` (taken from any Sim):
        its telemetry CSV starts again and, when stepped on, is byte for byte the CSV of the
        run the snapshot came from. Its Python drivers stay its own. A ``ValueError`` for
        bytes that are not a snapshot, one of another format, or one whose level file has
        changed or gone since."""
        try:
            snap = pickle.loads(state) if isinstance(state, (bytes, bytearray)) else None
        except Exception as e:  # noqa: BLE001 (any unpickling error means the same)
            raise ValueError(f"restore: not a Flockway snapshot ({e})") from None
        if not isinstance(snap, dict) or "calls" not in snap:
            raise ValueError("restore: not a Flockway snapshot")
        if snap.get("format") != SNAPSHOT_FORMAT:
            raise ValueError(
                f"restore: a snapshot of format {snap.get('format')!r}; this Flockway reads "
                f"format {SNAPSHOT_FORMAT}"
            )
        path = snap["opened"][0]
        try:
            text = Path(path).read_text(encoding="utf-8")
        except OSError as e:
            raise ValueError(f"restore: the snapshot's level {path} cannot be read: {e}") from None
        if text != snap["level_text"]:
            raise ValueError(f"restore: the level {path} changed since the snapshot was taken")
        self._opened = tuple(snap["opened"])
        self.level = Path(path)
        self._s = self._open()
        for name, args in snap["calls"]:
            getattr(self._s, name)(*args)
        assert self.time_s == snap["time_s"], "a replayed run reaches the snapshot's time"

    def clone(self) -> Sim:
        """An independent copy of this Sim in its state now (see :meth:`snapshot`), with the
        same Python drivers; it streams its telemetry to a temporary file of its own (none if
        this one writes none)."""
        twin = Sim.__new__(Sim)
        twin._init_copy(self.csv is not None, self.drivers)
        twin.restore(self.snapshot())
        return twin

    def __deepcopy__(self, memo: dict[int, Any]) -> Sim:
        twin = Sim.__new__(Sim)
        twin._init_copy(self.csv is not None, copy.deepcopy(self.drivers, memo))
        twin.restore(self.snapshot())
        return twin

    def __getstate__(self) -> dict[str, Any]:
        # A pickled Sim is its snapshot; its copy writes its telemetry to a temporary file.
        return {"snapshot": self.snapshot(), "csv": self.csv is not None, "drivers": self.drivers}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._init_copy(state["csv"], state["drivers"])
        self.restore(state["snapshot"])

    def _init_copy(self, csv: bool, drivers: dict[str, Any]) -> None:
        """The attributes a copy has before it is restored."""
        self._snapshots = True
        self._tmp = None
        self.csv = None
        if csv:
            self._tmp = tempfile.TemporaryDirectory(prefix="flockway-")
            self.csv = Path(self._tmp.name) / "run.csv"
        self.drivers = dict(drivers)

    # -- time ------------------------------------------------------------------------------
    @property
    def time_s(self) -> float:
        """Simulated time, s."""
        return self._s.time_s

    @property
    def duration_s(self) -> float:
        """The level's own duration, s (a Sim runs for as long as it is stepped)."""
        return self._s.duration_s

    @property
    def collisions(self) -> int:
        """Vehicle contacts and guardrail hits so far."""
        return self._s.collisions

    @property
    def name(self) -> str:
        """The level's name in reports."""
        return self._s.name

    def step(self, n: int = 1) -> None:
        """Runs ``n`` fixed steps of 1/120 s (the Python drivers decide before each)."""
        if n < 0:
            raise ValueError(f"step({n}): expected 0 or more steps")
        if not self.drivers:
            self._s.step(int(n))
            return
        for _ in range(int(n)):
            self._drive()
            self._s.step(1)

    def run(self, seconds: float | None = None) -> dict[str, Any]:
        """Steps to ``seconds`` of simulated time (the level's duration without it); returns the
        summary."""
        end = self.duration_s if seconds is None else float(seconds)
        ticks = round(end / DT_S) - round(self.time_s / DT_S)
        if ticks > 0:
            self.step(ticks)
        return self.summary()

    # -- state -----------------------------------------------------------------------------
    def vehicles(self) -> dict[str, np.ndarray]:
        """Every vehicle now, in id order: ``id``, ``road`` (name), ``road_index``, ``lane``,
        ``s_m``, ``lateral_m``, ``x_m``, ``y_m``, ``z_m``, ``speed_mps``, ``accel_mps2``,
        ``heading_rad``, ``throttle``, ``steering``, ``profile`` and ``model`` (names), ``route``
        (its name: the route's or destination's, ``""`` following the road) and ``next_road``
        (the next road of the level its route takes, ``""`` without one)."""
        raw = self._s.vehicles()
        out = {
            k: v
            for k, v in raw.items()
            if k not in ("road_names", "profiles", "models", "routes", "road", "profile",
                         "model", "route", "next_road")
        }
        out["road_index"] = raw["road"]
        out["road"] = _names(raw["road_names"], raw["road"])
        out["profile"] = _names(raw["profiles"], raw["profile"])
        out["model"] = _names(raw["models"], raw["model"])
        out["route"] = _names(raw["routes"], raw["route"])
        roads = np.asarray(list(raw["road_names"]) + [""], dtype=str)
        out["next_road"] = roads[np.where(raw["next_road"] < 0, len(roads) - 1, raw["next_road"])]
        return out

    def leader(self, ids: Any) -> tuple[np.ndarray, np.ndarray]:
        """Each vehicle's leader in its lane: its id (-1 without one within 500 m) and the
        bumper-to-bumper gap, m (inf without one)."""
        d = self._s.leaders(_ids(ids))
        return d["id"], d["gap_m"]

    def leaders(self, ids: Any) -> dict[str, np.ndarray]:
        """:meth:`leader` with the leader's speed too: ``id``, ``gap_m``, ``speed_mps``."""
        return self._s.leaders(_ids(ids))

    # -- commands --------------------------------------------------------------------------
    def set_target(self, ids: Any, speed_mps: Any, lane: Any = None) -> None:
        """Drives these vehicles at ``speed_mps`` (in ``lane``; their own without it) through
        the shared controller, which keeps them in lane and stops them where a junction holds
        them. Holds until the next command; a vehicle of a built-in model is taken over."""
        i = _ids(ids)
        lanes = None if lane is None else _values(lane, len(i), np.int64)
        self._s.set_target(i, _values(speed_mps, len(i), np.float64), lanes)

    def set_controls(
        self, ids: Any, throttle: Any, steering: Any, handbrake: Any = None
    ) -> None:
        """Gives these vehicles their controls directly: throttle -1..1 (negative brakes, and
        from a standstill reverses), steering -1..1 (positive left), handbrake."""
        i = _ids(ids)
        brake = None if handbrake is None else _values(handbrake, len(i), np.bool_)
        self._s.set_controls(
            i,
            _values(throttle, len(i), np.float64),
            _values(steering, len(i), np.float64),
            brake,
        )

    def release(self, ids: Any) -> None:
        """Hands vehicles back to their own drivers."""
        self._s.release(_ids(ids))

    def spawn(
        self,
        road: str,
        s_m: float,
        profile: str,
        lane: int = 0,
        speed_mps: float = 0.0,
        route: list[str] | None = None,
        destination: str | None = None,
    ) -> int:
        """Adds a vehicle of driver profile ``profile``; returns its id. It follows the road
        (each lane's link) unless given ``route`` (the roads to take in order, from ``road``;
        the junction paths between them are found) or ``destination`` (a road it takes the
        quickest way to, at free flow). A route whose roads do not lead one onto the next, a
        road the level lacks or a destination it cannot reach is a ``ValueError``."""
        return self._s.spawn(road, float(s_m), int(lane), float(speed_mps), profile,
                             None if route is None else [str(r) for r in route],
                             None if destination is None else str(destination))

    def set_route(self, vehicle: int, roads: list[str]) -> None:
        """Sends ``vehicle`` along ``roads`` from the road it is on (which may come first);
        it takes the new route's lanes from here on. Checked as :meth:`spawn`'s ``route``."""
        self._s.set_route(int(vehicle), [str(r) for r in roads])

    def set_destination(self, vehicle: int, road: str) -> None:
        """Sends ``vehicle`` the quickest way (at free flow) from the road it is on to
        ``road``; a ``ValueError`` if it cannot get there."""
        self._s.set_destination(int(vehicle), str(road))

    def despawn(self, ids: Any) -> None:
        """Removes vehicles."""
        self._s.despawn(_ids(ids))

    # -- signals and junctions -------------------------------------------------------------
    def signals(self) -> list[dict[str, Any]]:
        """Every signalised junction now, in the level's order: a dict each with ``junction``
        (name), ``mode`` (``"plan"``: the level's program by the clock; ``"running"``: a
        program running on from a phase set by :meth:`set_phase` or :meth:`set_program`;
        ``"held"``: a state set by :meth:`set_signal_state`), ``custom`` (the program was set
        from Python), ``phase`` (index, ``None`` while a state is held), ``time_in_phase_s``,
        ``state`` (a letter per connection: ``G`` green, ``g`` green that gives way, ``y``
        amber, ``r`` red), ``phases`` (the program in force, ``(duration_s, state)`` pairs) and
        ``connections`` (``(from_road, from_lane, to_road, to_lane)`` per letter)."""
        return self._s.signals()

    def set_phase(self, junction: str, phase: int) -> None:
        """Switches ``junction``'s signal to phase ``phase`` of its program now; the program
        runs on from there, each phase for its duration. Raises ``ValueError`` for a junction
        without a signal or a phase its program lacks."""
        self._s.set_phase(str(junction), _index(phase, "phase"))

    def set_signal_state(self, junction: str, state: str, amber_s: float = 0.0,
                         all_red_s: float = 0.0) -> None:
        """Shows ``state`` (a letter per connection, as :meth:`signals` gives them) at
        ``junction`` now and holds it until the next change. The state is shown as given: with
        ``amber_s`` above 0, a movement losing its green shows amber for that long first and a
        movement gaining green stays as it was until then, so two conflicting greens never
        overlap; ``all_red_s`` then shows every changing movement red that long (the clearance
        for a vehicle still in the junction). Raises ``ValueError`` for a wrong length, an
        unknown letter or a negative time."""
        self._s.set_signal_state(str(junction), str(state), float(amber_s), float(all_red_s))

    def set_program(
        self,
        junction: str,
        phases: list[tuple[float, str]] | None = None,
        phase: int = 0,
    ) -> None:
        """Runs a program of ``(duration_s, state)`` phases at ``junction`` from its phase
        ``phase`` now, cycling; ``phases=None`` goes back to the level's own program, by the
        clock as the level has it. Raises ``ValueError`` for a program that does not fit the
        junction (a duration not above 0, a state of the wrong length or letters)."""
        program = None if phases is None else [(float(d), str(s)) for d, s in phases]
        self._s.set_program(str(junction), program, _index(phase, "phase"))

    def junctions(self) -> dict[str, np.ndarray]:
        """Every lane into every junction now, one entry per lane, in the level's junction
        order: ``junction`` and ``road`` (names), ``lane``, ``length_m`` (the road's),
        ``vehicles`` (on the lane), ``approaching`` (within 100 m of the line),
        ``halting`` (slower than 0.1 m/s), ``queue_vehicles`` and ``queue_m`` (the queue
        standing at the line: vehicles below 2 m/s one behind the other, the first within 20 m
        of the line and each within 10 m of the one before; its length from the line to the
        last one's rear bumper), ``mean_speed_mps`` (of the approaching vehicles, NaN with
        none), ``waiting_s`` (the vehicles' time halted since each entered the road, summed)
        and ``delay_s`` (time lost on the lane so far against its speed limit, by every vehicle
        that drove it)."""
        raw = self._s.approaches()
        out = {k: v for k, v in raw.items() if k not in ("junctions", "road_names", "junction", "road")}
        out["junction"] = _names(raw["junctions"], raw["junction"])
        out["road"] = _names(raw["road_names"], raw["road"])
        return out

    def signal_log(self):
        """Every change of every signal so far as a pandas DataFrame: the signals CSV written
        beside the telemetry (``run.signals.csv``), whoever set the signal."""
        import pandas as pd

        if self.csv is None:
            raise RuntimeError("this Sim writes no files (it was made with csv=False)")
        path = self.csv.with_name(f"{self.csv.stem}.signals.csv")
        if not path.exists():
            raise RuntimeError(f"{self.level} has no signals, so no {path.name} is written")
        return pd.read_csv(path, keep_default_na=False, na_values=[])

    def detectors(self) -> dict[str, np.ndarray]:
        """Every induction loop of the level now (a loop per lane a detector covers), in the
        level's detector order, then lane order: ``detector`` and ``road`` (names), ``lane``,
        ``s_m``, ``vehicles`` (over the point in the last step); the current period so far:
        ``period_begin_s``, ``count`` (vehicles whose front passed), ``occupancy_pct`` (share
        of the period a vehicle covered the point), ``mean_speed_kmh`` (of those that passed,
        NaN with none); and the last closed period: ``last_count``, ``last_flow_veh_h``,
        ``last_occupancy_pct``, ``last_mean_speed_kmh`` (0, 0, 0 and NaN before the first
        period closes). Empty arrays for a level without detectors."""
        raw = self._s.detectors()
        out = {k: v for k, v in raw.items() if k not in ("detectors", "road_names", "detector", "road")}
        out["detector"] = _names(raw["detectors"], raw["detector"])
        out["road"] = _names(raw["road_names"], raw["road"])
        return out

    def detector_log(self, current: bool = False):
        """Every detector period closed so far as a pandas DataFrame, a row per loop and
        period: the columns of the detectors CSV written beside the telemetry
        (``run.detectors.csv``), kept in memory too, so it works with ``csv=False``. With
        ``current=True``, each loop's current period so far follows (its ``end_s`` is now). A
        speed or length with no vehicle is NaN."""
        import io

        import pandas as pd

        return pd.read_csv(io.StringIO(self._s.detector_log_csv(bool(current))))

    # -- results ---------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        """The summary of the run so far: the JSON contract of ``flockway run --summary``."""
        return json.loads(self._s.summary_json())

    def telemetry(self):
        """The telemetry so far as a pandas DataFrame: the CSV contract of ``flockway run
        --csv`` (a row per vehicle every sample period)."""
        import pandas as pd

        if self.csv is None:
            raise RuntimeError("this Sim writes no telemetry (it was made with csv=False)")
        return pd.read_csv(self.csv, keep_default_na=False, na_values=[])

    # -- pictures --------------------------------------------------------------------------
    def render(
        self,
        width: int = 640,
        height: int = 480,
        view: str = "top",
        region: tuple[float, float, float, float] | None = None,
    ) -> np.ndarray:
        """The scene now as an ``(height, width, 3)`` array of RGB bytes, drawn off screen by
        the window's renderer (Vulkan; Mesa's lavapipe where there is no GPU). ``view`` is
        ``"top"`` (straight down) or ``"orbit"`` (perspective from the south-west);
        ``region`` ``(x0, y0, x1, y1)`` in metres limits the picture to that ground box (the
        whole level without it). A ``RuntimeError`` says why when no renderer is available."""
        box = None if region is None else tuple(float(x) for x in region)
        return self._s.render(int(width), int(height), str(view), box)

    def region_around(self, vehicle: int, width_m: float = 120.0,
                      aspect: float = 4 / 3) -> tuple[float, float, float, float]:
        """A ground box ``width_m`` wide (and ``width_m / aspect`` high) centred on a vehicle,
        for :meth:`render`."""
        v = self.vehicles()
        at = np.flatnonzero(v["id"] == vehicle)
        if len(at) == 0:
            raise KeyError(f"there is no vehicle {vehicle}")
        x, y = float(v["x_m"][at[0]]), float(v["y_m"][at[0]])
        hw, hh = width_m / 2, width_m / aspect / 2
        return (x - hw, y - hh, x + hw, y + hh)

    # -- Python drivers --------------------------------------------------------------------
    def observe(self, model: str | None = None) -> dict[str, np.ndarray]:
        """What a Python driver sees: :meth:`vehicles` (of custom model ``model`` only, when
        given) with each one's leader (``leader_id``, ``gap_m``, ``leader_speed_mps``), and
        ``time_s`` and ``dt_s``."""
        v = self.vehicles()
        if model is not None:
            keep = v["model"] == f"Custom({model})"
            v = {k: a[keep] for k, a in v.items()}
        lead = self._s.leaders(np.ascontiguousarray(v["id"], dtype=np.uint32))
        v["leader_id"] = lead["id"]
        v["gap_m"] = lead["gap_m"]
        v["leader_speed_mps"] = lead["speed_mps"]
        v["time_s"] = np.float64(self.time_s)
        v["dt_s"] = np.float64(DT_S)
        return v

    def _drive(self) -> None:
        for model, driver in self.drivers.items():
            obs = self.observe(model)
            ids = obs["id"]
            if len(ids) == 0:
                continue
            self.command(ids, driver.decide(obs), source=f"driver `{model}`")

    def command(self, ids: Any, decision: Any, source: str = "command") -> None:
        """Applies a driver's decision to ``ids``: target speeds (an array), or a dict with
        ``speed_mps`` (and ``lane``), or with ``throttle`` and ``steering`` (and
        ``handbrake``)."""
        if isinstance(decision, Mapping):
            if "throttle" in decision or "steering" in decision:
                self.set_controls(
                    ids,
                    decision.get("throttle", 0.0),
                    decision.get("steering", 0.0),
                    decision.get("handbrake"),
                )
            elif "speed_mps" in decision:
                self.set_target(ids, decision["speed_mps"], decision.get("lane"))
            else:
                raise ValueError(
                    f"{source}: expected speeds, or a dict with `speed_mps` (and `lane`) or "
                    f"`throttle` and `steering`; got keys {sorted(decision)}"
                )
        else:
            self.set_target(ids, decision)

    def __repr__(self) -> str:
        return f"Sim({str(self.level)!r}, t={self.time_s:.3f} s)"


def _index(value: Any, what: str) -> int:
    """``value`` as an index from 0, or a ``ValueError`` naming it."""
    i = int(value)
    if i != value or i < 0:
        raise ValueError(f"{what} {value!r}: expected a whole number from 0")
    return i


def _names(names: list[str], index: np.ndarray) -> np.ndarray:
    table = np.asarray(names if names else [""], dtype=str)
    return table[index]


def run(
    level: str | os.PathLike[str],
    drivers: Mapping[str, Any] | None = None,
    seed: int | None = None,
    overrides: Mapping[str, float] | None = None,
    seconds: float | None = None,
    csv: str | os.PathLike[str] | None = None,
) -> dict[str, Any]:
    """Runs a level to its end (or ``seconds``) with ``drivers`` for its custom models; returns
    the summary, as ``flockway run --summary`` writes it."""
    sim = Sim(level, seed=seed, overrides=overrides, drivers=drivers, csv=csv, snapshots=False)
    return sim.run(seconds)
