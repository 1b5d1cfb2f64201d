//! The pbrt-v4 reader's materials, lights and textures: what each statement becomes in
//! raylink's scene, on small scenes written to files.

use raylink::image::Image;
use raylink::math::{Rgb, Vec3};
use raylink::scene::{Classic, Light, Scene};
use std::path::Path;

#[path = "common/pbrt.rs"]
mod pbrt_common;
use pbrt_common::*;

/// The scene's materials in Whitted's classic terms (the fields the reader sets).
fn classics(s: &Scene) -> Vec<&Classic> {
    s.materials.iter().map(|m| m.approximation()).collect()
}

#[test]
fn materials_map_to_raylink_fields() {
    let s = world(&format!(
        "Material \"conductor\" {TRI}\
         Material \"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\" \"float roughness\" 0.25 {TRI}\
         Material \"dielectric\" \"float eta\" 1.33 {TRI}\
         Material \"coateddiffuse\" \"rgb reflectance\" [0.2 0.3 0.4] \"float roughness\" 0.04 \"bool remaproughness\" false {TRI}\
         Material \"diffuse\" {TRI}\
         MakeNamedMaterial \"m\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.1 0.2 0.3]\n\
         NamedMaterial \"m\" {TRI}"
    ));
    let m = classics(&s);
    assert_eq!(m.len(), 6);
    // Copper (pbrt's default conductor) with its complex Fresnel: reddish at normal
    // incidence.
    let cu = m[0].specular_at_normal();
    assert!(cu.x > 0.9 && cu.z < 0.6, "{cu}");
    assert_eq!(m[0].conductor, raylink::scene::Conductor::named("Cu"));
    assert_eq!(m[0].diffuse, raylink::scene::Texture::Constant(Rgb::ZERO));
    assert!(!m[0].fresnel);
    // Gold, roughness remapped to alpha = sqrt(0.25).
    assert_eq!(m[1].conductor, raylink::scene::Conductor::named("Au"));
    assert!((m[1].roughness - 0.5).abs() < 1e-6 && m[1].roughness_v.is_none());
    assert_eq!(
        (m[2].specular, m[2].transmission, m[2].ior, m[2].fresnel),
        (Rgb::ONE, Rgb::ONE, 1.33, true)
    );
    assert_eq!(
        m[3].diffuse,
        raylink::scene::Texture::Constant(Rgb::new(0.2, 0.3, 0.4))
    );
    assert!((m[3].roughness - 0.04).abs() < 1e-6 && m[3].fresnel && m[3].specular == Rgb::ONE);
    assert_eq!(
        m[4].diffuse,
        raylink::scene::Texture::Constant(Rgb::splat(0.5))
    );
    assert_eq!(s.materials[5].name, "m");
    // Anisotropic conductors keep α_x and α_y; `reflectance` gives the index with that
    // normal-incidence reflectance (pbrt-v4: η = 1, k = 2√r/√(1−r)).
    let s = world(&format!(
        "Material \"conductor\" \"float uroughness\" 0.04 \"float vroughness\" 0.16 {TRI}\
         Material \"conductor\" \"rgb reflectance\" [0.9 0.5 0.2] \"float roughness\" 0.3 \"bool remaproughness\" false {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = classics(&s);
    assert!((m[0].roughness - 0.2).abs() < 1e-6);
    assert!((m[0].roughness_v.unwrap() - 0.4).abs() < 1e-6);
    let r = m[1].specular_at_normal();
    assert!(
        (r - Rgb::new(0.9, 0.5, 0.2)).abs().max_element() < 1e-4,
        "{r}"
    );
    assert!((m[1].roughness - 0.3).abs() < 1e-6);
    // A rough dielectric is glass with GGX reflection and refraction, without a warning:
    // isotropic, or anisotropic (u along the tangent, v along the bitangent), remapped
    // unless `remaproughness` is false.
    let s = world(&format!(
        "Material \"dielectric\" \"float roughness\" 0.09 {TRI}\
         Material \"dielectric\" \"float uroughness\" 0.04 \"float vroughness\" 0.25 {TRI}\
         Material \"dielectric\" \"float roughness\" 0.2 \"bool remaproughness\" false {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = classics(&s);
    for g in &m {
        assert_eq!(
            (g.specular, g.transmission, g.ior, g.fresnel),
            (Rgb::ONE, Rgb::ONE, 1.5, true)
        );
    }
    assert!((m[0].roughness - 0.3).abs() < 1e-6 && m[0].roughness_v.is_none());
    assert!((m[1].roughness - 0.2).abs() < 1e-6);
    assert!((m[1].roughness_v.unwrap() - 0.5).abs() < 1e-6);
    assert!((m[2].roughness - 0.2).abs() < 1e-6 && m[2].roughness_v.is_none());
    // Diffuse transmission: reflectance and transmittance (0.25 each by default) times
    // `scale`, without a warning.
    let s = world(&format!(
        "Material \"diffusetransmission\" {TRI}\
         Material \"diffusetransmission\" \"rgb reflectance\" [0.2 0.4 0.1] \"rgb transmittance\" [0.3 0.5 0.1] \"float scale\" 2 {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = classics(&s);
    assert_eq!(
        m[0].diffuse,
        raylink::scene::Texture::Constant(Rgb::splat(0.25))
    );
    assert_eq!(
        m[0].diffuse_transmission,
        raylink::scene::Texture::Constant(Rgb::splat(0.25))
    );
    assert_eq!(
        m[1].diffuse,
        raylink::scene::Texture::Constant(Rgb::new(0.4, 0.8, 0.2))
    );
    assert_eq!(
        m[1].diffuse_transmission,
        raylink::scene::Texture::Constant(Rgb::new(0.6, 1.0, 0.2))
    );
    assert_eq!((m[1].specular, m[1].transmission), (Rgb::ZERO, Rgb::ZERO));
    // A textured transmittance stays a texture (a leaf's veins), without a warning.
    let s = world(&format!(
        "Texture \"c\" \"spectrum\" \"checkerboard\" \"rgb tex1\" [0.5 0.5 0.5] \"rgb tex2\" [0.1 0.2 0.3]\n\
         Material \"diffusetransmission\" \"texture transmittance\" \"c\" {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let t = &s.materials[0].approximation().diffuse_transmission;
    assert!(
        matches!(t, raylink::scene::Texture::UvChecker { .. }),
        "{t:?}"
    );
    // A thin dielectric is a thin sheet of index `eta` (1.5), without a warning.
    let s = world(&format!(
        "Material \"thindielectric\" {TRI}\
         Material \"thindielectric\" \"float eta\" 1.33 {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = classics(&s);
    for (g, eta) in m.iter().zip([1.5, 1.33]) {
        assert_eq!(
            (g.specular, g.transmission, g.ior, g.fresnel, g.thin),
            (Rgb::ONE, Rgb::ONE, eta, true, true)
        );
        assert_eq!((g.roughness, g.roughness_v), (0.0, None));
    }
    assert!(
        !world(&format!("Material \"dielectric\" {TRI}")).materials[0]
            .approximation()
            .thin
    );
    // Unsupported material types: a warning and a substitute.
    let s = world(&format!("Material \"hair\" \"float eumelanin\" 1.3 {TRI}"));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains(":5: material \"hair\" is not supported"));
}

#[test]
fn named_glasses_and_metals_keep_their_spectra() {
    let s = world(&format!(
        "Material \"dielectric\" \"spectrum eta\" \"glass-SF11\" {TRI}\
         Material \"dielectric\" \"float eta\" 1.5 {TRI}\
         Material \"conductor\" {TRI}\
         Material \"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\" {TRI}\
         Material \"conductor\" \"rgb eta\" [0.2 0.9 1.1] \"rgb k\" [3.9 2.4 2.1] {TRI}\
         Material \"conductor\" \"rgb reflectance\" [0.9 0.6 0.5] {TRI}"
    ));
    let m = classics(&s);
    let glass = m[0].spectral.dispersion.map(|n| n.name);
    assert_eq!(glass, Some("SF11"));
    // The RGB index is the glass's at 587.6 nm (SF11's n_d is 1.78472).
    assert!((m[0].ior - 1.78472).abs() < 2e-4, "{}", m[0].ior);
    assert!(m[1].spectral.dispersion.is_none());
    let metal = |c: &Classic| c.spectral.metal.map(|(eta, k)| (eta.name, k.name));
    // pbrt-v4's default conductor is copper's measured index.
    assert_eq!(metal(m[2]), Some(("metal-Cu-eta", "metal-Cu-k")));
    assert_eq!(metal(m[3]), Some(("metal-Au-eta", "metal-Au-k")));
    assert_eq!(metal(m[4]), None);
    assert_eq!(metal(m[5]), None);
}

#[test]
fn lights_and_environment() {
    let s = world(&format!(
        "AttributeBegin Translate 0 1 0 LightSource \"point\" \"rgb I\" [1 2 3] \"float scale\" 2 \"point3 from\" [1 0 0] AttributeEnd\n\
         LightSource \"distant\" \"point3 from\" [0 0 0] \"point3 to\" [0 -1 0] \"blackbody L\" 6500\n\
         LightSource \"infinite\" \"rgb L\" [0.1 0.2 0.3]\n{TRI}"
    ));
    assert_eq!(
        s.lights[0],
        raylink::scene::Light::Point(raylink::scene::lights::PointLight {
            position: Vec3::new(1.0, 1.0, 0.0),
            intensity: Rgb::new(2.0, 4.0, 6.0),
            spectrum: None,
        })
    );
    let raylink::scene::Light::Directional(ref l) = s.lights[1] else {
        panic!()
    };
    let (direction, irradiance) = (l.direction, l.irradiance);
    assert!(close(direction, Vec3::NEG_Y));
    assert!((raylink::math::luminance(irradiance) - 1.0).abs() < 0.03);
    assert_eq!(s.background, Rgb::new(0.1, 0.2, 0.3));

    // An equal-area environment map: the texel of +z (the centre) is read back for +z.
    let dir = tempfile::tempdir().unwrap();
    let mut image = Image::new(8, 8);
    for p in &mut image.pixels {
        *p = Rgb::splat(0.25);
    }
    image.set(4, 4, Rgb::new(4.0, 5.0, 6.0));
    raylink::image::output::write_image(
        &dir.path().join("sky.exr"),
        &image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let s = load_in(
        dir.path(),
        &format!("{HEADER}LightSource \"infinite\" \"string filename\" \"sky.exr\" \"float scale\" 2\n{TRI}"),
        &[],
    )
    .unwrap();
    let env = s.environment.as_ref().expect("environment map");
    assert_eq!(env.eval(Vec3::Z), Rgb::new(8.0, 10.0, 12.0));
    assert_eq!(env.eval(Vec3::X), Rgb::splat(0.5));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);

    // A 2:1 lat-long map (an extension: pbrt-v4 needs `imgtool makeequiarea`) is converted,
    // with a warning, in makeequiarea's orientation: texel (12, 3) of 32x16 is φ = 140.6°
    // from +x towards +y, θ = 36.6° from +z.
    let mut image = Image::new(32, 16);
    image.pixels.fill(Rgb::splat(0.25));
    image.set(12, 3, Rgb::splat(1000.0));
    raylink::image::output::write_image(
        &dir.path().join("latlong.exr"),
        &image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let s = load_in(
        dir.path(),
        &format!("{HEADER}LightSource \"infinite\" \"string filename\" \"latlong.exr\"\n{TRI}"),
        &[],
    )
    .unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("\"latlong.exr\" is a lat-long image"),
        "{:?}",
        s.warnings
    );
    let env = s.environment.as_ref().expect("environment map");
    assert_eq!((env.image.width, env.image.height), (32, 32));
    let (theta, phi) = (
        std::f32::consts::PI * 3.5 / 16.0,
        std::f32::consts::TAU * 12.5 / 32.0,
    );
    let d = Vec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    );
    assert!(env.eval(d).x > 100.0, "{}", env.eval(d));
    assert!(env.eval(Vec3::new(d.x, -d.y, d.z)).x < 0.3);
    // `convert` names the lat-long file, which reads back to the same converted map.
    let out = dir.path().join("latlong.toml");
    raylink::scene::convert::write_toml(&s, &out).unwrap();
    let back = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    let x = back.environment.as_ref().unwrap();
    assert_eq!(x.file, Path::new("latlong.exr"));
    assert_eq!(
        (&x.image, x.transform, x.scale),
        (&env.image, env.transform, env.scale)
    );
}

#[test]
fn textures_checkerboard_and_imagemap() {
    let dir = tempfile::tempdir().unwrap();
    // 2x1 sRGB PNG: left texel mid-grey (sRGB 0.5 -> linear 0.214), right white.
    let mut image = Image::new(2, 1);
    image.set(
        0,
        0,
        Rgb::splat(raylink::image::output::srgb_decode(128.0 / 255.0)),
    );
    image.set(1, 0, Rgb::ONE);
    raylink::image::output::write_image(
        &dir.path().join("t.png"),
        &image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let s = load_in(
        dir.path(),
        &format!(
            "{HEADER}Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 4 \"float vscale\" 4 \
             \"rgb tex1\" [1 0 0] \"rgb tex2\" [0 0 1]\n\
             Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"t.png\"\n\
             Material \"diffuse\" \"texture reflectance\" \"c\" {TRI}\
             Material \"diffuse\" \"texture reflectance\" \"img\" {TRI}"
        ),
        &[],
    )
    .unwrap();
    let uv = raylink::math::Vec2::new;
    let checker = &s.materials[0].approximation().diffuse;
    assert_eq!(checker.eval(Vec3::ZERO, uv(0.1, 0.1), Vec3::Z), Rgb::X);
    assert_eq!(checker.eval(Vec3::ZERO, uv(0.3, 0.1), Vec3::Z), Rgb::Z);
    let img = &s.materials[1].approximation().diffuse;
    let left = img.eval(Vec3::ZERO, uv(0.25, 0.5), Vec3::Z);
    assert!(
        (left.x - raylink::image::output::srgb_decode(128.0 / 255.0)).abs() < 1e-3,
        "{left}"
    );
    assert!((img.eval(Vec3::ZERO, uv(0.75, 0.5), Vec3::Z).x - 1.0).abs() < 1e-3);
}

/// Spot lights as pbrt-v4 defines them (`from`, `to`, `coneangle` 30, `conedelta` 5, `I`,
/// `scale`, `power` = I·k_e with k_e = 2π((1 − cos start) + (cos start − cos end)/2)), and
/// two-sided diffuse area lights, both without warnings.
#[test]
fn spot_lights_and_two_sided_area_lights() {
    let s = world(&format!(
        "LightSource \"spot\" \"point3 from\" [0 2 0] \"point3 to\" [0 0 0] \"rgb I\" [1 2 3] \"float scale\" 2\n\
         LightSource \"spot\" \"float coneangle\" 40 \"float conedelta\" 10 \"float power\" 100\n\
         AttributeBegin AreaLightSource \"diffuse\" \"bool twosided\" true {TRI} AttributeEnd\n"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Light::Spot(ref spot) = s.lights[0] else {
        panic!("{:?}", s.lights[0])
    };
    let (position, direction, intensity, cone_angle, cone_delta) = (
        spot.position,
        spot.direction,
        spot.intensity,
        spot.cone_angle,
        spot.cone_delta,
    );
    // The header's `Scale -1 1 1` mirrors nothing on the y axis.
    assert!(close(position, Vec3::new(0.0, 2.0, 0.0)), "{position}");
    assert!(close(direction, Vec3::new(0.0, -1.0, 0.0)), "{direction}");
    assert_eq!(
        (intensity, cone_angle, cone_delta),
        (Rgb::new(2.0, 4.0, 6.0), 30.0, 5.0)
    );
    let Light::Spot(ref spot) = s.lights[1] else {
        panic!("{:?}", s.lights[1])
    };
    let intensity = spot.intensity;
    let (cs, ce) = (30f64.to_radians().cos(), 40f64.to_radians().cos());
    let k_e = std::f64::consts::TAU * ((1.0 - cs) + (cs - ce) / 2.0);
    assert!(
        (intensity.x as f64 - 100.0 / k_e).abs() < 1e-4,
        "{intensity}"
    );
    let emitter = s.materials.iter().find(|m| m.is_emissive()).unwrap();
    assert!(emitter.two_sided_emission);
}

/// `mix` chooses its second material with probability `amount` at each hit: read without a
/// warning as a mix of the two named materials, which are kept (before it) even when no
/// shape uses them; under an area light, both its materials emit.
#[test]
fn mix_materials_keep_both_materials() {
    let named = "MakeNamedMaterial \"white\" \"string type\" \"diffuse\" \"rgb reflectance\" [1 1 1]\n\
                 MakeNamedMaterial \"glass\" \"string type\" \"dielectric\"\n\
                 MakeNamedMaterial \"both\" \"string type\" \"mix\" \"string materials\" [\"white\" \"glass\"] \"float amount\" 0.3\n";
    let s = world(&format!("{named}NamedMaterial \"both\"\n{TRI}"));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let i = s.shapes[0].material;
    let mix = s.materials[i].mix().cloned().expect("a mix");
    assert!((mix.amount - 0.3).abs() < 1e-6);
    let [a, b] = mix.materials;
    assert!(a < i && b < i, "the mixed materials come before the mix");
    assert_eq!(
        s.materials[a].approximation().diffuse,
        raylink::scene::Texture::Constant(Rgb::ONE)
    );
    let glass = s.materials[b].approximation();
    assert!(glass.fresnel && glass.transmission == Rgb::ONE);
    // The mix's own fields are those of the material with the larger weight.
    assert_eq!(
        s.materials[i].approximation().diffuse,
        s.materials[a].approximation().diffuse
    );
    // Under an area light both mixed materials emit, as the mix does.
    let s = world(&format!(
        "{named}AttributeBegin AreaLightSource \"diffuse\" \"rgb L\" [2 2 2]\nNamedMaterial \"both\"\n{TRI}AttributeEnd\n"
    ));
    let m = &s.materials[s.shapes[0].material];
    assert_eq!(m.emission, Rgb::splat(2.0));
    for j in m.mix().unwrap().materials {
        assert_eq!(s.materials[j].emission, Rgb::splat(2.0));
        assert!(s.materials[j].mix().is_none());
    }
    // Two names are needed.
    let dir = tempfile::tempdir().unwrap();
    let bad = load_in(
        dir.path(),
        &format!("{HEADER}{named}MakeNamedMaterial \"x\" \"string type\" \"mix\" \"string materials\" [\"white\"]\nNamedMaterial \"x\"\n{TRI}"),
        &[],
    );
    assert!(bad.is_err());
}
