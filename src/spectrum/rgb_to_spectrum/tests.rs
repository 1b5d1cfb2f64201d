use super::*;

/// The RGB of a reflectance under the space's illuminant by the 1 nm sum of the matching
/// functions, evaluating the spectrum as a renderer would (single precision).
fn rgb_of(space: &ColorSpace, s: impl Fn(f32) -> f32) -> DVec3 {
    let ill = space.illuminant;
    space.xyz_to_rgb(cie::spectrum_to_xyz(|l| s(l as f32) as f64 * ill.eval(l)))
}

/// The grid of colours each space is held to: every combination of the levels.
fn grid(levels: &[f32]) -> Vec<[f32; 3]> {
    let mut v = Vec::new();
    for &r in levels {
        for &g in levels {
            for &b in levels {
                v.push([r, g, b]);
            }
        }
    }
    v
}

/// The sRGB colours of the grid `levels`, in `space`: colours real surfaces have (sRGB's
/// gamut lies within the reflectances'), where Rec.2020 and ACES2065-1 reach far beyond;
/// those with a component outside [0, 1] in `space` (sRGB's D65 white is not ACES's) are left
/// out.
fn srgb_grid_in(space: &ColorSpace, levels: &[f32]) -> Vec<[f32; 3]> {
    let m = space.rgb_from_xyz() * ColorSpace::srgb().xyz_from_rgb();
    grid(levels)
        .into_iter()
        .map(|c| (m * DVec3::from(c.map(f64::from))).as_vec3().to_array())
        .filter(|c| c.iter().all(|v| (0.0..=1.0).contains(v)))
        .collect()
}

fn round_trip(space: &ColorSpace, colours: Vec<[f32; 3]>) {
    let mut worst = (0.0f64, [0.0f32; 3]);
    for rgb in colours {
        let s = solve(space, rgb);
        let back = rgb_of(space, |l| s.eval(l));
        let err = (back - DVec3::from(rgb.map(f64::from))).abs().max_element();
        if err > worst.0 {
            worst = (err, rgb);
        }
        // A reflectance: within [0, 1] everywhere.
        let m = s.max_value();
        assert!((0.0..=1.0).contains(&m), "{rgb:?}: max {m}");
        for l in (360..=830).step_by(5) {
            let v = s.eval(l as f32);
            assert!((0.0..=1.0).contains(&v), "{rgb:?} at {l} nm: {v}");
            assert!(v <= m + 1e-6);
        }
    }
    assert!(
        worst.0 < 1e-3,
        "{}: {:?} comes back {} off",
        space.name,
        worst.1,
        worst.0
    );
}

#[test]
fn srgb_colours_round_trip() {
    round_trip(
        ColorSpace::srgb(),
        grid(&[0.0, 0.1, 0.3, 0.5, 0.7, 0.9, 1.0]),
    );
}

#[test]
fn dci_p3_colours_round_trip() {
    let space = ColorSpace::dci_p3();
    round_trip(space, grid(&[0.05, 0.2, 0.4, 0.6, 0.8, 0.95]));
    round_trip(space, srgb_grid_in(space, &[0.0, 0.2, 0.4, 0.6, 0.8, 1.0]));
}

#[test]
fn rec2020_colours_round_trip() {
    let space = ColorSpace::rec2020();
    round_trip(space, grid(&[0.2, 0.35, 0.5, 0.65]));
    round_trip(space, srgb_grid_in(space, &[0.0, 0.2, 0.4, 0.6, 0.8, 1.0]));
}

#[test]
fn aces_colours_round_trip() {
    let space = ColorSpace::aces2065_1();
    round_trip(space, grid(&[0.3, 0.4, 0.5, 0.6]));
    round_trip(space, srgb_grid_in(space, &[0.0, 0.2, 0.4, 0.6, 0.8, 0.95]));
}

#[test]
fn greys_are_constant_spectra() {
    for g in [0.0, 0.18, 0.5, 0.9, 1.0] {
        let s = solve(ColorSpace::srgb(), [g; 3]);
        for l in [360.0, 500.0, 830.0] {
            assert!((s.eval(l) - g).abs() < 1e-6);
        }
    }
}

#[test]
fn albedo_refuses_components_outside_0_1() {
    assert!(RgbAlbedo::new(ColorSpace::srgb(), [0.2, 1.2, 0.1]).is_err());
    assert!(RgbAlbedo::new(ColorSpace::srgb(), [0.2, -0.1, 0.1]).is_err());
    let a = RgbAlbedo::new(ColorSpace::srgb(), [0.2, 0.6, 0.1]).unwrap();
    let back = rgb_of(ColorSpace::srgb(), |l| a.eval(l));
    assert!((back - DVec3::new(0.2, 0.6, 0.1)).abs().max_element() < 1e-3);
}

#[test]
fn unbounded_spectra_keep_their_rgb() {
    for space in ColorSpace::all() {
        let mut colours = srgb_grid_in(space, &[0.1, 0.5, 0.9]);
        for c in &mut colours {
            *c = c.map(|v| v * 7.0);
        }
        colours.extend([[0.2, 0.1, 0.05], [10.0, 10.0, 10.0], [0.0, 0.0, 0.0]]);
        for rgb in colours {
            let u = RgbUnbounded::new(space, rgb);
            let back = rgb_of(space, |l| u.eval(l));
            let want = DVec3::from(rgb.map(f64::from));
            let err = (back - want).abs().max_element() / want.max_element().max(1.0);
            assert!(err < 1e-3, "{}: {rgb:?} comes back {back}", space.name);
        }
    }
}

#[test]
fn illuminant_spectra_emit_their_rgb() {
    // An emitter's colour is its spectrum integrated alone (no illuminant lights it): RGB
    // (1, 1, 1) is the white at luminance 1, and every RGB comes back.
    for space in ColorSpace::all() {
        for rgb in [[1.0, 1.0, 1.0], [5.0, 2.0, 0.5], [0.1, 0.3, 0.2]] {
            let e = RgbIlluminant::new(space, rgb);
            let xyz = cie::spectrum_to_xyz(|l| e.eval(l as f32) as f64);
            let back = space.xyz_to_rgb(xyz);
            let want = DVec3::from(rgb.map(f64::from));
            let err = (back - want).abs().max_element() / want.max_element();
            assert!(err < 1e-3, "{}: {rgb:?} comes back {back}", space.name);
        }
    }
}

#[test]
fn a_solve_is_deterministic() {
    let a = solve(ColorSpace::rec2020(), [0.8, 0.3, 0.1]);
    let b = solve(ColorSpace::rec2020(), [0.8, 0.3, 0.1]);
    assert_eq!(a, b);
}
