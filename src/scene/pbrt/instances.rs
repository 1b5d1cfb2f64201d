//! `ObjectInstance`: an object's shapes placed by the current transform. Shapes that emit,
//! move or have an alpha are copied into world space at each placement (light sampling,
//! motion and the cut-out tests work on world-space shapes); the others are stored once, as
//! a prototype, and placed as an instance, so memory grows with the objects, not with their
//! placements.

use super::builder::Builder;
use super::cost::Cost;
use super::{shapes, Loc};
use crate::scene::{Instance, Prototype, Shape};
use glam::DMat4;

impl Builder {
    /// Whether a shape of an object is copied at each placement rather than instanced.
    pub(super) fn copied_when_placed(&self, shape: &Shape) -> bool {
        shape.alpha.is_some() || shape.moves() || self.materials[shape.material].is_emissive()
    }

    /// Places object `name` (defined) by `t`, object to world.
    pub(super) fn place_object(
        &mut self,
        name: &str,
        t: &DMat4,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        let what = format!("ObjectInstance \"{name}\"");
        let def = &self.objects[name];
        // Counted before it is copied: what the copies and the placement will take.
        let copies = def.instance_cost(shapes::uniform_scale(t).is_some());
        let shares = !def.shared.is_empty();
        let placement = Cost {
            data: std::mem::size_of::<Instance>() as u64,
            primitives: u64::from(shares),
        };
        let first = shares && def.prototype.is_none();
        let prototype = if first {
            def.prototype_cost()
        } else {
            Cost::default()
        };
        self.reserve(loc, &what, copies.add(placement).add(prototype), true)?;
        let def = &self.objects[name];
        let copied: Vec<Shape> = def
            .shapes
            .iter()
            .flat_map(|s| shapes::instance(s, t))
            .collect();
        self.shapes.extend(copied);
        if !shares {
            return Ok(());
        }
        let index = match def.prototype {
            Some(i) => i,
            None => {
                let i = self.prototypes.len() as u32;
                self.prototypes.push(Prototype {
                    name: name.to_string(),
                    shapes: def.shared.clone(),
                });
                self.objects.get_mut(name).expect("defined").prototype = Some(i);
                i
            }
        };
        let instance = Instance::new(index, *t)
            .ok_or_else(|| loc.error(format!("{what}: the transform is singular")))?;
        self.instances.push(instance);
        Ok(())
    }
}
