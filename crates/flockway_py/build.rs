//! Embeds the shipped levels and the assets they use, so an installed wheel can run them from
//! anywhere (`flockway.level_path("stern_ring")` unpacks them once into a cache directory).

use std::path::{Path, PathBuf};

fn ron_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            ron_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "ron") {
            out.push(path);
        }
    }
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut files = Vec::new();
    for dir in ["levels", "assets"] {
        println!("cargo:rerun-if-changed={}", root.join(dir).display());
        ron_files(&root.join(dir), &mut files);
    }
    // Sorted, so the table (and the wheel) is the same on every machine.
    files.sort();
    let mut table =
        String::from("/// The shipped levels and assets: (path under the repository, text).\n");
    table.push_str("pub const SHIPPED: &[(&str, &str)] = &[\n");
    for f in &files {
        println!("cargo:rerun-if-changed={}", f.display());
        let rel = f
            .strip_prefix(&root)
            .expect("under the root")
            .to_string_lossy()
            .replace('\\', "/");
        let abs = f.canonicalize().expect("a file");
        table.push_str(&format!("    ({rel:?}, include_str!({abs:?})),\n"));
    }
    table.push_str("];\n");
    let out = Path::new(&std::env::var("OUT_DIR").expect("OUT_DIR")).join("shipped.rs");
    std::fs::write(out, table).expect("write the table");
}
