//! Contact sheets: many renders side by side, each with a caption, for a quick visual audit.
//!
//! In: images (all the same size) and captions. Out: one [`RgbImage`]. Captions are drawn with
//! the embedded DejaVu Sans (`assets/fonts/`, see its PROVENANCE.md), so no system fonts are used.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};

use super::image::RgbImage;

const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Height of the caption strip under each tile, pixels.
const CAPTION: u32 = 22;
/// A caption's font size in pixels, and the smallest it shrinks to where it would not fit its
/// tile (a longer one is cut at the tile's edge).
const CAPTION_SIZE: f32 = 15.0;
const CAPTION_SMALLEST: f32 = 9.0;

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
            let width = tile_w.saturating_sub(12);
            draw_text(&mut sheet, caption, x0 + 6, y0 + tile_h + 4, width, fitted_size(caption, width, CAPTION_SIZE));
        }
        sheet
    }
}

/// The embedded caption font.
fn font() -> FontRef<'static> {
    FontRef::try_from_slice(FONT).expect("the embedded font is valid")
}

/// The size at which `text` fits in `max_width` pixels: `size` where it does, else as much
/// smaller as it needs, down to [`CAPTION_SMALLEST`].
fn fitted_size(text: &str, max_width: u32, size: f32) -> f32 {
    let width = text_width(text, size);
    if width <= max_width as f32 {
        return size;
    }
    // Widths scale with the size; the margin keeps rounding from cutting the last glyph.
    (size * max_width as f32 / width * 0.995).max(CAPTION_SMALLEST)
}

/// How wide `text` is at `size` pixels (advances and kerning).
fn text_width(text: &str, size: f32) -> f32 {
    glyph_carets(text, size).last().map_or(0.0, |&(_, _, end)| end)
}

/// Each glyph of `text` at `size` pixels with where it starts and where the next one starts.
fn glyph_carets(text: &str, size: f32) -> Vec<(ab_glyph::GlyphId, f32, f32)> {
    let font = font();
    let scaled = font.as_scaled(PxScale::from(size));
    let mut caret = 0.0f32;
    let mut previous = None;
    text.chars()
        .map(|ch| {
            let id = scaled.glyph_id(ch);
            if let Some(prev) = previous {
                caret += scaled.kern(prev, id);
            }
            previous = Some(id);
            let start = caret;
            caret += scaled.h_advance(id);
            (id, start, caret)
        })
        .collect()
}

/// Draws light text on the sheet with its top-left at (x, y), clipped to `max_width`.
pub fn draw_text(image: &mut RgbImage, text: &str, x: u32, y: u32, max_width: u32, size: f32) {
    let font = font();
    let ascent = font.as_scaled(PxScale::from(size)).ascent();
    for (id, start, end) in glyph_carets(text, size) {
        if end > max_width as f32 {
            break;
        }
        let glyph = id.with_scale_and_position(size, point(x as f32 + start, y as f32 + ascent));
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A caption too long for its tile is drawn smaller, whole: on the emotions sheet's
    /// 242-pixel tiles the anger caption was cut after "17+4" at 15 px.
    #[test]
    fn a_long_caption_shrinks_to_fit_its_tile() {
        let (short, long) = ("wm1 neutral (0)", "wm1 anger (5+7+9+10+15+17+42)");
        let width = 242 - 12;
        assert_eq!(fitted_size(short, width, CAPTION_SIZE), CAPTION_SIZE);
        assert!(text_width(long, CAPTION_SIZE) > width as f32, "the long caption fits at 15 px");
        let size = fitted_size(long, width, CAPTION_SIZE);
        assert!((CAPTION_SMALLEST..CAPTION_SIZE).contains(&size), "{size} px");
        assert!(text_width(long, size) <= width as f32 && text_width(long, size) > 0.95 * width as f32);
        // Drawn at that size, its last glyph (the closing bracket) is on the sheet.
        let mut whole = RgbImage::new(242, 22);
        let mut cut = RgbImage::new(242, 22);
        draw_text(&mut whole, long, 6, 4, width, size);
        draw_text(&mut cut, &long[..long.len() - 1], 6, 4, width, size);
        assert_ne!(whole.data, cut.data, "the closing bracket was not drawn");
        // Beyond the smallest size a caption is cut at the tile's edge.
        assert_eq!(fitted_size(&long.repeat(4), width, CAPTION_SIZE), CAPTION_SMALLEST);
    }
}
