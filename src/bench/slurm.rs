//! `--shard auto` and the run a shard belongs to, read from a Slurm job array's
//! environment.
//!
//! An array task (`sbatch --array=MIN-MAX[:STEP]`) has `SLURM_ARRAY_TASK_ID` and the
//! array's `SLURM_ARRAY_TASK_MIN`, `SLURM_ARRAY_TASK_MAX`, `SLURM_ARRAY_TASK_COUNT` and
//! `SLURM_ARRAY_TASK_STEP`. The array's indices, in order, are the shards 1..=N: with
//! `--array=0-3` task 0 runs shard 1/4 and task 3 shard 4/4; with `--array=1-12:4`
//! (tasks 1, 5, 9) task 5 runs shard 2/3. The indices must be such a range: a list
//! (`--array=1,2,7`) is refused, as is a task index outside the array, a value that is
//! not a whole number, or values that disagree with each other.
//!
//! The run a shard belongs to is `SLURM_ARRAY_JOB_ID` (one id for every task of an
//! array, and for a task Slurm runs again), unless `--run-id` names it; the merge
//! refuses shards of different runs.

use super::Shard;

/// The array's task index variable: set in every task of an array, nowhere else.
pub const TASK_ID: &str = "SLURM_ARRAY_TASK_ID";
/// The array's lowest task index.
pub const TASK_MIN: &str = "SLURM_ARRAY_TASK_MIN";
/// The array's highest task index.
pub const TASK_MAX: &str = "SLURM_ARRAY_TASK_MAX";
/// The number of tasks in the array.
pub const TASK_COUNT: &str = "SLURM_ARRAY_TASK_COUNT";
/// The step between task indices (1 unless `--array=A-B:STEP`).
pub const TASK_STEP: &str = "SLURM_ARRAY_TASK_STEP";
/// The array's job id: the same in every task of the array.
pub const ARRAY_JOB_ID: &str = "SLURM_ARRAY_JOB_ID";

/// The shard of this array task, from the environment `var` reads (`std::env::var` in
/// the command line; a map in tests). The error is one line that starts with
/// `--shard auto:` and names the variable that is missing or wrong.
pub fn shard(var: impl Fn(&str) -> Option<String>) -> Result<Shard, String> {
    let bad = |why: String| format!("--shard auto: {why}");
    let num = |name: &str| -> Result<Option<u64>, String> {
        match var(name) {
            None => Ok(None),
            Some(v) => v.parse::<u64>().map(Some).map_err(|_| {
                bad(format!(
                    "{name}={v:?} is not a whole number (a Slurm job array sets it)"
                ))
            }),
        }
    };
    let Some(id) = num(TASK_ID)? else {
        return Err(bad(format!(
            "{TASK_ID} is not set: this is not a Slurm array task (submit with sbatch --array=0-3, or give --shard I/N)"
        )));
    };
    let Some(min) = num(TASK_MIN)? else {
        return Err(bad(format!(
            "{TASK_ID} is set but {TASK_MIN} is not: cannot tell where the array's indices start"
        )));
    };
    let step = num(TASK_STEP)?.unwrap_or(1);
    if step == 0 {
        return Err(bad(format!("{TASK_STEP}=0: an array's step is at least 1")));
    }
    let (max, count) = (num(TASK_MAX)?, num(TASK_COUNT)?);
    let range = |max: u64| {
        format!(
            "{min}-{max}{}",
            if step > 1 {
                format!(":{step}")
            } else {
                String::new()
            }
        )
    };
    let count = match (max, count) {
        (None, None) => {
            return Err(bad(format!(
                "neither {TASK_MAX} nor {TASK_COUNT} is set: cannot tell how many tasks the array has"
            )));
        }
        (Some(max), c) => {
            if max < min || (max - min) % step != 0 {
                return Err(bad(format!(
                    "{TASK_MIN}={min}, {TASK_MAX}={max} and {TASK_STEP}={step} are not a range of task indices"
                )));
            }
            let n = (max - min) / step + 1;
            match c {
                Some(c) if c != n => {
                    return Err(bad(format!(
                        "{TASK_COUNT}={c} but the range {} holds {n} indices: the array must be a range such as --array=0-3 (not a list)",
                        range(max)
                    )));
                }
                _ => n,
            }
        }
        (None, Some(0)) => return Err(bad(format!("{TASK_COUNT}=0"))),
        (None, Some(c)) => c,
    };
    let last = min + (count - 1) * step;
    if id < min || id > last || (id - min) % step != 0 {
        return Err(bad(format!(
            "{TASK_ID}={id} is not an index of the array {}",
            range(last)
        )));
    }
    let index = (id - min) / step + 1;
    let too_big = |_| bad(format!("an array of {count} tasks is too large"));
    Ok(Shard {
        index: usize::try_from(index).map_err(too_big)?,
        count: usize::try_from(count).map_err(too_big)?,
    })
}

/// `--shard`'s value: `I/N`, or `auto` for the array task's shard (see [`shard`]).
pub fn resolve(arg: &str, var: impl Fn(&str) -> Option<String>) -> Result<Shard, String> {
    if arg == "auto" {
        shard(var)
    } else {
        Shard::parse(arg)
    }
}

/// Checks a run id (`--run-id`, or the array's job id): 1 to 64 letters, digits, `.`,
/// `_` or `-`.
pub fn check_run_id(id: &str) -> Result<(), String> {
    let ok = (1..=64).contains(&id.len())
        && id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-'));
    if ok {
        Ok(())
    } else {
        Err(format!(
            "run id {id:?}: expected 1 to 64 letters, digits, '.', '_' or '-' (such as a Slurm job id)"
        ))
    }
}

/// The run a shard belongs to: `given` (`--run-id`) if any, else the array's job id
/// when this is an array task, else none.
pub fn run_id(
    given: Option<&str>,
    var: impl Fn(&str) -> Option<String>,
) -> Result<Option<String>, String> {
    match given {
        Some(id) => check_run_id(id).map(|()| Some(id.to_string())),
        None => match var(ARRAY_JOB_ID) {
            Some(id) => check_run_id(&id)
                .map(|()| Some(id))
                .map_err(|e| format!("{ARRAY_JOB_ID}: {e}")),
            None => Ok(None),
        },
    }
}
