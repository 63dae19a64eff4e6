use activeskin::skin::*;
use activeskin::target::*;
use glam::Vec3;
fn main() {
    let dx = 1.0 / 32.0;
    let start = Sphere {
        center: Vec3::ZERO,
        radius: 0.7,
    };
    let torus = Torus {
        center: Vec3::ZERO,
        major: 0.6,
        minor: 0.25,
    };
    let mut params = SkinParams {
        dx,
        ..Default::default()
    };
    params.speed.alpha = 4.0;
    let mut skin: Skin<f32> = Skin::new(&start, params);
    let t0 = std::time::Instant::now();
    let m = skin.mesh();
    println!(
        "start: verts {} tris {} topo {:?} chi {} area {:.4} (4πr²={:.4}) vol {:.4}",
        m.positions.len(),
        m.triangles.len(),
        m.topology(),
        m.euler_characteristic(),
        m.area(),
        4.0 * std::f64::consts::PI * 0.49,
        m.volume()
    );
    for frame in 0..40 {
        let s = skin.advance(&torus, 1.0 / 24.0);
        let m = skin.mesh();
        let (mut sum, mut max) = (0.0f64, 0.0f32);
        for p in &m.positions {
            let d = torus.distance(*p).abs() / dx;
            sum += d as f64;
            max = max.max(d);
        }
        if frame % 4 == 3 {
            println!("frame {frame}: sub {} band {} blocks {} chi {} comps {} mean {:.4} max {:.4} change {:.5} topo {:?}", s.substeps, s.band_nodes, s.blocks, s.euler_characteristic, s.components, sum / m.positions.len() as f64, max, s.max_change_voxels, m.topology());
        }
    }
    println!("{:?}", t0.elapsed());
}
