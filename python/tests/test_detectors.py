"""Induction loops from Python: each loop now, every closed period, and the detectors CSV they
match."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import flockway

LEVEL = "signal_queue"  # a stop-bar loop and an advance loop, 60 s periods


def test_each_loop_now_shows_its_period_so_far_and_its_last_period() -> None:
    s = flockway.Sim(LEVEL, seed=8, csv=False)
    d = s.detectors()
    assert list(d["detector"]) == ["stop_bar", "advance"]
    assert list(d["road"]) == ["approach", "approach"]
    assert list(d["lane"]) == [0, 0]
    assert list(d["s_m"]) == [398.0, 200.0]
    assert np.all(np.isnan(d["last_mean_speed_kmh"])) and list(d["last_count"]) == [0, 0]
    s.run(150.0)
    d = s.detectors()
    # The current period began at 120 s; the last closed one is 60–120 s.
    assert list(d["period_begin_s"]) == [120.0, 120.0]
    log = s.detector_log()
    assert list(log["begin_s"]) == [0.0, 0.0, 60.0, 60.0]
    last = log[log["begin_s"] == 60.0].set_index("detector")
    for k, name in enumerate(d["detector"]):
        assert d["last_count"][k] == last.loc[name, "count"]
        assert d["last_flow_veh_h"][k] == pytest.approx(last.loc[name, "flow_veh_h"], abs=0.05)
        assert d["last_occupancy_pct"][k] == pytest.approx(last.loc[name, "occupancy_pct"], abs=5e-4)
        assert d["last_mean_speed_kmh"][k] == pytest.approx(last.loc[name, "mean_speed_kmh"], abs=5e-4)
    # Cars arrive at about 50 km/h at the advance loop and queue over the stop bar.
    assert 8 <= last.loc["advance", "count"] <= 14
    assert last.loc["advance", "mean_speed_kmh"] == pytest.approx(50.0, abs=2.0)
    assert last.loc["stop_bar", "occupancy_pct"] > 3 * last.loc["advance", "occupancy_pct"]
    assert 0.0 <= d["occupancy_pct"].min() and d["occupancy_pct"].max() <= 100.0


def test_the_vehicles_over_a_loop_are_the_ones_the_vehicle_columns_put_there() -> None:
    s = flockway.Sim(LEVEL, seed=8, csv=False)
    for _ in range(240):
        s.step(6)  # every 0.05 s for 12 s: cars pass the advance loop
        v = s.vehicles()
        over = np.abs(v["s_m"] - 200.0) <= 2.3  # half a sedan's 4.6 m
        on_road = v["road"] == "approach"
        assert s.detectors()["vehicles"][1] == int(np.sum(over & on_road))


def test_the_log_is_the_detectors_csv_and_the_current_periods_follow_on_request(
    tmp_path: Path,
) -> None:
    s = flockway.Sim(LEVEL, seed=4, csv=tmp_path / "run.csv")
    s.run(130.0)
    written = pd.read_csv(tmp_path / "run.detectors.csv")
    assert list(written.columns) == [
        "begin_s", "end_s", "detector", "road", "lane", "s_m", "count", "flow_veh_h",
        "occupancy_pct", "mean_speed_kmh", "harmonic_speed_kmh", "mean_length_m",
    ]
    assert list(written["end_s"]) == [60.0, 60.0, 120.0, 120.0]
    pd.testing.assert_frame_equal(s.detector_log(), written)
    # The periods so far (120–130 s) after the closed ones, as the loops show them now.
    with_current = s.detector_log(current=True)
    assert list(with_current["end_s"]) == [60.0, 60.0, 120.0, 120.0, 130.0, 130.0]
    now = s.detectors()
    tail = with_current.iloc[4:]
    assert list(tail["begin_s"]) == list(now["period_begin_s"])
    assert list(tail["count"]) == list(now["count"])
    assert np.allclose(tail["occupancy_pct"], now["occupancy_pct"], atol=5e-4)


def test_a_level_without_detectors_has_none() -> None:
    s = flockway.Sim("dense_road", seed=1, csv=False)
    s.step(10)
    d = s.detectors()
    assert all(len(v) == 0 for v in d.values())
    assert "detector" in d and "last_count" in d
    log = s.detector_log()
    assert len(log) == 0 and "occupancy_pct" in log.columns


def test_a_detector_added_by_an_edit_measures_in_the_run() -> None:
    level = flockway.Level("dense_road")
    level.apply('AddDetector((name: "loop", road: "main", s_m: 300.0, period_s: 20.0))')
    level.set("detector", "loop", "lanes", [1, 2])
    with pytest.raises(ValueError, match="outside road `main`"):
        level.set("detector", "loop", "s_m", 5000.0)
    assert level.to_dict()["detectors"] == [
        {"name": "loop", "road": "main", "s_m": 300.0, "lanes": [1, 2], "period_s": 20.0}
    ]
    sim = level.to_sim(seed=2, csv=False)
    sim.run(45.0)
    log = sim.detector_log()
    assert list(log["lane"]) == [1, 2, 1, 2]
    assert list(log["end_s"]) == [20.0, 20.0, 40.0, 40.0]
    assert (log["count"][2:] > 10).all()
