//! The material interface: the pbrt reader makes each pbrt-v4 material its own kind, and a
//! kind's BSDF is what its own file says (the lobes of its approximation, a coat over them,
//! or a table), so the Monte Carlo techniques and the approximating ones see one surface.

use super::bsdf::point;
use crate::bsdf::{Bsdf, Transport};
use crate::math::{Rng, Vec2, Vec3};
use crate::scene::{Scene, Surface};
use std::path::Path;

/// A scene with one shape per pbrt-v4 material type raylink has a kind for.
const MATERIALS: &str = r#"
LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective"
Film "rgb" "integer xresolution" 4 "integer yresolution" 4
WorldBegin
MakeNamedMaterial "d" "string type" "diffuse" "rgb reflectance" [0.2 0.4 0.6]
MakeNamedMaterial "dt" "string type" "diffusetransmission" "rgb transmittance" [0.3 0.3 0.3]
MakeNamedMaterial "c" "string type" "conductor" "float roughness" 0.1
MakeNamedMaterial "g" "string type" "dielectric" "float eta" 1.33 "float roughness" 0.05
MakeNamedMaterial "t" "string type" "thindielectric" "float eta" 1.5
MakeNamedMaterial "cd" "string type" "coateddiffuse" "rgb reflectance" [0.5 0.2 0.1]
MakeNamedMaterial "cc" "string type" "coatedconductor" "float interface.roughness" 0.1
MakeNamedMaterial "m" "string type" "mix" "string materials" ["d" "g"] "float amount" 0.8
"#;

fn scene() -> Scene {
    let mut text = MATERIALS.to_string();
    for name in ["d", "dt", "c", "g", "t", "cd", "cc", "m"] {
        text += &format!("NamedMaterial \"{name}\"\nShape \"sphere\" \"float radius\" 0.1\n");
    }
    crate::scene::pbrt::from_str(&text, Path::new("materials.pbrt")).expect("the scene reads")
}

#[test]
fn each_pbrt_material_becomes_its_own_kind() {
    let scene = scene();
    let kinds: Vec<(&str, &str)> = scene
        .materials
        .iter()
        .map(|m| (m.name.as_str(), m.model().kind()))
        .collect();
    for want in [
        ("d", "diffuse"),
        ("dt", "diffusetransmission"),
        ("c", "conductor"),
        ("g", "dielectric"),
        ("t", "thindielectric"),
        ("cd", "coateddiffuse"),
        ("cc", "coatedconductor"),
        ("m", "mix"),
    ] {
        assert!(kinds.contains(&want), "{want:?} not in {kinds:?}");
    }
}

/// Random pairs of directions on both sides of the surface.
fn directions(n: usize) -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng::for_key(0x6d61_7473, &[]);
    let dir = |rng: &mut Rng| {
        Vec3::new(
            rng.uniform() - 0.5,
            rng.uniform() - 0.5,
            rng.uniform() - 0.5,
        )
        .normalize()
    };
    (0..n).map(|_| (dir(&mut rng), dir(&mut rng))).collect()
}

/// f·cos, the density and a sample of `bsdf` for each pair, bit for bit.
fn signature(bsdf: &Bsdf, pairs: &[(Vec3, Vec3)]) -> Vec<u32> {
    let mut out = Vec::new();
    for (k, &(wo, wi)) in pairs.iter().enumerate() {
        let (f, pdf) = bsdf.eval_and_pdf(wo, wi, Transport::Radiance);
        out.extend(f.to_array().map(f32::to_bits));
        out.push(pdf.to_bits());
        let u = Vec2::new((k as f32 * 0.37).fract(), (k as f32 * 0.61).fract());
        if let Some(s) = bsdf.sample(wo, (k as f32 * 0.13).fract(), u, Transport::Radiance) {
            out.extend(s.wi.to_array().map(f32::to_bits));
            out.extend(s.weight.to_array().map(f32::to_bits));
        }
    }
    out
}

/// The kinds whose BSDF is the lobe mixture scatter exactly as the lobes of their own
/// approximation; the coated kinds and the mix do not (a coat, the dominant material), and
/// a coat changes what the lobes alone give.
#[test]
fn a_kind_scatters_as_its_file_says() {
    let scene = scene();
    let pairs = directions(256);
    let sp = point();
    for m in &scene.materials {
        let own = signature(&m.bsdf(&sp, Vec3::Z), &pairs);
        let lobes = signature(&m.approximation().lobe_bsdf(&sp, Vec3::Z), &pairs);
        match &m.surface {
            Surface::CoatedDiffuse(_) | Surface::CoatedConductor(_) => {
                assert_ne!(own, lobes, "{}: the coat is not its lobes", m.name)
            }
            Surface::Mix(mix) => {
                let dominant = signature(&mix.dominant.model().bsdf(&sp, Vec3::Z), &pairs);
                assert_eq!(
                    own, dominant,
                    "{}: a mix answers as its dominant material",
                    m.name
                );
                assert!(
                    matches!(*mix.dominant, Surface::Dielectric(_)),
                    "amount 0.8: the glass"
                );
            }
            _ => assert_eq!(own, lobes, "{}", m.name),
        }
    }
}
