//! Random mutations of a valid scene file and scratch CSV (a fixed seed, a bounded count and
//! time): every one gives a clean error or a valid render, never a panic, a hang, a NaN pixel or
//! a validation message.
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::{Duration, Instant};

use scratchart_design::scenes::Rng;
use scratchart_model::scene::Scene;
use scratchart_render::Renderer;
use scratchart_tests::*;

const SCENE: &str = r#"{"plate":{"size_mm":20,"roughness":0.03,"f0":0.9},"views":[{"name":"a","camera":{"eye":[0,-40,40],"target":[0,0,0],"up":[0,0,1],"fov_y_deg":30,"width":12,"height":10},"light":{"kind":"point","position":[0,40,40],"intensity":2000}},{"name":"b","camera":{"eye":[30,0,30],"target":[0,0,0],"up":[0,0,1],"fov_y_deg":35,"width":9,"height":9},"light":{"kind":"directional","direction":[0,1,1],"intensity":3}}],"scratches":"s.csv"}"#;
const CSV: &str = "x0,y0,x1,y1,w,d,alpha\n0,0,5,1,0.1,0.1,0.2\n-3,2,4,-6,0.05,0.02,0.01\n1,1,1.5,1.2,0.2,0.3,0.5\n";

/// Numbers a careless edit might leave (all finite JSON numbers).
const NUMBERS: &[&str] = &[
    "0", "1", "2", "7", "25.5", "100", "0.001", "1e6", "1e-9", "3", "0.99", "45", "4096", "64",
];

/// Tokens a careless edit or a broken tool might leave behind.
const TOKENS: &[&str] = &[
    "",
    "0",
    "-1",
    "1e309",
    "-0",
    "NaN",
    "null",
    "true",
    "\"\"",
    "[]",
    "{}",
    ",",
    ":",
    "\"",
    "{",
    "}",
    "[",
    "]",
    "1e-300",
    "99999999999",
    "4294967296",
    "0.5",
    "\u{feff}",
    "\n",
    "#",
    " ",
    "nan",
    "inf",
];

fn mutate(text: &str, rng: &mut Rng) -> String {
    let mut s: Vec<char> = text.chars().collect();
    let edits = if rng.range(0.0, 1.0) < 0.7 { 1 } else { 2 };
    for _ in 0..edits {
        if s.is_empty() {
            break;
        }
        let at = rng.range(0.0, s.len() as f64) as usize % s.len();
        match rng.range(0.0, 10.0) as u32 {
            0 => {
                s.remove(at);
            }
            1 => {
                let t = TOKENS[rng.range(0.0, TOKENS.len() as f64) as usize % TOKENS.len()];
                for (k, c) in t.chars().enumerate() {
                    s.insert(at + k, c);
                }
            }
            2 => {
                // Replace a number-looking run with a token.
                let mut end = at;
                while end < s.len() && (s[end].is_ascii_digit() || s[end] == '.' || s[end] == '-') {
                    end += 1;
                }
                let t = TOKENS[rng.range(0.0, TOKENS.len() as f64) as usize % TOKENS.len()];
                s.splice(at..end, t.chars());
            }
            3..=7 => {
                // Move to the next number and give it another (finite, maybe absurd) value.
                let mut a = at;
                while a < s.len() && !s[a].is_ascii_digit() {
                    a += 1;
                }
                let mut end = a;
                while end < s.len() && (s[end].is_ascii_digit() || s[end] == '.' || s[end] == 'e') {
                    end += 1;
                }
                let t = NUMBERS[rng.range(0.0, NUMBERS.len() as f64) as usize % NUMBERS.len()];
                s.splice(a..end, t.chars());
            }
            8 => {
                let len = (rng.range(1.0, 12.0) as usize).min(s.len() - at);
                let dup: Vec<char> = s[at..at + len].to_vec();
                for (k, c) in dup.into_iter().enumerate() {
                    s.insert(at + len + k, c);
                }
            }
            _ => {
                s.truncate(at);
            }
        }
    }
    s.into_iter().collect()
}

#[test]
fn mutated_scene_files_give_clean_errors_or_valid_renders() {
    let ctx = gpu();
    let renderer = Renderer::new(&ctx).unwrap();
    let dir = std::env::temp_dir().join(format!("scratchart-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut rng = Rng::new(2026);
    let (mut errors, mut renders) = (0, 0);
    let t0 = Instant::now();
    for case in 0..300 {
        // Mutate the JSON, the CSV, or both.
        let which = case % 3;
        let json = if which != 1 {
            mutate(SCENE, &mut rng)
        } else {
            SCENE.to_string()
        };
        let csv = if which != 0 {
            mutate(CSV, &mut rng)
        } else {
            CSV.to_string()
        };
        std::fs::write(dir.join("scene.json"), &json).unwrap();
        std::fs::write(dir.join("s.csv"), &csv).unwrap();
        let t = Instant::now();
        let loaded = catch_unwind(|| Scene::load_with_warnings(&dir.join("scene.json")))
            .unwrap_or_else(|_| panic!("case {case}: the reader panicked on\n{json}\n{csv}"));
        match loaded {
            Err(e) => {
                let msg = e.to_string();
                assert!(!msg.is_empty() && !msg.contains("panicked"), "case {case}: {msg}");
                errors += 1;
            }
            Ok((scene, _warnings)) => {
                scene.validate().expect("a loaded scene is valid");
                let result = catch_unwind(AssertUnwindSafe(|| {
                    renderer.upload(&scene).and_then(|mut gs| renderer.render(&mut gs))
                }))
                .unwrap_or_else(|_| panic!("case {case}: the renderer panicked on\n{json}\n{csv}"));
                match result {
                    Ok(frame) => {
                        for (v, img) in frame.images.iter().enumerate() {
                            assert!(
                                img.iter().all(|x| x.is_finite() && *x >= 0.0),
                                "case {case} view {v}: a non-finite or negative pixel\n{json}\n{csv}"
                            );
                        }
                        renders += 1;
                    }
                    // A scene over the device's limits (a mutated width, say) is a clean error.
                    Err(e) => {
                        assert!(
                            scratchart::exit::class(&e) == scratchart_exit::Class::Device,
                            "case {case}: {e}"
                        );
                        errors += 1;
                    }
                }
            }
        }
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "case {case} took {:?}",
            t.elapsed()
        );
    }
    eprintln!(
        "300 mutations: {errors} clean errors, {renders} valid renders in {:?}",
        t0.elapsed()
    );
    assert!(errors > 30 && renders > 30, "the mutations should hit both outcomes");
    let _ = std::fs::remove_dir_all(&dir);
    assert_no_validation(&ctx);
}
