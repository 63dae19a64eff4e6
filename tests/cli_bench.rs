//! `activeskin bench --json` runs ours and OpenVDB side by side and reports every figure.
#![cfg(feature = "vdb")]

use std::process::Command;

#[test]
fn bench_reports_every_ratio() {
    let out = Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .args(["bench", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for (section, key) in [
        ("step", "ratio"),
        ("step_with_velocity", "ours_band_nodes_per_s"),
        ("step_with_velocity", "against_velocity_off"),
        ("meshing", "speedup"),
        ("memory", "ratio_fixed16"),
        ("scaling", "exponent"),
        ("scaling", "speedup_over_1_thread"),
        ("flicker", "gain"),
        ("advection", "speedup"),
    ] {
        let v = report[section][key].as_f64();
        assert!(
            v.is_some_and(|v| v.is_finite() && v > 0.0),
            "{section}.{key}: {report}"
        );
    }
    // Memory does not depend on timing: the fixed16 goal (half of OpenVDB's narrow band,
    // spare arena capacity included) is asserted.
    let fixed16 = report["memory"]["ratio_fixed16"].as_f64().unwrap();
    assert!(fixed16 <= 0.5, "fixed16 memory ratio {fixed16}");
    assert!(
        report["memory"]["ours_fixed16_bytes"].as_f64()
            < report["memory"]["ours_f32_bytes"].as_f64()
    );
    // Both reach the target (0.1 voxel mean, 0.5 max) in every race, with tension too.
    let races = report["morph_to_accuracy"].as_array().unwrap();
    assert_eq!(races.len(), 3);
    for race in races {
        assert!(race["ours_s"].as_f64().is_some_and(|s| s > 0.0), "{race}");
        assert!(
            race["openvdb_s"].as_f64().is_some_and(|s| s > 0.0),
            "{race}"
        );
    }
    assert!(races[2]["beta"].as_f64().unwrap() > 0.0);
    // Advection is deterministic on both sides: one turn keeps the volume within 1 %.
    for side in ["ours_volume_pct", "openvdb_volume_pct"] {
        let v = report["advection"][side].as_f64().unwrap();
        assert!(v.abs() < 1.0, "advection {side} {v}");
    }
    // Flicker is deterministic: the goal (3× less than per-frame surfacing) is asserted.
    assert!(
        report["flicker"]["gain"].as_f64().unwrap() >= 3.0,
        "{report}"
    );
    // The scaling exponent (cost against the area: 2, not the volume's 3) is timed, and a
    // shared machine spreads it (1.17 seen with a compile beside it): reported above, not
    // asserted; that memory follows the surface, not the box, is in tests/far_apart.rs.
}
