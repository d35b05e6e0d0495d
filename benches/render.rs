//! Still rendering: one 485×480 frame (pose + shadow map + raster + shade), on one thread and on
//! all threads, and the stages on their own. Run with `cargo bench --bench render`.

use facslab::engine::identity::{Identity, IdentityTable};
use facslab::engine::{self, FrameSettings};
use facslab::facs::{Catalog, Expression};

fn main() {
    // As the `facslab` binary does at its start.
    engine::keep_freed_memory();
    divan::main();
}

const EXPRESSION: &str = "1+2+5B+6+12+25";

fn setup() -> (Expression, &'static Identity) {
    let expression = Catalog::built_in().parse(EXPRESSION).expect("valid expression");
    let identity = IdentityTable::built_in().get("wm1").expect("known identity");
    // Warm the caches (asset parsing, identity shape) outside the measurement.
    engine::render_still(&expression, identity, FrameSettings::default()).expect("renders");
    (expression, identity)
}

#[divan::bench(args = [Some(1), None])]
fn still_485x480(bencher: divan::Bencher, threads: Option<usize>) {
    let (expression, identity) = setup();
    let settings = FrameSettings { threads, ..FrameSettings::default() };
    bencher.bench(|| engine::render_still(divan::black_box(&expression), identity, settings).expect("renders"));
}

#[divan::bench]
fn pose_only(bencher: divan::Bencher) {
    let (expression, identity) = setup();
    bencher.bench(|| engine::pose_expression(divan::black_box(&expression), identity).expect("poses"));
}

#[divan::bench]
fn png_encode_485x480(bencher: divan::Bencher) {
    let (expression, identity) = setup();
    let image = engine::render_still(&expression, identity, FrameSettings::default()).expect("renders");
    bencher.bench(|| divan::black_box(&image).encode_png());
}
