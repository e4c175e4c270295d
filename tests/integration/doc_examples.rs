//! Every fenced ```` ```rhai ```` example in README.md and docs/*.md runs: each is written to a
//! folder that holds small stand-ins for the files the examples name (`box.nc`, `mantle.npy`,
//! `okada.nc`, `sst.nc`, …, made with the crate's own writers) and run by `hdrvis run`, with the small sizes
//! `every_script_runs_and_writes_valid_images` uses for the parameters a block reads. An example
//! that no longer parses (a reserved word as a map key), names an unknown option or function, or
//! fails at run time fails this test. A block fenced ```` ```rhai,no_run ```` is not run; the docs
//! have none today, and any one must say in its text why it cannot run on its own. The scripts in
//! `scripts/` are run by `scripts.rs`.

use hdrvis::datasets::netcdf::write_grid;
use hdrvis::datasets::npy::{write_npy_f32, write_npz};
use std::path::Path;
use std::process::Command;

/// One fenced Rhai block of a Markdown file.
struct Example {
    /// `file:line` of the opening fence.
    place: String,
    source: String,
    run: bool,
}

/// The fenced blocks whose info string starts with `rhai` (`rhai` or `rhai,no_run`).
fn rhai_blocks(file: &Path) -> Vec<Example> {
    let text = std::fs::read_to_string(file).unwrap();
    let mut blocks = Vec::new();
    let mut lines = text.lines().enumerate();
    while let Some((number, line)) = lines.next() {
        let Some(info) = line.trim_start().strip_prefix("```") else {
            continue;
        };
        let body: Vec<&str> = lines
            .by_ref()
            .map(|(_, l)| l)
            .take_while(|l| !l.trim_start().starts_with("```"))
            .collect();
        let mut words = info.split(',').map(str::trim);
        if words.next() == Some("rhai") {
            blocks.push(Example {
                place: format!("{}:{}", file.display(), number + 1),
                source: body.join("\n"),
                run: !words.any(|w| w == "no_run"),
            });
        }
    }
    blocks
}

/// `file:line` of indented (unfenced) code blocks that open with a Rhai `let`: examples this
/// test would not see.
fn indented_rhai(file: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(file).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let mut in_fence = false;
    let mut places = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
        } else if !in_fence
            && line.starts_with("    let ")
            && (i == 0 || lines[i - 1].trim().is_empty())
        {
            places.push(format!("{}:{}", file.display(), i + 1));
        }
    }
    places
}

/// Small stand-ins for every data file the examples read.
fn write_data_files(dir: &Path) {
    // box.nc: T = 1 + x and S = 100 + y on a 6 x 5 x 4 box (x, y, z).
    let (nx, ny, nz) = (6u32, 5u32, 4u32);
    let x: Vec<f64> = (0..nx).map(f64::from).collect();
    let y: Vec<f64> = (0..ny).map(f64::from).collect();
    let z: Vec<f64> = (0..nz).map(f64::from).collect();
    let cells = (0..nz).flat_map(|k| (0..ny).flat_map(move |j| (0..nx).map(move |i| (i, j, k))));
    let t: Vec<f32> = cells.clone().map(|(i, _, _)| 1.0 + i as f32).collect();
    let s: Vec<f32> = cells.map(|(_, j, _)| 100.0 + j as f32).collect();
    write_grid(
        dir.join("box.nc"),
        &[("z", &z, "m"), ("y", &y, "m"), ("x", &x, "m")],
        &[("T", &t, "K", "temperature"), ("S", &s, "1", "salinity")],
        &[],
    )
    .unwrap();

    // Surfaces: a smooth displacement field with a few fringes, on a 16 x 12 grid.
    let (nx, ny) = (16u32, 12u32);
    let lon: Vec<f64> = (0..nx).map(|i| 140.0 + 0.1 * f64::from(i)).collect();
    let lat: Vec<f64> = (0..ny).map(|j| 35.0 + 0.1 * f64::from(j)).collect();
    let nodes = || (0..ny).flat_map(move |j| (0..nx).map(move |i| (f64::from(i), f64::from(j))));
    let bump = |(i, j): (f64, f64), scale: f64| {
        scale * (-((i - 8.0).powi(2) + (j - 6.0).powi(2)) / 20.0).exp()
    };
    let ux: Vec<f64> = nodes().map(|p| bump(p, 0.3) * (p.0 - 8.0)).collect();
    let uy: Vec<f64> = nodes().map(|p| bump(p, 0.3) * (p.1 - 6.0)).collect();
    let uz: Vec<f64> = nodes().map(|p| bump(p, 2.0) - 0.5).collect();
    write_grid(
        dir.join("tsunami.nc"),
        &[
            ("lat", &lat, "degrees_north"),
            ("lon", &lon, "degrees_east"),
        ],
        &[("max_abs_eta", &uz, "m", "maximum wave height")],
        &[],
    )
    .unwrap();
    write_grid(
        dir.join("okada.nc"),
        &[("y", &lat, "km"), ("x", &lon, "km")],
        &[
            ("ux", &ux, "m", "east displacement"),
            ("uy", &uy, "m", "north displacement"),
            ("uz", &uz, "m", "up displacement"),
        ],
        &[],
    )
    .unwrap();
    // sst.nc: twelve monthly steps of a temperature in K, for the arithmetic example.
    let months: Vec<f64> = (0..12).map(|m| 30.0 * f64::from(m)).collect();
    let mut sst = Vec::new();
    for m in 0..12 {
        sst.extend(nodes().map(|(i, j)| 280.0 + i + j + 3.0 * (i + f64::from(m)).sin()));
    }
    write_grid(
        dir.join("sst.nc"),
        &[
            ("time", &months, "days since 2000-01-01"),
            ("lat", &lat, "degrees_north"),
            ("lon", &lon, "degrees_east"),
        ],
        &[("sst", &sst, "K", "sea surface temperature")],
        &[],
    )
    .unwrap();
    let elevation: Vec<f64> = nodes().map(|(i, _)| 100.0 * i).collect();
    let shape = [ny as usize, nx as usize];
    write_npz(
        &dir.join("field.npz"),
        &[("uz", &shape, &uz), ("elevation", &shape, &elevation)],
        false,
    )
    .unwrap();

    // mantle.npy: a positive field over six decades, 12³ voxels.
    let n = 12usize;
    let mantle: Vec<f32> = (0..n * n * n)
        .map(|v| 10f32.powf(-3.0 + 6.0 * v as f32 / (n * n * n) as f32))
        .collect();
    write_npy_f32(&dir.join("mantle.npy"), &[n, n, n], &mantle).unwrap();

    // render.exr: an HDR ramp over four decades.
    let (w, h) = (24u32, 16u32);
    let pixels = (0..w * h)
        .map(|p| {
            let v = 10f32.powf(-2.0 + 4.0 * (p % w) as f32 / w as f32);
            [v, 0.5 * v, 0.25 * v, 1.0]
        })
        .collect();
    let img = hdrvis::model::HdrImage::from_pixels(w, h, pixels);
    hdrvis::io::exr::write_exr(&img, &dir.join("render.exr")).unwrap();
}

#[test]
fn every_rhai_example_in_the_docs_runs() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut pages = vec![root.join("README.md")];
    let mut docs: Vec<_> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    pages.extend(docs);
    let examples: Vec<Example> = pages.iter().flat_map(|p| rhai_blocks(p)).collect();
    let unfenced: Vec<String> = pages.iter().flat_map(|p| indented_rhai(p)).collect();
    assert!(
        unfenced.is_empty(),
        "fence these examples with ```rhai so they are run: {unfenced:?}"
    );
    // README's tour, variables, sweeps, movies, tone mapping and surfaces at the time of writing.
    assert!(
        examples.len() >= 6,
        "too few ```rhai blocks found: {:?}",
        examples.iter().map(|e| &e.place).collect::<Vec<_>>()
    );

    let work = tempfile::tempdir().unwrap();
    let dir = work.path();
    write_data_files(dir);
    let mut failures = Vec::new();
    for (i, example) in examples.iter().filter(|e| e.run).enumerate() {
        // MP4 and WebM need ffmpeg, which CI requires; elsewhere its absence skips the example.
        let needs_ffmpeg = [".mp4\"", ".webm\""]
            .iter()
            .any(|ext| example.source.contains(ext));
        if needs_ffmpeg && !crate::scripts::ffmpeg_tools() {
            continue;
        }
        let script = dir.join(format!("example{i}.rhai"));
        std::fs::write(&script, &example.source).unwrap();
        let sets = crate::scripts::sets_read_by(
            &example.source,
            &[("n", "40"), ("size", "40"), ("frames", "3")],
        );
        let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
            .arg("run")
            .arg(&script)
            .arg("--out")
            .arg(dir.join(format!("out{i}")))
            .args(&sets)
            .env("HDRVIS_CACHE", dir.join("cache"))
            .current_dir(dir)
            .output()
            .unwrap();
        let wrote = String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| l.starts_with("wrote "))
            .count();
        if !out.status.success() {
            failures.push(format!(
                "{}: {}",
                example.place,
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        } else if example.source.contains("save_") && wrote == 0 {
            failures.push(format!("{}: saves nothing", example.place));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn fences_are_read_and_an_example_with_a_reserved_word_fails() {
    // The extraction finds blocks by their fence, and a reserved word as a map key fails to run:
    // the failure the docs had before `variable:` replaced `var:`.
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("page.md");
    std::fs::write(
        &page,
        "text\n\n```rhai\nlet v = load_volume(\"box.nc\", #{ var: \"T\" });\n```\n\n\
         ```rhai,no_run\nlet x = 1;\n```\n\n```sh\nls\n```\n",
    )
    .unwrap();
    let blocks = rhai_blocks(&page);
    assert_eq!(blocks.len(), 2);
    assert_eq!(
        (blocks[0].run, blocks[0].place.ends_with("page.md:3")),
        (true, true)
    );
    assert!(!blocks[1].run);
    std::fs::write(
        &page,
        "text\n\n    let x = 1;\n\n```\n\n    let y = 2;\n```\n",
    )
    .unwrap();
    assert_eq!(indented_rhai(&page), [format!("{}:3", page.display())]);
    write_data_files(dir.path());
    let script = dir.path().join("bad.rhai");
    std::fs::write(&script, &blocks[0].source).unwrap();
    let (code, _, stderr) = crate::cli::hdrvis(&["run", "bad.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("variable"), "{stderr}");
}
