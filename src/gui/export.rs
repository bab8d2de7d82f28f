//! Writing the window out as PNG (the pixels of an eframe screenshot, encoded by the `image`
//! crate). The plotted data go out as CSV/SVG through [`crate::signal::export`].

use std::path::Path;

/// Encodes `image` (sRGB, as egui renders it) as an 8-bit RGBA PNG at `path`. Returns a line
/// for the status area.
pub fn write_png(path: &Path, image: &egui::ColorImage) -> Result<String, String> {
    let [w, h] = image.size;
    if w == 0 || h == 0 || image.pixels.len() != w * h {
        return Err(format!("{}: empty screenshot ({w} × {h}), nothing written", path.display()));
    }
    let bytes: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_srgba_unmultiplied()).collect();
    let (wu, hu) = (u32::try_from(w).map_err(|e| e.to_string())?, u32::try_from(h).map_err(|e| e.to_string())?);
    let img = image::RgbaImage::from_raw(wu, hu, bytes).ok_or_else(|| format!("{}: screenshot buffer of the wrong size", path.display()))?;
    img.save_with_format(path, image::ImageFormat::Png).map_err(|e| format!("{}: cannot write PNG ({e})", path.display()))?;
    Ok(format!("window ({w} × {h} px) written to {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG written from a ColorImage reads back with the same size and pixels.
    #[test]
    fn png_round_trip() {
        let (w, h) = (7usize, 3usize);
        let pixels: Vec<egui::Color32> = (0..w * h).map(|k| egui::Color32::from_rgb((k * 11) as u8, (255 - k * 5) as u8, 40)).collect();
        let img = egui::ColorImage::new([w, h], pixels.clone());
        let dir = std::env::temp_dir().join(format!("twinscope-png-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("view.png");
        let msg = write_png(&p, &img).unwrap();
        assert!(msg.contains("7 × 3 px"));
        let back = image::open(&p).unwrap().to_rgba8();
        assert_eq!(back.dimensions(), (7, 3));
        for (k, c) in pixels.iter().enumerate() {
            let px = back.get_pixel((k % w) as u32, (k / w) as u32);
            assert_eq!(px.0, [c.r(), c.g(), c.b(), 255], "pixel {k}");
        }
        assert!(write_png(&p, &egui::ColorImage::new([0, 0], Vec::new())).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
