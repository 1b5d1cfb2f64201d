use super::*;
use crate::spectrum::named_data::METAL_LAMBDA;
use crate::spectrum::{cie, ColorSpace};
use glam::DVec3;

/// The helium d line (nm), where glass catalogues give n_d.
const D_LINE: f64 = 587.5618;

fn n(name: &str, lambda: f64) -> f64 {
    named(name).unwrap().eval(lambda as f32) as f64
}

#[test]
fn glasses_have_their_catalogue_indices() {
    // n_d: Schott N-BK7 1.5168, N-BAF10 1.6700, N-FK51A 1.4866; fused silica 1.4585
    // (Malitson).
    for (name, nd) in [
        ("glass-BK7", 1.5168),
        ("glass-BAF10", 1.6700),
        ("glass-FK51A", 1.4866),
        ("glass-fused-silica", 1.4585),
    ] {
        let got = n(name, D_LINE);
        assert!((got - nd).abs() < 1e-4, "{name}: {got}");
    }
    // Normal dispersion: the index falls with wavelength.
    assert!(n("glass-BK7", 400.0) > n("glass-BK7", 700.0));
}

#[test]
fn sellmeier_coefficients_agree_with_pbrts_tables() {
    // pbrt-v4's glass tables (computed by refractiveindex.info from the catalogues),
    // independent of the coefficients typed here: (name, λ nm, n) at the start of each table,
    // whose first wavelength is exact (the others are rounded to the nanometre), and BK7's,
    // whose steps are whole nanometres.
    for (name, lambda, want) in [
        ("glass-BK7", 300.0, 1.552_770_263_573_9),
        ("glass-BK7", 586.0, 1.516_865_556_749),
        ("glass-BK7", 916.0, 1.508_742_672_736_3),
        ("glass-BAF10", 350.0, 1.712_688_084_826_8),
        ("glass-FK51A", 290.0, 1.514_577_720_408_2),
        ("glass-LASF9", 370.0, 1.919_972_554_570_5),
        ("glass-F5", 370.0, 1.728_654_984_724_5),
        ("glass-F10", 380.0, 1.790_578_894_841_9),
        ("glass-SF11", 370.0, 1.870_021_617_323_4),
    ] {
        let got = n(name, lambda);
        assert!(
            (got - want).abs() < 2e-6,
            "{name} at {lambda}: {got} against {want}"
        );
    }
}

#[test]
fn cauchy_fits_bk7_near_the_d_line() {
    // The textbook two-term Cauchy fit of BK7: A = 1.5046, B = 0.00420 µm².
    let c = Cauchy {
        a: 1.5046,
        b: 0.00420,
    };
    assert!((c.eta(D_LINE) - 1.5168).abs() < 2e-4);
    assert!((c.eta(D_LINE) - n("glass-BK7", D_LINE)).abs() < 2e-4);
}

#[test]
fn lookup_follows_pbrts_names() {
    let cu = named("metal-Cu-eta").unwrap();
    assert_eq!(cu.name, "metal-Cu-eta");
    assert!((cu.eval(METAL_LAMBDA[41]) - 0.468).abs() < 1e-6);
    assert!((named("metal-Cu-k").unwrap().eval(METAL_LAMBDA[45]) - 3.67).abs() < 1e-6);
    assert_eq!(named("glass-F11"), named("glass-SF11"));
    assert_eq!(named("stdillum-D65").unwrap().name, "stdillum-D65");
    for bad in [
        "metal-Cu",
        "metal-Cu-n",
        "metal-Zz-eta",
        "glass-XYZ",
        "stdillum-Q",
        "",
    ] {
        assert!(named(bad).is_none(), "{bad}");
    }
    for m in ["Ag", "Al", "Au", "Cu", "Cr", "Ni", "Ti"] {
        for p in ["eta", "k"] {
            let name = format!("metal-{m}-{p}");
            assert_eq!(named(&name).unwrap().name, name);
        }
    }
}

/// Rakić et al.'s Lorentz–Drude parameters for copper and gold (Appl. Opt. 37, 1998, Table
/// 1), to hold the model's code to the measured tables.
const COPPER_LD: LorentzDrude = LorentzDrude {
    plasma: 10.83,
    drude: (0.575, 0.030),
    lorentz: [
        (0.061, 0.291, 0.378),
        (0.104, 2.957, 1.056),
        (0.723, 5.300, 3.213),
        (0.638, 11.18, 4.305),
    ],
};
const GOLD_LD: LorentzDrude = LorentzDrude {
    plasma: 9.03,
    drude: (0.760, 0.053),
    lorentz: [
        (0.024, 0.415, 0.241),
        (0.010, 0.830, 0.345),
        (0.071, 2.969, 0.870),
        (0.601, 4.304, 2.494),
    ],
};

/// Reflectance at normal incidence of a conductor of index η + ik in vacuum.
fn fresnel(eta: f64, k: f64) -> f64 {
    ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k)
}

/// ε by the same model written as five Lorentz oscillators (the free electrons one of
/// frequency 0), and its square root in polar form: a second implementation.
fn eta_k_polar(m: &LorentzDrude, lambda: f64) -> (f64, f64) {
    let w = 1_239.841_984 / lambda;
    let wp2 = m.plasma * m.plasma;
    let mut osc = vec![(m.drude.0, 0.0, m.drude.1)];
    osc.extend(m.lorentz);
    let (mut re, mut im) = (1.0, 0.0);
    for (f, wj, g) in osc {
        // f ωp² / (a − ib) = f ωp² (a + ib) / (a² + b²).
        let (a, b) = (wj * wj - w * w, w * g);
        re += f * wp2 * a / (a * a + b * b);
        im += f * wp2 * b / (a * a + b * b);
    }
    let (r, theta) = (re.hypot(im).sqrt(), im.atan2(re) / 2.0);
    (r * theta.cos(), r * theta.sin())
}

#[test]
fn the_lorentz_drude_model_is_right() {
    for m in [COPPER_LD, GOLD_LD, CHROMIUM, NICKEL, TITANIUM] {
        for lambda in [360.0, 450.0, 550.0, 650.0, 830.0] {
            let (e, k) = m.eta_k(lambda);
            let (pe, pk) = eta_k_polar(&m, lambda);
            assert!(
                (e - pe).abs() < 1e-9 && (k - pk).abs() < 1e-9,
                "{m:?} at {lambda}"
            );
            assert!(e > 0.0 && k > 0.0);
        }
    }
    // Against copper's measured table in the red, where the fit is close: k within 5 %,
    // the reflectance within 0.02.
    for lambda in [700.0, 750.0, 800.0] {
        let (eta, k) = COPPER_LD.eta_k(lambda);
        let (te, tk) = (n("metal-Cu-eta", lambda), n("metal-Cu-k", lambda));
        assert!((k / tk - 1.0).abs() < 0.05, "{lambda}: k {k} against {tk}");
        assert!((fresnel(eta, k) - fresnel(te, tk)).abs() < 0.02, "{lambda}");
    }
    // Chromium, nickel and titanium are grey metals of middling reflectance.
    for m in ["Cr", "Ni", "Ti"] {
        for lambda in [450.0, 550.0, 650.0] {
            let r = fresnel(
                n(&format!("metal-{m}-eta"), lambda),
                n(&format!("metal-{m}-k"), lambda),
            );
            assert!((0.45..0.75).contains(&r), "{m} at {lambda}: R {r}");
        }
    }
}

/// The sRGB colour of a metal's normal reflectance under D65 by Monte Carlo over sampled
/// wavelengths, the way a spectral renderer sees it.
fn metal_rgb_sampled(metal: &str) -> DVec3 {
    let eta = named(&format!("metal-{metal}-eta")).unwrap();
    let k = named(&format!("metal-{metal}-k")).unwrap();
    let d65 = named("stdillum-D65").unwrap();
    let n = 20000;
    let mut sum = DVec3::ZERO;
    for i in 0..n {
        let w = SampledWavelengths::sample_visible((i as f32 + 0.5) / n as f32);
        let (e, kk) = (eta.sample(&w), k.sample(&w));
        let mut r = SampledSpectrum::ZERO;
        for j in 0..crate::spectrum::N_SAMPLES {
            r[j] = fresnel(e[j] as f64, kk[j] as f64) as f32;
        }
        sum += (r * d65.sample(&w))
            .to_rgb(&w, ColorSpace::srgb())
            .as_dvec3();
    }
    sum / n as f64
}

#[test]
fn gold_is_yellow_and_copper_matches_direct_integration() {
    let gold = metal_rgb_sampled("Au");
    assert!(gold.x > gold.y && gold.y > gold.z, "gold {gold}");
    let copper = metal_rgb_sampled("Cu");
    // Direct integration every nanometre with the published sRGB matrix (IEC 61966-2-1).
    let mut xyz = DVec3::ZERO;
    let mut norm = 0.0;
    for l in 360..=830 {
        let l = l as f64;
        let r = fresnel(n("metal-Cu-eta", l), n("metal-Cu-k", l));
        let e = cie::Illuminant::D65.eval(l);
        xyz += cie::cmf_xyz(l) * r * e;
        norm += cie::cmf_xyz(l).y * e;
    }
    let xyz = xyz / norm;
    let direct = DVec3::new(
        3.2406 * xyz.x - 1.5372 * xyz.y - 0.4986 * xyz.z,
        -0.9689 * xyz.x + 1.8758 * xyz.y + 0.0415 * xyz.z,
        0.0557 * xyz.x - 0.2040 * xyz.y + 1.0570 * xyz.z,
    );
    assert!(
        direct.x > direct.y && direct.y > direct.z,
        "copper {direct}"
    );
    let err = ((copper - direct) / direct).abs().max_element();
    assert!(
        err < 0.01,
        "copper: sampled {copper} against direct {direct}"
    );
}
