//! Illumination networks (Buckalew & Fussell 1989), relighting: a light basis superposed per
//! emissive material, a distribution warm-started from it for other reflectances, and a
//! reflectance series relighting one material with no distribution.

use super::bsdf::classic_mut;
use super::network_common::{build, params, scene};
use super::network_scenes::{wall, CAMERA};
use crate::integrators::illumination_network::distribute::{distribute, DistributeOptions, Run};
use crate::integrators::illumination_network::preprocess::Builder;
use crate::scene::Scene;

/// A closed box lit by two emissive walls, "warm" (y = 0) and "cold" (x = 1); the others are
/// "m", except the floor (z = 0) and the wall x = 0 when their materials are given.
fn two_light_box(floor: Option<&str>, mirror: Option<&str>) -> Scene {
    let mut materials = "[materials.m]\ndiffuse = [0.6, 0.5, 0.4]\n\
                         [materials.warm]\ndiffuse = 0.3\nemission = [2, 1, 0.5]\n\
                         [materials.cold]\ndiffuse = 0.5\nemission = [0.5, 1, 3]\n"
        .to_string();
    for (name, m) in [("floor", floor), ("mirror", mirror)] {
        if let Some(m) = m {
            materials += &format!("[materials.{name}]\n{m}\n");
        }
    }
    let mut text = format!("{CAMERA}\n{materials}\n");
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let mat = match (axis, side == 0.0) {
                (1, true) => "warm",
                (0, false) => "cold",
                (2, true) if floor.is_some() => "floor",
                (0, true) if mirror.is_some() => "mirror",
                _ => "m",
            };
            text += &wall(axis, side, mat);
        }
    }
    scene(&text)
}

/// Asserts that `got` is within `bound` of `want`, relative: Σ|got − want| / Σ|want|.
fn assert_close(what: &str, got: &[crate::math::Rgb], want: &[crate::math::Rgb], bound: f64) {
    assert_eq!(got.len(), want.len(), "{what}");
    let (mut err, mut total) = (0.0f64, 0.0f64);
    for (x, y) in got.iter().zip(want) {
        err += (*x - *y).abs().element_sum() as f64;
        total += y.abs().element_sum() as f64;
    }
    assert!(
        total > 0.0 && err / total < bound,
        "{what}: relative error {}",
        err / total
    );
}

/// Superposition: in a closed box with two emissive materials, the basis solution for
/// strengths (a, b) agrees with a distribution of the box lit at (a, b); each material's own
/// solution is exactly the basis with the other switched off, and they add up exactly.
#[test]
fn light_basis_superposes_per_material() {
    use crate::integrators::illumination_network::relight::LightBasis;
    use crate::math::Rgb;
    let s = two_light_box(None, None);
    let net = build(&s, params(5, 1.0 / 8.0), Builder::Scan);
    let options = DistributeOptions {
        tolerance: 1e-5,
        ..Default::default()
    };
    let emission: Vec<Rgb> = s.materials.iter().map(|m| m.emission).collect();
    let basis = LightBasis::compute(&net, &s, &emission, &options, Run::now());
    assert_eq!(basis.lights.len(), 2);
    let index = |name: &str| s.materials.iter().position(|m| m.name == name).unwrap();
    let (warm, cold) = (index("warm"), index("cold"));
    let with = |a: f32, b: f32| {
        let mut e = emission.clone();
        e[warm] *= a;
        e[cold] *= b;
        e
    };
    let sup = |a: f32, b: f32| basis.superpose(&net, &s, &with(a, b), &options).unwrap();
    let (only_warm, only_cold, both) = (sup(1.0, 0.0), sup(0.0, 1.0), sup(1.0, 1.0));
    for ((x, y), z) in only_warm
        .diffuse
        .iter()
        .zip(&only_cold.diffuse)
        .zip(&both.diffuse)
    {
        assert_eq!(*x + *y, *z);
    }
    // Against a distribution of the scene lit at other strengths.
    let (a, b) = (3.0, 0.25);
    let mut lit = s.clone();
    lit.materials[warm].emission *= a;
    lit.materials[cold].emission *= b;
    let reference = distribute(&net, &lit, &options);
    let got = sup(a, b);
    let (mut err, mut total) = (0.0f64, 0.0f64);
    for (x, y) in got.diffuse.iter().zip(&reference.diffuse) {
        err += (*x - *y).abs().element_sum() as f64;
        total += y.element_sum() as f64;
    }
    assert!(
        total > 0.0 && err / total < 1e-4,
        "relative error {}",
        err / total
    );
    // Other reflectances: the basis refuses.
    let mut grey = s.clone();
    classic_mut(&mut grey.materials[index("m")]).diffuse =
        crate::scene::Texture::Constant(Rgb::splat(0.2));
    assert!(basis
        .superpose(&net, &grey, &emission, &options)
        .unwrap_err()
        .contains("reflectances"));
}

/// Relighting with other reflectances starts from the stored light basis (incremental
/// radiosity): the first sweep gathers the old solution through the new reflectances and
/// only the change is shot on. Against a cold distribution of the changed scene: the same
/// radiances (diffuse, directional, the direct part) up to the tolerance, the energy balance
/// kept, fewer sweeps; with nothing changed, one sweep. Cases: a diffuse box whose walls
/// change colour, and a box whose floor goes from diffuse to glossy (new directional nodes)
/// and whose mirror wall gets rougher.
#[test]
fn warm_start_from_a_basis_for_other_reflectances_matches_a_cold_distribution() {
    use crate::integrators::illumination_network::distribute::Order;
    use crate::integrators::illumination_network::relight::LightBasis;
    use crate::math::Rgb;
    use crate::scene::Texture;
    let box_with = |floor: &str, mirror: &str| two_light_box(Some(floor), Some(mirror));
    let diffuse_box = box_with("diffuse = 0.4", "diffuse = 0.7");
    let mut recoloured = diffuse_box.clone();
    let m = recoloured
        .materials
        .iter()
        .position(|m| m.name == "m")
        .unwrap();
    classic_mut(&mut recoloured.materials[m]).diffuse = Texture::Constant(Rgb::new(0.3, 0.6, 0.5));
    let glossy_box = box_with("diffuse = 0.4", "diffuse = 0\nspecular = 0.7");
    let changed_glossy = box_with(
        "diffuse = 0.2\nspecular = 0.5\nroughness = 0.3",
        "diffuse = 0\nspecular = 0.7\nroughness = 0.1",
    );
    for order in [Order::Sweeps, Order::ConjugateGradients] {
        let options = DistributeOptions {
            tolerance: 1e-5,
            order,
            ..Default::default()
        };
        for (name, old, new, step) in [
            ("diffuse box", &diffuse_box, &recoloured, 1.0 / 8.0),
            ("unchanged", &diffuse_box, &diffuse_box, 1.0 / 8.0),
            ("glossy box", &glossy_box, &changed_glossy, 1.0 / 6.0),
        ] {
            let net = build(old, params(5, step), Builder::Scan);
            let emission: Vec<Rgb> = old.materials.iter().map(|m| m.emission).collect();
            let basis = LightBasis::compute(&net, old, &emission, &options, Run::now());
            let warm = basis.redistribute(&net, new, &emission, &options, Run::now());
            let cold = distribute(&net, new, &options);
            assert!(warm.stats.warm_start && !cold.stats.warm_start);
            let close = |what: &str, got: &[Rgb], want: &[Rgb], bound: f64| {
                assert_close(&format!("{name}: {what}"), got, want, bound)
            };
            close("diffuse", &warm.diffuse, &cold.diffuse, 1e-4);
            close("direct", &warm.direct, &cold.direct, 1e-5);
            if name == "glossy box" {
                assert!(!warm.directional.is_empty());
                assert!(basis.dir_index != cold.dir_index, "new directional nodes");
                close("directional", &warm.directional, &cold.directional, 1e-4);
                close("incoming", &warm.incoming, &cold.incoming, 1e-4);
            }
            let st = &warm.stats;
            for c in 0..3 {
                let balance = st.emitted[c] - st.escaped[c] - st.absorbed[c] - st.unshot[c];
                assert!(
                    balance.abs() < 1e-4 * st.emitted[c],
                    "{name}: channel {c}: {balance}"
                );
                assert!((st.emitted[c] - cold.stats.emitted[c]).abs() <= 1e-6 * st.emitted[c]);
            }
            if name == "unchanged" {
                assert_eq!(st.sweeps, 1, "{name}");
            } else {
                // The sweeps carry the change alone from the start; conjugate gradients
                // start from a smaller residual at the same rate (a gather or two fewer, in
                // the larger scenes).
                let fewer = match order {
                    Order::Sweeps => st.sweeps < cold.stats.sweeps,
                    _ => st.sweeps <= cold.stats.sweeps,
                };
                assert!(
                    fewer,
                    "{name}: {} sweeps warm, {} cold",
                    st.sweeps, cold.stats.sweeps
                );
            }
            eprintln!(
                "{order:?}, {name}: {} sweeps warm, {} cold",
                st.sweeps, cold.stats.sweeps
            );
        }
    }
}

/// Reflectance series: the floor of a closed box recoloured is a weighted sum of the
/// series' terms, with no distribution, agreeing with a distribution of the recoloured box
/// (the reflected light and its direct part), and exactly doubled with the lights doubled;
/// changes the series does not cover are refused with the reason (another material changed,
/// the material made glossy, one light alone changed); a network with directional surfaces
/// gets no series; the series survive the basis's bytes, and damage to them is refused.
#[test]
fn a_reflectance_series_relights_one_material_without_a_distribution() {
    use crate::integrators::illumination_network::relight::{LightBasis, MAX_SERIES_TERMS};
    use crate::math::Rgb;
    use crate::scene::Texture;
    let s = two_light_box(Some("diffuse = 0.4"), None);
    let net = build(&s, params(5, 1.0 / 8.0), Builder::Scan);
    let options = DistributeOptions {
        tolerance: 1e-5,
        ..Default::default()
    };
    let emission: Vec<Rgb> = s.materials.iter().map(|m| m.emission).collect();
    let mut basis = LightBasis::compute(&net, &s, &emission, &options, Run::now());
    basis
        .add_series(&net, &s, (&options, Run::now()), "floor")
        .unwrap();
    let terms = basis.series[0].terms.len();
    assert!((3..MAX_SERIES_TERMS).contains(&terms), "{terms} terms");
    let index = |name: &str| s.materials.iter().position(|m| m.name == name).unwrap();
    let with_floor = |kd: Rgb| {
        let mut t = s.clone();
        classic_mut(&mut t.materials[index("floor")]).diffuse = Texture::Constant(kd);
        t
    };
    let recoloured = with_floor(Rgb::new(0.9, 0.1, 0.6));
    let (got, used) = basis
        .relit_from_series(&net, &recoloured, &emission, &options)
        .unwrap();
    assert_eq!(used.name, "floor");
    assert_eq!(got.stats.sweeps, 0);
    let reference = distribute(&net, &recoloured, &options);
    let close = assert_close;
    close("diffuse", &got.diffuse, &reference.diffuse, 1e-4);
    close("direct", &got.direct, &reference.direct, 1e-5);
    // The old colour gives the basis's own solution back; the lights doubled, double.
    let (unchanged, _) = basis
        .relit_from_series(&net, &s, &emission, &options)
        .unwrap();
    let superposed = basis.superpose(&net, &s, &emission, &options).unwrap();
    close("unchanged", &unchanged.diffuse, &superposed.diffuse, 1e-4);
    let doubled = DistributeOptions {
        light_scale: 2.0,
        ..options
    };
    let (twice, _) = basis
        .relit_from_series(&net, &recoloured, &emission, &doubled)
        .unwrap();
    for (x, y) in twice.diffuse.iter().zip(&got.diffuse) {
        assert_eq!(*x, *y * 2.0);
    }
    // Changes the series does not cover.
    let mut two_changed = recoloured.clone();
    classic_mut(&mut two_changed.materials[index("m")]).diffuse =
        Texture::Constant(Rgb::splat(0.2));
    let e = basis
        .relit_from_series(&net, &two_changed, &emission, &options)
        .unwrap_err();
    assert!(e.contains("no stored reflectance series"), "{e}");
    let mut glossy = recoloured.clone();
    classic_mut(&mut glossy.materials[index("floor")]).specular = Rgb::splat(0.3);
    let e = basis
        .relit_from_series(&net, &glossy, &emission, &options)
        .unwrap_err();
    assert!(e.contains("one diffuse colour"), "{e}");
    let mut one_light = emission.clone();
    one_light[index("warm")] *= 2.0;
    let e = basis
        .relit_from_series(&net, &recoloured, &one_light, &options)
        .unwrap_err();
    assert!(e.contains("unevenly"), "{e}");
    // A network with a mirror gets no series.
    let mirrored = two_light_box(Some("diffuse = 0.4"), Some("diffuse = 0\nspecular = 0.7"));
    let mnet = build(&mirrored, params(5, 1.0 / 6.0), Builder::Scan);
    let memission: Vec<Rgb> = mirrored.materials.iter().map(|m| m.emission).collect();
    let mut mbasis = LightBasis::compute(&mnet, &mirrored, &memission, &options, Run::now());
    let e = mbasis
        .add_series(&mnet, &mirrored, (&options, Run::now()), "floor")
        .unwrap_err();
    assert!(
        e.contains("diffuse surfaces") && e.contains("mirror"),
        "{e}"
    );
    // The bytes: the series come back; cut or lengthened, the basis is refused.
    let bytes = basis.to_bytes();
    let back = LightBasis::from_bytes(&bytes, net.nodes(), net.slots()).unwrap();
    assert_eq!(back, basis);
    for cut in [1, 12, 200] {
        assert!(
            LightBasis::from_bytes(&bytes[..bytes.len() - cut], net.nodes(), net.slots()).is_err()
        );
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(LightBasis::from_bytes(&longer, net.nodes(), net.slots()).is_err());
}
