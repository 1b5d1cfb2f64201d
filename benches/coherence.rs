//! Criterion bench of the coherence recorder's segment walk (`ActiveVoxels::walk`), the cost
//! that `raylink animate --records tables` adds to every ray: a grid shaped like the circus animation's
//! (35×33×8 voxels, a quarter of them active, in two boxes), segments like its camera and
//! shadow rays (long rays from outside, short ones ending inside, and shadow rays from inside
//! to far lights). One thread. Also the clip that segment records pay instead.
//!
//! `cargo bench --bench coherence`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use raylink::coherence::grid::{ActiveVoxels, Grid};
use raylink::math::Vec3;
use std::time::Duration;

/// A small deterministic generator.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn walk(c: &mut Criterion) {
    let (lo, hi) = (Vec3::new(-1.7, 0.0, 0.25), Vec3::new(3.5, 4.8, 1.35));
    let grid = Grid::new(lo, hi, [35, 33, 8]);
    let boxes = [
        (Vec3::new(-1.5, 0.3, 0.3), Vec3::new(0.5, 3.5, 1.0)),
        (Vec3::new(1.0, 0.0, 0.4), Vec3::new(3.4, 2.0, 1.3)),
    ];
    let active = ActiveVoxels::boxes(grid.clone(), &boxes, 1e-3);
    let mut rng = Lcg(5);
    let mut point =
        |scale: Vec3, offset: Vec3| offset + Vec3::new(rng.next(), rng.next(), rng.next()) * scale;
    let camera = Vec3::new(0.0, 2.4, 9.5);
    let lights = [Vec3::new(-4.0, 8.0, 4.0), Vec3::new(5.0, 7.0, 2.0)];
    let mut segments = Vec::new();
    for i in 0..100_000 {
        // A point on the scene's surfaces: in or around the grid.
        let p = point(Vec3::new(12.0, 5.0, 8.0), Vec3::new(-6.0, 0.0, -4.0));
        if i % 3 == 0 {
            segments.push((camera, p - camera, 0.0, 1.0));
        } else {
            let l = lights[i % 2];
            segments.push((p, l - p, 1e-4, 1.0));
        }
    }
    let mut group = c.benchmark_group("coherence");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(3));
    group.throughput(Throughput::Elements(segments.len() as u64));
    let mut set = vec![0u64; grid.len().div_ceil(64)];
    group.bench_function("walk", |b| {
        b.iter(|| {
            for &(o, d, t0, t1) in &segments {
                active.walk(o, d, t0, t1, |v| set[v / 64] |= 1 << (v % 64));
            }
            set.iter().map(|w| w.count_ones()).sum::<u32>()
        })
    });
    // What segment records pay instead (`--records segments`): the clip to the box around
    // the active voxels, and a copy of the end points of what is left.
    let mut kept = Vec::with_capacity(segments.len());
    group.bench_function("clip", |b| {
        b.iter(|| {
            kept.clear();
            for &(o, d, t0, t1) in &segments {
                if let Some(s) = active.clip_segment(o, d, t0, t1) {
                    kept.push(s);
                }
            }
            kept.len()
        })
    });
    group.finish();
}

criterion_group!(benches, walk);
criterion_main!(benches);
