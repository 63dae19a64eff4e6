//! `activeskin validate FILE.vdb`: our mesh and measures against OpenVDB's on a user's own
//! level set, as a table; exit 1 when out of tolerance (for pipeline QA).

use std::path::PathBuf;

use activeskin::validate;
use activeskin::vdb::Grid;
use anyhow::bail;

#[derive(clap::Args)]
pub struct ValidateArgs {
    /// A VDB file holding a level set.
    file: PathBuf,
    /// Grid name, `name[1]` for a second grid of one name, or index in the file
    /// (default: `surface` or `phi`, Houdini's and Mantaflow's level sets, else the first float grid).
    #[arg(long)]
    grid: Option<String>,
}

pub fn run(args: &ValidateArgs) -> anyhow::Result<()> {
    let path = &args.file;
    let grid = Grid::read(path, args.grid.as_deref())?;
    let report =
        validate::compare(&grid).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    println!("{}: grid '{}'", path.display(), grid.name());
    println!(
        "{:<40} {:>14} {:>14} {:>12} {:>10}",
        "", "ours", "OpenVDB", "difference", "tolerance"
    );
    for row in &report.rows {
        let relative = row.name.starts_with("area") || row.name.starts_with("volume");
        let (difference, tolerance) = if relative {
            (
                format!("{:.3} %", 100.0 * row.difference),
                format!("{:.1} %", 100.0 * row.tolerance),
            )
        } else {
            (
                format!("{:.3}", row.difference),
                format!("{}", row.tolerance),
            )
        };
        // Why a row out of its own tolerance passes, or FAIL.
        let verdict = match (row.within(), row.offset, row.explained, row.passes()) {
            (true, ..) => String::new(),
            (false, Some(offset), _, true) => {
                format!(
                    "  {offset:.3} voxel offset (≤ {})",
                    validate::OFFSET_TOLERANCE
                )
            }
            (false, _, Some(why), _) => format!("  expected: {why}"),
            (false, Some(offset), _, false) => format!("  {offset:.3} voxel offset  FAIL"),
            _ => "  FAIL".to_string(),
        };
        println!(
            "{:<40} {:>14.6} {:>14.6} {:>12} {:>10}{verdict}",
            row.name, row.ours, row.openvdb, difference, tolerance,
        );
    }
    match (report.check.is_empty(), report.exact_flagged) {
        (true, _) => println!("checkLevelSet: valid"),
        (false, Some(exact)) => println!(
            "checkLevelSet: {}; on meshToLevelSet of the same surface: {exact} voxels{}",
            report.check,
            if report.check_passes() {
                " (thin features: no worse, accepted)"
            } else {
                "  FAIL"
            }
        ),
        (false, None) => println!("checkLevelSet: {}  FAIL", report.check),
    }
    if !report.passes() {
        let failed: Vec<&str> = report
            .rows
            .iter()
            .filter(|r| !r.passes())
            .map(|r| r.name)
            .chain((!report.check_passes()).then_some("checkLevelSet"))
            .collect();
        bail!(
            "{}: out of tolerance: {}",
            path.display(),
            failed.join(", ")
        );
    }
    Ok(())
}
