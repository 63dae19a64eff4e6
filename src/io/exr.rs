//! OpenEXR: one layer `surface` with RGBA (linear, premultiplied), Z (depth along the
//! ray), N.X/N.Y/N.Z (world-space normals) and, given the surface's velocity, the motion
//! pass forward.u/forward.v (pixels over the next frame, v upward: Nuke's VectorBlur
//! reads it), as Nuke and Blender name them.

use std::path::Path;

use crate::render::Render;

pub fn write(image: &Render, path: &Path) -> Result<(), exr::error::Error> {
    use exr::prelude::*;
    let flat = |f: &dyn Fn(usize) -> f32| -> FlatSamples {
        FlatSamples::F32((0..image.rgba.len()).map(f).collect())
    };
    let channel = |name: &str, f: &dyn Fn(usize) -> f32| AnyChannel::new(name, flat(f));
    let mut list = vec![
        channel("R", &|i| image.rgba[i][0]),
        channel("G", &|i| image.rgba[i][1]),
        channel("B", &|i| image.rgba[i][2]),
        channel("A", &|i| image.rgba[i][3]),
        channel("Z", &|i| image.depth[i]),
        channel("N.X", &|i| image.normal[i].x),
        channel("N.Y", &|i| image.normal[i].y),
        channel("N.Z", &|i| image.normal[i].z),
    ];
    if let Some(motion) = &image.motion {
        list.push(channel("forward.u", &|i| motion[i][0]));
        list.push(channel("forward.v", &|i| motion[i][1]));
    }
    let channels = AnyChannels::sort(SmallVec::from_vec(list));
    let layer = Layer::new(
        (image.width, image.height),
        LayerAttributes::named("surface"),
        // Tiles stored in increasing order: the same image is the same bytes (stored as
        // the compressing threads finished them, it was not).
        Encoding {
            line_order: LineOrder::Increasing,
            ..Encoding::FAST_LOSSLESS
        },
        channels,
    );
    Image::from_layer(layer).write().to_file(path)
}
