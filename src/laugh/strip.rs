//! Frame strips: a few frames of a laugh side by side, to see a take at a glance (the docs'
//! strips, `facslab laugh --strip`).
//!
//! In: curves, a person, a frame size and a style. Out: one [`RgbImage`] of [`STRIP_FRAMES`]
//! frames left to right, the middles of as many equal parts of the take.
//! Invariant: frame `k` of the strip is exactly frame [`strip_frames`]`[k]` of the video the
//! same curves make (the same timeline, the same still path).

use crate::engine::identity::IdentityTable;
use crate::engine::image::RgbImage;
use crate::engine::{self, EngineError, FrameSettings, Style};
use crate::facs::Catalog;

use super::curves::Curves;

/// Frames in a strip.
pub const STRIP_FRAMES: usize = 6;

/// The frame numbers of a strip of a take of `count` frames.
pub fn strip_frames(count: usize) -> Vec<usize> {
    (0..STRIP_FRAMES).map(|k| (2 * k + 1) * count / (2 * STRIP_FRAMES)).collect()
}

/// Images of one size side by side, left to right.
pub fn side_by_side(images: &[RgbImage]) -> RgbImage {
    let (w, h) = images.first().map_or((1, 1), |i| (i.width, i.height));
    let mut strip = RgbImage::new(w * images.len().max(1) as u32, h);
    for (k, image) in images.iter().enumerate() {
        let offset = k * w as usize * 3;
        for y in 0..h as usize {
            let row = y * w as usize * 3;
            let dst = y * strip.width as usize * 3 + offset;
            strip.data[dst..dst + w as usize * 3].copy_from_slice(&image.data[row..row + w as usize * 3]);
        }
    }
    strip
}

/// The strip of `curves` on `identity` (a known id) at `size` in `style`.
pub fn render_strip(curves: &Curves, identity: &str, size: (u32, u32), style: Style) -> Result<RgbImage, StripError> {
    let person = IdentityTable::active().get(identity).map_err(|e| StripError::Identity(e.to_string()))?;
    let timeline = curves.to_timeline(identity, size);
    let settings = FrameSettings { width: size.0, height: size.1, threads: None, style, ..Default::default() };
    let frames = strip_frames(timeline.frame_count())
        .into_iter()
        .map(|f| {
            let expression = timeline.frame_expression(f, Catalog::built_in()).map_err(|e| StripError::Frame(e.to_string()))?;
            Ok(engine::render_still(&expression, person, FrameSettings { shoulders: timeline.frame_shoulders(f), ..settings })?)
        })
        .collect::<Result<Vec<_>, StripError>>()?;
    Ok(side_by_side(&frames))
}

/// Why a strip could not be made.
#[derive(Debug, thiserror::Error)]
pub enum StripError {
    #[error("{0}")]
    Identity(String),
    #[error("a frame of the curves: {0}")]
    Frame(String),
    #[error(transparent)]
    Engine(#[from] EngineError),
}
