//! Script API for sweeps shared out over several processes: `shard(list)` returns the items this
//! task owns (see [`super::shard`]), and the planning run behind `hdrvis sweep-status`, in which
//! the script's own logic runs (parameters, loops, loads, `shard`, every option check) while
//! renders return blank images of the requested size and every save records its path instead
//! of writing ([`super::ScriptHost::plan_only`]). The plan is therefore the script's real list
//! of outputs, found without rendering.

use super::convert::{err, RResult};
use super::shard::Shard;
use super::{run_script_file, ScriptHost, ScriptOptions, MAX_ARRAY_SIZE};
use crate::error::{Error, Result};
use crate::render::session::RenderSession;
use rhai::{Array, Dynamic, Engine};
use std::ops::{Range, RangeInclusive};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// `shard(list)` and `shard(range)`.
pub(crate) fn register(engine: &mut Engine, host: &Arc<ScriptHost>) {
    let h = host.clone();
    engine.register_fn("shard", move |items: Array| -> Array {
        let r = h.shard.range(items.len());
        items[r].to_vec()
    });
    let h = host.clone();
    engine.register_fn("shard", move |items: Range<i64>| -> RResult<Array> {
        owned_numbers(h.shard, items.start, items.end.max(items.start))
    });
    let h = host.clone();
    engine.register_fn(
        "shard",
        move |items: RangeInclusive<i64>| -> RResult<Array> {
            let (start, end) = (*items.start(), *items.end());
            owned_numbers(h.shard, start, end.saturating_add(1).max(start))
        },
    );
}

/// The numbers of `start..end` that `shard` owns, as a script array; a share longer than a
/// script array may be is refused (a range is a loop's worth of work, not 2^63 items).
fn owned_numbers(shard: Shard, start: i64, end: i64) -> RResult<Array> {
    let owned = shard.numbers(start, end);
    let count = owned.end.abs_diff(owned.start);
    if count > MAX_ARRAY_SIZE as u64 {
        return err(
            "shard",
            format!(
                "{start}..{end} gives this task {count} items; a script array holds at most {MAX_ARRAY_SIZE}"
            ),
        );
    }
    Ok(owned.map(Dynamic::from).collect())
}

/// What `hdrvis sweep-status` reports.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SweepStatus {
    /// Every output the sweep writes, in the order the script writes them.
    pub outputs: Vec<PathBuf>,
    /// Those not on disk.
    pub missing: Vec<PathBuf>,
    /// With a task count: each task that has outputs missing, and how many.
    pub tasks_missing: Vec<(u64, usize)>,
    /// With a task count: outputs more than one task writes (work outside `shard`), each
    /// with the tasks that write it.
    pub shared: Vec<(PathBuf, Vec<u64>)>,
}

/// The outputs the script at `script` writes under `opts` (its `out_dir`, `sets`, ...), found by
/// a planning run without rendering, and which of them are missing. With `tasks`, the sweep is
/// planned once per task of an array of that many, so the report says which tasks have outputs
/// missing (the indices to resubmit) and which outputs several tasks write.
pub fn sweep_status(
    script: &Path,
    opts: &ScriptOptions,
    tasks: Option<u64>,
) -> Result<SweepStatus> {
    if tasks == Some(0) {
        return Err(Error::invalid("--array", "expected at least 1 task, got 0"));
    }
    let mut plan = opts.clone();
    plan.plan_only = true;
    plan.resume = false;
    plan.write_outputs = false;
    plan.on_written = None;
    plan.progress = false;
    // One session for every task's plan, so a file the script loads is read once.
    plan.session = Some(opts.session.clone().unwrap_or_else(|| {
        Arc::new(RenderSession::new(
            opts.backend,
            opts.cache_mib.saturating_mul(1 << 20),
        ))
    }));
    let mut status = SweepStatus::default();
    let mut owners: Vec<(PathBuf, Vec<u64>)> = Vec::new();
    for index in 0..tasks.unwrap_or(1) {
        plan.shard = match tasks {
            Some(count) => Shard { index, count },
            None => opts.shard,
        };
        let mut missing_here = 0;
        for path in run_script_file(script, &plan)?.written {
            match owners.iter_mut().find(|(p, _)| *p == path) {
                Some((_, tasks)) => {
                    if !tasks.contains(&index) {
                        tasks.push(index);
                    }
                    continue;
                }
                None => owners.push((path.clone(), vec![index])),
            }
            // A damaged output is as missing as an absent one: `--resume` writes it again.
            if !path.is_file() || super::resume::output_intact(&path).is_err() {
                missing_here += 1;
                status.missing.push(path.clone());
            }
            status.outputs.push(path);
        }
        if tasks.is_some() && missing_here > 0 {
            status.tasks_missing.push((index, missing_here));
        }
    }
    status.shared = owners.into_iter().filter(|(_, t)| t.len() > 1).collect();
    Ok(status)
}

/// Checks a script before it is handed to a batch job: it parses, every `--set` names a
/// parameter it reads, and, when `shared` (a job array shares it out), it calls `shard`
/// (without it, every task would render everything).
pub fn check_sweep_script(script: &Path, sets: &[(String, String)], shared: bool) -> Result<()> {
    let source = std::fs::read_to_string(script).map_err(|e| Error::io(script, e))?;
    let ast = Engine::new_raw().compile(&source).map_err(|e| {
        Error::Script(super::describe_parse_error(
            &script.display().to_string(),
            &source,
            &e,
        ))
    })?;
    super::check_sets_are_read(&ast, sets)?;
    if !shared {
        return Ok(());
    }
    let mut calls_shard = false;
    super::for_each_call(&ast, |call| calls_shard |= call.name == "shard");
    if calls_shard {
        Ok(())
    } else {
        Err(Error::format(
            script,
            "never calls shard(...), so every array task would render the whole sweep; loop over shard(items) to share it out",
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::script::run_script_source;

    const SWEEP: &str = r#"
        let v = generate_mantle(#{ n: 8 });
        let tf = tf_emission_absorption(1.0, 1.0);
        for i in shard([0, 1, 2, 3, 4]) {
            let img = render_volume(v, #{ tf: tf, width: 7, height: 5 });
            if img.width != 7 || img.height != 5 { throw "planned image of the wrong size"; }
            let views = bracket(img, [-1.0, 1.0]);
            save_png(views[1], `p/f${i}.png`, 0.5);
            save_exr(tonemap(exposure(img, 1.0), "aces"), `p/f${i}.exr`);
        }
        let owned = [];
        for i in shard(10..=19) { owned.push(i); }
        if owned != [15, 16, 17, 18, 19] { throw `shard(10..=19) gave ${owned}`; }
        owned.clear();
        for i in shard(0..3) { owned.push(i); }
        if owned != [1, 2] { throw `shard(0..3) gave ${owned}`; }
    "#;

    #[test]
    fn a_planning_run_lists_the_task_outputs_without_rendering_or_writing() {
        let dir = tempfile::tempdir().unwrap();
        let mut opts = ScriptOptions::new(dir.path().join("out"));
        opts.progress = false;
        opts.plan_only = true;
        opts.shard = Shard { index: 1, count: 2 };
        let report = run_script_source(SWEEP, "sweep.rhai", dir.path(), &opts).unwrap();
        let names: Vec<String> = report
            .written
            .iter()
            .map(|p| {
                p.strip_prefix(dir.path().canonicalize().unwrap().join("out"))
                    .unwrap()
                    .display()
                    .to_string()
            })
            .collect();
        // Task 1 of 2 owns items 2, 3 and 4 of five.
        assert_eq!(
            names,
            ["p/f2.png", "p/f2.exr", "p/f3.png", "p/f3.exr", "p/f4.png", "p/f4.exr"]
        );
        assert!(report.written.iter().all(|p| !p.exists()));
        assert!(!dir.path().join("out/p").exists());
        assert!(
            report.passes.iter().all(|p| p.name != "raycast"),
            "{:?}",
            report.passes
        );
    }

    #[test]
    fn a_share_larger_than_a_script_array_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut opts = ScriptOptions::new(dir.path().join("out"));
        opts.progress = false;
        for (source, count) in [
            ("shard(0..9223372036854775807)", "9223372036854775807 items"),
            (
                "shard(-9223372036854775808..=9223372036854775807)",
                "18446744073709551615 items",
            ),
        ] {
            let e = run_script_source(source, "s.rhai", dir.path(), &opts)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(count) && e.contains("holds at most 32768"),
                "{e}"
            );
        }
        opts.shard = Shard { index: 2, count: 3 };
        let r = run_script_source(
            "let s = shard(0..30); if s != [20, 21, 22, 23, 24, 25, 26, 27, 28, 29] { throw s; }",
            "s.rhai",
            dir.path(),
            &opts,
        );
        r.unwrap();
    }

    #[test]
    fn a_sweep_script_without_shard_is_refused_for_a_job_array() {
        let dir = tempfile::tempdir().unwrap();
        let with = dir.path().join("with.rhai");
        let without = dir.path().join("without.rhai");
        std::fs::write(&with, SWEEP).unwrap();
        std::fs::write(
            &without,
            "let n = param(\"n\", 3); for i in 0..n { print(i); }",
        )
        .unwrap();
        check_sweep_script(&with, &[], true).unwrap();
        check_sweep_script(&without, &[], false).unwrap();
        let e = check_sweep_script(&without, &[], true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("never calls shard"), "{e}");
        let e = check_sweep_script(&with, &[("size".into(), "3".into())], true)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--set size:"), "{e}");
    }
}
