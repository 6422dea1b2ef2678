//! `flockway import`: a SUMO network as a level.

use super::fail;
use flockway::level::{import_sumo, level_to_string, write_atomic};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Largest network file read, bytes (a city's net is tens of MB).
const MAX_NET_BYTES: u64 = 512 * 1024 * 1024;

pub fn import(net: &Path, output: &Path, routes: &[PathBuf]) -> ExitCode {
    if output.exists() {
        return fail(format!(
            "{} already exists; `flockway import` never overwrites a file: choose another name",
            output.display()
        ));
    }
    let text = match read_input(net, "network") {
        Ok(t) => t,
        Err(e) => return fail(e),
    };
    let name = output.file_stem().map_or_else(
        || "imported".to_owned(),
        |s| s.to_string_lossy().into_owned(),
    );
    let mut demand = Vec::with_capacity(routes.len());
    for path in routes {
        match read_input(path, "demand file") {
            Ok(t) => demand.push((path.clone(), t)),
            Err(e) => return fail(e),
        }
    }
    let (level, report) = match import_sumo(&text, net, &name, &demand) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
    if !report.skipped.is_empty() {
        let counts: Vec<String> = report
            .skipped
            .iter()
            .map(|(class, n)| format!("{n} {class}"))
            .collect();
        eprintln!(
            "warning: left out what the sedan does not stand for: {}",
            counts.join(", ")
        );
    }
    let body = match level_to_string(&level) {
        Ok(t) => t,
        Err(e) => return fail(e),
    };
    let header = format!(
        "// {name}: imported by `flockway import` from {}.\n",
        net.file_name().map_or_else(
            || net.display().to_string(),
            |n| n.to_string_lossy().into_owned()
        )
    );
    if let Err(e) = write_atomic(output, format!("{header}{body}").as_bytes()) {
        return fail(e);
    }
    outln!(
        "wrote {} ({} roads, {} junctions, {} spawners, {} destroyers)",
        output.display(),
        level.roads.len(),
        level.junctions.len(),
        level.spawners.len(),
        level.destroyers.len()
    );
    if !demand.is_empty() {
        outln!(
            "demand: {} vehicles in timetables, {} driver profiles, {} s to run",
            report.vehicles,
            level.driver_profiles.len(),
            level.duration_s
        );
    }
    outln!("run it:   flockway run {}", output.display());
    ExitCode::SUCCESS
}

/// The text of the input file `path` (a `kind` of file, for errors): at most
/// [`MAX_NET_BYTES`] on disk, unpacked by [`read_net`]; the error names the file.
fn read_input(path: &Path, kind: &str) -> Result<String, String> {
    match std::fs::metadata(path) {
        Ok(m) if m.len() > MAX_NET_BYTES => {
            return Err(format!(
                "{}: {} bytes is too large a {kind} (the limit is 512 MiB)",
                path.display(),
                m.len()
            ));
        }
        Err(e) => return Err(format!("{}: {e}", path.display())),
        Ok(_) => {}
    }
    read_net(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The network's text: the file as it is, or unpacked when it is gzip-compressed (netconvert
/// writes `.net.xml.gz` when asked for that name; netedit writes several gzip members one after
/// another, all read), at most [`MAX_NET_BYTES`] either way.
fn read_net(net: &Path) -> Result<String, String> {
    let bytes = std::fs::read(net).map_err(|e| e.to_string())?;
    if !bytes.starts_with(&[0x1f, 0x8b]) {
        return String::from_utf8(bytes).map_err(|e| format!("not UTF-8 text: {e}"));
    }
    let mut text = String::new();
    flate2::read::MultiGzDecoder::new(bytes.as_slice())
        .take(MAX_NET_BYTES + 1)
        .read_to_string(&mut text)
        .map_err(|e| format!("a gzip-compressed file that does not unpack to UTF-8 text: {e}"))?;
    if text.len() as u64 > MAX_NET_BYTES {
        return Err("unpacks to more than 512 MiB, too large a network".to_owned());
    }
    Ok(text)
}
