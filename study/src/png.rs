//! PNG figures: plotters draws into an RGB buffer and the `png` crate encodes it, so the
//! build needs neither plotters' `bitmap_encoder` nor the `image` crate behind it (a sixth of
//! a fresh build for one file format).

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

/// Draws with `draw` on a white-initialised `size` canvas and writes it to `path` as an 8-bit
/// RGB PNG. The error says which step failed and names the file.
pub fn draw_png<F>(path: &Path, size: (u32, u32), draw: F) -> Result<(), String>
where
    F: FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), String>,
{
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw(&root)?;
        root.present().map_err(|e| e.to_string())?;
    }
    write_rgb(path, size, &rgb).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

fn write_rgb(path: &Path, (width, height): (u32, u32), rgb: &[u8]) -> std::io::Result<()> {
    let file = BufWriter::new(File::create(path)?);
    let mut encoder = png::Encoder::new(file, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // Figures are flat colours and text at twice the logical size: the strongest deflate and
    // the adaptive filter make a committed figure a third of the default's size.
    encoder.set_compression(png::Compression::Best);
    encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drawn square comes back from the file with its colour at its place.
    #[test]
    fn a_drawn_square_reads_back_from_the_file() {
        let path = std::env::temp_dir().join(format!("swarmfl-png-{}.png", std::process::id()));
        draw_png(&path, (40, 30), |root| {
            root.fill(&WHITE).map_err(|e| e.to_string())?;
            root.draw(&Rectangle::new([(10, 5), (20, 15)], RED.filled()))
                .map_err(|e| e.to_string())
        })
        .unwrap();
        let decoder = png::Decoder::new(File::open(&path).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!((info.width, info.height), (40, 30));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        let px = |x: usize, y: usize| &buf[(y * 40 + x) * 3..(y * 40 + x) * 3 + 3];
        assert_eq!(px(15, 10), &[255, 0, 0]);
        assert_eq!(px(2, 2), &[255, 255, 255]);
    }

    /// A folder that does not exist is named in the error, not a panic.
    #[test]
    fn a_missing_folder_is_an_error_naming_the_file() {
        let path = Path::new("/nonexistent-swarmfl-dir/figure.png");
        let err = draw_png(path, (4, 4), |_| Ok(())).unwrap_err();
        assert!(err.contains("/nonexistent-swarmfl-dir/figure.png"), "{err}");
    }
}
