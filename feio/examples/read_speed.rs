//! Reading speed of `feio::read` on matrix files: bytes, wall time, MB/s and
//! stored entries per file (issue 27: at least 200 MB/s of Matrix Market text
//! on one core). One core: `RAYON_NUM_THREADS=1 taskset -c 0 cargo run
//! --release -p feio --example read_speed -- FILE...`.
use std::time::Instant;

fn main() {
    let files: Vec<String> = std::env::args().skip(1).collect();
    if files.is_empty() {
        eprintln!("usage: read_speed FILE...");
        std::process::exit(2);
    }
    for f in files {
        let path = std::path::Path::new(&f);
        let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        let t0 = Instant::now();
        match feio::read(path, feio::Format::Auto) {
            Ok(t) => {
                let s = t0.elapsed().as_secs_f64();
                println!(
                    "{f}: {bytes} bytes, {} stored entries, {s:.2} s, {:.0} MB/s ({} threads)",
                    t.nnz(),
                    bytes as f64 / s / 1e6,
                    rayon::current_num_threads()
                );
            }
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(2);
            }
        }
    }
}
