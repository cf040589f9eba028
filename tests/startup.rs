//! Start-up: the kernels are compiled to SPIR-V at build time (`scratchart_glsl::PRECOMPILED`,
//! `engine/build.rs`). A design iteration on this device (renderer, backward, loss, Adam, the
//! scratch projection) compiles no GLSL at run time, and the built SPIR-V is exactly what the
//! run-time compiler makes of the same sources with the same options.
use scratchart_tests::*;
use scratchart_vulkan::ShaderCompiler;
use std::path::Path;

#[test]
fn a_design_iteration_compiles_no_glsl_and_prebuilt_spirv_matches() {
    let ctx = gpu();
    let views = vec![orbit_view("a", 32, 45.0, 0.0, 45.0, 180.0, 20.0)];
    let scene = random_scene(3, 50, 20.0, 0.2, 0.15, 0.1, views);
    let targets = scratchart::bench::bench_targets(&ctx, &scene, None).unwrap();
    let before = ShaderCompiler::runtime_compiles();
    let row = scratchart::bench::run_iterations(&ctx, "startup", &scene, targets, 0, 2).unwrap();
    assert_eq!(row.iters, 2);
    let after = ShaderCompiler::runtime_compiles();
    assert_eq!(
        after - before,
        0,
        "a design iteration compiled {} kernel(s) at run time: add their variants to scratchart_glsl::PRECOMPILED",
        after - before
    );

    // Built-in SPIR-V against the run-time compiler on the same sources.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders");
    let from_dir = ShaderCompiler::from_dir(&root).unwrap();
    let built = ShaderCompiler::embedded().unwrap();
    for (file, defines) in [
        ("forward.comp", vec![("SA_INTEGRATOR_CLOSED_FORM", "1")]),
        ("bin.comp", vec![("COUNT", "1")]),
    ] {
        let a = built.compile(file, &defines).unwrap();
        let b = from_dir.compile(file, &defines).unwrap();
        assert!(!a.is_empty());
        assert!(
            a == b,
            "{file} {defines:?}: the built SPIR-V differs from a run-time compilation"
        );
    }
    assert!(
        ShaderCompiler::runtime_compiles() >= after + 2,
        "compiling from a directory must not use the built copy"
    );
    assert_no_validation(&ctx);
}

/// The persistent pipeline cache: written when a context that built pipelines is dropped, with a
/// header for this device; read back by the next context; a damaged file is ignored and replaced.
#[test]
fn the_pipeline_cache_persists_and_survives_a_damaged_file() {
    use scratchart_vulkan::{Context, ContextDesc, PipelineCacheDir};
    let dir = std::env::temp_dir().join(format!("scratchart-pipeline-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let make = || {
        Context::new(ContextDesc {
            validation: true,
            quiet: true,
            pipeline_cache: PipelineCacheDir::Dir(dir.clone()),
            ..Default::default()
        })
        .unwrap()
    };
    let file;
    {
        let ctx = make();
        file = ctx.pipeline_cache_file().expect("a cache file in the given directory");
        assert!(file.starts_with(&dir));
        assert!(!file.exists(), "nothing is written before the context is dropped");
        let _r = scratchart_render::Renderer::new(&ctx).unwrap();
        assert_no_validation(&ctx);
    }
    let first = std::fs::read(&file).expect("the cache is written when the context is dropped");
    assert!(
        first.len() >= 32,
        "a Vulkan pipeline cache starts with a 32-byte header"
    );
    let u = |i: usize| u32::from_le_bytes(first[i..i + 4].try_into().unwrap());
    assert_eq!(u(4), 1, "header version one");
    {
        let ctx = make();
        let _r = scratchart_render::Renderer::new(&ctx).unwrap();
        assert_no_validation(&ctx);
    }
    // A damaged file: garbage, then a truncated header. Neither stops a context.
    for junk in [vec![0xAB; 100], first[..20].to_vec()] {
        std::fs::write(&file, &junk).unwrap();
        {
            let ctx = make();
            let _r = scratchart_render::Renderer::new(&ctx).unwrap();
            assert_no_validation(&ctx);
        }
        let again = std::fs::read(&file).unwrap();
        assert!(
            again.len() >= 32 && again[4..8] == first[4..8],
            "the damaged cache was not replaced"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
