//! The scenes of the coherence tests that both the library's tests (`src/tests/coherence.rs`)
//! and the command line's (`tests/coherence.rs`, which includes this file) render: a floor and
//! a glass sphere under a point light, and a mirror sphere that moves for two frames.

pub(crate) const BASE: &str = r#"
[camera]
position = [0, 1.4, 5.5]
look_at = [0, 0.8, 0]
fov = 40
width = 48
height = 36

[world]
ambient = 0.1
background = [0.3, 0.5, 0.85]

[materials.floor]
diffuse = { checker = { even = [0.85, 0.12, 0.05], odd = [0.95, 0.85, 0.15], size = 0.5 } }

[materials.glass]
diffuse = 0.03
specular = 0.15
transmission = 0.85
ior = 1.5

[materials.mirror]
diffuse = 0.2
specular = 0.7
phong_exponent = 60

[materials.wall]
diffuse = 0.5

[[shapes]]
type = "quad"
material = "floor"
vertices = [[-6, 0, 3], [6, 0, 3], [6, 0, -12], [-6, 0, -12]]

[[shapes]]
type = "sphere"
material = "glass"
center = [-1.2, 0.6, 0.2]
radius = 0.6
"#;

const LIGHTS: &str = r#"
[[lights]]
type = "point"
position = [-4, 7, 6]
intensity = 180
"#;

/// [`BASE`] with `extra` and the light, over four frames; `animation` adds to the
/// `[animation]` table.
pub(crate) fn animated(animation: &str, extra: &str) -> String {
    format!("[animation]\nframes = 4\n{BASE}{extra}{LIGHTS}").replace(
        "[animation]\nframes = 4\n",
        &format!("[animation]\nframes = 4\n{animation}"),
    )
}

pub(crate) const MOVING: &str = r#"
[[shapes]]
type = "sphere"
material = "mirror"
center = [0.9, 0.4, -0.8]
radius = 0.4

[[shapes.keyframes]]
frame = 0
translate = [0, 1.5, 0]
interpolation = "smooth"
[[shapes.keyframes]]
frame = 2
translate = [0, 0, 0]
"#;
