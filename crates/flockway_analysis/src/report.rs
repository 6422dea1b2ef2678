//! The run report: one self-contained HTML file with the summary, expectations and plots.

use crate::{
    AnalysisError, PLOT_NAMES, PLOT_SIZE, PlotFormat, PlotInfo, Summary, Trace, Wave, render_plot,
};
use base64::Engine;
use serde_json::Value;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// Writes `out` (atomically): the run's summary (`summary`, the JSON of `flockway run
/// --summary`, if given), its expectations and their results, figures measured from the trace
/// (vehicles, speeds per driver profile, the stop-and-go wave), and every plot embedded as PNG.
/// The file needs no network and no other file.
pub fn write_report(
    trace: &Trace,
    info: &PlotInfo,
    summary: Option<&Summary>,
    wave: Option<&Wave>,
    out: &Path,
) -> Result<(), AnalysisError> {
    let dir = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let io = |path: &Path, source| AnalysisError::Io {
        path: path.to_owned(),
        source,
    };
    let scratch = tempfile::tempdir_in(dir).map_err(|e| io(dir, e))?;
    let mut plots = Vec::new();
    for name in PLOT_NAMES {
        let path = scratch.path().join(format!("{name}.png"));
        if render_plot(name, trace, info, &path, PlotFormat::Png, PLOT_SIZE)? {
            let bytes = std::fs::read(&path).map_err(|e| io(&path, e))?;
            plots.push((
                name,
                base64::engine::general_purpose::STANDARD.encode(bytes),
            ));
        }
    }
    let html = render_html(trace, info, summary, wave, &plots);
    let mut file = tempfile::NamedTempFile::new_in(dir).map_err(|e| io(dir, e))?;
    file.write_all(html.as_bytes()).map_err(|e| io(out, e))?;
    file.as_file().sync_all().map_err(|e| io(out, e))?;
    file.persist(out).map_err(|e| io(out, e.error))?;
    Ok(())
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn number(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        format!("{v:.3}")
    }
}

fn json_cell(v: &Value) -> String {
    match v {
        Value::Null => "—".to_owned(),
        Value::Number(n) => n.as_f64().map_or_else(|| n.to_string(), number),
        Value::String(s) => escape(s),
        Value::Bool(b) => b.to_string(),
        other => escape(&other.to_string()),
    }
}

/// A measured value as a cell: "—" where there is none (or it is not finite).
fn value_cell(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite())
        .map_or_else(|| "—".to_owned(), number)
}

fn render_html(
    trace: &Trace,
    info: &PlotInfo,
    summary: Option<&Summary>,
    wave: Option<&Wave>,
    plots: &[(&str, String)],
) -> String {
    let title = match info.seed {
        Some(seed) => format!("{} · seed {seed}", info.level),
        None => info.level.clone(),
    };
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>Flockway run report: {t}</title>\n<style>\n\
         body {{ font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }}\n\
         table {{ border-collapse: collapse; margin: 1em 0; }}\n\
         th, td {{ border: 1px solid #ccc; padding: 0.3em 0.8em; text-align: left; }}\n\
         td.num {{ text-align: right; font-variant-numeric: tabular-nums; }}\n\
         .pass {{ color: #1a7f37; font-weight: bold; }} .fail {{ color: #cf222e; font-weight: bold; }}\n\
         img {{ width: 100%; border: 1px solid #ddd; margin: 0.5em 0 1.5em; }}\n\
         </style>\n</head>\n<body>\n<h1>Flockway run report: {t}</h1>\n",
        t = escape(&title)
    );

    match summary {
        Some(summary) => {
            let verdict = if summary.passed {
                "<span class=\"pass\">all expectations held</span>"
            } else {
                "<span class=\"fail\">an expectation failed</span>"
            };
            let _ = writeln!(h, "<p>Verdict: {verdict}.</p>");
            h.push_str("<h2>Summary</h2>\n<table>\n<tr><th>key</th><th>value</th></tr>\n");
            // The table lists the summary's keys as the file has them.
            if let Ok(Value::Object(obj)) = serde_json::to_value(summary) {
                for (k, v) in &obj {
                    if matches!(k.as_str(), "expectations" | "metrics") {
                        continue;
                    }
                    if let Value::Object(inner) = v {
                        for (name, x) in inner {
                            let _ = writeln!(
                                h,
                                "<tr><td>{}.{}</td><td class=\"num\">{}</td></tr>",
                                escape(k),
                                escape(name),
                                json_cell(x)
                            );
                        }
                    } else {
                        let _ = writeln!(
                            h,
                            "<tr><td>{}</td><td class=\"num\">{}</td></tr>",
                            escape(k),
                            json_cell(v)
                        );
                    }
                }
            }
            h.push_str("</table>\n<h2>Expectations</h2>\n");
            match summary.expectations.as_slice() {
                [] => h.push_str("<p>The level states no expectations.</p>\n"),
                list => {
                    h.push_str(
                        "<table>\n<tr><th>result</th><th>expectation</th><th>measured</th></tr>\n",
                    );
                    for e in list {
                        let ok = e.passed;
                        let _ = writeln!(
                            h,
                            "<tr><td class=\"{}\">{}</td><td><code>{}</code></td><td class=\"num\">{}</td></tr>",
                            if ok { "pass" } else { "fail" },
                            if ok { "PASS" } else { "FAIL" },
                            escape(&e.name),
                            value_cell(e.value),
                        );
                    }
                    h.push_str("</table>\n");
                }
            }
            h.push_str("<h2>Every metric</h2>\n<table>\n<tr><th>metric</th><th>value</th></tr>\n");
            for (k, v) in &summary.metrics {
                let _ = writeln!(
                    h,
                    "<tr><td>{}</td><td class=\"num\">{}</td></tr>",
                    escape(k),
                    value_cell(Some(*v))
                );
            }
            h.push_str("</table>\n");
        }
        None => h.push_str(
            "<p>No run summary was given (<code>flockway report RUN.csv --summary \
             SUMMARY.json</code> adds it): the expectations and their results are not shown.</p>\n",
        ),
    }

    h.push_str(
        "<h2>Measured from the telemetry</h2>\n<table>\n<tr><th>quantity</th><th>value</th></tr>\n",
    );
    let vehicles = trace.by_vehicle();
    let row = |h: &mut String, k: &str, v: String| {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{}</td></tr>",
            escape(k),
            v
        );
    };
    row(&mut h, "samples", trace.samples().len().to_string());
    row(&mut h, "vehicles seen", vehicles.len().to_string());
    row(&mut h, "last sample time (s)", number(trace.end_s()));
    for (d, name) in trace.drivers().iter().enumerate() {
        let speeds: Vec<f64> = trace
            .samples()
            .iter()
            .filter(|s| usize::from(s.driver) == d)
            .map(|s| s.speed_kmh)
            .collect();
        let n = speeds.len() as f64;
        let mean = speeds.iter().sum::<f64>() / n;
        let std = (speeds.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
        row(
            &mut h,
            &format!("speed of `{name}` over all samples (km/h)"),
            format!("{} ± {}", number(mean), number(std)),
        );
    }
    match wave {
        Some(w) => {
            row(&mut h, "wave measured on road", escape(&w.road));
            row(&mut h, "wave_detected", w.detected.to_string());
            row(
                &mut h,
                "wave_speed_kmh",
                w.speed_kmh().map_or("—".to_owned(), number),
            );
            row(
                &mut h,
                "wave_period_s",
                w.period_s().map_or("—".to_owned(), number),
            );
            row(
                &mut h,
                "speed pattern amplitude (km/h, rms)",
                number(w.amplitude_kmh),
            );
            row(
                &mut h,
                "pattern correlation at its best speed",
                format!(
                    "{} at {} km/h",
                    number(w.correlation),
                    number(w.best_speed_kmh)
                ),
            );
        }
        None => row(
            &mut h,
            "wave",
            "not measured (no road shared by two vehicles)".to_owned(),
        ),
    }
    h.push_str("</table>\n<h2>Plots</h2>\n");
    for (name, data) in plots {
        let _ = writeln!(
            h,
            "<h3>{}</h3>\n<img alt=\"{}\" src=\"data:image/png;base64,{}\">",
            name.replace('_', " "),
            name,
            data
        );
    }
    h.push_str("<p>Made by Flockway.</p>\n</body>\n</html>\n");
    h
}
