//! Mixed materials (pbrt-v4's `mix`): one of two materials chosen at each hit by a hash of
//! the hit, so the image is the blend of the two within Monte Carlo error, and the same
//! for any thread count.

#[path = "common/render.rs"]
mod render_common;

use raylink::image::compare::mean;
use raylink::image::Image;
use raylink::scene::Scene;
use raylink::{Backend, Technique};
use render_common::{boxed, image, View};
use std::path::Path;

/// A white (kd = 1) and a black diffuse material and their mix choosing black with
/// probability 0.3, on a square seen head-on under a uniform background of radiance 1.
fn scene(material: &str) -> Scene {
    let text = format!(
        "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov = 30\nwidth = 16\nheight = 16\n\
         [world]\nbackground = 1\n\
         [materials.white]\ndiffuse = 1\n\
         [materials.black]\ndiffuse = 0\n\
         [materials.grey]\nmix = {{ materials = [\"white\", \"black\"], amount = 0.3 }}\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"{material}\"\n\
         vertices = [[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]]\n"
    );
    raylink::scene::toml::from_str(&text, Path::new("mix.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn render(scene: &Scene, spp: u32, threads: usize) -> Image {
    let view = View {
        size: (16, 16),
        seed: 5,
        threads: Some(threads),
        accel: Backend::Embree,
    };
    image(scene, Technique::Path(boxed(3, spp)), view)
}

/// The mix renders 0.7 × the white square's radiance: the image mean within 4 standard
/// errors of the choice's binomial noise (16×16 pixels × 64 samples; the white square's own
/// noise is far smaller), and every pixel within 5 of a pixel's.
#[test]
fn a_mix_renders_the_blend_of_its_materials() {
    let spp = 64;
    let white = render(&scene("white"), spp, 2);
    let grey = render(&scene("grey"), spp, 2);
    let (w, g) = (mean(&white, None).x as f64, mean(&grey, None).x as f64);
    let n = (16 * 16 * spp) as f64;
    let se = (0.3 * 0.7 / n).sqrt() * w;
    eprintln!(
        "mix: mean {g:.5} vs 0.7 × white {:.5} (se {se:.5})",
        0.7 * w
    );
    assert!((g - 0.7 * w).abs() < 4.0 * se, "{g} vs 0.7 × {w}");
    let pixel_se = (0.3 * 0.7 / spp as f64).sqrt() * w;
    for (p, q) in grey.pixels.iter().zip(&white.pixels) {
        let want = 0.7 * q.x as f64;
        assert!(
            (p.x as f64 - want).abs() < 5.0 * pixel_se,
            "{} vs {want}",
            p.x
        );
    }
    // Not one material everywhere (as a substitute would render): some pixels are darker
    // than 0.6 and some brighter than 0.8 at 64 samples.
    assert!(grey.pixels.iter().any(|p| p.x < 0.6 * w as f32));
    assert!(grey.pixels.iter().any(|p| p.x > 0.8 * w as f32));
}

/// The choice is a function of the hit: the same image bit for bit on 1 and 2 threads.
#[test]
fn a_mix_renders_the_same_on_any_thread_count() {
    let s = scene("grey");
    let (a, b) = (render(&s, 8, 1), render(&s, 8, 2));
    assert!(
        a.pixels == b.pixels,
        "images differ between 1 and 2 threads"
    );
    assert!(mean(&a, None).x > 0.5, "an empty image");
}
