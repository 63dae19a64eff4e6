//! PNG: the beauty over a grey background, 8-bit sRGB.

use std::io::BufWriter;
use std::path::Path;

use crate::render::Render;

pub fn write(image: &Render, path: &Path) -> Result<(), png::EncodingError> {
    let file = std::fs::File::create(path)?;
    let mut encoder = png::Encoder::new(
        BufWriter::new(file),
        image.width as u32,
        image.height as u32,
    );
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let background = 0.18f32;
    let bytes: Vec<u8> = image
        .rgba
        .iter()
        .flat_map(|&[r, g, b, a]| {
            [r, g, b].map(|c| {
                let linear = c + background * (1.0 - a);
                (255.0 * linear.clamp(0.0, 1.0).powf(1.0 / 2.2)).round() as u8
            })
        })
        .collect();
    let mut writer = encoder.write_header()?;
    writer.write_image_data(&bytes)?;
    writer.finish()
}
