use super::texture::{ImageTexture, UvMapping};
use crate::math::{Rgb, Vec2, Vec3};
use std::sync::Arc;

/// A surface in Whitted's model (eq. 2 of the paper): I = ka·Ia + kd Σ(N·Lj) + ks S + kt T,
/// with a Phong highlight for point lights, plus emission for area lights.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// kd: diffuse reflectance.
    pub diffuse: Texture,
    /// ka: ambient reflectance; `None` means "the diffuse colour", the usual choice.
    pub ambient: Option<Rgb>,
    /// ks: specular (mirror) reflection coefficient; also scales the Phong highlight.
    pub specular: Rgb,
    /// kt: transmission coefficient.
    pub transmission: Rgb,
    /// Index of refraction of the material's inside (outside is vacuum, 1).
    pub ior: f32,
    /// Exponent n of the Phong highlight.
    pub phong_exponent: f32,
    /// Microfacet roughness, GGX α: the Monte Carlo integrators use a GGX reflection lobe;
    /// Whitted's integrator draws the normal of each reflected or refracted ray from the GGX
    /// distribution (glossy reflection, frosted transmission). 0 is a perfect mirror or
    /// clear glass.
    pub roughness: f32,
    /// When true, ks and kt are weighted by the Fresnel reflectance at the hit.
    pub fresnel: bool,
    /// Emitted radiance; a shape with a non-zero emission is an area light.
    pub emission: Rgb,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: String::new(),
            diffuse: Texture::Constant(Rgb::splat(0.5)),
            ambient: None,
            specular: Rgb::ZERO,
            transmission: Rgb::ZERO,
            ior: 1.5,
            phong_exponent: 50.0,
            roughness: 0.0,
            fresnel: false,
            emission: Rgb::ZERO,
        }
    }
}

impl Material {
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    pub fn is_transmissive(&self) -> bool {
        self.transmission.max_element() > 0.0
    }
}

/// A colour that may vary over a surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Constant(Rgb),
    /// A solid (3-D) checkerboard in world space: cubes of side `size` alternate colours.
    Checker {
        even: Rgb,
        odd: Rgb,
        size: f32,
    },
    /// A checkerboard over the surface's (u, v) (pbrt's 2-D `checkerboard`): `even` where
    /// floor(s) + floor(t) is even for (s, t) = `mapping`(u, v).
    UvChecker {
        even: Rgb,
        odd: Rgb,
        mapping: UvMapping,
    },
    /// An image looked up by (u, v).
    Image(Arc<ImageTexture>),
}

impl Texture {
    /// The colour at world position `p` with surface coordinates `uv`.
    pub fn eval(&self, p: Vec3, uv: Vec2) -> Rgb {
        match *self {
            Texture::Constant(c) => c,
            Texture::Checker { even, odd, size } => {
                // A small bias keeps faces that lie exactly on a cell boundary on one side.
                let cell = ((p + Vec3::splat(1e-4)) / size).floor();
                if (cell.x + cell.y + cell.z).rem_euclid(2.0) < 0.5 {
                    even
                } else {
                    odd
                }
            }
            Texture::UvChecker { even, odd, mapping } => {
                let st = mapping.map(uv).floor();
                if (st.x + st.y).rem_euclid(2.0) < 0.5 {
                    even
                } else {
                    odd
                }
            }
            Texture::Image(ref image) => image.eval(uv),
        }
    }

    /// The largest value the texture takes (for contribution bounds and validation).
    pub fn max_value(&self) -> Rgb {
        match *self {
            Texture::Constant(c) => c,
            Texture::Checker { even, odd, .. } | Texture::UvChecker { even, odd, .. } => {
                even.max(odd)
            }
            Texture::Image(ref image) => image.max_value(),
        }
    }
}
