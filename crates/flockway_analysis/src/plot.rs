//! Plots of a run: speed histories, space–time diagram, mean speed, fundamental diagram.

use crate::{AnalysisError, Sample, Trace};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Image format of written plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlotFormat {
    /// Portable Network Graphics (raster).
    #[default]
    Png,
    /// Scalable Vector Graphics.
    Svg,
}

impl PlotFormat {
    /// The file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            PlotFormat::Png => "png",
            PlotFormat::Svg => "svg",
        }
    }
}

/// What the plots are titled with.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlotInfo {
    /// Level name.
    pub level: String,
    /// Seed of the run, if known.
    pub seed: Option<u64>,
    /// Known road lengths by name, metres (the space–time diagram's extent).
    pub road_lengths: BTreeMap<String, f64>,
    /// Whether the run had destroyers (then the fundamental diagram is drawn); `None` infers it
    /// from vehicles leaving before the end.
    pub destroyers: Option<bool>,
    /// The run's junction capacity samples (then the capacity plot is drawn).
    pub capacity: Vec<crate::CapacitySample>,
}

impl PlotInfo {
    fn title(&self, what: &str) -> String {
        match self.seed {
            Some(seed) => format!("{} · seed {seed} · {what}", self.level),
            None => format!("{} · {what}", self.level),
        }
    }
}

/// The plots [`write_plots`] makes, by file stem (a documented contract).
pub const PLOT_NAMES: [&str; 5] = [
    "speed_history",
    "space_time",
    "mean_speed",
    "fundamental_diagram",
    "capacity",
];

/// Default image size, pixels.
pub const PLOT_SIZE: (u32, u32) = (1600, 900);

/// Writes `speed_history`, `space_time`, `mean_speed` and, for runs with destroyers,
/// `fundamental_diagram` into `dir` (created if needed). Returns the files written.
pub fn write_plots(
    trace: &Trace,
    info: &PlotInfo,
    dir: &Path,
    format: PlotFormat,
) -> Result<Vec<PathBuf>, AnalysisError> {
    write_plots_sized(trace, info, dir, format, PLOT_SIZE)
}

/// [`write_plots`] at a chosen image size, pixels.
pub fn write_plots_sized(
    trace: &Trace,
    info: &PlotInfo,
    dir: &Path,
    format: PlotFormat,
    size: (u32, u32),
) -> Result<Vec<PathBuf>, AnalysisError> {
    std::fs::create_dir_all(dir).map_err(|source| AnalysisError::Io {
        path: dir.to_owned(),
        source,
    })?;
    let mut written = Vec::new();
    for name in PLOT_NAMES {
        let path = dir.join(format!("{name}.{}", format.extension()));
        if render_plot(name, trace, info, &path, format, size)? {
            written.push(path);
        }
    }
    Ok(written)
}

/// Renders one of [`PLOT_NAMES`] to `path`. Returns false if the run has nothing to show for it
/// (the fundamental diagram of a run without destroyers).
pub fn render_plot(
    name: &str,
    trace: &Trace,
    info: &PlotInfo,
    path: &Path,
    format: PlotFormat,
    size: (u32, u32),
) -> Result<bool, AnalysisError> {
    register_fonts();
    if name == "fundamental_diagram" && !info.destroyers.unwrap_or_else(|| trace.vehicles_leave()) {
        return Ok(false);
    }
    if name == "capacity" && info.capacity.is_empty() {
        return Ok(false);
    }
    if !PLOT_NAMES.contains(&name) {
        return Err(AnalysisError::Plot {
            path: path.to_owned(),
            message: format!("no plot named `{name}` (expected one of {PLOT_NAMES:?})"),
        });
    }
    let fail = |message: String| AnalysisError::Plot {
        path: path.to_owned(),
        message,
    };
    match format {
        PlotFormat::Png => {
            let root = BitMapBackend::new(path, size).into_drawing_area();
            draw(name, &root, trace, info).map_err(fail)?;
            root.present().map_err(|e| fail(e.to_string()))?;
        }
        PlotFormat::Svg => {
            let root = SVGBackend::new(path, size).into_drawing_area();
            draw(name, &root, trace, info).map_err(fail)?;
            root.present().map_err(|e| fail(e.to_string()))?;
        }
    }
    Ok(true)
}

fn draw<DB: DrawingBackend>(
    name: &str,
    root: &DrawingArea<DB, Shift>,
    trace: &Trace,
    info: &PlotInfo,
) -> Result<(), String> {
    match name {
        "speed_history" => speed_history(root, trace, info),
        "space_time" => space_time(root, trace, info),
        "mean_speed" => mean_speed(root, trace, info),
        "capacity" => capacity(root, info),
        _ => fundamental_diagram(root, trace, info),
    }
}

fn register_fonts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // Bundled, so plots draw the same text on machines without system fonts.
        let fonts = [
            (
                "sans-serif",
                FontStyle::Normal,
                epaint_default_fonts::UBUNTU_LIGHT,
            ),
            (
                "sans-serif",
                FontStyle::Bold,
                epaint_default_fonts::UBUNTU_LIGHT,
            ),
            (
                "monospace",
                FontStyle::Normal,
                epaint_default_fonts::HACK_REGULAR,
            ),
        ];
        for (name, style, bytes) in fonts {
            if plotters::style::register_font(name, style, bytes).is_err() {
                tracing_free_warn(name);
            }
        }
    });
}

fn tracing_free_warn(name: &str) {
    eprintln!("warning: the bundled font for `{name}` did not load; plot text may be missing");
}

/// Colours by driver profile, chosen by each profile's driver model (the CSV's `model` column):
/// human-like red (as in the thesis), autonomous models blue, others (the IDM, plugins, a CSV
/// without models) green, orange, purple and cyan. A second profile of a family gets a shade of
/// its colour.
fn profile_colours(trace: &Trace) -> Vec<RGBColor> {
    const HUMAN: [RGBColor; 3] = [
        RGBColor(214, 39, 40),
        RGBColor(160, 20, 60),
        RGBColor(240, 110, 90),
    ];
    const AUTONOMOUS: [RGBColor; 3] = [
        RGBColor(31, 119, 180),
        RGBColor(20, 70, 140),
        RGBColor(100, 170, 230),
    ];
    const OTHERS: [RGBColor; 4] = [
        RGBColor(44, 160, 44),
        RGBColor(255, 127, 14),
        RGBColor(148, 103, 189),
        RGBColor(23, 190, 207),
    ];
    let mut counts = [0usize; 3];
    (0..trace.drivers().len())
        .map(|d| {
            let family = match trace.model_of(d as u16) {
                Some("Human") => 0,
                Some("Flock" | "FlockLanes" | "WaveDamper") => 1,
                _ => 2,
            };
            let k = counts[family];
            counts[family] += 1;
            match family {
                0 => HUMAN[k % HUMAN.len()],
                1 => AUTONOMOUS[k % AUTONOMOUS.len()],
                _ => OTHERS[k % OTHERS.len()],
            }
        })
        .collect()
}

fn caption_style() -> TextStyle<'static> {
    TextStyle::from(("sans-serif", 34).into_font())
}

fn speed_max(trace: &Trace) -> f64 {
    let top = trace
        .samples()
        .iter()
        .map(|s| s.speed_kmh)
        .fold(0.0, f64::max);
    (top * 1.1 / 10.0).ceil().max(1.0) * 10.0
}

fn time_range(trace: &Trace) -> std::ops::Range<f64> {
    let start = trace.samples().first().map_or(0.0, |s| s.time_s);
    start..trace.end_s().max(start + 1.0)
}

/// A chart with the common frame: white background, a titled caption, labelled axes with units.
fn chart_on<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: String,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    (x_desc, y_desc): (&str, &str),
    y_label_area: u32,
) -> Result<ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>, String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let mut chart = ChartBuilder::on(root)
        .caption(title, caption_style())
        .margin(24)
        .x_label_area_size(70)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(x, y)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .axis_desc_style(("sans-serif", 26))
        .label_style(("sans-serif", 22))
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(chart)
}

/// The legend box of a chart's labelled series.
fn legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    position: SeriesLabelPosition,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .legend_area_size(44)
        .label_font(("sans-serif", 24))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .draw()
        .map_err(|e| e.to_string())
}

fn speed_history<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    trace: &Trace,
    info: &PlotInfo,
) -> Result<(), String> {
    let colours = profile_colours(trace);
    let vehicles = trace.by_vehicle();
    {
        let mut chart = chart_on(
            root,
            info.title("speed history"),
            time_range(trace),
            0.0..speed_max(trace),
            ("time (s)", "speed (km/h)"),
            90,
        )?;
        let mut labelled = vec![false; colours.len()];
        for samples in vehicles.values() {
            let driver = usize::from(samples[0].driver);
            let colour = colours[driver];
            let series = chart
                .draw_series(LineSeries::new(
                    samples.iter().map(|s| (s.time_s, s.speed_kmh)),
                    colour.mix(0.55).stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
            if !labelled[driver] {
                labelled[driver] = true;
                series
                    .label(trace.drivers()[driver].clone())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 30, y)], colour.stroke_width(4))
                    });
            }
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        Ok(())
    }
}

/// Speed colour scale of the space–time diagram: red (stopped) through yellow to green (fast).
fn speed_colour(speed: f64, max: f64) -> RGBColor {
    let f = (speed / max).clamp(0.0, 1.0);
    let lerp = |a: f64, b: f64, t: f64| (a + (b - a) * t).round() as u8;
    if f < 0.5 {
        let t = f / 0.5;
        RGBColor(
            lerp(200.0, 245.0, t),
            lerp(20.0, 200.0, t),
            lerp(30.0, 40.0, t),
        )
    } else {
        let t = (f - 0.5) / 0.5;
        RGBColor(
            lerp(245.0, 30.0, t),
            lerp(200.0, 150.0, t),
            lerp(40.0, 60.0, t),
        )
    }
}

/// The road with the most samples (ties: the first named).
fn busiest_road(trace: &Trace) -> Option<u16> {
    let mut count = vec![0usize; trace.roads().len()];
    for s in trace.samples() {
        count[usize::from(s.road)] += 1;
    }
    (0..count.len())
        .max_by_key(|&i| (count[i], std::cmp::Reverse(i)))
        .map(|i| i as u16)
}

fn space_time<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    trace: &Trace,
    info: &PlotInfo,
) -> Result<(), String> {
    let road = busiest_road(trace).ok_or("no samples")?;
    let road_name = &trace.roads()[usize::from(road)];
    let top = trace
        .samples()
        .iter()
        .filter(|s| s.road == road)
        .map(|s| s.s_m)
        .fold(1.0, f64::max);
    let length = info
        .road_lengths
        .get(road_name)
        .copied()
        .unwrap_or(top)
        .max(top);
    let vmax = speed_max(trace);
    // Colours are quantised so a trajectory is drawn as few polylines as its speed allows.
    const BINS: f64 = 24.0;
    let bin = |v: f64| ((v / vmax).clamp(0.0, 1.0) * BINS).round();
    let vehicles = trace.by_vehicle();
    {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (main, bar) = root.split_horizontally(root.dim_in_pixel().0 - 150);
        let mut chart = chart_on(
            &main,
            info.title(&format!("space–time diagram, road `{road_name}`")),
            time_range(trace),
            0.0..length,
            ("time (s)", "arc position (m)"),
            100,
        )?;
        for samples in vehicles.values() {
            for run in trajectory_runs(samples, road) {
                // Pieces of one colour bin each, sharing their end points.
                let mut start = 0;
                while start + 1 < run.len() {
                    let b = bin(run[start].speed_kmh);
                    let mut end = start + 1;
                    while end + 1 < run.len() && bin(run[end].speed_kmh) == b {
                        end += 1;
                    }
                    let colour = speed_colour(b / BINS * vmax, vmax);
                    chart
                        .draw_series(std::iter::once(PathElement::new(
                            run[start..=end]
                                .iter()
                                .map(|s| (s.time_s, s.s_m))
                                .collect::<Vec<_>>(),
                            colour.stroke_width(2),
                        )))
                        .map_err(|e| e.to_string())?;
                    start = end;
                }
            }
        }
        // The colour bar.
        let mut scale = ChartBuilder::on(&bar)
            .margin_top(80)
            .margin_bottom(94)
            .margin_right(70)
            .y_label_area_size(0)
            .right_y_label_area_size(60)
            .build_cartesian_2d(0.0..1.0, 0.0..vmax)
            .map_err(|e| e.to_string())?;
        scale
            .configure_mesh()
            .disable_x_mesh()
            .disable_y_mesh()
            .disable_x_axis()
            .y_desc("speed (km/h)")
            .axis_desc_style(("sans-serif", 22))
            .label_style(("sans-serif", 20))
            .draw()
            .map_err(|e| e.to_string())?;
        let steps = 60;
        scale
            .draw_series((0..steps).map(|i| {
                let lo = vmax * f64::from(i) / f64::from(steps);
                let hi = vmax * f64::from(i + 1) / f64::from(steps);
                Rectangle::new(
                    [(0.0, lo), (1.0, hi)],
                    speed_colour(0.5 * (lo + hi), vmax).filled(),
                )
            }))
            .map_err(|e| e.to_string())?;
        Ok(())
    }
}

/// A vehicle's samples on `road`, split where it leaves the road or wraps around a loop.
fn trajectory_runs(samples: &[Sample], road: u16) -> Vec<&[Sample]> {
    let mut out = Vec::new();
    let mut start = None;
    for i in 0..=samples.len() {
        let breaks = i == samples.len()
            || samples[i].road != road
            || (i > 0 && samples[i - 1].road == road && samples[i].s_m + 1.0 < samples[i - 1].s_m);
        if breaks {
            if let Some(s) = start.take()
                && i - s >= 2
            {
                out.push(&samples[s..i]);
            }
            if i < samples.len() && samples[i].road == road {
                start = Some(i);
            }
        } else if start.is_none() {
            start = Some(i);
        }
    }
    out
}

/// Mean, standard deviation and count of speeds at one time, overall and per driver profile.
struct SpeedAt {
    time_s: f64,
    mean: f64,
    std: f64,
    by_driver: Vec<Option<f64>>,
}

fn speed_over_time(trace: &Trace) -> Vec<SpeedAt> {
    let drivers = trace.drivers().len();
    trace
        .by_time()
        .map(|(time_s, samples)| {
            let n = samples.len() as f64;
            let mean = samples.iter().map(|s| s.speed_kmh).sum::<f64>() / n;
            let var = samples
                .iter()
                .map(|s| (s.speed_kmh - mean).powi(2))
                .sum::<f64>()
                / n;
            let mut sums = vec![(0.0, 0usize); drivers];
            for s in samples {
                let e = &mut sums[usize::from(s.driver)];
                e.0 += s.speed_kmh;
                e.1 += 1;
            }
            SpeedAt {
                time_s,
                mean,
                std: var.sqrt(),
                by_driver: sums
                    .into_iter()
                    .map(|(sum, k)| (k > 0).then(|| sum / k as f64))
                    .collect(),
            }
        })
        .collect()
}

fn mean_speed<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    trace: &Trace,
    info: &PlotInfo,
) -> Result<(), String> {
    let series = speed_over_time(trace);
    let colours = profile_colours(trace);
    {
        let mut chart = chart_on(
            root,
            info.title("mean speed and spread"),
            time_range(trace),
            0.0..speed_max(trace),
            ("time (s)", "speed (km/h)"),
            90,
        )?;
        let band: Vec<(f64, f64)> = series
            .iter()
            .map(|p| (p.time_s, p.mean + p.std))
            .chain(
                series
                    .iter()
                    .rev()
                    .map(|p| (p.time_s, (p.mean - p.std).max(0.0))),
            )
            .collect();
        let grey = RGBColor(60, 60, 60);
        chart
            .draw_series(std::iter::once(Polygon::new(band, grey.mix(0.18).filled())))
            .map_err(|e| e.to_string())?
            .label("± 1 standard deviation")
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 8), (x + 30, y + 8)], grey.mix(0.18).filled())
            });
        chart
            .draw_series(LineSeries::new(
                series.iter().map(|p| (p.time_s, p.mean)),
                BLACK.stroke_width(3),
            ))
            .map_err(|e| e.to_string())?
            .label("mean, all vehicles")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 30, y)], BLACK.stroke_width(3)));
        if trace.drivers().len() > 1 {
            for (d, name) in trace.drivers().iter().enumerate() {
                let colour = colours[d];
                chart
                    .draw_series(LineSeries::new(
                        series
                            .iter()
                            .filter_map(|p| p.by_driver[d].map(|m| (p.time_s, m))),
                        colour.stroke_width(2),
                    ))
                    .map_err(|e| e.to_string())?
                    .label(format!("mean, {name}"))
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 30, y)], colour.stroke_width(3))
                    });
            }
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        Ok(())
    }
}

/// One point of the fundamental diagram: a stretch of road over a time window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowDensity {
    /// Index into [`Trace::roads`].
    pub road: u16,
    /// Vehicles per kilometre (all lanes).
    pub density_veh_per_km: f64,
    /// Vehicles per hour (all lanes).
    pub flow_veh_per_h: f64,
}

/// Flow and density by Edie's definitions over cells of `cell_m` × `window_s`: flow is the
/// distance all vehicles travelled in the cell over its area, density the time they spent in it.
/// Each sample stands for one sampling period of travel.
pub fn flow_density(trace: &Trace, cell_m: f64, window_s: f64) -> Vec<FlowDensity> {
    let times = trace.times();
    let dt = {
        let mut steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        steps.sort_by(f64::total_cmp);
        steps.get(steps.len() / 2).copied().unwrap_or(0.5)
    };
    let start = times.first().copied().unwrap_or(0.0);
    // (road, cell, window) -> (distance m, time s)
    let mut cells: BTreeMap<(u16, u64, u64), (f64, f64)> = BTreeMap::new();
    for s in trace.samples() {
        let cell = (s.s_m / cell_m).floor().max(0.0) as u64;
        let window = ((s.time_s - start) / window_s).floor().max(0.0) as u64;
        let e = cells.entry((s.road, cell, window)).or_default();
        e.0 += s.speed_kmh / 3.6 * dt;
        e.1 += dt;
    }
    let full_windows = ((trace.end_s() - start) / window_s).floor() as u64;
    let area = cell_m * window_s;
    cells
        .into_iter()
        .filter(|((_, _, w), _)| *w < full_windows)
        .map(|((road, _, _), (distance, time))| FlowDensity {
            road,
            density_veh_per_km: time / area * 1000.0,
            flow_veh_per_h: distance / area * 3600.0,
        })
        .collect()
}

fn fundamental_diagram<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    trace: &Trace,
    info: &PlotInfo,
) -> Result<(), String> {
    let points = flow_density(trace, 100.0, 30.0);
    let kmax = points
        .iter()
        .map(|p| p.density_veh_per_km)
        .fold(10.0, f64::max)
        * 1.1;
    let qmax = points
        .iter()
        .map(|p| p.flow_veh_per_h)
        .fold(100.0, f64::max)
        * 1.1;
    const COLOURS: [RGBColor; 4] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
    ];
    {
        let mut chart = chart_on(
            root,
            info.title("fundamental diagram (100 m × 30 s cells)"),
            0.0..kmax,
            0.0..qmax,
            ("density (veh/km)", "flow (veh/h)"),
            110,
        )?;
        for (r, name) in trace.roads().iter().enumerate() {
            let colour = COLOURS[r % COLOURS.len()];
            let mine: Vec<_> = points.iter().filter(|p| usize::from(p.road) == r).collect();
            if mine.is_empty() {
                continue;
            }
            chart
                .draw_series(mine.iter().map(|p| {
                    Circle::new(
                        (p.density_veh_per_km, p.flow_veh_per_h),
                        5,
                        colour.mix(0.7).filled(),
                    )
                }))
                .map_err(|e| e.to_string())?
                .label(format!("road `{name}`"))
                .legend(move |(x, y)| Circle::new((x + 10, y), 6, colour.filled()));
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        Ok(())
    }
}

/// Capacity of each yielding approach per demand step (points) against the gap-acceptance
/// formula at the entering drivers' mean critical gap and follow-up time, with ±25 %, and the
/// HCM 6 single-lane roundabout model.
fn capacity<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    info: &PlotInfo,
) -> Result<(), String> {
    // Only saturated approaches show their capacity (an unsaturated one shows its demand).
    let samples: Vec<&crate::CapacitySample> = info
        .capacity
        .iter()
        .filter(|c| c.saturated_share >= crate::SATURATED_SHARE)
        .collect();
    let n = samples.len().max(1) as f64;
    let t_c = samples.iter().map(|c| c.critical_gap_s).sum::<f64>() / n;
    let t_f = samples.iter().map(|c| c.follow_up_s).sum::<f64>() / n;
    let qmax = samples
        .iter()
        .map(|c| c.conflicting_veh_per_h)
        .fold(600.0, f64::max)
        * 1.2;
    let gap = |q: f64| {
        let q = q / 3600.0;
        if q <= 0.0 {
            3600.0 / t_f
        } else {
            3600.0 * q * libm::exp(-q * t_c) / (1.0 - libm::exp(-q * t_f))
        }
    };
    let hcm = |q: f64| 1380.0 * libm::exp(-0.00102 * q);
    let cmax = samples
        .iter()
        .map(|c| c.capacity_veh_per_h)
        .fold(gap(0.0).max(hcm(0.0)), f64::max)
        * 1.1;
    let mut chart = chart_on(
        root,
        info.title("capacity of the yielding approaches per demand step"),
        0.0..qmax,
        0.0..cmax,
        ("flow given way to (veh/h)", "capacity (veh/h)"),
        110,
    )?;
    let curve = |f: &dyn Fn(f64) -> f64, scale: f64| -> Vec<(f64, f64)> {
        (0..=100)
            .map(|i| {
                let q = qmax * f64::from(i) / 100.0;
                (q, f(q) * scale)
            })
            .collect()
    };
    let blue = RGBColor(31, 119, 180);
    let grey = RGBColor(120, 120, 120);
    chart
        .draw_series(LineSeries::new(curve(&gap, 1.0), blue.stroke_width(3)))
        .map_err(|e| e.to_string())?
        .label(format!(
            "c = q·e^(−q·t_c) / (1 − e^(−q·t_f)), t_c {t_c:.1} s, t_f {t_f:.1} s"
        ))
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], blue.stroke_width(3)));
    for scale in [0.75, 1.25] {
        chart
            .draw_series(DashedLineSeries::new(
                curve(&gap, scale),
                8,
                6,
                blue.mix(0.6).stroke_width(2),
            ))
            .map_err(|e| e.to_string())?;
    }
    chart
        .draw_series(DashedLineSeries::new(
            curve(&hcm, 1.0),
            4,
            6,
            grey.stroke_width(2),
        ))
        .map_err(|e| e.to_string())?
        .label("HCM 6 roundabout entry: 1 380·e^(−0.00102·v_c)")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey.stroke_width(2)));
    for scale in [0.75, 1.25] {
        chart
            .draw_series(DashedLineSeries::new(
                curve(&hcm, scale),
                2,
                8,
                grey.mix(0.6).stroke_width(2),
            ))
            .map_err(|e| e.to_string())?;
    }
    let red = RGBColor(214, 39, 40);
    chart
        .draw_series(samples.iter().map(|c| {
            Circle::new(
                (c.conflicting_veh_per_h, c.capacity_veh_per_h),
                7,
                red.filled(),
            )
        }))
        .map_err(|e| e.to_string())?
        .label("measured (one demand step of one saturated approach lane)")
        .legend(move |(x, y)| Circle::new((x + 10, y), 6, red.filled()));
    legend(&mut chart, SeriesLabelPosition::UpperRight)
}
