//! Scattering at surfaces for the physically based integrators. A [`Bsdf`] is made by a
//! material ([`crate::scene::materials`]) at a surface point from plain [`Lobes`]:
//!
//! - `kd`: Lambertian reflection kd/π;
//! - `kdt`: Lambertian transmission kdt/π to the other side (pbrt-v4's
//!   `DiffuseTransmissionBxDF` with kd), not weighted by Fresnel;
//! - `ks`: reflection, a perfect mirror when `alphas` are 0, otherwise a GGX microfacet
//!   lobe with those α;
//! - `kt` with `ior`: smooth refraction when `alphas` are 0, otherwise GGX microfacet
//!   refraction sharing the reflection's microfacets (a rough dielectric interface,
//!   [`dielectric`]);
//! - `fresnel`: ks is weighted by the dielectric Fresnel reflectance F, kt by 1 − F and kd by
//!   (1 − F(θi))(1 − F(θo)) (a coated surface), which makes ks = kt = 1 a glass (rough when
//!   α > 0, F then taken at each microfacet);
//! - `thin`: a thin dielectric sheet (pbrt-v4's `ThinDielectricBxDF`): kt passes light
//!   straight through, F becomes the sheet's reflectance R (both faces, light bouncing between
//!   them summed), seen alike from both sides, and the lobes are smooth whatever α;
//! - `conductor` (η, k): ks is weighted by the complex Fresnel reflectance of the metal per
//!   channel (pbrt-v4's `ConductorBxDF`), smooth or GGX, isotropic or anisotropic;
//!
//! and two BSDFs in place of the lobes: a [`Coating`] over the diffuse kd or the conductor,
//! light bouncing between the two included ([`Bsdf::coated`]; [`layered`], pbrt-v4's
//! `LayeredBxDF`; f and the density are estimates), and a tabulated reflectance
//! ([`Bsdf::tabulated`], [`TabulatedBrdf`]), importance-sampled from the table mixed with
//! the cosine.
//!
//! Every BSDF can evaluate, sample, and give the density of its samples, for both transport
//! directions (Veach's thesis, ch. 5): in [`Transport::Radiance`] refraction scales radiance
//! by (ηi/ηt)², and in [`Transport::Importance`] the shading-normal correction
//! |wo·ns||wi·ng| / (|wo·ng||wi·ns|) keeps the adjoint BSDF consistent.

mod colours;
mod dielectric;
mod lambertian;
mod layer;
mod layered;
mod microfacet;
mod parameters;
pub mod passes;
pub mod phase;
mod tabulated;

pub use colours::LobeColours;
pub use lambertian::LambertianFrom;
pub use microfacet::Ggx;
pub use parameters::{interned, Coating, Conductor, Lobes, SpectralParts};
#[cfg(test)]
pub use tabulated::synthetic_merl;
pub use tabulated::TabulatedBrdf;

use dielectric::RoughInterface;
use layered::Layered;

use crate::math::optics::{
    fresnel_dielectric, fresnel_dielectric_mean, fresnel_thin_dielectric, refract,
};
use crate::math::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::math::{frame, luminance, Rgb, Rng, Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Which quantity a path carries: radiance (paths from the camera) or importance (paths from
/// the lights).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transport {
    Radiance,
    Importance,
}

/// A sampled scattering direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f·|cos θi| / pdf: what the path throughput is multiplied by.
    pub weight: Rgb,
    /// Density of `wi` in solid angle (for a delta lobe, the probability of choosing it).
    pub pdf: f32,
    /// Whether the direction came from a perfectly specular lobe.
    pub delta: bool,
}

/// The BSDF at one surface point (borrowing a tabulated material's table).
#[derive(Clone, Copy, Debug)]
pub struct Bsdf<'a> {
    /// Shading frame: tangent, bitangent, normal (the normal on the side of `ng`).
    t: Vec3,
    b: Vec3,
    n: Vec3,
    ng: Vec3,
    kd: Rgb,
    kdt: Rgb,
    ks: Rgb,
    kt: Rgb,
    /// Index of refraction inside (the side opposite `ng`) relative to outside.
    ior: f32,
    ggx: Option<Ggx>,
    fresnel: bool,
    conductor: Option<Conductor>,
    /// The transmission is a GGX lobe (rough refraction), not a delta.
    rough_transmission: bool,
    /// A thin sheet: straight-through transmission, the sheet's reflectance for F.
    thin: bool,
    /// Only the Lambertian lobe: the common case takes a short path.
    lambertian: bool,
    /// A tabulated reflectance, the only lobe when present.
    table: Option<&'a TabulatedBrdf>,
    /// A coat over the diffuse or conductor base: evaluated and sampled in place of the
    /// lobes, which the approximating techniques (the irradiance cache's diffuse and glossy
    /// parts) still read.
    /// A coat over the diffuse or conductor base (borrowed: the walk's state is built when
    /// it is needed, so that uncoated BSDFs stay small).
    coating: Option<&'a Coating>,
    /// Dispersion and measured metals, for spectral renders.
    spectral: SpectralParts,
}

/// The mirror image of a local direction about the normal.
fn mirror(lo: Vec3) -> Vec3 {
    Vec3::new(-lo.x, -lo.y, lo.z)
}

/// Lobe selection probabilities for a given outgoing direction.
struct LobeShares {
    diffuse: f32,
    diffuse_transmit: f32,
    specular: f32,
    transmit: f32,
    /// Fresnel reflectance at the outgoing direction (1 when Fresnel is off).
    f: f32,
    /// What the mirror lobe reflects at the outgoing direction: ks·F, with the conductor's
    /// Fresnel per channel.
    mirror: Rgb,
    /// n_incident / n_transmitted for light leaving along wo's side.
    eta: f32,
}

impl<'a> Bsdf<'a> {
    /// The shading and geometric normals a BSDF faces for a path arriving from `wo`
    /// (pointing away): opaque surfaces reflect on both sides, so when `wo` is behind the
    /// geometric normal both normals are flipped to face it; transmissive surfaces keep
    /// their orientation, which tells inside from outside.
    pub fn facing(transmissive: bool, ns: Vec3, ng: Vec3, wo: Vec3) -> (Vec3, Vec3) {
        if !transmissive && wo.dot(ng) < 0.0 {
            (-ns, -ng)
        } else {
            (ns, ng)
        }
    }

    /// The BSDF of lobes `l` with shading normal `n` and geometric normal `ng` as
    /// [`Bsdf::facing`] orients them.
    pub fn of_lobes(l: &Lobes, n: Vec3, ng: Vec3) -> Bsdf<'a> {
        let transmissive = l.kt.max_element() > 0.0;
        let (t, b) = frame(n);
        let (ax, ay) = (l.alphas.0.clamp(0.0, 1.0), l.alphas.1.clamp(0.0, 1.0));
        // Below this α the lobe is numerically a mirror; a thin sheet is smooth.
        let ggx = (ax.max(ay) >= 1e-3 && !l.thin).then_some(Ggx {
            alpha_x: ax,
            alpha_y: ay,
        });
        // An index-matched interface refracts every microfacet's light straight on: a delta
        // whatever the roughness.
        let rough_transmission =
            transmissive && ggx.is_some() && l.conductor.is_none() && l.ior != 1.0;
        Bsdf {
            t,
            b,
            n,
            ng,
            kd: l.kd,
            kdt: l.kdt,
            ks: l.ks,
            kt: l.kt,
            ior: l.ior,
            ggx,
            fresnel: l.fresnel,
            conductor: l.conductor,
            rough_transmission,
            thin: l.thin,
            lambertian: l.lambertian,
            table: None,
            coating: None,
            spectral: l.spectral,
        }
    }

    /// The BSDF of `coating` over the base lobes `l` (its diffuse kd, or its conductor with
    /// its roughness): evaluated and sampled as the layers, while the lobes stay what the
    /// approximating techniques read.
    pub fn coated(l: &Lobes, coating: &'a Coating, n: Vec3, ng: Vec3) -> Bsdf<'a> {
        Bsdf {
            coating: Some(coating),
            ..Bsdf::of_lobes(l, n, ng)
        }
    }

    /// The BSDF of a tabulated reflectance with shading normal `n` and geometric normal
    /// `ng`, both on the side the light leaves toward.
    pub fn tabulated(table: &'a TabulatedBrdf, n: Vec3, ng: Vec3) -> Bsdf<'a> {
        let (t, b) = frame(n);
        Bsdf {
            t,
            b,
            n,
            ng,
            kd: Rgb::ZERO,
            kdt: Rgb::ZERO,
            ks: Rgb::ZERO,
            kt: Rgb::ZERO,
            ior: 1.0,
            ggx: None,
            fresnel: false,
            conductor: None,
            rough_transmission: false,
            thin: false,
            lambertian: false,
            table: Some(table),
            coating: None,
            spectral: SpectralParts::default(),
        }
    }

    /// The coat's layered BSDF, if the surface has a coat.
    fn layered(&self) -> Option<Layered> {
        self.coating
            .map(|c| Layered::new(c, self.kd, self.conductor, self.ggx))
    }

    fn local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    fn world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }

    /// Whether a non-delta lobe scatters through the surface (to the other side of `ng`).
    fn transmits(&self) -> bool {
        self.rough_transmission || self.kdt.max_element() > 0.0
    }

    /// The side of the geometric normal `wo` lies on, when [`eval`](Self::eval) can only be
    /// non-zero for directions on that side (no non-delta transmission): light from below
    /// that horizon cannot reach `wo`, so next-event estimation need not look there.
    pub fn reflecting_side(&self, wo: Vec3) -> Option<Vec3> {
        let go = wo.dot(self.ng);
        (go != 0.0 && !self.transmits()).then(|| if go > 0.0 { self.ng } else { -self.ng })
    }

    /// Whether scattering can be anything but a perfect mirror or refraction.
    pub fn has_non_delta(&self) -> bool {
        if let Some(l) = self.layered() {
            return l.has_non_delta();
        }
        self.kd.max_element() > 0.0 || self.kdt.max_element() > 0.0 || self.has_glossy()
    }

    /// Whether the BSDF has a diffuse lobe (reflection or transmission, under a coat too):
    /// where photon mapping keeps a camera path's visible point.
    pub fn has_diffuse(&self) -> bool {
        self.kd.max_element() > 0.0 || self.kdt.max_element() > 0.0
    }

    /// Whether a direction from anywhere (a path guide's) can be weighed by
    /// [`eval_and_pdf`](Self::eval_and_pdf) alone: no delta lobe, and no coat (whose value
    /// is itself an estimate).
    pub fn guidable(&self) -> bool {
        if self.coating.is_some() {
            return false;
        }
        if self.table.is_some() || self.lambertian {
            return true;
        }
        let smooth = self.ggx.is_none();
        let mirror = smooth && (self.ks.max_element() > 0.0 || self.conductor.is_some());
        let transmits = self.kt.max_element() > 0.0;
        let refraction = transmits && (smooth || !self.rough_transmission || self.thin);
        !mirror && !refraction && self.has_non_delta()
    }

    /// The diffuse reflectance (for albedo outputs).
    pub fn albedo(&self) -> Rgb {
        if let Some(table) = self.table {
            return table.most_reflected();
        }
        match self.conductor {
            Some(c) => self.kd + self.kdt + self.ks * c.reflectance(1.0) + self.kt,
            None => self.kd + self.kdt + self.ks + self.kt,
        }
    }

    /// What the coat lets through of diffuse light that arrives evenly from every direction
    /// and leaves toward `wo`: (1 − F(θo)) times the cosine-weighted mean of 1 − F(θi) (the
    /// diffuse lobe's factor (1 − F(θi))(1 − F(θo)) averaged over the incident light); 1
    /// without a coat. Irradiance caches multiply their diffuse part by it.
    pub fn diffuse_coat(&self, wo: Vec3) -> f32 {
        if !self.fresnel {
            return 1.0;
        }
        let lo = self.local(wo);
        let eta = self.eta_leaving(lo);
        (1.0 - fresnel_dielectric(lo.z.abs(), eta)) * (1.0 - fresnel_dielectric_mean(eta))
    }

    /// The shading normal, on the side the BSDF faces.
    pub fn shading_normal(&self) -> Vec3 {
        self.n
    }

    /// n_incident / n_transmitted for light leaving along local direction `lo`'s side: from
    /// outside (the side of `ng`) 1/ior, from inside ior; a thin sheet has both sides outside.
    fn eta_leaving(&self, lo: Vec3) -> f32 {
        if lo.z >= 0.0 || self.thin {
            1.0 / self.ior
        } else {
            self.ior
        }
    }

    fn lobes(&self, lo: Vec3) -> LobeShares {
        let eta = self.eta_leaving(lo);
        let f = if self.fresnel && self.thin {
            fresnel_thin_dielectric(lo.z, self.ior)
        } else if self.fresnel {
            fresnel_dielectric(lo.z.abs(), eta)
        } else {
            1.0
        };
        let rest = if self.fresnel { 1.0 - f } else { 1.0 };
        let diffuse = luminance(self.kd) * rest;
        let (mut specular, mirror) = match self.conductor {
            Some(c) => {
                let mirror = self.ks * c.reflectance(lo.z.abs());
                (luminance(mirror), mirror)
            }
            None => (luminance(self.ks) * f, self.ks * f),
        };
        let mut transmit = luminance(self.kt) * rest;
        if self.rough_transmission {
            // One microfacet lobe reflects and refracts. F at the macro normal only sets its
            // share against the diffuse lobe; beyond the critical angle it is 1, yet tilted
            // microfacets still refract, so the lobe keeps a small share.
            specular = (specular + transmit).max(1e-2 * luminance(self.kt));
            transmit = 0.0;
        }
        let diffuse_transmit = luminance(self.kdt);
        let total = diffuse + diffuse_transmit + specular + transmit;
        let norm = if total > 0.0 { 1.0 / total } else { 0.0 };
        LobeShares {
            diffuse: diffuse * norm,
            diffuse_transmit: diffuse_transmit * norm,
            specular: specular * norm,
            transmit: transmit * norm,
            f,
            mirror,
            eta,
        }
    }

    /// The GGX interface seen from local direction `lo`'s side (a dielectric's microfacets:
    /// not a conductor's).
    fn interface(&self, lo: Vec3) -> Option<RoughInterface> {
        if self.conductor.is_some() {
            return None;
        }
        Some(RoughInterface {
            ggx: self.ggx?,
            ks: self.ks,
            kt: if self.rough_transmission {
                self.kt
            } else {
                Rgb::ZERO
            },
            fresnel: self.fresnel,
            eta: self.eta_leaving(lo),
        })
    }

    /// Correction for shading normals in importance transport (1 for radiance).
    fn adjoint(&self, wo: Vec3, wi: Vec3, lo: Vec3, li: Vec3, mode: Transport) -> f32 {
        match mode {
            Transport::Radiance => 1.0,
            Transport::Importance => {
                let den = wo.dot(self.ng).abs() * li.z.abs();
                if den == 0.0 {
                    0.0
                } else {
                    lo.z.abs() * wi.dot(self.ng).abs() / den
                }
            }
        }
    }

    /// f(wo, wi)·|cos θi| for the non-delta lobes (with the adjoint correction in importance
    /// transport). Both directions point away from the surface.
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: Transport) -> Rgb {
        match self.connectable(wo, wi) {
            Some((lo, li)) => self.eval_connected(wo, wi, lo, li, mode),
            None => Rgb::ZERO,
        }
    }

    /// [`eval`](Self::eval) and [`pdf`](Self::pdf) of one pair of directions (next-event
    /// estimation needs both), taking the directions into the shading frame once.
    pub fn eval_and_pdf(&self, wo: Vec3, wi: Vec3, mode: Transport) -> (Rgb, f32) {
        match self.connectable(wo, wi) {
            Some((lo, li)) => (
                self.eval_connected(wo, wi, lo, li, mode),
                self.pdf_connected(lo, li),
            ),
            None => (Rgb::ZERO, 0.0),
        }
    }

    /// [`eval_and_pdf`](Self::eval_and_pdf) with the reverse density too (of sampling `wo`
    /// from `wi`), as bidirectional weights need them: f, pdf(wo → wi), pdf(wi → wo).
    #[inline(always)]
    pub fn eval_and_pdfs(&self, wo: Vec3, wi: Vec3, mode: Transport) -> (Rgb, f32, f32) {
        if let Some(l) = LambertianFrom::of(self, wo) {
            return l.eval_and_pdfs(wi, mode);
        }
        match self.connectable(wo, wi) {
            Some((lo, li)) => (
                self.eval_connected(wo, wi, lo, li, mode),
                self.pdf_connected(lo, li),
                self.pdf_connected(li, lo),
            ),
            None => (Rgb::ZERO, 0.0, 0.0),
        }
    }

    /// [`eval`](Self::eval) of directions that [`connectable`](Self::connectable) took to
    /// the shading frame as `lo`, `li`.
    fn eval_connected(&self, wo: Vec3, wi: Vec3, lo: Vec3, li: Vec3, mode: Transport) -> Rgb {
        if let Some(l) = self.layered() {
            return l.f(lo, li, mode) * li.z.abs() * self.adjoint(wo, wi, lo, li, mode);
        }
        match self.eval_lobes(wo, wi, lo, li, mode) {
            Some((diffuse, glossy, cos, adjoint)) => (diffuse + glossy) * cos * adjoint,
            None => Rgb::ZERO,
        }
    }

    /// Whether the BSDF has a glossy lobe: GGX reflection or refraction or a tabulated
    /// reflectance, neither diffuse nor a delta.
    pub fn has_glossy(&self) -> bool {
        self.table.is_some()
            || (self.ggx.is_some() && (self.ks.max_element() > 0.0 || self.rough_transmission))
    }

    /// The glossy lobes' share of [`Bsdf::eval`]: f_glossy(wo, wi)·|cos θi|, rough refraction
    /// and a tabulated reflectance included.
    pub fn eval_glossy(&self, wo: Vec3, wi: Vec3, mode: Transport) -> Rgb {
        let Some((lo, li)) = self.connectable(wo, wi) else {
            return Rgb::ZERO;
        };
        match self.eval_lobes(wo, wi, lo, li, mode) {
            Some((_, glossy, cos, adjoint)) => glossy * cos * adjoint,
            None => Rgb::ZERO,
        }
    }

    /// Local `wo` and `wi` if some non-delta lobe may connect them: on one side for
    /// reflection, on opposite sides only through a rough refraction or a diffuse
    /// transmission, and each on the same side of the shading normal as of the geometric
    /// one (otherwise light would leak through the surface).
    #[inline(always)]
    fn connectable(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
        let (go, gi) = (wo.dot(self.ng), wi.dot(self.ng));
        if go * gi == 0.0 || (go * gi < 0.0 && !self.transmits()) {
            return None;
        }
        let (lo, li) = (self.local(wo), self.local(wi));
        if lo.z * go <= 0.0 || li.z * gi <= 0.0 {
            return None;
        }
        Some((lo, li))
    }

    /// The diffuse and glossy parts of f(wo, wi), |cos θi| and the adjoint correction, given
    /// the directions in the shading frame as [`connectable`](Self::connectable) returns
    /// them; `None` where no lobe connects them.
    fn eval_lobes(
        &self,
        wo: Vec3,
        wi: Vec3,
        mut lo: Vec3,
        mut li: Vec3,
        mode: Transport,
    ) -> Option<(Rgb, Rgb, f32, f32)> {
        if let Some(table) = self.table {
            // The light arrives along wi for radiance, along wo for importance.
            let f = match mode {
                Transport::Radiance => table.eval(li, lo),
                Transport::Importance => table.eval(lo, li),
            };
            let adjoint = self.adjoint(wo, wi, lo, li, mode);
            return Some((Rgb::ZERO, f, li.z, adjoint));
        }
        if self.lambertian {
            // The common case: `connectable` put both directions on one side.
            let adjoint = self.adjoint(wo, wi, lo, li, mode);
            return Some((self.kd * FRAC_1_PI, Rgb::ZERO, li.z.abs(), adjoint));
        }
        let eta = self.eta_leaving(lo);
        let interface = self.interface(lo);
        if lo.z < 0.0 {
            // Seen from inside a transmissive surface: mirror both to the upper side.
            lo = -lo;
            li = -li;
        }
        let adjoint = self.adjoint(wo, wi, lo, li, mode);
        if li.z < 0.0 {
            let diffuse = self.kdt * FRAC_1_PI;
            let glossy = match interface {
                Some(i) if self.rough_transmission => i.eval(lo, li, mode),
                _ => Rgb::ZERO,
            };
            return Some((diffuse, glossy, -li.z, adjoint));
        }
        let mut diffuse = Rgb::ZERO;
        if self.kd.max_element() > 0.0 {
            let coat = if self.fresnel {
                (1.0 - fresnel_dielectric(lo.z, eta)) * (1.0 - fresnel_dielectric(li.z, eta))
            } else {
                1.0
            };
            diffuse = self.kd * (FRAC_1_PI * coat);
        }
        let mut glossy = Rgb::ZERO;
        if let Some(ggx) = self.ggx {
            if self.ks.max_element() > 0.0 {
                glossy = match (self.conductor, interface) {
                    (Some(c), _) => {
                        let h = (lo + li).normalize();
                        let dg = ggx.d(h) * ggx.g(lo, li);
                        self.ks * c.reflectance(lo.dot(h).abs()) * (dg / (4.0 * lo.z * li.z))
                    }
                    (None, Some(i)) => i.eval(lo, li, mode),
                    (None, None) => Rgb::ZERO,
                };
            }
        }
        Some((diffuse, glossy, li.z, adjoint))
    }

    /// Density (solid angle) with which [`Bsdf::sample`] produces `wi` from `wo` through a
    /// non-delta lobe.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if let Some(l) = LambertianFrom::of(self, wo) {
            return l.pdf(wi);
        }
        match self.connectable(wo, wi) {
            Some((lo, li)) => self.pdf_connected(lo, li),
            None => 0.0,
        }
    }

    /// [`pdf`](Self::pdf) of directions that [`connectable`](Self::connectable) took to the
    /// shading frame.
    fn pdf_connected(&self, mut lo: Vec3, mut li: Vec3) -> f32 {
        if let Some(table) = self.table {
            // Sampled given wo whatever the transport: one density serves both.
            return table.pdf(lo, li);
        }
        if let Some(l) = self.layered() {
            // The walk's directions do not depend on the transport.
            return l.pdf(lo, li, Transport::Radiance);
        }
        if self.lambertian {
            return cosine_hemisphere_pdf(li.z.abs());
        }
        let lobes = self.lobes(lo);
        let interface = self.interface(lo);
        if lo.z < 0.0 {
            lo = -lo;
            li = -li;
        }
        let mut pdf = 0.0;
        if li.z > 0.0 {
            pdf += lobes.diffuse * cosine_hemisphere_pdf(li.z);
        } else {
            pdf += lobes.diffuse_transmit * cosine_hemisphere_pdf(-li.z);
        }
        if lobes.specular > 0.0 {
            match (self.ggx, interface) {
                (_, Some(i)) => pdf += i.pdf(lo, li, lobes.specular),
                (Some(ggx), None) if li.z > 0.0 => {
                    let h = (lo + li).normalize();
                    pdf += lobes.specular * ggx.visible_pdf(lo, h) / (4.0 * lo.dot(h).abs());
                }
                _ => {}
            }
        }
        pdf
    }

    /// Where the smooth lobes scatter `wo`: its mirror image and the line through the surface
    /// (refracted by the index, straight on through a thin sheet; `None` beyond the critical
    /// angle). Rough lobes scatter around these.
    pub fn smooth_directions(&self, wo: Vec3) -> (Vec3, Option<Vec3>) {
        let lo_raw = self.local(wo);
        let side = lo_raw.z.signum();
        let lo = lo_raw * side;
        let reflected = self.world(mirror(lo) * side);
        let through = self.through(wo, lo, side, self.eta_leaving(lo_raw));
        (reflected, through.map(|(_, wi)| wi))
    }

    /// The transmitted direction of `wo` (local `lo` on the upper side, `side` its sign):
    /// local and world, refracted with `eta`, or straight on through a thin sheet.
    fn through(&self, wo: Vec3, lo: Vec3, side: f32, eta: f32) -> Option<(Vec3, Vec3)> {
        if self.thin {
            return Some((-lo, -wo));
        }
        let li = refract(-lo, Vec3::Z, eta)?;
        Some((li, self.world(li * side)))
    }

    /// What the BSDF sends toward `wo` of light arriving evenly over the hemisphere on `wo`'s
    /// side and over the other one: ∫ f·|cos θi| dωi over each (the directional albedo split
    /// by side). Exact for smooth lobes; with a rough or diffuse one, an estimate from a
    /// stratified `n`×`n` set of samples, the same at every call.
    pub fn albedo_by_side(&self, wo: Vec3, n: u32, mode: Transport) -> (Rgb, Rgb) {
        let lo = self.local(wo);
        if !self.has_non_delta() && self.coating.is_none() {
            let lobes = self.lobes(lo);
            if lobes.transmit <= 0.0 {
                return (lobes.mirror, Rgb::ZERO);
            }
            let rest = if self.fresnel { 1.0 - lobes.f } else { 1.0 };
            let scale = match mode {
                Transport::Radiance if !self.thin => lobes.eta * lobes.eta,
                _ => 1.0,
            };
            return (lobes.mirror, self.kt * (rest * scale));
        }
        let (mut same, mut other) = (Rgb::ZERO, Rgb::ZERO);
        let count = (n * n).max(1);
        // Jittered strata for the direction, and the lobe choice's strata in a shuffled
        // order: a fixed stream, so every call gives the same estimate.
        let mut rng = Rng::for_key(0x616c_6265, &[]);
        let mut order: Vec<u32> = (0..count).collect();
        for i in (1..order.len()).rev() {
            order.swap(i, rng.next_u32() as usize % (i + 1));
        }
        for (k, &stratum) in order.iter().enumerate() {
            let (i, j) = (k as u32 % n, k as u32 / n);
            let u = Vec2::new(
                (i as f32 + rng.uniform()) / n as f32,
                (j as f32 + rng.uniform()) / n as f32,
            );
            let u_lobe = (stratum as f32 + rng.uniform()) / count as f32;
            if let Some(s) = self.sample(wo, u_lobe, u, mode) {
                if s.wi.dot(self.ng) * wo.dot(self.ng) > 0.0 {
                    same += s.weight;
                } else {
                    other += s.weight;
                }
            }
        }
        (same / count as f32, other / count as f32)
    }

    /// A direction from the coat's random walk: its weight, and for MIS the estimated
    /// density of the direction (the walk's own density, for a delta path).
    fn sample_layered(
        &self,
        l: &Layered,
        wo: Vec3,
        lo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: Transport,
    ) -> Option<BsdfSample> {
        let s = l.sample(lo, u_lobe, u, mode)?;
        let wi = self.world(s.wi);
        if wi.dot(self.ng) * wo.dot(self.ng) <= 0.0 {
            return None;
        }
        let pdf = if s.specular { s.pdf } else { self.pdf(wo, wi) };
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: s.weight * self.adjoint(wo, wi, lo, s.wi, mode),
            pdf,
            delta: s.specular,
        })
    }

    /// Samples a direction `wi` from `wo`; `u_lobe` picks the lobe and `u` the direction.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: Transport) -> Option<BsdfSample> {
        let lo_raw = self.local(wo);
        if lo_raw.z == 0.0 {
            return None;
        }
        if let Some(l) = self.layered() {
            return self.sample_layered(&l, wo, lo_raw, u_lobe, u, mode);
        }
        if self.lambertian {
            let li = cosine_hemisphere(u) * lo_raw.z.signum();
            let wi = self.world(li);
            if wi.dot(self.ng) * wo.dot(self.ng) <= 0.0 || li.z == 0.0 {
                return None;
            }
            // f·cos/pdf = kd (times the adjoint correction).
            return Some(BsdfSample {
                wi,
                weight: self.kd * self.adjoint(wo, wi, lo_raw, li, mode),
                pdf: cosine_hemisphere_pdf(li.z.abs()),
                delta: false,
            });
        }
        let lobes = self.lobes(lo_raw);
        let side = lo_raw.z.signum();
        // Work with wo on the upper side.
        let lo = lo_raw * side;
        let go = wo.dot(self.ng);
        // Lobes in the order diffuse, diffuse transmission, specular, transmission.
        let diffuse_end = lobes.diffuse + lobes.diffuse_transmit;
        let specular_end = diffuse_end + lobes.specular;
        let table = self.table.is_some();
        if table || u_lobe < diffuse_end || (u_lobe < specular_end && self.ggx.is_some()) {
            // A non-delta lobe: the weight comes from the whole mixture.
            let li = if let Some(t) = self.table {
                t.sample(lo, u_lobe, u)
            } else if u_lobe < lobes.diffuse {
                cosine_hemisphere(u)
            } else if u_lobe < diffuse_end {
                -cosine_hemisphere(u)
            } else if let Some(interface) = self.interface(lo_raw) {
                // The rest of u_lobe chooses between reflection and refraction.
                let u_choice = ((u_lobe - diffuse_end) / lobes.specular).min(1.0);
                interface.sample(lo, u_choice, u)?
            } else {
                let h = self.ggx?.sample_visible(lo, u);
                let li = 2.0 * lo.dot(h) * h - lo;
                if li.z <= 0.0 {
                    return None;
                }
                li
            };
            let wi = self.world(li * side);
            // The geometric normal must agree on the side wi is on.
            if wi.dot(self.ng) * go * li.z <= 0.0 {
                return None;
            }
            let (f, pdf) = self.eval_and_pdf(wo, wi, mode);
            if pdf <= 0.0 || f == Rgb::ZERO {
                return None;
            }
            return Some(BsdfSample {
                wi,
                weight: f / pdf,
                pdf,
                delta: false,
            });
        }
        if u_lobe < specular_end {
            // Perfect mirror.
            let li = mirror(lo);
            let wi = self.world(li * side);
            let gi = wi.dot(self.ng);
            if gi * go <= 0.0 {
                return None;
            }
            let weight = lobes.mirror / lobes.specular;
            let adj = self.adjoint(wo, wi, lo, li, mode);
            return Some(BsdfSample {
                wi,
                weight: weight * adj,
                pdf: lobes.specular,
                delta: true,
            });
        }
        if lobes.transmit <= 0.0 {
            return None;
        }
        // Smooth refraction; straight on through a thin sheet.
        let (li, wi) = self.through(wo, lo, side, lobes.eta)?;
        if wi.dot(self.ng) * go >= 0.0 {
            return None;
        }
        let rest = if self.fresnel { 1.0 - lobes.f } else { 1.0 };
        let mut weight = self.kt * rest / lobes.transmit;
        if mode == Transport::Radiance && !self.thin {
            weight *= lobes.eta * lobes.eta;
        }
        weight *= self.adjoint(wo, wi, lo, li, mode);
        Some(BsdfSample {
            wi,
            weight,
            pdf: lobes.transmit,
            delta: true,
        })
    }
}
