//! What the network tests share: scenes parsed from text, the test networks' parameters,
//! a network built with Embree's help, the Cornell box.

use super::network_scenes::closed_box_text;
use crate::accel::{self, Backend};
use crate::control::Control;
use crate::image::filter::Filter;
use crate::image::Image;
use crate::integrators::illumination_network::preprocess::Builder;
use crate::integrators::illumination_network::{Network, NetworkParams};
use crate::render::progressive::render_passes;
use crate::scene::Scene;
use crate::transport::ProgressiveOptions;
use crate::transport::View;
use crate::transport::{Context, MonteCarlo};
use std::path::Path;

pub(crate) fn scene(text: &str) -> Scene {
    crate::scene::toml::from_str(text, Path::new("test.toml")).expect("test scene parses")
}

/// The unit cube, closed, every wall of material `m` except the floor (y = 0) of `floor`.
pub(crate) fn closed_box(materials: &str, m: &str, floor: &str) -> Scene {
    scene(&closed_box_text(materials, m, floor))
}

pub(crate) fn params(slopes: u32, step: f32) -> NetworkParams {
    NetworkParams {
        slopes,
        step,
        patch_size: step,
        jitter: 1.0,
        seed: 7,
    }
}

pub(crate) fn build(scene: &Scene, p: NetworkParams, builder: Builder) -> Network {
    let accel = accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    Network::build(scene, &ctx, p, builder).unwrap()
}

/// `scene` rendered by a Monte Carlo `integrator` (the references of the network and table
/// tests) at `size`×`size` pixels, `spp` samples per pixel, seed `seed`, a box filter.
pub(crate) fn monte_carlo_image(
    scene: &Scene,
    integrator: &dyn MonteCarlo,
    size: u32,
    spp: u32,
    seed: u64,
) -> Image {
    let accel = accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let options = ProgressiveOptions {
        view: View {
            seed,
            ..View::new(size, size)
        },
        spp,
        time_limit: None,
        filter: Filter::Box { radius: 0.5 },
        reconstruction: crate::image::filter::Reconstruction::Splat,
        adaptive: None,
        max_component_value: None,
        statistics: false,
    };
    let watch = crate::render::Watch::nobody();
    let (film, _) =
        render_passes(&ctx, integrator, &options, None, watch, &Control::default()).unwrap();
    film.image().unwrap()
}

pub(crate) fn cornell() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml")).unwrap()
}
