//! Light-transport techniques, one module each.

pub mod whitted;
