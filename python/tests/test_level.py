"""Editing levels from Python: flockway.Level applies the editor's commands, checked, with undo,
saves, and runs the result."""

from __future__ import annotations

from pathlib import Path

import pytest

import flockway


def test_three_variants_of_a_level_are_made_saved_and_run(tmp_path: Path) -> None:
    spawned = {}
    for interval in (5.0, 10.0, 20.0):
        level = flockway.Level("crossroads_signal")
        for arm in ("west", "east", "south", "north"):
            level.set("spawner", arm, "interval_s", {"min": interval * 0.8, "max": interval * 1.2})
        level.set("junction", "crossroads", "signal.phases.0.duration_s", 30)
        level.set("level", None, "seed", 11)
        saved = level.save(tmp_path / f"every_{interval:g}_s.ron")
        again = flockway.Level(saved).to_dict()
        assert again["spawners"][0]["interval_s"] == {"min": interval * 0.8, "max": interval * 1.2}
        assert again["junctions"][0]["signal"]["phases"][0]["duration_s"] == 30.0
        assert again["seed"] == 11
        summary = level.to_sim().run(40.0)
        spawned[interval] = summary["vehicles_spawned"]
        assert summary["collisions_vehicle"] == 0
    assert spawned[5.0] > spawned[10.0] > spawned[20.0], spawned


def test_a_refused_edit_raises_saying_what_and_leaves_the_level_as_it_was() -> None:
    level = flockway.Level("crossroads_signal")
    before = level.to_dict()
    with pytest.raises(ValueError, match="lanes 17: expected 1 to 16"):
        level.set("road", "west in", "lanes", 17)
    with pytest.raises(ValueError, match="there is no road `nowhere`"):
        level.set("road", "nowhere", "lanes", 2)
    with pytest.raises(ValueError, match="unknown field `lane`"):
        level.set("road", "west in", "lane", 2)
    with pytest.raises(ValueError, match="outside road"):
        level.set("spawner", "west", "s_m", 5000)
    with pytest.raises(ValueError, match="not an edit command"):
        level.apply("SetRoad(road: 0)")
    with pytest.raises(ValueError, match="expected one of"):
        level.set("street", "west in", "lanes", 2)
    assert level.to_dict() == before
    assert not level.dirty


def test_ron_and_dict_commands_undo_and_redo_and_a_rename_is_followed() -> None:
    level = flockway.Level("crossroads_signal")
    level.apply('Set(item: Road("west in"), field: "name", value: "avenue")')
    level.apply({"Set": {"item": {"Road": "avenue"}, "field": "speed_limit_kmh", "value": 40}})
    d = level.to_dict()
    assert d["spawners"][0]["road"] == "avenue"
    assert d["junctions"][0]["connections"][0]["from"] == "avenue"
    assert level.dirty
    assert level.undo() and level.undo()
    assert level.to_dict()["roads"][0]["name"] == "west in"
    assert level.redo()
    assert level.to_dict()["roads"][0]["name"] == "avenue"
    # Deleting a road takes what refers to it along: its spawner, connections, routes.
    level.apply("DeleteRoad(road: 0)")
    d = level.to_dict()
    assert all(s["road"] != "avenue" for s in d["spawners"])
    assert all(c["from"] != "avenue" for c in d["junctions"][0]["connections"])


def test_a_new_level_is_drawn_by_commands_and_runs(tmp_path: Path) -> None:
    level = flockway.Level()
    level.apply("AddRoad(at: (0, 0, 0))")
    level.apply("AppendPoint(road: 0, at: (400, 0, 0))")
    level.set("road", "road 1", "lanes", 2)
    level.apply(
        'AddSpawner((name: "in", road: "road 1", lane: 0, s_m: 5, interval_s: (min: 2, max: 3),'
        ' profiles: [(profile: "autonomous", weight: 1)]))'
    )
    level.apply('AddDestroyer((name: "out", place: OnRoad(road: "road 1", s_m: 390)))')
    with pytest.raises(ValueError, match="no file yet"):
        level.save()
    path = level.save(tmp_path / "drawn.ron")
    assert level.path == path and not level.dirty
    summary = level.to_sim(seed=3).run(30.0)
    assert summary["vehicles_spawned"] >= 8
    assert summary["collisions_vehicle"] == 0


def test_load_opens_a_file_and_an_invalid_level_is_not_saved(tmp_path: Path) -> None:
    level = flockway.Level.load(flockway.level_path("crossroads_signal"))
    assert level.to_dict()["name"] == "crossroads_signal"
    drawing = flockway.Level()
    drawing.apply("AddRoad(at: (0, 0, 0))")  # one point: not a road yet
    with pytest.raises(ValueError, match="Not saved, because `flockway run` would refuse"):
        drawing.save(tmp_path / "half.ron")
    assert not (tmp_path / "half.ron").exists()
