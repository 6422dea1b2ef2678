"""Signals from Python: reading and setting phases, states and programs, their effect on traffic
and in the signals CSV, and what each lane into a junction shows."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import flockway

LEVEL = "crossroads_signal"
JUNCTION = "crossroads"


def _state(sim: flockway.Sim) -> str:
    return sim.signals()[0]["state"]


def test_signals_show_the_level_program_by_the_clock() -> None:
    s = flockway.Sim(LEVEL, seed=5, csv=False)
    sig = s.signals()
    assert [x["junction"] for x in sig] == [JUNCTION]
    first = sig[0]
    assert first["mode"] == "plan" and first["custom"] is False
    assert len(first["connections"]) == len(first["state"]) == 12
    assert first["connections"][0] == ("west in", 0, "east out", 0)
    phases = first["phases"]
    s.run(phases[0][0] + 1.0)
    now = s.signals()[0]
    assert now["phase"] == 1
    assert now["state"] == phases[1][1]
    assert now["time_in_phase_s"] == pytest.approx(1.0, abs=1e-9)


def test_a_phase_switch_shows_at_once_runs_on_and_is_written_to_the_signals_csv(
    tmp_path: Path,
) -> None:
    s = flockway.Sim(LEVEL, seed=5, csv=tmp_path / "run.csv")
    phases = s.signals()[0]["phases"]
    s.run(10.0)
    s.set_phase(JUNCTION, 3)
    sig = s.signals()[0]
    assert (sig["mode"], sig["phase"], sig["time_in_phase_s"]) == ("running", 3, 0.0)
    assert sig["state"] == phases[3][1]
    # The program runs on from there: phase 4 after phase 3's duration.
    s.run(10.0 + phases[3][0] + 0.5)
    assert s.signals()[0]["phase"] == 4
    log = s.signal_log()
    at_switch = log[log["time_s"] == 10.0]
    assert "".join(at_switch.sort_values("connection")["state"]) != ""
    assert set(at_switch["connection"]) == {
        k for k, (a, b) in enumerate(zip(phases[0][1], phases[3][1])) if a != b
    }
    for _, row in at_switch.iterrows():
        assert row["state"] == phases[3][1][row["connection"]]
    after = log[np.isclose(log["time_s"], 10.0 + phases[3][0])]
    assert len(after) > 0 and set(after["state"]) == {"y"}


def test_a_held_state_with_amber_turns_red_after_the_amber_and_stays(tmp_path: Path) -> None:
    s = flockway.Sim(LEVEL, seed=5, csv=tmp_path / "run.csv")
    s.run(5.0)
    green_ew = _state(s)
    ns = "".join("G" if c == "r" else "r" for c in green_ew)
    s.set_signal_state(JUNCTION, ns, amber_s=3.0)
    between = _state(s)
    assert all(b == "y" for g, b in zip(green_ew, between) if g in "Gg")
    assert all(b == "r" for g, b in zip(green_ew, between) if g not in "Gg")
    assert s.signals()[0]["mode"] == "held" and s.signals()[0]["phase"] is None
    s.run(7.99)
    assert _state(s) == between
    s.run(8.0 + 1 / 120)
    assert _state(s) == ns
    s.run(200.0)
    assert _state(s) == ns, "a held state stays"
    log = s.signal_log()
    assert set(log[log["time_s"] == 5.0]["state"]) == {"y"}
    assert set(log[log["time_s"] == 8.0]["state"]) == {"r", "G"}


def test_a_held_red_builds_queues_that_drain_on_green() -> None:
    s = flockway.Sim(LEVEL, seed=7, csv=False)
    n = len(_state(s))
    s.set_signal_state(JUNCTION, "r" * n)
    s.run(90.0)
    j = s.junctions()
    assert list(j["junction"]) == [JUNCTION] * 4
    assert set(j["road"]) == {"west in", "east in", "south in", "north in"}
    for key in ("vehicles", "approaching", "halting", "queue_vehicles"):
        assert j[key].dtype.kind == "u", key
    assert np.all(j["queue_vehicles"] >= 3), j
    assert np.all(j["queue_m"] > 15.0), j
    # Standing vehicles are all queued; the last few may still be creeping up.
    assert np.all((j["halting"] >= 3) & (j["halting"] <= j["queue_vehicles"]))
    assert np.all(j["queue_vehicles"] <= j["vehicles"])
    assert np.all(j["waiting_s"] > 30.0)
    assert np.all(j["delay_s"] > j["waiting_s"]), "standing counts whole in the delay"
    assert s.collisions == 0
    queued = j["queue_vehicles"].copy()
    delay = j["delay_s"].copy()
    # Green north-south (its level's phase 3), west-east kept red.
    ns = s.signals()[0]["phases"][3][1]
    s.set_signal_state(JUNCTION, ns)
    s.run(120.0)
    after = s.junctions()
    drained = np.isin(after["road"], ["south in", "north in"])
    assert np.all(after["queue_vehicles"][drained] <= 1), after["queue_vehicles"]
    assert np.all(after["queue_vehicles"][~drained] > queued[~drained])
    assert np.all(after["delay_s"] >= delay), "delay only accumulates"
    assert s.collisions == 0


def test_a_program_from_python_runs_and_none_restores_the_level_program() -> None:
    s = flockway.Sim(LEVEL, seed=5, csv=False)
    n = len(_state(s))
    mine = [(4.0, "G" * 6 + "r" * 6), (2.0, "r" * n), (4.0, "r" * 6 + "G" * 6), (2.0, "r" * n)]
    s.set_program(JUNCTION, mine, phase=2)
    sig = s.signals()[0]
    assert sig["custom"] and sig["phases"] == mine and _state(s) == mine[2][1]
    s.run(4.5)
    assert _state(s) == mine[3][1]
    s.run(6.5)
    assert _state(s) == mine[0][1]
    s.set_program(JUNCTION, None)
    sig = s.signals()[0]
    assert sig["mode"] == "plan" and not sig["custom"]
    assert sig["state"] == sig["phases"][sig["phase"]][1]


@pytest.mark.parametrize(
    ("call", "says"),
    [
        (lambda s: s.set_phase("crossroads", 6), "no phase 6"),
        (lambda s: s.set_phase("nowhere", 0), "no signalised junction `nowhere`"),
        (lambda s: s.set_phase("crossroads", -1), "whole number from 0"),
        (lambda s: s.set_signal_state("crossroads", "GGG"), "3 letter(s) for 12"),
        (lambda s: s.set_signal_state("crossroads", "x" * 12), "has `x`"),
        (lambda s: s.set_signal_state("crossroads", "r" * 12, amber_s=-1.0), "amber time -1"),
        (lambda s: s.set_program("crossroads", [(0.0, "r" * 12)]), "more than 0"),
        (lambda s: s.set_program("crossroads", []), "at least one phase"),
        (lambda s: s.set_program("crossroads", [(5.0, "r" * 12)], phase=1), "no phase 1"),
    ],
)
def test_bad_signal_commands_raise_value_error_and_change_nothing(call, says) -> None:
    s = flockway.Sim(LEVEL, seed=5, csv=False)
    before = s.signals()
    with pytest.raises(ValueError, match=None) as err:
        call(s)
    assert says in str(err.value)
    assert s.signals() == before


def test_a_level_without_signals_has_none_and_its_junctions_still_report_lanes() -> None:
    s = flockway.Sim("sugiyama_ring", seed=1, csv=False)
    assert s.signals() == []
    assert len(s.junctions()["lane"]) == 0
    with pytest.raises(ValueError, match="signalised junctions are: none"):
        s.set_phase("x", 0)
