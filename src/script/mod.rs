//! The Rhai scripting layer: one engine constructor that always sets limits and a sandbox, and
//! one module per API area registering functions that return errors instead of panicking.
//! Paths a script reads resolve against its own folder and must stay inside the script folder,
//! the output folder or folders the user allowed; outputs go only under the output folder.

mod api_arithmetic;
mod api_bricks;
mod api_datasets;
pub(crate) mod api_doc;
mod api_fields;
mod api_grids;
mod api_output;
mod api_post;
mod api_render;
mod api_sections;
mod api_surface;
mod api_sweep;
mod convert;
mod lines;
mod options;
mod resume;
mod sandbox;
mod shard;
mod slurm_job;

use crate::error::{Error, Result};
use crate::gpu::BackendChoice;
use crate::model::mesh::MeshField;
use crate::model::Grid;
use crate::model::HdrImage;
use crate::render::passes::PassRecord;
use crate::render::session::RenderSession;
use crate::render::surface::SurfaceOptions;
use crate::render::{VolumeRenderOptions, VolumeSource};
use rhai::{Dynamic, Engine, EvalAltResult, Position};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub use api_sweep::{check_sweep_script, sweep_status, SweepStatus};
pub(crate) use sandbox::Sandbox;
pub use shard::Shard;
pub use slurm_job::SlurmJob;

/// How a script is run: where it writes, what `param()` returns, what else it may read.
#[derive(Clone, Debug)]
pub struct ScriptOptions {
    pub out_dir: PathBuf,
    /// `--set name=value` pairs, in order.
    pub sets: Vec<(String, String)>,
    pub allowed_paths: Vec<PathBuf>,
    pub backend: BackendChoice,
    /// Operation budget of a run without a [`timeout`](Self::timeout): a runaway loop stops with
    /// an error after this many operations (seconds of a tight loop: see docs/scripting.md).
    pub max_operations: u64,
    /// `--resume`: outputs that already exist are not written again, and `already_done(path)`
    /// tells the script so it can skip the work.
    pub resume: bool,
    /// Show progress bars on stderr (`progress(i, n)`); off for tests and pipes.
    pub progress: bool,
    /// The session whose result cache and renderers the run uses; a new one when `None`. The TUI
    /// and sweeps pass the same session to every run, so unchanged stages are not recomputed.
    pub session: Option<Arc<RenderSession>>,
    /// Result-cache budget of a new session, MiB.
    pub cache_mib: u64,
    /// Keep the images passed to `preview(image)` in [`ScriptReport::previews`] instead of
    /// printing them to the terminal (`hdrvis tui` shows them itself, `run --preview` at the end).
    pub capture_previews: bool,
    /// Default `memory_budget` of every render, in MiB of GPU memory (`--gpu-memory`).
    pub gpu_memory_mib: Option<f64>,
    /// Wall-clock limit of the run (`--timeout`): past it the script stops with an error at its
    /// next operation, and the clock replaces the operation budget. `None` (the default of
    /// `hdrvis run`) runs without one; interactive front ends re-run scripts with
    /// [`INTERACTIVE_TIMEOUT`].
    pub timeout: Option<Duration>,
    /// Carry out `save_exr`/`save_png`; off in `hdrvis tui`, whose re-runs must not overwrite
    /// the script's outputs (its `s` key saves the view instead).
    pub write_outputs: bool,
    /// Keep what `print` and `debug` say in [`ScriptReport::printed`] instead of writing it to
    /// stdout (where it would land on the TUI's screen).
    pub capture_prints: bool,
    /// Told of every output the moment it is complete on disk (`hdrvis run` prints "wrote ...",
    /// so an interrupted run has already reported what it wrote).
    pub on_written: Option<WrittenObserver>,
    /// The share of the sweep this run owns: what `shard(list)` returns (`--shard`, Slurm).
    pub shard: Shard,
    /// A planning run (`hdrvis sweep-status`): renders return blank images and saves record
    /// their path in [`ScriptReport::written`] without writing; see `api_sweep`.
    pub plan_only: bool,
}

/// A callback for each file a run writes; see [`ScriptOptions::on_written`].
#[derive(Clone)]
pub struct WrittenObserver(pub Arc<dyn Fn(&Path) + Send + Sync>);

impl std::fmt::Debug for WrittenObserver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("WrittenObserver")
    }
}

/// The wall-clock limit interactive front ends (the TUI) give each re-run of a script, so a
/// parameter change can never hang the session.
pub(crate) const INTERACTIVE_TIMEOUT: Duration = Duration::from_secs(60);

/// Largest number of array elements a script may hold in one value, nested arrays counted.
/// Rhai re-measures a container after every call that may change it (`push`, `+=`, ...), so
/// growing one in a loop costs time quadratic in its size: 2^15 elements keep the worst case
/// under a second, where 2^20 took minutes, and are far more than scripts need (control points,
/// frame lists).
pub(crate) const MAX_ARRAY_SIZE: usize = 1 << 15;
/// Largest number of map entries in one value, nested maps counted (same quadratic re-measure).
pub(crate) const MAX_MAP_SIZE: usize = 1 << 14;
/// Longest string a script may build, in bytes.
pub(crate) const MAX_STRING_SIZE: usize = 1 << 20;

impl ScriptOptions {
    pub fn new(out_dir: impl Into<PathBuf>) -> Self {
        ScriptOptions {
            out_dir: out_dir.into(),
            sets: Vec::new(),
            allowed_paths: Vec::new(),
            backend: BackendChoice::Auto,
            max_operations: 100_000_000,
            resume: false,
            progress: true,
            session: None,
            cache_mib: crate::render::cache::DEFAULT_BUDGET_MIB,
            capture_previews: false,
            gpu_memory_mib: None,
            timeout: None,
            write_outputs: true,
            capture_prints: false,
            on_written: None,
            shard: Shard::ALL,
            plan_only: false,
        }
    }
}

/// The type of a script parameter, taken from the default given to `param(name, default)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    Int,
    Float,
    Bool,
    Text,
}

/// One `param(name, default)` call of a run: what the script accepts and what it got.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamRecord {
    pub name: String,
    pub kind: ParamKind,
    /// The default as the script wrote it (`to_string` of the value).
    pub default: String,
    /// The value the script received (the default, or the `--set` override).
    pub value: String,
}

/// What a run produced, for the CLI to report.
#[derive(Debug, Default, Clone)]
pub struct ScriptReport {
    pub written: Vec<PathBuf>,
    /// Every pass of the run, in order: what ran (with its time) and what came from the cache.
    pub passes: Vec<PassRecord>,
    /// Every parameter the script asked for, in first-call order.
    pub params: Vec<ParamRecord>,
    /// Images passed to `preview(image)` when [`ScriptOptions::capture_previews`] is on.
    pub previews: Vec<Arc<HdrImage>>,
    /// The last image the script rendered, loaded or saved (what the TUI shows when the script
    /// previews nothing).
    pub last_image: Option<Arc<HdrImage>>,
    /// The last `render_volume` or `render_surface` of the run: what it drew and its options,
    /// so a client (the TUI) can render it again with another camera, transfer function, ν or
    /// mode without re-running the script.
    pub last_render: Option<LastRender>,
    /// What `print`/`debug` said, when [`ScriptOptions::capture_prints`] is on.
    pub printed: Vec<String>,
}

/// A volume render call as the script made it: the source and the resolved options.
#[derive(Clone, Debug)]
pub struct LastVolumeRender {
    pub source: VolumeSource,
    pub options: VolumeRenderOptions,
}

/// A surface render call as the script made it: the grid or mesh and the resolved options.
#[derive(Clone, Debug)]
pub struct LastSurfaceRender {
    pub field: SurfaceField,
    pub options: SurfaceOptions,
}

/// What a surface render drew.
#[derive(Clone, Debug)]
pub enum SurfaceField {
    Grid(Arc<Grid>),
    Mesh(Arc<MeshField>),
}

impl SurfaceField {
    /// Its images under `opts`, through the session's cache.
    pub(crate) fn render(
        &self,
        session: &RenderSession,
        opts: &SurfaceOptions,
    ) -> Result<Arc<Vec<HdrImage>>> {
        match self {
            SurfaceField::Grid(g) => session.surface(g, opts),
            SurfaceField::Mesh(m) => session.mesh_surface(m, opts),
        }
    }
}

/// The last render call of a run, volume or surface.
#[derive(Clone, Debug)]
pub enum LastRender {
    Volume(LastVolumeRender),
    Surface(LastSurfaceRender),
}

/// State shared by the registered functions of one run.
pub(crate) struct ScriptHost {
    pub sandbox: Sandbox,
    pub sets: HashMap<String, String>,
    pub session: Arc<RenderSession>,
    pub written: Mutex<Vec<PathBuf>>,
    pub params: Mutex<Vec<ParamRecord>>,
    pub capture_previews: bool,
    pub previews: Mutex<Vec<Arc<HdrImage>>>,
    pub last_image: Mutex<Option<Arc<HdrImage>>>,
    pub last_render: Mutex<Option<LastRender>>,
    pub printed: Mutex<Vec<String>>,
    /// [`ScriptOptions::write_outputs`].
    pub write_outputs: bool,
    capture_prints: bool,
    pub resume: bool,
    progress_enabled: bool,
    progress: Mutex<crate::io::progress::Progress>,
    /// Default memory budget of renders (MiB), and the bricked path's caches.
    pub gpu_memory_mib: Option<f64>,
    on_written: Option<WrittenObserver>,
    /// [`ScriptOptions::shard`].
    pub shard: Shard,
    /// The run's `--timeout` deadline and limit, set by [`new_engine`]: long native calls
    /// (generators) check it through [`ScriptHost::check_deadline`].
    pub deadline: std::sync::OnceLock<(Instant, Duration)>,
    /// A planning run (`hdrvis sweep-status`): every function checks its arguments as in a real
    /// run, then renders return blank images of the requested size, image operations return
    /// their input, and saves record their path instead of writing.
    pub plan_only: bool,
}

impl ScriptHost {
    /// Remembers the run's latest render call, for [`ScriptReport::last_render`].
    pub(crate) fn note_render(&self, render: LastRender) {
        *self.last_render.lock().expect("last render poisoned") = Some(render);
    }

    /// Remembers the image most recently produced, for [`ScriptReport::last_image`].
    pub(crate) fn note_image(&self, img: &Arc<HdrImage>) {
        *self.last_image.lock().expect("last image poisoned") = Some(img.clone());
    }

    /// Records a `param()` call (the first call of a name keeps its list position).
    pub(crate) fn note_param(&self, record: ParamRecord) {
        let mut params = self.params.lock().expect("params poisoned");
        match params.iter_mut().find(|p| p.name == record.name) {
            Some(p) => *p = record,
            None => params.push(record),
        }
    }

    /// Whether an output may be skipped: `--resume` is on and the file is already there and
    /// reads back whole ([`resume::output_intact`]); one that does not is written again.
    pub(crate) fn already_done(&self, path: &Path) -> bool {
        if !self.resume || !path.is_file() {
            return false;
        }
        match resume::output_intact(path) {
            Ok(()) => true,
            Err(why) => {
                crate::io::notice(&format!(
                    "--resume: {} {why}; it is written again",
                    path.display()
                ));
                false
            }
        }
    }

    /// Reports loop progress on stderr with an ETA from the rate measured so far.
    pub(crate) fn progress(&self, done: u64, total: u64, label: &str) {
        if self.progress_enabled {
            let mut state = self.progress.lock().expect("progress poisoned");
            state.report(done, total, label);
        }
    }

    /// In a planning run, records the output `path` would be and returns true: the caller then
    /// skips the writing.
    pub(crate) fn planned(&self, path: &Path) -> bool {
        if self.plan_only {
            self.written
                .lock()
                .expect("written poisoned")
                .push(path.to_path_buf());
        }
        self.plan_only
    }

    /// An error once the run's `--timeout` deadline has passed (a generator calls this between
    /// its steps, so a long one stops within a step of the limit).
    pub(crate) fn check_deadline(&self) -> Result<()> {
        match self.deadline.get() {
            Some((deadline, limit)) if Instant::now() >= *deadline => Err(Error::invalid(
                "--timeout",
                format!(
                    "stopped at the time limit of {:?} s (--timeout) while generating",
                    limit.as_secs_f64()
                ),
            )),
            _ => Ok(()),
        }
    }

    /// Writes the output `path` with `write` and records it the moment it has its final name
    /// (see [`crate::io::recording_output`]: a run stopped by a signal lists exactly the
    /// outputs on disk).
    pub(crate) fn write_output(
        self: &Arc<Self>,
        path: &Path,
        write: impl FnOnce(&Path) -> Result<()>,
    ) -> Result<()> {
        let host = self.clone();
        let record = Box::new(move |p: &Path| host.note_written(p.to_path_buf()));
        crate::io::recording_output(path, record, || write(path))
    }

    /// Records a finished output and tells the observer.
    fn note_written(&self, path: PathBuf) {
        if let Some(observer) = &self.on_written {
            (observer.0)(&path);
        }
        self.written.lock().expect("written poisoned").push(path);
    }
}

/// Builds the engine every script runs in. Limits are always set: operations, call depth,
/// expression depth, string, array and map sizes, and with `timeout` the wall-clock time from
/// now instead of the operation count; modules cannot be imported from disk.
pub(crate) fn new_engine(
    host: Arc<ScriptHost>,
    max_operations: u64,
    timeout: Option<Duration>,
) -> Engine {
    let mut engine = Engine::new();
    engine.set_max_operations(max_operations);
    // A limit past what the clock can represent (centuries) is a deadline 136 years away.
    let deadline = timeout.and_then(|limit| {
        let now = Instant::now();
        let at = now
            .checked_add(limit)
            .or_else(|| now.checked_add(Duration::from_secs(1 << 32)))?;
        Some((at, limit))
    });
    if let Some((deadline, limit)) = deadline {
        let _ = host.deadline.set((deadline, limit));
        engine.set_max_operations(0);
        // Rhai calls this before every operation; the clock is read every 1024th, which keeps
        // the cost out of tight loops and still stops within microseconds of the deadline.
        engine.on_progress(move |operations| {
            (operations % 1024 == 0 && Instant::now() >= deadline)
                .then(|| Dynamic::from(limit.as_secs_f64()))
        });
    }
    register_sleep(&mut engine, host.clone());
    bound_maps_grown_by_index(&mut engine);
    engine
        .set_max_call_levels(64)
        .set_max_expr_depths(64, 32)
        .set_max_string_size(MAX_STRING_SIZE)
        .set_max_array_size(MAX_ARRAY_SIZE)
        .set_max_map_size(MAX_MAP_SIZE)
        .set_max_variables(1 << 12)
        .set_max_functions(1 << 10)
        .set_max_modules(0)
        .set_module_resolver(rhai::module_resolvers::DummyModuleResolver::new());
    // `eval` would let a script build code from strings and dodge the checks on its source.
    engine.disable_symbol("eval");
    if host.capture_prints {
        let h = host.clone();
        engine.on_print(move |text| {
            h.printed
                .lock()
                .expect("printed poisoned")
                .push(text.into())
        });
        let h = host.clone();
        engine.on_debug(move |text, _, _| {
            h.printed
                .lock()
                .expect("printed poisoned")
                .push(text.into())
        });
    }
    api_render::register(&mut engine, host.clone());
    api_output::register_output(&mut engine, &host);
    api_output::register_params(&mut engine, host.clone());
    api_bricks::register(&mut engine, host.clone());
    api_post::register(&mut engine, host.clone());
    api_datasets::register(&mut engine, host.clone());
    api_fields::register(&mut engine);
    api_grids::register(&mut engine);
    api_arithmetic::register(&mut engine);
    api_surface::register(&mut engine, host.clone());
    api_sections::register(&mut engine, host.clone());
    api_sweep::register(&mut engine, &host);
    engine
}

/// Rhai checks the size of what an index assignment stores but not of the map it grows
/// (`m[key] = v` with a new key), so a loop could grow a map without bound. Each access of a
/// variable holding a map checks its length here instead.
fn bound_maps_grown_by_index(engine: &mut Engine) {
    // Every 61st access is checked (a prime, so that a loop body's accesses all take turns),
    // which keeps the hook's cost out of tight loops; a growing map is caught within a loop
    // round or two of passing the limit.
    let accesses = std::sync::atomic::AtomicU32::new(0);
    #[allow(deprecated)] // Volatile, not deprecated (Rhai's words): the one hook on every access.
    engine.on_var(move |name, _, ctx| {
        if !accesses
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed)
            .is_multiple_of(61)
        {
            return Ok(None);
        }
        let too_large = ctx
            .scope()
            .get(name)
            .and_then(|v| v.read_lock::<rhai::Map>().map(|m| m.len() > MAX_MAP_SIZE))
            .unwrap_or(false);
        if too_large {
            return Err(Box::new(rhai::EvalAltResult::ErrorDataTooLarge(
                "Size of object map".into(),
                rhai::Position::NONE,
            )));
        }
        Ok(None)
    });
}

/// Most seconds a run without `--timeout` may sleep in all: like its operation budget, a bound
/// that ends a `loop { sleep(...) }` nobody asked to wait for.
pub(crate) const MAX_SLEEP_WITHOUT_TIMEOUT_S: f64 = 1.0;

/// `sleep(seconds)` in place of Rhai's own, which blocks past any limit: with `--timeout` a sleep
/// ends at the deadline with the timeout's error; without, the run's sleeps add up to at most
/// [`MAX_SLEEP_WITHOUT_TIMEOUT_S`].
fn register_sleep(engine: &mut Engine, host: Arc<ScriptHost>) {
    let slept = Arc::new(Mutex::new(0.0_f64));
    let sleep = move |seconds: f64| -> convert::RResult<()> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return convert::err("sleep", format!("expected seconds >= 0, got {seconds}"));
        }
        match host.deadline.get().copied() {
            Some((deadline, limit)) => {
                let left = deadline.saturating_duration_since(Instant::now());
                let wanted = Duration::from_secs_f64(seconds.min(1e9));
                std::thread::sleep(wanted.min(left));
                if wanted >= left {
                    return Err(Box::new(rhai::EvalAltResult::ErrorTerminated(
                        Dynamic::from(limit.as_secs_f64()),
                        rhai::Position::NONE,
                    )));
                }
            }
            None => {
                let mut total = slept.lock().expect("sleep total poisoned");
                if *total + seconds > MAX_SLEEP_WITHOUT_TIMEOUT_S {
                    return convert::err(
                        "sleep",
                        format!(
                            "a run without --timeout sleeps at most {MAX_SLEEP_WITHOUT_TIMEOUT_S} s in all; give --timeout SECONDS to wait longer"
                        ),
                    );
                }
                *total += seconds;
                std::thread::sleep(Duration::from_secs_f64(seconds));
            }
        }
        Ok(())
    };
    let sleep_int = sleep.clone();
    engine.register_fn("sleep", sleep);
    engine.register_fn("sleep", move |seconds: i64| sleep_int(seconds as f64));
}

/// The API reference of the engine scripts run in.
pub fn api_reference() -> String {
    api_doc::reference_markdown()
}

#[cfg(test)]
pub(crate) fn test_host() -> Arc<ScriptHost> {
    let dir = std::env::temp_dir();
    Arc::new(ScriptHost {
        sandbox: Sandbox::new(&dir, &dir.join("hdrvis-test-out"), &[]).unwrap(),
        sets: HashMap::new(),
        session: Arc::new(RenderSession::new(BackendChoice::Auto, 1 << 30)),
        written: Mutex::new(Vec::new()),
        params: Mutex::new(Vec::new()),
        capture_previews: false,
        previews: Mutex::new(Vec::new()),
        last_image: Mutex::new(None),
        last_render: Mutex::new(None),
        printed: Mutex::new(Vec::new()),
        write_outputs: true,
        capture_prints: false,
        resume: false,
        progress_enabled: false,
        progress: Mutex::new(crate::io::progress::Progress::default()),
        gpu_memory_mib: None,
        on_written: None,
        shard: Shard::ALL,
        deadline: std::sync::OnceLock::new(),
        plan_only: false,
    })
}

/// Runs a script file.
pub fn run_script_file(path: &Path, opts: &ScriptOptions) -> Result<ScriptReport> {
    crate::io::check_regular_file(path)?;
    let source = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    run_script_source(&source, &path.display().to_string(), dir, opts)
}

/// Runs script text whose relative paths resolve against `script_dir`.
pub fn run_script_source(
    source: &str,
    name: &str,
    script_dir: &Path,
    opts: &ScriptOptions,
) -> Result<ScriptReport> {
    // Generated datasets live in the cache; scripts read them through `generate`.
    let mut readable = opts.allowed_paths.clone();
    readable.push(crate::datasets::cache::cache_dir());
    // Where datasets are made when the cache folder cannot be written.
    readable.push(crate::datasets::cache::private_dir_path().to_path_buf());
    let sandbox = Sandbox::new(script_dir, &opts.out_dir, &readable)?;
    let mut sets = HashMap::new();
    for (k, v) in &opts.sets {
        sets.insert(k.clone(), v.clone());
    }
    if opts.resume {
        remove_stale_temporaries(&opts.out_dir, opts.shard.count > 1);
    }
    let session = opts.session.clone().unwrap_or_else(|| {
        Arc::new(RenderSession::new(
            opts.backend,
            opts.cache_mib.saturating_mul(1 << 20),
        ))
    });
    // The log holds this run's passes only; what earlier runs left is theirs.
    session.log().take();
    let host = Arc::new(ScriptHost {
        sandbox,
        sets,
        session: session.clone(),
        written: Mutex::new(Vec::new()),
        params: Mutex::new(Vec::new()),
        capture_previews: opts.capture_previews,
        previews: Mutex::new(Vec::new()),
        last_image: Mutex::new(None),
        last_render: Mutex::new(None),
        printed: Mutex::new(Vec::new()),
        write_outputs: opts.write_outputs,
        capture_prints: opts.capture_prints,
        resume: opts.resume,
        progress_enabled: opts.progress,
        progress: Mutex::new(crate::io::progress::Progress::default()),
        gpu_memory_mib: opts.gpu_memory_mib,
        on_written: opts.on_written.clone(),
        shard: opts.shard,
        deadline: std::sync::OnceLock::new(),
        plan_only: opts.plan_only,
    });
    let engine = new_engine(host.clone(), opts.max_operations, opts.timeout);
    let ast = engine
        .compile(source)
        .map_err(|e| Error::Script(describe_parse_error(name, source, &e)))?;
    check_sets_are_read(&ast, &opts.sets)?;
    if !opts.plan_only {
        check_movie_encoders(&ast)?;
    }
    // Files that data files name (an NRRD header's `data file`) obey the sandbox too.
    let scope = crate::datasets::access::ReadScope::enter(host.sandbox.readable());
    engine
        .run_ast(&ast)
        .map_err(|e| Error::Script(describe_eval_error(name, source, &e)))?;
    drop(scope);
    drop(engine);
    fn take<T: Default>(m: &Mutex<T>) -> T {
        std::mem::take(&mut *m.lock().expect("run state poisoned"))
    }
    Ok(ScriptReport {
        written: take(&host.written),
        passes: session.log().take(),
        params: take(&host.params),
        previews: take(&host.previews),
        last_image: take(&host.last_image),
        last_render: take(&host.last_render),
        printed: take(&host.printed),
    })
}

/// The movies the script writes under a literal path (`save_animation(frames, "orbit.mp4")`)
/// checked before anything runs, so a missing ffmpeg is said before the frames are rendered
/// rather than after.
fn check_movie_encoders(ast: &rhai::AST) -> Result<()> {
    let mut paths = Vec::new();
    for_each_call(ast, |call| {
        if call.name == "save_animation" && call.args.len() >= 2 {
            if let rhai::Expr::StringConstant(s, _) = &call.args[1] {
                paths.push(s.to_string());
            }
        }
    });
    for p in paths {
        crate::io::animation::check_encoder(Path::new(&p))?;
    }
    Ok(())
}

/// Calls `visit` with every function call in the script's syntax tree, function bodies
/// included (a call is an expression, or a statement of its own such as a function's last line).
pub(crate) fn for_each_call(ast: &rhai::AST, mut visit: impl FnMut(&rhai::FnCallExpr)) {
    use rhai::{ASTNode, Expr, Stmt};
    ast.walk(&mut |path: &[ASTNode]| {
        match path.last() {
            Some(ASTNode::Expr(Expr::FnCall(call, _))) => visit(call),
            Some(ASTNode::Stmt(Stmt::FnCall(call, _))) => visit(call),
            _ => {}
        }
        true
    });
}

/// The names the script's `param(NAME, default)` calls read, found in its syntax tree (function
/// bodies included), sorted; `None` when some call computes its name, so the set is unknown.
pub(crate) fn script_param_names(ast: &rhai::AST) -> Option<Vec<String>> {
    let mut names = std::collections::BTreeSet::new();
    let mut computed = false;
    for_each_call(ast, |call| {
        if call.name == "param" && call.args.len() == 2 {
            match &call.args[0] {
                rhai::Expr::StringConstant(s, _) => {
                    names.insert(s.to_string());
                }
                _ => computed = true,
            }
        }
    });
    (!computed).then(|| names.into_iter().collect())
}

/// Whether the script at `path` may read `param(name, ...)`: false only when it parses and
/// names all its parameters literally, none of them `name` (front ends use it before setting a
/// parameter of their own, such as the TUI's `preview_scale`).
pub(crate) fn may_read_param(path: &Path, name: &str) -> bool {
    let Ok(source) = std::fs::read_to_string(path) else {
        return true;
    };
    match Engine::new_raw().compile(&source) {
        Ok(ast) => script_param_names(&ast).is_none_or(|names| names.iter().any(|n| n == name)),
        Err(_) => true,
    }
}

/// Refuses a `--set NAME=...` that no `param("NAME", ...)` of the script reads, before anything
/// runs: a misspelt name would otherwise run the whole script with the default.
fn check_sets_are_read(ast: &rhai::AST, sets: &[(String, String)]) -> Result<()> {
    let Some(known) = script_param_names(ast) else {
        return Ok(());
    };
    let Some((unread, _)) = sets.iter().find(|(k, _)| !known.contains(k)) else {
        return Ok(());
    };
    let listed = if known.is_empty() {
        "the script reads no parameters".to_string()
    } else {
        format!("its parameters: {}", known.join(", "))
    };
    let hint = crate::error::closest_name(unread, known.iter().map(String::as_str))
        .map(|c| format!("did you mean {c}? "))
        .unwrap_or_default();
    Err(Error::invalid(
        format!("--set {unread}"),
        format!("no param(\"{unread}\", ...) in the script reads it; {hint}{listed}"),
    ))
}

/// A run killed mid-write leaves its temporary file (`.hdrvis-*.tmp`, see io::write_atomic)
/// behind; the finished outputs are never partial, so resuming only has to sweep these away.
/// When the run is one task of several sharing the folder (`shared`), another task may be
/// writing one right now: only temporaries untouched for [`STALE_TEMPORARY`] go, as a writer
/// keeps its file's modification time fresh.
fn remove_stale_temporaries(dir: &Path, shared: bool) {
    let stale = |p: &Path| {
        !shared
            || std::fs::metadata(p)
                .and_then(|m| m.modified())
                .ok()
                .and_then(|t| t.elapsed().ok())
                .is_some_and(|age| age >= STALE_TEMPORARY)
    };
    let walk = |d: &Path, stack: &mut Vec<PathBuf>| {
        if let Ok(entries) = std::fs::read_dir(d) {
            for e in entries.flatten() {
                let p = e.path();
                let name = e.file_name().to_string_lossy().to_string();
                if p.is_dir() {
                    stack.push(p);
                } else if name.starts_with(".hdrvis-") && name.ends_with(".tmp") && stale(&p) {
                    let _ = std::fs::remove_file(&p);
                }
            }
        }
    };
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        walk(&d, &mut stack);
    }
}

/// How long a temporary output of a shared sweep folder must be left untouched before a
/// resumed task takes it for the remains of a killed one.
const STALE_TEMPORARY: Duration = Duration::from_secs(600);

/// A parse error at `file:line:col`; a reserved word used as a map key (`#{var: ...}`) names the
/// option to write instead.
fn describe_parse_error(name: &str, source: &str, err: &rhai::ParseError) -> String {
    let mut msg = err.to_string();
    if let Some(idx) = msg.rfind(" (line ") {
        msg.truncate(idx);
    }
    if msg.contains("'var' is a reserved keyword") {
        msg.push_str("; to pick a variable of a data file write variable: \"NAME\"");
    }
    format_error(name, source, &msg, err.position())
}

fn describe_eval_error(name: &str, source: &str, err: &EvalAltResult) -> String {
    // Errors raised inside registered functions carry the call site as their position.
    let mut msg = err.to_string();
    match err {
        EvalAltResult::ErrorFunctionNotFound(sig, _) => {
            let fn_name = sig.split(['(', ' ']).next().unwrap_or(sig);
            let known = api_doc::signatures_named(fn_name);
            if !known.is_empty() {
                msg = format!(
                    "wrong arguments in call {sig}; expected {}",
                    known.join(" or ")
                );
            }
        }
        EvalAltResult::ErrorTerminated(limit, _) => {
            msg = format!("stopped at the time limit of {limit} s (--timeout)");
        }
        EvalAltResult::ErrorDataTooLarge(what, _) => {
            msg = format!(
                "{what} over the script limit (arrays {MAX_ARRAY_SIZE} elements, maps {MAX_MAP_SIZE} entries, strings {MAX_STRING_SIZE} bytes, nested ones counted)"
            );
        }
        _ => {}
    }
    if let Some(idx) = msg.rfind(" (line ") {
        msg.truncate(idx);
    }
    format_error(name, source, &msg, err.position())
}

/// `file:line:column: message`, then the source line and a caret under the column.
pub(crate) fn format_error(name: &str, source: &str, msg: &str, pos: Position) -> String {
    match (pos.line(), pos.position()) {
        (Some(line), col) => {
            let col = col.unwrap_or(1);
            let text = source.lines().nth(line - 1).unwrap_or("");
            format!(
                "{name}:{line}:{col}: {msg}\n  {text}\n  {}^",
                " ".repeat(col.saturating_sub(1))
            )
        }
        _ => format!("{name}: {msg}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_registered_function_is_documented_and_vice_versa() {
        let engine = new_engine(test_host(), 1000, None);
        let registered = api_doc::registered(&engine);
        let documented = api_doc::documented();
        let undocumented: Vec<_> = registered.difference(&documented).collect();
        let stale: Vec<_> = documented.difference(&registered).collect();
        assert!(
            undocumented.is_empty(),
            "registered but not in api_doc::API: {undocumented:?}"
        );
        assert!(stale.is_empty(), "documented but not registered: {stale:?}");
    }

    #[test]
    fn docs_api_md_is_current() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/api.md");
        let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            on_disk == api_reference(),
            "docs/api.md is stale: regenerate it with `cargo run -- api > docs/api.md`"
        );
    }

    fn run_for(source: &str, timeout: Option<Duration>) -> (Result<ScriptReport>, f64) {
        let dir = tempfile::tempdir().unwrap();
        let mut opts = ScriptOptions::new(dir.path().join("out"));
        opts.progress = false;
        opts.timeout = timeout;
        let start = Instant::now();
        let result = run_script_source(source, "s.rhai", dir.path(), &opts);
        (result, start.elapsed().as_secs_f64())
    }

    /// `cut: #{ plane }` takes one map or an array of them; a plane without its normal, a zero
    /// normal, four planes and a plane that is not a map are one-line errors naming the field.
    #[test]
    fn cut_planes_are_read_as_a_map_or_an_array() {
        let render = |cut: &str| {
            let source = format!(
                "let v = generate_mantle(#{{ n: 8 }}); let img = render_volume(v, #{{ tf: tf_emission_absorption(1.0, 1.0), width: 8, height: 8, cut: {cut} }}); save_exr(img, \"c.exr\");"
            );
            run_for(&source, None)
                .0
                .map(|_| ())
                .map_err(|e| e.to_string())
        };
        let p = "#{ point: [0.0, 0.0, 0.0], normal: [1.0, 0.0, 1.0] }";
        render(&format!("#{{ plane: {p} }}")).unwrap();
        render(&format!("#{{ plane: [{p}, {p}], z: [-2.0, 0.0] }}")).unwrap();
        for (cut, want) in [
            (
                "#{ plane: #{ point: [0.0, 0.0, 0.0] } }".to_string(),
                "cut plane normal: missing; expected [x, y, z]",
            ),
            (
                "#{ plane: #{ point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, 0.0] } }".to_string(),
                "cut plane: point [0.0, 0.0, 0.0], normal [0.0, 0.0, 0.0]; expected a finite point and a finite non-zero normal",
            ),
            (
                format!("#{{ plane: [{p}, {p}, {p}, {p}] }}"),
                "cut plane: 4 planes; expected at most 3",
            ),
            (
                "#{ plane: 1.0 }".to_string(),
                "cut plane: expected a map #{ point: [x, y, z], normal: [x, y, z] } or an array of them",
            ),
        ] {
            let e = render(&cut).unwrap_err();
            let first = e.lines().next().unwrap_or_default();
            assert!(first.ends_with(want), "{cut}: {e}");
        }
    }

    #[test]
    fn sleeps_end_at_the_timeout_and_are_bounded_without_one() {
        let (r, took) = run_for("sleep(8);", Some(Duration::from_millis(300)));
        let e = r.unwrap_err().to_string();
        assert!(e.contains("time limit of 0.3 s (--timeout)"), "{e}");
        assert!(took < 2.0, "sleep(8) under --timeout 0.3 took {took:.2} s");
        let (r, took) = run_for("loop { sleep(0.5); }", Some(Duration::from_millis(700)));
        assert!(r.unwrap_err().to_string().contains("time limit"));
        assert!(took < 2.0, "{took:.2} s");
        let (r, took) = run_for("loop { sleep(0.25); }", None);
        let e = r.unwrap_err().to_string();
        assert!(e.contains("sleeps at most 1 s in all"), "{e}");
        assert!(took < 2.0, "{took:.2} s");
        let (r, _) = run_for("sleep(0.1); sleep(0);", None);
        r.unwrap();
        let (r, _) = run_for("sleep(-1.0);", None);
        assert!(r.unwrap_err().to_string().contains("expected seconds >= 0"));
    }

    #[test]
    fn a_long_generator_stops_at_the_timeout() {
        // At n = 1500 the tsunami takes tens of seconds; it checks the clock every 1 % of its
        // steps.
        let (r, took) = run_for(
            "generate(\"tsunami\", #{ n: 1500 });",
            Some(Duration::from_millis(1500)),
        );
        let e = r.unwrap_err().to_string();
        assert!(
            e.contains("time limit of 1.5 s (--timeout) while generating"),
            "{e}"
        );
        assert!(
            took < 6.0,
            "the generator ran {took:.1} s past a 1.5 s limit"
        );
    }

    #[test]
    fn an_okada_grid_stops_at_the_timeout() {
        // At n = 4001 the surface grid takes about 25 s on two cores; it checks the clock after
        // each of 32 bands of rows.
        let (r, took) = run_for(
            "generate(\"okada\", #{ n: 4001 });",
            Some(Duration::from_millis(1500)),
        );
        let e = r.unwrap_err().to_string();
        assert!(e.contains("time limit of 1.5 s (--timeout)"), "{e}");
        assert!(took < 6.0, "the grid ran {took:.1} s past a 1.5 s limit");
    }

    #[test]
    fn maps_grown_by_index_stop_at_the_map_limit() {
        let (r, took) = run_for("let m = #{}; for i in 0..100000 { m[`k${i}`] = i; }", None);
        let e = r.unwrap_err().to_string();
        assert!(e.contains("map"), "{e}");
        assert!(took < 10.0, "{took:.2} s");
        let (r, _) = run_for(
            &format!("let m = #{{}}; for i in 0..{MAX_MAP_SIZE} {{ m[`k${{i}}`] = i; }}"),
            None,
        );
        r.unwrap();
    }
}
