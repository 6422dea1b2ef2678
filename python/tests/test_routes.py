"""Routes from Python: spawning along a route or to a destination, changing a vehicle's route or
destination, and the route and next-road columns."""

from __future__ import annotations

import numpy as np
import pytest

import flockway

LEVEL = "crossroads_signal"


def _row(sim: flockway.Sim, vid: int) -> dict[str, object]:
    v = sim.vehicles()
    at = np.flatnonzero(v["id"] == vid)
    assert len(at) == 1, f"vehicle {vid} is gone"
    return {k: a[at[0]] for k, a in v.items()}


def _roads_taken(sim: flockway.Sim, vid: int, seconds: float) -> list[str]:
    taken: list[str] = []
    for _ in range(int(seconds * 2)):
        sim.step(60)
        v = sim.vehicles()
        at = np.flatnonzero(v["id"] == vid)
        if len(at) == 0:
            break
        road = str(v["road"][at[0]])
        if not taken or taken[-1] != road:
            taken.append(road)
    return taken


def test_a_vehicle_spawned_on_a_route_takes_it_and_shows_it() -> None:
    s = flockway.Sim(LEVEL, seed=2, csv=False)
    vid = s.spawn("west in", 150.0, "autonomous", speed_mps=10.0, route=["west in", "north out"])
    row = _row(s, vid)
    assert row["route"] == "north out" and row["next_road"] == "north out"
    taken = _roads_taken(s, vid, 90.0)
    assert taken[0] == "west in" and taken[-1] == "north out", taken
    assert any(r.startswith("crossroads#") for r in taken)
    assert s.collisions == 0


def test_a_destination_is_reached_the_quickest_way_and_set_destination_changes_it() -> None:
    s = flockway.Sim(LEVEL, seed=3, csv=False)
    a = s.spawn("east in", 120.0, "autonomous", speed_mps=10.0, destination="north out")
    assert _row(s, a)["route"] == "north out"
    b = s.spawn("south in", 120.0, "autonomous", speed_mps=10.0, destination="west out")
    s.set_destination(b, "east out")
    row = _row(s, b)
    assert row["route"] == "east out" and row["next_road"] == "east out"
    assert _roads_taken(s, a, 90.0)[-1] == "north out"
    assert _roads_taken(s, b, 90.0)[-1] == "east out"


def test_set_route_turns_a_level_vehicle_and_a_road_follower_has_no_route() -> None:
    s = flockway.Sim(LEVEL, seed=4, csv=False)
    free = s.spawn("north in", 100.0, "autonomous", speed_mps=8.0)
    assert _row(s, free)["route"] == ""
    on_west: np.ndarray = np.array([])
    while len(on_west) == 0 and s.time_s < 30.0:
        s.step(60)
        v = s.vehicles()
        on_west = v["id"][(v["road"] == "west in") & (v["s_m"] < 150.0)]
    assert len(on_west), "the level's west spawner has sent a car"
    assert _row(s, int(on_west[0]))["route"] in ("straight", "left", "right")
    vid = int(on_west[0])
    s.set_route(vid, ["south out"])
    row = _row(s, vid)
    assert row["route"] == "south out" and row["next_road"] == "south out"
    assert _roads_taken(s, vid, 90.0)[-1] == "south out"


@pytest.mark.parametrize(
    ("call", "says"),
    [
        (lambda s: s.spawn("west in", 10.0, "autonomous", route=["east out", "west in"]),
         "road `east out` does not lead onto road `west in`"),
        (lambda s: s.spawn("west in", 10.0, "autonomous", route=["nowhere"]), "no road `nowhere`"),
        (lambda s: s.spawn("west in", 10.0, "autonomous", destination="east in"),
         "cannot be reached"),
        (lambda s: s.spawn("west in", 10.0, "autonomous", route=["east out"],
                           destination="east out"), "not both"),
        (lambda s: s.set_route(0, ["south in", "north in"]),
         "vehicle 0: road `south in` does not lead onto road `north in`"),
        (lambda s: s.set_destination(0, "north in"),
         "vehicle 0: road `north in` cannot be reached from road `south in`"),
    ],
)
def test_bad_routes_raise_value_error_and_change_nothing(call, says) -> None:
    s = flockway.Sim(LEVEL, seed=5, csv=False)
    while 0 not in set(s.vehicles()["id"].tolist()):
        s.step(60)
    assert _row(s, 0)["road"] == "south in"
    before = s.vehicles()
    with pytest.raises(ValueError) as err:
        call(s)
    assert says in str(err.value)
    after = s.vehicles()
    assert list(after["id"]) == list(before["id"])
    assert list(after["route"]) == list(before["route"])


def test_an_unknown_vehicle_is_a_key_error() -> None:
    s = flockway.Sim(LEVEL, seed=5, csv=False)
    with pytest.raises(KeyError):
        s.set_destination(999, "east out")
