//! Which share of a sweep one task owns, when the sweep is shared out over several processes:
//! `hdrvis run --shard I/N`, a Slurm job array (`SLURM_ARRAY_TASK_ID` with `_COUNT` or
//! `_MIN`/`_MAX`/`_STEP`) and `srun` steps (`SLURM_PROCID` of `SLURM_NTASKS`) — unless the
//! step's tasks are the ranks of one MPI world, which render every volume together and so
//! must all own the same share. Task `i` of `n`
//! owns one contiguous block of a list of `len` items, `[⌊i·len/n⌋, ⌊(i+1)·len/n⌋)`: the blocks
//! are disjoint, cover the list, differ in size by at most one, and keep neighbouring items (the
//! frames of one camera path, the levels of one transfer function) in one process, where the
//! render session reuses what they share.

use crate::error::{Error, Result};
use std::ops::Range;

/// Task `index` of `count` (0-based, like `SLURM_ARRAY_TASK_ID` in `--array=0-(N-1)`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Default for Shard {
    fn default() -> Self {
        Shard::ALL
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Where a run's share came from, for its log line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardSource {
    /// No flag and no Slurm task variables: the run owns every item.
    Alone,
    Flag,
    SlurmArray,
    SrunSteps,
    /// A job array whose tasks each run several `srun` tasks: the array's share is shared again.
    SlurmArrayAndSteps,
}

impl std::fmt::Display for ShardSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ShardSource::Alone => "alone",
            ShardSource::Flag => "--shard",
            ShardSource::SlurmArray => "Slurm job array",
            ShardSource::SrunSteps => "srun tasks",
            ShardSource::SlurmArrayAndSteps => "Slurm job array and srun tasks",
        })
    }
}

impl Shard {
    /// A run alone: it owns every item.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// `I/N` as `--shard` takes it: 0 ≤ I < N.
    pub fn parse(text: &str) -> Result<Shard> {
        let bad = |why: &str| {
            Error::invalid(
                "--shard",
                format!(
                    "expected I/N with whole numbers 0 <= I < N (task I of N), got {text:?}{why}"
                ),
            )
        };
        let (i, n) = text.split_once('/').ok_or_else(|| bad(""))?;
        let (Ok(index), Ok(count)) = (i.trim().parse::<u64>(), n.trim().parse::<u64>()) else {
            return Err(bad(""));
        };
        if count == 0 {
            return Err(bad(": N must be at least 1"));
        }
        if index >= count {
            return Err(bad(&format!(": tasks are numbered 0 to {}", count - 1)));
        }
        Ok(Shard { index, count })
    }

    /// The share the Slurm variables give (through `var`, the environment's lookup), or
    /// [`Shard::ALL`] without them. Under an array whose tasks run `srun` steps of several tasks,
    /// each array task's share is shared again among its steps' tasks. Variables that do not
    /// agree are a one-line error naming the variable.
    ///
    /// `mpi_ranks` is the size of the MPI world this process is one rank of (1 outside one).
    /// With more than one, the `srun` step's tasks are those ranks: every `render_volume` is a
    /// collective call they make together, so the step variables share nothing out (each rank
    /// owning a different share would hang the ranks or mix their volumes). The job array
    /// still shares: every rank of one array task owns that task's share.
    pub(crate) fn from_slurm(
        var: impl Fn(&str) -> Option<String>,
        mpi_ranks: usize,
    ) -> Result<(Shard, ShardSource)> {
        let array = array_share(&var)?;
        let steps = if mpi_ranks > 1 {
            None
        } else {
            step_share(&var)?
        };
        Ok(match (array, steps) {
            (None, None) => (Shard::ALL, ShardSource::Alone),
            (Some(a), None) => (a, ShardSource::SlurmArray),
            (None, Some(s)) => (s, ShardSource::SrunSteps),
            (Some(a), Some(s)) => {
                // Each array task's share is shared again: a.count * s.count tasks in all,
                // counted in u128 so that absurd variables are refused instead of wrapping.
                let count = u128::from(a.count) * u128::from(s.count);
                let index = u128::from(a.index) * u128::from(s.count) + u128::from(s.index);
                let count = u64::try_from(count).map_err(|_| {
                    Error::invalid(
                        "SLURM_NTASKS",
                        format!(
                            "{} tasks in each of {} array tasks make more than 2^64 tasks",
                            s.count, a.count
                        ),
                    )
                })?;
                // index < count, which fits.
                let index = index as u64;
                (Shard { index, count }, ShardSource::SlurmArrayAndSteps)
            }
        })
    }

    /// `--shard` when given (it wins over the environment), else the Slurm variables; every
    /// rank of an MPI world of `mpi_ranks` gets the same share ([`Shard::from_slurm`]).
    pub fn resolve(
        flag: Option<&str>,
        var: impl Fn(&str) -> Option<String>,
        mpi_ranks: usize,
    ) -> Result<(Shard, ShardSource)> {
        match flag {
            Some(text) => Ok((Shard::parse(text)?, ShardSource::Flag)),
            None => Shard::from_slurm(var, mpi_ranks),
        }
    }

    /// The items of a list of `len` this task owns: one contiguous block.
    pub fn range(&self, len: usize) -> Range<usize> {
        let block = self.block(0, len as i128);
        // Both edges lie in 0..=len.
        block.start as usize..block.end as usize
    }

    /// The integers of `start..end` (none when `end <= start`) this task owns: one contiguous
    /// block, as [`Shard::range`] gives of a list, for any `i64` bounds (`0..i64::MAX`,
    /// `i64::MIN..i64::MAX`).
    pub fn numbers(&self, start: i64, end: i64) -> Range<i64> {
        let block = self.block(i128::from(start), i128::from(end.max(start)));
        // Both edges lie between start and end.
        block.start as i64..block.end as i64
    }

    /// `[start + ⌊i·len/n⌋, start + ⌊(i+1)·len/n⌋)` of `start..end`: the offsets in u128, as
    /// i and len are below 2^64 and their product below 2^128; the edges in i128.
    fn block(&self, start: i128, end: i128) -> Range<i128> {
        let len = (end - start) as u128;
        let edge = |i: u64| start + (u128::from(i) * len / u128::from(self.count)) as i128;
        edge(self.index)..edge(self.index + 1)
    }
}

/// A variable that must be a whole number ≥ 0 when set.
fn number(var: &impl Fn(&str) -> Option<String>, name: &str) -> Result<Option<u64>> {
    var(name)
        .map(|text| {
            text.trim().parse::<u64>().map_err(|_| {
                Error::invalid(name, format!("expected a whole number >= 0, got {text:?}"))
            })
        })
        .transpose()
}

/// Task `(ID − MIN) / STEP` of the job array, with the count from `SLURM_ARRAY_TASK_COUNT` or
/// from `MIN`, `MAX` and `STEP`; `None` outside an array.
fn array_share(var: &impl Fn(&str) -> Option<String>) -> Result<Option<Shard>> {
    let Some(id) = number(var, "SLURM_ARRAY_TASK_ID")? else {
        return Ok(None);
    };
    let min = number(var, "SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
    let step = number(var, "SLURM_ARRAY_TASK_STEP")?.unwrap_or(1);
    let max = number(var, "SLURM_ARRAY_TASK_MAX")?;
    let given_count = number(var, "SLURM_ARRAY_TASK_COUNT")?;
    let bad = |name: &str, msg: String| Err(Error::invalid(name, msg));
    if step == 0 {
        return bad("SLURM_ARRAY_TASK_STEP", "expected at least 1, got 0".into());
    }
    if id < min {
        return bad(
            "SLURM_ARRAY_TASK_MIN",
            format!("{min} is above SLURM_ARRAY_TASK_ID {id}"),
        );
    }
    if let Some(max) = max.filter(|&max| max < id) {
        return bad(
            "SLURM_ARRAY_TASK_MAX",
            format!("{max} is below SLURM_ARRAY_TASK_ID {id}"),
        );
    }
    if (id - min) % step != 0 {
        return bad(
            "SLURM_ARRAY_TASK_STEP",
            format!("SLURM_ARRAY_TASK_ID {id} is not SLURM_ARRAY_TASK_MIN {min} plus a multiple of {step}"),
        );
    }
    // u128: MIN 0, MAX 2^64 - 1, STEP 1 make 2^64 tasks, one more than a u64 holds.
    let from_range = max.map(|max| u128::from((max - min) / step) + 1);
    let count = match (given_count.map(u128::from), from_range) {
        (Some(c), Some(r)) if c != r => {
            return bad(
                "SLURM_ARRAY_TASK_COUNT",
                format!("{c} tasks, but SLURM_ARRAY_TASK_MIN {min} to MAX {} in steps of {step} make {r}; only an array of evenly spaced indices (--array=0-{}) can share a sweep", max.unwrap_or(0), c.max(1) - 1),
            )
        }
        (Some(c), _) => c,
        (None, Some(r)) => r,
        (None, None) => {
            return bad(
                "SLURM_ARRAY_TASK_ID",
                "is set without SLURM_ARRAY_TASK_COUNT or SLURM_ARRAY_TASK_MAX".into(),
            )
        }
    };
    let index = (id - min) / step;
    if u128::from(index) >= count {
        return bad(
            "SLURM_ARRAY_TASK_COUNT",
            format!("{count}, but SLURM_ARRAY_TASK_ID {id} is task {index} of the array"),
        );
    }
    let Ok(count) = u64::try_from(count) else {
        return bad(
            "SLURM_ARRAY_TASK_MAX",
            format!(
                "{} with MIN {min} and STEP {step} makes 2^64 tasks or more",
                max.unwrap_or(0)
            ),
        );
    };
    Ok(Some(Shard { index, count }))
}

/// Task `SLURM_PROCID` of `SLURM_NTASKS` inside an `srun` step (`SLURM_STEP_ID` set); `None`
/// outside one and for a step of one task. A batch script's own shell also has `SLURM_PROCID`
/// (0) and, with `--ntasks`, `SLURM_NTASKS`, but runs once: it owns the array task's whole share.
fn step_share(var: &impl Fn(&str) -> Option<String>) -> Result<Option<Shard>> {
    if var("SLURM_STEP_ID").is_none() {
        return Ok(None);
    }
    let procid = number(var, "SLURM_PROCID")?;
    let ntasks = match number(var, "SLURM_NTASKS")? {
        Some(n) => Some(n),
        None => number(var, "SLURM_STEP_NUM_TASKS")?,
    };
    match (procid, ntasks) {
        (None, None) | (Some(0), None) | (Some(0), Some(1)) => Ok(None),
        (_, Some(0)) => Err(Error::invalid("SLURM_NTASKS", "expected at least 1, got 0")),
        (Some(index), Some(count)) if index < count => Ok(Some(Shard { index, count })),
        (Some(index), Some(count)) => Err(Error::invalid(
            "SLURM_PROCID",
            format!("{index} is not below SLURM_NTASKS {count}"),
        )),
        (None, Some(_)) => Err(Error::invalid(
            "SLURM_PROCID",
            "not set in an srun step of several tasks (SLURM_NTASKS is)",
        )),
        (Some(index), None) => Err(Error::invalid(
            "SLURM_NTASKS",
            format!("not set, but SLURM_PROCID is {index}"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(pairs: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            pairs
                .iter()
                .find(|(k, _)| *k == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn blocks_are_disjoint_cover_the_list_and_differ_by_at_most_one() {
        for len in [0usize, 1, 2, 7, 10, 1000] {
            for count in [1u64, 2, 3, 4, 7, 13] {
                let mut next = 0;
                let mut sizes = Vec::new();
                for index in 0..count {
                    let r = Shard { index, count }.range(len);
                    assert_eq!(r.start, next, "len {len} count {count} task {index}");
                    next = r.end;
                    sizes.push(r.len());
                }
                assert_eq!(next, len);
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(hi - lo <= 1, "{sizes:?}");
            }
        }
        // 10 items over 4 tasks: 2, 3, 2, 3.
        let blocks: Vec<_> = (0..4)
            .map(|i| Shard { index: i, count: 4 }.range(10))
            .collect();
        assert_eq!(blocks, [0..2, 2..5, 5..7, 7..10]);
    }

    #[test]
    fn number_blocks_of_any_i64_range_cover_it_without_overflow() {
        for (start, end) in [
            (0, i64::MAX),
            (i64::MIN, i64::MAX),
            (-5, 5),
            (i64::MAX - 3, i64::MAX),
        ] {
            for count in [1u64, 2, 3, 7, u64::MAX] {
                let mut next = start;
                for index in [0, 1, count / 2, count - 1] {
                    let r = Shard {
                        index: index.min(count - 1),
                        count,
                    }
                    .numbers(start, end);
                    assert!(r.start >= start && r.end <= end && r.start <= r.end);
                    if index == 0 {
                        assert_eq!(r.start, start);
                    }
                    if index == count - 1 {
                        assert_eq!(r.end, end, "{start}..{end} over {count}");
                    }
                    next = next.max(r.end);
                }
                assert_eq!(next, end);
            }
        }
        // i64::MIN..i64::MAX over 2 tasks: halves of 2^63 - 1 and 2^63 (floor at the middle).
        let halves = [0, 1].map(|index| Shard { index, count: 2 }.numbers(i64::MIN, i64::MAX));
        assert_eq!(halves, [i64::MIN..-1, -1..i64::MAX]);
        let thirds: Vec<_> = (0..3)
            .map(|index| Shard { index, count: 3 }.numbers(0, i64::MAX))
            .collect();
        assert_eq!(thirds[0], 0..3074457345618258602);
        assert_eq!(thirds[1].end, 6148914691236517204);
        assert_eq!(Shard::ALL.numbers(5, 2), 5..5);
        assert_eq!(
            Shard { index: 3, count: 4 }.range(usize::MAX).end,
            usize::MAX
        );
    }

    #[test]
    fn absurd_slurm_counts_are_refused_not_wrapped() {
        let max = u64::MAX.to_string();
        let err = Shard::from_slurm(
            env(&[("SLURM_ARRAY_TASK_ID", "0"), ("SLURM_ARRAY_TASK_MAX", &max)]),
            1,
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.starts_with("SLURM_ARRAY_TASK_MAX:") && err.contains("2^64"),
            "{err}"
        );
        let big = (1u64 << 40).to_string();
        let err = Shard::from_slurm(
            env(&[
                ("SLURM_ARRAY_TASK_ID", "1"),
                ("SLURM_ARRAY_TASK_COUNT", &big),
                ("SLURM_STEP_ID", "0"),
                ("SLURM_PROCID", "2"),
                ("SLURM_NTASKS", &big),
            ]),
            1,
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.starts_with("SLURM_NTASKS:") && err.contains("more than 2^64"),
            "{err}"
        );
        let (shard, _) = Shard::from_slurm(
            env(&[
                ("SLURM_ARRAY_TASK_ID", "1"),
                ("SLURM_ARRAY_TASK_COUNT", "2"),
                ("SLURM_STEP_ID", "0"),
                ("SLURM_PROCID", "2"),
                ("SLURM_NTASKS", &big),
            ]),
            1,
        )
        .unwrap();
        assert_eq!(
            shard,
            Shard {
                index: (1 << 40) + 2,
                count: 1 << 41
            }
        );
    }

    #[test]
    fn the_flag_is_parsed_and_bad_ones_are_refused() {
        assert_eq!(Shard::parse("1/3").unwrap(), Shard { index: 1, count: 3 });
        assert_eq!(Shard::parse(" 0 / 1 ").unwrap(), Shard::ALL);
        for bad in ["3/2", "2/2", "0/0", "x/y", "1", "-1/2", "1/2/3", ""] {
            let e = Shard::parse(bad).unwrap_err().to_string();
            assert!(e.starts_with("--shard: expected I/N"), "{bad}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }

    #[test]
    fn slurm_arrays_and_steps_give_the_task_its_share() {
        let share = |pairs: &[(&str, &str)]| Shard::from_slurm(env(pairs), 1).unwrap();
        assert_eq!(share(&[]), (Shard::ALL, ShardSource::Alone));
        let array = [
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert_eq!(share(&array).0, Shard { index: 2, count: 4 });
        // MIN/MAX alone, an offset array 5-8, and a stepped one 0-12:4.
        let offset = [
            ("SLURM_ARRAY_TASK_ID", "7"),
            ("SLURM_ARRAY_TASK_MIN", "5"),
            ("SLURM_ARRAY_TASK_MAX", "8"),
        ];
        assert_eq!(share(&offset).0, Shard { index: 2, count: 4 });
        let stepped = [
            ("SLURM_ARRAY_TASK_ID", "8"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "12"),
            ("SLURM_ARRAY_TASK_STEP", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert_eq!(share(&stepped).0, Shard { index: 2, count: 4 });
        let steps = [
            ("SLURM_STEP_ID", "0"),
            ("SLURM_PROCID", "1"),
            ("SLURM_NTASKS", "3"),
        ];
        assert_eq!(
            share(&steps),
            (Shard { index: 1, count: 3 }, ShardSource::SrunSteps)
        );
        // A batch shell (no step) with --ntasks runs once: it owns everything.
        assert_eq!(
            share(&[("SLURM_PROCID", "0"), ("SLURM_NTASKS", "4")]).0,
            Shard::ALL
        );
        // Array task 2 of 4, srun task 1 of 3: task 7 of 12.
        let both: Vec<_> = array.iter().chain(&steps).copied().collect();
        assert_eq!(
            share(&both).0,
            Shard {
                index: 7,
                count: 12
            }
        );
        // The flag wins over the environment.
        assert_eq!(
            Shard::resolve(Some("0/2"), env(&array), 1).unwrap(),
            (Shard { index: 0, count: 2 }, ShardSource::Flag)
        );
    }

    #[test]
    fn the_ranks_of_one_mpi_world_own_the_same_share() {
        // srun --mpi=pmix -n 4 inside array task 2 of 4: the step's tasks are one MPI world.
        let array = [
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        let shares: Vec<_> = (0..4)
            .map(|rank| {
                let procid = rank.to_string();
                let pairs: Vec<(&str, &str)> = array
                    .iter()
                    .copied()
                    .chain([
                        ("SLURM_STEP_ID", "0"),
                        ("SLURM_PROCID", procid.as_str()),
                        ("SLURM_NTASKS", "4"),
                    ])
                    .collect();
                let mpi = Shard::from_slurm(env(&pairs), 4).unwrap();
                let alone = Shard::from_slurm(env(&pairs), 1).unwrap();
                (mpi, alone)
            })
            .collect();
        for (rank, (mpi, alone)) in shares.iter().enumerate() {
            // Every rank: array task 2 of 4, frames 5..7 of 10, as the batch shell would own.
            assert_eq!(
                *mpi,
                (Shard { index: 2, count: 4 }, ShardSource::SlurmArray),
                "rank {rank}"
            );
            assert_eq!(mpi.0.range(10), 5..7);
            // Four independent processes (no MPI world) share the array task's share again.
            let index = 2 * 4 + rank as u64;
            assert_eq!(alone.0, Shard { index, count: 16 }, "rank {rank}");
        }
        // An MPI step outside an array owns everything; --shard still shares it.
        let step = [
            ("SLURM_STEP_ID", "0"),
            ("SLURM_PROCID", "1"),
            ("SLURM_NTASKS", "2"),
        ];
        assert_eq!(
            Shard::resolve(None, env(&step), 2).unwrap(),
            (Shard::ALL, ShardSource::Alone)
        );
        assert_eq!(
            Shard::resolve(Some("1/3"), env(&step), 2).unwrap(),
            (Shard { index: 1, count: 3 }, ShardSource::Flag)
        );
    }

    #[test]
    fn inconsistent_slurm_variables_name_the_variable() {
        let cases: &[(&[(&str, &str)], &str)] = &[
            (
                &[("SLURM_ARRAY_TASK_ID", "x")],
                "SLURM_ARRAY_TASK_ID: expected",
            ),
            (
                &[("SLURM_ARRAY_TASK_ID", "1")],
                "SLURM_ARRAY_TASK_ID: is set without",
            ),
            (
                &[
                    ("SLURM_ARRAY_TASK_ID", "4"),
                    ("SLURM_ARRAY_TASK_COUNT", "4"),
                ],
                "SLURM_ARRAY_TASK_COUNT:",
            ),
            (
                &[
                    ("SLURM_ARRAY_TASK_ID", "1"),
                    ("SLURM_ARRAY_TASK_MIN", "2"),
                    ("SLURM_ARRAY_TASK_COUNT", "4"),
                ],
                "SLURM_ARRAY_TASK_MIN:",
            ),
            (
                &[("SLURM_ARRAY_TASK_ID", "5"), ("SLURM_ARRAY_TASK_MAX", "3")],
                "SLURM_ARRAY_TASK_MAX:",
            ),
            (
                // A listed array (--array=1,3,8): its count is not its range's.
                &[
                    ("SLURM_ARRAY_TASK_ID", "3"),
                    ("SLURM_ARRAY_TASK_MIN", "1"),
                    ("SLURM_ARRAY_TASK_MAX", "8"),
                    ("SLURM_ARRAY_TASK_COUNT", "3"),
                ],
                "SLURM_ARRAY_TASK_COUNT:",
            ),
            (
                &[
                    ("SLURM_ARRAY_TASK_ID", "3"),
                    ("SLURM_ARRAY_TASK_MAX", "8"),
                    ("SLURM_ARRAY_TASK_STEP", "2"),
                ],
                "SLURM_ARRAY_TASK_STEP:",
            ),
            (
                &[
                    ("SLURM_STEP_ID", "0"),
                    ("SLURM_PROCID", "3"),
                    ("SLURM_NTASKS", "3"),
                ],
                "SLURM_PROCID:",
            ),
            (
                &[("SLURM_STEP_ID", "0"), ("SLURM_PROCID", "1")],
                "SLURM_NTASKS:",
            ),
        ];
        for (pairs, needle) in cases {
            let e = Shard::from_slurm(env(pairs), 1).unwrap_err().to_string();
            assert!(e.starts_with(needle), "{pairs:?}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
