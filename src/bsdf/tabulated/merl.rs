//! MERL measured BRDFs (Matusik, Pfister, Brand and McMillan 2003, "A Data-Driven
//! Reflectance Model"): the binary files of the MERL BRDF database, looked up as the
//! database's reference code `BRDFRead.cpp` does.
//!
//! A file holds three little-endian i32 dimensions (90, 90, 180), then 3·90·90·180
//! little-endian f64 values: the red block, then green, then blue, each scaled by 1/1500,
//! 1.15/1500 and 1.66/1500 to give f in 1/sr. A value is indexed by the half-angle θh (90
//! cells, θh = (π/2)(i/90)², finer near the highlight), the difference angle θd (90 cells of
//! 1°) and the difference azimuth φd over [0, π) (180 cells of 1°; φd and φd + π are one by
//! reciprocity), φd fastest. Negative values mark missing measurements and count as 0.

use crate::math::{Rgb, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};

const THETA_H: usize = 90;
const THETA_D: usize = 90;
const PHI_D: usize = 180;
const CELLS: usize = THETA_H * THETA_D * PHI_D;
/// The reference code's `RED_SCALE`, `GREEN_SCALE` and `BLUE_SCALE`.
const SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// A measured BRDF in f per cell (1/sr, scaled, missing values 0).
#[derive(Debug, PartialEq)]
pub(super) struct Merl {
    values: Vec<Rgb>,
}

impl Merl {
    /// The BRDF in `bytes` (a file's contents); `Err` says what is wrong.
    pub(super) fn parse(bytes: &[u8]) -> Result<Merl, String> {
        let need = 12 + 3 * CELLS * 8;
        if bytes.len() < 12 {
            return Err(format!(
                "{} bytes, too short for a MERL BRDF's header",
                bytes.len()
            ));
        }
        let dim = |k: usize| i32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().unwrap());
        let dims = [dim(0), dim(1), dim(2)];
        if dims != [THETA_H as i32, THETA_D as i32, PHI_D as i32] {
            return Err(format!(
                "dimensions {} × {} × {}; a MERL BRDF has 90 × 90 × 180",
                dims[0], dims[1], dims[2]
            ));
        }
        if bytes.len() != need {
            return Err(format!(
                "{} bytes; a MERL BRDF of 90 × 90 × 180 has {need}",
                bytes.len()
            ));
        }
        let value = |k: usize| {
            let at = 12 + 8 * k;
            f64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
        };
        let mut values = Vec::with_capacity(CELLS);
        for i in 0..CELLS {
            let mut c = [0.0f32; 3];
            for (ch, out) in c.iter_mut().enumerate() {
                let v = value(ch * CELLS + i);
                if !v.is_finite() {
                    return Err(format!("value {} is not a number", ch * CELLS + i));
                }
                *out = (v.max(0.0) * SCALE[ch]) as f32;
            }
            values.push(Rgb::new(c[0], c[1], c[2]));
        }
        Ok(Merl { values })
    }

    /// f for light arriving along local direction `li` and leaving along `lo`.
    pub(super) fn eval(&self, li: Vec3, lo: Vec3) -> Rgb {
        self.values[cell(li, lo)]
    }
}

/// The index of the value for directions `li` and `lo`: `BRDFRead.cpp`'s
/// `std_coords_to_half_diff_coords` (the half vector h; the difference vector is `li`
/// rotated by −φh about the normal, then by −θh about the bitangent) and `lookup_brdf_val`'s
/// indexing, with `li` as its "in".
fn cell(li: Vec3, lo: Vec3) -> usize {
    let h = (li + lo).normalize_or(Vec3::Z);
    let theta_h = h.z.clamp(-1.0, 1.0).acos();
    let phi_h = h.y.atan2(h.x);
    let (sp, cp) = phi_h.sin_cos();
    let (st, ct) = theta_h.sin_cos();
    // About the normal by −φh, then about the bitangent (0, 1, 0) by −θh.
    let t = Vec3::new(li.x * cp + li.y * sp, li.y * cp - li.x * sp, li.z);
    let d = Vec3::new(t.x * ct - t.z * st, t.y, t.z * ct + t.x * st);
    let theta_d = d.z.clamp(-1.0, 1.0).acos();
    let mut phi_d = d.y.atan2(d.x);
    // `theta_half_index`: the square-root mapping.
    let ih = if theta_h <= 0.0 {
        0
    } else {
        ((theta_h / FRAC_PI_2 * THETA_H as f32 * THETA_H as f32).sqrt() as usize).min(THETA_H - 1)
    };
    // `theta_diff_index`.
    let id = ((theta_d / FRAC_PI_2 * THETA_D as f32) as usize).min(THETA_D - 1);
    // `phi_diff_index`: φd and φd + π are the same cell.
    if phi_d < 0.0 {
        phi_d += PI;
    }
    let ip = ((phi_d / PI * PHI_D as f32) as usize).min(PHI_D - 1);
    (ih * THETA_D + id) * PHI_D + ip
}

/// The bytes of a MERL file whose value in each cell is `g(θh, θd, φd)` at the cell's
/// centre, in the file's units (before the channel scales), per channel.
#[cfg(test)]
pub fn synthetic(g: impl Fn(f32, f32, f32) -> [f64; 3]) -> Vec<u8> {
    let mut out = Vec::with_capacity(12 + 3 * CELLS * 8);
    for d in [THETA_H, THETA_D, PHI_D] {
        out.extend((d as i32).to_le_bytes());
    }
    let mut blocks: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(CELLS));
    // Cell i of θh spans (π/2)(i/90)² to (π/2)((i+1)/90)².
    let edge = |i: f32| FRAC_PI_2 * (i / THETA_H as f32).powi(2);
    for ih in 0..THETA_H {
        let th = 0.5 * (edge(ih as f32) + edge(ih as f32 + 1.0));
        for id in 0..THETA_D {
            let td = (id as f32 + 0.5) * FRAC_PI_2 / THETA_D as f32;
            for ip in 0..PHI_D {
                let pd = (ip as f32 + 0.5) * PI / PHI_D as f32;
                for (block, v) in blocks.iter_mut().zip(g(th, td, pd)) {
                    block.push(v);
                }
            }
        }
    }
    for v in blocks.into_iter().flatten() {
        out.extend(v.to_le_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Short files and wrong dimensions are refused.
    #[test]
    fn bad_files_say_what_is_wrong() {
        let good = synthetic(|_, _, _| [1.0; 3]);
        let e = Merl::parse(&good[..8]).unwrap_err();
        assert!(e.contains("too short for a MERL"), "{e}");
        let e = Merl::parse(&good[..good.len() - 8]).unwrap_err();
        assert!(e.contains("34992004 bytes; a MERL BRDF"), "{e}");
        let mut wrong = good.clone();
        wrong[8..12].copy_from_slice(&360i32.to_le_bytes());
        let e = Merl::parse(&wrong).unwrap_err();
        assert!(e.contains("dimensions 90 × 90 × 360"), "{e}");
        assert!(Merl::parse(&good).is_ok());
    }

    /// Negative values (missing measurements) read as 0; the channels take their scales.
    #[test]
    fn missing_values_are_zero_and_channels_are_scaled() {
        let m = Merl::parse(&synthetic(
            |th, _, _| {
                if th > 0.5 {
                    [-1.0; 3]
                } else {
                    [1500.0; 3]
                }
            },
        ))
        .unwrap();
        // Directions in the x–z plane at signed angles from the normal: their half vector is
        // at the mean angle.
        let at = |a: f32| Vec3::new(a.sin(), 0.0, a.cos());
        let measured = Rgb::new(1.0, 1.15, 1.66);
        let near = |a: Rgb, b: Rgb| (a - b).abs().max_element() < 1e-6;
        assert!(near(m.eval(Vec3::Z, Vec3::Z), measured));
        assert!(near(m.eval(at(0.9), at(-0.1)), measured));
        assert!(near(m.eval(at(-1.3), at(0.5)), measured));
        assert_eq!(m.eval(at(1.2), at(0.2)), Rgb::ZERO);
    }
}
