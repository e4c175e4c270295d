//! The dataset cache on the file systems clusters have: entries truncated, changed and deleted
//! between runs, a cache folder and a home that cannot be written (a second user, a read-only
//! mount), a cache file system that fills up, several runs at once, damaged outputs under
//! `--resume` and an output folder that fills up. Every run must exit 0 with outputs identical
//! to a clean run's, and say what it did about the cache. The tests that mount file systems or
//! switch user need root, as CI has; elsewhere they say so and return.

use crate::common::missing;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A script that generates a mantle of `n`³ through the cache and renders it.
fn script(n: usize) -> String {
    format!(
        r#"let v = load_volume(generate("mantle", #{{ n: {n} }}));
let img = render_volume(v, #{{ tf: tf_emission_absorption(1.0, 1.0), width: 24, height: 16 }});
save_exr(img, "m.exr");
"#
    )
}

/// A copy of the binary in `dir` that the user `nobody` may run: the checkout (and so the
/// built binary) may lie in a folder only its owner may enter, as /root is.
fn binary_for_nobody(dir: &Path) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let copy = dir.join("hdrvis-for-nobody");
    if !copy.is_file() {
        std::fs::copy(env!("CARGO_BIN_EXE_hdrvis"), &copy).unwrap();
        std::fs::set_permissions(&copy, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    copy
}

/// `setpriv` running the binary as the user `nobody`.
fn as_nobody(dir: &Path) -> Command {
    let mut c = Command::new("setpriv");
    c.args(["--reuid=65534", "--regid=65534", "--clear-groups", "--"])
        .arg(binary_for_nobody(dir));
    c
}

/// `hdrvis run s.rhai --out OUT` in `dir` with `env`, optionally as the user `nobody`.
fn run_in(dir: &Path, out: &str, env: &[(&str, &Path)], nobody: bool) -> Output {
    let mut cmd = if nobody {
        as_nobody(dir)
    } else {
        Command::new(env!("CARGO_BIN_EXE_hdrvis"))
    };
    cmd.args(["run", "s.rhai", "--out", out]).current_dir(dir);
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("run hdrvis")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter(|l| !l.contains("XDG_RUNTIME_DIR"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Asserts the run exited 0 and wrote `dir/out/m.exr` with the bytes of `want`.
fn assert_same_output(out: &Output, dir: &Path, name: &str, want: &[u8]) {
    assert!(out.status.success(), "{name}: {}", stderr(out));
    let got = std::fs::read(dir.join(name).join("m.exr")).unwrap();
    assert!(got == want, "{name}: the output differs from a clean run's");
}

/// The mantle entries (data files, not their check files) in `cache`.
fn entries(cache: &Path) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(cache)
        .map(|l| l.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    found.retain(|p| {
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        name.starts_with("mantle-") && name.ends_with(".nc")
    });
    found.sort();
    found
}

fn is_root() -> bool {
    rustix::process::geteuid().is_root()
}

/// A tmpfs of `size` mounted at `at` while the guard lives.
struct Mount(PathBuf);

impl Mount {
    fn tmpfs(at: &Path, size: &str) -> Option<Mount> {
        std::fs::create_dir_all(at).unwrap();
        let ok = Command::new("mount")
            .args([
                "-t",
                "tmpfs",
                "-o",
                &format!("size={size},mode=0755"),
                "tmpfs",
            ])
            .arg(at)
            .status()
            .is_ok_and(|s| s.success());
        ok.then(|| Mount(at.to_path_buf()))
    }

    fn remount_read_only(&self) {
        let ok = Command::new("mount")
            .args(["-o", "remount,ro"])
            .arg(&self.0)
            .status()
            .unwrap();
        assert!(ok.success());
    }
}

impl Drop for Mount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// A scratch folder everyone may enter, with the script in it.
fn scratch(n: usize) -> tempfile::TempDir {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::write(dir.path().join("s.rhai"), script(n)).unwrap();
    dir
}

#[test]
fn truncated_changed_and_deleted_entries_are_made_again() {
    let dir = scratch(20);
    let d = dir.path();
    let cache = d.join("cache");
    let env = [("HDRVIS_CACHE", cache.as_path())];
    let clean = run_in(d, "clean", &env, false);
    assert!(clean.status.success(), "{}", stderr(&clean));
    assert!(!stderr(&clean).contains("note:"), "{}", stderr(&clean));
    let want = std::fs::read(d.join("clean/m.exr")).unwrap();
    let entry = entries(&cache).pop().expect("a mantle entry");
    let check = PathBuf::from(format!("{}.check", entry.display()));
    let damages: [(&str, &dyn Fn()); 4] = [
        ("truncated", &|| {
            let f = std::fs::OpenOptions::new()
                .write(true)
                .open(&entry)
                .unwrap();
            f.set_len(f.metadata().unwrap().len() / 3).unwrap();
        }),
        ("changed", &|| {
            let mut bytes = std::fs::read(&entry).unwrap();
            let i = bytes.len() - 100;
            bytes[i] ^= 0x20;
            std::fs::write(&entry, bytes).unwrap();
        }),
        ("check file deleted", &|| {
            std::fs::remove_file(&check).unwrap()
        }),
        ("deleted", &|| std::fs::remove_file(&entry).unwrap()),
    ];
    for (what, damage) in damages {
        damage();
        let out = run_in(d, what, &env, false);
        assert_same_output(&out, d, what, &want);
        let said = stderr(&out);
        if what == "deleted" {
            assert!(!said.contains("note:"), "{what}: {said}");
        } else {
            let line = said
                .lines()
                .find(|l| l.starts_with("note: cache: "))
                .unwrap_or("");
            assert!(
                line.contains(&entry.display().to_string()) && line.contains("set aside as"),
                "{what}: {said}"
            );
        }
        assert_eq!(entries(&cache), std::slice::from_ref(&entry), "{what}");
    }
    let cli = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_hdrvis"))
            .args(args)
            .env("HDRVIS_CACHE", &cache)
            .output()
            .unwrap()
    };
    let du = String::from_utf8_lossy(&cli(&["cache", "du"]).stdout).to_string();
    let failed = du.lines().find(|l| l.starts_with("failed")).unwrap_or("");
    assert!(failed.contains(" 3 files"), "{du}");
    let verify = cli(&["cache", "verify"]);
    let said = String::from_utf8_lossy(&verify.stdout).to_string();
    assert!(
        verify.status.success() && said.contains(" 0 failed"),
        "{said}"
    );
    std::fs::write(&entry, b"not a dataset").unwrap();
    let verify = cli(&["cache", "verify"]);
    let said = String::from_utf8_lossy(&verify.stdout).to_string();
    assert_eq!(verify.status.code(), Some(1), "{said}");
    assert!(
        said.contains(&format!("failed: {}: is 13 bytes long", entry.display()))
            && said.contains(", 1 failed"),
        "{said}"
    );
    assert!(entries(&cache).is_empty(), "verify sets the entry aside");
}

#[test]
fn a_damaged_pipeline_cache_is_set_aside_and_compiled_afresh() {
    let dir = scratch(12);
    let d = dir.path();
    let cache = d.join("cache");
    let env = [("HDRVIS_CACHE", cache.as_path())];
    let clean = run_in(d, "clean", &env, false);
    assert!(clean.status.success(), "{}", stderr(&clean));
    let want = std::fs::read(d.join("clean/m.exr")).unwrap();
    let Some(blob) = std::fs::read_dir(cache.join("pipelines"))
        .ok()
        .and_then(|mut l| l.find_map(|e| e.ok().map(|e| e.path())))
    else {
        eprintln!("skipped: this adapter keeps no pipeline cache (Vulkan only)");
        return;
    };
    let mut bytes = std::fs::read(&blob).unwrap();
    let i = bytes.len() / 2;
    bytes[i] ^= 1;
    std::fs::write(&blob, bytes).unwrap();
    let out = run_in(d, "again", &env, false);
    assert_same_output(&out, d, "again", &want);
    assert!(
        stderr(&out).contains("checksum); set aside as")
            && stderr(&out).contains("pipelines are compiled afresh"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn several_runs_at_once_make_the_entry_once_and_agree() {
    let dir = scratch(40);
    let d = dir.path();
    let cache = d.join("cache");
    let runs: Vec<_> = (0..4)
        .map(|i| {
            Command::new(env!("CARGO_BIN_EXE_hdrvis"))
                .args(["run", "s.rhai", "--out", &format!("o{i}")])
                .env("HDRVIS_CACHE", &cache)
                .current_dir(d)
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    let outs: Vec<Output> = runs
        .into_iter()
        .map(|c| c.wait_with_output().unwrap())
        .collect();
    let want = std::fs::read(d.join("o0/m.exr")).unwrap();
    for (i, out) in outs.iter().enumerate() {
        assert_same_output(out, d, &format!("o{i}"), &want);
        assert!(!stderr(out).contains("note:"), "{}", stderr(out));
    }
    let mut names: Vec<String> = std::fs::read_dir(&cache)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with("mantle") || n.contains("partial"))
        .collect();
    names.sort();
    assert_eq!(names.len(), 2, "one entry and its check file: {names:?}");
}

#[test]
fn a_cache_nobody_can_write_is_used_when_good_and_bypassed_when_not() {
    if !is_root() {
        return missing(
            "HDRVIS_REQUIRE_ROOT",
            "switching to the user nobody needs root",
        )
        .unwrap_or(());
    }
    use std::os::unix::fs::PermissionsExt;
    let dir = scratch(18);
    let d = dir.path();
    let cache = d.join("cache");
    std::fs::create_dir_all(&cache).unwrap();
    for out in ["empty", "good", "home"] {
        let o = d.join(out);
        std::fs::create_dir_all(&o).unwrap();
        std::fs::set_permissions(&o, std::fs::Permissions::from_mode(0o777)).unwrap();
    }
    let env = [("HDRVIS_CACHE", cache.as_path())];
    // Root's clean run makes no entry: the reference comes from a private cache.
    let reference = d.join("reference-cache");
    let clean = run_in(d, "clean", &[("HDRVIS_CACHE", reference.as_path())], false);
    assert!(clean.status.success(), "{}", stderr(&clean));
    let want = std::fs::read(d.join("clean/m.exr")).unwrap();

    // An empty cache owned by root: the entry is made privately for the run, and removed after.
    let out = run_in(d, "empty", &env, true);
    assert_same_output(&out, d, "empty", &want);
    let said = stderr(&out);
    assert!(
        said.contains(&format!(
            "note: cache: {} cannot be written (Permission denied",
            cache.display()
        )) && said.contains("for this run"),
        "{said}"
    );
    assert!(entries(&cache).is_empty());
    let left: Vec<_> = std::fs::read_dir(std::env::temp_dir())
        .unwrap()
        .flatten()
        .filter(|e| {
            use std::os::unix::fs::MetadataExt;
            e.file_name().to_string_lossy().starts_with("hdrvis-run-")
                && e.metadata().is_ok_and(|m| m.uid() == 65534)
        })
        .collect();
    assert!(left.is_empty(), "the private folder outlived the run");
    // `hdrvis gen` hands the user the file: it stays, and the note says so.
    let gen = as_nobody(d)
        .args(["gen", "mantle", "--n", "9"])
        .env("HDRVIS_CACHE", &cache)
        .current_dir(d)
        .output()
        .unwrap();
    assert!(gen.status.success(), "{}", stderr(&gen));
    let made = PathBuf::from(String::from_utf8_lossy(&gen.stdout).trim());
    assert!(made.is_file(), "{made:?}");
    assert!(
        stderr(&gen).contains("stays where it is when hdrvis ends"),
        "{}",
        stderr(&gen)
    );
    std::fs::remove_dir_all(made.parent().unwrap()).unwrap();

    // The same cache once root made the entry: used as it is, without a word.
    let made = run_in(d, "root", &env, false);
    assert!(made.status.success(), "{}", stderr(&made));
    let out = run_in(d, "good", &env, true);
    assert_same_output(&out, d, "good", &want);
    assert!(!stderr(&out).contains("note:"), "{}", stderr(&out));

    // No HDRVIS_CACHE and a home nobody may write in, outside any checkout.
    let home = d.join("home-of-root");
    std::fs::create_dir_all(&home).unwrap();
    let out = {
        let mut cmd = as_nobody(d);
        cmd.args(["run", "s.rhai", "--out", "home"])
            .current_dir(d)
            .env_remove("HDRVIS_CACHE")
            .env_remove("XDG_CACHE_HOME")
            .env("HOME", &home);
        cmd.output().unwrap()
    };
    assert_same_output(&out, d, "home", &want);
    let said = stderr(&out);
    assert!(
        said.contains(&format!(
            "note: cache: {} cannot be written",
            home.join(".cache/hdrvis").display()
        )),
        "{said}"
    );
}

#[test]
fn a_read_only_or_full_cache_file_system_never_stops_a_run() {
    if !is_root() {
        return missing("HDRVIS_REQUIRE_ROOT", "mounting file systems needs root").unwrap_or(());
    }
    let dir = scratch(24);
    let d = dir.path();
    let reference = d.join("reference-cache");
    let clean = run_in(d, "clean", &[("HDRVIS_CACHE", reference.as_path())], false);
    assert!(clean.status.success(), "{}", stderr(&clean));
    let want = std::fs::read(d.join("clean/m.exr")).unwrap();

    // 24³ floats (54 KiB and more as NetCDF) do not fit in 32 KiB: no space left mid-write.
    let small = d.join("small");
    let Some(_small) = Mount::tmpfs(&small, "32k") else {
        return missing(
            "HDRVIS_REQUIRE_ROOT",
            "this machine refuses to mount a tmpfs",
        )
        .unwrap_or(());
    };
    let out = run_in(d, "full", &[("HDRVIS_CACHE", small.as_path())], false);
    assert_same_output(&out, d, "full", &want);
    assert!(
        stderr(&out).contains("cannot be written (No space left on device"),
        "{}",
        stderr(&out)
    );
    let mut left: Vec<String> = Vec::new();
    for e in std::fs::read_dir(&small).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        if name == "pipelines" {
            // Compiled pipelines, if they fitted, and never a temporary file beside them.
            for p in std::fs::read_dir(e.path()).unwrap().flatten() {
                let name = p.file_name().to_string_lossy().to_string();
                if !name.ends_with(".bin") || name.starts_with('.') {
                    left.push(name);
                }
            }
        } else if !name.ends_with(".lock") {
            left.push(name);
        }
    }
    assert!(
        left.is_empty(),
        "a full cache keeps no partial file: {left:?}"
    );

    // A cache made read-only after a good run: its entry is used; a new entry goes elsewhere.
    let ro = d.join("ro");
    let mount = Mount::tmpfs(&ro, "8m").unwrap();
    let made = run_in(d, "made", &[("HDRVIS_CACHE", ro.as_path())], false);
    assert!(made.status.success(), "{}", stderr(&made));
    mount.remount_read_only();
    let out = run_in(d, "on-ro", &[("HDRVIS_CACHE", ro.as_path())], false);
    assert_same_output(&out, d, "on-ro", &want);
    assert!(!stderr(&out).contains("note:"), "{}", stderr(&out));
    std::fs::write(d.join("s.rhai"), script(25)).unwrap();
    let out = run_in(d, "on-ro-new", &[("HDRVIS_CACHE", ro.as_path())], false);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("cannot be written (Read-only file system"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn resume_writes_again_an_output_that_does_not_read_back() {
    let dir = scratch(12);
    let d = dir.path();
    std::fs::write(
        d.join("s.rhai"),
        format!("{}save_png(img, \"m.png\");\n", script(12)),
    )
    .unwrap();
    let cache = d.join("cache");
    let env = [("HDRVIS_CACHE", cache.as_path())];
    let first = run_in(d, "o", &env, false);
    assert!(first.status.success(), "{}", stderr(&first));
    let (png, exr) = (d.join("o/m.png"), d.join("o/m.exr"));
    let want = std::fs::read(&png).unwrap();
    let exr_time = std::fs::metadata(&exr).unwrap().modified().unwrap();
    std::fs::write(&png, &want[..want.len() - 20]).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args(["run", "s.rhai", "--out", "o", "--resume"])
        .env("HDRVIS_CACHE", &cache)
        .current_dir(d)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(std::fs::read(&png).unwrap(), want, "m.png written again");
    assert_eq!(
        std::fs::metadata(&exr).unwrap().modified().unwrap(),
        exr_time
    );
    assert!(
        stderr(&out).contains(&format!(
            "note: --resume: {} does not end with PNG's IEND chunk (cut short); it is written again",
            png.display()
        )),
        "{}",
        stderr(&out)
    );
}

#[test]
fn an_output_that_does_not_fit_leaves_nothing_and_says_which() {
    if !is_root() {
        return missing("HDRVIS_REQUIRE_ROOT", "mounting file systems needs root").unwrap_or(());
    }
    let dir = scratch(12);
    let d = dir.path();
    // 512² pixels of four 32-bit channels, uncompressed: 4 MiB into 64 KiB.
    std::fs::write(
        d.join("s.rhai"),
        r#"let v = load_volume(generate("mantle", #{ n: 12 }));
let img = render_volume(v, #{ tf: tf_emission_absorption(1.0, 1.0), width: 512, height: 512 });
save_exr(img, "big.exr", #{ compression: "none" });
"#,
    )
    .unwrap();
    let out_dir = d.join("out");
    let Some(_mount) = Mount::tmpfs(&out_dir, "64k") else {
        return missing(
            "HDRVIS_REQUIRE_ROOT",
            "this machine refuses to mount a tmpfs",
        )
        .unwrap_or(());
    };
    let out = run_in(
        d,
        "out",
        &[("HDRVIS_CACHE", d.join("cache").as_path())],
        false,
    );
    assert_eq!(out.status.code(), Some(1));
    let said = stderr(&out);
    let error = said
        .lines()
        .find(|l| l.starts_with("error: "))
        .unwrap_or("");
    assert!(
        error.contains(&out_dir.join("big.exr").display().to_string())
            && error.contains("No space left on device"),
        "{said}"
    );
    let left: Vec<_> = std::fs::read_dir(&out_dir).unwrap().flatten().collect();
    assert!(left.is_empty(), "a failed write leaves no file: {left:?}");
}
