//! The face engine: expression → deformed mesh → pixels.
