//! Whitted 1980.
