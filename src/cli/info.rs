//! `activeskin info FILE...`: one block per grid.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use activeskin::vdb::{self, GridSummary};
use activeskin::volume::GridClass;

pub fn run(files: &[PathBuf]) -> anyhow::Result<()> {
    // Describe every file before failing, so one bad file does not hide the others.
    let mut failures = Vec::new();
    for path in files {
        match vdb::list_grids(path) {
            Ok(grids) => {
                print!("{}", describe(path, &grids));
                // Float grids are targets (`skin`), point data grids particles.
                let usable = |g: &GridSummary| {
                    g.error.is_empty()
                        && (g.value_type == "float" || g.value_type.starts_with("ptdataidx"))
                };
                if !grids.iter().any(usable) {
                    failures.push(format!(
                        "{}: no float or point data grid that activeskin can use",
                        path.display()
                    ));
                }
            }
            Err(e) => failures.push(e.to_string()),
        }
    }
    match (failures.len(), files.len()) {
        (0, _) => Ok(()),
        (1, 1) => anyhow::bail!("{}", failures[0]),
        (n, _) => {
            for failure in &failures {
                super::note(&format!("error: {failure}"));
            }
            anyhow::bail!("{n} of {} files could not be used", files.len())
        }
    }
}

fn class_name(class: GridClass) -> &'static str {
    match class {
        GridClass::LevelSet => "level set",
        GridClass::FogVolume => "fog volume",
        GridClass::Staggered => "staggered",
        _ => "unknown",
    }
}

/// Numbers as a user reads them: single precision is plenty to describe a grid, and shows
/// 0.02 and 1.1 rather than 0.019999999552965164 and 1.1000000163912773.
fn number(x: f64) -> String {
    format!("{}", x as f32)
}

fn vec3(v: [f64; 3]) -> String {
    format!("({}, {}, {})", number(v[0]), number(v[1]), number(v[2]))
}

pub fn describe(path: &Path, grids: &[GridSummary]) -> String {
    let mut s = String::new();
    let plural = if grids.len() == 1 { "" } else { "s" };
    let _ = writeln!(s, "{}: {} grid{plural}", path.display(), grids.len());
    for g in grids {
        let _ = writeln!(s, "grid '{}'", g.name);
        let _ = writeln!(s, "  value type     {}", g.value_type);
        let _ = writeln!(
            s,
            "  class          {}",
            class_name(activeskin::vdb::from_bridge_class(g.grid_class))
        );
        let [x, y, z] = g.voxel_size;
        let voxel = if x == y && y == z {
            number(x)
        } else {
            vec3(g.voxel_size)
        };
        let transform = if g.uniform_linear {
            "uniform linear transform"
        } else {
            "NOT a uniform linear transform"
        };
        let _ = writeln!(s, "  voxel size     {voxel} ({transform})");
        if !g.error.is_empty() {
            // Listed from its metadata: what the writer recorded, and why it stops there.
            let _ = writeln!(
                s,
                "  NOT DECODABLE  {} (other grids are read as usual)",
                g.error
            );
            let _ = writeln!(s, "  active voxels  {} (as written)", g.active_voxels);
            if g.has_bbox {
                let _ = writeln!(
                    s,
                    "  bbox (world)   {} to {} (as written)",
                    vec3(g.bbox_min),
                    vec3(g.bbox_max)
                );
            }
            continue;
        }
        let _ = writeln!(s, "  active voxels  {}", g.active_voxels);
        if g.value_type.starts_with("ptdataidx") {
            let _ = writeln!(
                s,
                "  points         {} (particles: activeskin particles)",
                g.points
            );
        }
        if g.has_bbox {
            let _ = writeln!(
                s,
                "  bbox (world)   {} to {}",
                vec3(g.bbox_min),
                vec3(g.bbox_max)
            );
        } else {
            let _ = writeln!(s, "  bbox (world)   empty");
        }
        let _ = writeln!(s, "  background     {}", g.background);
    }
    s
}
