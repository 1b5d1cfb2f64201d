//! `[render]`: the settings a scene file carries, with the line of each for messages. Only
//! the form is checked here (types, names); ranges are the technique's to check when a job
//! is made (`Technique::create`), whose message then names this file and line.

use super::Builder;
use crate::image::filter::Filter;
use crate::scene::toml::diagnostics::Site;
use crate::scene::toml::schema::RenderDesc;
use crate::scene::SettingSource;
use crate::settings::{AntiAliasing, NetworkBuilder, NetworkOrder, Settings, TechniqueKind};
use std::ops::Range;
use toml::Spanned;

impl Builder<'_> {
    /// `[render] output`: a file name, kept as written (the command line takes it relative
    /// to the current directory, as pbrt-v4 does its `Film "filename"`).
    pub(super) fn output(
        &self,
        output: Option<Spanned<String>>,
    ) -> crate::error::Result<Option<std::path::PathBuf>> {
        let Some(output) = output else {
            return Ok(None);
        };
        let span = output.span();
        let name = output.into_inner();
        if name.is_empty() || name.contains('\0') {
            let site = self.site("render".into(), span.clone());
            return Err(self.ctx.fail(
                &site,
                "output",
                "must name a file (an image path such as \"room.exr\")",
            ));
        }
        Ok(Some(name.into()))
    }

    /// `[render] color_space`: the linear outputs' colour space; `None` for sRGB.
    pub(super) fn color_space(
        &self,
        name: Option<Spanned<String>>,
    ) -> crate::error::Result<Option<&'static crate::spectrum::ColorSpace>> {
        let Some(name) = name else {
            return Ok(None);
        };
        let site = self.site("render".into(), name.span());
        let space = crate::image::output::color_space_named(name.get_ref())
            .map_err(|why| self.ctx.fail(&site, "color_space", why))?;
        Ok((space != crate::spectrum::ColorSpace::srgb()).then_some(space))
    }

    pub(super) fn render(
        &self,
        desc: Spanned<RenderDesc>,
    ) -> crate::error::Result<(Settings, Vec<SettingSource>)> {
        let ctx = self.ctx;
        let span = desc.span();
        let site = self.site("render".into(), span.clone());
        let d = desc.into_inner();
        let mut sources = Vec::new();
        let mut source = |setting: &'static str, table: &str, key: &str, span: &Range<usize>| {
            sources.push(SettingSource {
                setting,
                key: format!("[{table}] {key}"),
                line: ctx.key_line(span, key),
                file: None,
            })
        };
        let mut s = Settings::default();
        macro_rules! take {
            ($field:ident, $value:expr, $table:expr, $key:expr, $span:expr) => {
                if let Some(v) = $value {
                    s.$field = Some(v);
                    source(stringify!($field), $table, $key, $span);
                }
            };
        }
        if let Some(name) = d.integrator {
            let kind = TechniqueKind::from_name(&name).ok_or_else(|| {
                ctx.fail(
                    &site,
                    "integrator",
                    format!("unknown integrator \"{name}\" ({})", technique_names()),
                )
            })?;
            take!(integrator, Some(kind), "render", "integrator", &span);
        }
        take!(spp, d.spp, "render", "spp", &span);
        take!(max_depth, d.max_depth, "render", "max_depth", &span);
        take!(time_limit, d.time_limit, "render", "time_limit", &span);
        take!(
            adaptive_threshold,
            d.adaptive_threshold,
            "render",
            "adaptive_threshold",
            &span
        );
        take!(
            adaptive_min_samples,
            d.adaptive_min_samples,
            "render",
            "adaptive_min_samples",
            &span
        );
        take!(guiding, d.guiding, "render", "guiding", &span);
        take!(spectral, d.spectral, "render", "spectral", &span);
        take!(
            max_component_value,
            d.max_component_value,
            "render",
            "max_component_value",
            &span
        );
        let filter = d.filter.map(|f| self.filter(&site, f)).transpose()?;
        take!(filter, filter, "render", "filter", &span);
        let aa = match d.aa.as_deref() {
            None => None,
            Some("adaptive") => Some(AntiAliasing::Adaptive),
            Some("uniform") => Some(AntiAliasing::Uniform),
            Some(other) => {
                return Err(ctx.fail(
                    &site,
                    "aa",
                    format!("must be \"adaptive\" or \"uniform\", got \"{other}\""),
                ))
            }
        };
        take!(aa, aa, "render", "aa", &span);
        take!(
            aa_threshold,
            d.aa_threshold,
            "render",
            "aa_threshold",
            &span
        );
        take!(aa_depth, d.aa_depth, "render", "aa_depth", &span);
        if let Some(w) = d.whitted {
            let span = w.span();
            let w = w.into_inner();
            let t = "render.whitted";
            take!(area_samples, w.area_samples, t, "area_samples", &span);
            take!(fresnel, w.fresnel, t, "fresnel", &span);
        }
        if let Some(c) = d.irradiance_cache {
            let span = c.span();
            let c = c.into_inner();
            let t = "render.irradiance-cache";
            take!(ab, c.ab, t, "ab", &span);
            take!(ic_accuracy, c.accuracy, t, "accuracy", &span);
            take!(ic_samples, c.samples, t, "samples", &span);
            take!(ic_gradients, c.gradients, t, "gradients", &span);
            take!(ar, c.ar, t, "ar", &span);
            let file = c.cache_file.map(|f| self.dir.join(f));
            take!(cache_file, file, t, "cache_file", &span);
        }
        if let Some(n) = d.network {
            let span = n.span();
            let site = self.site("render.network".into(), span.clone());
            let n = n.into_inner();
            let t = "render.network";
            take!(slopes, n.slopes, t, "slopes", &span);
            take!(intercept_step, n.intercept_step, t, "intercept_step", &span);
            take!(patch_size, n.patch_size, t, "patch_size", &span);
            take!(network_jitter, n.jitter, t, "jitter", &span);
            let builder = match n.builder.as_deref() {
                None => None,
                Some("scan") => Some(NetworkBuilder::Scan),
                Some("embree") => Some(NetworkBuilder::Embree),
                Some(other) => {
                    return Err(ctx.fail(
                        &site,
                        "builder",
                        format!("must be \"scan\" or \"embree\", got \"{other}\""),
                    ))
                }
            };
            take!(network_builder, builder, t, "builder", &span);
            take!(tolerance, n.tolerance, t, "tolerance", &span);
            let order = match n.order.as_deref() {
                None => None,
                Some("cg") => Some(NetworkOrder::ConjugateGradients),
                Some("sweeps") => Some(NetworkOrder::Sweeps),
                Some("shoot") => Some(NetworkOrder::Shoot),
                Some(other) => {
                    return Err(ctx.fail(
                        &site,
                        "order",
                        format!("must be \"cg\", \"sweeps\" or \"shoot\", got \"{other}\""),
                    ))
                }
            };
            take!(network_order, order, t, "order", &span);
            take!(network_hybrid, n.hybrid, t, "hybrid", &span);
            let file = n.file.map(|f| self.dir.join(f));
            take!(network_file, file, t, "file", &span);
        }
        if let Some(p) = d.sppm {
            let span = p.span();
            let p = p.into_inner();
            let t = "render.sppm";
            take!(
                photons_per_iteration,
                p.photons_per_iteration,
                t,
                "photons_per_iteration",
                &span
            );
            take!(sppm_radius, p.radius, t, "radius", &span);
        }
        Ok((s, sources))
    }

    fn filter(
        &self,
        site: &Site,
        f: crate::scene::toml::schema::FilterDesc,
    ) -> crate::error::Result<Filter> {
        let ctx = self.ctx;
        let Some(mut filter) = Filter::named(&f.kind, f.radius) else {
            return Err(ctx.fail(
                site,
                "filter.type",
                format!(
                    "must be \"box\", \"triangle\" or \"gaussian\", got \"{}\"",
                    f.kind
                ),
            ));
        };
        if let (Filter::Gaussian { sigma, .. }, Some(s)) = (&mut filter, f.sigma) {
            *sigma = s;
        }
        if f.sigma.is_some() && !matches!(filter, Filter::Gaussian { .. }) {
            return Err(ctx.fail(site, "filter.sigma", "only a gaussian filter takes sigma"));
        }
        filter.validate().map_err(|m| ctx.fail(site, "filter", m))?;
        Ok(filter)
    }
}

/// "whitted, path, ... or network": every technique's name.
fn technique_names() -> String {
    let names: Vec<&str> = TechniqueKind::ALL.iter().map(|k| k.name()).collect();
    let (last, rest) = names.split_last().expect("there are techniques");
    format!("{} or {last}", rest.join(", "))
}
