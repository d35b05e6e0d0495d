//! Large labelled sets: a 10,000-still set (250 two-AU combinations × 5 intensities × the eight
//! evaluation people, 485×480) built once on all cores, then as 4 shards one after the other
//! (each on all cores) and merged. Prints stills per second per core for both, and the merge
//! time. Each build is measured twice: by the wall clock (stills per second per core: meaningful
//! on an otherwise idle machine) and by the CPU time the process spent (stills per CPU second:
//! the same figure whatever else runs, since it counts only this process's cores). Run with
//! `cargo bench --bench large_set`; `FACSLAB_LARGE_SET_STILLS=N` (a multiple of 40) sets a
//! smaller or larger set.

use std::path::Path;
use std::time::Instant;

use facslab::stimuli::{self, BuildOptions, DitherKey, Dithering, SetSpec, Shard};

/// AUs combined in pairs (upper with lower face and within each), in catalog order.
const AUS: [&str; 24] = ["1", "2", "4", "5", "6", "7", "9", "10", "11", "12", "13", "14", "15", "16", "17", "18", "20", "22", "23", "24", "25", "26", "27", "28"];

fn spec_text(stills: usize) -> String {
    let combinations = stills / 40;
    let pairs: Vec<String> = AUS
        .iter()
        .enumerate()
        .flat_map(|(i, a)| AUS[i + 1..].iter().map(move |b| format!("\"{a}+{b}\"")))
        .take(combinations)
        .collect();
    assert_eq!(pairs.len(), combinations, "at most {} stills", 40 * AUS.len() * (AUS.len() - 1) / 2);
    format!(
        "name = \"large\"\nseed = 2026\n\n[[group]]\nname = \"pairs\"\nexpressions = [{}]\nstills = [0.15, 0.3, 0.55, 0.85, 1.0]\nidentity = \"each\"\n",
        pairs.join(", ")
    )
}

/// Wall and CPU seconds of one step.
#[derive(Clone, Copy, Default)]
struct Spent {
    wall: f64,
    cpu: f64,
}

impl std::ops::AddAssign for Spent {
    fn add_assign(&mut self, other: Spent) {
        self.wall += other.wall;
        self.cpu += other.cpu;
    }
}

/// User plus system CPU seconds of this process so far (all its threads).
fn cpu_seconds() -> f64 {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: getrusage writes a whole `rusage` into the pointer it is given and reads nothing.
    let usage = unsafe {
        assert_eq!(libc::getrusage(libc::RUSAGE_SELF, usage.as_mut_ptr()), 0, "getrusage");
        usage.assume_init()
    };
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 / 1e6;
    seconds(usage.ru_utime) + seconds(usage.ru_stime)
}

fn timed<T>(what: &str, f: impl FnOnce() -> T) -> (T, Spent) {
    let (started, cpu) = (Instant::now(), cpu_seconds());
    let value = f();
    let spent = Spent { wall: started.elapsed().as_secs_f64(), cpu: cpu_seconds() - cpu };
    eprintln!("{what}: {:.1} s wall, {:.1} s CPU", spent.wall, spent.cpu);
    (value, spent)
}

fn main() {
    divan::main();
}

/// One sample: the whole comparison takes minutes.
#[divan::bench(sample_count = 1, sample_size = 1)]
fn ten_thousand_stills_one_build_vs_four_shards() {
    let stills: usize = std::env::var("FACSLAB_LARGE_SET_STILLS").ok().and_then(|v| v.parse().ok()).unwrap_or(10_000);
    let spec = SetSpec::from_toml(&spec_text(stills)).expect("a valid spec");
    assert_eq!(spec.entries.len(), stills);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let dir = tempfile::tempdir().expect("a temporary directory");
    let key = DitherKey::generate().expect("a dither key");
    let options = BuildOptions { jobs: None, progress: false, dither: Dithering::Key(key) };
    let root = dir.path();
    let (_, whole) = timed("one build", || stimuli::build(&spec, &root.join("whole"), &options).expect("builds"));
    let mut sharded = Spent::default();
    let parts: Vec<_> = (1..=4).map(|k| root.join(format!("part{k}"))).collect();
    for (k, part) in (1..=4).zip(&parts) {
        let shard = Shard::new(k, 4).expect("a valid shard");
        sharded += timed(&format!("shard {shard}"), || stimuli::build_shard(&spec, shard, part, &options).expect("builds")).1;
    }
    let (_, merge) = timed("merge", || stimuli::merge(&parts, &root.join("merged")).expect("merges"));
    let same = std::fs::read(root.join("whole/manifest.csv")).ok() == std::fs::read(root.join("merged/manifest.csv")).ok();
    let line = |what: &str, s: Spent| {
        let (per_core, per_cpu) = (stills as f64 / s.wall / cores as f64, stills as f64 / s.cpu);
        println!("{what:<18} {:7.1} s wall {per_core:6.2} stills/s/core  {:7.1} s CPU {per_cpu:6.2} stills/CPU-s", s.wall, s.cpu);
    };
    println!("{stills} stills at 485x480 on {cores} cores");
    line("one build:", whole);
    line("4 shards (serial):", sharded);
    println!("merge:             {:7.1} s  (manifest equal to the one build: {same})", merge.wall);
    assert!(same && dir_size(&root.join("merged")) == dir_size(&root.join("whole")));
}

fn dir_size(path: &Path) -> u64 {
    std::fs::read_dir(path)
        .map(|entries| {
            entries
                .flatten()
                .map(|e| if e.path().is_dir() { dir_size(&e.path()) } else { e.metadata().map_or(0, |m| m.len()) })
                .sum()
        })
        .unwrap_or(0)
}
