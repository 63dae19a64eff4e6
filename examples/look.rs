//! The look of a mesh sequence (issue 49): per frame, particle-scale bumps (degrees, on
//! the largest piece), connected pieces. `cargo run --release --example look -- RADIUS
//! mesh.0001.obj mesh.0002.obj ...`; the means over the meshes come last.

use activeskin::measure::look;

fn main() {
    let mut args = std::env::args().skip(1);
    let radius: f32 = args
        .next()
        .and_then(|r| r.parse().ok())
        .expect("usage: look RADIUS MESH...");
    let (mut bumps, mut pieces, mut n) = (0.0, 0.0, 0.0);
    for path in args {
        let mesh = activeskin::io::obj::read(std::path::Path::new(&path)).expect("an OBJ mesh");
        let (b, p) = (look::bumps(&mesh, radius), look::pieces(&mesh, radius));
        println!("{path}: bumps {b:.2}°, {p} pieces");
        (bumps, pieces, n) = (bumps + b, pieces + p as f64, n + 1.0);
    }
    println!("mean: bumps {:.2}°, pieces {:.1}", bumps / n, pieces / n);
}
