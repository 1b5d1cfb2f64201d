//! Rendering engine.
