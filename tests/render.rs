//! The off-screen renderer, end to end: `flockway render` on a shipped level, compared with a
//! checked-in picture. Runs on Mesa's software Vulkan (lavapipe) in CI; a machine without any
//! graphics adapter fails here rather than skipping.
//!
//! To accept a deliberate change of the picture, run once with `FLOCKWAY_BLESS=1`: it rewrites
//! the reference and then fails, so it can never be left on.
#![cfg(feature = "window")]

use std::path::Path;
use std::process::Command;

fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("a frame");
    assert_eq!(info.color_type, png::ColorType::Rgba, "{}", path.display());
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

fn render(level: &str, out: &Path, extra: &[&str]) {
    let result = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(["render", level, "-o"])
        .arg(out)
        .args(extra)
        .output()
        .expect("flockway runs");
    assert!(
        result.status.success(),
        "flockway render failed (is a Vulkan or GL driver installed? CI installs \
         mesa-vulkan-drivers):\n{}",
        String::from_utf8_lossy(&result.stderr)
    );
}

#[test]
fn a_shipped_level_renders_as_its_reference_picture() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bless = std::env::var_os("FLOCKWAY_BLESS").is_some();
    for (name, level, args) in [
        (
            "sugiyama_ring_orbit",
            "levels/sugiyama_ring.ron",
            &["--at", "30", "--size", "480x270", "--camera", "orbit"][..],
        ),
        (
            "speed_limit_change_top",
            "levels/speed_limit_change.ron",
            &["--at", "20", "--size", "480x270", "--camera", "top"][..],
        ),
    ] {
        let out = dir.path().join(format!("{name}.png"));
        render(level, &out, args);
        let reference = Path::new("tests/golden").join(format!("{name}.png"));
        if bless {
            std::fs::copy(&out, &reference).expect("write the reference");
            continue;
        }
        let (w, h, got) = read_png(&out);
        let (rw, rh, want) = read_png(&reference);
        assert_eq!((w, h), (rw, rh), "{name}: size");
        // Software rasterisers may differ by a rounding step at edges between versions: allow a
        // small share of slightly different pixels, never a different picture.
        let mut off = 0usize;
        let mut total_diff = 0u64;
        for (a, b) in got.chunks(4).zip(want.chunks(4)) {
            let d = a
                .iter()
                .zip(b)
                .map(|(x, y)| x.abs_diff(*y))
                .max()
                .unwrap_or(0);
            total_diff += u64::from(d);
            if d > 24 {
                off += 1;
            }
        }
        let pixels = (w * h) as usize;
        let mean = total_diff as f64 / pixels as f64;
        assert!(
            off * 200 <= pixels && mean < 1.5,
            "{name}: {off} of {pixels} pixels differ by more than 24, mean difference {mean:.2} \
             (the picture is {}; the reference {})",
            out.display(),
            reference.display()
        );
    }
    assert!(
        !bless,
        "FLOCKWAY_BLESS: wrote the references; run again without it"
    );
}

#[test]
fn the_picture_shows_the_scene_not_an_empty_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("ring.png");
    render(
        "levels/sugiyama_ring.ron",
        &out,
        &["--at", "5", "--size", "400x225"],
    );
    let (w, h, rgba) = read_png(&out);
    assert_eq!((w, h), (400, 225));
    // Human-like cars are red: strongly red pixels exist; the ground is green; asphalt is dark.
    let red = rgba
        .chunks(4)
        .filter(|p| p[0] > 150 && p[1] < 90 && p[2] < 90)
        .count();
    let green = rgba
        .chunks(4)
        .filter(|p| {
            u16::from(p[1]) > u16::from(p[0]) + 20 && u16::from(p[1]) > u16::from(p[2]) + 20
        })
        .count();
    let dark = rgba
        .chunks(4)
        .filter(|p| p[0] < 90 && p[1] < 90 && p[2] < 90)
        .count();
    let pixels = (w * h) as usize;
    assert!(red > 30, "{red} red pixels: no cars drawn?");
    assert!(
        green * 2 > pixels,
        "{green} green pixels of {pixels}: no ground?"
    );
    assert!(dark > 200, "{dark} dark pixels: no road?");
}

#[test]
fn a_bad_render_request_is_a_clear_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args([
            "render",
            "levels/sugiyama_ring.ron",
            "-o",
            "/tmp/x.png",
            "--size",
            "10x10",
        ])
        .output()
        .expect("flockway runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("200 to 8000 pixels"));
    let out = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args([
            "render",
            "levels/sugiyama_ring.ron",
            "-o",
            "/tmp/x.png",
            "--at",
            "-1",
        ])
        .output()
        .expect("flockway runs");
    assert_eq!(out.status.code(), Some(2));
}
