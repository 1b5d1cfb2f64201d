//! The light basis and its reflectance series as bytes, stored in the network file before
//! the link table.

use super::{BasisLight, LightBasis, ReflectanceSeries, SeriesTerm, MAX_SERIES_TERMS};
use crate::binary_file::Reader;
use crate::integrators::illumination_network::{ESCAPE, NONE};
use crate::math::Rgb;
use rayon::prelude::*;

impl LightBasis {
    /// Bytes of the serialised basis.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::new();
        let u32s = |b: &mut Vec<u8>, v: &[u32]| {
            for x in v {
                b.extend_from_slice(&x.to_le_bytes());
            }
        };
        let rgbs = |b: &mut Vec<u8>, v: &[Rgb]| {
            for x in v {
                for c in 0..3 {
                    b.extend_from_slice(&x[c].to_le_bytes());
                }
            }
        };
        // A light's or a series' head ([`LightBasis::from_bytes`] reads it back).
        let named = |b: &mut Vec<u8>, material: u32, name: &str, sweeps: u32| {
            u32s(b, &[material, name.len() as u32, sweeps]);
            b.extend_from_slice(name.as_bytes());
        };
        b.extend_from_slice(&self.reflectance.to_le_bytes());
        b.extend_from_slice(&self.tolerance.to_le_bytes());
        b.extend_from_slice(&self.max_sweeps.to_le_bytes());
        b.extend_from_slice(&self.order.to_le_bytes());
        b.extend_from_slice(&self.seconds.to_le_bytes());
        u32s(
            &mut b,
            &[
                self.lights.len() as u32,
                self.dir_index.len() as u32,
                self.dir_rows.len() as u32,
            ],
        );
        u32s(&mut b, &self.dir_index);
        u32s(&mut b, &self.dir_rows);
        for l in &self.lights {
            named(&mut b, l.material, &l.name, l.sweeps);
            rgbs(&mut b, &[l.emission]);
            for v in l.balance.iter().flatten() {
                b.extend_from_slice(&v.to_le_bytes());
            }
            for part in [&l.diffuse, &l.direct, &l.directional, &l.incoming] {
                b.extend_from_slice(&(part.len() as u32).to_le_bytes());
                rgbs(&mut b, part);
            }
        }
        // The reflectance series follow the lights (a basis without them ends here, as
        // files written before them do).
        if !self.series.is_empty() {
            u32s(&mut b, &[self.series.len() as u32]);
        }
        for s in &self.series {
            named(&mut b, s.material, &s.name, s.sweeps);
            b.extend_from_slice(&s.others.to_le_bytes());
            u32s(&mut b, &[s.terms.len() as u32]);
            for t in &s.terms {
                for v in t.flux.iter().chain(&t.escaped) {
                    b.extend_from_slice(&v.to_le_bytes());
                }
                for part in [&t.diffuse, &t.direct] {
                    b.extend_from_slice(&(part.len() as u32).to_le_bytes());
                    rgbs(&mut b, part);
                }
            }
        }
        b
    }

    /// Parses [`LightBasis::to_bytes`] for a network of `nodes` nodes and `slots` slots, and
    /// checks that its contents are ones a distribution writes ([`LightBasis::check`]): the
    /// reason when they are not.
    pub fn from_bytes(bytes: &[u8], nodes: usize, slots: usize) -> Result<LightBasis, String> {
        let basis = Self::parse(bytes, nodes, slots)?;
        basis.check(nodes)?;
        Ok(basis)
    }

    /// The basis's sizes and values checked: the directional nodes numbered in node order,
    /// their rows' entries a node, an escape or no link, one light or series per material,
    /// every emission, radiance and flux finite, and the emissions and radiances not negative.
    fn check(&self, nodes: usize) -> Result<(), String> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(format!(
                "tolerance {} is not a positive number",
                self.tolerance
            ));
        }
        if self.order > 2 {
            return Err(format!(
                "distribution order {} is none raylink has",
                self.order
            ));
        }
        if !(self.seconds.is_finite() && self.seconds >= 0.0) {
            return Err(format!("time of {} s is not a duration", self.seconds));
        }
        let mut next = 0u32;
        for (node, &k) in self.dir_index.iter().enumerate() {
            if k != NONE {
                if k != next {
                    return Err(format!(
                        "directional node {k} at node {node}, where {next} comes next"
                    ));
                }
                next += 1;
            }
        }
        let bad_row = self
            .dir_rows
            .par_iter()
            .position_first(|&t| t != NONE && t != ESCAPE && t as usize >= nodes);
        if let Some(i) = bad_row {
            return Err(format!(
                "a directional row links to node {}, past the last ({})",
                self.dir_rows[i],
                nodes.saturating_sub(1)
            ));
        }
        let mut materials: Vec<u32> = self.lights.iter().map(|l| l.material).collect();
        if let Some(m) = repeated(&mut materials) {
            return Err(format!("two lights for material {m}"));
        }
        let mut materials: Vec<u32> = self.series.iter().map(|s| s.material).collect();
        if let Some(m) = repeated(&mut materials) {
            return Err(format!("two reflectance series for material {m}"));
        }
        let tol = self.tolerance;
        for l in &self.lights {
            let what = |part: &str| format!("light '{}': {part}", l.name);
            if !(0..3).all(|c| l.emission[c].is_finite() && l.emission[c] >= 0.0)
                || l.emission.max_element() <= 0.0
            {
                return Err(what(&format!(
                    "emission {} is not a positive colour",
                    l.emission
                )));
            }
            // The emitted flux is a sum of emissions; the others are signed sums where a
            // distribution has converged only to its tolerance (a little unshot flux may be
            // negative).
            for (name, v) in ["emitted", "escaped", "absorbed", "unshot"]
                .iter()
                .zip(&l.balance)
            {
                fluxes(v, *name == "emitted").map_err(|e| what(&format!("{name} flux {e}")))?;
            }
            for (name, part) in [
                ("diffuse", &l.diffuse),
                ("direct", &l.direct),
                ("directional", &l.directional),
                ("incoming", &l.incoming),
            ] {
                radiances(part, tol).map_err(|e| what(&format!("{name} radiance {e}")))?;
            }
        }
        for s in &self.series {
            for (n, t) in s.terms.iter().enumerate() {
                let what = |part: &str| format!("series '{}', term {n}: {part}", s.name);
                fluxes(&t.flux, false).map_err(|e| what(&format!("flux {e}")))?;
                fluxes(&t.escaped, false).map_err(|e| what(&format!("escaped flux {e}")))?;
                radiances(&t.diffuse, tol).map_err(|e| what(&format!("radiance {e}")))?;
                let direct = radiances(&t.direct, tol);
                direct.map_err(|e| what(&format!("direct radiance {e}")))?;
            }
        }
        Ok(())
    }

    /// The basis's bytes read, their counts checked against the network's.
    fn parse(bytes: &[u8], nodes: usize, slots: usize) -> Result<LightBasis, String> {
        // Every read that runs out of bytes says so.
        fn cut<T>(v: Option<T>) -> Result<T, String> {
            v.ok_or_else(|| "truncated".to_string())
        }
        let mut r = Reader { rest: bytes };
        let f64_of = |r: &mut Reader| cut(r.take::<8>()).map(f64::from_le_bytes);
        let mut basis = LightBasis {
            reflectance: cut(r.u64())?,
            tolerance: cut(r.f32())?,
            max_sweeps: cut(r.u32())?,
            order: cut(r.u32())?,
            seconds: f64_of(&mut r)?,
            ..LightBasis::default()
        };
        let n_lights = cut(r.u32())?;
        let (n_index, n_rows) = (cut(r.u32())? as usize, cut(r.u32())? as usize);
        let u32s = |r: &mut Reader, n: usize| -> Result<Vec<u32>, String> {
            if r.rest.len() / 4 < n {
                return cut(None);
            }
            let (a, rest) = r.rest.split_at(4 * n);
            r.rest = rest;
            Ok(a.chunks_exact(4)
                .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                .collect())
        };
        let rgbs = |r: &mut Reader, n: usize| -> Result<Vec<Rgb>, String> {
            if r.rest.len() / 12 < n {
                return cut(None);
            }
            let (a, rest) = r.rest.split_at(12 * n);
            r.rest = rest;
            Ok(a.par_chunks_exact(12)
                .map(|c| {
                    let f = |i: usize| f32::from_le_bytes(c[i..i + 4].try_into().unwrap());
                    Rgb::new(f(0), f(4), f(8))
                })
                .collect())
        };
        // A light's or a series' head: its material, name and sweeps.
        let named = |r: &mut Reader| -> Result<(u32, String, u32), String> {
            let (material, name_len) = (cut(r.u32())?, cut(r.u32())? as usize);
            let sweeps = cut(r.u32())?;
            if r.rest.len() < name_len {
                return cut(None);
            }
            let (name, rest) = r.rest.split_at(name_len);
            r.rest = rest;
            let name = String::from_utf8(name.to_vec())
                .map_err(|_| format!("the name of material {material} is not UTF-8"))?;
            Ok((material, name, sweeps))
        };
        if n_index != nodes {
            return Err(format!(
                "{n_index} directional-node entries for {nodes} nodes"
            ));
        }
        basis.dir_index = u32s(&mut r, n_index)?;
        let dir = basis.dir_index.iter().filter(|&&k| k != NONE).count();
        if n_rows as u64 != dir as u64 * slots as u64 {
            return Err(format!(
                "{n_rows} directional row entries for {dir} directional nodes of {slots} slots"
            ));
        }
        basis.dir_rows = u32s(&mut r, n_rows)?;
        for _ in 0..n_lights {
            let (material, name, sweeps) = named(&mut r)?;
            let emission = rgbs(&mut r, 1)?[0];
            let mut balance = [[0.0; 3]; 4];
            for v in balance.iter_mut().flatten() {
                *v = f64_of(&mut r)?;
            }
            let mut parts = Vec::new();
            for (part, want) in [
                ("diffuse", nodes),
                ("direct", nodes),
                ("directional", n_rows),
                ("incoming", n_rows),
            ] {
                let n = cut(r.u32())? as usize;
                if n != want {
                    return Err(format!(
                        "light '{name}' has {n} {part} radiances where {want} are needed"
                    ));
                }
                parts.push(rgbs(&mut r, n)?);
            }
            let [diffuse, direct, directional, incoming]: [Vec<Rgb>; 4] =
                parts.try_into().expect("four parts");
            basis.lights.push(BasisLight {
                material,
                name,
                emission,
                sweeps,
                balance,
                diffuse,
                direct,
                directional,
                incoming,
            });
        }
        let n_series = if r.rest.is_empty() { 0 } else { cut(r.u32())? };
        for _ in 0..n_series {
            let (material, name, sweeps) = named(&mut r)?;
            let others = cut(r.u64())?;
            let n_terms = cut(r.u32())? as usize;
            if n_terms == 0 || n_terms > MAX_SERIES_TERMS {
                return Err(format!(
                    "series '{name}' has {n_terms} terms (1 to {MAX_SERIES_TERMS})"
                ));
            }
            let mut terms = Vec::with_capacity(n_terms);
            for n in 0..n_terms {
                let mut term = SeriesTerm::default();
                for v in term.flux.iter_mut().chain(&mut term.escaped) {
                    *v = f64_of(&mut r)?;
                }
                // Every term has each node's radiance; terms 0 and 1 the direct light too.
                let direct_len = if n <= 1 { nodes } else { 0 };
                for (part, want) in [(&mut term.diffuse, nodes), (&mut term.direct, direct_len)] {
                    let got = cut(r.u32())? as usize;
                    if got != want {
                        return Err(format!(
                            "series '{name}', term {n}, has {got} radiances where {want} are \
                             needed"
                        ));
                    }
                    *part = rgbs(&mut r, want)?;
                }
                terms.push(term);
            }
            basis.series.push(ReflectanceSeries {
                material,
                name,
                others,
                sweeps,
                terms,
            });
        }
        if !r.rest.is_empty() {
            return Err(format!("{} bytes past its end", r.rest.len()));
        }
        Ok(basis)
    }
}

/// A material that `materials` holds twice, if any.
fn repeated(materials: &mut [u32]) -> Option<u32> {
    materials.sort_unstable();
    materials.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
}

/// Fluxes per channel: finite, and not negative when `positive`; else the first bad one.
fn fluxes(v: &[f64; 3], positive: bool) -> Result<(), String> {
    match v
        .iter()
        .find(|f| !(f.is_finite() && (**f >= 0.0 || !positive)))
    {
        Some(f) => Err(format!("{f} is negative or not finite")),
        None => Ok(()),
    }
}

/// Radiances: finite, and not negative beyond what a distribution converged to `tolerance`
/// (relative to the largest) leaves; else the first bad one and its index.
fn radiances(v: &[Rgb], tolerance: f32) -> Result<(), String> {
    let finite = |x: &Rgb| (0..3).all(|c| x[c].is_finite());
    let largest = v
        .par_iter()
        .map(|x| {
            if finite(x) {
                x.abs().max_element()
            } else {
                0.0
            }
        })
        .reduce(|| 0.0, f32::max);
    let floor = -tolerance * largest;
    let ok = |x: &Rgb| finite(x) && x.min_element() >= floor;
    match v.par_iter().position_first(|x| !ok(x)) {
        Some(i) => Err(format!("{} at entry {i} is negative or not finite", v[i])),
        None => Ok(()),
    }
}
