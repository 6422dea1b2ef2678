//! The documentation and the code agree: the contract tables in `docs/` list exactly what the
//! one definition of each contract holds, and every link between the pages leads somewhere.

use flockway::analysis::{CSV_COLUMNS, Summary};
use flockway::level::Metric;
use std::path::{Path, PathBuf};

fn read(path: &str) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The first cells (between backticks) of the table rows under `heading`, up to the next heading.
fn table_keys(text: &str, heading: &str) -> Vec<String> {
    let start = text
        .find(heading)
        .unwrap_or_else(|| panic!("no heading `{heading}`"));
    let body = &text[start + heading.len()..];
    let end = body.find("\n#").unwrap_or(body.len());
    body[..end]
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split('`').next())
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_summary_table_lists_the_summary_type_s_keys_in_file_order() {
    let keys = table_keys(&read("docs/cli.md"), "## The summary JSON");
    assert_eq!(keys, Summary::keys());
}

#[test]
fn the_signals_table_lists_the_signals_csv_columns_in_order() {
    let keys = table_keys(&read("docs/cli.md"), "## The signals CSV");
    assert_eq!(keys, flockway::run::telemetry::SIGNAL_COLUMNS);
}

#[test]
fn the_detectors_table_lists_the_detectors_csv_columns_in_order() {
    let keys = table_keys(&read("docs/cli.md"), "## The detectors CSV");
    assert_eq!(keys, flockway::run::DETECTOR_COLUMNS);
}

#[test]
fn the_conflicts_table_lists_the_conflicts_csv_columns_in_order() {
    let keys = table_keys(&read("docs/cli.md"), "## The conflicts CSV");
    assert_eq!(keys, flockway::run::CONFLICT_COLUMNS);
}

#[test]
fn the_csv_table_lists_the_telemetry_columns_in_order() {
    let keys = table_keys(&read("docs/cli.md"), "## The telemetry CSV");
    assert_eq!(keys, CSV_COLUMNS);
}

#[test]
fn the_metric_table_lists_every_metric_with_its_unit() {
    let text = read("docs/levels.md");
    let keys = table_keys(&text, "## Metrics");
    let names: Vec<&str> = Metric::ALL.iter().map(|m| m.name()).collect();
    assert_eq!(keys, names);
    for m in Metric::ALL {
        let info = m.info();
        let row = format!("| `{}` |", info.name);
        let line = text
            .lines()
            .find(|l| l.starts_with(&row))
            .unwrap_or_default();
        assert!(
            line.contains(&format!("| {} | {} |", info.unit, info.description)),
            "{}: the table says `{line}`",
            info.name
        );
    }
}

fn markdown_files() -> Vec<PathBuf> {
    let mut files = vec![PathBuf::from("README.md"), PathBuf::from("CHANGELOG.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir("docs")
        .expect("docs/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    files
}

#[test]
fn every_relative_link_in_the_docs_leads_to_a_file() {
    for file in markdown_files() {
        let text = read(&file.to_string_lossy());
        let dir = file.parent().unwrap_or(Path::new("."));
        for (i, _) in text.match_indices("](") {
            let rest = &text[i + 2..];
            let Some(end) = rest.find(')') else { continue };
            let target = &rest[..end];
            if target.starts_with("http") || target.starts_with('#') || target.contains(' ') {
                continue;
            }
            let path = target.split('#').next().unwrap_or_default();
            assert!(
                dir.join(path).exists(),
                "{}: the link `{target}` leads nowhere",
                file.display()
            );
        }
    }
}

#[test]
fn the_edit_script_in_the_levels_page_applies_to_the_level_it_names() {
    let text = read("docs/levels.md");
    let section = &text[text.find("## Editing from scripts").expect("section")..];
    let start = section.find("```ron\n").expect("a RON block") + "```ron\n".len();
    let block = &section[start..start + section[start..].find("```").expect("closed")];
    let dir = tempfile::tempdir().expect("tempdir");
    let script = dir.path().join("edits.ron");
    std::fs::write(&script, block).expect("write");
    let mut editor = flockway::edit::Editor::open(Path::new("levels/crossroads_signal.ron"))
        .expect("the level the example edits");
    let applied = flockway::edit::apply_script(&mut editor, &script)
        .unwrap_or_else(|e| panic!("the documented script applies: {e}"));
    assert_eq!(applied, 4);
    let level = editor.level();
    assert_eq!(level.road("west in").expect("road").lanes, 2);
    assert_eq!(level.seed, 7);
    assert!(flockway::level::validate(level).is_empty());
}
