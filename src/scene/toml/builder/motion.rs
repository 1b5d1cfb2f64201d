//! A shape's `motion`: transform steps that move it, after its `transform`, by shutter
//! close. The shape as built is its geometry at shutter open.

use super::super::checks::geometry_is_finite;
use super::super::diagnostics::Site;
use super::super::schema::{OneOrMany, TransformOp};
use super::Builder;
use crate::scene::{Geometry, Shape, Sphere};

impl Builder<'_> {
    /// Gives `shapes` (built from one `[[shapes]]` table) their geometry at shutter close.
    pub(super) fn motion(
        &self,
        site: &Site,
        desc: Option<OneOrMany<TransformOp>>,
        shapes: &mut [Shape],
    ) -> crate::error::Result<()> {
        let Some(desc) = desc else {
            return Ok(());
        };
        let ctx = self.ctx;
        let xf = self.transform_steps(site, Some(desc), "motion")?;
        if xf.flips {
            return Err(ctx.fail(
                site,
                "motion",
                "cannot mirror: a shape moving straight into its mirror image passes through \
                 flat",
            ));
        }
        for shape in shapes.iter_mut() {
            if self.materials[shape.material].is_emissive() {
                // Light samples are taken on still emitters: one that moved would light its
                // surroundings from where it was at shutter open.
                return Err(ctx.fail(
                    site,
                    "motion",
                    "an emitting shape cannot move (its light would not move with it); move \
                     the shapes it lights instead, or use an animation",
                ));
            }
            let mut end = shape.geometry.clone();
            match &mut end {
                Geometry::Sphere(Sphere { center, radius }) => {
                    (*center, *radius) = xf
                        .sphere(*center, *radius)
                        .map_err(|m| ctx.fail(site, "motion", m))?;
                }
                Geometry::Triangles(m) => xf.place(&mut m.positions, &mut m.normals),
                Geometry::Quads(q) => xf.place(&mut q.positions, &mut None),
            }
            if !geometry_is_finite(&end) {
                return Err(ctx.fail(
                    site,
                    "motion",
                    "overflows: it moves the shape out of the range of finite numbers",
                ));
            }
            if end != shape.geometry {
                shape.motion = Some(end);
            }
        }
        Ok(())
    }
}
