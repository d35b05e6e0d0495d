//! Rasteriser throughput: a UV sphere of ~8,000 triangles (the size of the head mesh) at the
//! stimulus size 485×480, Lambert-shaded, on one thread and on all threads.
//!
//! Run with `cargo bench --bench raster`. On a busy machine wall-clock figures are noisy; with
//! `RENDER_CPU_TIME=1` the bench instead prints the CPU time per one-thread frame, read from
//! `/proc/thread-self/schedstat` (Linux), which other processes do not inflate as much
//! (`RENDER_PNG=out.png` also writes the benchmarked frame).

use divan::Bencher;
use facslab::engine::camera::Camera;
use facslab::engine::raster::{Fragment, RenderOptions, SampleCount, Shader, Triangles, render, visibility};
use glam::{Vec2, Vec3};

fn main() {
    if std::env::var_os("RENDER_CPU_TIME").is_some() {
        cpu_time_report();
    } else {
        divan::main();
    }
}

/// Nanoseconds this thread has spent on a CPU.
fn thread_cpu_ns() -> u64 {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat").expect("Linux schedstat");
    stat.split_whitespace().next().and_then(|t| t.parse().ok()).expect("schedstat run time")
}

fn cpu_time_report() {
    let mesh = sphere(64, 63);
    let scene = [Triangles {
        positions: &mesh.positions,
        normals: &mesh.normals,
        uvs: &mesh.uvs,
        indices: &mesh.indices,
        part: 0,
        two_sided: false,
        coverage: &[],
    }];
    let camera = camera();
    println!("{} triangles, {}x{}", mesh.indices.len(), camera.width, camera.height);
    if let Some(path) = std::env::var_os("RENDER_PNG") {
        std::fs::write(&path, render(&scene, &camera, &Lambert, &RenderOptions::default()).encode_png()).expect("write PNG");
        println!("wrote {}", path.to_string_lossy());
    }
    for spp in [4, 8, 16] {
        let options = RenderOptions { samples_per_pixel: samples(spp), threads: Some(1), backface_culling: true, shade_per_surface: false };
        let frames = 60;
        let mut best = u64::MAX;
        let mut total = 0;
        for _ in 0..frames {
            let start = thread_cpu_ns();
            divan::black_box(render(divan::black_box(&scene), &camera, &Lambert, &options));
            let spent = thread_cpu_ns() - start;
            best = best.min(spent);
            total += spent;
        }
        println!(
            "{spp:>2} spp, one thread: CPU time per frame mean {:.2} ms, best {:.2} ms",
            total as f64 / frames as f64 / 1e6,
            best as f64 / 1e6
        );
    }
}

struct Sphere {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    indices: Vec<[u32; 3]>,
}

/// A unit UV sphere with `segments` × `rings` quads split into triangles, counter-clockwise
/// seen from outside: 64 × 63 gives 8,064 triangles.
fn sphere(segments: u32, rings: u32) -> Sphere {
    let mut s = Sphere { positions: vec![], normals: vec![], uvs: vec![], indices: vec![] };
    for r in 0..=rings {
        let v = r as f32 / rings as f32;
        let theta = v * std::f32::consts::PI;
        for g in 0..=segments {
            let u = g as f32 / segments as f32;
            let phi = u * std::f32::consts::TAU;
            let n = Vec3::new(theta.sin() * phi.sin(), theta.cos(), theta.sin() * phi.cos());
            s.positions.push(n);
            s.normals.push(n);
            s.uvs.push(Vec2::new(u, v));
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for g in 0..segments {
            let (a, b, c, d) = (r * row + g, r * row + g + 1, (r + 1) * row + g + 1, (r + 1) * row + g);
            s.indices.push([a, d, c]);
            s.indices.push([a, c, b]);
        }
    }
    s
}

struct Lambert;

impl Shader for Lambert {
    fn shade(&self, f: &Fragment) -> Vec3 {
        let light = Vec3::new(0.4, 0.6, 0.7).normalize();
        Vec3::new(0.8, 0.6, 0.5) * (0.1 + 0.9 * f.normal.dot(light).max(0.0))
    }
    fn background(&self, _: u32, _: u32) -> Vec3 {
        Vec3::splat(0.2)
    }
}

fn camera() -> Camera {
    Camera::frame_box(Vec3::splat(-1.0), Vec3::splat(1.0), Vec3::Z, Vec3::Y, 30.0, 485, 480, 0.1)
}

fn samples(n: u32) -> SampleCount {
    match n {
        4 => SampleCount::X4,
        8 => SampleCount::X8,
        16 => SampleCount::X16,
        _ => SampleCount::X1,
    }
}

fn bench_render(bencher: Bencher, spp: u32, threads: Option<usize>) {
    let mesh = sphere(64, 63);
    let scene = [Triangles {
        positions: &mesh.positions,
        normals: &mesh.normals,
        uvs: &mesh.uvs,
        indices: &mesh.indices,
        part: 0,
        two_sided: false,
        coverage: &[],
    }];
    let camera = camera();
    let options = RenderOptions { samples_per_pixel: samples(spp), threads, backface_culling: true, shade_per_surface: false };
    bencher.bench(|| render(divan::black_box(&scene), &camera, &Lambert, &options));
}

#[divan::bench(args = [4, 8, 16])]
fn render_one_thread(bencher: Bencher, spp: u32) {
    bench_render(bencher, spp, Some(1));
}

#[divan::bench(args = [4, 8, 16])]
fn render_all_threads(bencher: Bencher, spp: u32) {
    bench_render(bencher, spp, None);
}

#[divan::bench(args = [16])]
fn visibility_one_thread(bencher: Bencher, spp: u32) {
    let mesh = sphere(64, 63);
    let scene = [Triangles { positions: &mesh.positions, normals: &[], uvs: &[], indices: &mesh.indices, part: 0, two_sided: false, coverage: &[] }];
    let camera = camera();
    let options = RenderOptions { samples_per_pixel: samples(spp), threads: Some(1), backface_culling: true, shade_per_surface: false };
    bencher.bench(|| visibility(divan::black_box(&scene), &camera, &options));
}

#[divan::bench]
fn encode_png(bencher: Bencher) {
    let mesh = sphere(64, 63);
    let scene = [Triangles {
        positions: &mesh.positions,
        normals: &mesh.normals,
        uvs: &mesh.uvs,
        indices: &mesh.indices,
        part: 0,
        two_sided: false,
        coverage: &[],
    }];
    let image = render(&scene, &camera(), &Lambert, &RenderOptions::default());
    bencher.bench(|| divan::black_box(&image).encode_png());
}
