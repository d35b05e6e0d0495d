//! Contact sheets: many renders side by side, each with a caption, for a quick visual audit.
//!
//! In: images (all the same size) and captions. Out: one [`RgbImage`]. Captions are drawn with
//! the embedded DejaVu Sans (`assets/fonts/`, see its PROVENANCE.md), so no system fonts are used.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};

use super::image::RgbImage;

const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Height of the caption strip under each tile, pixels.
const CAPTION: u32 = 22;

/// Lays tiles out in rows of `columns`.
pub struct ContactSheet {
    columns: u32,
    tiles: Vec<(RgbImage, String)>,
}

impl ContactSheet {
    pub fn new(columns: u32) -> ContactSheet {
        ContactSheet { columns: columns.max(1), tiles: Vec::new() }
    }

    pub fn push(&mut self, image: RgbImage, caption: impl Into<String>) {
        self.tiles.push((image, caption.into()));
    }

    /// The finished sheet; tiles are placed in the order they were pushed.
    pub fn compose(&self) -> RgbImage {
        let (tile_w, tile_h) = self.tiles.first().map_or((1, 1), |(i, _)| (i.width, i.height));
        let rows = (self.tiles.len() as u32).div_ceil(self.columns).max(1);
        let cell_h = tile_h + CAPTION;
        let mut sheet = RgbImage::new(tile_w * self.columns, cell_h * rows);
        sheet.data.fill(24);
        for (n, (tile, caption)) in self.tiles.iter().enumerate() {
            let (x0, y0) = ((n as u32 % self.columns) * tile_w, (n as u32 / self.columns) * cell_h);
            for y in 0..tile.height.min(tile_h) {
                for x in 0..tile.width.min(tile_w) {
                    sheet.set_pixel(x0 + x, y0 + y, tile.pixel(x, y));
                }
            }
            draw_text(&mut sheet, caption, x0 + 6, y0 + tile_h + 4, tile_w - 12, 15.0);
        }
        sheet
    }
}

/// Draws light text on the sheet with its top-left at (x, y), clipped to `max_width`.
pub fn draw_text(image: &mut RgbImage, text: &str, x: u32, y: u32, max_width: u32, size: f32) {
    let font = FontRef::try_from_slice(FONT).expect("the embedded font is valid");
    let scaled = font.as_scaled(PxScale::from(size));
    let mut caret = 0.0f32;
    let mut previous = None;
    for ch in text.chars() {
        let id = scaled.glyph_id(ch);
        if let Some(prev) = previous {
            caret += scaled.kern(prev, id);
        }
        previous = Some(id);
        let glyph = id.with_scale_and_position(size, point(x as f32 + caret, y as f32 + scaled.ascent()));
        caret += scaled.h_advance(id);
        if caret > max_width as f32 {
            break;
        }
        let Some(outline) = font.outline_glyph(glyph) else { continue };
        let bounds = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            let (px, py) = (bounds.min.x as i32 + gx as i32, bounds.min.y as i32 + gy as i32);
            if px < 0 || py < 0 || px as u32 >= image.width || py as u32 >= image.height {
                return;
            }
            let old = image.pixel(px as u32, py as u32);
            let blend = |c: u8| (c as f32 + (235.0 - c as f32) * coverage.clamp(0.0, 1.0)).round() as u8;
            image.set_pixel(px as u32, py as u32, old.map(blend));
        });
    }
}
