//! `flockway import`: a SUMO network as a level.

use super::fail;
use flockway::level::{import_sumo_net, level_to_string, write_atomic};
use std::io::Read;
use std::path::Path;
use std::process::ExitCode;

/// Largest network file read, bytes (a city's net is tens of MB).
const MAX_NET_BYTES: u64 = 512 * 1024 * 1024;

pub fn import(net: &Path, output: &Path) -> ExitCode {
    if output.exists() {
        return fail(format!(
            "{} already exists; `flockway import` never overwrites a file: choose another name",
            output.display()
        ));
    }
    match std::fs::metadata(net) {
        Ok(m) if m.len() > MAX_NET_BYTES => {
            return fail(format!(
                "{}: {} bytes is too large a network (the limit is 512 MiB)",
                net.display(),
                m.len()
            ));
        }
        Err(e) => return fail(format!("{}: {e}", net.display())),
        Ok(_) => {}
    }
    let text = match read_net(net) {
        Ok(t) => t,
        Err(e) => return fail(format!("{}: {e}", net.display())),
    };
    let name = output.file_stem().map_or_else(
        || "imported".to_owned(),
        |s| s.to_string_lossy().into_owned(),
    );
    let level = match import_sumo_net(&text, net, &name) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
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
    println!(
        "wrote {} ({} roads, {} junctions, {} spawners, {} destroyers)",
        output.display(),
        level.roads.len(),
        level.junctions.len(),
        level.spawners.len(),
        level.destroyers.len()
    );
    println!("run it:   flockway run {}", output.display());
    ExitCode::SUCCESS
}

/// The network's text: the file as it is, or unpacked when it is gzip-compressed (netconvert
/// writes `.net.xml.gz` when asked for that name), at most [`MAX_NET_BYTES`] either way.
fn read_net(net: &Path) -> Result<String, String> {
    let bytes = std::fs::read(net).map_err(|e| e.to_string())?;
    if !bytes.starts_with(&[0x1f, 0x8b]) {
        return String::from_utf8(bytes).map_err(|e| format!("not UTF-8 text: {e}"));
    }
    let mut text = String::new();
    flate2::read::GzDecoder::new(bytes.as_slice())
        .take(MAX_NET_BYTES + 1)
        .read_to_string(&mut text)
        .map_err(|e| format!("a gzip-compressed file that does not unpack to UTF-8 text: {e}"))?;
    if text.len() as u64 > MAX_NET_BYTES {
        return Err("unpacks to more than 512 MiB, too large a network".to_owned());
    }
    Ok(text)
}
