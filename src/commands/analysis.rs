//! `flockway plot` and `flockway report`: a run's CSV (and summary) turned into plots and a
//! self-contained HTML report.

use super::fail;
use flockway::analysis::{PlotFormat, Summary, Trace};
use std::process::ExitCode;

/// Loads a run's CSV and, if given, its summary JSON.
fn load_run(
    csv: &std::path::Path,
    summary: Option<&std::path::Path>,
) -> Result<(Trace, Option<Summary>), String> {
    let trace = Trace::read_csv(csv).map_err(|e| e.to_string())?;
    let summary = match summary {
        Some(path) => Some(Summary::read(path).map_err(|e| e.to_string())?),
        None => None,
    };
    Ok((trace, summary))
}

/// `flockway plot`.
pub fn plot(
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
    let info = flockway::analysis::plot_info(csv, summary.as_ref());
    match flockway::analysis::write_plots_sized(&trace, &info, dir, format, size) {
        Ok(files) => {
            for f in files {
                outln!("wrote {}", f.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

/// `flockway report`.
pub fn report(
    csv: &std::path::Path,
    out: &std::path::Path,
    summary: Option<&std::path::Path>,
) -> ExitCode {
    let (trace, summary) = match load_run(csv, summary) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    let info = flockway::analysis::plot_info(csv, summary.as_ref());
    let wave = flockway::analysis::wave_of(&trace, &info, summary.as_ref());
    match flockway::analysis::write_report(&trace, &info, summary.as_ref(), wave.as_ref(), out) {
        Ok(()) => {
            outln!("wrote {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}
