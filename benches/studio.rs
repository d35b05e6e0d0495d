//! The live render API: the round trip of `POST /api/v1/render` for a 485×480 still (JSON in,
//! PNG out) against the real studio router on a loopback port, as the editor's preview does it.
//! Run with `cargo bench --bench studio`.

use std::net::SocketAddr;

use facslab::studio::{StudioState, router};

fn main() {
    divan::main();
}

/// A studio on a free loopback port, served by its own runtime thread.
fn start() -> (SocketAddr, tokio::runtime::Runtime) {
    let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build().expect("a runtime");
    let listener = runtime.block_on(tokio::net::TcpListener::bind("127.0.0.1:0")).expect("a port");
    let addr = listener.local_addr().expect("an address");
    runtime.spawn(async move { axum::serve(listener, router(StudioState::default())).await });
    (addr, runtime)
}

#[divan::bench(sample_count = 60, args = ["1+2+5B+6+12+25", "L12C+R14"])]
fn render_round_trip_485x480(bencher: divan::Bencher, expression: &str) {
    let (addr, runtime) = start();
    let client = reqwest::Client::new();
    let url = format!("http://{addr}/api/v1/render");
    let body = serde_json::json!({ "expression": expression, "identity": "wm1", "size": "485x480" });
    let post = || {
        runtime.block_on(async {
            let response = client.post(&url).json(&body).send().await.expect("an answer");
            assert_eq!(response.status(), 200);
            response.bytes().await.expect("a body")
        })
    };
    post(); // the asset and the person's shape are prepared once, outside the measurement
    bencher.bench_local(post);
}
