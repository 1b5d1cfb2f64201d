//! Tabulated BRDFs: a table of an analytic lobe reproduces the lobe, its sampling passes the
//! chi-square test, a table of a constant renders as the Lambertian surface it describes in
//! the path tracer, and a scene file naming one loads it (or says what is wrong with it).

use super::bsdf::{check, check_in, directions, material, point};
use super::network_common::{monte_carlo_image, scene};
use crate::bsdf::{TabulatedBrdf, Transport};
use crate::image::Image;
use crate::integrators::bdpt::{Bdpt, BdptOptions};
use crate::integrators::path::{PathOptions, PathTracer};
use crate::math::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::math::{luminance, Rgb, Rng, Vec2, Vec3};
use crate::scene::materials::Measured;
use crate::scene::{Material, Scene, Surface};
use crate::transport::MonteCarlo;
use std::sync::Arc;

/// The isotropic table of `m`'s BRDF (from [`Bsdf::eval`]) on a grid of `dt`° in θ and `dp`°
/// in φo − φi.
fn table_of(m: &Material, dt: f32, dp: f32) -> TabulatedBrdf {
    table_with(m, dt, dp, false, |_| 1.0)
}

/// The table of `m`'s BRDF times `factor(θi in degrees)` (which makes it not reciprocal) on
/// a grid of `dt`° in θ and `dp`° in φ: over φo − φi, or over φi and φo when `anisotropic`.
fn table_with(
    m: &Material,
    dt: f32,
    dp: f32,
    anisotropic: bool,
    factor: impl Fn(f32) -> f32,
) -> TabulatedBrdf {
    let thetas: Vec<f32> = (0..=(90.0 / dt) as u32).map(|k| k as f32 * dt).collect();
    let phis: Vec<f32> = (0..(360.0 / dp) as u32).map(|k| k as f32 * dp).collect();
    let phis_i = if anisotropic { phis.clone() } else { vec![0.0] };
    let dir = |t: f32, p: f32| {
        let (t, p) = (t.min(89.9).to_radians(), p.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    };
    let mut values = Vec::new();
    for &ti in &thetas {
        for &pi in &phis_i {
            for &to in &thetas {
                for &po in &phis {
                    let (wi, wo) = (dir(ti, pi), dir(to, po));
                    let bsdf = m.bsdf(&point(), wo);
                    values.push(bsdf.eval(wo, wi, Transport::Radiance) / wi.z * factor(ti));
                }
            }
        }
    }
    TabulatedBrdf::new([thetas.clone(), phis_i, thetas, phis], values).unwrap()
}

fn tabulated(table: TabulatedBrdf) -> Material {
    Material::new("", Surface::Measured(Measured::new(Arc::new(table))))
}

/// A rough conductor's lobe (GGX α 0.4 with a gold tint, no Fresnel) tabulated every 2° in θ
/// and 5° in φ gives the lobe back: the directional albedo within 1% at five angles, and f
/// itself within 5% (relative to the lobe's peak) at 2,000 random pairs of directions
/// (multilinear interpolation of a smooth lobe; measured 0.05% and 2.5%).
#[test]
fn a_tabulated_lobe_reproduces_the_analytic_one() {
    let glossy = material(|m| {
        m.specular = Rgb::new(0.9, 0.7, 0.4);
        m.roughness = 0.4;
    });
    let table = table_of(&glossy, 2.0, 5.0);
    let tab = tabulated(table);
    let mut worst_albedo = 0.0f32;
    for c in [0.1f32, 0.3, 0.5, 0.7, 0.95] {
        let wo = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
        let want = glossy
            .bsdf(&point(), wo)
            .albedo_by_side(wo, 64, Transport::Radiance);
        let got = tab.model().table().unwrap().albedo(wo);
        let err = ((got - want.0).abs() / want.0).max_element();
        worst_albedo = worst_albedo.max(err);
    }
    let mut rng = Rng::for_key(11, &[]);
    let mut worst_f = 0.0f32;
    for _ in 0..2000 {
        let mut d = || cosine_hemisphere(Vec2::new(rng.uniform(), rng.uniform()));
        let (wo, wi) = (d(), d());
        let want = glossy.bsdf(&point(), wo).eval(wo, wi, Transport::Radiance);
        let got = tab.bsdf(&point(), wo).eval(wo, wi, Transport::Radiance);
        let peak =
            glossy
                .bsdf(&point(), wo)
                .eval(wo, Vec3::new(-wo.x, -wo.y, wo.z), Transport::Radiance)
                / wo.z;
        worst_f = worst_f.max(((got - want) / wi.z / peak).abs().max_element());
    }
    eprintln!("albedo within {worst_albedo:.4}, f within {worst_f:.4} of the peak");
    assert!(worst_albedo < 0.01, "albedo off by {worst_albedo}");
    assert!(worst_f < 0.05, "f off by {worst_f} of the peak");
}

/// Sampling a tabulated BSDF matches its density, from several directions.
#[test]
fn tabulated_sampling_passes_chi_square() {
    let glossy = material(|m| {
        m.specular = Rgb::splat(0.8);
        m.roughness = 0.3;
    });
    let m = tabulated(table_of(&glossy, 5.0, 10.0));
    for (i, wo) in directions().into_iter().enumerate() {
        check(&format!("tabulated{i}"), &m, wo);
    }
}

/// A sharp lobe: GGX α 0.1, white.
fn sharp_lobe() -> Material {
    material(|m| {
        m.specular = Rgb::splat(0.9);
        m.roughness = 0.1;
    })
}

/// [`sharp_lobe`] tabulated every 1° in θ and 2° in φ.
fn sharp() -> Material {
    tabulated(table_of(&sharp_lobe(), 1.0, 2.0))
}

/// The table's own sampling of a sharp lobe passes the chi-square test in both transport
/// modes, and so does a table that is not reciprocal (the lobe times 0.2 + cos θi), whose
/// sampling serves both modes from one density.
#[test]
fn a_sharp_table_passes_chi_square_in_both_modes() {
    let skewed = tabulated(table_with(&sharp_lobe(), 2.0, 4.0, false, |t| {
        0.2 + t.to_radians().cos()
    }));
    for (m, name) in [(sharp(), "sharp"), (skewed, "skewed")] {
        for (i, wo) in directions().into_iter().enumerate() {
            for mode in [Transport::Radiance, Transport::Importance] {
                check_in(&format!("{name}{i}-{mode:?}"), &m, wo, 64, mode);
            }
        }
    }
}

/// An anisotropic table that is not reciprocal (an anisotropic rough conductor's lobe times
/// 0.2 + cos θi, every 5° in θ and 15° in φi and φo) passes the chi-square test in both
/// modes: the rows over the given direction's φ, and the choice among four of them.
#[test]
fn an_anisotropic_table_passes_chi_square_in_both_modes() {
    let ggx = material(|m| {
        m.specular = Rgb::new(0.9, 0.6, 0.3);
        m.roughness = 0.15;
        m.roughness_v = Some(0.4);
    });
    let m = tabulated(table_with(&ggx, 5.0, 15.0, true, |t| {
        0.2 + t.to_radians().cos()
    }));
    for (i, wo) in directions().into_iter().enumerate().skip(1) {
        for mode in [Transport::Radiance, Transport::Importance] {
            check_in(&format!("aniso{i}-{mode:?}"), &m, wo, 48, mode);
        }
    }
}

/// Mean and variance of `weight` over `n` draws of (u_lobe, u).
fn moments(n: usize, key: u64, mut weight: impl FnMut(f32, Vec2) -> f32) -> (f64, f64) {
    let mut rng = Rng::for_key(key, &[]);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let u_lobe = rng.uniform();
        let u = Vec2::new(rng.uniform(), rng.uniform());
        let w = weight(u_lobe, u) as f64;
        sum += w;
        sum2 += w * w;
    }
    let mean = sum / n as f64;
    (mean, sum2 / n as f64 - mean * mean)
}

/// For the sharp table, the single-sample estimate of the albedo (the weight of one
/// `Bsdf::sample`) has at least 5× less variance than with cosine sampling, toward three
/// directions; both estimates agree (both are unbiased), and the sampled one is within 0.5%
/// of a stratified estimate over a million cells.
#[test]
fn sampling_a_sharp_table_lowers_the_variance_of_its_albedo() {
    let m = sharp();
    let n = 400_000;
    for (i, wo) in directions().into_iter().enumerate() {
        let wo = wo.normalize();
        let bsdf = m.bsdf(&point(), wo);
        let (mean, var) = moments(n, 3, |u_lobe, u| {
            bsdf.sample(wo, u_lobe, u, Transport::Radiance)
                .map_or(0.0, |s| s.weight.y)
        });
        // Cosine sampling about the normal (z here): f·cos/pdf = π f.
        let (mean_cos, var_cos) = moments(n, 4, |_, u| {
            let wi = cosine_hemisphere(u);
            bsdf.eval(wo, wi, Transport::Radiance).y / cosine_hemisphere_pdf(wi.z)
        });
        // The reference: cosine sampling stratified over 1024² cells.
        let strata = 1024;
        let mut rng = Rng::for_key(5, &[]);
        let mut reference = 0.0f64;
        for k in 0..strata * strata {
            let (a, b) = ((k % strata) as f32, (k / strata) as f32);
            let u = Vec2::new(a + rng.uniform(), b + rng.uniform()) / strata as f32;
            let wi = cosine_hemisphere(u);
            let f = bsdf.eval(wo, wi, Transport::Radiance).y / cosine_hemisphere_pdf(wi.z);
            reference += f as f64;
        }
        reference /= (strata * strata) as f64;
        let ratio = var_cos / var;
        let sigma = ((var + var_cos) / n as f64).sqrt();
        let off = (mean - reference).abs() / reference;
        eprintln!(
            "direction {i}: albedo {mean:.4} (cosine {mean_cos:.4}, stratified {reference:.4}), \
             variance {var:.4} vs cosine {var_cos:.4}: {ratio:.1}× lower"
        );
        assert!(ratio >= 5.0, "direction {i}: only {ratio:.2}× lower");
        assert!(
            (mean - mean_cos).abs() < 4.0 * sigma,
            "{mean} vs {mean_cos}"
        );
        assert!(off < 0.005, "{mean} vs stratified {reference}");
    }
}

/// The unit box with a lamp under the ceiling and a floor of `floor` (TOML keys), seen from a
/// corner.
fn lamp_box(floor: &str) -> Scene {
    let mut text = String::from(
        "[camera]\nposition = [0.5, 0.5, 2.4]\nlook_at = [0.5, 0.4, 0]\nfov = 45\n\
         width = 24\nheight = 24\n\
         [materials.white]\ndiffuse = 0.6\n[materials.lamp]\ndiffuse = 0\nemission = 5\n",
    );
    text += &format!("[materials.floor]\n{floor}\n");
    for (axis, side) in [(0, 0.0), (0, 1.0), (2, 0.0), (1, 1.0)] {
        text += &super::network_scenes::wall(axis, side, "white");
    }
    text += &super::network_scenes::wall(1, 0.0, "floor");
    text += "[[shapes]]\ntype = \"quad\"\nmaterial = \"lamp\"\n\
             vertices = [[0.3, 0.99, 0.3], [0.7, 0.99, 0.3], [0.7, 0.99, 0.7], \
             [0.3, 0.99, 0.7]]\n";
    scene(&text)
}

fn path_image(scene: &Scene) -> Image {
    image_by(scene, &PathTracer::new(PathOptions { max_depth: 8 }), 16)
}

/// `scene` rendered by `integrator` at 24×24 pixels, `spp` samples per pixel, seed 5.
fn image_by(scene: &Scene, integrator: &dyn MonteCarlo, spp: u32) -> Image {
    monte_carlo_image(scene, integrator, 24, spp, 5)
}

/// A table holding the constant 0.5/π is the Lambertian floor of albedo 0.5: the path
/// tracer draws the same directions with the same weights from the same random numbers, so
/// the two images agree to rounding (within 1e-4 relative in the mean, every pixel within
/// 1e-3), while a floor of albedo 0.45 differs by far more.
#[test]
fn a_constant_table_renders_as_the_lambertian_surface() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("white.brdf");
    let text = format!(
        "# a Lambertian reflector of albedo 0.5\ntheta_i 0 90\nphi_i 0\ntheta_o 0 90\n\
         phi_o 0\nvalues\n{v}\n{v}\n{v}\n{v}\n",
        v = 0.5 / std::f32::consts::PI
    );
    std::fs::write(&file, text).unwrap();
    let table = path_image(&lamp_box(&format!("brdf = \"{}\"", file.display())));
    let lambert = path_image(&lamp_box("diffuse = 0.5"));
    let darker = path_image(&lamp_box("diffuse = 0.45"));
    let compare = |a: &Image, b: &Image| {
        let (mut sum, mut diff, mut worst) = (0.0f64, 0.0f64, 0.0f32);
        for (p, q) in a.pixels.iter().zip(&b.pixels) {
            sum += q.length() as f64;
            diff += (*p - *q).length() as f64;
            worst = worst.max((*p - *q).length() / q.length().max(1e-3));
        }
        (diff / sum, worst)
    };
    let (mean, worst) = compare(&table, &lambert);
    let (off, _) = compare(&darker, &lambert);
    eprintln!("table vs Lambertian: {mean:.2e} mean, {worst:.2e} worst; albedo 0.45: {off:.3}");
    assert!(mean < 1e-4 && worst < 1e-3, "{mean}, {worst}");
    assert!(off > 100.0 * mean.max(1e-5), "{off}");
}

/// A glossy floor that is not reciprocal (GGX α 0.2 times 0.2 + cos θi, every 2° in θ and
/// 4° in φ) renders alike in the path tracer and in BDPT, which combines the table's
/// sampling density in both directions (radiance and importance) by multiple importance
/// sampling: the images' means agree within 1.5%, and within 3% in each quarter (measured
/// 0.05% and 0.19%; evaluating the table with its arguments swapped in importance transport
/// gives 2.3% and 10%).
#[test]
fn path_tracing_and_bdpt_agree_on_a_glossy_table() {
    let ggx = material(|m| {
        m.specular = Rgb::splat(0.8);
        m.roughness = 0.2;
    });
    let table = table_with(&ggx, 2.0, 4.0, false, |t| 0.2 + t.to_radians().cos());
    let mut scene = lamp_box("diffuse = 0.5");
    let floor = scene
        .materials
        .iter()
        .position(|m| m.name == "floor")
        .unwrap();
    scene.materials[floor].surface = Surface::Measured(Measured::new(Arc::new(table)));
    let path = image_by(&scene, &PathTracer::new(PathOptions { max_depth: 8 }), 1024);
    let bdpt = image_by(
        &scene,
        &Bdpt::new(BdptOptions {
            max_depth: 8,
            spectral: false,
        }),
        1024,
    );
    let mean = |img: &Image, quarter: Option<usize>| {
        let mut sum = 0.0f64;
        for (k, p) in img.pixels.iter().enumerate() {
            let (x, y) = (k % 24, k / 24);
            if quarter.is_none_or(|q| q == (x / 12) + 2 * (y / 12)) {
                sum += luminance(*p) as f64;
            }
        }
        sum
    };
    let whole = (mean(&path, None) - mean(&bdpt, None)).abs() / mean(&bdpt, None);
    let worst = (0..4)
        .map(|q| (mean(&path, Some(q)) - mean(&bdpt, Some(q))).abs() / mean(&bdpt, Some(q)))
        .fold(0.0, f64::max);
    eprintln!("path vs BDPT on a glossy table: {whole:.4} in the mean, {worst:.4} worst quarter");
    assert!(whole < 0.015 && worst < 0.03, "{whole}, {worst}");
}

/// A scene naming a table loads it and its path; errors in the table name the table's file and
/// line, and other lobes beside a table are refused.
#[test]
fn scene_files_name_tables_and_their_errors() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.brdf");
    std::fs::write(
        &good,
        "theta_i 0\nphi_i 0\ntheta_o 0\nphi_o 0\nvalues\n0.1 0.2 0.3\n",
    )
    .unwrap();
    let bad = dir.path().join("bad.brdf");
    std::fs::write(
        &bad,
        "theta_i 0\nphi_i 0\ntheta_o 0\nphi_o 0\nvalues\n0.1 0.2\n",
    )
    .unwrap();
    let text = |keys: &str| {
        format!("[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\nfov = 40\n[materials.m]\n{keys}\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 0.5\nmaterial = \"m\"\n")
    };
    let load = |keys: &str| crate::scene::toml::from_str(&text(keys), &dir.path().join("s.toml"));
    let s = load("brdf = \"good.brdf\"").unwrap();
    let t = s.materials[0].model().table().expect("a table");
    assert_eq!(t.file, std::path::Path::new("good.brdf"));
    let albedo = Rgb::new(0.1, 0.2, 0.3) * std::f32::consts::PI;
    assert!((t.most_reflected() - albedo).abs().max_element() < 1e-5);
    let e = load("brdf = \"bad.brdf\"").unwrap_err().to_string();
    assert!(
        e.contains("bad.brdf:6: a value is one number or three"),
        "{e}"
    );
    let e = load("brdf = \"good.brdf\"\nspecular = 0.5")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 7: materials.m.specular: a material with a tabulated"),
        "{e}"
    );
    let e = load("brdf = \"missing.brdf\"").unwrap_err().to_string();
    assert!(
        e.contains("missing.brdf") && e.contains("materials.m.brdf"),
        "{e}"
    );
}

/// The channel scales of MERL files: what a value of 1 in the file is in 1/sr.
const MERL_SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// A MERL file of `g(θh, θd)` (f in 1/sr, grey) in `dir`, loaded through a scene file.
fn merl_material(dir: &std::path::Path, name: &str, g: impl Fn(f32, f32) -> f32) -> Material {
    let bytes = crate::bsdf::synthetic_merl(|th, td, _| {
        let f = g(th, td) as f64;
        [0, 1, 2].map(|c| f / MERL_SCALE[c])
    });
    std::fs::write(dir.join(name), bytes).unwrap();
    let text = format!(
        "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\nfov = 40\n[materials.m]\n\
         brdf = \"{name}\"\n[[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 0.5\n\
         material = \"m\"\n"
    );
    let scene = crate::scene::toml::from_str(&text, &dir.join("s.toml")).unwrap();
    scene.materials[0].clone()
}

/// θh and θd of a pair of directions, from the half vector alone (not the MERL code's
/// rotations): θd is the angle between `wi` and h.
fn half_diff(wi: Vec3, wo: Vec3) -> (f32, f32) {
    let h = (wi + wo).normalize();
    (
        h.z.clamp(-1.0, 1.0).acos(),
        wi.dot(h).clamp(-1.0, 1.0).acos(),
    )
}

/// A MERL file read from a scene: a constant ρ/π is f = ρ/π everywhere with albedo ρ, and a
/// function of θh and θd is looked up at the right cell (within the cells' size: 0.015 for
/// this function, at 2,000 random pairs), with the albedo of the function itself (within
/// 1%, by the same quadrature over the function).
#[test]
fn merl_files_give_back_their_function() {
    let dir = tempfile::tempdir().unwrap();
    let rho = 0.7f32;
    let flat = merl_material(dir.path(), "flat.binary", |_, _| rho / std::f32::consts::PI);
    let table = flat.model().table().unwrap();
    assert_eq!(table.file, std::path::Path::new("flat.binary"));
    assert!(
        (table.most_reflected() - Rgb::splat(rho))
            .abs()
            .max_element()
            < 1e-3
    );
    let g = |th: f32, td: f32| 0.1 + 0.5 * th.cos() * (1.0 + 0.3 * td.cos());
    let shaped = merl_material(dir.path(), "shaped.binary", g);
    let table = shaped.model().table().unwrap();
    let mut rng = Rng::for_key(23, &[]);
    let mut worst = 0.0f32;
    for _ in 0..2000 {
        let mut d = || cosine_hemisphere(Vec2::new(rng.uniform(), rng.uniform()));
        let (wi, wo) = (d(), d());
        let flat_f = flat.model().table().unwrap().eval(wi, wo);
        assert!(
            (flat_f - Rgb::splat(rho / std::f32::consts::PI))
                .abs()
                .max_element()
                < 1e-6
        );
        let (th, td) = half_diff(wi, wo);
        worst = worst.max(
            (table.eval(wi, wo) - Rgb::splat(g(th, td)))
                .abs()
                .max_element(),
        );
    }
    // The albedo by the table's quadrature (64 × 128 in cos² θ, φ), of the function.
    let mut worst_albedo = 0.0f32;
    for c in [0.2f32, 0.6, 0.95] {
        let wo = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
        let (nu, nv) = (64, 128);
        let mut sum = 0.0f64;
        for i in 0..nu {
            let c2 = (i as f32 + 0.5) / nu as f32;
            let (z, s) = (c2.sqrt(), (1.0 - c2).sqrt());
            for j in 0..nv {
                let phi = std::f32::consts::TAU * (j as f32 + 0.5) / nv as f32;
                let (th, td) = half_diff(Vec3::new(s * phi.cos(), s * phi.sin(), z), wo);
                sum += g(th, td) as f64;
            }
        }
        let want = (sum * std::f64::consts::PI / (nu * nv) as f64) as f32;
        let got = table.albedo(wo).y;
        worst_albedo = worst_albedo.max((got - want).abs() / want);
    }
    eprintln!("MERL lookup within {worst:.4}, albedo within {worst_albedo:.1e}");
    assert!(worst < 0.015, "lookup off by {worst}");
    assert!(worst_albedo < 0.01, "albedo off by {worst_albedo}");
}

/// A MERL BRDF with a sharp highlight (a narrow function of θh) is sampled from its
/// distribution: the chi-square test passes in both modes, and one sample's estimate of the
/// albedo has at least 5× less variance than with cosine sampling.
#[test]
fn a_sharp_merl_brdf_is_importance_sampled() {
    let dir = tempfile::tempdir().unwrap();
    let m = merl_material(dir.path(), "sharp.binary", |th, _| {
        0.02 + 20.0 * (-(th / 0.08).powi(2)).exp()
    });
    for (i, wo) in directions().into_iter().enumerate() {
        for mode in [Transport::Radiance, Transport::Importance] {
            check_in(&format!("merl{i}-{mode:?}"), &m, wo, 48, mode);
        }
    }
    let wo = directions()[1].normalize();
    let bsdf = m.bsdf(&point(), wo);
    let n = 200_000;
    let (mean, var) = moments(n, 7, |u_lobe, u| {
        bsdf.sample(wo, u_lobe, u, Transport::Radiance)
            .map_or(0.0, |s| s.weight.y)
    });
    let (mean_cos, var_cos) = moments(n, 8, |_, u| {
        let wi = cosine_hemisphere(u);
        bsdf.eval(wo, wi, Transport::Radiance).y / cosine_hemisphere_pdf(wi.z)
    });
    let ratio = var_cos / var;
    eprintln!("MERL albedo {mean:.4} (cosine {mean_cos:.4}), variance {ratio:.1}× lower");
    assert!(ratio >= 5.0, "only {ratio:.2}× lower");
}

/// A MERL file that is short or has other dimensions is a one-line error naming the file.
#[test]
fn bad_merl_files_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut header = Vec::new();
    for d in [90i32, 90, 360] {
        header.extend(d.to_le_bytes());
    }
    std::fs::write(dir.path().join("wide.binary"), &header).unwrap();
    header[8..12].copy_from_slice(&180i32.to_le_bytes());
    header.extend([0u8; 80]);
    std::fs::write(dir.path().join("short.binary"), &header).unwrap();
    let load = |name: &str| {
        let text = format!(
            "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\nfov = 40\n[materials.m]\n\
             brdf = \"{name}\"\n[[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\n\
             radius = 0.5\nmaterial = \"m\"\n"
        );
        let e = crate::scene::toml::from_str(&text, &dir.path().join("s.toml")).unwrap_err();
        e.to_string()
    };
    for (name, want) in [
        (
            "wide.binary",
            "dimensions 90 × 90 × 360; a MERL BRDF has 90 × 90 × 180",
        ),
        (
            "short.binary",
            "92 bytes; a MERL BRDF of 90 × 90 × 180 has 34992012",
        ),
    ] {
        let e = load(name);
        assert!(e.contains(name) && e.contains(want), "{e}");
        assert!(!e.trim_end().contains('\n'), "{e}");
    }
}
