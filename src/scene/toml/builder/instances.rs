//! `[[shapes]]`, `[[objects]]` and `[[instances]]`: shapes in world space, and objects
//! stored once and placed by instances. An object's shapes that emit, move or have an alpha
//! are copied into world space at each placement (light sampling, motion and the cut-out
//! tests work on world-space shapes); the others are placed as instances of one prototype.

use super::super::diagnostics::Site;
use super::super::schema::{InstanceDesc, ObjectDesc, ShapeDesc};
use super::Builder;
use crate::error::Error;
use crate::scene::pbrt::GeometryCost;
use crate::scene::{Instance, Prototype, Shape};
use std::collections::HashMap;
use std::sync::Arc;
use toml::Spanned;

/// What the shape tables of a file become.
pub(in super::super) struct Placed {
    /// World-space shapes: `[[shapes]]`, then the copies of objects' emitting or cut-out
    /// shapes.
    pub(in super::super) shapes: Vec<Shape>,
    pub(in super::super) prototypes: Vec<Arc<Prototype>>,
    pub(in super::super) instances: Vec<Instance>,
}

impl Builder<'_> {
    /// Reads the shapes, objects and instances, checking the geometry read so far against
    /// the job's memory budget.
    pub(in super::super) fn placed(
        &mut self,
        shapes: Vec<Spanned<ShapeDesc>>,
        objects: Vec<Spanned<ObjectDesc>>,
        instances: Vec<Spanned<InstanceDesc>>,
    ) -> crate::error::Result<Placed> {
        let ctx = self.ctx;
        if shapes.is_empty() && instances.is_empty() {
            return Err(Error::input(
                ctx.path,
                "the scene has no shapes: add at least one [[shapes]] table",
            ));
        }
        let mut cost = GeometryCost::default();
        let mut world = self.shape_list(shapes, "shapes", &mut cost)?;
        // Per object: its prototype (if any shape is shared) and the shapes copied.
        let mut defined: HashMap<String, (Option<u32>, Vec<Shape>)> = HashMap::new();
        let mut prototypes = Vec::new();
        for (i, desc) in objects.into_iter().enumerate() {
            let site = self.site(format!("objects[{i}]"), desc.span());
            let desc = desc.into_inner();
            if defined.contains_key(&desc.name) {
                return Err(ctx.fail(
                    &site,
                    "name",
                    format!("another object is named \"{}\"", desc.name),
                ));
            }
            if desc.shapes.is_empty() {
                return Err(ctx.fail(
                    &site,
                    "",
                    "an object needs at least one [[objects.shapes]] table".to_string(),
                ));
            }
            let list = self.shape_list(desc.shapes, &format!("objects[{i}].shapes"), &mut cost)?;
            let (copied, shared): (Vec<Shape>, Vec<Shape>) = list.into_iter().partition(|s| {
                s.alpha.is_some() || s.moves() || self.materials[s.material].is_emissive()
            });
            let prototype = (!shared.is_empty()).then(|| {
                prototypes.push(Arc::new(Prototype {
                    name: desc.name.clone(),
                    shapes: shared,
                }));
                prototypes.len() as u32 - 1
            });
            defined.insert(desc.name, (prototype, copied));
        }
        let mut placed = Vec::new();
        for (i, desc) in instances.into_iter().enumerate() {
            if let Some(control) = ctx.control {
                control.cancel.check("reading the scene")?;
            }
            let site = self.site(format!("instances[{i}]"), desc.span());
            let desc = desc.into_inner();
            let Some((prototype, copied)) = defined.get(&desc.object) else {
                return Err(ctx.fail(
                    &site,
                    "object",
                    format!("no [[objects]] table is named \"{}\"", desc.object),
                ));
            };
            let m = self.transform(&site, desc.transform)?.m.as_dmat4();
            for shape in copied {
                let copies = crate::scene::pbrt::placed_copies(shape, &m);
                cost = copies
                    .iter()
                    .fold(cost, |c, s| c.add(GeometryCost::of(&s.geometry)));
                world.extend(copies);
            }
            if let Some(p) = *prototype {
                let instance = Instance::new(p, m)
                    .ok_or_else(|| ctx.fail(&site, "transform", "is singular"))?;
                placed.push(instance);
                cost = cost.add(GeometryCost {
                    data: std::mem::size_of::<Instance>() as u64,
                    primitives: 1,
                });
            }
            self.check_budget(&site, cost)?;
        }
        Ok(Placed {
            shapes: world,
            prototypes,
            instances: placed,
        })
    }

    /// The shapes of `list` (named `name[i]` in messages), adding their cost to `cost`.
    fn shape_list(
        &mut self,
        list: Vec<Spanned<ShapeDesc>>,
        name: &str,
        cost: &mut GeometryCost,
    ) -> crate::error::Result<Vec<Shape>> {
        let mut shapes = Vec::new();
        for (i, desc) in list.into_iter().enumerate() {
            if let Some(control) = self.ctx.control {
                control.cancel.check("reading the scene")?;
            }
            let site = self.site(format!("{name}[{i}]"), desc.span());
            let mut desc = desc.into_inner();
            let alpha = self.alpha(&site, desc.alpha.take())?;
            let media = self.shape_media(&site, desc.media.take())?;
            let motion = desc.motion.take();
            let mut new = self.shape(&site, desc)?;
            self.motion(&site, motion, &mut new)?;
            if alpha.is_some() {
                new.iter_mut().for_each(|s| s.alpha = alpha.clone());
            }
            new.iter_mut().for_each(|s| s.media = media);
            *cost = new
                .iter()
                .fold(*cost, |c, s| c.add(GeometryCost::of(&s.geometry)));
            self.check_budget(&site, *cost)?;
            shapes.extend(new);
        }
        Ok(shapes)
    }

    /// The geometry read so far and its intersection structures against the job's budget.
    fn check_budget(&self, site: &Site, cost: GeometryCost) -> crate::error::Result<()> {
        let ctx = self.ctx;
        let Some(control) = ctx.control else {
            return Ok(());
        };
        let needed = cost
            .bytes()
            .saturating_add(ctx.text.len() as u64)
            .saturating_add(self.images.get());
        // The message only for a refusal: its line number counts the file's lines up to the
        // table, which for every shape or instance made reading quadratic.
        if control.budget.check("", needed).is_ok() {
            return Ok(());
        }
        control.budget.check(
            &format!(
                "{}: line {}: {}: the scene's geometry ({} primitives so far) and its \
                 intersection structures",
                ctx.path.display(),
                ctx.key_line(&site.span, ""),
                site.name,
                cost.primitives
            ),
            needed,
        )
    }
}
