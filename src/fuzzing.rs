//! Entry points for the fuzz targets in `fuzz/` (cargo fuzz): each hands arbitrary bytes to
//! one reader the way a user's file reaches it, through a file in a per-process scratch
//! folder. A reader may reject the bytes, but only with a one-line error: a panic, an abort
//! or a multi-line message is a bug the fuzzer reports. Not an API.

use crate::integrators::irradiance_cache::{file as ic_file, IcOptions};
use crate::scene::{obj, ply, Scene};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// This process's scratch folder (fuzzers run several processes side by side).
fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("raylink-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("the scratch folder can be made");
        dir
    })
}

/// `name` in the scratch folder, for this thread (tests replay corpora on several threads).
fn scratch_path(name: &str) -> PathBuf {
    let thread = format!("{:?}", std::thread::current().id());
    let thread: String = thread.chars().filter(char::is_ascii_digit).collect();
    scratch().join(format!("{thread}-{name}"))
}

fn put(name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch_path(name);
    std::fs::write(&path, bytes).expect("the scratch file can be written");
    path
}

/// A rejection must be one line (the CLI prints it as `raylink: error: ...`).
fn one_line<T>(result: crate::error::Result<T>) -> Option<T> {
    match result {
        Ok(v) => Some(v),
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.contains('\n'), "a multi-line error: {msg:?}");
            None
        }
    }
}

/// A native TOML scene (with its animation keyframes), as `raylink render` reads it.
pub fn scene_toml(data: &[u8]) {
    one_line(Scene::load(&put("scene.toml", data)));
}

/// A pbrt-v4 scene.
pub fn pbrt(data: &[u8]) {
    one_line(Scene::load(&put("scene.pbrt", data)));
}

/// An OBJ file and the MTL file it may name (`mtllib m.mtl`): the bytes before the first NUL
/// are the OBJ, the rest the MTL.
pub fn obj(data: &[u8]) {
    let split = data.iter().position(|&b| b == 0).unwrap_or(data.len());
    put("m.mtl", data.get(split + 1..).unwrap_or_default());
    one_line(obj::load(&put("m.obj", &data[..split]), true));
}

/// A PLY mesh (ASCII or binary).
pub fn ply(data: &[u8]) {
    one_line(ply::read(&put("m.ply", data)));
}

/// A NanoVDB volume, its grids "density" and "temperature" read as a `nanovdb` medium reads
/// them, within a budget of 64 MiB (a small file may describe a grid of 512³ samples).
pub fn nanovdb(data: &[u8]) {
    use crate::input_file::Allowance;
    let budget = Allowance::new(crate::control::MemoryBudget::bytes(64 << 20), 0);
    let path = put("volume.nvdb", data);
    one_line(crate::scene::media::nanovdb::read(
        &path,
        &["density", "temperature"],
        &budget,
    ));
}

/// The scene the cache-file target loads caches for.
fn cache_scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        crate::scene::toml::from_str(
            "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 0, 0]\n\
             [materials.white]\ndiffuse = [0.8, 0.8, 0.8]\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"white\"\n\
             [[lights]]\ntype = \"point\"\nposition = [0, 3, 0]\nintensity = [5, 5, 5]\n",
            Path::new("fuzz.toml"),
        )
        .expect("the fuzz scene is valid")
    })
}

/// An irradiance-cache file's records: the bytes follow a valid header for a fixed scene, and
/// the file gets a valid checksum, so the fuzzer explores the record reader rather than the
/// checksum.
pub fn irradiance_cache(data: &[u8]) {
    let scene = cache_scene();
    let options = IcOptions::default();
    let mut bytes = ic_file::FORMAT.start(data.len() + 64);
    bytes.extend_from_slice(&ic_file::header(scene, &options));
    bytes.extend_from_slice(data);
    let path = scratch_path("cache.rlic");
    ic_file::FORMAT
        .save(&path, bytes)
        .expect("the scratch file can be written");
    one_line(ic_file::load(&path, scene, &options));
}

/// The scene the network-file target loads networks for: a closed box with a lamp.
fn network_scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        crate::scene::toml::from_str(NETWORK_SCENE, Path::new("fuzz-network.toml"))
            .expect("the fuzz scene is valid")
    })
}

/// The network-file target's scene (also used to make its seed corpus).
pub const NETWORK_SCENE: &str = "[camera]\nposition = [0.5, 0.5, 0.9]\nlook_at = [0.5, 0.5, 0]\n\
     [materials.white]\ndiffuse = 0.7\n[materials.lamp]\nemission = [5, 5, 5]\n\
     [[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\n\
     vertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]\n\
     [[shapes]]\ntype = \"quad\"\nmaterial = \"lamp\"\n\
     vertices = [[0.25, 0.25, 1], [0.25, 0.75, 1], [0.75, 0.75, 1], [0.75, 0.25, 1]]\n";

/// An illumination-network file for a fixed scene: the bytes follow the magic and version
/// (the seed corpus holds real networks of [`NETWORK_SCENE`] without them). The reader checks
/// the header (scene, parameters, sizes) before the checksums.
pub fn network(data: &[u8]) {
    use crate::integrators::illumination_network::file as net_file;
    let mut bytes = net_file::FORMAT.start(data.len());
    bytes.extend_from_slice(data);
    let path = put("network.rlnet", &bytes);
    one_line(net_file::load_all(&path, network_scene(), None));
}

/// [`network`] with both checksums made right for the bytes (where the header's counts place
/// the prefix checksum within the file), so that the fuzzer explores what follows them: the
/// node and link tables and the light basis, read by the whole load and the prefix's.
pub fn network_sealed(data: &[u8]) {
    use crate::binary_file::checksum;
    use crate::integrators::illumination_network::file as net_file;
    let mut bytes = net_file::FORMAT.start(data.len());
    bytes.extend_from_slice(data);
    let word = |at: usize| {
        bytes
            .get(at..at + 8)
            .map(|w| u64::from_le_bytes(w.try_into().unwrap()))
    };
    // The nodes count (u32 at 48) and the basis length (u64 at 112) place the prefix checksum.
    let nodes = word(48).map(|w| w & 0xffff_ffff);
    let prefix = nodes
        .zip(word(112))
        .and_then(|(n, basis)| 120u64.checked_add(4 * n)?.checked_add(basis));
    if let Some(p) = prefix.and_then(|p| usize::try_from(p).ok()) {
        if p.checked_add(16).is_some_and(|end| end <= bytes.len()) {
            let sum = checksum(&bytes[..p]);
            bytes[p..p + 8].copy_from_slice(&sum.to_le_bytes());
        }
    }
    if bytes.len() >= 20 {
        let n = bytes.len() - 8;
        let sum = checksum(&bytes[..n]);
        bytes[n..].copy_from_slice(&sum.to_le_bytes());
    }
    let path = put("network-sealed.rlnet", &bytes);
    one_line(net_file::load_all(&path, network_scene(), None));
    one_line(net_file::load_prefix(&path, network_scene(), None));
}

/// The checkpoint target's render: its settings string, film size (two tiles) and samples per
/// pixel (the fuzz inputs are checkpoint bodies after this settings string).
pub(crate) const CHECKPOINT_SETTINGS: &str = "fuzz checkpoint";
pub(crate) const CHECKPOINT_SIZE: (u32, u32) = (17, 2);
pub(crate) const CHECKPOINT_SPP: u32 = 64;

/// A render checkpoint's counts and sums: the bytes follow a valid header and the settings of
/// a fixed render, and the file gets a valid checksum, so that the fuzzer explores the
/// semantic checks (sizes, passes, tiles, sample totals, values) behind it, as `--resume`
/// reads it. Returns whether the checkpoint was accepted.
pub fn checkpoint(data: &[u8]) -> bool {
    use crate::render::{checkpoint, Film};
    let settings = CHECKPOINT_SETTINGS.as_bytes();
    let mut bytes = checkpoint::FORMAT.start(data.len() + settings.len() + 16);
    bytes.extend_from_slice(&(settings.len() as u64).to_le_bytes());
    bytes.extend_from_slice(settings);
    bytes.extend_from_slice(data);
    let path = scratch_path("render.checkpoint");
    checkpoint::FORMAT
        .save(&path, bytes)
        .expect("the scratch file can be written");
    let (width, height) = CHECKPOINT_SIZE;
    let blank = Film::new(
        width,
        height,
        crate::image::filter::Filter::default(),
        crate::image::filter::Reconstruction::Splat,
    )
    .expect("the fuzz film can be made");
    if let Some(resumed) = one_line(checkpoint::load(
        &path,
        CHECKPOINT_SETTINGS,
        blank,
        CHECKPOINT_SPP,
    )) {
        // What is accepted must be a film a render of CHECKPOINT_SPP passes through.
        assert!(
            resumed.film.spp < CHECKPOINT_SPP,
            "accepted a finished film"
        );
        return true;
    }
    false
}

/// The numbers a camera-and-transform input is made of: little-endian f64s, eight bytes
/// each (zeros past the end), so that every value from 1e-300 to 1e300, NaN and infinity
/// can reach the readers.
struct Numbers<'a>(&'a [u8]);

impl Numbers<'_> {
    fn next(&mut self) -> f64 {
        let mut word = [0u8; 8];
        let n = self.0.len().min(8);
        word[..n].copy_from_slice(&self.0[..n]);
        self.0 = &self.0[n..];
        f64::from_le_bytes(word)
    }

    fn three(&mut self) -> [f64; 3] {
        [self.next(), self.next(), self.next()]
    }

    /// A small choice (0..n) from the next number's low bits.
    fn pick(&mut self, n: u64) -> u64 {
        self.next().to_bits() % n
    }
}

/// Formats a number as the scene files write it (`inf` and `NaN` stay as Rust prints them:
/// the readers must refuse them too).
fn text(v: f64) -> String {
    format!("{v:e}")
}

fn text3(v: [f64; 3]) -> String {
    v.map(text).join(" ")
}

/// Camera and transform paths: the bytes are numbers (little-endian f64s, eight bytes
/// each) for a camera (eye, target, up, field of view, lens, orthographic size), two
/// transform steps and a light's `from` and `to`, put into a camera checked directly, a
/// pbrt scene and a TOML scene. Each may be refused with one line; what is accepted must
/// give finite rays within the range the backends trace, and lights inside it.
pub fn camera(data: &[u8]) {
    use crate::scene::{Camera, Projection, MAX_COORDINATE};
    let mut n = Numbers(data);
    let (eye, target, up) = (n.three(), n.three(), n.three());
    let (fov, lens, focal, size) = (n.next(), n.next(), n.next(), n.next());
    let projection = n.pick(3);
    let steps: Vec<(u64, [f64; 3], f64)> =
        (0..2).map(|_| (n.pick(4), n.three(), n.next())).collect();
    let (from, to, light) = (n.three(), n.three(), n.pick(3));
    let (scale, cone) = (n.next(), n.next());
    let v3 = |v: [f64; 3]| crate::math::Vec3::from_array(v.map(|x| x as f32));
    let camera = Camera {
        position: v3(eye),
        look_at: v3(target),
        up: v3(up),
        fov_deg: fov as f32,
        width: 16,
        height: 9,
        projection: match projection {
            0 => Projection::Pinhole,
            1 => Projection::ThinLens {
                radius: lens as f32,
                focal_distance: focal as f32,
            },
            _ => Projection::Orthographic { size: size as f32 },
        },
    };
    let traceable = |camera: &Camera| {
        for (x, y) in [(0.0, 0.0), (16.0, 0.0), (0.0, 9.0), (16.0, 9.0), (8.0, 4.5)] {
            let ray = camera.ray(x, y);
            assert!(
                ray.origin.is_finite()
                    && ray.dir.is_finite()
                    && ray.origin.abs().max_element() <= MAX_COORDINATE,
                "an accepted camera gives the ray {ray:?}: {camera:?}"
            );
        }
    };
    if camera.check().is_ok() {
        traceable(&camera);
    }
    let in_range = |scene: &Scene| {
        for (p, intensity) in scene.lights.iter().filter_map(|l| l.model().point_source()) {
            assert!(
                p.is_finite() && p.abs().max_element() <= MAX_COORDINATE && intensity.is_finite(),
                "an accepted light at {p:?} of {intensity:?}"
            );
        }
    };

    // pbrt: the steps before LookAt and around the light.
    let pbrt_step = |&(kind, v, angle): &(u64, [f64; 3], f64)| match kind {
        0 => format!("Translate {}\n", text3(v)),
        1 => format!("Scale {}\n", text3(v)),
        2 => format!("Rotate {} {}\n", text(angle), text3(v)),
        _ => format!("LookAt 0 0 0 {} {}\n", text3(v), text3([angle, 1.0, 0.0])),
    };
    let camera_type = match projection {
        0 => format!("\"perspective\" \"float fov\" {}", text(fov)),
        1 => format!(
            "\"perspective\" \"float fov\" {} \"float lensradius\" {} \"float focaldistance\" {}",
            text(fov),
            text(lens),
            text(focal)
        ),
        _ => format!(
            "\"orthographic\" \"float screenwindow\" [-{0} {0} -{0} {0}]",
            text(size)
        ),
    };
    let light_type = ["point", "spot", "distant"][light as usize];
    let pbrt = format!(
        "{}LookAt {} {} {}\nCamera {camera_type}\nWorldBegin\nAttributeBegin\n{}\
         LightSource \"{light_type}\" \"point3 from\" [{}] \"point3 to\" [{}] \"float scale\" {} \
         \"float coneangle\" {}\nAttributeEnd\n\
         Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 2]\n",
        pbrt_step(&steps[0]),
        text3(eye),
        text3(target),
        text3(up),
        pbrt_step(&steps[1]),
        text3(from),
        text3(to),
        text(scale),
        text(cone),
    );
    if let Some(scene) = one_line(Scene::load(&put("camera.pbrt", pbrt.as_bytes()))) {
        assert!(
            scene.camera.check().is_ok(),
            "pbrt accepted {:?}",
            scene.camera
        );
        traceable(&scene.camera);
        in_range(&scene);
    }

    // TOML: the camera's fields, the steps as a shape's transform, the light's aim.
    let array = |v: [f64; 3]| format!("[{}]", v.map(text).join(", "));
    let toml_step = |&(kind, v, angle): &(u64, [f64; 3], f64)| match kind {
        0 | 3 => format!("{{ translate = {} }}", array(v)),
        1 => format!("{{ scale = {} }}", array(v)),
        _ => format!(
            "{{ rotate = {{ axis = {}, degrees = {} }} }}",
            array(v),
            text(angle)
        ),
    };
    let lens_lines = match projection {
        0 => String::new(),
        1 => format!(
            "lens_radius = {}\nfocal_distance = {}\n",
            text(lens),
            text(focal)
        ),
        _ => format!("projection = \"orthographic\"\nsize = {}\n", text(size)),
    };
    let light_lines = match light {
        0 => format!(
            "type = \"point\"\nposition = {}\nintensity = {}",
            array(from),
            text(scale)
        ),
        1 => format!(
            "type = \"spot\"\nposition = {}\ndirection = {}\nintensity = 1\ncone_angle = {}",
            array(from),
            array(to),
            text(cone)
        ),
        _ => format!(
            "type = \"directional\"\ndirection = {}\nirradiance = 1",
            array(to)
        ),
    };
    let toml = format!(
        "[camera]\nposition = {}\nlook_at = {}\nup = {}\nfov = {}\n{lens_lines}\
         [materials.white]\ndiffuse = 0.5\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\ntransform = [{}, {}]\n\
         [[lights]]\n{light_lines}\n",
        array(eye),
        array(target),
        array(up),
        text(fov),
        toml_step(&steps[0]),
        toml_step(&steps[1]),
    );
    if let Some(scene) = one_line(Scene::load(&put("camera.toml", toml.as_bytes()))) {
        assert!(
            scene.camera.check().is_ok(),
            "TOML accepted {:?}",
            scene.camera
        );
        traceable(&scene.camera);
        in_range(&scene);
    }
}
