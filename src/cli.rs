//! The command line: every command, option and help text (clap). `main.rs` dispatches them to
//! `commands`.

use clap::{Args, Parser, Subcommand};
use flockway::analysis::PlotFormat;
use flockway::level::Template;
use std::path::PathBuf;

/// Flockway: a deterministic traffic sandbox with rigid-body cars and flocking drivers.
///
/// Levels are RON files (see levels/ for examples). Every run with the same level and seed gives
/// the same results, byte for byte.
#[derive(Parser)]
#[command(name = "flockway", version, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
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
    /// Turn a SUMO network (`.net.xml`, as netconvert writes it) into a level that runs.
    ///
    /// Edges become roads (lanes, widths, shapes, speed limits), junctions keep their
    /// connections and right of way, traffic lights their fixed-time programs; a spawner on each
    /// lane of every edge nothing leads onto sends cars to every edge that leads nowhere, where a
    /// destroyer takes them. Never overwrites a file. Exit status: 0, or 2 if the network cannot
    /// be read (FILE:LINE:COLUMN: what was expected) or the level cannot be written.
    Import {
        /// The SUMO network file (`.net.xml`, or gzip-compressed `.net.xml.gz`).
        #[arg(value_name = "NET.net.xml")]
        net: PathBuf,
        /// The level file to write.
        #[arg(short, long, value_name = "LEVEL.ron")]
        output: PathBuf,
        /// SUMO demand to run on it (`.rou.xml`, plain or gzip-compressed; several separated
        /// by commas or given again, read in order): its vehicles, trips and flows leave at
        /// their times on their routes, in place of the spawners at the network's edges.
        #[arg(long, value_name = "A.rou.xml[,B.rou.xml]", value_delimiter = ',')]
        routes: Vec<PathBuf>,
    },
    /// Run a level and the SUMO scenario it was imported from side by side, and compare them:
    /// vehicles departed and arrived, mean travel time, trip speed and time lost, per route
    /// (departure edge → arrival edge), per fringe edge, and each edge's vehicle count by the GEH
    /// statistic.
    ///
    /// Both run for the same simulated time with the same seed. SUMO is `--sumo-bin`,
    /// `$SUMO_HOME/bin/sumo` or `sumo` on the PATH (`python3 -m pip install eclipse-sumo`).
    /// Exit status: 0 if the scenario matches (departed and arrived within 5 %, mean travel time
    /// within 25 %, GEH < 5 on at least 85 % of edge counts), 1 if not, 2 if an input is invalid
    /// or SUMO fails.
    Compare {
        /// The level (as `flockway import NET --routes ROUTES` wrote it).
        #[arg(value_name = "LEVEL.ron")]
        level: PathBuf,
        /// The SUMO configuration to run (its network, demand and options).
        #[arg(long, value_name = "SCENARIO.sumocfg", required_unless_present = "net", conflicts_with_all = ["net", "routes"])]
        sumo: Option<PathBuf>,
        /// The SUMO network to run (with --routes), instead of a configuration.
        #[arg(long, value_name = "NET.net.xml", requires = "routes")]
        net: Option<PathBuf>,
        /// The demand to run on --net (several separated by commas or given again).
        #[arg(
            long,
            value_name = "A.rou.xml[,B.rou.xml]",
            value_delimiter = ',',
            requires = "net"
        )]
        routes: Vec<PathBuf>,
        /// Simulated seconds to run both for (default: the level's duration).
        #[arg(long, value_name = "S")]
        seconds: Option<f64>,
        /// Seed for both (default: the level's).
        #[arg(long, value_name = "N")]
        seed: Option<u64>,
        /// SUMO's `sumo` program, or the directory it is in.
        #[arg(long, value_name = "PATH")]
        sumo_bin: Option<PathBuf>,
        /// Print one JSON object (keys seconds, totals, routes, fringe, edges, geh_match_share,
        /// verdict) instead of tables.
        #[arg(long)]
        json: bool,
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
        /// Also write every run's summary (the `run --summary` JSON) to this file, a line per
        /// run in the order the runs are listed (levels, then seeds); never overwritten by half.
        #[arg(long, value_name = "FILE.jsonl")]
        summaries: Option<PathBuf>,
        /// Drive a driver profile with a built-in model (its default parameters) instead of the
        /// level's: how a challenge's custom profile is run with a built-in driver. Repeatable.
        #[arg(long = "driver", value_name = "PROFILE=MODEL", value_parser = flockway::run::parse_driver)]
        drivers: Vec<(String, flockway::drivers::BuiltinModel)>,
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
    /// runs with destroyers, fundamental_diagram; with the summary of a run with priority
    /// junctions, capacity.
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
    /// Open the editor on a level (a new empty level without one), or with `--apply` edit it
    /// headless with a script of edits.
    ///
    /// The window needs a display; `--apply` does not. Exit status with `--apply`: 0 when every
    /// edit was applied and the level saved; 2 when the script or the level is invalid or an
    /// edit is refused (the message gives the edit's number and line:col; nothing is written).
    Edit {
        /// The level file.
        #[arg(value_name = "LEVEL")]
        level: Option<PathBuf>,
        /// Apply the edits in this file (a RON list of editor commands, e.g.
        /// `[SetRoad(road: 0, name: "main", lanes: 3, lane_width_m: 3.5, speed_limit_kmh: 80)]`),
        /// all or none, each checked as the editor checks it, and save the level.
        #[arg(long, value_name = "EDITS.ron", requires = "level")]
        apply: Option<PathBuf>,
        /// With `--apply`: write the edited level here instead of over LEVEL.
        #[arg(long, short, value_name = "OUT.ron", requires = "apply")]
        output: Option<PathBuf>,
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
        /// Only this part of the level in view: the ground box from (X0, Y0) to (X1, Y1), in
        /// the level's metres (e.g. `1100,-60,1600,20` for the merge of on_ramp.ron).
        #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = parse_region, allow_hyphen_values = true)]
        region: Option<[f64; 4]>,
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
pub enum TemplateArg {
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
pub enum CameraArg {
    /// Straight down, the whole level in view.
    Top,
    /// Perspective from the south-west, the whole level in view.
    Orbit,
}

#[cfg(feature = "window")]
impl From<CameraArg> for flockway::app::View {
    fn from(c: CameraArg) -> flockway::app::View {
        match c {
            CameraArg::Top => flockway::app::View::Top,
            CameraArg::Orbit => flockway::app::View::Orbit,
        }
    }
}

/// Plot image format on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Format {
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
pub struct RunArgs {
    /// The level file to run (e.g. levels/dense_road.ron).
    #[arg(value_name = "LEVEL")]
    pub level: PathBuf,
    /// Simulated seconds to run, instead of the level's duration_s.
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// Seed for every random stream, instead of the level's seed.
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
    /// Stream per-vehicle telemetry to this CSV file as the run goes.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Also write one telemetry CSV per vehicle into this directory (vehicle_NNNNNN.csv).
    #[arg(long, value_name = "DIR")]
    pub per_vehicle: Option<PathBuf>,
    /// Stream one row per traffic conflict (time to collision, post-encroachment time,
    /// deceleration to avoid the crash; thresholds in the level's `ssm`) to this CSV file.
    #[arg(long, value_name = "FILE")]
    pub conflicts: Option<PathBuf>,
    /// Write the run summary as JSON to this file (keys documented in the README).
    #[arg(long, value_name = "FILE")]
    pub summary: Option<PathBuf>,
    /// Write the run's plots into this directory at the end (see `flockway plot`).
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Image format of --plots.
    #[arg(long, value_enum, default_value_t = Format::Png, requires = "plots")]
    pub plot_format: Format,
    /// Drive a driver profile with a built-in model (its default parameters) instead of the
    /// level's, e.g. `controller=WaveDamper` on a challenge. Repeatable.
    #[arg(long = "driver", value_name = "PROFILE=MODEL", value_parser = flockway::run::parse_driver)]
    pub drivers: Vec<(String, flockway::drivers::BuiltinModel)>,
    /// Every driver decides every S seconds (a whole number of 1/120 s ticks up to 1 s; 0:
    /// every tick), holding its target in between, instead of each profile's `action_step_s`.
    #[arg(long, value_name = "S")]
    pub action_step: Option<f32>,
    /// Print nothing but errors; the exit status tells the outcome.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Parses `X0,Y0,X1,Y1`: a ground box in metres, X1 > X0 and Y1 > Y0, at least 1 m each way.
pub fn parse_region(text: &str) -> Result<[f64; 4], String> {
    let bad = || format!("expected X0,Y0,X1,Y1 in metres, e.g. 1100,-60,1600,20, found `{text}`");
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    let [x0, y0, x1, y1] = v[..] else {
        return Err(bad());
    };
    if !v.iter().all(|x| x.is_finite() && x.abs() <= 1e7) {
        return Err(bad());
    }
    if x1 < x0 + 1.0 || y1 < y0 + 1.0 {
        return Err(format!(
            "{text}: the box needs X1 > X0 and Y1 > Y0, at least 1 m each way"
        ));
    }
    Ok([x0, y0, x1, y1])
}

/// Parses `WIDTHxHEIGHT` (each 200–8000 pixels).
pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected WIDTHxHEIGHT in pixels, e.g. 1600x900, found `{text}`");
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if !(200..=8000).contains(&w) || !(200..=8000).contains(&h) {
        return Err(format!("{w}x{h}: each side must be 200 to 8000 pixels"));
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_region_is_a_ground_box_with_its_corners_in_order() {
        assert_eq!(
            parse_region("1100,-30,1500,20"),
            Ok([1100.0, -30.0, 1500.0, 20.0])
        );
        assert_eq!(parse_region(" 0 , 0 , 1 , 1 "), Ok([0.0, 0.0, 1.0, 1.0]));
        for bad in [
            "",
            "1,2,3",
            "1,2,3,4,5",
            "a,0,1,1",
            "0,0,inf,1",
            "NaN,0,1,1",
        ] {
            let e = parse_region(bad).expect_err(bad);
            assert!(e.contains("expected X0,Y0,X1,Y1"), "{bad}: {e}");
        }
        let e = parse_region("10,0,5,5").expect_err("backwards");
        assert!(e.contains("X1 > X0"), "{e}");
        assert!(parse_region("0,0,0.5,10").is_err());
    }

    #[test]
    fn a_size_is_two_sides_in_pixels() {
        assert_eq!(parse_size("1600x900"), Ok((1600, 900)));
        assert!(parse_size("100x900").is_err());
        assert!(parse_size("1600").is_err());
    }
}
