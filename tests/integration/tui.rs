//! The real `hdrvis tui` binary driven inside tmux (send-keys, capture-pane): open a scene, save,
//! change exposure, save again, quit; the saved EXR and PNG files exist and differ exactly as an
//! exposure change should, and the terminal is restored (alternate screen left, shell prompt
//! back, line editing and echo on). Also: SIGTERM restores the terminal, a script error shows
//! with line and caret inside the TUI and a corrected file reloads by itself. And real terminals
//! under Xvfb, the picture located in a screenshot: xterm in VT340 mode (sixel), and kitty
//! (Debian's 0.26, direct placement) for the TUI and for `run --preview`.
//!
//! Missing tmux, xterm, kitty or Xvfb skip with a printed reason, unless `HDRVIS_REQUIRE_TUI_TOOLS=1`
//! (CI), which turns a missing tool into a failure.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn have(tool: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {tool} >/dev/null 2>&1")])
        .status()
        .is_ok_and(|s| s.success())
}

/// Whether the tools are there; without them the test is skipped, or fails under CI.
fn tools(list: &[&str]) -> bool {
    let missing: Vec<&str> = list.iter().copied().filter(|t| !have(t)).collect();
    if missing.is_empty() {
        return true;
    }
    crate::common::missing::<()>(
        "HDRVIS_REQUIRE_TUI_TOOLS",
        &format!("{missing:?} not installed (apt-get install tmux xterm kitty xvfb x11-apps)"),
    );
    false
}

/// A tmux server of its own (`-L`), one 80 × 24 window running a plain shell.
struct Tmux {
    socket: String,
}

impl Tmux {
    fn start(name: &str) -> Tmux {
        let socket = format!("hdrvis-test-{}-{name}", std::process::id());
        let t = Tmux { socket };
        let shell = "env -u TMUX PS1='ready$ ' TERM=xterm-256color bash --norc --noprofile";
        t.tmux(&["new-session", "-d", "-x", "80", "-y", "24", shell]);
        t.wait_for("ready$", Duration::from_secs(10));
        t
    }

    fn tmux(&self, args: &[&str]) -> String {
        let out = Command::new("tmux")
            .args(["-L", &self.socket, "-f", "/dev/null"])
            .args(args)
            .output()
            .expect("tmux runs");
        String::from_utf8_lossy(&out.stdout).to_string()
    }

    fn screen(&self) -> String {
        self.tmux(&["capture-pane", "-p"])
    }

    fn keys(&self, keys: &[&str]) {
        let mut args = vec!["send-keys"];
        args.extend_from_slice(keys);
        self.tmux(&args);
    }

    fn line(&self, text: &str) {
        self.tmux(&["send-keys", "-l", text]);
        self.tmux(&["send-keys", "Enter"]);
    }

    fn wait_for(&self, text: &str, timeout: Duration) -> String {
        let t0 = Instant::now();
        loop {
            let s = self.screen();
            if s.contains(text) {
                return s;
            }
            if t0.elapsed() > timeout {
                panic!("waited {timeout:?} for {text:?}; screen:\n{s}");
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    fn alternate_screen(&self) -> bool {
        self.tmux(&["display-message", "-p", "#{alternate_on}"])
            .trim()
            == "1"
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        self.tmux(&["kill-server"]);
    }
}

fn demo_script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/tui_demo.rhai")
}

fn tui_command(script: &Path, out: &Path, extra: &str) -> String {
    format!(
        "{} tui {} --out {} --protocol halfblocks --set n=40 --set size=64 {extra}; echo \"tui\"-exit=$?; stty -a | grep -o -- '-\\?icanon\\|-\\?echo ' | tr '\\n' ' '; echo",
        env!("CARGO_BIN_EXE_hdrvis"),
        script.display(),
        out.display()
    )
}

/// After the TUI ended: normal screen, the exit line, a cooked terminal (`stty` reports
/// `icanon` and `echo`, not `-icanon`/`-echo`), and the prompt back.
fn assert_restored(t: &Tmux, exit: &str) {
    let s = t.wait_for(exit, Duration::from_secs(10));
    assert!(!t.alternate_screen(), "alternate screen still on:\n{s}");
    let t0 = Instant::now();
    let s = loop {
        let s = t.screen();
        // The typed command line holds neither "icanon echo" nor "-icanon"; only stty's output.
        if s.contains("icanon echo") || s.contains("-icanon") || s.contains("-echo ") {
            break s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "no stty output:\n{s}"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(
        s.contains("icanon echo") && !s.contains("-icanon") && !s.contains("-echo "),
        "raw mode left on:\n{s}"
    );
    let t0 = Instant::now();
    while t.screen().matches("ready$").count() < 2 {
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "no prompt:\n{}",
            t.screen()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(
        !t.screen().contains("log10 luminance"),
        "the TUI is still on screen"
    );
}

fn srgb_decode(v: u8) -> f64 {
    hdrvis::model::colormap::srgb_to_linear(v as f64 / 255.0)
}

#[test]
fn open_save_expose_save_quit_in_tmux() {
    if !tools(&["tmux"]) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let t = Tmux::start("save");
    t.line(&tui_command(&demo_script(), &out, ""));
    t.wait_for("image    64×64 full", Duration::from_secs(60));
    assert!(t.alternate_screen());
    t.keys(&["s"]);
    t.wait_for("saved tui_demo_view001.exr", Duration::from_secs(20));
    t.keys(&["+"]);
    t.wait_for("exposure +0.5 EV", Duration::from_secs(5));
    t.keys(&["s"]);
    t.wait_for("saved tui_demo_view002.exr", Duration::from_secs(20));
    t.keys(&["q"]);
    assert_restored(&t, "tui-exit=0");

    let exr =
        |i: u32| hdrvis::io::exr::read_exr(&out.join(format!("tui_demo_view00{i}.exr"))).unwrap();
    let png = |i: u32| {
        image::open(out.join(format!("tui_demo_view00{i}.png")))
            .unwrap()
            .to_rgb8()
    };
    let (e1, e2) = (exr(1), exr(2));
    assert_eq!((e1.width, e1.height), (64, 64));
    let gain = 2f64.sqrt();
    let mut lit = 0;
    for (a, b) in e1.pixels.iter().zip(&e2.pixels) {
        for k in 0..3 {
            if a[k].is_finite() {
                let expect = a[k] as f64 * gain;
                assert!(
                    (b[k] as f64 - expect).abs() <= 1e-6 * expect.abs() + 1e-30,
                    "{} vs {expect}",
                    b[k]
                );
                lit += (a[k] > 0.0) as usize;
            }
        }
        assert_eq!(a[3], b[3], "alpha is not exposed");
    }
    assert!(lit > 100, "the view has content");
    // The PNGs are the 0 EV and +0.5 EV display views: linear values sqrt(2) apart wherever
    // neither clips (within 8-bit quantisation), never darker.
    let (p1, p2) = (png(1), png(2));
    let mut compared = 0;
    for (a, b) in p1.pixels().zip(p2.pixels()) {
        for k in 0..3 {
            assert!(b[k] >= a[k]);
            if a[k] >= 40 && b[k] < 250 {
                let ratio = srgb_decode(b[k]) / srgb_decode(a[k]);
                assert!(
                    (ratio - gain).abs() < 0.06,
                    "{} -> {}: ratio {ratio}",
                    a[k],
                    b[k]
                );
                compared += 1;
            }
        }
    }
    assert!(
        compared > 50,
        "too few unclipped pixels to compare ({compared})"
    );
}

#[test]
fn sigterm_restores_the_terminal() {
    if !tools(&["tmux", "pkill"]) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let t = Tmux::start("sigterm");
    t.line(&tui_command(
        &demo_script(),
        &dir.path().join("out"),
        "--set scene=volume",
    ));
    t.wait_for("log10 luminance", Duration::from_secs(60));
    // The shell's child is the TUI.
    let shell = t.tmux(&["display-message", "-p", "#{pane_pid}"]);
    let status = Command::new("pkill")
        .args(["-TERM", "-P", shell.trim()])
        .status()
        .unwrap();
    assert!(status.success());
    assert_restored(&t, "tui-exit=");
}

#[test]
fn script_errors_show_with_caret_and_a_fixed_file_reloads() {
    if !tools(&["tmux"]) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("scene.rhai");
    let good = std::fs::read_to_string(demo_script()).unwrap();
    std::fs::write(&script, &good).unwrap();
    let t = Tmux::start("error");
    t.line(&tui_command(&script, &dir.path().join("out"), ""));
    t.wait_for("image    64×64 full", Duration::from_secs(60));
    // Break the file: an unknown function on the first line; the TUI reloads on its own.
    std::fs::write(
        &script,
        format!("let broken = no_such_function(1);\n{good}"),
    )
    .unwrap();
    let s = t.wait_for("script error", Duration::from_secs(30));
    assert!(s.contains("scene.rhai:1:14"), "{s}");
    assert!(s.contains("let broken = no_such_function(1);"), "{s}");
    let lines: Vec<&str> = s.lines().collect();
    let src = lines.iter().position(|l| l.contains("let broken")).unwrap();
    let caret = lines[src + 1]
        .find('^')
        .expect("caret under the source line");
    assert_eq!(caret, lines[src].find("let broken").unwrap() + 13);
    assert!(
        s.contains("image    64×64"),
        "the last good image is kept:\n{s}"
    );
    // Fix it: the error goes away.
    std::fs::write(&script, &good).unwrap();
    t.wait_for("full", Duration::from_secs(30));
    let t0 = Instant::now();
    while t.screen().contains("script error") {
        assert!(t0.elapsed() < Duration::from_secs(30), "{}", t.screen());
        std::thread::sleep(Duration::from_millis(200));
    }
    t.keys(&["q"]);
    assert_restored(&t, "tui-exit=0");
}

/// A scene with no `param` at all: the TUI's own keys must still orbit it and change its opacity.
const PLAIN_SCENE: &str = r#"
let mantle = generate_mantle(#{ n: 32, field: "fluctuation", seed: 7 });
let tf = tf_lut(#{ scale: "symlog", linthresh: 1e-3, domain: [-0.3, 0.45], colormap: "spectral",
    emission: [[0.0, -1.0], [1.0, -0.5]], opacity: [[0.0, -1.5], [0.5, -3.0], [1.0, -1.0]] });
let img = render_volume(mantle, #{ tf: tf, camera: camera_orbit(30.0, 20.0), width: 64, height: 64 });
save_exr(img, "scene.exr");
save_png(img, "scene.png");
print("hello from the script");
"#;

#[test]
fn a_script_without_params_is_orbited_and_made_denser_without_rewriting_its_outputs() {
    if !tools(&["tmux"]) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (script, out) = (dir.path().join("plain.rhai"), dir.path().join("out"));
    std::fs::write(&script, PLAIN_SCENE).unwrap();
    let bin = env!("CARGO_BIN_EXE_hdrvis");
    let run = Command::new(bin)
        .args([
            "run",
            script.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let outputs = [out.join("scene.exr"), out.join("scene.png")];
    let mtimes: Vec<_> = outputs
        .iter()
        .map(|p| std::fs::metadata(p).unwrap().modified().unwrap())
        .collect();
    std::thread::sleep(Duration::from_millis(50));

    let t = Tmux::start("plain");
    t.line(&format!(
        "{bin} tui {} --out {} --protocol halfblocks; echo \"tui\"-exit=$?; stty -a | grep -o -- '-\\?icanon\\|-\\?echo ' | tr '\\n' ' '; echo",
        script.display(),
        out.display()
    ));
    t.wait_for("image    64×64 full", Duration::from_secs(60));
    // The script's output is logged when its run ends, which on a loaded machine can be a
    // frame after the picture arrives.
    t.wait_for("print: hello from the script", Duration::from_secs(30));
    let idle = |t: &Tmux, what: &str| {
        let s = t.wait_for(what, Duration::from_secs(30));
        let t0 = Instant::now();
        let mut s = s;
        while s.contains("rendering…") {
            assert!(t0.elapsed() < Duration::from_secs(60), "{s}");
            std::thread::sleep(Duration::from_millis(100));
            s = t.screen();
        }
        s
    };
    t.keys(&["s"]);
    t.wait_for("saved plain_view001.exr", Duration::from_secs(20));
    t.keys(&["l"]);
    let s = idle(&t, "camera   az +15°");
    // The status line reports the re-render and its time.
    let status = s.lines().last().unwrap_or_default().to_string();
    let ms = status
        .split("re-render ")
        .nth(1)
        .and_then(|r| r.split(" ms").next())
        .and_then(|v| v.trim().parse::<f64>().ok());
    assert!(
        ms.is_some_and(|ms| ms > 0.0),
        "no re-render time: {status:?}"
    );
    assert!(!s.contains("has no param"), "{s}");
    t.keys(&["s"]);
    t.wait_for("saved plain_view002.exr", Duration::from_secs(20));
    t.keys(&["a"]);
    idle(&t, "opacity  +0.25 decades");
    t.keys(&["s"]);
    t.wait_for("saved plain_view003.exr", Duration::from_secs(20));
    t.keys(&["q"]);
    assert_restored(&t, "tui-exit=0");

    let view =
        |i: u32| hdrvis::io::exr::read_exr(&out.join(format!("plain_view00{i}.exr"))).unwrap();
    let (v1, v2, v3) = (view(1), view(2), view(3));
    let differing = |a: &hdrvis::model::HdrImage, b: &hdrvis::model::HdrImage| {
        a.pixels
            .iter()
            .zip(&b.pixels)
            .filter(|(p, q)| (0..3).any(|k| (p[k] - q[k]).abs() > 1e-4 * p[k].abs().max(1e-3)))
            .count()
    };
    assert!(
        differing(&v1, &v2) > 200,
        "the orbit changed {} pixels",
        differing(&v1, &v2)
    );
    assert!(
        differing(&v2, &v3) > 200,
        "the opacity changed {} pixels",
        differing(&v2, &v3)
    );
    // More extinction: the picture's total emission changes, and the first view is the script's
    // own render (what `hdrvis run` saved).
    let script_img = hdrvis::io::exr::read_exr(&outputs[0]).unwrap();
    assert_eq!(
        differing(&script_img, &v1),
        0,
        "the first view is the script's render"
    );
    for (p, before) in outputs.iter().zip(&mtimes) {
        let after = std::fs::metadata(p).unwrap().modified().unwrap();
        assert_eq!(after, *before, "{} was written again", p.display());
    }
}

/// A surface script with no `param`: the ν, mode and colour-range keys still work.
const PLAIN_SURFACE: &str = r#"
let grid = load_grid(generate("okada", #{ n: 33 }));
let img = render_surface(grid, #{ property: "uz", nu: 20.0, width: 64, height: 64 });
save_exr(img, "surface.exr");
"#;

#[test]
fn a_surface_script_without_params_takes_the_nu_mode_and_range_keys() {
    if !tools(&["tmux"]) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (script, out) = (dir.path().join("surf.rhai"), dir.path().join("out"));
    std::fs::write(&script, PLAIN_SURFACE).unwrap();
    let bin = env!("CARGO_BIN_EXE_hdrvis");
    let t = Tmux::start("surf");
    t.line(&format!(
        "{bin} tui {} --out {} --protocol halfblocks; echo \"tui\"-exit=$?",
        script.display(),
        out.display()
    ));
    t.wait_for("image    64×64 full", Duration::from_secs(60));
    let settle = |t: &Tmux| {
        let t0 = Instant::now();
        while t.screen().contains("rendering…") {
            assert!(t0.elapsed() < Duration::from_secs(60), "{}", t.screen());
            std::thread::sleep(Duration::from_millis(100));
        }
    };
    let mut saved = 0;
    let mut save = |t: &Tmux| {
        saved += 1;
        t.keys(&["s"]);
        t.wait_for(
            &format!("saved surf_view00{saved}.exr"),
            Duration::from_secs(20),
        );
    };
    save(&t);
    // The panel shows the edit in the frame that marks the render busy: wait for it, then for
    // the render.
    t.keys(&["n"]);
    t.wait_for("×1.25", Duration::from_secs(20));
    settle(&t);
    save(&t);
    t.keys(&["m"]);
    t.wait_for("mode modulated", Duration::from_secs(20));
    settle(&t);
    save(&t);
    t.keys(&[">"]);
    t.wait_for("colour range [", Duration::from_secs(20));
    settle(&t);
    save(&t);
    t.keys(&["l"]);
    t.wait_for("map view has no camera", Duration::from_secs(20));
    t.keys(&["q"]);
    t.wait_for("tui-exit=0", Duration::from_secs(20));

    let view =
        |i: u32| hdrvis::io::exr::read_exr(&out.join(format!("surf_view00{i}.exr"))).unwrap();
    let meta = |i: u32, key: &str| view(i).meta(key).unwrap_or_default().to_string();
    assert_eq!(meta(1, "nu"), "20");
    assert_eq!(meta(2, "nu"), "25", "n multiplies ν by 1.25");
    assert_eq!(
        (meta(2, "mode"), meta(3, "mode")),
        ("cyclic".into(), "modulated".into())
    );
    let range = |i: u32| -> Vec<f64> {
        meta(i, "legend_domain")
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect()
    };
    let (r3, r4) = (range(3), range(4));
    let width = r3[1] - r3[0];
    assert!(width > 0.0, "{r3:?}");
    for k in 0..2 {
        assert!(
            (r4[k] - (r3[k] + 0.25 * width)).abs() < 1e-6 * width,
            "> moves the colour range a quarter of its width: {r3:?} -> {r4:?}"
        );
    }
}

/// Reads an X window dump (`xwd`, ZPixmap, 24/32 bits per pixel) into RGB.
fn read_xwd(b: &[u8]) -> Option<image::RgbImage> {
    let field = |i: usize| -> Option<u32> {
        Some(u32::from_be_bytes(
            b.get(i * 4..i * 4 + 4)?.try_into().ok()?,
        ))
    };
    let (header, format, width, height) = (field(0)?, field(2)?, field(4)?, field(5)?);
    let (byte_order, bpp, stride) = (field(7)?, field(11)?, field(12)? as usize);
    let masks = [field(14)?, field(15)?, field(16)?];
    let ncolors = field(19)? as usize;
    if format != 2 || bpp != 32 {
        return None;
    }
    let data = b.get(header as usize + ncolors * 12..)?;
    let mut img = image::RgbImage::new(width, height);
    for y in 0..height {
        for x in 0..width {
            let o = y as usize * stride + x as usize * 4;
            let raw: [u8; 4] = data.get(o..o + 4)?.try_into().ok()?;
            let p = if byte_order == 0 {
                u32::from_le_bytes(raw)
            } else {
                u32::from_be_bytes(raw)
            };
            let c = masks.map(|m| ((p & m) >> m.trailing_zeros()) as u8);
            img.put_pixel(x, y, image::Rgb(c));
        }
    }
    Some(img)
}

/// Kills a child process on drop.
struct Child(std::process::Child);

/// Stops a child process with SIGTERM on drop (so Xvfb removes its lock file and socket), and
/// kills it when it has not gone within two seconds.
struct Terminated(std::process::Child);

impl Drop for Terminated {
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.0.id().to_string()])
            .status();
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(2) {
            if let Ok(Some(_)) = self.0.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Drop for Child {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Writes the picture the screenshot tests look for: green everywhere, a red square in its
/// top-left quarter (orientation), 96 x 64 (aspect 3:2).
fn target_exr(dir: &Path) -> PathBuf {
    let (w, h) = (96u32, 64u32);
    let pixels = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if x < w / 4 && y < h / 4 {
                [1.0, 0.0, 0.0, 1.0]
            } else {
                [0.0, 1.0, 0.0, 1.0]
            }
        })
        .collect();
    let exr = dir.join("target.exr");
    hdrvis::io::exr::write_exr(&hdrvis::model::HdrImage::from_pixels(w, h, pixels), &exr).unwrap();
    exr
}

/// Starts Xvfb on a display it picks itself (it writes the number to the pipe, so stale lock
/// files or a parallel run never make a test wait on a display that is not there).
fn start_xvfb() -> (Terminated, String) {
    let mut xvfb = Command::new("Xvfb")
        .args([
            "-displayfd",
            "1",
            "-screen",
            "0",
            "800x600x24",
            "-nolisten",
            "tcp",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut number = String::new();
    std::io::BufRead::read_line(
        &mut std::io::BufReader::new(xvfb.stdout.take().unwrap()),
        &mut number,
    )
    .unwrap();
    let display = format!(":{}", number.trim());
    let xvfb = Terminated(xvfb);
    assert!(number.trim().parse::<u32>().is_ok(), "Xvfb did not start");
    (xvfb, display)
}

/// Takes screenshots of `display` until the target picture ([`target_exr`]) shows, then checks
/// it: its 3:2 aspect, the red square in its top-left quarter, red covering about 1/16 of it.
fn assert_target_on_screen(display: &str, dir: &Path, what: &str) {
    let shot = dir.join("shot.png");
    let t0 = Instant::now();
    let (mut found, mut last) = (None, String::new());
    while t0.elapsed() < Duration::from_secs(60) && found.is_none() {
        std::thread::sleep(Duration::from_millis(500));
        let grab = Command::new("xwd")
            .args(["-root", "-silent", "-display", display])
            .output()
            .unwrap();
        let Some(img) = read_xwd(&grab.stdout) else {
            continue;
        };
        img.save(&shot).unwrap();
        if let Some(keep) = std::env::var_os("HDRVIS_KEEP_SCREENSHOT") {
            let _ = std::fs::copy(&shot, keep);
        }
        // The bounding box of saturated green and red pixels.
        let is = |p: &image::Rgb<u8>, c: usize| {
            p[c] > 200 && (0..3).filter(|&k| k != c).all(|k| p[k] < 60)
        };
        let bbox = |c: usize| {
            let mut b: Option<(u32, u32, u32, u32)> = None;
            let mut n = 0u32;
            for (x, y, p) in img.enumerate_pixels() {
                if is(p, c) {
                    n += 1;
                    b = Some(match b {
                        None => (x, y, x, y),
                        Some((x0, y0, x1, y1)) => (x0.min(x), y0.min(y), x1.max(x), y1.max(y)),
                    });
                }
            }
            b.map(|b| (b, n))
        };
        last = format!("green {:?}, red {:?}", bbox(1), bbox(0));
        if let (Some((g, gn)), Some((r, rn))) = (bbox(1), bbox(0)) {
            if gn > 2000 && rn > 100 {
                found = Some((g, r, gn, rn));
            }
        }
    }
    let ((gx0, gy0, gx1, gy1), (rx0, ry0, rx1, ry1), gn, rn) =
        found.unwrap_or_else(|| panic!("{what}: no picture in the screenshot after 60 s: {last}"));
    let (gw, gh) = ((gx1 - gx0 + 1) as f64, (gy1 - gy0 + 1) as f64);
    assert!((gw / gh - 1.5).abs() < 0.1, "{what}: aspect {gw}x{gh}");
    assert!(
        rx0 <= gx0 + 2 && ry0 <= gy0 + 2,
        "{what}: red at ({rx0}, {ry0}), picture at ({gx0}, {gy0})"
    );
    assert!(((rx1 - rx0 + 1) as f64 / gw - 0.25).abs() < 0.05, "{what}");
    assert!(((ry1 - ry0 + 1) as f64 / gh - 0.25).abs() < 0.05, "{what}");
    let red_share = rn as f64 / (gn + rn) as f64;
    assert!(
        (red_share - 1.0 / 16.0).abs() < 0.02,
        "{what}: red share {red_share}"
    );
}

#[test]
fn xterm_vt340_shows_the_sixel_picture() {
    if !tools(&["Xvfb", "xterm", "xwd"]) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exr = target_exr(dir.path());
    let (_xvfb, display) = start_xvfb();
    let shell = format!(
        "{} tui {} --out {}; sleep 30",
        env!("CARGO_BIN_EXE_hdrvis"),
        exr.display(),
        dir.path().join("out").display()
    );
    let _xterm = Child(
        Command::new("xterm")
            .args([
                "-display",
                &display,
                "-ti",
                "vt340",
                "-xrm",
                "XTerm*numColorRegisters: 256",
                "-geometry",
                "80x24+0+0",
                "-e",
                "sh",
                "-c",
                &shell,
            ])
            .env_remove("TMUX")
            .env_remove("TERM_PROGRAM")
            .env_remove("HDRVIS_TUI_PROTOCOL")
            .spawn()
            .unwrap(),
    );
    assert_target_on_screen(&display, dir.path(), "xterm sixel");
}

/// Runs `shell` in a real kitty (Debian's package) under Xvfb, on Mesa's software OpenGL, finds
/// the picture in a screenshot and, with `expect_text`, that text on kitty's screen (read back
/// through kitty's remote control), e.g. the protocol the TUI's status line names.
fn kitty_shows_the_target(shell: &str, dir: &Path, what: &str, expect_text: Option<&str>) {
    kitty_with_font_shows_the_target(shell, dir, what, expect_text, None);
}

/// [`kitty_shows_the_target`] with kitty's font set to `font` (fontconfig's default otherwise).
fn kitty_with_font_shows_the_target(
    shell: &str,
    dir: &Path,
    what: &str,
    expect_text: Option<&str>,
    font: Option<&str>,
) {
    let (_xvfb, display) = start_xvfb();
    let socket = format!("unix:{}", dir.join("kitty.sock").display());
    let font = format!("font_family={}", font.unwrap_or("monospace"));
    let _kitty = Child(
        Command::new("kitty")
            .args([
                "--config",
                "NONE",
                "-o",
                "initial_window_width=800",
                "-o",
                "initial_window_height=600",
                "-o",
                "remember_window_size=no",
                "-o",
                "font_size=10",
                "-o",
                &font,
                "-o",
                "allow_remote_control=yes",
                "--listen-on",
                &socket,
                "sh",
                "-c",
                shell,
            ])
            .env("DISPLAY", &display)
            .env("LIBGL_ALWAYS_SOFTWARE", "1")
            .env_remove("TMUX")
            .env_remove("HDRVIS_TUI_PROTOCOL")
            .env_remove("KITTY_WINDOW_ID")
            .env_remove("TERM_PROGRAM")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    );
    assert_target_on_screen(&display, dir, what);
    if let Some(text) = expect_text {
        let screen = Command::new("kitty")
            .args(["@", "--to", &socket, "get-text"])
            .output()
            .unwrap();
        let screen = String::from_utf8_lossy(&screen.stdout);
        assert!(
            screen.contains(text),
            "{what}: {text:?} not on screen:\n{screen}"
        );
    }
}

#[test]
fn kitty_shows_the_tui_picture() {
    if !tools(&["Xvfb", "kitty", "xwd"]) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exr = target_exr(dir.path());
    let shell = format!(
        "{} tui {} --out {}; sleep 30",
        env!("CARGO_BIN_EXE_hdrvis"),
        exr.display(),
        dir.path().join("out").display()
    );
    // kitty 0.26 has no Unicode placeholders: the picture must be a directly placed image, not
    // half blocks.
    kitty_shows_the_target(
        &shell,
        dir.path(),
        "kitty tui",
        Some("kitty direct placement"),
    );
}

#[test]
fn kitty_shows_the_run_preview_picture() {
    if !tools(&["Xvfb", "kitty", "xwd"]) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    target_exr(dir.path());
    let script = dir.path().join("show.rhai");
    std::fs::write(&script, "preview(load_image(\"target.exr\"));\n").unwrap();
    let shell = format!(
        "{} run {} --out {} --preview; sleep 30",
        env!("CARGO_BIN_EXE_hdrvis"),
        script.display(),
        dir.path().join("out").display()
    );
    kitty_shows_the_target(&shell, dir.path(), "kitty run --preview", None);
}

/// The inline preview asks the terminal for its cell size, so the picture keeps its aspect in
/// fonts whose cells are not 1:2 (Noto Sans Mono's are wider; DejaVu Sans Mono's are close).
#[test]
fn kitty_run_preview_keeps_the_aspect_in_any_font() {
    if !tools(&["Xvfb", "kitty", "xwd", "fc-list"]) {
        return;
    }
    let fonts =
        String::from_utf8_lossy(&Command::new("fc-list").output().unwrap().stdout).to_string();
    for font in ["Noto Sans Mono", "DejaVu Sans Mono"] {
        if !fonts.contains(font) {
            crate::common::missing::<()>(
                "HDRVIS_REQUIRE_TUI_TOOLS",
                &format!("the font {font} is not installed (fonts-noto-mono, fonts-dejavu-core)"),
            );
            continue;
        }
        let dir = tempfile::tempdir().unwrap();
        target_exr(dir.path());
        std::fs::write(
            dir.path().join("show.rhai"),
            "preview(load_image(\"target.exr\"));\n",
        )
        .unwrap();
        let shell = format!(
            "{} run {} --out {} --preview; sleep 30",
            env!("CARGO_BIN_EXE_hdrvis"),
            dir.path().join("show.rhai").display(),
            dir.path().join("out").display()
        );
        let what = format!("kitty run --preview in {font}");
        kitty_with_font_shows_the_target(&shell, dir.path(), &what, None, Some(font));
    }
}

#[test]
fn the_demo_script_reports_params_previews_and_reuses_the_session() {
    use hdrvis::gpu::BackendChoice;
    use hdrvis::render::session::RenderSession;
    use hdrvis::script::{run_script_file, ParamKind, ScriptOptions};
    use std::sync::Arc;
    let dir = tempfile::tempdir().unwrap();
    let session = Arc::new(RenderSession::new(BackendChoice::Auto, 1 << 30));
    let mut opts = ScriptOptions::new(dir.path());
    opts.session = Some(session);
    opts.capture_previews = true;
    opts.progress = false;
    for scene in ["volume", "surface"] {
        opts.sets = vec![
            ("scene".into(), scene.into()),
            ("n".into(), "40".into()),
            ("preview_scale".into(), "0.25".into()),
        ];
        let first = run_script_file(&demo_script(), &opts).unwrap();
        assert_eq!(first.previews.len(), 1, "{scene}: one preview() captured");
        assert!(first.written.is_empty(), "{scene}: preview() wrote nothing");
        assert_eq!(first.previews[0].width, 96, "{scene}: 384 x 0.25");
        let names: Vec<&str> = first.params.iter().map(|p| p.name.as_str()).collect();
        let camera_or_nu: &[&str] = if scene == "volume" {
            &[
                "azimuth",
                "elevation",
                "zoom",
                "opacity",
                "lens_lo",
                "lens_hi",
            ]
        } else {
            &["nu", "mode"]
        };
        for n in ["scene", "n", "preview_scale", "size"]
            .iter()
            .chain(camera_or_nu)
        {
            assert!(names.contains(n), "{scene}: {n} missing from {names:?}");
        }
        let scale = first
            .params
            .iter()
            .find(|p| p.name == "preview_scale")
            .unwrap();
        assert_eq!(
            (scale.kind, scale.value.as_str()),
            (ParamKind::Float, "0.25")
        );
        // Change what the TUI's keys change: the data stages come from the session's cache.
        let key = if scene == "volume" { "azimuth" } else { "nu" };
        opts.sets.push((key.into(), "50.0".into()));
        let second = run_script_file(&demo_script(), &opts).unwrap();
        let cached: Vec<String> = second
            .passes
            .iter()
            .filter(|p| p.is_cached())
            .map(|p| p.name.clone())
            .collect();
        assert!(
            !cached.is_empty(),
            "{scene}: nothing reused: {:?}",
            second.passes
        );
        assert_ne!(
            first.previews[0].pixels, second.previews[0].pixels,
            "{scene}: {key} changed the picture"
        );
    }
}
