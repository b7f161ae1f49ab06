//! The viewer's text overlay, drawn into the frame's RGB8 pixels with plotters (the same
//! TrueType font lookup as the charts: `RAYSPACE_FONT` or the usual system fonts).

use anyhow::{anyhow, Result};
use plotters::prelude::*;

/// Draw `lines` at the top left of the `w × h` RGB8 image on a dimmed band.
pub fn draw(rgb: &mut [u8], w: u32, h: u32, lines: &[String]) -> Result<()> {
    crate::bench::charts::font()?;
    let size = 14u32;
    let band = ((lines.len() as u32) * (size + 4) + 8).min(h) as usize;
    // Dim the band first, so the text reads on any picture.
    for px in rgb[..band * w as usize * 3].iter_mut() {
        *px /= 3;
    }
    let root = BitMapBackend::with_buffer(rgb, (w, h)).into_drawing_area();
    let style = ("sans-serif", size as f64).into_font().color(&WHITE);
    for (i, l) in lines.iter().enumerate() {
        root.draw_text(l, &style, (6, 4 + i as i32 * (size as i32 + 4)))
            .map_err(|e| anyhow!("overlay: {e:?}"))?;
    }
    root.present().map_err(|e| anyhow!("overlay: {e:?}"))?;
    Ok(())
}
