//! Techniques made from their settings: one dispatch from a [`Technique`] to the
//! [`Lifecycle`] that prepares and renders it (pbrt-v4's `Integrator::Create`).

use super::technique::Technique;
use crate::error::Result;
use crate::integrators::bdpt::{Bdpt, BdptOptions};
use crate::integrators::illumination_network::technique::NetworkTechnique;
use crate::integrators::irradiance_cache::technique::CacheTechnique;
use crate::integrators::light::{LightOptions, LightTracer};
use crate::integrators::path::{PathOptions, PathTracer};
use crate::integrators::whitted::{Whitted, WhittedOptions};
use crate::scene::Scene;
use crate::transport::technique::MonteCarloSettings;
use crate::transport::technique::{Lifecycle, Tiles};
use crate::transport::MonteCarlo;
use crate::transport::PixelSampling;

/// The technique `technique` describes, for `scene` (pbrt's `Integrator::Create`).
pub(crate) fn create(technique: &Technique, scene: &Scene) -> Result<Box<dyn Lifecycle>> {
    Ok(match technique {
        Technique::Whitted(w) => Box::new(WhittedTechnique {
            integrator: Whitted::new(WhittedOptions {
                max_depth: w.max_depth,
                area_samples: w.area_samples,
                fresnel: w.fresnel,
                ..WhittedOptions::default()
            }),
            sampling: w.sampling,
        }),
        Technique::Path(mc) => Box::new(MonteCarloTechnique {
            integrator: PathTracer::new(PathOptions {
                max_depth: mc.max_depth,
            }),
            settings: *mc,
        }),
        Technique::Light(mc) => {
            refuse_orthographic(scene, "light")?;
            Box::new(MonteCarloTechnique {
                integrator: LightTracer::new(LightOptions {
                    max_depth: mc.max_depth,
                }),
                settings: *mc,
            })
        }
        Technique::Bdpt(mc) => {
            refuse_orthographic(scene, "bdpt")?;
            Bdpt::check_scene(scene).map_err(|e| crate::error::Error::input(&scene.source, e))?;
            Box::new(MonteCarloTechnique {
                integrator: Bdpt::new(BdptOptions {
                    max_depth: mc.max_depth,
                }),
                settings: *mc,
            })
        }
        Technique::IrradianceCache(mc, cache) => Box::new(CacheTechnique::new(*mc, cache.clone())),
        Technique::Network(n) => Box::new(NetworkTechnique::new(n.clone(), scene)),
    })
}

/// Whitted's ray tracer: nothing to prepare.
struct WhittedTechnique {
    integrator: Whitted,
    sampling: PixelSampling,
}

impl Lifecycle for WhittedTechnique {
    fn tiles(&self) -> Tiles<'_> {
        Tiles::Pixels(&self.integrator, self.sampling)
    }
}

/// The path, light and bidirectional tracers: nothing to prepare.
struct MonteCarloTechnique<T> {
    integrator: T,
    settings: MonteCarloSettings,
}

impl<T: MonteCarlo + Send> Lifecycle for MonteCarloTechnique<T> {
    fn tiles(&self) -> Tiles<'_> {
        Tiles::Samples(&self.integrator, self.settings)
    }
}

/// Light paths reach the camera by connecting to it, which an orthographic camera's
/// importance (a delta in direction) does not allow; pbrt-v4 refuses it too.
fn refuse_orthographic(scene: &Scene, integrator: &str) -> crate::error::Result<()> {
    if matches!(
        scene.camera.projection,
        crate::scene::Projection::Orthographic { .. }
    ) {
        return Err(crate::error::Error::input(
            &scene.source,
            format!(
                "the {integrator} integrator cannot connect light paths to an orthographic camera (projection = \"orthographic\"): use a perspective camera or the path integrator"
            ),
        ));
    }
    Ok(())
}
