//! Criterion benches of the intersection kernels, so that regressions show: camera, shadow and
//! diffuse-bounce rays (the ray sets of `raylink bench`) and the builds, for both backends, on
//! the Cornell box and a mid-size scene. Rays are traced on one thread; builds use all cores.
//!
//! `cargo bench --bench accel` (add `-- cornell` to run one scene's group).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use raylink::accel::{self, Backend};
use raylink::bench::{count_hits, rays, scenes, RayKind};
use std::time::Duration;

const SCENES: [&str; 2] = ["cornell", "spheres-100k"];

fn kernels(c: &mut Criterion) {
    raylink::platform::set_flush_denormals();
    for name in SCENES {
        let scene = scenes::resolve(name).expect("bench scene");
        let reference =
            accel::build(&scene, Backend::Embree, &Default::default()).expect("Embree builds");
        let sets = rays::generate(&scene, reference.as_ref(), 160, 120, 1);
        let mut group = c.benchmark_group(format!("trace/{name}"));
        group
            .sample_size(20)
            .measurement_time(Duration::from_secs(3));
        for backend in Backend::ALL {
            let accel = accel::build(&scene, backend, &Default::default()).expect("backend builds");
            for kind in RayKind::ALL {
                let rays = sets.get(kind);
                group.throughput(Throughput::Elements(rays.len() as u64));
                group.bench_function(BenchmarkId::new(kind.name(), backend), |b| {
                    b.iter(|| count_hits(accel.as_ref(), rays, kind))
                });
            }
        }
        group.finish();
    }
}

fn builds(c: &mut Criterion) {
    for name in SCENES {
        let scene = scenes::resolve(name).expect("bench scene");
        let mut group = c.benchmark_group(format!("build/{name}"));
        group
            .sample_size(10)
            .measurement_time(Duration::from_secs(3))
            .throughput(Throughput::Elements(scenes::primitive_count(&scene) as u64));
        for backend in Backend::ALL {
            group.bench_function(BenchmarkId::from_parameter(backend), |b| {
                b.iter(|| {
                    accel::build(&scene, backend, &Default::default()).expect("backend builds")
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, kernels, builds);
criterion_main!(benches);
