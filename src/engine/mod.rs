//! The face engine: expression → deformed mesh → pixels.
pub mod asset;
pub mod rig;
pub mod identity;
pub mod pose;
