//! The Python package (`python/`, issue 30): its wheel built with maturin into a venv of
//! the test's own (made here, once per build folder; maturin and numpy from pip),
//! installed, and `python/tests/test_activeskin.py` run against this build's binary —
//! the same meshes as the command byte for byte, ValueError with the command's message,
//! the GIL released while a frame computes.
#![cfg(feature = "cli")]

mod common;

use std::path::Path;
use std::process::Command;

use common::{assert_ok, scratch};

#[test]
fn the_wheel_skins_numpy_particles_as_the_command_does() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("python");
    let venv = work.join("venv");
    let python = venv.join("bin/python");
    let ready = Command::new(&python)
        .args(["-c", "import maturin, numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ready {
        assert_ok(
            &Command::new("python3")
                .args(["-m", "venv", "--clear"])
                .arg(&venv)
                .output()
                .expect("python3 (make deps installs python3-venv)"),
        );
        assert_ok(
            &Command::new(&python)
                .args([
                    "-m",
                    "pip",
                    "install",
                    "--quiet",
                    "--disable-pip-version-check",
                ])
                .args(["maturin>=1.5,<2", "numpy"])
                .output()
                .expect("pip"),
        );
    }
    // Its own target folder: the build running this test holds the workspace's.
    let wheels = work.join("wheels");
    let _ = std::fs::remove_dir_all(&wheels);
    let built = Command::new(venv.join("bin/maturin"))
        .args(["build", "--release", "--quiet", "-m"])
        .arg(root.join("python/Cargo.toml"))
        .arg("-o")
        .arg(&wheels)
        .env("CARGO_TARGET_DIR", work.join("target"))
        .output()
        .expect("maturin");
    assert_ok(&built);
    let wheel = std::fs::read_dir(&wheels)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "whl"))
        .expect("a wheel");
    let name = wheel.file_name().unwrap().to_string_lossy().into_owned();
    assert!(name.contains("abi3"), "{name}: not an abi3 wheel");
    assert_ok(
        &Command::new(&python)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--force-reinstall",
                "--no-deps",
            ])
            .arg(&wheel)
            .output()
            .unwrap(),
    );
    let dir = scratch();
    let run = Command::new(&python)
        .arg(root.join("python/tests/test_activeskin.py"))
        .arg(env!("CARGO_BIN_EXE_activeskin"))
        .arg(dir.path())
        .output()
        .unwrap();
    println!("{}", String::from_utf8_lossy(&run.stdout));
    assert_ok(&run);
}
