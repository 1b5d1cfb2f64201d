//! The light basis and its reflectance series as bytes, stored in the network file before
//! the link table.

use super::{BasisLight, LightBasis, ReflectanceSeries, SeriesTerm, MAX_SERIES_TERMS};
use crate::binary_file::Reader;
use crate::integrators::illumination_network::NONE;
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

    /// Parses [`LightBasis::to_bytes`] for a network of `nodes` nodes and `slots` slots.
    pub fn from_bytes(bytes: &[u8], nodes: usize, slots: usize) -> Option<LightBasis> {
        let mut r = Reader { rest: bytes };
        let mut basis = LightBasis {
            reflectance: r.u64()?,
            tolerance: r.f32()?,
            max_sweeps: r.u32()?,
            order: r.u32()?,
            seconds: f64::from_le_bytes(r.take::<8>()?),
            ..LightBasis::default()
        };
        let (n_lights, n_index, n_rows) = (r.u32()?, r.u32()? as usize, r.u32()? as usize);
        let u32s = |r: &mut Reader, n: usize| -> Option<Vec<u32>> {
            if r.rest.len() < 4 * n {
                return None;
            }
            let (a, rest) = r.rest.split_at(4 * n);
            r.rest = rest;
            Some(
                a.chunks_exact(4)
                    .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
            )
        };
        let rgbs = |r: &mut Reader, n: usize| -> Option<Vec<Rgb>> {
            if r.rest.len() < 12 * n {
                return None;
            }
            let (a, rest) = r.rest.split_at(12 * n);
            r.rest = rest;
            Some(
                a.par_chunks_exact(12)
                    .map(|c| {
                        let f = |i: usize| f32::from_le_bytes(c[i..i + 4].try_into().unwrap());
                        Rgb::new(f(0), f(4), f(8))
                    })
                    .collect(),
            )
        };
        // A light's or a series' head: its material, name and sweeps.
        let named = |r: &mut Reader| -> Option<(u32, String, u32)> {
            let (material, name_len, sweeps) = (r.u32()?, r.u32()? as usize, r.u32()?);
            if r.rest.len() < name_len {
                return None;
            }
            let (name, rest) = r.rest.split_at(name_len);
            r.rest = rest;
            Some((material, String::from_utf8(name.to_vec()).ok()?, sweeps))
        };
        basis.dir_index = u32s(&mut r, n_index)?;
        basis.dir_rows = u32s(&mut r, n_rows)?;
        let dir = basis.dir_index.iter().filter(|&&k| k != NONE).count();
        if n_index != nodes || n_rows != dir * slots {
            return None;
        }
        for _ in 0..n_lights {
            let (material, name, sweeps) = named(&mut r)?;
            let emission = rgbs(&mut r, 1)?[0];
            let mut balance = [[0.0; 3]; 4];
            for v in balance.iter_mut().flatten() {
                *v = f64::from_le_bytes(r.take::<8>()?);
            }
            let mut parts = Vec::new();
            for want in [nodes, nodes, n_rows, n_rows] {
                let n = r.u32()? as usize;
                if n != want {
                    return None;
                }
                parts.push(rgbs(&mut r, n)?);
            }
            let incoming = parts.pop()?;
            let directional = parts.pop()?;
            let direct = parts.pop()?;
            let diffuse = parts.pop()?;
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
        let n_series = if r.rest.is_empty() { 0 } else { r.u32()? };
        for _ in 0..n_series {
            let (material, name, sweeps) = named(&mut r)?;
            let others = r.u64()?;
            let n_terms = r.u32()? as usize;
            if n_terms == 0 || n_terms > MAX_SERIES_TERMS {
                return None;
            }
            let mut terms = Vec::with_capacity(n_terms);
            for n in 0..n_terms {
                let mut term = SeriesTerm::default();
                for v in term.flux.iter_mut().chain(&mut term.escaped) {
                    *v = f64::from_le_bytes(r.take::<8>()?);
                }
                // Every term has each node's radiance; terms 0 and 1 the direct light too.
                let direct_len = if n <= 1 { nodes } else { 0 };
                for (part, want) in [(&mut term.diffuse, nodes), (&mut term.direct, direct_len)] {
                    if r.u32()? as usize != want {
                        return None;
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
        r.rest.is_empty().then_some(basis)
    }
}
