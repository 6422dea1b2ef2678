//! The `flockway` command: run, check and (in later releases) edit and plot levels.

use clap::{Args, Parser, Subcommand};
use flockway::analysis::{PlotFormat, Trace};
use flockway::run::{RunError, RunOptions, Runner, level_name};
use flockway_level::{Template, level_to_string, load_level, write_atomic};
use flockway_vehicle::{DynoReport, DynoSettings, VehicleParams, VehicleType, run_dyno};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

/// Flockway: a deterministic traffic sandbox with rigid-body cars and flocking drivers.
///
/// Levels are RON files (see levels/ for examples). Every run with the same level and seed gives
/// the same results, byte for byte.
#[derive(Parser)]
#[command(name = "flockway", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a level headless and check its expectations.
    ///
    /// Exit status: 0 if every expectation held, 1 if one failed, 2 if the level or an argument
    /// is invalid.
    Run(RunArgs),
    /// Write a new level from a template, ready for `flockway run` and `flockway edit`.
    ///
    /// Templates: `straight` (default): a 500 m two-lane road with a spawner of half autonomous,
    /// half human-like cars and a destroyer; `ring`: 20 autonomous cars on a single-lane loop;
    /// `empty`: the reference vehicle types and driver profiles only. Never overwrites a file.
    /// Exit status: 0, or 2 if the file exists or cannot be written.
    New {
        /// The level file to write (e.g. my_level.ron).
        #[arg(value_name = "LEVEL.ron")]
        level: PathBuf,
        /// What the new level holds.
        #[arg(long, value_enum, default_value_t = TemplateArg::Straight)]
        template: TemplateArg,
    },
    /// Check that level files load and validate, without running them.
    ///
    /// Prints each problem as FILE:LINE:COLUMN: message. Exit status: 0 if all are valid, 2 if not.
    Check {
        /// Level files to check.
        #[arg(required = true, value_name = "LEVEL")]
        levels: Vec<PathBuf>,
    },
    /// Run many levels (files or directories of .ron files), in parallel, and check their
    /// expectations: each for the level's seed, or for several seeds.
    ///
    /// Prints one line per run and ends with `N passed, N failed`. Exit status: 0 if every run
    /// passed, 1 if one failed, 2 if a level or argument is invalid.
    Test {
        /// Level files or directories.
        #[arg(required = true, value_name = "LEVEL|DIR")]
        paths: Vec<PathBuf>,
        /// Run each level for N seeds: its own seed and the N − 1 after it.
        #[arg(long, value_name = "N", conflicts_with = "seed_list")]
        seeds: Option<u64>,
        /// Run each level for these seeds (comma-separated).
        #[arg(long, value_name = "A,B,C", value_delimiter = ',')]
        seed_list: Option<Vec<u64>>,
        /// Simulated seconds per run instead of each level's duration.
        #[arg(long, value_name = "S")]
        seconds: Option<f64>,
        /// Parallel runs (default: the machine's cores).
        #[arg(long, short, value_name = "N")]
        jobs: Option<usize>,
    },
    /// Measure a vehicle on the test tracks: 0–100 km/h, top speed, 100–0 km/h braking, skid-pad
    /// grip and standstill drift.
    ///
    /// Prints a table, or with --json one object with the keys zero_to_100_kmh_s, top_speed_kmh,
    /// braking_100_0_m, max_lateral_g and standstill_drift_m. Exit status: 0, or 2 if the vehicle
    /// file is invalid.
    Dyno {
        /// Vehicle definition to measure (default: assets/vehicles/sedan.ron's reference sedan).
        #[arg(value_name = "VEHICLE")]
        vehicle: Option<PathBuf>,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Draw a run's plots from its telemetry CSV: speed_history, space_time, mean_speed and, for
    /// runs with destroyers, fundamental_diagram.
    ///
    /// Exit status: 0, or 2 if the CSV (or summary) is missing, foreign or malformed.
    Plot {
        /// The telemetry CSV of `flockway run --csv`.
        #[arg(value_name = "RUN.csv")]
        csv: PathBuf,
        /// Directory to write the plots into (created if needed).
        #[arg(long, short, value_name = "DIR", default_value = ".")]
        output: PathBuf,
        /// Image format.
        #[arg(long, value_enum, default_value_t = Format::Png)]
        format: Format,
        /// The run's `--summary` JSON: titles get its level and seed, plots its road lengths.
        #[arg(long, value_name = "FILE")]
        summary: Option<PathBuf>,
        /// Image size in pixels.
        #[arg(long, value_name = "WxH", default_value = "1600x900", value_parser = parse_size)]
        size: (u32, u32),
    },
    /// Open the editor on a level (a new empty level without one).
    ///
    /// Needs a display; without one, use `flockway run` or `flockway render`.
    Edit {
        /// The level file.
        #[arg(value_name = "LEVEL")]
        level: Option<PathBuf>,
    },
    /// Open a level in the window and start playing it.
    Play {
        /// The level file.
        #[arg(value_name = "LEVEL")]
        level: PathBuf,
    },
    /// Simulate a level headless to a moment and render the scene (no HUD) to a PNG, with the
    /// window's renderer, on any machine with a Vulkan or GL driver (Mesa's software ones do).
    ///
    /// Exit status: 0, or 2 if the level or an argument is invalid or there is no graphics
    /// adapter.
    Render {
        /// The level file.
        #[arg(value_name = "LEVEL")]
        level: PathBuf,
        /// The PNG to write.
        #[arg(long, short, value_name = "FILE.png", required = true)]
        output: PathBuf,
        /// Simulated seconds before the picture (0: as the level starts, after its first step).
        #[arg(long, value_name = "SECONDS", default_value_t = 0.0)]
        at: f64,
        /// Image size in pixels.
        #[arg(long, value_name = "WxH", default_value = "1600x900", value_parser = parse_size)]
        size: (u32, u32),
        /// Camera.
        #[arg(long, value_enum, default_value_t = CameraArg::Top)]
        camera: CameraArg,
        /// Seed instead of the level's.
        #[arg(long, value_name = "N")]
        seed: Option<u64>,
    },
    /// Write one self-contained HTML report of a run: summary, expectations and their results,
    /// the stop-and-go wave, and every plot embedded.
    ///
    /// Exit status: 0, or 2 if the CSV (or summary) is missing, foreign or malformed.
    Report {
        /// The telemetry CSV of `flockway run --csv`.
        #[arg(value_name = "RUN.csv")]
        csv: PathBuf,
        /// The HTML file to write.
        #[arg(long, short, value_name = "FILE", required = true)]
        output: PathBuf,
        /// The run's `--summary` JSON, for the summary table and the expectations.
        #[arg(long, value_name = "FILE")]
        summary: Option<PathBuf>,
    },
}

/// Template of `flockway new`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum TemplateArg {
    /// A two-lane road with a spawner and a destroyer.
    Straight,
    /// 20 cars on a single-lane loop.
    Ring,
    /// Vehicle types and driver profiles only.
    Empty,
}

impl From<TemplateArg> for Template {
    fn from(t: TemplateArg) -> Template {
        match t {
            TemplateArg::Straight => Template::Straight,
            TemplateArg::Ring => Template::Ring,
            TemplateArg::Empty => Template::Empty,
        }
    }
}

/// Camera of `flockway render`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum CameraArg {
    /// Straight down, the whole level in view.
    Top,
    /// Perspective from the south-west, the whole level in view.
    Orbit,
}

/// Plot image format on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    /// PNG raster images.
    Png,
    /// SVG vector images.
    Svg,
}

impl From<Format> for PlotFormat {
    fn from(f: Format) -> PlotFormat {
        match f {
            Format::Png => PlotFormat::Png,
            Format::Svg => PlotFormat::Svg,
        }
    }
}

#[derive(Args)]
struct RunArgs {
    /// The level file to run (e.g. levels/dense_road.ron).
    #[arg(value_name = "LEVEL")]
    level: PathBuf,
    /// Simulated seconds to run, instead of the level's duration_s.
    #[arg(long, value_name = "S")]
    seconds: Option<f64>,
    /// Seed for every random stream, instead of the level's seed.
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// Stream per-vehicle telemetry to this CSV file as the run goes.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Also write one telemetry CSV per vehicle into this directory (vehicle_NNNNNN.csv).
    #[arg(long, value_name = "DIR")]
    per_vehicle: Option<PathBuf>,
    /// Write the run summary as JSON to this file (keys documented in the README).
    #[arg(long, value_name = "FILE")]
    summary: Option<PathBuf>,
    /// Write the run's plots into this directory at the end (see `flockway plot`).
    #[arg(long, value_name = "DIR")]
    plots: Option<PathBuf>,
    /// Image format of --plots.
    #[arg(long, value_enum, default_value_t = Format::Png, requires = "plots")]
    plot_format: Format,
    /// Print nothing but errors; the exit status tells the outcome.
    #[arg(long, short)]
    quiet: bool,
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("FLOCKWAY_LOG")
                .unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    match cli.command {
        Command::Run(args) => run(args),
        Command::New { level, template } => new_level(&level, template.into()),
        Command::Check { levels } => check(&levels),
        Command::Dyno { vehicle, json } => dyno(vehicle.as_deref(), json),
        Command::Test {
            paths,
            seeds,
            seed_list,
            seconds,
            jobs,
        } => test(&paths, seeds, seed_list, seconds, jobs),
        Command::Plot {
            csv,
            output,
            format,
            summary,
            size,
        } => plot(&csv, &output, format.into(), summary.as_deref(), size),
        Command::Report {
            csv,
            output,
            summary,
        } => report(&csv, &output, summary.as_deref()),
        Command::Edit { level } => window(level.as_deref(), false),
        Command::Play { level } => window(Some(&level), true),
        Command::Render {
            level,
            output,
            at,
            size,
            camera,
            seed,
        } => render(&level, &output, at, size, camera, seed),
    }
}

fn fail(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(2)
}

fn new_level(path: &std::path::Path, template: Template) -> ExitCode {
    if path.exists() {
        return fail(format!(
            "{} already exists; `flockway new` never overwrites a file: choose another name",
            path.display()
        ));
    }
    let name = path
        .file_stem()
        .map_or_else(|| "level".to_owned(), |s| s.to_string_lossy().into_owned());
    let level = template.level(&name);
    let text = match level_to_string(&level) {
        Ok(t) => t,
        Err(e) => return fail(e),
    };
    let header = format!(
        "// {name}: made by `flockway new --template {template}`: {}.\n",
        template.summary()
    );
    if let Err(e) = write_atomic(path, format!("{header}{text}").as_bytes()) {
        return fail(e);
    }
    let shown = shell_quote(&path.display().to_string());
    println!("wrote {} ({})", path.display(), template.summary());
    println!("run it:   flockway run {shown}");
    println!("edit it:  flockway edit {shown}");
    ExitCode::SUCCESS
}

/// A path as a shell word: quoted when it holds anything a shell would split or expand.
fn shell_quote(text: &str) -> String {
    let plain = !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+:=@%,".contains(c));
    if plain {
        text.to_owned()
    } else {
        format!("'{}'", text.replace('\'', "'\\''"))
    }
}

fn check(levels: &[PathBuf]) -> ExitCode {
    let mut bad = 0;
    for path in levels {
        let loaded = load_level(path).map_err(RunError::from).and_then(|level| {
            let name = level_name(&level, path);
            let assets = flockway::run::find_assets_dir(Some(path));
            flockway::run::load_vehicle_types(&level, &name, &assets)?;
            flockway::run::load_driver_profiles(&level, &name, &assets)?;
            Ok((level, name))
        });
        match loaded {
            Ok((level, name)) => println!(
                "ok    {} ({}, {} road(s), {} vehicle type(s))",
                path.display(),
                name,
                level.roads.len(),
                level.vehicle_types.len()
            ),
            Err(e) => {
                bad += 1;
                eprintln!("error: {e}");
            }
        }
    }
    if bad == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    }
}

fn run(args: RunArgs) -> ExitCode {
    let level = match load_level(&args.level) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
    let name = level_name(&level, &args.level);
    let options = RunOptions {
        seconds: args.seconds,
        seed: args.seed,
        csv: args.csv.clone(),
        per_vehicle: args.per_vehicle.clone(),
        assets: Some(flockway::run::find_assets_dir(Some(&args.level))),
        plots: args
            .plots
            .clone()
            .map(|dir| (dir, PlotFormat::from(args.plot_format))),
    };
    let mut runner = match Runner::new(level, &name, &options) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    let total = runner.total_ticks();
    let interactive = !args.quiet && std::io::stderr().is_terminal();
    let bar = interactive.then(|| {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("{prefix} [{bar:40}] {percent:>3}% {msg} (eta {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_prefix(name.clone());
        bar
    });
    // Steps in chunks of one simulated second, so progress updates without slowing the run.
    let mut next_line = 1;
    while runner.ticks_done() < total {
        if let Err(e) = runner.step(120) {
            return fail(e);
        }
        let done = runner.ticks_done();
        if let Some(bar) = &bar {
            bar.set_position(done);
            bar.set_message(format!(
                "{:.0}/{:.0} s",
                done as f64 / 120.0,
                total as f64 / 120.0
            ));
        } else if !args.quiet && done * 10 >= next_line * total {
            eprintln!(
                "{name}: {}% ({:.1} of {:.1} simulated s)",
                done * 100 / total,
                done as f64 / 120.0,
                total as f64 / 120.0
            );
            next_line = done * 10 / total + 1;
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let report = match runner.finish() {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    if let Some(path) = &args.summary {
        let mut text = match serde_json::to_string_pretty(&report.to_json()) {
            Ok(t) => t,
            Err(e) => return fail(e),
        };
        text.push('\n');
        if let Err(e) = write_atomic(path, text.as_bytes()) {
            return fail(RunError::Level(e));
        }
    }
    if !args.quiet {
        print!("{}", report.to_text());
    }
    if report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// Loads a run's CSV and, if given, its summary JSON.
fn load_run(
    csv: &std::path::Path,
    summary: Option<&std::path::Path>,
) -> Result<(Trace, Option<serde_json::Value>), String> {
    let trace = Trace::read_csv(csv).map_err(|e| e.to_string())?;
    let summary = match summary {
        Some(path) => Some(flockway::run::read_summary(path).map_err(|e| e.to_string())?),
        None => None,
    };
    Ok((trace, summary))
}

/// Parses `WIDTHxHEIGHT` (each 200–8000 pixels).
fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected WIDTHxHEIGHT in pixels, e.g. 1600x900, found `{text}`");
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if !(200..=8000).contains(&w) || !(200..=8000).contains(&h) {
        return Err(format!("{w}x{h}: each side must be 200 to 8000 pixels"));
    }
    Ok((w, h))
}

fn plot(
    csv: &std::path::Path,
    dir: &std::path::Path,
    format: PlotFormat,
    summary: Option<&std::path::Path>,
    size: (u32, u32),
) -> ExitCode {
    let (trace, summary) = match load_run(csv, summary) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    let info = flockway::run::plot_info(csv, summary.as_ref());
    match flockway::analysis::write_plots_sized(&trace, &info, dir, format, size) {
        Ok(files) => {
            for f in files {
                println!("wrote {}", f.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

fn report(
    csv: &std::path::Path,
    out: &std::path::Path,
    summary: Option<&std::path::Path>,
) -> ExitCode {
    let (trace, summary) = match load_run(csv, summary) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    let info = flockway::run::plot_info(csv, summary.as_ref());
    let wave = flockway::run::wave_of(&trace, &info, summary.as_ref());
    match flockway::analysis::write_report(&trace, &info, summary.as_ref(), wave.as_ref(), out) {
        Ok(()) => {
            println!("wrote {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

#[cfg(feature = "window")]
fn window(level: Option<&std::path::Path>, play: bool) -> ExitCode {
    use flockway::app::{AppState, Editor};
    let editor = match level {
        Some(path) => match Editor::open(path) {
            Ok(e) => e,
            Err(e) => return fail(e),
        },
        None => Editor::new(),
    };
    let assets = flockway::run::find_assets_dir(level);
    let levels_dir = assets.parent().map(|p| p.join("levels"));
    let mut app = AppState::new(editor, assets);
    if let Some(dir) = levels_dir
        && let Ok(entries) = std::fs::read_dir(dir)
    {
        let mut shipped: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "ron"))
            .collect();
        shipped.sort();
        app.shipped = shipped;
    }
    app.recovered = flockway::app::recover(level);
    if play {
        app.play();
    }
    match flockway::app::run(app) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

#[cfg(not(feature = "window"))]
fn window(_: Option<&std::path::Path>, _: bool) -> ExitCode {
    fail("this build has no window (built without the `window` feature); use `flockway run`")
}

#[cfg(feature = "window")]
fn render(
    path: &std::path::Path,
    out: &std::path::Path,
    at: f64,
    size: (u32, u32),
    camera: CameraArg,
    seed: Option<u64>,
) -> ExitCode {
    use flockway::app::{Camera, Gpu, OFFSCREEN_FORMAT, SceneRenderer, StaticScene, VehicleFrame};
    use flockway::road::RoadNetwork;
    if !(at.is_finite() && (0.0..=flockway::run::MAX_RUN_SECONDS).contains(&at)) {
        return fail(format!(
            "--at {at}: expected simulated seconds from 0 to a week"
        ));
    }
    let level = match load_level(path) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
    let name = level_name(&level, path);
    let options = RunOptions {
        // At least one step, so the level's initial vehicles are on the road.
        seconds: Some(at.max(1.0 / 120.0)),
        seed,
        assets: Some(flockway::run::find_assets_dir(Some(path))),
        ..RunOptions::default()
    };
    let mut runner = match Runner::new(level, &name, &options) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    while runner.ticks_done() < runner.total_ticks() {
        if let Err(e) = runner.step(120) {
            return fail(e);
        }
    }
    let gpu = match Gpu::headless() {
        Ok(g) => g,
        Err(e) => return fail(e),
    };
    let scene = StaticScene::build(
        runner.sim().world().resource::<RoadNetwork>(),
        runner.level(),
    );
    let mut vehicles = VehicleFrame::default();
    vehicles.capture(runner.sim_mut().world_mut());
    let mut renderer = SceneRenderer::new(&gpu.device, OFFSCREEN_FORMAT);
    renderer.set_static(&gpu.device, &scene);
    renderer.set_vehicles(&gpu.device, &gpu.queue, &vehicles.instances);
    let aspect = size.0 as f32 / size.1 as f32;
    let cam = match camera {
        CameraArg::Top => Camera::top_fit(scene.min, scene.max, aspect),
        CameraArg::Orbit => Camera::orbit_fit(scene.min, scene.max),
    };
    let image = match flockway::app::render_image(&gpu, &renderer, &cam, size) {
        Ok(i) => i,
        Err(e) => return fail(e),
    };
    if let Err(e) = image.save_png(out) {
        return fail(e);
    }
    println!(
        "wrote {} ({}×{}, {} vehicles at {:.2} s, {})",
        out.display(),
        size.0,
        size.1,
        vehicles.instances.len(),
        runner.ticks_done() as f64 / 120.0,
        gpu.describe()
    );
    ExitCode::SUCCESS
}

#[cfg(not(feature = "window"))]
fn render(
    _: &std::path::Path,
    _: &std::path::Path,
    _: f64,
    _: (u32, u32),
    _: CameraArg,
    _: Option<u64>,
) -> ExitCode {
    fail("this build has no renderer (built without the `window` feature); use `flockway run`")
}

fn dyno(vehicle: Option<&std::path::Path>, json: bool) -> ExitCode {
    let params = match vehicle {
        Some(path) => match VehicleParams::load(path) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        },
        None => VehicleParams::default(),
    };
    let name = params.name.clone();
    let model = Arc::new(VehicleType::new(params));
    let report = run_dyno(&model, &DynoSettings::default());
    if json {
        match serde_json::to_string_pretty(&report) {
            Ok(text) => println!("{text}"),
            Err(e) => return fail(e),
        }
    } else {
        print!("{}", dyno_table(&name, &report));
    }
    ExitCode::SUCCESS
}

fn dyno_table(name: &str, r: &DynoReport) -> String {
    let t100 = r
        .zero_to_100_kmh_s
        .map_or("not reached".to_owned(), |t| format!("{t:.2} s"));
    format!(
        "dyno: {name}\n\
         \x20 0-100 km/h          {t100}\n\
         \x20 top speed           {:.1} km/h\n\
         \x20 braking 100-0 km/h  {:.1} m\n\
         \x20 max lateral         {:.3} g  (50 m circle)\n\
         \x20 standstill drift    {:.4} m  (60 s, no input)\n",
        r.top_speed_kmh, r.braking_100_0_m, r.max_lateral_g, r.standstill_drift_m
    )
}

/// One run of `flockway test`: a level and a seed.
struct TestRun {
    path: PathBuf,
    seed: Option<u64>,
}

fn test(
    paths: &[PathBuf],
    seeds: Option<u64>,
    seed_list: Option<Vec<u64>>,
    seconds: Option<f64>,
    jobs: Option<usize>,
) -> ExitCode {
    let mut files = Vec::new();
    for p in paths {
        if p.is_dir() {
            match std::fs::read_dir(p) {
                Ok(entries) => {
                    let mut found: Vec<PathBuf> = entries
                        .filter_map(|e| e.ok().map(|e| e.path()))
                        .filter(|f| f.extension().is_some_and(|x| x == "ron"))
                        .collect();
                    found.sort();
                    files.extend(found);
                }
                Err(e) => return fail(format!("{}: {e}", p.display())),
            }
        } else {
            files.push(p.clone());
        }
    }
    if files.is_empty() {
        return fail("no level files found");
    }
    let mut runs = Vec::new();
    for f in &files {
        let level = match load_level(f) {
            Ok(l) => l,
            Err(e) => return fail(e),
        };
        let list: Vec<Option<u64>> = match (&seed_list, seeds) {
            (Some(list), _) => list.iter().map(|s| Some(*s)).collect(),
            (None, Some(n)) => (0..n.max(1))
                .map(|k| Some(level.seed.wrapping_add(k)))
                .collect(),
            (None, None) => vec![None],
        };
        runs.extend(list.into_iter().map(|seed| TestRun {
            path: f.clone(),
            seed,
        }));
    }
    let workers = jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .clamp(1, runs.len());
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: std::sync::Mutex<Vec<(usize, Result<flockway::run::RunReport, String>)>> =
        std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(run) = runs.get(i) else { break };
                    let outcome = run_one(run, seconds);
                    match &outcome {
                        Ok(r) => println!(
                            "{} {} seed {} ({:.0} s simulated in {:.1} s)",
                            if r.passed { "PASS" } else { "FAIL" },
                            run.path.display(),
                            r.seed,
                            r.sim_seconds,
                            r.wall_seconds
                        ),
                        Err(e) => println!("ERROR {}: {e}", run.path.display()),
                    }
                    if let Ok(mut all) = results.lock() {
                        all.push((i, outcome));
                    }
                }
            });
        }
    });
    let mut results = results.into_inner().unwrap_or_default();
    results.sort_by_key(|(i, _)| *i);
    let (mut passed, mut failed, mut errors) = (0, 0, 0);
    for (i, r) in &results {
        match r {
            Ok(report) if report.passed => passed += 1,
            Ok(report) => {
                failed += 1;
                for e in report.expectations.iter().filter(|e| !e.passed) {
                    let value = e
                        .value
                        .map_or("not measured".to_owned(), |v| format!("{v:.3}"));
                    println!(
                        "  {} seed {}: {} (measured {value})",
                        runs[*i].path.display(),
                        report.seed,
                        e.name
                    );
                }
            }
            Err(_) => errors += 1,
        }
    }
    println!("{passed} passed, {} failed", failed + errors);
    if errors > 0 {
        ExitCode::from(2)
    } else if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

fn run_one(run: &TestRun, seconds: Option<f64>) -> Result<flockway::run::RunReport, String> {
    let level = load_level(&run.path).map_err(|e| e.to_string())?;
    let name = level_name(&level, &run.path);
    let options = RunOptions {
        seconds,
        seed: run.seed,
        assets: Some(flockway::run::find_assets_dir(Some(&run.path))),
        ..RunOptions::default()
    };
    let runner = Runner::new(level, &name, &options).map_err(|e| e.to_string())?;
    runner.finish().map_err(|e| e.to_string())
}
