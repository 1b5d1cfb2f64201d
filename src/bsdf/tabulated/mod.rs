//! A reflectance given as a table: samples of the BRDF f(θi, φi, θo, φo) on a grid of
//! angles in the surface's shading frame, read from a text file and interpolated
//! multilinearly. With a single φi the BRDF is isotropic: it depends on φo − φi only. A
//! file named `*.binary` is instead a MERL measured BRDF (the `merl` module).
//!
//! The file (`docs/scene-format.md`, "Tabulated BRDFs", documents it):
//!
//! ```text
//! # comments and blank lines are skipped
//! theta_i 0 30 60 90        # degrees from the normal, increasing, within [0, 90]
//! phi_i 0                   # degrees, increasing, within [0, 360): one value = isotropic
//! theta_o 0 30 60 90
//! phi_o 0 90 180 270        # the azimuth wraps around from the last value to the first
//! values
//! 0.3                       # f in 1/sr: one value (grey) or three (r g b) per line,
//! 0.25 0.3 0.31             # θi slowest, then φi, θo, and φo fastest
//! ```

mod merl;
mod sampling;

use crate::math::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::math::{Rgb, Vec2, Vec3};
#[cfg(test)]
pub use merl::synthetic as synthetic_merl;
use merl::Merl;
use sampling::Sampler;
use std::f32::consts::{PI, TAU};
use std::path::{Path, PathBuf};

/// The share of a table's samples drawn from its own distribution ([`TabulatedBrdf::sample`]);
/// the rest follow the cosine, so every direction where f > 0 can be drawn.
pub const TABLE_SHARE: f32 = 0.9;

/// A tabulated BRDF.
#[derive(Debug, PartialEq)]
pub struct TabulatedBrdf {
    /// The file as the scene names it (empty for a table made in code).
    pub file: PathBuf,
    /// The grid's angles in radians, per axis: θi, φi, θo, φo.
    axes: [Vec<f32>; 4],
    /// f per grid point, φo fastest.
    values: Vec<Rgb>,
    /// The largest directional albedo ∫ f cos θi dωi over the outgoing angles, per channel.
    most_reflected: Rgb,
    /// A hash of the grid and values: what a saved solution made with the table checks.
    digest: u64,
    /// Importance sampling of the table; `None` for a constant table (sampled by the cosine).
    sampler: Option<Sampler>,
    /// A MERL measured BRDF, which `eval` looks up; the grid then holds it sampled on a
    /// grid of angles for the sampling structure only.
    merl: Option<Merl>,
}

/// One axis's place of an angle: the two grid indices around it and the weight of the second.
type Place = [(usize, f32); 2];

impl TabulatedBrdf {
    /// A table from its axes (in degrees) and values (φo fastest); `Err` says what is wrong.
    pub fn new(axes_degrees: [Vec<f32>; 4], values: Vec<Rgb>) -> Result<TabulatedBrdf, String> {
        const NAMES: [&str; 4] = ["theta_i", "phi_i", "theta_o", "phi_o"];
        for (k, axis) in axes_degrees.iter().enumerate() {
            let name = NAMES[k];
            let limit = if k % 2 == 0 { 90.0 } else { 360.0 };
            if axis.is_empty() {
                return Err(format!("{name} has no angle"));
            }
            if let Some(a) = axis.iter().find(|a| !(0.0..=limit).contains(*a)) {
                return Err(format!("{name}: {a} is outside [0, {limit}]"));
            }
            if k % 2 == 1 && axis.contains(&360.0) {
                return Err(format!("{name}: 360 is 0; give azimuths within [0, 360)"));
            }
            if axis.windows(2).any(|w| w[1] <= w[0]) {
                return Err(format!("{name}: the angles must increase"));
            }
        }
        let count = (axes_degrees.iter())
            .try_fold(1usize, |n, a| n.checked_mul(a.len()))
            .unwrap_or(usize::MAX);
        if values.len() != count {
            return Err(format!(
                "{} values for a grid of {} ({} × {} × {} × {})",
                values.len(),
                count,
                axes_degrees[0].len(),
                axes_degrees[1].len(),
                axes_degrees[2].len(),
                axes_degrees[3].len()
            ));
        }
        if let Some(v) = values
            .iter()
            .find(|v| !v.is_finite() || v.min_element() < 0.0)
        {
            return Err(format!("values must be finite and not negative, got {v}"));
        }
        let axes: [Vec<f32>; 4] = axes_degrees.map(|a| a.iter().map(|d| d.to_radians()).collect());
        let bits = axes
            .iter()
            .flatten()
            .copied()
            .chain(values.iter().flat_map(|v| v.to_array()));
        let bytes: Vec<u8> = bits.flat_map(|x| x.to_bits().to_le_bytes()).collect();
        let digest = crate::binary_file::fnv1a(&bytes);
        Ok(Self::assemble(axes, values, None, digest))
    }

    /// The table of a grid (angles in radians) or of a MERL BRDF with its grid for
    /// sampling: the albedo and sampling structure computed.
    fn assemble(
        axes: [Vec<f32>; 4],
        values: Vec<Rgb>,
        merl: Option<Merl>,
        digest: u64,
    ) -> TabulatedBrdf {
        let mut table = TabulatedBrdf {
            file: PathBuf::new(),
            axes,
            values,
            most_reflected: Rgb::ZERO,
            digest,
            sampler: None,
            merl,
        };
        table.most_reflected = table.largest_albedo();
        table.sampler = Sampler::build(&table);
        table
    }

    /// A MERL measured BRDF from the bytes of its file (the `merl` module describes the
    /// format); `Err` says what is wrong.
    pub fn from_merl(bytes: &[u8]) -> Result<TabulatedBrdf, String> {
        let merl = Merl::parse(bytes)?;
        // The grid the sampling structure is built on: every 2° in θ, 5° in φo − φi.
        let thetas: Vec<f32> = (0..=45).map(|k| (2 * k) as f32).collect();
        let phis: Vec<f32> = (0..72).map(|k| (5 * k) as f32).collect();
        let dir = |t: f32, p: f32| {
            let (t, p) = (t.min(89.9).to_radians(), p.to_radians());
            Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
        };
        let mut values = Vec::with_capacity(thetas.len() * thetas.len() * phis.len());
        for &ti in &thetas {
            for &to in &thetas {
                for &po in &phis {
                    values.push(merl.eval(dir(ti, 0.0), dir(to, po)));
                }
            }
        }
        let radians = |a: &[f32]| a.iter().map(|d| d.to_radians()).collect::<Vec<f32>>();
        let axes = [
            radians(&thetas),
            vec![0.0],
            radians(&thetas),
            radians(&phis),
        ];
        let digest = crate::binary_file::fnv1a(bytes);
        Ok(Self::assemble(axes, values, Some(merl), digest))
    }

    /// Reads the text format of the module documentation from `path`, which the scene
    /// names `file`; errors name the file and line.
    pub fn read(path: &Path, file: PathBuf) -> Result<TabulatedBrdf, String> {
        if path.extension().is_some_and(|e| e == "binary") {
            let bytes = crate::input_file::read(path, &crate::input_file::MERL, None)
                .map_err(|e| e.to_string())?;
            let table = Self::from_merl(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
            return Ok(TabulatedBrdf { file, ..table });
        }
        let text = crate::input_file::read_to_string(path, &crate::input_file::BRDF_TABLE, None)
            .map_err(|e| e.to_string())?;
        let table = Self::parse(&text).map_err(|e| format!("{}:{e}", path.display()))?;
        Ok(TabulatedBrdf { file, ..table })
    }

    /// [`TabulatedBrdf::read`] from the file's text; errors start with the line number.
    pub fn parse(text: &str) -> Result<TabulatedBrdf, String> {
        const NAMES: [&str; 4] = ["theta_i", "phi_i", "theta_o", "phi_o"];
        let mut axes: [Option<Vec<f32>>; 4] = Default::default();
        let mut values = Vec::new();
        let mut in_values = false;
        let mut last = 0;
        // The line of each axis, for its errors.
        let mut axis_lines = [0; 4];
        for (i, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            let at = i + 1;
            if line.is_empty() {
                continue;
            }
            last = at;
            let mut words = line.split_whitespace();
            let numbers = |words: std::str::SplitWhitespace| {
                words
                    .map(|w| {
                        w.parse::<f32>()
                            .map_err(|_| format!("{at}: \"{w}\" is not a number"))
                    })
                    .collect::<Result<Vec<f32>, String>>()
            };
            if in_values {
                let v = numbers(words)?;
                let value = match v[..] {
                    [g] => Rgb::splat(g),
                    [r, g, b] => Rgb::new(r, g, b),
                    _ => return Err(format!("{at}: a value is one number or three (r g b)")),
                };
                if !value.is_finite() || value.min_element() < 0.0 {
                    return Err(format!(
                        "{at}: values must be finite and not negative, got {value}"
                    ));
                }
                values.push(value);
                continue;
            }
            let key = words.next().unwrap_or("");
            if key == "values" {
                if let Some(k) = axes.iter().position(Option::is_none) {
                    return Err(format!("{at}: {} must come before the values", NAMES[k]));
                }
                in_values = true;
                continue;
            }
            let Some(k) = NAMES.iter().position(|n| *n == key) else {
                return Err(format!(
                    "{at}: unknown key \"{key}\"; expected theta_i, phi_i, theta_o, phi_o or values"
                ));
            };
            if axes[k].is_some() {
                return Err(format!("{at}: {key} is given twice"));
            }
            axes[k] = Some(numbers(words)?);
            axis_lines[k] = at;
        }
        if !in_values {
            return Err(format!("{}: no \"values\" line", last.max(1)));
        }
        let axes = axes.map(Option::unwrap_or_default);
        TabulatedBrdf::new(axes, values).map_err(|e| {
            // An axis's error names the axis first: point at its line.
            let line = (NAMES.iter().zip(axis_lines))
                .find(|(name, _)| e.starts_with(*name))
                .map_or(last, |(_, line)| line);
            format!("{line}: {e}")
        })
    }

    /// f for light arriving along local direction `li` and leaving along `lo` (both in the
    /// shading frame, on the side of its normal).
    pub fn eval(&self, li: Vec3, lo: Vec3) -> Rgb {
        if let Some(merl) = &self.merl {
            return merl.eval(li, lo);
        }
        let (ti, pi) = angles(li);
        let (to, po) = angles(lo);
        let [a_ti, a_pi, a_to, a_po] = &self.axes;
        // Isotropic: φo measured from φi, placed at the table's one φi.
        let (pi, po) = if a_pi.len() == 1 {
            (a_pi[0], (po - pi + a_pi[0]).rem_euclid(TAU))
        } else {
            (pi, po)
        };
        let places = [
            clamped(a_ti, ti),
            wrapped(a_pi, pi),
            clamped(a_to, to),
            wrapped(a_po, po),
        ];
        let sizes = [a_pi.len(), a_to.len(), a_po.len()];
        let mut f = Rgb::ZERO;
        for corner in 0..16 {
            let mut index = 0;
            let mut weight = 1.0;
            for (axis, place) in places.iter().enumerate() {
                let (i, w) = place[(corner >> axis) & 1];
                index = if axis == 0 {
                    i
                } else {
                    index * sizes[axis - 1] + i
                };
                weight *= w;
            }
            if weight > 0.0 {
                f += self.values[index] * weight;
            }
        }
        f
    }

    /// A direction (local, upper hemisphere) sampled given local direction `given`: with
    /// probability [`TABLE_SHARE`] from the table's distribution for `given` (chosen by
    /// `u_lobe`), otherwise by the cosine; a constant table always by the cosine (`u`
    /// alone). The same whichever argument of f `given` is: see the `sampling` module.
    pub fn sample(&self, given: Vec3, u_lobe: f32, u: Vec2) -> Vec3 {
        let cosine_share = 1.0 - TABLE_SHARE;
        match &self.sampler {
            Some(s) if u_lobe >= cosine_share => {
                let u_row = ((u_lobe - cosine_share) / TABLE_SHARE).min(1.0 - f32::EPSILON);
                s.sample(given, u_row, [u.x, u.y])
            }
            _ => cosine_hemisphere(u),
        }
    }

    /// The density in solid angle with which [`TabulatedBrdf::sample`] draws `sampled`
    /// given `given` (both local).
    pub fn pdf(&self, given: Vec3, sampled: Vec3) -> f32 {
        let cosine = cosine_hemisphere_pdf(sampled.z);
        match &self.sampler {
            Some(s) => (1.0 - TABLE_SHARE) * cosine + TABLE_SHARE * s.pdf(given, sampled),
            None => cosine,
        }
    }

    /// A hash of the table's grid and values.
    pub fn digest(&self) -> u64 {
        self.digest
    }

    /// The largest directional albedo over the outgoing directions, per channel (light that
    /// arrives evenly from the whole hemisphere, leaving toward the worst direction).
    pub fn most_reflected(&self) -> Rgb {
        self.most_reflected
    }

    /// The directional albedo toward local direction `lo`: ∫ f(li, lo) cos θi dωi, by the
    /// midpoint rule over 64 × 128 cells in (cos² θi, φi), where cos θi dωi is uniform.
    pub fn albedo(&self, lo: Vec3) -> Rgb {
        let (nu, nv) = (64, 128);
        let mut sum = Rgb::ZERO;
        for i in 0..nu {
            let c2 = (i as f32 + 0.5) / nu as f32;
            let (c, s) = (c2.sqrt(), (1.0 - c2).sqrt());
            // Summed by rings: a sum of 8,192 in f32 would lose 1e-4 of it.
            let mut ring = Rgb::ZERO;
            for j in 0..nv {
                let phi = TAU * (j as f32 + 0.5) / nv as f32;
                ring += self.eval(Vec3::new(s * phi.cos(), s * phi.sin(), c), lo);
            }
            sum += ring;
        }
        // cos θ dω = ½ d(cos² θ) dφ: the cell's weight is π / cells.
        sum * (PI / (nu * nv) as f32)
    }

    fn largest_albedo(&self) -> Rgb {
        // An isotropic table reflects alike toward every φo: one azimuth is enough.
        let phis = if self.axes[1].len() == 1 {
            &self.axes[3][..1]
        } else {
            &self.axes[3][..]
        };
        let mut most = Rgb::ZERO;
        for &t in &self.axes[2] {
            for &p in phis {
                let lo = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos().max(1e-4));
                most = most.max(self.albedo(lo.normalize()));
            }
        }
        most
    }
}

/// (θ, φ) of a local direction, φ within [0, 2π).
fn angles(v: Vec3) -> (f32, f32) {
    let theta = v.z.clamp(-1.0, 1.0).acos();
    let phi = v.y.atan2(v.x).rem_euclid(TAU);
    (theta, phi)
}

/// The grid indices around `x` on an axis of increasing angles, held at its ends.
fn clamped(axis: &[f32], x: f32) -> Place {
    let n = axis.len();
    if n == 1 || x <= axis[0] {
        return [(0, 1.0), (0, 0.0)];
    }
    if x >= axis[n - 1] {
        return [(n - 1, 1.0), (n - 1, 0.0)];
    }
    let k = axis.partition_point(|&a| a <= x).clamp(1, n - 1);
    let w = (x - axis[k - 1]) / (axis[k] - axis[k - 1]);
    [(k - 1, 1.0 - w), (k, w)]
}

/// The grid indices around azimuth `x` (within [0, 2π)) on an axis that wraps around from
/// its last angle to its first.
fn wrapped(axis: &[f32], x: f32) -> Place {
    let n = axis.len();
    if n == 1 {
        return [(0, 1.0), (0, 0.0)];
    }
    let k = axis.partition_point(|&a| a <= x);
    let (lo, hi) = if k == 0 || k == n {
        (n - 1, 0)
    } else {
        (k - 1, k)
    };
    let (a, mut b) = (axis[lo], axis[hi]);
    let mut x = x;
    if hi <= lo {
        b += TAU;
        if x < a {
            x += TAU;
        }
    }
    let w = ((x - a) / (b - a)).clamp(0.0, 1.0);
    [(lo, 1.0 - w), (hi, w)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
        let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    /// A grid holding a linear function of the four angles is interpolated exactly between
    /// its points (multilinear interpolation reproduces a function linear in each axis), and
    /// the azimuth wraps from 270° back to 0°.
    #[test]
    fn interpolation_is_exact_for_linear_functions() {
        let axes = [
            vec![0.0, 40.0, 80.0],
            vec![0.0, 180.0],
            vec![10.0, 50.0, 90.0],
            vec![0.0, 90.0, 180.0, 270.0],
        ];
        let g = |ti: f32, pi: f32, to: f32, po: f32| {
            1.0 + ti / 90.0 + 0.5 * to / 90.0 + 0.1 * (pi / 180.0) + 0.01 * po / 90.0
        };
        let mut values = Vec::new();
        for &ti in &axes[0] {
            for &pi in &axes[1] {
                for &to in &axes[2] {
                    for &po in &axes[3] {
                        values.push(Rgb::splat(g(ti, pi, to, po)));
                    }
                }
            }
        }
        let t = TabulatedBrdf::new(axes, values).unwrap();
        let f = t.eval(dir(20.0, 90.0), dir(30.0, 45.0)).x;
        assert!((f - g(20.0, 90.0, 30.0, 45.0)).abs() < 1e-4, "{f}");
        // Between 270° and 360° (= 0°): halfway from g(…, 270) to g(…, 0).
        let f = t.eval(dir(40.0, 0.0), dir(50.0, 315.0)).x;
        let want = 0.5 * (g(40.0, 0.0, 50.0, 270.0) + g(40.0, 0.0, 50.0, 0.0));
        assert!((f - want).abs() < 1e-4, "{f} vs {want}");
    }

    /// An isotropic table (one φi) depends on φo − φi alone.
    #[test]
    fn one_phi_i_is_isotropic() {
        let t = TabulatedBrdf::parse(
            "theta_i 0 90\nphi_i 0\ntheta_o 0 90\nphi_o 0 180\nvalues\n1\n2\n3\n4\n5\n6\n7\n8\n",
        )
        .unwrap();
        let a = t.eval(dir(30.0, 10.0), dir(45.0, 100.0));
        let b = t.eval(dir(30.0, 200.0), dir(45.0, 290.0));
        assert!((a - b).abs().max_element() < 1e-5, "{a} vs {b}");
        assert_ne!(a, t.eval(dir(30.0, 10.0), dir(45.0, 10.0)));
    }

    /// A constant table ρ/π reflects ρ toward every direction.
    #[test]
    fn a_constant_table_has_albedo_rho() {
        let t = TabulatedBrdf::parse(&format!(
            "theta_i 0\nphi_i 0\ntheta_o 0\nphi_o 0\nvalues\n{}\n",
            0.6 / PI
        ))
        .unwrap();
        for lo in [dir(0.0, 0.0), dir(70.0, 30.0)] {
            assert!((t.albedo(lo) - Rgb::splat(0.6)).abs().max_element() < 1e-4);
        }
        assert!((t.most_reflected() - Rgb::splat(0.6)).abs().max_element() < 1e-4);
    }

    /// Bad files are refused with the line and the problem.
    #[test]
    fn bad_tables_name_the_line() {
        let head = "theta_i 0 90\nphi_i 0\ntheta_o 0 90\nphi_o 0\n";
        for (text, want) in [
            (
                format!("{head}values\n1\n2\n3\n"),
                "8: 3 values for a grid of 4",
            ),
            (
                format!("{head}values\n1\n2 x 3\n"),
                "7: \"x\" is not a number",
            ),
            (
                format!("{head}values\n1\n1 2\n"),
                "7: a value is one number or three",
            ),
            ("theta_i 0 95\n".to_string(), "1: no \"values\""),
            (
                "theta_i 0 95\nphi_i 0\ntheta_o 0\nphi_o 0\nvalues\n1\n2\n".into(),
                "1: theta_i: 95 is outside [0, 90]",
            ),
            ("theta_i 0\nvalues\n".into(), "2: phi_i must come before"),
            ("gamma 1\n".into(), "1: unknown key \"gamma\""),
            (
                format!("{head}values\n1\n-1\n1\n1\n"),
                "7: values must be finite",
            ),
            ("phi_o 0 90 45\nphi_o 1\n".into(), "2: phi_o is given twice"),
        ] {
            let e = TabulatedBrdf::parse(&text).unwrap_err();
            assert!(e.starts_with(want), "{e:?} should start with {want:?}");
        }
    }
}
