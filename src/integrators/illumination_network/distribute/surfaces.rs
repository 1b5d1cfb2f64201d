//! The nodes' surfaces from the scene's materials, and the check that light can leave.

use crate::bsdf::{Bsdf, Lobes, TabulatedBrdf};
use crate::integrators::illumination_network::{Network, ESCAPE, NONE};
use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::{Classic, Conductor, Material, Scene};
use std::sync::Arc;

/// The surface of one node.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Surface {
    pub kd: Rgb,
    /// The specular lobe's reflectance at normal incidence (a metal's Fresnel included).
    pub ks: Rgb,
    pub kt: Rgb,
    /// Lambertian transmission (a translucent sheet), carried by the tables as the other
    /// directional lobes.
    pub kdt: Rgb,
    pub alpha: f32,
    /// What else the directional lobes' BSDF is made of.
    pub optics: Optics,
    /// Emitted radiance (fronts of emissive materials only).
    pub emission: Rgb,
    /// A mix: the directional lobes above are weighted by 1 − amount, and another
    /// surface's by amount (kd is already the blend of the two).
    pub blend: Option<Arc<Blend>>,
}

/// The second material of a mix, as the network carries it.
#[derive(Clone, Debug, PartialEq)]
pub struct Blend {
    /// Its directional lobes (its kd and emission are zero).
    pub other: Surface,
    pub amount: f32,
}

/// A node material's optics besides its coefficients: the directional lobes scatter as the
/// path tracer's BSDF of the same material without its diffuse lobe.
#[derive(Clone, Debug, PartialEq)]
pub struct Optics {
    /// ks before a metal's Fresnel reflectance.
    pub specular: Rgb,
    pub ior: f32,
    pub fresnel: bool,
    /// A thin sheet: transmission straight on, the sheet's reflectance for Fresnel's.
    pub thin: bool,
    pub conductor: Option<Conductor>,
    /// A tabulated reflectance: then the only lobe (ks is its largest albedo).
    pub brdf: Option<Arc<TabulatedBrdf>>,
}

impl Default for Optics {
    fn default() -> Self {
        Optics {
            specular: Rgb::ZERO,
            ior: 1.0,
            fresnel: false,
            thin: false,
            conductor: None,
            brdf: None,
        }
    }
}

impl Surface {
    pub fn directional(&self) -> bool {
        self.parts().any(|(_, p)| p.has_own_lobes())
    }

    /// Whether the surface has directional lobes of its own (a mix's other part aside).
    pub fn has_own_lobes(&self) -> bool {
        self.ks.max_element() > 0.0 || self.kt.max_element() > 0.0 || self.kdt.max_element() > 0.0
    }

    /// The surfaces whose directional lobes this one scatters by, with their weights: itself
    /// (its own lobes), and for a mix the other material's too.
    pub fn parts(&self) -> impl Iterator<Item = (f32, &Surface)> {
        let amount = self.blend.as_ref().map_or(0.0, |b| b.amount);
        let other = self.blend.as_ref().map(|b| (b.amount, &b.other));
        std::iter::once((1.0 - amount, self))
            .chain(other)
            .filter(|(w, _)| *w > 0.0)
    }

    /// The bits of this surface's own directional lobes (ks, kt, kdt, α and optics; not a
    /// mix's other part): equal keys, equal lobes.
    pub fn lobe_key(&self) -> Vec<u32> {
        let o = &self.optics;
        let mut key = Vec::with_capacity(24);
        for v in [self.ks, self.kt, self.kdt, o.specular] {
            key.extend(v.to_array().map(f32::to_bits));
        }
        key.extend([
            self.alpha.to_bits(),
            o.ior.to_bits(),
            u32::from(o.fresnel),
            u32::from(o.thin),
        ]);
        if let Some(c) = o.conductor {
            key.extend(c.eta.to_array().map(f32::to_bits));
            key.extend(c.k.to_array().map(f32::to_bits));
        }
        if let Some(t) = &o.brdf {
            let d = t.digest();
            key.extend([d as u32, (d >> 32) as u32]);
        }
        key
    }

    /// The most the surface scatters of the light from one direction, per channel, as the
    /// network bounds it: kd plus the weighted ks + kt + kdt of its parts.
    pub fn scattered(&self) -> Rgb {
        self.kd
            + self
                .parts()
                .map(|(w, p)| (p.ks + p.kt + p.kdt) * w)
                .sum::<Rgb>()
    }

    /// The BSDF of the directional lobes (specular and transmission) at a node with unit
    /// normal `n` (facing the node's side) on a patch whose geometric normal is `ng`
    /// (orientation tells a transmitting material's inside from its outside).
    pub(crate) fn directional_bsdf(&self, ng: Vec3, n: Vec3) -> Bsdf<'_> {
        if let Some(table) = &self.optics.brdf {
            return Bsdf::tabulated(table, n, n);
        }
        let o = &self.optics;
        let lobes = Lobes {
            kd: Rgb::ZERO,
            kdt: self.kdt,
            ks: o.specular,
            kt: self.kt,
            ior: o.ior,
            alphas: (self.alpha, self.alpha),
            fresnel: o.fresnel,
            thin: o.thin,
            conductor: o.conductor,
            lambertian: !o.fresnel
                && o.specular.max_element() <= 0.0
                && self.kt.max_element() <= 0.0
                && self.kdt.max_element() <= 0.0,
            spectral: Default::default(),
        };
        // Oriented as a material's BSDF is toward n: an opaque surface faces n's side.
        let face = if self.kt.max_element() <= 0.0 && n.dot(ng) < 0.0 {
            -ng
        } else {
            ng
        };
        Bsdf::of_lobes(&lobes, face, face)
    }
}

/// The most material `m` (with diffuse colour `kd` at the point) can reflect and transmit of
/// the light arriving from one direction, per channel: kd + ks + kt, or with Fresnel weighting,
/// where ks takes F and kd and kt share 1 − F, the larger of ks and kd + kt (a glass is
/// ks = kt = 1); plus kdt, which Fresnel does not weight. The network scales a material down
/// to at most 1.
fn most_scattered(m: &Classic, table: Option<&Arc<TabulatedBrdf>>, kd: Rgb, kdt: Rgb) -> Rgb {
    let (ks, kt) = (m.specular_at_normal(), m.transmission);
    if let Some(table) = table {
        table.most_reflected()
    } else if m.fresnel {
        ks.max(kd + kt) + kdt
    } else {
        kd + ks + kt + kdt
    }
}

/// The nodes' surfaces from the scene's materials (diffuse textures are evaluated at the
/// patch centre).
pub fn surfaces(net: &Network, scene: &Scene, light_scale: f32) -> Vec<Surface> {
    let emission: Vec<Rgb> = scene
        .materials
        .iter()
        .map(|m| m.emission * light_scale)
        .collect();
    surfaces_with(net, scene, &emission)
}

/// [`surfaces`] with the emission of each material given (indexed as `scene.materials`):
/// relighting distributes one emissive material at a time.
pub fn surfaces_with(net: &Network, scene: &Scene, emission: &[Rgb]) -> Vec<Surface> {
    (0..net.nodes() as u32)
        .map(|node| {
            let (poly, cell, side) = net.node_place(node);
            let pg = &net.patches.polygons[poly as usize];
            let mi = scene.shapes[pg.shape as usize].material;
            let m = &scene.materials[mi];
            let (s, t) = pg.cell_centre(cell);
            let local = pg.point(s, t);
            let p = net.space.to_world(local);
            // The geometric normal, for textures that depend on it.
            let n = match pg.sphere {
                Some((centre, _)) => (local - centre).normalize_or_zero(),
                None => pg.n.normalize_or_zero(),
            };
            Surface {
                emission: if side == 0 || m.two_sided_emission {
                    emission[mi]
                } else {
                    Rgb::ZERO
                },
                ..surface_of(scene, mi, p, Vec2::new(s, t), n)
            }
        })
        .collect()
}

/// The surface (without emission) of material `mi` at point `p` with texture coordinates
/// `uv` and geometric normal `n`. A mix blends its two materials: their diffuse colours, and their directional lobes
/// through [`Blend`]; a material of a nested mix is its material with the larger weight.
fn surface_of(scene: &Scene, mi: usize, p: Vec3, uv: Vec2, n: Vec3) -> Surface {
    let m = &scene.materials[mi];
    let Some(mix) = m.mix() else {
        return plain_surface(m, p, uv, n);
    };
    let [a, b] = mix
        .materials
        .map(|i| plain_surface(&scene.materials[i], p, uv, n));
    let t = mix.amount;
    Surface {
        kd: a.kd * (1.0 - t) + b.kd * t,
        blend: Some(Arc::new(Blend {
            other: Surface { kd: Rgb::ZERO, ..b },
            amount: t,
        })),
        ..a
    }
}

/// The diffuse colour the network gives material `mi` at `p` (scaled down with the rest of
/// the material to scatter at most all the light; a mix's blend).
pub(crate) fn network_kd(scene: &Scene, mi: usize, p: Vec3, uv: Vec2, n: Vec3) -> Rgb {
    surface_of(scene, mi, p, uv, n).kd
}

/// The surface of a material that is not a mix (as its material with the larger weight
/// otherwise): its approximation in Whitted's terms, or its table.
fn plain_surface(material: &Material, p: Vec3, uv: Vec2, n: Vec3) -> Surface {
    let m = material.approximation();
    let table = material.model().table();
    let kd = m.diffuse.eval(p, uv, n);
    let (mut kd, mut ks, mut kt) = (kd, m.specular_at_normal(), m.transmission);
    let mut kdt = m.diffuse_transmission.eval(p, uv, n);
    let mut specular = m.specular;
    if let Some(table) = table {
        (kd, ks, specular) = (Rgb::ZERO, table.most_reflected(), Rgb::ZERO);
    }
    let total = most_scattered(m, table, kd, kdt);
    for c in 0..3 {
        if total[c] > 1.0 {
            kd[c] /= total[c];
            ks[c] /= total[c];
            kt[c] /= total[c];
            kdt[c] /= total[c];
            specular[c] /= total[c];
        }
    }
    Surface {
        kd,
        ks,
        kt,
        kdt,
        // An anisotropic lobe becomes the isotropic one of mean α; a thin sheet is smooth
        // (its transmission is the straight line on).
        alpha: match m.roughness_v {
            _ if m.thin => 0.0,
            // A table may reflect anywhere: the widest lobe.
            _ if table.is_some() => 1.0,
            Some(v) => 0.5 * (m.roughness + v),
            None => m.roughness,
        },
        optics: Optics {
            specular,
            ior: m.ior,
            fresnel: m.fresnel,
            thin: m.thin,
            conductor: m.conductor,
            brdf: table.cloned(),
        },
        emission: Rgb::ZERO,
        blend: None,
    }
}

/// The colour channel (0 red, 1 green, 2 blue) in which emitted light can never leave some
/// part of the scene: a group of nodes that reflect or transmit all of it (kd + ks + kt = 1),
/// holding an emitter, with no link from it to an absorbing node or out of the scene (the
/// whole scene when it is closed, or a sealed box inside an open one). Its radiance has no
/// finite value (each bounce carries all of it on), so no distribution converges: the sweeps
/// would run to `max_sweeps`, conjugate gradients stop at a value set by rounding. Gives the
/// channel and an emitting node of such a group, `None` when every channel is bounded.
/// Needs the link table; walks the links of the lossless nodes joined to a lossless
/// emitter, none when no emitter is lossless (the usual case).
pub fn lossless_channel(net: &Network, surfaces: &[Surface]) -> Option<(usize, u32)> {
    let nodes = net.nodes();
    (0..3).find_map(|c| {
        let lossless = |i: usize| surfaces[i].scattered()[c] >= 1.0 - 1e-6;
        let mut seen = vec![false; nodes];
        let mut stack = Vec::new();
        (0..nodes)
            .filter(|&i| surfaces[i].emission[c] > 0.0 && lossless(i))
            .find(|&emitter| {
                if seen[emitter] {
                    // Its group was walked whole from an earlier emitter, and can leave.
                    return false;
                }
                // The whole group of lossless nodes the emitter's light can reach: over links,
                // and through transmitting patches to their other side.
                let mut leaves = false;
                seen[emitter] = true;
                stack.push(emitter as u32);
                while let Some(i) = stack.pop() {
                    let transmits = (surfaces[i as usize].parts())
                        .any(|(_, p)| p.kt[c] > 0.0 || p.kdt[c] > 0.0);
                    let through = transmits.then(|| net.twin(i));
                    let links = net.links_of(i).iter().map(|&l| net.code.target(l));
                    for t in links.chain(through) {
                        if t == ESCAPE || t == NONE || !lossless(t as usize) {
                            leaves = true;
                        } else if !seen[t as usize] {
                            seen[t as usize] = true;
                            stack.push(t);
                        }
                    }
                }
                !leaves
            })
            .map(|emitter| (c, emitter as u32))
    })
}
