//! The nodes' surfaces from the scene's materials, and the check that light can leave.

use crate::bsdf::Bsdf;
use crate::integrators::illumination_network::{Network, ESCAPE, NONE};
use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::{Conductor, Material, Scene, SurfacePoint, Texture};

/// The surface of one node.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Surface {
    pub kd: Rgb,
    /// The specular lobe's reflectance at normal incidence (a metal's Fresnel included).
    pub ks: Rgb,
    pub kt: Rgb,
    pub alpha: f32,
    /// What else the directional lobes' BSDF is made of.
    pub optics: Optics,
    /// Emitted radiance (fronts of emissive materials only).
    pub emission: Rgb,
}

/// A node material's optics besides its coefficients: the directional lobes scatter as the
/// path tracer's BSDF of the same material without its diffuse lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Optics {
    /// ks before a metal's Fresnel reflectance.
    pub specular: Rgb,
    pub ior: f32,
    pub fresnel: bool,
    /// A thin sheet: transmission straight on, the sheet's reflectance for Fresnel's.
    pub thin: bool,
    pub conductor: Option<Conductor>,
}

impl Default for Optics {
    fn default() -> Self {
        Optics {
            specular: Rgb::ZERO,
            ior: 1.0,
            fresnel: false,
            thin: false,
            conductor: None,
        }
    }
}

impl Surface {
    pub fn directional(&self) -> bool {
        self.ks.max_element() > 0.0 || self.kt.max_element() > 0.0
    }

    /// The BSDF of the directional lobes (specular and transmission) at a node with unit
    /// normal `n` (facing the node's side) on a patch whose geometric normal is `ng`
    /// (orientation tells a transmitting material's inside from its outside).
    pub(crate) fn directional_bsdf(&self, ng: Vec3, n: Vec3) -> Bsdf {
        let m = Material {
            diffuse: Texture::Constant(Rgb::ZERO),
            specular: self.optics.specular,
            transmission: self.kt,
            ior: self.optics.ior,
            roughness: self.alpha,
            fresnel: self.optics.fresnel,
            thin: self.optics.thin,
            conductor: self.optics.conductor,
            ..Material::default()
        };
        let sp = SurfacePoint {
            p: Vec3::ZERO,
            ng,
            ns: ng,
            uv: Vec2::ZERO,
            t: 0.0,
            shape: 0,
            material: 0,
        };
        Bsdf::new(&m, &sp, n)
    }
}

/// The most material `m` (with diffuse colour `kd` at the point) can reflect and transmit of
/// the light arriving from one direction, per channel: kd + ks + kt, or with Fresnel weighting,
/// where ks takes F and kd and kt share 1 − F, the larger of ks and kd + kt (a glass is
/// ks = kt = 1). The network scales a material down to at most 1.
pub(crate) fn most_scattered(m: &Material, kd: Rgb) -> Rgb {
    let (ks, kt) = (m.specular_at_normal(), m.transmission);
    if m.fresnel {
        ks.max(kd + kt)
    } else {
        kd + ks + kt
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
            let p = net.space.to_world(pg.point(s, t));
            let kd = m.diffuse.eval(p, Vec2::new(s, t));
            let (mut kd, mut ks, mut kt) = (kd, m.specular_at_normal(), m.transmission);
            let mut specular = m.specular;
            let total = most_scattered(m, kd);
            for c in 0..3 {
                if total[c] > 1.0 {
                    kd[c] /= total[c];
                    ks[c] /= total[c];
                    kt[c] /= total[c];
                    specular[c] /= total[c];
                }
            }
            Surface {
                kd,
                ks,
                kt,
                // An anisotropic lobe becomes the isotropic one of mean α; a thin sheet is
                // smooth (its transmission is the straight line on).
                alpha: match m.roughness_v {
                    _ if m.thin => 0.0,
                    Some(v) => 0.5 * (m.roughness + v),
                    None => m.roughness,
                },
                optics: Optics {
                    specular,
                    ior: m.ior,
                    fresnel: m.fresnel,
                    thin: m.thin,
                    conductor: m.conductor,
                },
                emission: if side == 0 || m.two_sided_emission {
                    emission[mi]
                } else {
                    Rgb::ZERO
                },
            }
        })
        .collect()
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
        let lossless = |i: usize| {
            let s = &surfaces[i];
            s.kd[c] + s.ks[c] + s.kt[c] >= 1.0 - 1e-6
        };
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
                    let through = (surfaces[i as usize].kt[c] > 0.0).then(|| net.twin(i));
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
