//! OpenEXR: one layer `surface` with RGBA (linear, premultiplied), Z (depth along the
//! ray) and N.X/N.Y/N.Z (world-space normals), as Nuke and Blender name them.

use std::path::Path;

use crate::render::Render;

pub fn write(image: &Render, path: &Path) -> Result<(), exr::error::Error> {
    use exr::prelude::*;
    let flat = |f: &dyn Fn(usize) -> f32| -> FlatSamples {
        FlatSamples::F32((0..image.rgba.len()).map(f).collect())
    };
    let channel = |name: &str, f: &dyn Fn(usize) -> f32| AnyChannel::new(name, flat(f));
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![
        channel("R", &|i| image.rgba[i][0]),
        channel("G", &|i| image.rgba[i][1]),
        channel("B", &|i| image.rgba[i][2]),
        channel("A", &|i| image.rgba[i][3]),
        channel("Z", &|i| image.depth[i]),
        channel("N.X", &|i| image.normal[i].x),
        channel("N.Y", &|i| image.normal[i].y),
        channel("N.Z", &|i| image.normal[i].z),
    ]));
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
