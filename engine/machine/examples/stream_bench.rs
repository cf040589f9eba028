//! Streaming throughput over a pseudo-terminal: a long plan to a fake Marlin (and a fake GRBL)
//! that answer at once. Prints lines per second; the bar is 1,000 lines/s ("never the
//! bottleneck"). Not a test: run it with
//! `cargo run --release -p scratchart-machine --example stream_bench [-- CUTS]`.

// The fakes sit behind pseudo-terminals, which only Unix has.
#[cfg(unix)]
mod bench {
    use std::time::{Duration, Instant};

    use scratchart_machine::controller::Rezero;
    use scratchart_machine::fake::{FakeGrbl, FakeMarlin, GrblConfig, MarlinConfig};
    use scratchart_machine::job::{carve, Options};
    use scratchart_machine::plan::Cut;
    use scratchart_machine::stream::Control;
    use scratchart_observe::Silent;
    use scratchart_tool::machine::MachineProfile;

    pub fn main() {
        let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(5000);
        let dir = std::env::temp_dir().join(format!("scratchart_stream_bench_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let cuts: Vec<Cut> = (0..n)
            .map(|k| {
                let t = k as f64 / n as f64;
                Cut {
                    a: [-40.0 + 80.0 * t, -40.0],
                    b: [-40.0 + 80.0 * t, 40.0 - 10.0 * t],
                    z: 0.02,
                    scratch: k,
                    bulge: 0.0,
                }
            })
            .collect();
        for (name, profile) in [("marlin", MachineProfile::marlin()), ("grbl", MachineProfile::grbl())] {
            let plan = dir.join(format!("bench_{name}.nc"));
            std::fs::write(&plan, scratchart_machine::gcode::write(&cuts, &profile, 100.0, &[])).unwrap();
            let fake = match name {
                "marlin" => FakeMarlin::start(MarlinConfig {
                    line_delay: Duration::ZERO,
                    ..MarlinConfig::default()
                }),
                _ => FakeGrbl::start(GrblConfig {
                    line_delay: Duration::ZERO,
                    ..GrblConfig::default()
                }),
            }
            .unwrap();
            let opts = Options {
                plan: plan.clone(),
                port: fake.path().to_string(),
                baud: 115200,
                journal: dir.join(format!("bench_{name}.journal.json")),
                check: false,
                resume: false,
                restart: false,
                rezero: Rezero::Keep,
                profile: None,
                emergency: false,
                detect_timeout: Duration::from_secs(4),
                resume_command: String::new(),
                frame: None,
            };
            let t0 = Instant::now();
            let s = carve(&opts, &Control::default(), &Silent).expect("the benchmark job runs");
            let secs = t0.elapsed().as_secs_f64();
            let r = fake.record();
            assert!(r.overflows.is_empty(), "receive buffer overflow: {:?}", r.overflows);
            println!(
                "{name}: {} lines ({n} scratches) in {secs:.2} s, {:.0} lines/s (streaming {:.2} s: {:.0} lines/s)",
                s.lines,
                s.lines as f64 / secs,
                s.seconds,
                s.lines as f64 / s.seconds
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

fn main() {
    #[cfg(unix)]
    bench::main();
    #[cfg(not(unix))]
    eprintln!("stream_bench streams to fake controllers on pseudo-terminals: run it on Linux or macOS");
}
