//! The native module of the `flockway` Python package (`flockway._flockway`): a
//! [`Session`] — a level run step by step — with NumPy arrays in and out. The Python side
//! (`python/flockway/`) builds the documented API on it: `Sim`, drivers written in Python, the
//! gymnasium and PettingZoo environments and the sweeps.

mod level;

use flockway_drivers::ExternalCommand;
use flockway_runner::{Heading, Override, RunError, Session, SessionError};
use flockway_vehicle::Controls;
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1};
use pyo3::exceptions::{PyFileNotFoundError, PyKeyError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A run error as Python sees it: a missing file is `FileNotFoundError`, anything else a
/// `ValueError` with the message `flockway run` prints (file:line:col for a bad level).
fn run_error(e: RunError) -> PyErr {
    let message = e.to_string();
    match e {
        RunError::Level(flockway_level::LevelError::Io { source, .. })
            if source.kind() == std::io::ErrorKind::NotFound =>
        {
            PyFileNotFoundError::new_err(message)
        }
        _ => PyValueError::new_err(message),
    }
}

/// A command error: an unknown vehicle is a `KeyError`, anything else a `ValueError`.
fn session_error(e: SessionError) -> PyErr {
    match e {
        SessionError::NoVehicle(_) => PyKeyError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Where a spawned vehicle goes: along `route`, to `destination`, or (neither) along the road.
fn heading<'a>(
    route: Option<&'a [String]>,
    destination: Option<&'a str>,
) -> PyResult<Option<Heading<'a>>> {
    match (route, destination) {
        (Some(_), Some(_)) => Err(PyValueError::new_err(
            "give a route or a destination, not both",
        )),
        (Some(roads), None) => Ok(Some(Heading::Roads(roads))),
        (None, Some(road)) => Ok(Some(Heading::Destination(road))),
        (None, None) => Ok(None),
    }
}

/// Checks that `values` has one entry per id.
fn same_length(what: &'static str, values: usize, ids: usize) -> PyResult<()> {
    if values == ids {
        Ok(())
    } else {
        Err(session_error(SessionError::Length {
            what,
            got: values,
            ids,
        }))
    }
}

/// A level run step by step (see `flockway.Sim` for the documented API).
#[pyclass(module = "flockway._flockway", name = "Session")]
struct PySession {
    inner: Session,
    /// The off-screen renderer, made at the first `render`.
    view: Option<flockway_render::OffscreenView>,
}

#[pymethods]
impl PySession {
    /// Opens the level at `path` with `seed` (the level's without one), the `(key, value)`
    /// `overrides`, streaming its telemetry CSV to `csv` when given.
    #[new]
    #[pyo3(signature = (path, seed=None, overrides=Vec::new(), csv=None, models=Vec::new()))]
    fn new(
        path: PathBuf,
        seed: Option<u64>,
        overrides: Vec<(String, f64)>,
        csv: Option<PathBuf>,
        models: Vec<(String, String)>,
    ) -> PyResult<PySession> {
        let overrides: Vec<Override> = overrides
            .into_iter()
            .map(|(key, value)| Override { key, value })
            .collect();
        let drivers = models
            .iter()
            .map(|(name, model)| flockway_runner::parse_driver(&format!("{name}={model}")))
            .collect::<Result<_, _>>()
            .map_err(PyValueError::new_err)?;
        let inner = Session::open(&path, seed, &overrides, drivers, csv).map_err(run_error)?;
        Ok(PySession { inner, view: None })
    }

    /// Runs `n` fixed steps of 1/120 s, letting other Python threads run meanwhile (a
    /// `VectorEnv` steps its simulations on all cores at once).
    fn step(&mut self, py: Python<'_>, n: u64) -> PyResult<()> {
        let inner = &mut self.inner;
        py.detach(|| inner.step(n)).map_err(run_error)
    }

    /// Simulated time, s.
    #[getter]
    fn time_s(&self) -> f64 {
        self.inner.time_s()
    }

    /// The level's own duration, s.
    #[getter]
    fn duration_s(&self) -> f64 {
        self.inner.duration_s()
    }

    /// The level's name in reports.
    #[getter]
    fn name(&self) -> String {
        self.inner.name().to_owned()
    }

    /// Vehicle contacts and guardrail hits so far.
    #[getter]
    fn collisions(&self) -> u64 {
        self.inner.collisions()
    }

    /// The road names, by road index.
    #[getter]
    fn road_names(&self) -> Vec<String> {
        self.inner.road_names().to_vec()
    }

    /// Every vehicle now, in id order: a dict of arrays (names indexed by the `road`,
    /// `profile` and `model` columns under `road_names`, `profiles`, `models`).
    fn vehicles<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let v = self.inner.vehicles();
        let d = PyDict::new(py);
        d.set_item("id", v.id.into_pyarray(py))?;
        d.set_item("road", v.road.into_pyarray(py))?;
        d.set_item("lane", v.lane.into_pyarray(py))?;
        d.set_item("s_m", v.s_m.into_pyarray(py))?;
        d.set_item("lateral_m", v.lateral_m.into_pyarray(py))?;
        d.set_item("x_m", v.x_m.into_pyarray(py))?;
        d.set_item("y_m", v.y_m.into_pyarray(py))?;
        d.set_item("z_m", v.z_m.into_pyarray(py))?;
        d.set_item("speed_mps", v.speed_mps.into_pyarray(py))?;
        d.set_item("accel_mps2", v.accel_mps2.into_pyarray(py))?;
        d.set_item("heading_rad", v.heading_rad.into_pyarray(py))?;
        d.set_item("throttle", v.throttle.into_pyarray(py))?;
        d.set_item("steering", v.steering.into_pyarray(py))?;
        d.set_item("profile", v.profile.into_pyarray(py))?;
        d.set_item("model", v.model.into_pyarray(py))?;
        d.set_item("road_names", self.inner.road_names().to_vec())?;
        d.set_item("route", v.route.into_pyarray(py))?;
        d.set_item("next_road", v.next_road.into_pyarray(py))?;
        d.set_item("profiles", v.profiles)?;
        d.set_item("models", v.models)?;
        d.set_item("routes", v.routes)?;
        Ok(d)
    }

    /// Each vehicle's leader: `(leader ids, bumper gaps in m, leader speeds in m/s)`, −1, inf
    /// and NaN where there is none within 500 m.
    fn leaders<'py>(
        &mut self,
        py: Python<'py>,
        ids: PyReadonlyArray1<'py, u32>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let l = self.inner.leaders(ids.as_slice()?).map_err(session_error)?;
        let d = PyDict::new(py);
        d.set_item("id", l.id.into_pyarray(py))?;
        d.set_item("gap_m", l.gap_m.into_pyarray(py))?;
        d.set_item("speed_mps", l.speed_mps.into_pyarray(py))?;
        Ok(d)
    }

    /// Target speeds (and lanes, −1 to keep the current one) for the shared controller.
    #[pyo3(signature = (ids, speed_mps, lane=None))]
    fn set_target(
        &mut self,
        ids: PyReadonlyArray1<'_, u32>,
        speed_mps: PyReadonlyArray1<'_, f64>,
        lane: Option<PyReadonlyArray1<'_, i64>>,
    ) -> PyResult<()> {
        let ids = ids.as_slice()?;
        let speed = speed_mps.as_slice()?;
        same_length("speed_mps", speed.len(), ids.len())?;
        let lanes = match &lane {
            Some(l) => Some(l.as_slice()?),
            None => None,
        };
        if let Some(l) = lanes {
            same_length("lane", l.len(), ids.len())?;
            if let Some(k) = l.iter().position(|&x| x < -1) {
                return Err(PyValueError::new_err(format!(
                    "vehicle {}: lane {}: expected 0 or more (0 is the rightmost), or -1 to \
                     keep its lane",
                    ids[k], l[k]
                )));
            }
        }
        let commands: Vec<Option<ExternalCommand>> = (0..ids.len())
            .map(|k| {
                Some(ExternalCommand::Target {
                    speed_mps: speed[k] as f32,
                    lane: lanes.and_then(|l| u32::try_from(l[k]).ok()),
                })
            })
            .collect();
        self.inner.command(ids, &commands).map_err(session_error)
    }

    /// Throttle (−1..1, negative brakes), steering (−1..1, positive left) and handbrake, as
    /// given, with no controller.
    #[pyo3(signature = (ids, throttle, steering, handbrake=None))]
    fn set_controls(
        &mut self,
        ids: PyReadonlyArray1<'_, u32>,
        throttle: PyReadonlyArray1<'_, f64>,
        steering: PyReadonlyArray1<'_, f64>,
        handbrake: Option<PyReadonlyArray1<'_, bool>>,
    ) -> PyResult<()> {
        let ids = ids.as_slice()?;
        let (t, s) = (throttle.as_slice()?, steering.as_slice()?);
        same_length("throttle", t.len(), ids.len())?;
        same_length("steering", s.len(), ids.len())?;
        let brakes = match &handbrake {
            Some(h) => Some(h.as_slice()?),
            None => None,
        };
        if let Some(h) = brakes {
            same_length("handbrake", h.len(), ids.len())?;
        }
        let commands: Vec<Option<ExternalCommand>> = (0..ids.len())
            .map(|k| {
                Some(ExternalCommand::Controls(Controls {
                    throttle: t[k] as f32,
                    steering: s[k] as f32,
                    handbrake: brakes.is_some_and(|h| h[k]),
                }))
            })
            .collect();
        self.inner.command(ids, &commands).map_err(session_error)
    }

    /// Hands vehicles back to their own drivers.
    fn release(&mut self, ids: PyReadonlyArray1<'_, u32>) -> PyResult<()> {
        let ids = ids.as_slice()?;
        let none = vec![None; ids.len()];
        self.inner.command(ids, &none).map_err(session_error)
    }

    /// Spawns a vehicle of driver profile `profile` (along `route`, or the quickest way to
    /// `destination`); returns its id.
    #[pyo3(signature = (road, s_m, lane, speed_mps, profile, route=None, destination=None))]
    #[expect(
        clippy::too_many_arguments,
        reason = "the Python method's keywords, one each"
    )]
    fn spawn(
        &mut self,
        road: &str,
        s_m: f64,
        lane: u32,
        speed_mps: f64,
        profile: &str,
        route: Option<Vec<String>>,
        destination: Option<String>,
    ) -> PyResult<u32> {
        let heading = heading(route.as_deref(), destination.as_deref())?;
        self.inner
            .spawn(road, s_m, lane, speed_mps as f32, profile, heading.as_ref())
            .map_err(session_error)
    }

    /// Sends vehicle `id` along `roads` from the road it is on.
    fn set_route(&mut self, id: u32, roads: Vec<String>) -> PyResult<()> {
        self.inner
            .set_heading(id, &Heading::Roads(&roads))
            .map_err(session_error)
    }

    /// Sends vehicle `id` the quickest way to road `road`.
    fn set_destination(&mut self, id: u32, road: &str) -> PyResult<()> {
        self.inner
            .set_heading(id, &Heading::Destination(road))
            .map_err(session_error)
    }

    /// Removes vehicles.
    fn despawn(&mut self, ids: PyReadonlyArray1<'_, u32>) -> PyResult<()> {
        self.inner.despawn(ids.as_slice()?).map_err(session_error)
    }

    /// The scene now, drawn off screen (Vulkan, Mesa's lavapipe without a GPU, or GL): an
    /// `(height, width, 3)` array of RGB bytes. `view` is `"top"` or `"orbit"`; `region`
    /// `(x0, y0, x1, y1)` in metres limits the picture to that ground box.
    #[pyo3(signature = (width, height, view="top", region=None))]
    fn render<'py>(
        &mut self,
        py: Python<'py>,
        width: u32,
        height: u32,
        view: &str,
        region: Option<(f64, f64, f64, f64)>,
    ) -> PyResult<Bound<'py, numpy::PyArray3<u8>>> {
        if !(16..=8192).contains(&width) || !(16..=8192).contains(&height) {
            return Err(PyValueError::new_err(format!(
                "{width}x{height}: each side must be 16 to 8192 pixels"
            )));
        }
        let view = match view {
            "top" => flockway_render::View::Top,
            "orbit" => flockway_render::View::Orbit,
            other => {
                return Err(PyValueError::new_err(format!(
                    "view `{other}`: expected \"top\" or \"orbit\""
                )));
            }
        };
        if let Some((x0, y0, x1, y1)) = region
            && !([x0, y0, x1, y1].iter().all(|v| v.is_finite()) && x1 > x0 && y1 > y0)
        {
            return Err(PyValueError::new_err(format!(
                "region ({x0}, {y0}, {x1}, {y1}): expected finite x0 < x1 and y0 < y1, m"
            )));
        }
        if self.view.is_none() {
            let runner = self.inner.runner();
            let network = runner
                .sim()
                .world()
                .resource::<flockway_road::RoadNetwork>();
            let made = flockway_render::OffscreenView::new(network, runner.level())
                .map_err(|e| PyRuntimeError::new_err(format!("cannot render: {e}")))?;
            self.view = Some(made);
        }
        let Some(renderer) = self.view.as_mut() else {
            return Err(PyRuntimeError::new_err("cannot render"));
        };
        renderer.capture(self.inner.runner_mut().sim_mut().world_mut());
        let image = renderer
            .render(
                (width, height),
                view,
                region.map(|(a, b, c, d)| [a, b, c, d]),
            )
            .map_err(|e| PyRuntimeError::new_err(format!("cannot render: {e}")))?;
        let rgb: Vec<u8> = image
            .rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        let array = rgb.into_pyarray(py);
        array
            .reshape([image.height as usize, image.width as usize, 3])
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// Every signalised junction now: a list of dicts (`junction`, `mode`, `custom`, `phase`,
    /// `time_in_phase_s`, `state`, `phases` as `(duration_s, state)` pairs, `connections` as
    /// `(from, from_lane, to, to_lane)` tuples).
    fn signals<'py>(&mut self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.inner
            .signals()
            .into_iter()
            .map(|s| {
                let d = PyDict::new(py);
                d.set_item("junction", s.junction)?;
                d.set_item("mode", s.mode)?;
                d.set_item("custom", s.custom)?;
                d.set_item("phase", s.phase)?;
                d.set_item("time_in_phase_s", s.time_in_phase_s)?;
                d.set_item("state", s.state)?;
                d.set_item("phases", s.phases)?;
                d.set_item("connections", s.connections)?;
                Ok(d)
            })
            .collect()
    }

    /// Switches a junction's signal to phase `phase` of its program now.
    fn set_phase(&mut self, junction: &str, phase: usize) -> PyResult<()> {
        self.inner.set_phase(junction, phase).map_err(session_error)
    }

    /// Shows `state` at a junction now and holds it, with an amber of `amber_s` first for the
    /// movements losing green and then `all_red_s` of red for every changing movement.
    #[pyo3(signature = (junction, state, amber_s=0.0, all_red_s=0.0))]
    fn set_signal_state(
        &mut self,
        junction: &str,
        state: &str,
        amber_s: f64,
        all_red_s: f64,
    ) -> PyResult<()> {
        self.inner
            .set_signal_state(junction, state, amber_s, all_red_s)
            .map_err(session_error)
    }

    /// Runs a program of `(duration_s, state)` phases at a junction from phase `phase` now;
    /// `None` goes back to the level's program.
    #[pyo3(signature = (junction, phases, phase=0))]
    fn set_program(
        &mut self,
        junction: &str,
        phases: Option<Vec<(f64, String)>>,
        phase: usize,
    ) -> PyResult<()> {
        let program = phases.map(|phases| flockway_road::SignalProgram {
            offset_s: 0.0,
            phases: phases
                .into_iter()
                .map(|(duration_s, state)| flockway_road::Phase { duration_s, state })
                .collect(),
        });
        self.inner
            .set_program(junction, program, phase)
            .map_err(session_error)
    }

    /// Every lane into every junction now: a dict of arrays (junction names under
    /// `junctions`, road names under `road_names`).
    fn approaches<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let a = self.inner.approaches();
        let d = PyDict::new(py);
        d.set_item("junction", a.junction.into_pyarray(py))?;
        d.set_item("road", a.road.into_pyarray(py))?;
        d.set_item("lane", a.lane.into_pyarray(py))?;
        d.set_item("length_m", a.length_m.into_pyarray(py))?;
        d.set_item("vehicles", a.vehicles.into_pyarray(py))?;
        d.set_item("approaching", a.approaching.into_pyarray(py))?;
        d.set_item("halting", a.halting.into_pyarray(py))?;
        d.set_item("queue_vehicles", a.queue_vehicles.into_pyarray(py))?;
        d.set_item("queue_m", a.queue_m.into_pyarray(py))?;
        d.set_item("mean_speed_mps", a.mean_speed_mps.into_pyarray(py))?;
        d.set_item("waiting_s", a.waiting_s.into_pyarray(py))?;
        d.set_item("delay_s", a.delay_s.into_pyarray(py))?;
        d.set_item("junctions", a.junctions)?;
        d.set_item("road_names", self.inner.road_names().to_vec())?;
        Ok(d)
    }

    /// Every induction loop now: a dict of arrays (detector names under `detectors`, road
    /// names under `road_names`).
    fn detectors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = self.inner.detectors();
        let d = PyDict::new(py);
        d.set_item("detector", c.detector.into_pyarray(py))?;
        d.set_item("road", c.road.into_pyarray(py))?;
        d.set_item("lane", c.lane.into_pyarray(py))?;
        d.set_item("s_m", c.s_m.into_pyarray(py))?;
        d.set_item("vehicles", c.vehicles.into_pyarray(py))?;
        d.set_item("period_begin_s", c.period_begin_s.into_pyarray(py))?;
        d.set_item("count", c.count.into_pyarray(py))?;
        d.set_item("occupancy_pct", c.occupancy_pct.into_pyarray(py))?;
        d.set_item("mean_speed_kmh", c.mean_speed_kmh.into_pyarray(py))?;
        d.set_item("last_count", c.last_count.into_pyarray(py))?;
        d.set_item("last_flow_veh_h", c.last_flow_veh_h.into_pyarray(py))?;
        d.set_item("last_occupancy_pct", c.last_occupancy_pct.into_pyarray(py))?;
        d.set_item(
            "last_mean_speed_kmh",
            c.last_mean_speed_kmh.into_pyarray(py),
        )?;
        d.set_item("detectors", c.detectors)?;
        d.set_item("road_names", self.inner.road_names().to_vec())?;
        Ok(d)
    }

    /// Every detector period closed so far, as the detectors CSV's text; with `current`, each
    /// loop's current period so far after them.
    #[pyo3(signature = (current=false))]
    fn detector_log_csv(&self, current: bool) -> String {
        self.inner.detector_log(current)
    }

    /// The summary so far, as JSON text (the summary contract of `flockway run`).
    fn summary_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.inner.summary())
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }
}

mod shipped {
    include!(concat!(env!("OUT_DIR"), "/shipped.rs"));
}

/// The shipped levels and the assets they use: `(path under the repository, text)` pairs.
#[pyfunction]
fn shipped_files() -> Vec<(&'static str, &'static str)> {
    shipped::SHIPPED.to_vec()
}

/// Starts the process's task pool with `threads` threads (before the first `Sim`); returns its
/// size. A pool that runs already keeps its size: asking for another is a `RuntimeError`.
#[pyfunction]
fn set_threads(threads: usize) -> PyResult<usize> {
    if !(1..=1024).contains(&threads) {
        return Err(PyValueError::new_err(format!(
            "set_threads({threads}): expected 1 to 1024 threads"
        )));
    }
    let size = flockway_core::init_task_pool(Some(threads));
    if size != threads {
        return Err(PyRuntimeError::new_err(format!(
            "the task pool runs already with {size} thread(s): call set_threads({threads}) \
             before the first Sim, or set FLOCKWAY_THREADS"
        )));
    }
    Ok(size)
}

/// The module.
#[pymodule]
fn _flockway(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySession>()?;
    m.add_class::<level::PyLevel>()?;
    m.add_function(wrap_pyfunction!(shipped_files, m)?)?;
    m.add_function(wrap_pyfunction!(set_threads, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
