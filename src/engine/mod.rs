//! The face engine: expression → deformed mesh → pixels.

pub mod camera;
pub mod image;
pub mod raster;
