//! The Embree backend: a safe wrapper over the system Embree (3 or 4, chosen by build.rs) and
//! the [`Accel`] implementation on top of it. This module and `sys` hold the only
//! unsafe Embree code; the differences between Embree 3 and 4 stay inside `query`.

mod cutouts;
mod instances;
mod motion;
mod sys;

use super::cutout::Cutout;
use super::{Accel, Hit, Update};
use crate::control::CancelToken;
use crate::error::{Error, Result};
use crate::math::{Ray, Vec3, Vec4};
use crate::scene::{Geometry, Instance, Primitives, Scene as SceneDesc};
use std::ffi::{c_char, c_void, CStr, CString};
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, Mutex};

/// The Embree device plus the messages its error callback collected and the bytes its memory
/// monitor counted.
struct DeviceInner {
    raw: sys::RTCDevice,
    /// Boxed so the address handed to Embree as the callback's user pointer never moves.
    errors: Box<Mutex<Vec<String>>>,
    /// Bytes Embree has allocated and not freed (boxed for the same reason).
    memory: Box<AtomicI64>,
}

// SAFETY: an Embree device may be used from any thread; the error list is behind a mutex.
unsafe impl Send for DeviceInner {}
unsafe impl Sync for DeviceInner {}

impl Drop for DeviceInner {
    fn drop(&mut self) {
        // SAFETY: `raw` is a live device; scenes hold an Arc to us, so none outlives it.
        unsafe { sys::rtcReleaseDevice(self.raw) }
    }
}

impl DeviceInner {
    /// Turns errors Embree reported since the last check into a `Result`.
    fn check(&self, during: &str) -> Result<()> {
        let mut errors = self.errors.lock().unwrap_or_else(|e| e.into_inner());
        if errors.is_empty() {
            Ok(())
        } else {
            let message = format!("{during}: {}", errors.join("; "));
            errors.clear();
            Err(Error::Embree(message))
        }
    }
}

/// Embree's progress monitor during a commit: whether to go on (the token is not cancelled).
/// It must not unwind into C: it only reads an atomic flag.
unsafe extern "C" fn keep_building(token: *mut c_void, _done: f64) -> bool {
    // SAFETY: `commit_cancellable` passes a token that outlives the commit.
    let token = unsafe { &*(token as *const CancelToken) };
    !token.is_cancelled()
}

/// Called by Embree on every error. It must not unwind into C: it only records the message.
unsafe extern "C" fn record_error(user: *mut c_void, code: sys::RTCError, text: *const c_char) {
    if user.is_null() {
        return;
    }
    // SAFETY: `user` is the `Mutex<Vec<String>>` registered in `Device::with_config`, alive as
    // long as the device; `text` is a NUL-terminated string or null.
    let errors = unsafe { &*(user as *const Mutex<Vec<String>>) };
    let text = if text.is_null() {
        String::new()
    } else {
        unsafe { CStr::from_ptr(text) }
            .to_string_lossy()
            .into_owned()
    };
    if let Ok(mut list) = errors.lock() {
        list.push(format!("{} ({})", text, error_name(code)));
    }
}

/// Called by Embree before every allocation (positive `bytes`) and after every release
/// (negative); returning true lets the allocation proceed.
unsafe extern "C" fn track_memory(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    if !user.is_null() {
        // SAFETY: `user` is the `AtomicI64` registered in `Device::with_config`, alive as long
        // as the device.
        let memory = unsafe { &*(user as *const AtomicI64) };
        memory.fetch_add(bytes as i64, Ordering::Relaxed);
    }
    true
}

fn error_name(code: sys::RTCError) -> &'static str {
    match code {
        sys::RTC_ERROR_NONE => "no error",
        sys::RTC_ERROR_INVALID_ARGUMENT => "invalid argument",
        sys::RTC_ERROR_INVALID_OPERATION => "invalid operation",
        sys::RTC_ERROR_OUT_OF_MEMORY => "out of memory",
        sys::RTC_ERROR_UNSUPPORTED_CPU => "unsupported CPU",
        sys::RTC_ERROR_CANCELLED => "cancelled",
        _ => "unknown error",
    }
}

/// An Embree device.
#[derive(Clone)]
pub struct Device {
    inner: Arc<DeviceInner>,
}

impl Device {
    pub fn new() -> Result<Device> {
        Device::with_config("")
    }

    /// A device with an Embree configuration string (e.g. `"threads=2,verbose=1"`).
    pub fn with_config(config: &str) -> Result<Device> {
        let config = CString::new(config)
            .map_err(|_| Error::Embree("device configuration contains a NUL byte".into()))?;
        // SAFETY: `config` is a valid C string for the duration of the call.
        let raw = unsafe { sys::rtcNewDevice(config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: a null device asks for the error of the last failed device creation.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(Error::Embree(format!(
                "creating a device with configuration {:?} failed ({})",
                config,
                error_name(code)
            )));
        }
        let errors: Box<Mutex<Vec<String>>> = Box::default();
        let user = &*errors as *const Mutex<Vec<String>> as *mut c_void;
        let memory: Box<AtomicI64> = Box::default();
        let memory_user = &*memory as *const AtomicI64 as *mut c_void;
        // SAFETY: `raw` is live; both user pointers stay valid until the device is released
        // in Drop.
        unsafe {
            sys::rtcSetDeviceErrorFunction(raw, Some(record_error), user);
            sys::rtcSetDeviceMemoryMonitorFunction(raw, Some(track_memory), memory_user);
        }
        Ok(Device {
            inner: Arc::new(DeviceInner {
                raw,
                errors,
                memory,
            }),
        })
    }

    /// Bytes the device has allocated and not yet freed (Embree's memory monitor): buffers,
    /// acceleration structures and the allocators' reserved blocks.
    pub fn memory_bytes(&self) -> i64 {
        self.inner.memory.load(Ordering::Relaxed)
    }

    /// The version of the Embree library in use, such as "3.13.5".
    pub fn version(&self) -> String {
        // SAFETY: `raw` is a live device; the property query has no other preconditions.
        let v =
            unsafe { sys::rtcGetDeviceProperty(self.inner.raw, sys::RTC_DEVICE_PROPERTY_VERSION) };
        format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100)
    }
}

/// A geometry id within a scene.
pub(crate) type GeometryId = u32;

/// An Embree scene. Changes take `&mut self`; queries take `&self` and may run from many
/// threads at once. Queries on a scene changed since its last commit find nothing.
pub struct Scene {
    raw: sys::RTCScene,
    device: Arc<DeviceInner>,
    committed: bool,
    next_id: GeometryId,
    /// Geometries get refit quality (see [`Scene::new_dynamic`]).
    dynamic: bool,
    /// The alpha tests Embree's filter functions were handed (kept alive here).
    cutouts: Vec<Arc<Cutout>>,
}

// SAFETY: Embree allows concurrent queries on a committed scene; every change goes through
// `&mut self`, so no change can race a query.
unsafe impl Send for Scene {}
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: `raw` is a live scene owned by us.
        unsafe { sys::rtcReleaseScene(self.raw) }
    }
}

impl Scene {
    pub fn new(device: &Device) -> Result<Scene> {
        Scene::with_flags(device, false)
    }

    /// A scene meant to change between commits (animation): Embree keeps one BVH per
    /// geometry under a top-level BVH, and geometries added with refit quality have their
    /// BVH refitted, not rebuilt, when their vertices move.
    pub fn new_dynamic(device: &Device) -> Result<Scene> {
        Scene::with_flags(device, true)
    }

    fn with_flags(device: &Device, dynamic: bool) -> Result<Scene> {
        // SAFETY: the device is live.
        let raw = unsafe { sys::rtcNewScene(device.inner.raw) };
        device.inner.check("creating a scene")?;
        if raw.is_null() {
            return Err(Error::Embree("creating a scene failed".into()));
        }
        // SAFETY: `raw` is a live scene. Robust traversal avoids cracks between triangles.
        unsafe {
            if dynamic {
                sys::rtcSetSceneFlags(
                    raw,
                    sys::RTC_SCENE_FLAG_ROBUST | sys::RTC_SCENE_FLAG_DYNAMIC,
                );
                sys::rtcSetSceneBuildQuality(raw, sys::RTC_BUILD_QUALITY_LOW);
            } else {
                sys::rtcSetSceneFlags(raw, sys::RTC_SCENE_FLAG_ROBUST);
                sys::rtcSetSceneBuildQuality(raw, sys::RTC_BUILD_QUALITY_HIGH);
            }
        }
        Ok(Scene {
            raw,
            device: device.inner.clone(),
            committed: false,
            next_id: 0,
            dynamic,
            cutouts: Vec::new(),
        })
    }

    /// Adds a triangle mesh; returns its geometry id (ids count up from 0 in attach order).
    pub fn attach_triangles(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
    ) -> Result<GeometryId> {
        check_indices(positions.len(), indices.iter().flatten())?;
        self.attach(
            sys::RTC_GEOMETRY_TYPE_TRIANGLE,
            positions,
            (indices.as_flattened(), sys::RTC_FORMAT_UINT3, 3),
        )
    }

    /// Adds planar quads (each split by Embree into two triangles, with u, v across the quad).
    pub fn attach_quads(&mut self, positions: &[Vec3], indices: &[[u32; 4]]) -> Result<GeometryId> {
        check_indices(positions.len(), indices.iter().flatten())?;
        self.attach(
            sys::RTC_GEOMETRY_TYPE_QUAD,
            positions,
            (indices.as_flattened(), sys::RTC_FORMAT_UINT4, 4),
        )
    }

    /// Adds spheres given as (centre x, y, z, radius), using Embree's sphere geometry.
    pub fn attach_spheres(&mut self, spheres: &[Vec4]) -> Result<GeometryId> {
        if let Some(s) = spheres.iter().find(|s| !s.is_finite() || s.w <= 0.0) {
            return Err(Error::Embree(format!(
                "invalid sphere {s}: needs finite values and a positive radius"
            )));
        }
        let geometry = self.new_geometry(sys::RTC_GEOMETRY_TYPE_SPHERE_POINT)?;
        let vertex = (sys::RTC_BUFFER_TYPE_VERTEX, 0, sys::RTC_FORMAT_FLOAT4, 16);
        // SAFETY: `geometry` is live; a Vec4 is one FLOAT4 item.
        unsafe { fill_buffer(geometry, vertex, spheres) };
        self.finish_geometry(geometry)
    }

    fn new_geometry(&mut self, kind: sys::RTCGeometryType) -> Result<sys::RTCGeometry> {
        // SAFETY: the device is live.
        let geometry = unsafe { sys::rtcNewGeometry(self.device.raw, kind) };
        self.device.check("creating a geometry")?;
        if geometry.is_null() {
            return Err(Error::Embree("creating a geometry failed".into()));
        }
        Ok(geometry)
    }

    fn attach(
        &mut self,
        kind: sys::RTCGeometryType,
        positions: &[Vec3],
        (indices, index_format, per_prim): (&[u32], sys::RTCFormat, usize),
    ) -> Result<GeometryId> {
        if let Some(p) = positions.iter().find(|p| !p.is_finite()) {
            return Err(Error::Embree(format!("vertex {p} is not finite")));
        }
        let geometry = self.new_geometry(kind)?;
        let vertex = (sys::RTC_BUFFER_TYPE_VERTEX, 0, sys::RTC_FORMAT_FLOAT3, 12);
        // SAFETY: `geometry` is live.
        unsafe {
            fill_buffer(geometry, vertex, positions);
            fill_buffer(
                geometry,
                (sys::RTC_BUFFER_TYPE_INDEX, 0, index_format, 4 * per_prim),
                indices,
            );
        }
        self.finish_geometry(geometry)
    }

    /// Commits a filled geometry, attaches it under the next id and drops our reference.
    fn finish_geometry(&mut self, geometry: sys::RTCGeometry) -> Result<GeometryId> {
        let id = self.next_id;
        // SAFETY: `geometry` and the scene are live; the scene keeps its own reference.
        unsafe {
            if self.dynamic {
                sys::rtcSetGeometryBuildQuality(geometry, sys::RTC_BUILD_QUALITY_REFIT);
            }
            sys::rtcCommitGeometry(geometry);
            sys::rtcAttachGeometryByID(self.raw, geometry, id);
            sys::rtcReleaseGeometry(geometry);
        }
        self.device.check("adding a geometry")?;
        self.next_id += 1;
        self.committed = false;
        Ok(id)
    }

    /// Replaces the vertices of geometry `id` (a triangle or quad mesh with as many vertices,
    /// or spheres given as (centre, radius) for a sphere geometry). Takes effect at the next
    /// [`commit`](Self::commit).
    pub(crate) fn update_vertices(
        &mut self,
        id: GeometryId,
        data: &[f32],
        stride: usize,
    ) -> Result<()> {
        if id >= self.next_id {
            return Err(Error::Embree(format!("no geometry {id} to update")));
        }
        if data.iter().any(|x| !x.is_finite()) {
            return Err(Error::Embree(format!(
                "geometry {id}: the new vertices are not finite"
            )));
        }
        // SAFETY: the scene is live and `id` was attached to it. The vertex buffer was
        // created by `rtcSetNewGeometryBuffer` with `stride`-float items; the caller passes
        // as many items as it holds (checked against the buffer's size through the count the
        // wrapper kept is not possible, so `EmbreeAccel::update` checks the vertex counts).
        unsafe {
            let geometry = sys::rtcGetGeometry(self.raw, id);
            self.device.check("finding a geometry")?;
            let buf =
                sys::rtcGetGeometryBufferData(geometry, sys::RTC_BUFFER_TYPE_VERTEX, 0) as *mut f32;
            if buf.is_null() {
                return Err(Error::Embree(format!("geometry {id} has no vertex buffer")));
            }
            debug_assert_eq!(data.len() % stride, 0);
            std::ptr::copy_nonoverlapping(data.as_ptr(), buf, data.len());
            sys::rtcUpdateGeometryBuffer(geometry, sys::RTC_BUFFER_TYPE_VERTEX, 0);
            sys::rtcCommitGeometry(geometry);
        }
        self.device.check("updating a geometry")?;
        self.committed = false;
        Ok(())
    }

    /// Builds the acceleration structure; queries are valid from then until the next change.
    pub fn commit(&mut self) -> Result<()> {
        self.commit_cancellable(&CancelToken::new())
    }

    /// [`commit`](Self::commit), stopped early (with [`Error::Cancelled`]) once `cancel` is
    /// set: Embree asks a progress monitor whether to go on as it builds.
    pub(crate) fn commit_cancellable(&mut self, cancel: &CancelToken) -> Result<()> {
        let token: *const CancelToken = cancel;
        // SAFETY: the scene is live and no query can run during `&mut self`. The monitor
        // only reads the token, which outlives the call: it is removed before returning.
        unsafe {
            sys::rtcSetSceneProgressMonitorFunction(
                self.raw,
                Some(keep_building),
                token as *mut c_void,
            );
            sys::rtcCommitScene(self.raw);
            sys::rtcSetSceneProgressMonitorFunction(self.raw, None, std::ptr::null_mut());
        }
        let built = self.device.check("committing the scene");
        if cancel.is_cancelled() {
            return Err(Error::Cancelled {
                stage: "the intersection structure's build".into(),
            });
        }
        built?;
        self.committed = true;
        Ok(())
    }

    /// The closest hit along the ray within `[tmin, tmax]`.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !self.committed {
            return None;
        }
        let mut rayhit = sys::RTCRayHit {
            ray: to_rtc_ray(ray),
            ..Default::default()
        };
        rayhit.hit.geomID = sys::RTC_INVALID_GEOMETRY_ID;
        rayhit.hit.instID.fill(sys::RTC_INVALID_GEOMETRY_ID);
        query::intersect(self.raw, &mut rayhit);
        let h = rayhit.hit;
        (h.geomID != sys::RTC_INVALID_GEOMETRY_ID).then(|| Hit {
            t: rayhit.ray.tfar,
            u: h.u,
            v: h.v,
            ng: Vec3::new(h.Ng_x, h.Ng_y, h.Ng_z),
            geom_id: h.geomID,
            prim_id: h.primID,
            // The instance geometry's id; the normal is in the instanced scene's space.
            instance: (h.instID[0] != sys::RTC_INVALID_GEOMETRY_ID).then_some(h.instID[0]),
        })
    }

    /// Whether anything lies along the ray within `[tmin, tmax]`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        if !self.committed {
            return false;
        }
        let mut r = to_rtc_ray(ray);
        query::occluded(self.raw, &mut r);
        // Embree marks an occluded ray by setting tfar to -inf.
        r.tfar == f32::NEG_INFINITY
    }
}

fn check_indices<'a>(
    vertex_count: usize,
    mut indices: impl Iterator<Item = &'a u32>,
) -> Result<()> {
    match indices.find(|&&i| i as usize >= vertex_count) {
        Some(i) => Err(Error::Embree(format!(
            "index {i} is out of range for {vertex_count} vertices"
        ))),
        None => Ok(()),
    }
}

fn to_rtc_ray(ray: &Ray) -> sys::RTCRay {
    sys::RTCRay {
        org_x: ray.origin.x,
        org_y: ray.origin.y,
        org_z: ray.origin.z,
        tnear: ray.tmin,
        dir_x: ray.dir.x,
        dir_y: ray.dir.y,
        dir_z: ray.dir.z,
        time: ray.time,
        tfar: ray.tmax,
        // Embree 4's default geometry mask is 1, Embree 3's all ones: all ones hits both.
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

/// Gives `geometry` a new buffer (type, slot, format, bytes an item) holding `data`: Embree
/// allocates as many items as `data` fills (padding vertex buffers for its 16-byte loads),
/// and exactly those bytes are copied. A buffer Embree cannot allocate is left unfilled: the
/// device reports it when the geometry is committed.
///
/// # Safety
/// `geometry` must be live, and `data`'s bytes a whole number of items of the format.
unsafe fn fill_buffer<T: Copy>(
    geometry: sys::RTCGeometry,
    (kind, slot, format, item_bytes): (sys::RTCBufferType, u32, sys::RTCFormat, usize),
    data: &[T],
) {
    let bytes = std::mem::size_of_val(data);
    // SAFETY: the caller's; the buffer has room for `bytes / item_bytes` items.
    unsafe {
        let buffer = sys::rtcSetNewGeometryBuffer(
            geometry,
            kind,
            slot,
            format,
            item_bytes,
            bytes / item_bytes,
        );
        if !buffer.is_null() {
            std::ptr::copy_nonoverlapping(data.as_ptr() as *const u8, buffer as *mut u8, bytes);
        }
    }
}

/// The single-ray queries, whose signatures differ between Embree 3 and 4.
#[cfg(embree3)]
mod query {
    use super::sys;

    /// What `rtcInitIntersectContext` does; it is header-inline, so not in the library.
    fn context() -> sys::RTCIntersectContext {
        let mut ctx = sys::RTCIntersectContext {
            flags: sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
            filter: None,
            ..Default::default()
        };
        ctx.instID.fill(sys::RTC_INVALID_GEOMETRY_ID);
        ctx
    }

    pub fn intersect(scene: sys::RTCScene, rayhit: &mut sys::RTCRayHit) {
        let mut ctx = context();
        // SAFETY: the scene is committed and live; `rayhit` is aligned by its Rust type.
        unsafe { sys::rtcIntersect1(scene, &mut ctx, rayhit) }
    }

    pub fn occluded(scene: sys::RTCScene, ray: &mut sys::RTCRay) {
        let mut ctx = context();
        // SAFETY: as in `intersect`.
        unsafe { sys::rtcOccluded1(scene, &mut ctx, ray) }
    }
}

#[cfg(embree4)]
mod query {
    use super::sys;

    pub fn intersect(scene: sys::RTCScene, rayhit: &mut sys::RTCRayHit) {
        // SAFETY: the scene is committed and live; null arguments select Embree's defaults.
        unsafe { sys::rtcIntersect1(scene, rayhit, std::ptr::null_mut()) }
    }

    pub fn occluded(scene: sys::RTCScene, ray: &mut sys::RTCRay) {
        // SAFETY: as in `intersect`.
        unsafe { sys::rtcOccluded1(scene, ray, std::ptr::null_mut()) }
    }
}

/// Adds one shape's geometry to `scene`.
fn attach_geometry(scene: &mut Scene, geometry: &Geometry) -> Result<GeometryId> {
    match geometry.primitives() {
        Primitives::Sphere { center, radius } => scene.attach_spheres(&[center.extend(radius)]),
        Primitives::Triangles(m) => scene.attach_triangles(&m.positions, &m.indices),
        Primitives::Quads(q) => scene.attach_quads(&q.positions, &q.indices),
    }
}

/// The version string of the Embree library raylink runs on.
pub fn version() -> Result<String> {
    Ok(Device::new()?.version())
}

/// [`Accel`] over an Embree scene holding one geometry per scene shape, then one instance
/// geometry per scene instance.
pub struct EmbreeAccel {
    scene: Scene,
    device: Device,
    /// One Embree scene per prototype, held as long as the instances refer to them.
    _prototypes: Vec<Scene>,
    /// The scene's instances, for their normals' transforms; instance `i` is geometry
    /// `first_instance + i`.
    instances: Vec<Instance>,
    first_instance: u32,
    /// For a dynamic accel: what each geometry was built from, to tell a vertex update
    /// (refit) from a change of topology (rebuild).
    shapes: Option<Vec<ShapeKey>>,
}

/// The topology of a shape (kind, vertex count, hash of the indices) and a hash of its
/// vertices.
#[derive(Clone, Debug, PartialEq, Eq)]
struct ShapeKey {
    topology: (u8, usize, u64),
    vertices: u64,
}

fn shape_key(geometry: &Geometry) -> ShapeKey {
    use std::hash::{Hash, Hasher};
    let hash = |f: &dyn Fn(&mut std::collections::hash_map::DefaultHasher)| {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        f(&mut h);
        h.finish()
    };
    let floats = |v: &[Vec3]| {
        hash(&|h| {
            v.iter()
                .for_each(|p| p.to_array().map(f32::to_bits).hash(h))
        })
    };
    match geometry.primitives() {
        Primitives::Sphere { center, radius } => ShapeKey {
            topology: (0, 1, 0),
            vertices: hash(&|h| center.extend(radius).to_array().map(f32::to_bits).hash(h)),
        },
        Primitives::Triangles(m) => ShapeKey {
            topology: (1, m.positions.len(), hash(&|h| m.indices.hash(h))),
            vertices: floats(&m.positions),
        },
        Primitives::Quads(q) => ShapeKey {
            topology: (2, q.positions.len(), hash(&|h| q.indices.hash(h))),
            vertices: floats(&q.positions),
        },
    }
}

impl EmbreeAccel {
    pub fn build(desc: &SceneDesc) -> Result<EmbreeAccel> {
        EmbreeAccel::build_on(desc, Device::new()?)
    }

    /// [`build`](Self::build), stopped early once `cancel` is set.
    pub(crate) fn build_cancellable(desc: &SceneDesc, cancel: &CancelToken) -> Result<EmbreeAccel> {
        let device = Device::new()?;
        let scene = Scene::new(&device)?;
        EmbreeAccel::fill(desc, device, scene, None, cancel)
    }

    /// Builds on a given device (for example one made with `threads=1` to build on one thread).
    /// The accel should own its device alone for [`memory_bytes`](Self::memory_bytes) to be
    /// its own.
    pub(crate) fn build_on(desc: &SceneDesc, device: Device) -> Result<EmbreeAccel> {
        let scene = Scene::new(&device)?;
        EmbreeAccel::fill(desc, device, scene, None, &CancelToken::new())
    }

    /// Builds a dynamic scene (see [`Scene::new_dynamic`]) that [`update`](Self::update) can
    /// move to another frame of an animation.
    pub fn build_dynamic(desc: &SceneDesc, cancel: &CancelToken) -> Result<EmbreeAccel> {
        let device = Device::new()?;
        let scene = Scene::new_dynamic(&device)?;
        let keys = desc.shapes.iter().map(|s| shape_key(&s.geometry)).collect();
        EmbreeAccel::fill(desc, device, scene, Some(keys), cancel)
    }

    /// Moves a dynamic accel to `desc`'s geometry: moved vertices are copied into the
    /// geometries' buffers and their BVHs refitted; other changes rebuild the scene on the
    /// same device. A static accel is rebuilt.
    pub fn update(&mut self, desc: &SceneDesc) -> Result<Update> {
        let keys: Vec<ShapeKey> = desc.shapes.iter().map(|s| shape_key(&s.geometry)).collect();
        // A cut-out's filter holds its shape's geometry and alpha as they were: scenes with
        // cut-outs are built again (their spheres' uvs would move with a refit).
        let cutouts =
            !self.scene.cutouts.is_empty() || desc.shapes.iter().any(|s| s.alpha.is_some());
        // Instances are placed again by a rebuild too, and moving shapes (two vertex
        // buffers) are built again.
        let cutouts = cutouts || !self.instances.is_empty() || desc.has_instances();
        let cutouts = cutouts || desc.shapes.iter().any(|s| s.motion.is_some());
        let same_topology = !cutouts
            && self.shapes.as_ref().is_some_and(|old| {
                old.len() == keys.len()
                    && old.iter().zip(&keys).all(|(a, b)| a.topology == b.topology)
            });
        if !same_topology {
            let scene = if self.shapes.is_some() {
                Scene::new_dynamic(&self.device)?
            } else {
                Scene::new(&self.device)?
            };
            let dynamic = self.shapes.is_some().then_some(keys);
            let device = Device {
                inner: self.device.inner.clone(),
            };
            *self = EmbreeAccel::fill(desc, device, scene, dynamic, &CancelToken::new())?;
            return Ok(Update::Rebuilt);
        }
        let old = self.shapes.take().unwrap_or_default();
        let mut moved = 0;
        for (i, ((a, b), shape)) in old.iter().zip(&keys).zip(&desc.shapes).enumerate() {
            if a.vertices == b.vertices {
                continue;
            }
            moved += 1;
            let positions = match shape.geometry.primitives() {
                Primitives::Sphere { center, radius } => {
                    self.scene
                        .update_vertices(i as u32, &center.extend(radius).to_array(), 4)?;
                    continue;
                }
                Primitives::Triangles(m) => &m.positions,
                Primitives::Quads(q) => &q.positions,
            };
            let flat: Vec<f32> = positions.iter().flat_map(|p| p.to_array()).collect();
            self.scene.update_vertices(i as u32, &flat, 3)?;
        }
        self.shapes = Some(keys);
        if moved == 0 {
            return Ok(Update::Unchanged);
        }
        self.scene.commit()?;
        Ok(Update::Refit(moved))
    }

    fn fill(
        desc: &SceneDesc,
        device: Device,
        mut scene: Scene,
        shapes: Option<Vec<ShapeKey>>,
        cancel: &CancelToken,
    ) -> Result<EmbreeAccel> {
        for (shape, cutout) in desc.shapes.iter().zip(Cutout::of_scene(desc)) {
            let id = if shape.moves() {
                scene.attach_moving(shape)?
            } else {
                attach_geometry(&mut scene, &shape.geometry)?
            };
            if let Some(cutout) = cutout {
                scene.set_cutout(id, Arc::new(cutout))?;
            }
            cancel.check("the intersection structure's build")?;
        }
        let mut prototypes = Vec::with_capacity(desc.prototypes.len());
        for prototype in &desc.prototypes {
            let mut own = Scene::new(&device)?;
            for shape in &prototype.shapes {
                attach_geometry(&mut own, &shape.geometry)?;
            }
            own.commit_cancellable(cancel)?;
            prototypes.push(own);
        }
        let first_instance = scene.next_id;
        for instance in &desc.instances {
            scene.attach_instance(
                &prototypes[instance.prototype as usize],
                instance.to_world(),
            )?;
            cancel.check("the intersection structure's build")?;
        }
        scene.commit_cancellable(cancel)?;
        // Moving geometries cannot be refitted in place: `update` rebuilds them.
        let shapes = shapes.filter(|_| !desc.shapes.iter().any(|s| s.motion.is_some()));
        Ok(EmbreeAccel {
            scene,
            device,
            _prototypes: prototypes,
            instances: desc.instances.clone(),
            first_instance,
            shapes,
        })
    }

    /// Bytes allocated by Embree for this accel's device: its buffers, BVH and allocator blocks.
    pub fn memory_bytes(&self) -> usize {
        self.device.memory_bytes().max(0) as usize
    }
}

impl Accel for EmbreeAccel {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut hit = self.scene.intersect(ray)?;
        if let Some(id) = hit.instance {
            let i = id - self.first_instance;
            hit.ng = self.instances[i as usize].normal_to_world(hit.ng);
            hit.instance = Some(i);
        }
        Some(hit)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.scene.occluded(ray)
    }
}
