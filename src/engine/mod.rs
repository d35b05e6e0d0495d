//! The face engine: expression → deformed mesh → pixels.
pub mod asset;
pub mod rig;
