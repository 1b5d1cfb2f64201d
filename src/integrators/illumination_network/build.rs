//! The preprocess's entry point: patches and links for a scene, then the assembly; and what
//! it did.

use super::patches::Patches;
use super::preprocess::{self, Builder, EndPacking, LinkInputs};
use super::ray_space::RaySpace;
use super::{LinkCode, Network, NetworkParams};
use crate::control::Control;
use crate::scene::Scene;
use crate::transport::Context;
use std::time::Instant;

/// What a preprocess did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Line-patch intersections found.
    pub intersections: u64,
    /// Link ends stored (each link counts at both of its nodes).
    pub link_ends: u64,
    /// Slots whose line leaves the scene.
    pub escapes: u64,
    /// Links beyond the first of their slot at a node (a patch meeting two lines of a slot).
    pub extra: u64,
    /// Consecutive hits of a line on the same side or on touching surfaces (no link).
    pub degenerate: u64,
    /// Closest-hit queries (Embree builder).
    pub rays: u64,
    /// Whole preprocess, and its parts: finding and linking the lines (parallel over slots)
    /// and assembling the node table.
    pub seconds: f64,
    pub link_seconds: f64,
    pub assemble_seconds: f64,
}

/// Why a network could not be built: a problem of the scene or the parameters (a sentence),
/// or an error of another kind (memory the system refused), kept as it is.
#[derive(Debug)]
pub(crate) enum BuildError {
    Scene(String),
    Error(crate::error::Error),
}

impl From<String> for BuildError {
    fn from(s: String) -> Self {
        BuildError::Scene(s)
    }
}

impl From<&str> for BuildError {
    fn from(s: &str) -> Self {
        BuildError::Scene(s.to_string())
    }
}

impl From<crate::error::Error> for BuildError {
    fn from(e: crate::error::Error) -> Self {
        BuildError::Error(e)
    }
}

impl std::fmt::Display for BuildError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BuildError::Scene(s) => f.write_str(s),
            BuildError::Error(e) => e.fmt(f),
        }
    }
}

impl Network {
    /// Preprocess: patches and links for a scene. The Embree builder casts through `ctx`.
    pub fn build(
        scene: &Scene,
        ctx: &Context,
        params: NetworkParams,
        builder: Builder,
    ) -> Result<Network, String> {
        let control = Control::default();
        Self::build_packed(
            scene,
            ctx,
            params,
            builder,
            EndPacking::for_keys,
            true,
            &control,
        )
        .map_err(|e| e.to_string())
    }

    /// [`Network::build`] under a job's controls: its memory budget bounds the network, and
    /// a cancel stops the preprocess. A problem of the scene's is an error naming its file.
    pub(crate) fn build_with(
        scene: &Scene,
        ctx: &Context,
        params: NetworkParams,
        builder: Builder,
        control: &Control,
    ) -> crate::error::Result<Network> {
        let built = Self::build_packed(
            scene,
            ctx,
            params,
            builder,
            EndPacking::for_keys,
            true,
            control,
        );
        control.cancel.check("the network preprocess")?;
        built.map_err(|e| match e {
            BuildError::Scene(e) => crate::error::Error::input(&scene.source, e),
            BuildError::Error(e) => e,
        })
    }

    /// [`Network::build`] with the preprocess's link ends packed as `packing(side keys)` says,
    /// and the escapes of sides facing out of the scene dropped as the linking finds them or
    /// (`drop_outer` false) by the assembly, as those of any side that is not a node.
    fn build_packed(
        scene: &Scene,
        ctx: &Context,
        params: NetworkParams,
        builder: Builder,
        packing: impl FnOnce(usize) -> Result<EndPacking, String>,
        drop_outer: bool,
        control: &Control,
    ) -> Result<Network, BuildError> {
        params.validate().map_err(|e| e.to_string())?;
        let start = Instant::now();
        let bounds = scene.bounds().ok_or("the scene has no shapes")?;
        let space = RaySpace::new(params.slopes, params.step, bounds);
        let patches = Patches::new(scene, &space, params.patch_size)?;
        // A bound: a link per slot for each side of each cell (half of them are linked in a
        // closed room); the preprocess's link ends take about as much again.
        let table = patches.cells as u64 * 2 * space.slots() as u64 * 4;
        control
            .budget
            .check("the illumination network", 2 * table)
            .map_err(|e| e.to_string())?;
        if builder == Builder::Scan {
            if let Some(p) = patches.polygons.iter().find(|p| p.sphere.is_some()) {
                return Err(format!(
                    "shape {} is a sphere: the scan converter projects polygons only; use \
                     the embree network builder",
                    p.shape
                )
                .into());
            }
        }
        let keys = 2 * patches.cells as usize;
        let packing = packing(keys)?;
        let code = LinkCode::new(space.slots(), keys)?;
        let outer = match drop_outer {
            true => patches.outer_sides(),
            false => vec![0; keys.div_ceil(64)],
        };
        let t = Instant::now();
        let (batches, rays) = preprocess::build_links(&LinkInputs {
            ctx: (builder == Builder::Embree).then_some(ctx),
            space: &space,
            patches: &patches,
            seed: params.seed,
            jitter: params.jitter,
            builder,
            packing,
            outer: &outer,
            cancel: &control.cancel,
        });
        if control.cancel.is_cancelled() {
            return Err("cancelled".into());
        }
        let link_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mut net = Network::assemble(params, space, patches, &batches, packing, code)?;
        net.stats.assemble_seconds = t.elapsed().as_secs_f64();
        net.stats.link_seconds = link_seconds;
        net.stats.rays = rays.total();
        net.stats.seconds = start.elapsed().as_secs_f64();
        Ok(net)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{self, Backend};

    /// The loops over link ends are compiled apart for the usual packing
    /// ([`EndPacking::known`]): the other copies, those of networks of more than 2^23 side
    /// keys, must build the same network.
    #[test]
    fn every_packing_of_link_ends_builds_the_same_network() {
        let (scene, params) = cornell_network();
        let acc = accel::build(&scene, Backend::Embree, &Control::default()).unwrap();
        let ctx = Context::new(&scene, acc.as_ref());
        let usual = Network::build(&scene, &ctx, params, Builder::Scan).unwrap();
        // Blocks of 64 keys: the smallest the packing allows.
        let small = |_| {
            Ok(EndPacking {
                block_bits: 6,
                target_bits: 26,
            })
        };
        let other = Network::build_packed(
            &scene,
            &ctx,
            params,
            Builder::Scan,
            small,
            true,
            &Control::default(),
        )
        .unwrap();
        assert_eq!(
            EndPacking::for_keys(2 * usual.patches.cells as usize),
            Ok(EndPacking::USUAL)
        );
        assert!(usual.links.len() > 10_000 && usual.stats.escapes > 0 && usual.stats.extra > 0);
        assert_same_network(&usual, &other);
    }

    /// The linking drops the escapes of sides facing out of the scene, which the assembly
    /// would drop as those of sides that are not nodes: the network is the same either way.
    /// The Cornell box is open at the front, so some of its nodes have escapes.
    #[test]
    fn dropping_the_outer_sides_escapes_builds_the_same_network() {
        let (scene, params) = cornell_network();
        let acc = accel::build(&scene, Backend::Embree, &Control::default()).unwrap();
        let ctx = Context::new(&scene, acc.as_ref());
        for builder in [Builder::Scan, Builder::Embree] {
            let build = |drop| {
                Network::build_packed(
                    &scene,
                    &ctx,
                    params,
                    builder,
                    EndPacking::for_keys,
                    drop,
                    &Control::default(),
                )
                .unwrap()
            };
            let (dropped, kept) = (build(true), build(false));
            let outer = dropped.patches.outer_sides();
            // The ceiling and three walls (the floor is tilted by a hair).
            let ones: u32 = outer.iter().map(|w| w.count_ones()).sum();
            assert!(ones > 1000, "{ones} outer sides");
            assert!(dropped.stats.escapes > 0);
            assert_same_network(&dropped, &kept);
        }
    }

    /// The Cornell box and a small network's parameters.
    fn cornell_network() -> (Scene, NetworkParams) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let params = NetworkParams {
            slopes: 4,
            step: 1.0 / 32.0,
            patch_size: 1.0 / 16.0,
            jitter: 1.0,
            seed: 3,
        };
        (Scene::load(&path).unwrap(), params)
    }

    /// The two networks are the same, bit for bit.
    fn assert_same_network(a: &Network, b: &Network) {
        assert_eq!(a.key_of_node, b.key_of_node);
        assert_eq!(a.node_of_key, b.node_of_key);
        assert_eq!(a.link_start, b.link_start);
        assert_eq!(a.links, b.links);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.etendue), bits(&b.etendue));
        assert_eq!(bits(&a.escape_etendue), bits(&b.escape_etendue));
        assert_eq!(a.stats.extra, b.stats.extra);
        assert_eq!(a.stats.escapes, b.stats.escapes);
    }
}
