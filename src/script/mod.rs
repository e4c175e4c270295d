//! The Rhai scripting layer: one engine constructor that always sets limits and a sandbox, and
//! one module per API area registering functions that return errors instead of panicking.
//! Paths a script reads resolve against its own folder and must stay inside the script folder,
//! the output folder or folders the user allowed; outputs go only under the output folder.

mod api_render;
mod api_surface;
mod convert;
mod sandbox;

use crate::error::{Error, Result};
use crate::gpu::{BackendChoice, GpuContext};
use crate::render::volume::{GpuVolume, VolumeRenderer};
use rhai::{Engine, EvalAltResult, Position};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

pub use sandbox::Sandbox;

/// How a script is run: where it writes, what `param()` returns, what else it may read.
#[derive(Clone, Debug)]
pub struct ScriptOptions {
    pub out_dir: PathBuf,
    /// `--set name=value` pairs, in order.
    pub sets: Vec<(String, String)>,
    pub allowed_paths: Vec<PathBuf>,
    pub backend: BackendChoice,
    /// Operation budget: a runaway loop stops with an error after this many operations.
    pub max_operations: u64,
}

impl ScriptOptions {
    pub fn new(out_dir: impl Into<PathBuf>) -> Self {
        ScriptOptions {
            out_dir: out_dir.into(),
            sets: Vec::new(),
            allowed_paths: Vec::new(),
            backend: BackendChoice::Auto,
            max_operations: 500_000_000,
        }
    }
}

/// What a run produced, for the CLI to report.
#[derive(Debug, Default, Clone)]
pub struct ScriptReport {
    pub written: Vec<PathBuf>,
}

/// State shared by the registered functions of one run.
pub(crate) struct ScriptHost {
    pub sandbox: Sandbox,
    pub sets: HashMap<String, String>,
    pub backend: BackendChoice,
    renderer: OnceLock<Arc<VolumeRenderer>>,
    /// Uploaded volumes keyed by the address of the script's volume; the Arc is kept so the
    /// address cannot be reused while the entry lives.
    uploads: Mutex<Vec<(Arc<crate::model::Volume>, Arc<GpuVolume>)>>,
    pub written: Mutex<Vec<PathBuf>>,
}

impl ScriptHost {
    pub fn renderer(&self) -> Result<Arc<VolumeRenderer>> {
        if let Some(r) = self.renderer.get() {
            return Ok(r.clone());
        }
        let ctx = GpuContext::new(self.backend)?;
        Ok(self
            .renderer
            .get_or_init(|| Arc::new(VolumeRenderer::new(ctx)))
            .clone())
    }

    pub fn upload(&self, volume: &Arc<crate::model::Volume>) -> Result<Arc<GpuVolume>> {
        let renderer = self.renderer()?;
        let mut uploads = self.uploads.lock().expect("upload cache poisoned");
        if let Some((_, g)) = uploads.iter().find(|(v, _)| Arc::ptr_eq(v, volume)) {
            return Ok(g.clone());
        }
        let g = Arc::new(GpuVolume::upload(renderer.context(), volume)?);
        uploads.push((volume.clone(), g.clone()));
        Ok(g)
    }
}

/// Builds the engine every script runs in. Limits are always set: operations, call depth,
/// expression depth, string, array and map sizes; modules cannot be imported from disk.
pub(crate) fn new_engine(host: Arc<ScriptHost>, max_operations: u64) -> Engine {
    let mut engine = Engine::new();
    engine
        .set_max_operations(max_operations)
        .set_max_call_levels(64)
        .set_max_expr_depths(64, 32)
        .set_max_string_size(1 << 20)
        .set_max_array_size(1 << 20)
        .set_max_map_size(1 << 14)
        .set_max_variables(1 << 12)
        .set_max_functions(1 << 10)
        .set_max_modules(0)
        .set_module_resolver(rhai::module_resolvers::DummyModuleResolver::new());
    // `eval` would let a script build code from strings and dodge the checks on its source.
    engine.disable_symbol("eval");
    api_render::register(&mut engine, host.clone());
    api_surface::register(&mut engine, host);
    engine
}

/// Runs a script file.
pub fn run_script_file(path: &Path, opts: &ScriptOptions) -> Result<ScriptReport> {
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
    let sandbox = Sandbox::new(script_dir, &opts.out_dir, &opts.allowed_paths)?;
    let mut sets = HashMap::new();
    for (k, v) in &opts.sets {
        sets.insert(k.clone(), v.clone());
    }
    let host = Arc::new(ScriptHost {
        sandbox,
        sets,
        backend: opts.backend,
        renderer: OnceLock::new(),
        uploads: Mutex::new(Vec::new()),
        written: Mutex::new(Vec::new()),
    });
    let engine = new_engine(host.clone(), opts.max_operations);
    let ast = engine
        .compile(source)
        .map_err(|e| Error::Script(format_error(name, source, &e.to_string(), e.position())))?;
    engine
        .run_ast(&ast)
        .map_err(|e| Error::Script(describe_eval_error(name, source, &e)))?;
    let written = host.written.lock().expect("written list poisoned").clone();
    Ok(ScriptReport { written })
}

fn describe_eval_error(name: &str, source: &str, err: &EvalAltResult) -> String {
    // Errors raised inside registered functions carry the call site as their position.
    let mut msg = err.to_string();
    if let Some(idx) = msg.rfind(" (line ") {
        msg.truncate(idx);
    }
    format_error(name, source, &msg, err.position())
}

/// `file:line:column: message`, then the source line and a caret under the column.
pub fn format_error(name: &str, source: &str, msg: &str, pos: Position) -> String {
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
