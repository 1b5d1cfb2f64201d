//! Thin-lens depth of field and the orthographic camera: the blur of a point off the focal
//! plane against the analytic circle of confusion, path, light and bidirectional tracing
//! agreeing through the lens, an orthographic sphere's size independent of its distance,
//! and the light-path integrators refusing an orthographic camera.

#[path = "common/render.rs"]
mod render_common;

use raylink::image::Image;
use raylink::job::MonteCarloSettings;
use raylink::scene::{Projection, Scene};
use raylink::{Backend, Technique};
use render_common::{boxed, try_image, View};
use std::path::Path;

mod agreement;

fn render(
    scene: &Scene,
    technique: fn(MonteCarloSettings) -> Technique,
    (spp, max_depth, seed): (u32, u32, u64),
) -> raylink::Result<Image> {
    let view = View::of(scene, seed, None, Backend::Embree);
    try_image(scene, technique(boxed(max_depth, spp)), view)
}

fn manifest(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn parse(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("camera.toml")).unwrap()
}

/// Total (summed over channels / 3) and the intensity-weighted second moment about the
/// centroid, E[ρ²] in pixels², of the pixels with x in `columns`.
fn moments(image: &Image, columns: std::ops::Range<u32>) -> (f64, f64) {
    let (mut sum, mut sx, mut sy, mut sxx) = (0.0, 0.0, 0.0, 0.0);
    for y in 0..image.height {
        for x in columns.clone() {
            let p = image.get(x, y);
            let v = (p.x + p.y + p.z) as f64 / 3.0;
            let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
            sum += v;
            sx += v * cx;
            sy += v * cy;
            sxx += v * (cx * cx + cy * cy);
        }
    }
    let (mx, my) = (sx / sum, sy / sum);
    (sum, sxx / sum - mx * mx - my * my)
}

/// Two small emitting spheres on a black background, seen through a thin lens of radius
/// R = 0.2 focused at F = 5: one on the focal plane (left), one at Z = 2.5 (right). A point
/// at depth Z images to a disk of radius R·|1/F − 1/Z| / p pixels (p: the pixel's size at
/// unit distance), 7.17 pixels here. Blurring by a uniform disk of radius r adds r²/2 to the
/// image's second moment E[ρ²], so r = √(2 (E_lens − E_pinhole)) against the pinhole's
/// render of the same spheres. The measured blur radius must be within 3% of the analytic
/// one, the focused sphere's under 0.3 pixel, and both spheres' total light as without
/// the lens (within 2%); path and light tracing alike.
#[test]
fn defocus_blur_matches_the_circle_of_confusion() {
    let (size, fov, radius, focal) = (96u32, 30.0f64, 0.2f64, 5.0f64);
    let spheres = |lens: &str| {
        format!(
            "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nfov = {fov}\nwidth = {size}\nheight = {size}\n{lens}\n\
             [materials.glow]\ndiffuse = 0\nemission = 1\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [-0.6, 0, -5]\nradius = 0.04\nmaterial = \"glow\"\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0.25, 0, -2.5]\nradius = 0.02\nmaterial = \"glow\"\n"
        )
    };
    let lens = parse(&spheres(&format!(
        "lens_radius = {radius}\nfocal_distance = {focal}"
    )));
    assert_eq!(
        lens.camera.projection,
        Projection::ThinLens {
            radius: radius as f32,
            focal_distance: focal as f32
        }
    );
    let pinhole = parse(&spheres(""));
    // Pixel size at unit distance.
    let p = 2.0 * (fov.to_radians() / 2.0).tan() / size as f64;
    let coc = radius * (1.0 / focal - 1.0 / 2.5).abs() / p;
    let half = size / 2;
    let reference = render(&pinhole, Technique::Path, (256, 1, 3)).unwrap();
    let (flux_focus, m0_focus) = moments(&reference, 0..half);
    let (flux_near, m0_near) = moments(&reference, half..size);
    for (name, technique, spp) in [
        ("path", Technique::Path as fn(_) -> _, 1024),
        ("light", Technique::Light as fn(_) -> _, 1024),
    ] {
        let image = render(&lens, technique, (spp, 1, 5)).unwrap();
        let (f_focus, m_focus) = moments(&image, 0..half);
        let (f_near, m_near) = moments(&image, half..size);
        let r_focus = (2.0 * (m_focus - m0_focus)).max(0.0).sqrt();
        let r_near = (2.0 * (m_near - m0_near)).max(0.0).sqrt();
        eprintln!(
            "{name}: focused blur radius {r_focus:.3} px; near blur radius {r_near:.3} px vs circle of confusion {coc:.3} px; light {:.4} and {:.4} of the pinhole's",
            f_focus / flux_focus,
            f_near / flux_near
        );
        assert!(
            r_focus < 0.3,
            "{name}: focused sphere blurred by {r_focus} px"
        );
        assert!(
            (r_near / coc - 1.0).abs() < 0.03,
            "{name}: blur radius {r_near} px, circle of confusion {coc} px"
        );
        for (got, want) in [(f_focus, flux_focus), (f_near, flux_near)] {
            assert!(
                (got / want - 1.0).abs() < 0.02,
                "{name}: flux {got} vs {want}"
            );
        }
    }
}

/// The Cornell box through a thin lens (radius 0.25, focused on the short box 5.5 units
/// away, the back wall and the ceiling visibly blurred): path tracing (camera rays through
/// the lens), light tracing (connections to lens points, pbrt-v4's thin-lens importance)
/// and BDPT render the same image. Each is rendered with 8 seeds; per pixel, the difference
/// of two estimators' means over its standard error must exceed 5 in at most 1% of the
/// pixels, and the image-wide mean difference must be within 4 standard errors.
#[test]
fn path_light_and_bidirectional_agree_through_a_lens() {
    let mut scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    scene.camera.width = 48;
    scene.camera.height = 48;
    scene.camera.projection = Projection::ThinLens {
        radius: 0.25,
        focal_distance: 5.5,
    };
    let results = agreement::over_seeds(
        [
            ("path", (Technique::Path as fn(_) -> _, 16)),
            ("light", (Technique::Light as fn(_) -> _, 32)),
            ("bdpt", (Technique::Bdpt as fn(_) -> _, 8)),
        ],
        |&(technique, spp), seed| render(&scene, technique, (spp, 5, seed)).unwrap(),
    );
    agreement::assert_agree(&results, |_, _, _| true);
}

/// An orthographic camera of `size` 4 across a 64-pixel-wide film shows an emitting sphere of
/// radius 1 as a disk of diameter 2r/size·width = 32 pixels whatever its distance: measured
/// from the disk's area (the sum of box-filtered pixels of value 1 inside), within 0.5%, at
/// distances 3 and 30.
#[test]
fn orthographic_size_does_not_depend_on_distance() {
    for distance in [3.0, 30.0] {
        let scene = parse(&format!(
            "[camera]\nposition = [0, 0, {distance}]\nlook_at = [0, 0, 0]\nwidth = 64\nheight = 48\n\
             projection = \"orthographic\"\nsize = 4\n\
             [materials.glow]\ndiffuse = 0\nemission = 1\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"glow\"\n"
        ));
        assert_eq!(
            scene.camera.projection,
            Projection::Orthographic { size: 4.0 }
        );
        let image = render(&scene, Technique::Path, (64, 1, 1)).unwrap();
        let (area, _) = moments(&image, 0..64);
        let diameter = 2.0 * (area / std::f64::consts::PI).sqrt();
        eprintln!("distance {distance}: diameter {diameter:.3} px");
        assert!((diameter / 32.0 - 1.0).abs() < 0.005, "diameter {diameter}");
    }
}

/// Light paths cannot reach an orthographic camera: light tracing and BDPT refuse it with
/// one line naming the option.
#[test]
fn light_paths_refuse_an_orthographic_camera() {
    let scene = parse(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nprojection = \"orthographic\"\nsize = 4\n\
         [materials.glow]\nemission = 1\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"glow\"\n",
    );
    for technique in [
        Technique::Light as fn(_) -> _,
        Technique::Bdpt as fn(_) -> _,
    ] {
        let e = render(&scene, technique, (1, 1, 1))
            .unwrap_err()
            .to_string();
        assert!(!e.contains('\n'), "{e}");
        assert!(
            e.contains("camera.toml")
                && e.contains("orthographic camera (projection = \"orthographic\")"),
            "{e}"
        );
    }
}
